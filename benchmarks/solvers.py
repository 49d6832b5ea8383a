"""Benchmark of the LP back-ends and of the polytope operations built on them.

Run from the repository root::

    python -m benchmarks.solvers            # full run (about a minute)
    python -m benchmarks.solvers --quick    # fewer LPs and repetitions

Writes ``benchmarks/results/solvers.json`` and ``benchmarks/results/solvers.png`` and prints a
table. Everything is seeded. Timings are wall-clock on this machine; they are reported, never
asserted anywhere.

LPs: ``d`` variables in the box ``[-1, 1]^d`` and ``m`` random Gaussian rows through a point of
the box with a slack in ``[0.1, 1]``: bounded and feasible. Every back-end solves every LP
through the door :func:`frcontrol.solvers.solve_lp`; the answer is compared with HiGHS':

* ``wrong``: found, but the objective differs from HiGHS' by more than 1e-6 relatively
  (``grossly_wrong``: by more than 1e-3);
* ``false_infeasible``: declared infeasible (the LP is feasible by construction);
* ``other``: any other failure (``error``, ``unbounded``).

Times: ``adapter_us`` is the back-end call (``LPResult.solve_time``: set-up and solve),
``door_us`` the whole :func:`solve_lp` call (validation, residual check); per LP the median of
the repetitions, then the median over the LPs.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np

from frcontrol.polytope import Polytope, minimal_representation, project
from frcontrol.solvers import REFERENCE_LP_SOLVER, DoorOptions, available_solvers, settings_from, solve_lp

RESULTS = Path(__file__).parent / "results"
DIMENSIONS = (6, 8, 12)
ROW_COUNTS = (20, 50, 100, 200)
RELATIVE_OPTIMUM_TOLERANCE = 1e-6
GROSS_ERROR = 1e-3
PROXQP_OWN_DEFAULTS = dict(
    eps_abs=1e-5, eps_rel=0.0, check_duality_gap=False, eps_primal_inf=1e-4, eps_dual_inf=1e-4
)


def random_lp(rng: np.random.Generator, d: int, m: int, box: float = 1.0) -> dict:
    A = rng.standard_normal((m, d))
    x0 = rng.uniform(-0.5, 0.5, d) * box
    b = A @ x0 + rng.uniform(0.1, 1.0, m)
    return dict(c=rng.standard_normal(d), A_ub=A, b_ub=b, lb=-box, ub=box)


def badly_scaled_lp(rng: np.random.Generator, d: int, m: int) -> dict:
    """Feasible LPs with a wide box (1e3) and unit offsets: ProxQP's defaults fail on them."""
    return dict(
        c=rng.standard_normal(d), A_ub=rng.standard_normal((m, d)), b_ub=np.ones(m), lb=-1e3,
        ub=1e3,
    )


def backends() -> dict[str, tuple[str, dict]]:
    """Label -> (back-end, options)."""
    labels = {name: (name, {}) for name in available_solvers()}
    if "proxsuite" in labels:
        labels["proxsuite (ProxQP defaults)"] = ("proxsuite", PROXQP_OWN_DEFAULTS)
    return labels


def classify(result, reference) -> str:
    if result.found:
        gap = abs(result.objective - reference.objective) / (1 + abs(reference.objective))
        if gap <= RELATIVE_OPTIMUM_TOLERANCE:
            return "ok"
        return "wrong" if gap <= GROSS_ERROR else "grossly_wrong"
    return "false_infeasible" if result.status == "infeasible" else "other"


def bench_lps(n_lps: int, repeats: int, family=random_lp) -> list[dict]:
    rows = []
    for d in DIMENSIONS:
        for m in ROW_COUNTS:
            rng = np.random.default_rng(1000 * d + m)
            lps = [family(rng, d, m) for _ in range(n_lps)]
            references = [solve_lp(**lp, door=DoorOptions(settings_from(REFERENCE_LP_SOLVER))) for lp in lps]
            for label, (solver, options) in backends().items():
                how = DoorOptions(settings_from(solver).with_options(solver, **options))
                adapter_times, door_times = [], []
                outcomes = dict.fromkeys(
                    ("ok", "wrong", "grossly_wrong", "false_infeasible", "other"), 0
                )
                for lp, reference in zip(lps, references, strict=True):
                    adapter, door = [], []
                    for _ in range(repeats):
                        start = time.perf_counter()
                        result = solve_lp(**lp, door=how)
                        door.append(time.perf_counter() - start)
                        adapter.append(result.solve_time)
                    adapter_times.append(np.median(adapter))
                    door_times.append(np.median(door))
                    outcomes[classify(result, reference)] += 1
                rows.append(
                    dict(
                        backend=label, d=d, m=m, lps=n_lps,
                        adapter_us=float(np.median(adapter_times) * 1e6),
                        door_us=float(np.median(door_times) * 1e6),
                        **{k: v for k, v in outcomes.items() if k != "ok"},
                    )
                )
    return rows


def _stdout_bytes(function) -> tuple[int, object]:
    """(bytes the call wrote to file descriptor 1, its result)."""
    import os
    import sys
    import tempfile

    sys.stdout.flush()
    saved = os.dup(1)
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 1)
        try:
            result = function()
        finally:
            sys.stdout.flush()
            os.dup2(saved, 1)
            os.close(saved)
        return sink.seek(0, 2), result


def bench_qpsolvers(n_lps: int, repeats: int) -> list[dict]:
    """The same LPs through qpsolvers (as QPs with P = 0) and through frcontrol's door.

    Reports per back-end: the median time of ``qpsolvers.solve_problem`` and of the door's
    :func:`~frcontrol.solvers.solve_lp_prepared` (no validation, residual check kept), wrong
    optima, whether an infeasible and an unbounded LP can be told apart from the answer (the
    door's ``status``; qpsolvers' ``Solution`` has ``found`` only), and the bytes each writes to
    stdout. Needs qpsolvers (the ``dev`` extra); skipped, and said so, without it.
    """
    try:
        import warnings

        import qpsolvers
    except ImportError:
        print("qpsolvers is not installed (pip install '.[dev]'): no comparison")
        return []
    from frcontrol.solvers import lp_problem, solve

    names = {"daqp": "daqp", "highs": "highs", "proxqp": "proxsuite"}
    rows = []
    d, m = 8, 50
    rng = np.random.default_rng(8050)
    lps = [random_lp(rng, d, m) for _ in range(n_lps)]
    references = [solve_lp(**lp, door=DoorOptions(settings_from(REFERENCE_LP_SOLVER))) for lp in lps]
    infeasible = dict(c=np.ones(2), A_ub=np.array([[1.0, 0.0], [-1.0, 0.0]]), b_ub=np.array([-1.0, 0.0]))
    unbounded = dict(c=np.ones(2), A_ub=np.array([[0.0, 1.0]]), b_ub=np.array([1.0]))
    for theirs, ours in names.items():
        if theirs not in qpsolvers.available_solvers or ours not in available_solvers():
            continue

        def through_qpsolvers(lp, name=theirs):
            n = len(lp["c"])
            lb = np.full(n, float(lp.get("lb", -np.inf)))
            ub = np.full(n, float(lp.get("ub", np.inf)))
            problem = qpsolvers.Problem(np.zeros((n, n)), lp["c"], lp["A_ub"], lp["b_ub"],
                                        lb=None if np.all(np.isinf(lb)) else lb,
                                        ub=None if np.all(np.isinf(ub)) else ub)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return qpsolvers.solve_problem(problem, solver=name)

        theirs_times, ours_times, wrong, printed = [], [], 0, 0
        for lp, reference in zip(lps, references, strict=True):
            problem = lp_problem(**lp)
            for _ in range(repeats):
                start = time.perf_counter()
                written, solution = _stdout_bytes(lambda lp=lp: through_qpsolvers(lp))
                theirs_times.append(time.perf_counter() - start)
                printed += written
                start = time.perf_counter()
                solve(problem, solver=ours)
                ours_times.append(time.perf_counter() - start)
            if not solution.found or abs(float(lp["c"] @ solution.x) - reference.objective) > 1e-6 * (
                    1 + abs(reference.objective)):
                wrong += 1
        _, on_infeasible = _stdout_bytes(lambda: through_qpsolvers(infeasible))
        _, on_unbounded = _stdout_bytes(lambda: through_qpsolvers(unbounded))
        door_infeasible = solve_lp(**infeasible, door=DoorOptions(settings_from(ours))).status
        door_unbounded = solve_lp(**unbounded, door=DoorOptions(settings_from(ours))).status
        rows.append(dict(
            backend=ours, d=d, m=m, lps=n_lps,
            qpsolvers_us=float(np.median(theirs_times) * 1e6),
            door_prepared_us=float(np.median(ours_times) * 1e6),
            qpsolvers_wrong=wrong,
            qpsolvers_tells_infeasible_from_unbounded=bool(
                (on_infeasible.found, on_infeasible.x is None)
                != (on_unbounded.found, on_unbounded.x is None)),
            door_statuses=[door_infeasible, door_unbounded],
            qpsolvers_stdout_bytes=printed,
        ))
    return rows


def redundant_polytope(rng: np.random.Generator, d: int, m: int) -> Polytope:
    """m rows around the origin, offsets in [0.2, 3]: many rows are redundant."""
    A = rng.standard_normal((m, d))
    A /= np.linalg.norm(A, axis=1)[:, None]
    return Polytope(A, rng.uniform(0.2, 3.0, m))


def timed(function, repeats: int) -> tuple[float, object]:
    times, value = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        value = function()
        times.append(time.perf_counter() - start)
    return float(np.median(times)), value


def bench_minimal_representation(repeats: int) -> list[dict]:
    rows = []
    for d in (4, 8, 12):
        for m in (20, 50, 100, 200):
            rng = np.random.default_rng(7 * d + m)
            P = redundant_polytope(rng, d, m)
            for use_minrep in (True, False):
                seconds, minimal = timed(
                    lambda P=P, u=use_minrep: minimal_representation(P, use_minrep=u), repeats
                )
                rows.append(
                    dict(d=d, m=m, use_minrep=use_minrep, ms=seconds * 1e3,
                         rows_kept=int(minimal.A.shape[0]))
                )
    return rows


def bench_projection(repeats: int) -> list[dict]:
    rows = []
    for d in (4, 6, 8):
        for eliminated in (1, 2, 3):
            rng = np.random.default_rng(11 * d + eliminated)
            m = 2 * d + 2
            A = rng.standard_normal((m, d))
            P = Polytope(A, A @ rng.uniform(-1, 1, d) + rng.uniform(0.2, 1.0, m))
            seconds, shadow = timed(lambda P=P, k=d - eliminated: project(P, k), repeats)
            rows.append(
                dict(d=d, m=m, eliminated=eliminated, ms=seconds * 1e3,
                     rows_out=int(shadow.A.shape[0]))
            )
    return rows


def plot(lp_rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = sorted({row["backend"] for row in lp_rows})
    fig, axes = plt.subplots(1, len(DIMENSIONS), figsize=(5 * len(DIMENSIONS), 4), sharey=True)
    for ax, d in zip(np.atleast_1d(axes), DIMENSIONS, strict=True):
        for label in labels:
            points = [
                (r["m"], r["door_us"]) for r in lp_rows if r["d"] == d and r["backend"] == label
            ]
            m, us = zip(*points, strict=True)
            ax.plot(m, us, marker="o", label=label)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(ROW_COUNTS, [str(m) for m in ROW_COUNTS])
        ax.minorticks_off()
        ax.set_xlabel("rows m")
        ax.set_title(f"d = {d}")
        ax.grid(True, which="both", alpha=0.3)
    np.atleast_1d(axes)[0].set_ylabel("median time per LP through the door [us]")
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.suptitle("Small dense bounded feasible LPs (seeded); failures in solvers.json")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer LPs and repetitions")
    args = parser.parse_args()
    n_lps, repeats = (10, 3) if args.quick else (30, 5)

    lp_rows = bench_lps(n_lps, repeats)
    scaled_rows = bench_lps(n_lps, 1, family=badly_scaled_lp)
    minrep_rows = bench_minimal_representation(repeats)
    projection_rows = bench_projection(max(1, repeats // 2))
    qpsolvers_rows = bench_qpsolvers(n_lps, repeats)

    RESULTS.mkdir(parents=True, exist_ok=True)
    results = dict(
        machine=dict(python=platform.python_version(), processor=platform.processor(),
                     platform=platform.platform()),
        settings=dict(lps_per_size=n_lps, repeats=repeats,
                      relative_optimum_tolerance=RELATIVE_OPTIMUM_TOLERANCE),
        lp=lp_rows,
        lp_badly_scaled=[{k: v for k, v in r.items() if not k.endswith("_us")}
                         for r in scaled_rows],
        minimal_representation=minrep_rows,
        projection=projection_rows,
        qpsolvers=qpsolvers_rows,
    )
    (RESULTS / "solvers.json").write_text(json.dumps(results, indent=2) + "\n")
    plot(lp_rows, RESULTS / "solvers.png")

    print(f"{'back-end':30s} {'d':>3s} {'m':>4s} {'adapter us':>11s} {'door us':>9s} "
          f"{'wrong':>6s} {'gross':>6s} {'false inf':>9s} {'other':>6s}")
    for r in lp_rows:
        print(f"{r['backend']:30s} {r['d']:3d} {r['m']:4d} {r['adapter_us']:11.1f} "
              f"{r['door_us']:9.1f} {r['wrong']:6d} {r['grossly_wrong']:6d} "
              f"{r['false_infeasible']:9d} {r['other']:6d}")
    print("\nbadly scaled LPs (box 1e3, unit offsets): failures of", n_lps, "per size")
    for label in backends():
        rows = [r for r in scaled_rows if r["backend"] == label]
        kinds = ("wrong", "grossly_wrong", "false_infeasible", "other")
        total = {k: sum(r[k] for r in rows) for k in kinds}
        print(f"  {label:30s} {total} over {len(rows) * n_lps} LPs")
    print(f"\n{'minimal_representation':24s} {'d':>3s} {'m':>4s} {'minrep':>7s} {'ms':>8s} "
          f"{'kept':>5s}")
    for r in minrep_rows:
        print(f"{'':24s} {r['d']:3d} {r['m']:4d} {r['use_minrep']!s:>7s} {r['ms']:8.2f} "
              f"{r['rows_kept']:5d}")
    print(f"\n{'project (Fourier-Motzkin)':26s} {'d':>3s} {'m':>4s} {'elim':>5s} {'ms':>9s} "
          f"{'rows':>5s}")
    for r in projection_rows:
        print(f"{'':26s} {r['d']:3d} {r['m']:4d} {r['eliminated']:5d} {r['ms']:9.2f} "
              f"{r['rows_out']:5d}")
    print("\nthe same LPs (d = 8, m = 50) through qpsolvers (P = 0) and through the door (prepared):")
    for r in qpsolvers_rows:
        print(f"  {r['backend']:10s} qpsolvers {r['qpsolvers_us']:8.1f} us, "
              f"door {r['door_prepared_us']:8.1f} us; "
              f"wrong {r['qpsolvers_wrong']}; infeasible vs unbounded told apart: "
              f"{r['qpsolvers_tells_infeasible_from_unbounded']} (door: {r['door_statuses']}); "
              f"stdout bytes {r['qpsolvers_stdout_bytes']}")
    print(f"\nwrote {RESULTS / 'solvers.json'} and {RESULTS / 'solvers.png'}")


if __name__ == "__main__":
    main()
