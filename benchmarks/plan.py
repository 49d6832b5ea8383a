"""Benchmark: one flip plan, one simulated flip, and (when present) one climb plan.

Run from the repository root::

    python -m benchmarks.plan [--runs 15] [--sim-runs 3] [--climb-runs 3]

Named problems:

* ``flip_plan``: :func:`frcontrol.planning.flip.plan_flip` on the shipped ``rhex_flip`` scene, with
  its mode analysis (the engine's :func:`~frcontrol.engine.analyze`), the scene loaded once
  outside the timing;
* ``flip_plan_from_analysis``: the same plan from a precomputed analysis (the projections of the
  lower-dimensional modes it needs are cached in the analysis after the first run: the median is
  the warm figure, the first run is reported apart);
* ``flip_simulated``: :func:`~frcontrol.planning.flip_loop.simulate_flip` on ``rhex_flip`` (at most 2 s
  at 1 ms, a plan every 10 steps; the shipped 13.4 N m hips flip it, at 0.41 s) and on the same
  scene with realistic 10 N m hips (``flip_simulated_10Nm``: it does not flip, so this runs the
  whole 2 s);
* ``climb_plan``: :func:`frcontrol.planning.climb.plan_climb` on ``snake_climb`` with its scale
  bisection, if that module exists (it is written apart: the hook imports it inside a try).

Shares per stage come from the results' own ``timings`` (analysis, unambiguous sets, LPs,
verification; first plan, simulation, re-planning). A run counts only if its answer matches the
reference (the first run): the same mode and torques for a plan, the same verdict and number of
steps for a simulation, ``found`` for the climb. Targets: a flip plan <= 100 ms, a full simulated
flip <= 10 s, a climb plan <= 5 s.

Writes ``benchmarks/results/plan.json`` and ``benchmarks/results/plan.png``.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from frcontrol.engine import analyze
from frcontrol.planning.flip import plan_flip
from frcontrol.planning.flip_loop import simulate_flip
from frcontrol.scene import load_scene

RESULTS = Path(__file__).resolve().parent / "results"
TARGETS_S = {"flip_plan": 0.100, "flip_simulated": 10.0, "flip_simulated_10Nm": 10.0, "climb_plan": 5.0}
"""The speed targets [s] of the planning benchmarks."""


def _median_stages(runs: list[dict[str, float]], keys: list[str]) -> dict[str, float]:
    return {key: statistics.median(r.get(key, 0.0) for r in runs) for key in keys}


def bench_flip_plan(runs: int) -> dict[str, Any]:
    """One flip plan with its analysis, and from a precomputed analysis."""
    scene = load_scene("rhex_flip")
    reference = plan_flip(scene)
    key = (reference.mode, tuple(reference.torques.values()))
    walls, stages, rejected = [], [], 0
    for _ in range(runs):
        t0 = time.perf_counter()
        plan = plan_flip(scene)
        wall = time.perf_counter() - t0
        if not plan.found or not plan.unambiguous or (plan.mode, tuple(plan.torques.values())) != key:
            rejected += 1
            continue
        walls.append(wall)
        stages.append(dict(plan.timings))
    analysis = analyze(scene)
    t0 = time.perf_counter()
    first = plan_flip(scene, analysis=analysis)
    first_wall = time.perf_counter() - t0
    warm, warm_stages = [], []
    for _ in range(runs):
        t0 = time.perf_counter()
        plan = plan_flip(scene, analysis=analysis)
        wall = time.perf_counter() - t0
        if (plan.mode, tuple(plan.torques.values())) == key and plan.unambiguous:
            warm.append(wall)
            warm_stages.append(dict(plan.timings))
        else:
            rejected += 1
    keys = ["analysis", "unambiguous_sets", "lps", "verification"]
    return {
        "flip_plan": {
            "median_s": statistics.median(walls), "runs": len(walls), "rejected": rejected,
            "stages_s": _median_stages(stages, keys),
            "answer": {"mode": reference.mode, "torques": dict(reference.torques),
                       "pitch_acceleration": reference.pitch_acceleration, "margin": reference.margin,
                       "candidates": list(reference.candidates), "explored": list(reference.explored),
                       "pieces": len(reference.pieces)},
        },
        "flip_plan_from_analysis": {
            "median_s": statistics.median(warm), "first_s": first_wall, "first_mode": first.mode,
            "runs": len(warm), "stages_s": _median_stages(warm_stages, keys[1:]),
        },
    }


def bench_flip_simulated(runs: int, limit: float | None, max_time: float) -> dict[str, Any]:
    """The closed loop: plan, simulate, re-plan every 10 steps."""
    scene = load_scene("rhex_flip")
    if limit is not None:
        scene = replace(scene, inputs=replace(scene.inputs, lower=np.full(scene.inputs.count, -limit),
                                              upper=np.full(scene.inputs.count, limit)))
    walls, stages, answers = [], [], []
    reference = None
    for _ in range(runs):
        t0 = time.perf_counter()
        result = simulate_flip(scene, max_time=max_time)
        wall = time.perf_counter() - t0
        answer = (result.flipped, result.steps, result.body_contact_kept)
        reference = reference or answer
        if answer != reference:
            continue
        walls.append(wall)
        stages.append(dict(result.timings))
        answers.append(result)
    result = answers[0]
    return {
        "median_s": statistics.median(walls), "runs": len(walls),
        "stages_s": _median_stages(stages, ["first_plan", "simulation", "replanning"]),
        "answer": {"flipped": result.flipped, "time_to_vertical": result.time_to_vertical,
                   "body_contact_kept": result.body_contact_kept, "steps": result.steps,
                   "replans": result.replans, "held": len(result.held),
                   "max_pitch": float(result.trajectory.coordinate("theta").max()),
                   "limits_N_m": limit if limit is not None else 10.0, "max_time_s": max_time},
    }


def bench_climb(runs: int) -> dict[str, Any] | None:
    """--- climb hook --- plan_climb(snake_climb), if frcontrol.planning.climb exists."""
    try:
        from frcontrol.planning.climb import plan_climb
    except ImportError as err:  # written apart; absent or broken: reported, not fatal
        return {"skipped": f"frcontrol.planning.climb.plan_climb not importable: {err}"}
    scene = load_scene("snake_climb")
    walls, stages = [], []
    for _ in range(runs):
        t0 = time.perf_counter()
        plan = plan_climb(scene)
        wall = time.perf_counter() - t0
        if not getattr(plan, "found", False):
            continue
        walls.append(wall)
        stages.append(dict(getattr(plan, "timings", {})))
    if not walls:
        return {"skipped": "plan_climb found no plan (no valid run to time)"}
    keys = sorted({k for s in stages for k in s if k != "total"})
    # plan_climb's own timings may nest (a stage inside another): reported as they are, not stacked
    return {"median_s": statistics.median(walls), "runs": len(walls),
            "reported_timings_s": _median_stages(stages, keys),
            "answer": {"mode": getattr(plan, "mode", None),
                       "max_disturbance_scale": getattr(plan, "max_disturbance_scale", None)}}


def plot(results: dict[str, Any], path: Path) -> None:
    """Left: each problem's median time against its target (log scale). Right: its stage shares."""
    from matplotlib.figure import Figure

    rows = [(name, entry) for name, entry in results["problems"].items()
            if entry is not None and "median_s" in entry]
    figure = Figure(figsize=(11.0, 1.2 + 0.7 * len(rows)), layout="constrained")
    times_ax, shares_ax = figure.subplots(1, 2, sharey=True)
    names = [name for name, _ in rows]
    for y, (name, entry) in enumerate(rows):
        times_ax.barh(y, entry["median_s"], color="C0")
        times_ax.text(entry["median_s"] * 1.1, y, f"{entry['median_s']:.3g} s", va="center", fontsize=8)
        target = TARGETS_S.get(name)
        if target:
            times_ax.plot([target, target], [y - 0.4, y + 0.4], color="red", linewidth=1.5)
        left = 0.0
        stages = entry.get("stages_s", {})
        for i, (stage, seconds) in enumerate(stages.items()):
            share = seconds / entry["median_s"]
            shares_ax.barh(y, share, left=left, color=f"C{i % 10}", edgecolor="white")
            if share > 0.08:
                shares_ax.text(left + share / 2, y, stage, ha="center", va="center", fontsize=7,
                               color="white")
            left += share
        shares_ax.barh(y, max(1.0 - left, 0.0), left=left, color="0.8", edgecolor="white")
    times_ax.set_yticks(range(len(rows)), names)
    times_ax.set_xscale("log")
    times_ax.set_xlabel("median wall time [s] (red: target)")
    shares_ax.set_xlim(0, 1)
    shares_ax.set_xlabel("share of the time per stage (grey: other, or stages not reported)")
    figure.suptitle("flip and climb planning (python -m benchmarks.plan)", fontsize="medium")
    figure.savefig(path, dpi=120)


def main() -> None:
    """Run the benchmark and write the results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=15, help="runs per flip plan")
    parser.add_argument("--sim-runs", type=int, default=3, help="runs per simulated flip")
    parser.add_argument("--climb-runs", type=int, default=3, help="runs of the climb plan")
    args = parser.parse_args()
    problems: dict[str, Any] = {}
    problems.update(bench_flip_plan(args.runs))
    problems["flip_simulated"] = bench_flip_simulated(args.sim_runs, None, 2.0)
    problems["flip_simulated_10Nm"] = bench_flip_simulated(args.sim_runs, 10.0, 2.0)
    problems["climb_plan"] = bench_climb(args.climb_runs)
    results = {
        "machine": {"python": platform.python_version(), "platform": platform.platform(),
                    "processor": platform.processor()},
        "targets_s": TARGETS_S,
        "problems": problems,
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "plan.json").write_text(json.dumps(results, indent=2, default=float) + "\n")
    plot(results, RESULTS / "plan.png")
    for name, entry in problems.items():
        if entry is None or "median_s" not in entry:
            print(f"{name:26s} {entry.get('skipped') if entry else 'skipped'}")
            continue
        shares = entry.get("stages_s", {})
        stages = ", ".join(f"{k} {100 * v / entry['median_s']:.0f}%" for k, v in shares.items())
        target = TARGETS_S.get(name)
        verdict = "" if target is None else (" (target met)" if entry["median_s"] <= target else
                                              f" (target {target:g} s MISSED)")
        print(f"{name:26s} {entry['median_s']:.4g} s{verdict}: {stages}")
    print(f"wrote {RESULTS / 'plan.json'} and {RESULTS / 'plan.png'}")


if __name__ == "__main__":
    main()
