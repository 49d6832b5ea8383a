"""Benchmark: frc atlas throughput against workers, per-point cost, chunk overhead, the big rod atlas.

Run from the repository root::

    python -m benchmarks.atlas [--runs 3] [--big-runs 1] [--quick] [--replot] [--big-only]

The problem is the rod on the table sliding left (``--set state.v.x=-1``) over its pitch and the
tip's friction, ``state.q.theta`` in [0.1, 3.0] and ``contacts.tip.mu`` in [0, 2]: at every point the
pitch and the friction are set on the scene a worker loaded once (the tip moves, the table follows
it: :mod:`frcontrol.scene_numbers`), every rigid solution is found (``solutions_at``) and each
one's stability is checked.

* **per-point cost** (the reference, in this process): a sample of distinct grid points evaluated
  one after another as a chunk evaluates them (:func:`frcontrol.atlas.points.evaluate_point`: the
  scene loaded once, each point's pitch and friction set on it), in CPU time, median of ``--runs``
  runs; beside it, in the same runs, the same points with the scene loaded at every point
  (``reload=True``, the path before), ``solutions_at`` from scratch at the same points, and the
  calibration workload of ``benchmarks.ci``, with the ratios (per run, then their median).
* **throughput**: a 61 x 41 grid through :func:`frcontrol.atlas.run_atlas` serially (1 worker), on
  the local pool with 2 and with every core, and on a Dask ``LocalCluster`` of 2 single-threaded
  worker processes on 127.0.0.1 (when Dask is installed), each the median of ``--runs`` runs, in
  points/s, with the speed-up over the serial run and the parallel efficiency
  ``per-point cost x points / workers / wall``.
* **chunk overhead**: the same grid on 2 pool workers (and on the cluster) with chunks of 1 point
  and of 64: ``(wall(1) - wall(64)) / (chunks(1) - chunks(64))`` per chunk; and the pool's start-up
  (a run of 2 one-point chunks, less their compute).
* **the big rod atlas**: 181 x 101 points on 2 local workers, wall time against the budget
  ``2 x solutions_at's cost x points / 2`` (an atlas at most twice the queries it is made of).

Writes ``benchmarks/results/atlas.json`` and ``benchmarks/results/atlas.png``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from pathlib import Path

import numpy as np

from frcontrol.atlas import AtlasWorkers, build_atlas, run_atlas
from frcontrol.atlas.executors import default_workers
from frcontrol.atlas.points import evaluate_point

RESULTS = Path(__file__).resolve().parent / "results"
SETS = {"state.v.x": -1.0}
BUDGET_FACTOR = 2.0
"""The big atlas on W workers must take at most this x solutions_at's cost x points / W."""


def axes(n_theta: int, n_mu: int) -> list[str]:
    return [f"state.q.theta=0.1:3.0:{n_theta}", f"contacts.tip.mu=0:2:{n_mu}"]


def per_point_cost(runs: int, sample: int) -> dict:
    """Seconds per point over a sample of distinct points of the big grid, medians of ``runs`` runs.

    In each run, one after another on the same points: the chunk path (the scene loaded once, each
    point's pitch and friction set on it), the scene loaded at every point (``reload=True``, the
    path before), ``solutions_at`` from scratch on the point's scene (loaded beforehand, not timed),
    the same with each solution's stability (``classify_solutions``: what a point computes), the
    chunk path on as many points in the grid's order (as a worker computes a chunk: a new pitch
    every 101 points), and the calibration workload of ``benchmarks.ci``; the ratios are per run,
    then their median.
    """
    from benchmarks.ci import calibration_workload
    from frcontrol.atlas.points import numeric_axes

    plan = build_atlas("rod_on_table", axes(181, 101), overrides=SETS)
    paths = numeric_axes(plan)
    rng = np.random.default_rng(7)
    parts: dict[str, list[float]] = {"chunk": [], "reload": [], "solutions_at": [], "with_stability": [],
                                     "grid_order": [], "calibration": []}
    for _ in range(runs):
        points = [int(k) for k in rng.choice(plan.size, size=sample, replace=False)]
        scenes = [(plan.source.load(plan.point(k)[0]), plan.point(k)[1]) for k in points[: sample // 4]]
        first = int(rng.integers(plan.size - sample))
        timed = _timed_parts(plan, paths, points, scenes, range(first, first + sample))
        for name, seconds in timed.items():
            parts[name].append(seconds)
        start = time.process_time()
        calibration_workload()
        parts["calibration"].append(time.process_time() - start)
    def ratios(a: str, b: str) -> float:
        return statistics.median([x / y for x, y in zip(parts[a], parts[b], strict=True)])

    return {"sample_points": sample, "runs": runs, "clock": "CPU time of this process",
            "per_point_s": statistics.median(parts["chunk"]),
            "reload_per_point_s": statistics.median(parts["reload"]),
            "grid_order_per_point_s": statistics.median(parts["grid_order"]),
            "solutions_at_s": statistics.median(parts["solutions_at"]),
            "solutions_and_stability_s": statistics.median(parts["with_stability"]),
            "calibration_s": statistics.median(parts["calibration"]),
            "ratio_to_solutions_at": ratios("chunk", "solutions_at"),
            "grid_order_ratio_to_solutions_at": ratios("grid_order", "solutions_at"),
            "ratio_to_solutions_and_stability": ratios("chunk", "with_stability"),
            "ratio_to_calibration": ratios("chunk", "calibration"),
            "speedup_over_reload": ratios("reload", "chunk")}


def _timed_parts(plan, paths, points, scenes, in_order) -> dict[str, float]:
    """CPU seconds per point of each path of :func:`per_point_cost`, in one run."""
    import frcontrol
    from frcontrol.modes import ContactProblem
    from frcontrol.stability import classify_solutions

    out = {}
    start = time.process_time()
    for k in points:
        evaluate_point(plan, k, numeric_paths=paths)
    out["chunk"] = (time.process_time() - start) / len(points)
    start = time.process_time()
    for k in points[: len(scenes)]:
        evaluate_point(plan, k, reload=True)
    out["reload"] = (time.process_time() - start) / len(scenes)
    start = time.process_time()
    for scene, inputs in scenes:
        frcontrol.solutions_at(scene, inputs)
    out["solutions_at"] = (time.process_time() - start) / len(scenes)
    start = time.process_time()
    for scene, inputs in scenes:
        problem = ContactProblem.from_scene(scene)
        classify_solutions(problem, frcontrol.solutions_at(problem, inputs))
    out["with_stability"] = (time.process_time() - start) / len(scenes)
    start = time.process_time()
    for k in in_order:
        evaluate_point(plan, k, numeric_paths=paths)
    out["grid_order"] = (time.process_time() - start) / len(in_order)
    return out


def per_point_line(cost: dict) -> str:
    return (f"per point: {1e6 * cost['per_point_s']:.0f} us of CPU ({cost['ratio_to_solutions_at']:.2f}x "
            f"solutions_at's {1e6 * cost['solutions_at_s']:.0f} us, "
            f"{cost['ratio_to_solutions_and_stability']:.2f}x solutions_at with each solution's stability "
            f"{1e6 * cost['solutions_and_stability_s']:.0f} us, {cost['ratio_to_calibration']:.4f}x the "
            f"calibration's {1e3 * cost['calibration_s']:.2f} ms); in the grid's order "
            f"{1e6 * cost['grid_order_per_point_s']:.0f} us ({cost['grid_order_ratio_to_solutions_at']:.2f}x "
            f"solutions_at); loading the scene at every point "
            f"{1e6 * cost['reload_per_point_s']:.0f} us ({cost['speedup_over_reload']:.1f}x slower)")


def timed_run(plan, runs: int, **where) -> dict:
    walls, inside, cpu = [], [], []
    report = None
    for _ in range(runs):
        start = time.perf_counter()
        result = run_atlas(plan, where=AtlasWorkers(**where))
        walls.append(time.perf_counter() - start)
        inside.append(result.timings["per_point"])
        cpu.append(result.timings["cpu_per_point"])
        report = result.run
    wall = statistics.median(walls)
    # per point inside the workers (wall time there): above the serial cost when the workers wait
    # for a core (other work on the machine), not for the executor
    return {"wall_s": wall, "walls_s": walls, "points_per_s": plan.size / wall, "chunks": plan.chunk_count,
            "chunk_size": plan.chunk_size, "workers": report["workers"] if report else None,
            "per_point_in_workers_s": statistics.median(inside),
            "cpu_per_point_in_workers_s": statistics.median(cpu)}


def throughput(runs: int, n_theta: int, n_mu: int, cost: float, scheduler: str | None) -> list[dict]:
    plan = build_atlas("rod_on_table", axes(n_theta, n_mu), overrides=SETS)
    rows = []
    counts = sorted({1, 2, default_workers()})
    for workers in counts:
        row = {"executor": "serial" if workers == 1 else "pool", "workers": workers,
               **timed_run(plan, runs, workers=workers)}
        rows.append(row)
    if scheduler is not None:
        run_atlas(plan, where=AtlasWorkers(scheduler=scheduler))  # warm-up: the workers import frcontrol
        rows.append({"executor": "dask", "workers": 2, **timed_run(plan, runs, scheduler=scheduler)})
    serial = rows[0]["wall_s"]
    for row in rows:
        row["speedup"] = serial / row["wall_s"]
        row["efficiency"] = cost * plan.size / row["workers"] / row["wall_s"]
    return rows


def chunk_overhead(runs: int, n_theta: int, n_mu: int, scheduler: str | None) -> dict:
    out = {}
    where = [("pool", {"workers": 2})] + ([("dask", {"scheduler": scheduler})] if scheduler else [])
    for name, kwargs in where:
        fine = build_atlas("rod_on_table", axes(n_theta, n_mu), overrides=SETS, chunk_size=1)
        coarse = build_atlas("rod_on_table", axes(n_theta, n_mu), overrides=SETS, chunk_size=64)
        a, b = timed_run(fine, runs, **kwargs), timed_run(coarse, runs, **kwargs)
        out[name] = {"chunks_of_1": a, "chunks_of_64": b,
                     "per_chunk_s": (a["wall_s"] - b["wall_s"]) / (fine.chunk_count - coarse.chunk_count)}
    return out


def pool_start() -> float:
    """[s] A run of 2 one-point chunks on 2 pool workers: the workers' start and their imports of
    frcontrol (the 2 points cost about 5 ms)."""
    tiny = build_atlas("rod_on_table", ["contacts.tip.mu=0.5:1:2"], overrides=SETS, chunk_size=1)
    return timed_run(tiny, 1, workers=2)["wall_s"]


def big_atlas(runs: int, cost: float) -> dict:
    """The 181 x 101 atlas on 2 workers; ``cost`` [s]: one ``solutions_at`` (the budget's unit)."""
    plan = build_atlas("rod_on_table", axes(181, 101), overrides=SETS)
    load_before = os.getloadavg()[0]
    run = timed_run(plan, runs, workers=2)
    budget = BUDGET_FACTOR * cost * plan.size / 2
    return {"grid": [181, 101], "points": plan.size, "workers": 2, **run, "budget_s": budget,
            "within_budget": bool(run["wall_s"] <= budget), "ideal_s": cost * plan.size / 2,
            "load_average_before_after": [load_before, os.getloadavg()[0]]}


def plot(payload: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    rows = payload["throughput"]
    labels = [f"{r['executor']}\n{r['workers']} worker{'s' if r['workers'] > 1 else ''}" for r in rows]
    left.bar(labels, [r["points_per_s"] for r in rows], color="#4c72b0")
    ideal = 1.0 / payload["per_point"]["per_point_s"]
    for i, r in enumerate(rows):
        left.plot([i - 0.4, i + 0.4], [ideal * r["workers"]] * 2, color="k", ls="--")
        top = max(r["points_per_s"], ideal * r["workers"])
        left.text(i, top * 1.01, f"{r['points_per_s']:.0f}/s\n(x{r['speedup']:.2f})", ha="center",
                  va="bottom", fontsize=8)
    left.set_ylabel("grid points per second")
    left.set_ylim(0, 1.25 * max(max(r["points_per_s"], ideal * r["workers"]) for r in rows))
    left.set_title(f"{payload['grid']} rod grid; dashes: workers / per-point cost", fontsize=9)
    over = payload["chunk_overhead"]
    names = [k for k in ("pool", "dask") if k in over]
    right.bar(names, [1e3 * over[k]["per_chunk_s"] for k in names], color="#dd8452")
    right.set_ylabel("overhead per chunk [ms]")
    big = payload["big_atlas"]
    right.set_title(f"181 x 101 rod atlas on 2 workers: {big['wall_s']:.1f} s "
                    f"(budget {big['budget_s']:.1f} s)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _cluster():
    try:
        from distributed import LocalCluster
    except ImportError:
        return None
    return LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                        dashboard_address=None)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--big-runs", type=int, default=1)
    parser.add_argument("--quick", action="store_true", help="a smoke run: small grids, one run each")
    parser.add_argument("--replot", action="store_true", help="redraw atlas.png from atlas.json, no run")
    parser.add_argument("--big-only", action="store_true",
                        help="only the per-point cost and the 181 x 101 atlas, to atlas_big.json")
    args = parser.parse_args()
    if args.big_only:
        cost = per_point_cost(args.runs, 400)
        big = big_atlas(args.big_runs, cost["solutions_at_s"])
        payload = {"benchmark": "frc atlas: the 181 x 101 rod atlas on 2 workers", "command":
                   "python -m benchmarks.atlas --big-only", "per_point": cost, "big_atlas": big,
                   "cores": os.cpu_count(), "python": platform.python_version()}
        (RESULTS / "atlas_big.json").write_text(json.dumps(payload, indent=2) + "\n")
        print(per_point_line(cost))
        print(f"181 x 101 on 2 workers: {big['wall_s']:.1f} s, "
              f"budget {big['budget_s']:.1f} s ({'met' if big['within_budget'] else 'NOT met'}); "
              f"{1e3 * big['per_point_in_workers_s']:.2f} ms per point inside the workers "
              f"({1e3 * big['cpu_per_point_in_workers_s']:.2f} ms of CPU); "
              f"load {big['load_average_before_after']}")
        return
    if args.replot:
        plot(json.loads((RESULTS / "atlas.json").read_text()), RESULTS / "atlas.png")
        return
    runs = 1 if args.quick else args.runs
    n_theta, n_mu = (11, 7) if args.quick else (61, 41)
    start = time.perf_counter()
    first_pool = pool_start()
    cost = per_point_cost(runs, 60 if args.quick else 400)
    cluster = _cluster()
    try:
        scheduler = cluster.scheduler_address if cluster is not None else None
        rows = throughput(runs, n_theta, n_mu, cost["per_point_s"], scheduler)
        overhead = chunk_overhead(runs, n_theta, n_mu, scheduler)
        overhead["pool_start_s"] = first_pool
    finally:
        if cluster is not None:
            cluster.close()
    big = big_atlas(args.big_runs, cost["solutions_at_s"]) if not args.quick else {}
    payload = {"benchmark": "frc atlas: throughput, per-point cost, chunk overhead", "command":
               "python -m benchmarks.atlas", "grid": f"{n_theta} x {n_mu}", "per_point": cost,
               "throughput": rows, "chunk_overhead": overhead, "big_atlas": big,
               "cores": os.cpu_count(), "load_average": os.getloadavg(), "python": platform.python_version(),
               "machine": platform.machine(), "seconds": time.perf_counter() - start}
    folder = RESULTS if not args.quick else Path(os.environ.get("TMPDIR", "/tmp"))
    (folder / "atlas.json").write_text(json.dumps(payload, indent=2) + "\n")
    if big:
        plot(payload, folder / "atlas.png")
    print(per_point_line(cost))
    for r in rows:
        print(f"{r['executor']} x{r['workers']}: {r['points_per_s']:.0f} points/s, "
              f"speed-up {r['speedup']:.2f}, efficiency {r['efficiency']:.2f}, "
              f"{1e3 * r['per_point_in_workers_s']:.2f} ms per point inside the workers "
              f"({1e3 * r['cpu_per_point_in_workers_s']:.2f} ms of CPU)")
    for name in ("pool", "dask"):
        if name in overhead:
            print(f"{name}: {1e3 * overhead[name]['per_chunk_s']:.2f} ms per chunk")
    print(f"pool start-up (the first in a process): {overhead['pool_start_s']:.2f} s")
    if big:
        print(f"181 x 101 on 2 workers: {big['wall_s']:.1f} s, budget {big['budget_s']:.1f} s "
              f"({'met' if big['within_budget'] else 'NOT met'}); ideal {big['ideal_s']:.1f} s; "
              f"{1e3 * big['per_point_in_workers_s']:.2f} ms per point inside the workers "
              f"({1e3 * big['cpu_per_point_in_workers_s']:.2f} ms of CPU)")
    print(f"written to {folder}; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
