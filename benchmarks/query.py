"""Queries on an analysis, before and after, in one process: ``python -m benchmarks.query``.

For the rod on the table, the box on the slope and the RHex flip scene (at u = 0, and RHex also at
``benchmarks.ci.QUERY_GENERIC_INPUT``), with the analysis made beforehand (not timed):

- **before**: ``solutions_at(analysis, u, method="batch")``, the engine's rule mode by mode (the
  path of a query on an analysis before the stacked table of ``frcontrol/query.py``);
- **after**: ``solutions_at(analysis, u)``, the point location;
- **from scratch**: ``solutions_at(scene, u)``;
- per point: a loop of single queries over 2,000 inputs, and one batch ``solutions_at(analysis, U)``
  of :data:`BATCH_POINTS` inputs uniform within the limits.

Each figure is the median of :data:`RUNS` CPU-time samples, each preceded by a sample of
``benchmarks.ci``'s calibration workload, and is also given at machine factor 1.0: scaled by
:data:`REFERENCE_CALIBRATION` over the calibration's median. Prints one line per case.
"""

from __future__ import annotations

import statistics
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from benchmarks.ci import QUERY_GENERIC_INPUT, calibration_workload

RUNS = 7
"""Samples per figure (their median is the figure)."""

BATCH_POINTS = 100_000
"""Inputs of the batch."""

LOOP_POINTS = 2000
"""Inputs of the loop of single queries."""

REFERENCE_CALIBRATION = 2.4e-3
"""[s] CPU time of one calibration workload at machine factor 1.0 (the idle development machine,
where ``solutions_at`` from scratch on the rod took 40 us)."""


def per_call(call: Callable[[], Any], calls: int) -> float:
    """CPU seconds per call of ``calls`` calls."""
    start = time.process_time()
    for _ in range(calls):
        call()
    return (time.process_time() - start) / calls


def case(name: str, u: tuple[float, ...] | None) -> str:
    """One scene and input: the line of figures."""
    from frcontrol.engine import analyze, solutions_at
    from frcontrol.scene import load_scene

    scene = load_scene(name)
    analysis = analyze(scene, ambiguity=False)
    inputs = np.zeros(scene.inputs.count) if u is None else np.array(u, dtype=float)
    problem = analysis.problem
    U = np.random.default_rng(1).uniform(problem.lower, problem.upper, (BATCH_POINTS, problem.m))
    calls: dict[str, tuple[Callable[[], Any], int, int]] = {
        "calibration": (calibration_workload, 3, 1),
        "before": (lambda: solutions_at(analysis, inputs, method="batch"), 50, 1),
        "after": (lambda: solutions_at(analysis, inputs), 200, 1),
        "from scratch": (lambda: solutions_at(scene, inputs), 20, 1),
        "loop per point": (lambda: [solutions_at(analysis, x) for x in U[:LOOP_POINTS]], 1, LOOP_POINTS),
        "batch per point": (lambda: solutions_at(analysis, U), 1, BATCH_POINTS),
    }
    samples: dict[str, list[float]] = {label: [] for label in calls}
    for _ in range(RUNS):
        for label, (call, count, points) in calls.items():
            samples[label].append(per_call(call, count) / points)
    median = {label: statistics.median(values) for label, values in samples.items()}
    scale = REFERENCE_CALIBRATION / median["calibration"]
    figures = ", ".join(f"{label} {median[label] * scale * 1e6:.3g} us"
                        for label in calls if label != "calibration")
    return (f"{name}, u = {tuple(inputs.tolist())}: calibration {median['calibration'] * 1e3:.2f} ms CPU; "
            f"at factor 1.0: {figures} (after / before: {median['before'] / median['after']:.1f}x faster)")


def main() -> int:
    """Print every case."""
    for name, u in (("rod_on_table", None), ("box_on_slope", None), ("rhex_flip", None),
                    ("rhex_flip", QUERY_GENERIC_INPUT)):
        print(case(name, u), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
