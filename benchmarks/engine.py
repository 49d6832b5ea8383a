"""Speed of the mode-domain engine: ``python -m benchmarks.engine [--quick]``.

Measures, as medians of several runs on this machine:

- the full analysis (:func:`frcontrol.engine.analyze`: modes, responses, feasibility,
  full-dimensionality, overlaps; minimal forms and projections on demand) of the shipped rod,
  box, table, RHex flip and snake climb scenes, with the time per stage and per evaluated mode;
  and, like for like with the naive reference, the analysis without overlaps but with every
  feasible mode's minimal D_c and its projection T_c forced;
- every rigid-body solution at one input for RHex, from scratch and from a finished analysis;
- model assembly (M, h and every active contact's rows and drifts through ``Scene.state``)
  against the bare Pinocchio calls it makes, as a ratio;
- scaling in the number of contacts k = 1..8 (a straight snake lying on the ground, touching at
  k points): modes considered, evaluated and feasible, and time;
- a naive reference run in the same process: every one of the 4^k modes, each domain reduced by
  one LP per row, its projection computed, no early pruning of partial modes. It is written
  here, independently of the engine's enumeration, and cross-checks it: every mode the engine
  finds feasible the reference finds feasible too, and every extra mode of the reference is one
  whose solutions never move as it says (a degenerate mode the engine names by its motion).

Results: ``benchmarks/results/engine.json`` and ``engine.png``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

from frcontrol import polytope as poly
from frcontrol.engine import analyze, domain_polytope, motion_margin, solutions_at
from frcontrol.modes import ContactProblem, all_modes, build_mode_system
from frcontrol.response import solve_affine
from frcontrol.scene import load_scene, shipped_robots_dir
from frcontrol.solvers import solve_lp

RESULTS = Path(__file__).resolve().parent / "results"
SCENES = ["rod_on_table", "box_on_ground", "table_on_ground", "disk_in_wedge", "rhex_flip", "snake_climb"]
TARGETS = {
    "rhex_flip_analysis_ms": 50.0,
    "snake_8_contacts_s": 1.0,
    "rhex_solutions_at_ms": 5.0,
    "model_assembly_ratio": 2.0,
}


def median_time(func, runs: int) -> tuple[float, object]:
    """Median wall time [s] of ``runs`` calls (after one warm-up call), and the last result."""
    result = func()
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        result = func()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def snake_on_ground(k: int) -> Path:
    """A scene file: the straight snake lying on y = 0, touching at the first k link origins."""
    contacts = "".join(
        f'\n[[contacts]]\nname = "c{i}"\nlink = "link{i}"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n'
        f"mu = 0.5\nsurface_point = [0.0, 0.0]\n"
        for i in range(k)
    )
    joints = [f"j{i}" for i in range(1, 9)]
    text = (
        f'name = "snake on the ground, {k} contacts"\n'
        f'robot = "{shipped_robots_dir() / "snake_planar.urdf"}"\n'
        f"[state]\nq = {[0.0] * 11}\n{contacts}\n"
        f"[inputs]\ncoordinates = {json.dumps(joints)}\nlower = {[-5.0] * 8}\nupper = {[5.0] * 8}\n"
    )
    path = Path(tempfile.mkdtemp()) / f"snake_ground_{k}.toml"
    path.write_text(text)
    return path


# ------------------------------------------------------------------------------- naive reference
def naive_minimal(P: poly.Polytope) -> poly.Polytope | None:
    """One LP per row (no emptiness test first, no minrep, no ray shooting); None if empty."""
    rows = list(range(P.A.shape[0]))
    kept = []
    for i in rows:
        others = [j for j in rows if j != i]
        A, b = P.A[others], P.b[others]
        # max a_i x s.t. the other rows and a_i x <= b_i + 1: redundant iff the max stays <= b_i
        res = solve_lp(-P.A[i], np.vstack([A, P.A[i]]), np.concatenate([b, [P.b[i] + 1.0]]),
                       P.A_eq if P.A_eq.shape[0] else None, P.b_eq if P.A_eq.shape[0] else None)
        if res.status == "infeasible":
            return None
        if res.found and -res.objective > P.b[i] + 1e-9:
            kept.append(i)
    if not kept:
        return None
    return poly.Polytope(P.A[kept], P.b[kept], P.A_eq, P.b_eq)


def forced_analysis(scene) -> object:
    """The engine's analysis without overlaps, every minimal D_c and projected T_c computed."""
    result = analyze(scene, ambiguity=False)
    for mode in result.feasible_modes:
        _ = mode.domain, mode.input_domain
    return result


def naive_analysis(problem: ContactProblem) -> dict[str, bool]:
    """Every mode, fully: response, domain reduced row by row, projection. Mode -> feasible."""
    feasible = {}
    for mode in all_modes(problem.allowed_modes()):
        system = build_mode_system(problem, mode)
        response = solve_affine(system.A, system.B, system.c)
        if not response.consistent:
            feasible[mode] = False
            continue
        domain, _ = domain_polytope(problem, system, response)
        minimal = naive_minimal(domain)
        if minimal is None:
            feasible[mode] = False
            continue
        poly.chebyshev_ball(minimal)
        if response.ambiguity_dim:
            poly.project(minimal, range(problem.m))
        feasible[mode] = True
    return feasible


def degenerate(problem: ContactProblem, mode: str) -> bool:
    """The engine's motion test on a full mode: no solution moves as the mode says."""
    system = build_mode_system(problem, mode)
    response = solve_affine(system.A, system.B, system.c)
    domain, motion = domain_polytope(problem, system, response)
    return motion_margin(domain.A, domain.b, motion, domain.A_eq, domain.b_eq).verdict == "freedom"


# ------------------------------------------------------------------------------- model assembly
def bare_pinocchio(scene) -> callable:
    """The Pinocchio calls behind ``Scene.state``, with nothing around them."""
    robot = scene.robot
    model, data = robot.model, robot.data
    q_pin = robot.pinocchio_q_from_minimal(scene.q)
    v_pin = robot.pinocchio_v_from_minimal(scene.v)
    frames = [robot._contact_frames[i] for i in scene.active_indices]
    lwa = pin.LOCAL_WORLD_ALIGNED

    def run() -> None:
        pin.computeAllTerms(model, data, q_pin, v_pin)
        for fid in frames:
            pin.updateFramePlacement(model, data, fid)
            pin.getFrameJacobian(model, data, fid, lwa)
            pin.getFrameClassicalAcceleration(model, data, fid, lwa)

    return run


# ------------------------------------------------------------------------------- main
def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer runs, k up to 6")
    args = parser.parse_args(argv)
    runs = 3 if args.quick else 7
    out: dict = {"runs": runs, "scenes": {}, "scaling": [], "targets": TARGETS}

    print(f"{'scene':16s} {'modes':>6s} {'eval':>5s} {'feas':>5s} {'overl':>5s} {'median ms':>10s} "
          f"{'ms/mode':>8s} {'forced ms':>9s} {'naive ms':>9s} {'naive/forced':>12s}")
    for name in SCENES:
        scene = load_scene(name)
        elapsed, result = median_time(lambda s=scene: analyze(s), runs)
        e = result.enumeration
        stages = {k: v for k, v in result.timings.items() if k != "total"}
        problem = result.problem
        forced, _ = median_time(lambda s=scene: forced_analysis(s), runs)
        naive_runs = 1 if problem.k >= 3 else runs
        naive_elapsed, naive = median_time(lambda p=problem: naive_analysis(p), naive_runs)
        ours = {m.mode for m in result.feasible_modes}
        extra = {m for m, ok in naive.items() if ok} - ours
        check = ours <= {m for m, ok in naive.items() if ok} and all(degenerate(problem, m) for m in extra)
        entry = {
            "median_s": elapsed, "modes": e.total, "evaluated": e.evaluated, "feasible": e.feasible,
            "overlaps": len(result.overlaps), "stages_s": stages,
            "per_evaluated_mode_s": elapsed / max(e.evaluated, 1),
            "forced_median_s": forced,
            "naive_median_s": naive_elapsed, "naive_runs": naive_runs, "ratio_naive_over_forced":
            naive_elapsed / forced, "naive_feasible": sum(naive.values()),
            "naive_extra_modes_all_degenerate": bool(check),
        }
        out["scenes"][name] = entry
        print(f"{name:16s} {e.total:6d} {e.evaluated:5d} {e.feasible:5d} {len(result.overlaps):5d} "
              f"{1e3 * elapsed:10.1f} {1e3 * elapsed / max(e.evaluated, 1):8.2f} "
              f"{1e3 * forced:9.1f} {1e3 * naive_elapsed:9.1f} {naive_elapsed / forced:12.1f}"
              + ("" if check else "  MISMATCH"))

    rhex = load_scene("rhex_flip")
    analysis = analyze(rhex)
    u = np.array([-2.0, -5.0])
    scratch, sols = median_time(lambda: solutions_at(rhex, u), runs * 3)
    fast, sols_fast = median_time(lambda: solutions_at(analysis, u), runs * 3)
    out["rhex_solutions_at"] = {"input": u.tolist(), "from_scratch_s": scratch, "from_analysis_s": fast,
                                "modes": [s.mode for s in sols]}
    print(f"RHex every rigid solution at u = {u.tolist()}: {[s.mode for s in sols]}: "
          f"{1e3 * scratch:.2f} ms from scratch, {1e3 * fast:.2f} ms from the analysis")

    assembly = {}
    n_calls = 2000
    for name in ("rhex_flip", "snake_climb"):
        scene = load_scene(name)
        bare_calls = bare_pinocchio(scene)
        ours, _ = median_time(lambda s=scene: [s.state() for _ in range(n_calls)], runs)
        bare, _ = median_time(lambda f=bare_calls: [f() for _ in range(n_calls)], runs)
        assembly[name] = {"state_us": 1e6 * ours / n_calls, "bare_us": 1e6 * bare / n_calls,
                          "ratio": ours / bare}
        print(f"model assembly {name}: {1e6 * ours / n_calls:.1f} us vs bare Pinocchio "
              f"{1e6 * bare / n_calls:.1f} us (ratio {ours / bare:.2f})")
    out["model_assembly"] = assembly

    k_max = 6 if args.quick else 8
    print(f"{'k':>2s} {'modes':>6s} {'eval':>5s} {'feas':>5s} {'ms':>9s} {'forced ms':>9s} {'naive ms':>9s}")
    for k in range(1, k_max + 1):
        scene = load_scene(snake_on_ground(k))
        elapsed, result = median_time(lambda s=scene: analyze(s, ambiguity=False), 1 if k >= 6 else runs)
        e = result.enumeration
        row = {"k": k, "modes": e.total, "evaluated": e.evaluated, "feasible": e.feasible,
               "partial_checks": e.partial_checks, "time_s": elapsed}
        if k <= 6:
            row["forced_time_s"], _ = median_time(lambda s=scene: forced_analysis(s), 1)
        if k <= 4:
            naive_elapsed, _ = median_time(lambda p=result.problem: naive_analysis(p), 1)
            row["naive_time_s"] = naive_elapsed
        out["scaling"].append(row)
        print(f"{k:2d} {e.total:6d} {e.evaluated:5d} {e.feasible:5d} {1e3 * elapsed:9.1f} "
              f"{1e3 * row.get('forced_time_s', float('nan')):9.1f} "
              f"{1e3 * row.get('naive_time_s', float('nan')):9.1f}")

    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "engine.json").write_text(json.dumps(out, indent=2))
    plot(out, RESULTS / "engine.png")
    print(f"wrote {RESULTS / 'engine.json'} and {RESULTS / 'engine.png'}")
    return out


def plot(out: dict, path: Path) -> None:
    """Stage shares per scene, and time against the number of contacts."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.5))
    names = list(out["scenes"])
    stages = ["response", "feasibility", "domain", "projection", "ambiguity", "model"]
    bottom = np.zeros(len(names))
    for stage in stages:
        values = np.array([1e3 * out["scenes"][n]["stages_s"].get(stage, 0.0) for n in names])
        left.bar(names, values, bottom=bottom, label=stage)
        bottom += values
    left.set_ylabel("time per analysis [ms] (median run's stages)")
    left.set_title("analyze(): time by stage")
    left.tick_params(axis="x", rotation=30)
    left.legend(fontsize=8)
    ks = [r["k"] for r in out["scaling"]]
    right.semilogy(ks, [r["time_s"] for r in out["scaling"]], "o-", label="engine (pruned, lazy domains)")
    forced = [(r["k"], r["forced_time_s"]) for r in out["scaling"] if "forced_time_s" in r]
    right.semilogy(*zip(*forced, strict=True), "^-", label="engine, every D_c and T_c forced")
    naive = [(r["k"], r["naive_time_s"]) for r in out["scaling"] if "naive_time_s" in r]
    if naive:
        right.semilogy(*zip(*naive, strict=True), "s--", label="naive reference (all 4^k modes)")
    right.semilogy(ks, [r["feasible"] * 1e-3 for r in out["scaling"]], ":", label="feasible modes / 1000")
    right.axhline(1.0, color="grey", lw=0.8)
    right.set_xlabel("contacts k (snake lying on the ground)")
    right.set_ylabel("time [s]")
    right.set_title("scaling in the number of contacts")
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main(sys.argv[1:])
