"""The LP door's cost per call: ``python -m benchmarks.lp_door [--record] [--contacts K]``.

The forced analysis of the snake on the ground (``benchmarks/contacts.py``'s scene set) solves
thousands of small LPs; most of each LP's CPU time was the door's own bookkeeping, not the solve.
This benchmark replays a corpus of those LPs, recorded from the forced analysis with
``--record`` into ``benchmarks/data/lp_corpus.npz`` (every LP the door received, with the
arrays as the door received them), and times, in one process, per LP:

- ``door``: :func:`frcontrol.solvers.solve_lp_prepared`, as the polytope module called it before
  the lean path (problem object, adapter, residual check, result);
- ``lean``: :meth:`frcontrol.solvers.InequalityLPs.solve` (the door's lean path) on the LPs it
  serves (inequalities and simple bounds, no equality), the door for the rest;
- ``daqp``: ``daqp.solve`` alone on the arrays already in its layout (the floor);
- ``check``: the residual check alone (the kernel's ``lp_check``: compiled, or its NumPy twin).

Every time is the median of ``--runs`` passes over the corpus, also as a ratio to
``benchmarks/ci.py``'s calibration workload measured in the same process. Writes
``benchmarks/results/lp_door.json``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import statistics
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

import frcontrol.polytope  # noqa: F401  (it registers the kernel's lp_check)
from benchmarks.ci import calibration_workload, versions
from frcontrol import solvers
from frcontrol.kernel import backend
from frcontrol.solvers import LinearProgram

RESULTS = Path(__file__).resolve().parent / "results"
CORPUS = Path(__file__).resolve().parent / "data" / "lp_corpus.npz"
"""The recorded LPs (:func:`save_corpus`'s layout)."""

RECORD_CONTACTS = 6
"""Default contact count of the snake whose forced analysis is recorded (a corpus of a few MB)."""


def save_corpus(problems: list[LinearProgram], path: Path) -> None:
    """Every problem's arrays, concatenated, with their shapes ``(n, m_ub, m_eq)`` per problem."""
    shapes = np.array([(p.n, p.A_ub.shape[0], p.A_eq.shape[0]) for p in problems], dtype=np.int64)

    def flat(name: str) -> np.ndarray:
        return np.concatenate([getattr(p, name).reshape(-1) for p in problems])

    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, shapes=shapes, **{name: flat(name) for name in
                                                ("c", "A_ub", "b_ub", "A_eq", "b_eq", "lb", "ub")})


def load_corpus(path: Path = CORPUS) -> list[LinearProgram]:
    """The problems of :func:`save_corpus`, as the door's problem objects."""
    with np.load(path) as stored:
        data = {name: stored[name] for name in stored.files}  # read once (each access decompresses)
    offsets = {name: 0 for name in ("c", "A_ub", "b_ub", "A_eq", "b_eq", "lb", "ub")}

    def take(name: str, shape: tuple[int, ...]) -> np.ndarray:
        size = int(np.prod(shape))
        start = offsets[name]
        offsets[name] = start + size
        return np.ascontiguousarray(data[name][start:start + size].reshape(shape))

    problems = []
    for n, m_ub, m_eq in data["shapes"].tolist():
        problems.append(LinearProgram(take("c", (n,)), take("A_ub", (m_ub, n)), take("b_ub", (m_ub,)),
                                      take("A_eq", (m_eq, n)), take("b_eq", (m_eq,)), take("lb", (n,)),
                                      take("ub", (n,))))
    return problems


def record(contacts: int) -> list[LinearProgram]:
    """Every LP the door receives during the forced analysis of the snake with ``contacts`` contacts.

    Both ways in: the general door (:func:`frcontrol.solvers.solve`) and its lean path
    (:meth:`frcontrol.solvers.InequalityLPs.solve`, which the polytope module and the engine take);
    an LP the lean path hands on to the general door is recorded once.
    """
    from benchmarks.contacts import snake_scene
    from frcontrol.engine import analyze
    from frcontrol.scene import load_scene

    problems: list[LinearProgram] = []
    door, lean = solvers.solve, solvers.InequalityLPs.solve
    inside_lean = [False]

    def recording(problem: LinearProgram, **kwargs: Any) -> Any:
        if not inside_lean[0]:
            problems.append(problem)
        return door(problem, **kwargs)

    def recording_lean(self: solvers.InequalityLPs, c: np.ndarray, A_ub: np.ndarray, b_ub: np.ndarray,
                       lb: np.ndarray | None = None, ub: np.ndarray | None = None) -> Any:
        problems.append(solvers.lp_problem(c, A_ub, b_ub, lb=lb, ub=ub, validate=False))
        inside_lean[0] = True
        try:
            return lean(self, c, A_ub, b_ub, lb, ub)
        finally:
            inside_lean[0] = False

    scene = load_scene(snake_scene(contacts))
    solvers.solve = recording
    solvers.InequalityLPs.solve = recording_lean  # type: ignore[method-assign]
    try:
        done = analyze(scene, ambiguity=False)
        for mode in done.feasible_modes:
            _ = mode.domain, mode.input_domain
    finally:
        solvers.solve = door
        solvers.InequalityLPs.solve = lean  # type: ignore[method-assign]
    return problems


def lean_calls(problems: list[LinearProgram]) -> Iterator[Callable[[], Any]]:
    """One call per problem: the lean path where it serves the problem, else the door."""
    lp_check = backend().lp_check
    lps = solvers.InequalityLPs(check=lp_check)
    for p in problems:
        if p.A_eq.shape[0] == 0:
            bounds = (p.lb, p.ub) if p.has_bounds else (None, None)  # as the callers pass them
            yield lambda p=p, bounds=bounds: lps.solve(p.c, p.A_ub, p.b_ub, *bounds)
        else:
            yield lambda p=p: solvers.solve(p, check=lp_check)


class GeneralDoor:
    """:class:`frcontrol.solvers.InequalityLPs`'s interface on the general door (the path before it).

    Each LP through :func:`frcontrol.solvers.solve_lp_prepared`, as the polytope module and the
    engine called it before the lean path; :func:`general_door` puts it in the lean path's place.
    """

    def __init__(self, *, solver: str | None = None, settings: solvers.SolverSettings | None = None,
                 fallback: solvers.Fallback = solvers.NO_FALLBACK,
                 check: solvers.ResidualCheck = solvers.lp_check, **options: Any) -> None:
        chosen = solvers.settings_from(solver, settings)
        if options:
            chosen = chosen.with_options(chosen.lp, **options)
        self.door = solvers.DoorOptions(chosen, fallback=fallback, check=check)

    def solve(self, c: np.ndarray, A_ub: np.ndarray, b_ub: np.ndarray, lb: np.ndarray | None = None,
              ub: np.ndarray | None = None) -> solvers.LPResult:
        """:func:`frcontrol.solvers.solve_lp_prepared` of the LP."""
        return solvers.solve_lp_prepared(c, A_ub, b_ub, lb=lb, ub=ub, door=self.door)


@contextlib.contextmanager
def general_door() -> Iterator[None]:
    """Within the block, the geometry and polytope modules (the engine's LPs too) solve every LP
    through the general door."""
    from frcontrol import geometry, polytope

    saved = polytope.InequalityLPs, geometry.InequalityLPs
    polytope.InequalityLPs = geometry.InequalityLPs = GeneralDoor  # type: ignore[assignment, misc]
    try:
        yield
    finally:
        polytope.InequalityLPs, geometry.InequalityLPs = saved  # type: ignore[misc]


def per_lp_seconds(calls: list[Callable[[], Any]], runs: int) -> float:
    """Median over ``runs`` passes of the CPU time of one pass, divided by the calls."""
    times = []
    for _ in range(runs):
        start = time.process_time()
        for call in calls:
            call()
        times.append(time.process_time() - start)
    return statistics.median(times) / max(1, len(calls))


def measure(problems: list[LinearProgram], runs: int) -> dict[str, Any]:
    """Per-LP CPU time of each path of the module docstring."""
    import daqp

    from frcontrol.solvers import daqp_

    lp_check = backend().lp_check  # as the polytope module hands it to the door
    options = solvers.DoorOptions(check=lp_check)
    door = [lambda p=p: solvers.solve_lp_prepared(p.c, p.A_ub, p.b_ub, p.A_eq, p.b_eq, p.lb, p.ub,
                                                  door=options) for p in problems]
    stacked = [(p.c, *daqp_._stack(p, equalities_as_pairs=True)) for p in problems]
    bare = [lambda s=s: daqp.solve(None, *s) for s in stacked]
    check = [lambda p=p: solvers._check(p, p.c, solvers.FEASIBILITY_TOLERANCE, lp_check) for p in problems]
    lean = list(lean_calls(problems))
    figures = {name: per_lp_seconds(calls, runs) for name, calls in
               (("door", door), ("lean", lean), ("daqp", bare), ("check", check))}
    figures["lps"] = len(problems)
    figures["lean_served"] = sum(1 for p in problems if p.A_eq.shape[0] == 0)
    return figures


def main(argv: list[str] | None = None) -> int:
    """Record (``--record``) or load the corpus, time every path, write the JSON, print a table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--record", action="store_true", help="record the corpus again first")
    parser.add_argument("--contacts", type=int, default=RECORD_CONTACTS,
                        help="the snake's contacts (--record)")
    parser.add_argument("--runs", type=int, default=5, help="passes over the corpus (median)")
    parser.add_argument("--out", type=Path, default=RESULTS, help="the results folder")
    args = parser.parse_args(argv)
    if args.record:
        save_corpus(record(args.contacts), CORPUS)
    problems = load_corpus()
    calibration = statistics.median(_cpu_seconds(calibration_workload) for _ in range(9))
    figures = measure(problems, args.runs)
    for name in ("door", "lean", "daqp", "check"):
        print(f"{name:6s} {1e6 * figures[name]:7.2f} us per LP ({figures[name] / calibration:.5f} of the "
              f"calibration)")
    print(f"{figures['lps']} LPs, {figures['lean_served']} on the lean path; door/lean "
          f"{figures['door'] / figures['lean']:.2f}")
    command = "python -m benchmarks.lp_door " + " ".join(argv or sys.argv[1:])
    payload = {"benchmark": "lp_door", "command": command.strip(),
               "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "versions": versions(),
               "calibration_s": calibration, "runs": args.runs,
               "per_lp_s": figures, "ratio_to_calibration": {
                   k: v / calibration for k, v in figures.items() if k in ("door", "lean", "daqp", "check")}}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "lp_door.json").write_text(json.dumps(payload, indent=1) + "\n")
    return 0


def _cpu_seconds(call: Callable[[], Any]) -> float:
    start = time.process_time()
    call()
    return time.process_time() - start


if __name__ == "__main__":
    sys.exit(main())
