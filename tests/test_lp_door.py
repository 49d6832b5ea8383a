"""The LP door's lean path (:class:`frcontrol.solvers.InequalityLPs`) answers as the general door.

On the recorded corpus of the LPs a forced analysis solves (``benchmarks/data/lp_corpus.npz``, the
snake on the ground with 6 contacts: optimal and infeasible LPs) and on unbounded and crossed-bound
LPs added here, under both kernels of the residual check and with and without a fallback policy:
field for field the same result (the time aside). A wrong answer from the back-end is still caught
by the residual check, and a replaced adapter is honoured.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import frcontrol.polytope  # noqa: F401  (it registers the kernel's lp_check)
import frcontrol.solvers as door
from frcontrol.errors import SolverNotFound
from frcontrol.kernel import COMPILED, NUMPY, compiled
from frcontrol.solvers import (
    NO_FALLBACK,
    InequalityLPs,
    LinearProgram,
    LPResult,
    RawSolution,
    lp_problem,
    must_solve,
)

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:  # the benchmarks beside the package; the checkout LAST (see test_peers)
    sys.path.append(str(REPO))
from benchmarks.lp_door import CORPUS, load_corpus  # noqa: E402

KERNELS = ["numpy"] + (["compiled"] if compiled is not None else [])


def kernel_check(name: str) -> door.ResidualCheck:
    """The residual check of kernel ``name``, as its callers hand it to the door."""
    return {"numpy": NUMPY, "compiled": COMPILED}[name].lp_check
FIELDS = ("found", "status", "objective", "solver", "raw_status", "primal_residual", "residual_tolerance")


@pytest.fixture(scope="module")
def corpus() -> list[LinearProgram]:
    """The recorded LPs without equalities (the lean path's), and unbounded and crossed-bound ones."""
    problems = [p for p in load_corpus(CORPUS) if p.A_eq.shape[0] == 0]
    rng = np.random.default_rng(29)
    for n in (2, 3, 5):
        A = rng.standard_normal((n + 2, n))
        A[:, 0] = -np.abs(A[:, 0])  # every row loosens as x0 grows: max x0 is unbounded
        c = np.zeros(n)
        c[0] = -1.0
        problems.append(lp_problem(c, A, np.abs(rng.standard_normal(n + 2)), validate=False))
        lb, ub = np.full(n, -1.0), np.full(n, 1.0)
        lb[-1] = 2.0  # crossed: infeasible before any solve
        problems.append(lp_problem(c, A, np.ones(n + 2), lb=lb, ub=ub, validate=False))
    return problems


def lean_answer(lps: InequalityLPs, p: LinearProgram) -> LPResult:
    """The lean path's answer, with the bounds as its callers pass them (None when none is finite)."""
    bounds = (p.lb, p.ub) if p.has_bounds else (None, None)
    return lps.solve(p.c, p.A_ub, p.b_ub, *bounds)


def first_optimal(corpus: list[LinearProgram]) -> LinearProgram:
    return next(p for p in corpus if door.solve(p).found)


def assert_same(lean: LPResult, general: LPResult, label: str) -> None:
    for name in FIELDS:
        a, b = getattr(lean, name), getattr(general, name)
        assert a == b or (a != a and b != b), f"{label}: {name} {a!r} against {b!r}"
    assert (lean.x is None) == (general.x is None), label
    if lean.x is not None:
        assert np.array_equal(lean.x, general.x), label


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("policy", ["none", "must_solve"])
def test_the_lean_path_gives_the_doors_results_on_the_corpus(corpus, kernel, policy):
    fallback = NO_FALLBACK if policy == "none" else must_solve("a corpus LP", bounded=False)
    lps = InequalityLPs(fallback=fallback, check=kernel_check(kernel))
    statuses = set()
    for index, p in enumerate(corpus):
        general = door.solve(p, fallback=fallback, check=kernel_check(kernel))
        assert_same(lean_answer(lps, p), general, f"LP {index}")
        statuses.add(general.status)
    expected = {"optimal", "infeasible"} | ({"unbounded"} if policy == "none" else set())
    assert expected <= statuses  # the corpus holds every kind of answer


@pytest.mark.parametrize("kernel", KERNELS)
def test_a_wrong_answer_is_caught_by_the_residual_check(corpus, kernel, monkeypatch):
    """A lean adapter that claims optimal at a point outside the set: "error", then HiGHS's answer."""
    adapter, lean = door._LEAN_LP_SOLVERS["daqp"]
    told: list[int] = []

    def liar(c, A_ub, b_ub, lb, ub):  # type: ignore[no-untyped-def]
        status, x, raw = lean(c, A_ub, b_ub, lb, ub)
        if x is not None:
            told.append(1)
            row = int(np.argmax(A_ub @ x - b_ub))  # step out through a tight row, by 1e-3 of the scale
            x = x + 1e-3 * (1.0 + float(np.abs(b_ub).max())) * A_ub[row] / float(A_ub[row] @ A_ub[row])
        return status, x, raw

    monkeypatch.setitem(door._LEAN_LP_SOLVERS, "daqp", (adapter, liar))
    p = first_optimal(corpus)
    rejected = lean_answer(InequalityLPs(check=kernel_check(kernel)), p)
    assert told and rejected.status == "error" and not rejected.found and rejected.x is None
    assert "rejected" in rejected.raw_status and rejected.primal_residual > rejected.residual_tolerance
    second = lean_answer(InequalityLPs(fallback=must_solve("a corpus LP", bounded=True)), p)
    reference = door.solve(p, solver="highs")
    assert second.found and second.solver == "highs" and second.objective == reference.objective


def test_a_replaced_adapter_is_honoured(corpus, monkeypatch):
    """With another adapter registered under the name, the lean path asks it (the general door)."""
    def pessimist(problem, **options):  # type: ignore[no-untyped-def]
        return RawSolution("unbounded", None, "exitflag=-3 (as DAQP 0.11 once said)")

    p = first_optimal(corpus)
    monkeypatch.setitem(door._LP_SOLVERS, "daqp", pessimist)
    assert lean_answer(InequalityLPs(), p).status == "unbounded"
    retried = lean_answer(InequalityLPs(fallback=must_solve("a corpus LP", bounded=True)), p)
    assert retried.solver == "highs" and retried.found


def test_options_and_other_back_ends_take_the_general_door(corpus):
    p = first_optimal(corpus)
    for lps, general in ((InequalityLPs(solver="highs"), door.solve(p, solver="highs")),
                         (InequalityLPs(primal_tol=1e-7), door.solve(p, primal_tol=1e-7))):
        assert_same(lean_answer(lps, p), general, "general door")


def test_an_unknown_back_end_is_refused_when_the_lps_are_made():
    with pytest.raises(SolverNotFound, match="nosuch"):
        InequalityLPs(solver="nosuch")


def test_the_benchmarks_record_catches_the_lean_paths_lps(tmp_path):
    """``python -m benchmarks.lp_door --record``'s recording: the forced analysis's LPs take the lean
    path, so a recording of the general door alone found none (and the corpus could not be saved)."""
    from benchmarks.lp_door import record, save_corpus

    recorded = record(3)
    assert recorded and all(p.A_eq.shape[0] == 0 for p in recorded)
    save_corpus(recorded, tmp_path / "corpus.npz")
    again = load_corpus(tmp_path / "corpus.npz")
    assert len(again) == len(recorded)
    for a, b in zip(again, recorded, strict=True):
        assert np.array_equal(a.A_ub, b.A_ub) and np.array_equal(a.lb, b.lb)
