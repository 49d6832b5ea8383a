"""Benchmark: one full statics query on a 4-contact body.

Run from the repository root::

    python -m benchmarks.statics [--runs 200] [--strong-runs 10]

Two named problems, a 1 m x 0.5 m box (1 kg) with four contacts:

* ``box_in_slot``: on the floor (two lower corners, mu 0.5) between two walls (one contact on each
  side 0.35 m up, mu 0.3);
* ``box_in_corner``: on the floor (two lower corners, mu 0.5) against a wall on its right (its two
  right corners, mu 0.3).

The *statics query* is :func:`frcontrol.statics.analyze_statics` with ``strong=False``: the locked
body from the scene (Pinocchio), form and force closure with their margins, static equilibrium
(phase-one LP, implicit equalities, interior force set and the 16 LP ranges of the forces), the
support interval and weak stability. Strong stability runs the mode-domain engine (every contact
mode at rest) and is timed apart. The scene is loaded once, outside the timing. A run counts only if
its answers match the reference (the same query with HiGHS): the verdicts, the margins to 1e-7 and
the force-set dimension.

Writes ``benchmarks/results/statics.json`` and ``benchmarks/results/statics.png``.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from frcontrol.scene import load_scene, shipped_robots_dir
from frcontrol.statics import StaticsReport, analyze_statics

RESULTS = Path(__file__).resolve().parent / "results"
BUDGET_MS = 5.0
"""The target for one statics query on a 4-contact body [ms]."""


def _contact(name: str, point: list[float], normal: list[float], mu: float, surface: list[float]) -> str:
    return (f'[[contacts]]\nname = "{name}"\nlink = "box"\npoint = {point}\nnormal = {normal}\n'
            f"mu = {mu}\nsurface_point = {surface}\n")


def scene_text(name: str) -> str:
    """The TOML of a named benchmark problem."""
    head = (f'name = "{name}"\nrobot = "{shipped_robots_dir() / "box.urdf"}"\nbase = "planar"\n'
            "[state]\nq = [0.0, 0.25, 0.0]\n")
    floor = (_contact("floor_left", [-0.5, -0.25], [0.0, 1.0], 0.5, [0.0, 0.0])
             + _contact("floor_right", [0.5, -0.25], [0.0, 1.0], 0.5, [0.0, 0.0]))
    if name == "box_in_slot":
        walls = (_contact("wall_left", [-0.5, 0.1], [1.0, 0.0], 0.3, [-0.5, 0.0])
                 + _contact("wall_right", [0.5, 0.1], [-1.0, 0.0], 0.3, [0.5, 0.0]))
    elif name == "box_in_corner":
        walls = (_contact("wall_low", [0.5, -0.25], [-1.0, 0.0], 0.3, [0.5, 0.0])
                 + _contact("wall_high", [0.5, 0.25], [-1.0, 0.0], 0.3, [0.5, 0.0]))
    else:
        raise ValueError(f"unknown problem {name!r}")
    inputs = ('[inputs]\ncoordinates = ["x", "y", "theta"]\n'
              "lower = [-20.0, -20.0, -5.0]\nupper = [20.0, 20.0, 5.0]\n")
    return head + floor + walls + inputs


def answers(report: StaticsReport) -> dict:
    """The answers a run must reproduce."""
    return {
        "form_closure": report.form_closure.closed,
        "form_closure_margin": report.form_closure.margin,
        "force_closure": report.force_closure.closed,
        "force_closure_margin": report.force_closure.margin,
        "static_equilibrium": report.equilibrium.exists,
        "dimension": report.equilibrium.dimension,
        "weakly_stable": report.weakly_stable,
        "x_min": report.support.x_min,
        "x_max": report.support.x_max,
    }


def matches(got: dict, reference: dict, tol: float = 1e-7) -> bool:
    """Whether a run's answers match the reference's."""
    for key, value in reference.items():
        other = got[key]
        if isinstance(value, bool) or isinstance(value, int):
            if other != value:
                return False
        elif not (value == other or abs(value - other) <= tol * (1.0 + abs(value))):
            return False
    return True


def bench(name: str, runs: int, strong_runs: int, folder: Path) -> dict:
    """Time one problem."""
    path = folder / f"{name}.toml"
    path.write_text(scene_text(name))
    scene = load_scene(path)
    reference = answers(analyze_statics(scene, strong=False, solver="highs"))
    analyze_statics(scene, strong=False)  # warm-up (imports, first calls)
    totals, parts, rejected = [], {}, 0
    for _ in range(runs):
        start = time.perf_counter()
        report = analyze_statics(scene, strong=False)
        elapsed = time.perf_counter() - start
        if not matches(answers(report), reference):
            rejected += 1
            continue
        totals.append(elapsed)
        for part, seconds in report.timings.items():
            if part not in ("total", "strong_stability"):
                parts.setdefault(part, []).append(seconds)
    strong_times = []
    strong_verdict = None
    for _ in range(strong_runs):
        start = time.perf_counter()
        report = analyze_statics(scene)
        strong_times.append(time.perf_counter() - start)
        strong_verdict = report.strongly_stable
    ms = 1e3 * np.array(totals)
    return {
        "problem": name,
        "contacts": 4,
        "runs": runs,
        "accepted_runs": len(totals),
        "rejected_runs": rejected,
        "median_ms": float(np.median(ms)),
        "p10_ms": float(np.percentile(ms, 10)),
        "p90_ms": float(np.percentile(ms, 90)),
        "min_ms": float(ms.min()),
        "within_budget": bool(np.median(ms) <= BUDGET_MS),
        "parts_median_ms": {part: 1e3 * statistics.median(v) for part, v in parts.items()},
        "answers": {k: (v if isinstance(v, bool) or np.isfinite(v) else None) for k, v in reference.items()},
        "with_strong_stability": {
            "runs": strong_runs,
            "median_ms": 1e3 * statistics.median(strong_times) if strong_times else None,
            "strongly_stable": strong_verdict,
        },
    }


def plot(results: list[dict], path: Path) -> None:
    """Stacked bars of the median time per part, with the budget."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    names = [r["problem"] for r in results]
    parts = list(results[0]["parts_median_ms"])
    bottom = np.zeros(len(results))
    for part in parts:
        values = np.array([r["parts_median_ms"][part] for r in results])
        ax.bar(names, values, bottom=bottom, label=part)
        bottom += values
    ax.scatter(names, [r["median_ms"] for r in results], color="k", zorder=3, label="median total")
    ax.axhline(BUDGET_MS, color="r", ls="--", label=f"budget {BUDGET_MS:g} ms")
    ax.set_ylabel("time per statics query [ms]")
    ax.set_title("frcontrol.statics on a 4-contact body (DAQP; strong stability excluded)")
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    """Run the benchmark and write the results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--strong-runs", type=int, default=10)
    args = parser.parse_args()
    RESULTS.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        results = [bench(name, args.runs, args.strong_runs, Path(tmp))
                   for name in ("box_in_slot", "box_in_corner")]
    payload = {
        "benchmark": "statics query on a 4-contact body",
        "command": "python -m benchmarks.statics",
        "budget_ms": BUDGET_MS,
        "solver": "daqp",
        "python": platform.python_version(),
        "machine": platform.machine(),
        "processor": platform.processor() or platform.machine(),
        "results": results,
    }
    (RESULTS / "statics.json").write_text(json.dumps(payload, indent=2) + "\n")
    plot(results, RESULTS / "statics.png")
    for r in results:
        strong = r["with_strong_stability"]["median_ms"]
        print(f"{r['problem']}: median {r['median_ms']:.2f} ms (p10 {r['p10_ms']:.2f}, "
              f"p90 {r['p90_ms']:.2f}; {r['accepted_runs']}/{r['runs']} runs valid); "
              f"with strong stability: {strong:.1f} ms")


if __name__ == "__main__":
    main()
