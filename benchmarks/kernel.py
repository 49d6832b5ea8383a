"""Every rigid solution at one input, from scratch, with each kernel (``FRC_KERNEL``).

``python -m benchmarks.kernel [--runs 7] [--calls 200]``: the three ``solutions_at_*`` figures of
``benchmarks.ci`` (``solutions_at(scene, zeros)`` on a loaded scene, no prior analysis) measured
with the NumPy kernel and with the compiled one, interleaved, in one process: the median of
``--runs`` runs of ``--calls`` calls each (wall time per call), and the ratio of CPU times to
``benchmarks.ci.calibration_workload`` measured in the same process (the median of its runs).
Both kernels' answers are checked to list the same modes. Writes ``benchmarks/results/kernel.json``
(per scene and kernel: ``median_s`` [s, wall per call], ``min_s``, ``max_s``, ``ratio_to_calibration``
[-, CPU], the target of ``benchmarks.ci``) and ``benchmarks/results/kernel.png``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.ci import _prefer_installed_frcontrol, calibration_workload

SCENES = ("rod_on_table", "box_on_slope", "rhex_flip")
KERNEL_NAMES = ("numpy", "compiled")
RESULTS = Path(__file__).resolve().parent / "results"


def _time(call, calls: int) -> tuple[float, float]:
    wall, cpu = time.perf_counter(), time.process_time()
    for _ in range(calls):
        call()
    return (time.perf_counter() - wall) / calls, (time.process_time() - cpu) / calls


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--calls", type=int, default=200)
    args = parser.parse_args(argv)
    _prefer_installed_frcontrol()
    from frcontrol.engine import solutions_at
    from frcontrol.scene import load_scene

    scenes = {name: load_scene(name) for name in SCENES}
    inputs = {name: np.zeros(scene.inputs.count) for name, scene in scenes.items()}
    wall: dict[tuple[str, str], list[float]] = {}
    cpu: dict[tuple[str, str], list[float]] = {}
    calibration: list[float] = []
    for name, scene in scenes.items():
        answers = []
        for kernel in KERNEL_NAMES:
            os.environ["FRC_KERNEL"] = kernel
            answers.append([s.mode for s in solutions_at(scene, inputs[name])])
        if answers[0] != answers[1]:
            raise SystemExit(f"{name}: the kernels disagree: {answers}")
    for _ in range(args.runs):
        calibration.append(_time(calibration_workload, 3)[1])
        for name, scene in scenes.items():
            for kernel in KERNEL_NAMES:
                os.environ["FRC_KERNEL"] = kernel
                call = partial(solutions_at, scene, inputs[name])
                _time(call, 20)  # warm-up
                w, c = _time(call, args.calls)
                wall.setdefault((name, kernel), []).append(w)
                cpu.setdefault((name, kernel), []).append(c)
    base = statistics.median(calibration)
    result = _result(wall, cpu, base, args.runs, args.calls)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "kernel.json").write_text(json.dumps(result, indent=1))
    plot(result, RESULTS / "kernel.png")
    print(f"calibration workload: {base * 1e3:.2f} ms of CPU (median of {args.runs})")
    print(f"{'scene':<14} {'kernel':<9} {'median':>10} {'CPU ratio':>10}")
    for row in result["rows"]:
        print(f"{row['scene']:<14} {row['kernel']:<9} {row['median_s'] * 1e6:>7.0f} us "
              f"{row['ratio_to_calibration']:>10.4f}")
    return 0


def _result(wall: dict, cpu: dict, base: float, runs: int, calls: int) -> dict[str, Any]:
    from benchmarks.ci import FIGURES

    targets = {f.name: f.target_s for f in FIGURES}
    rows = [{"scene": name, "kernel": kernel, "median_s": statistics.median(wall[(name, kernel)]),
             "min_s": min(wall[(name, kernel)]), "max_s": max(wall[(name, kernel)]),
             "ratio_to_calibration": statistics.median(cpu[(name, kernel)]) / base,
             "target_s": targets[f"solutions_at_{name}"]}
            for name in SCENES for kernel in KERNEL_NAMES]
    return {"benchmark": "kernel", "runs": runs, "calls": calls,
            "calibration": "benchmarks.ci.calibration_workload", "calibration_median_cpu_s": base,
            "rows": rows, "python": platform.python_version(), "machine": platform.machine(),
            "date": time.strftime("%Y-%m-%d")}


def plot(result: dict[str, Any], path: Path) -> None:
    """Median wall time per call, per scene, with each kernel, against the target."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.5, 3.4))
    axes = fig.subplots(1, len(SCENES))
    for ax, name in zip(axes, SCENES, strict=True):
        rows = [r for r in result["rows"] if r["scene"] == name]
        ax.bar([r["kernel"] for r in rows], [r["median_s"] * 1e6 for r in rows],
               yerr=[[(r["median_s"] - r["min_s"]) * 1e6 for r in rows],
                     [(r["max_s"] - r["median_s"]) * 1e6 for r in rows]],
               color=["#9e9e9e", "#1f77b4"])
        ax.axhline(rows[0]["target_s"] * 1e6, color="k", lw=1.5, label="target")
        ax.set_title(name, fontsize=9)
        ax.set_ylabel("median per call [us]")
    axes[0].legend(fontsize=8)
    fig.suptitle(f"solutions_at from scratch, {result['runs']} runs of {result['calls']} calls "
                 "(bars: min-max)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)

if __name__ == "__main__":
    raise SystemExit(main())
