"""Projection by extreme rays (``project(..., method="extreme_rays")``, the default).

Each Fourier-Motzkin step keeps only the rows that are extreme rays of the projection cone
``{lambda >= 0 : lambda A_eliminated = 0}`` (Chernikov's rule and the combinatorial adjacency test,
no LP) and the rows are pruned by LP once. Held here to:

- the definition: after the whole elimination, the supports of the rows kept are exactly the
  extreme rays' supports found by brute force (every subset S of starting rows whose eliminated
  columns have a one-dimensional left null space spanned by a positive vector), on random systems
  in general position and on degenerate ones (entries in {-1, 0, 1}), and every row is that ray's
  combination of the starting rows;
- the former rule (LP pruning after every step): the same set in the same minimal form, on random,
  degenerate, flat (equalities) and unbounded polyhedra, and with the row cap forcing LP prunings
  in between;
- support functions (HiGHS) on a polytope with nine coordinates to eliminate, where the former rule's
  intermediate systems grow past any memory on the 12-contact snake.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from conftest import on
from test_projection_paths import assert_same_minimal_form

from frcontrol import polytope as poly
from frcontrol.geometry import row_norms
from frcontrol.solvers import REFERENCE_LP_SOLVER, InequalityLPs, SolverSettings, solve_lp

DATA = Path(__file__).resolve().parent / "data"

NULL_TOLERANCE = 1e-9
"""[-] A singular value below this times the largest is zero in the brute-force extreme-ray test."""


def extreme_supports(F: np.ndarray) -> set[frozenset[int]]:
    """Every extreme ray of ``{lambda >= 0 : lambda F = 0}`` by brute force, as its support."""
    rows, columns = F.shape
    found = set()
    for size in range(1, columns + 2):
        for S in itertools.combinations(range(rows), size):
            block = F[list(S)].T  # columns x |S|: its null space holds lambda_S
            if block.shape[0] == 0:
                null = np.eye(size)
            else:
                _, sigma, vt = np.linalg.svd(block)
                rank = int(np.count_nonzero(sigma > NULL_TOLERANCE * max(1.0, sigma.max(initial=0.0))))
                null = vt[rank:]
            if null.shape[0] != 1:
                continue
            ray = null[0] * np.sign(null[0][np.argmax(np.abs(null[0]))])
            if np.all(ray > NULL_TOLERANCE):
                found.add(frozenset(S))
    return found


def cancels(S: frozenset[int], unit: np.ndarray, rhs: np.ndarray, F: np.ndarray, kept: int) -> bool:
    """Whether ray S's row is ``0 <= b``, ``b >= 0`` (every column cancels): dropped, it implies nothing."""
    members = sorted(S)
    weights = np.abs(np.linalg.svd(F[members].T)[2][-1]) if F.shape[1] else np.ones(len(members))
    return bool(np.all(np.abs(weights @ unit[members, :kept]) <= 1e-12) and weights @ rhs[members] >= -1e-12)


def eliminate_with_supports(A: np.ndarray, b: np.ndarray, n_keep: int):  # type: ignore[no-untyped-def]
    """The default method's steps from ``A x <= b`` to ``n_keep`` columns, with the rows' supports."""
    norms = row_norms(A)
    A, b = A / norms[:, None], b / norms
    A[:, n_keep:][np.abs(A[:, n_keep:]) <= poly.ZERO_TOLERANCE] = 0.0  # as _eliminate_by_extreme_rays
    support = np.eye(A.shape[0], dtype=bool)
    steps = 0
    while A.shape[1] > n_keep:
        steps += 1
        A, b, support = poly._extreme_ray_step(A, b, support, n_keep, steps)
    return A, b, support


def system(rng: np.random.Generator, rows: int, kept: int, eliminated: int, degenerate: bool) -> np.ndarray:
    if degenerate:
        return rng.integers(-1, 2, size=(rows, kept + eliminated + 1)).astype(float)
    return rng.normal(size=(rows, kept + eliminated + 1))


@pytest.mark.parametrize("degenerate", [False, True])
@pytest.mark.parametrize("seed", range(6))
def test_the_rows_kept_are_exactly_the_extreme_rays(seed, degenerate):
    rng = np.random.default_rng(seed)
    rows, kept, eliminated = int(rng.integers(6, 11)), 2, int(rng.integers(2, 5))
    M = system(rng, rows, kept, eliminated, degenerate)
    A, b = M[:, :-1], M[:, -1]
    unit = A / row_norms(A)[:, None]
    F = unit[:, kept:]
    F = np.where(np.abs(F) > poly.ZERO_TOLERANCE, F, 0.0)
    out_A, out_b, support = eliminate_with_supports(A, b, kept)
    got = [frozenset(np.flatnonzero(s).tolist()) for s in support]
    assert len(got) == len(set(got)), "a ray came out twice"
    assert set(got) == {S for S in extreme_supports(F) if not cancels(S, unit, b / row_norms(A), F, kept)}
    for S, row, rhs in zip(got, out_A, out_b, strict=True):  # each row is its ray's combination
        members = sorted(S)
        _, _, vt = np.linalg.svd(F[members].T) if F.shape[1] else (None, None, np.eye(len(members)))
        weights = np.abs(vt[-1])
        combined = weights @ np.column_stack([unit[members, :kept], (b / row_norms(A))[members]])
        assert np.all(np.abs(weights @ F[members]) < 1e-9)  # the ray cancels the eliminated columns
        scale = np.linalg.norm(combined[:kept])
        if scale > 1e-9:  # (a row with no kept column left is 0 <= rhs: compared by its sign alone)
            np.testing.assert_allclose(np.append(row, rhs) / np.linalg.norm(row), combined / scale, atol=1e-8)
        else:
            assert np.linalg.norm(row) <= 1e-9 and np.sign(rhs) == np.sign(combined[-1])


def random_polyhedron(rng: np.random.Generator, d: int, rows: int, kind: str) -> poly.Polytope:
    """Rows around the origin; ``kind``: "bounded" (a box added), "degenerate" (integer rows and a
    box), "flat" (and one equality through the origin) or "unbounded" (rows of a cone, shifted)."""
    if kind == "degenerate":
        A = rng.integers(-1, 2, size=(rows, d)).astype(float)
        A = A[np.abs(A).sum(axis=1) > 0]
        b = rng.integers(1, 3, size=A.shape[0]).astype(float)
    else:
        A = rng.normal(size=(rows, d))
        b = rng.uniform(0.5, 2.0, rows)
    if kind == "unbounded":
        A[:, 0] = -np.abs(A[:, 0]) - 0.1  # x_0 can grow without bound
        return poly.Polytope(A, b)
    box_A, box_b = np.vstack([np.eye(d), -np.eye(d)]), np.full(2 * d, 3.0)
    P = poly.Polytope(np.vstack([A, box_A]), np.concatenate([b, box_b]))
    if kind == "flat":
        a = rng.normal(size=(1, d))
        return poly.Polytope(P.A, P.b, a, np.zeros(1))
    return P


@pytest.mark.parametrize("kind", ["bounded", "degenerate", "flat", "unbounded"])
@pytest.mark.parametrize("seed", range(5))
def test_both_methods_give_the_same_minimal_form(seed, kind):
    rng = np.random.default_rng(100 + seed)
    d = int(rng.integers(4, 8))
    P = random_polyhedron(rng, d, int(rng.integers(d + 2, 3 * d)), kind)
    keep = sorted(rng.choice(d, int(rng.integers(1, d - 1)), replace=False).tolist())
    new = poly.project(P, keep)
    old = poly.project(P, keep, method="fourier_motzkin")
    assert new.empty == old.empty
    if not new.empty:
        assert_same_minimal_form(new, old, f"{kind} {seed}")


@pytest.mark.parametrize("cap", [1, 5])
def test_the_row_cap_prunes_by_lp_and_goes_on(monkeypatch, cap):
    """Past EXTREME_RAY_MAX_ROWS rows the system is pruned and the elimination restarts from it."""
    rng = np.random.default_rng(9)
    P = random_polyhedron(rng, 7, 16, "bounded")
    expected = poly.project(P, 3)
    prunings = []
    original = poly._minimal

    def counting(*arguments, **keywords):  # type: ignore[no-untyped-def]
        prunings.append(arguments[0].dim)
        return original(*arguments, **keywords)

    monkeypatch.setattr(poly, "EXTREME_RAY_MAX_ROWS", cap)
    monkeypatch.setattr(poly, "_minimal", counting)
    capped = poly.project(P, 3)
    assert_same_minimal_form(capped, expected, f"cap {cap}")
    assert any(dim > 3 for dim in prunings[1:]), prunings  # a pruning before the end


def test_nine_coordinates_eliminated_agree_with_support_functions():
    """17 coordinates, 9 eliminated, 36 rows (the size of the 12-contact snake's mode that the
    former rule could not finish): the projection's support function is the polytope's (HiGHS)."""
    rng = np.random.default_rng(12)
    d, keep = 17, list(range(8))
    A = rng.normal(size=(20, d))  # the variables eliminated bounded by these rows alone, as a mode's w
    box = np.hstack([np.vstack([np.eye(8), -np.eye(8)]), np.zeros((16, d - 8))])
    P = poly.Polytope(np.vstack([A, box]), np.concatenate([rng.uniform(0.5, 2.0, 20), np.full(16, 3.0)]))
    shadow = poly.project(P, keep)
    assert not shadow.empty and shadow.dim == 8
    for _ in range(12):
        c = rng.normal(size=8)
        lifted = np.concatenate([c, np.zeros(d - 8)])
        expected = -solve_lp(-lifted, P.A, P.b, door=on(REFERENCE_LP_SOLVER)).objective
        got = -solve_lp(-c, shadow.A, shadow.b, door=on(REFERENCE_LP_SOLVER)).objective
        assert got == pytest.approx(expected, rel=1e-7, abs=1e-7)


def test_a_false_infeasible_verdict_is_overturned():
    """A redundancy LP over rows of a non-empty set that DAQP 0.11 called infeasible: the module's
    policy asks HiGHS, whose optimum passes the residual check."""
    data = np.load(DATA / "daqp_false_infeasible.npz")
    c, A, b = data["c"], np.ascontiguousarray(data["A"]), data["b"]
    assert solve_lp(c, A, b, door=on(REFERENCE_LP_SOLVER)).status == "optimal"  # the LP is feasible
    lps = InequalityLPs(settings=SolverSettings(), fallback=poly._REDUNDANCY_LP)
    result = lps.solve(c, A, b)
    assert result.status == "optimal"
    assert np.max(A @ result.x - b) <= 1e-9
    assert result.objective == pytest.approx(solve_lp(c, A, b, door=on(REFERENCE_LP_SOLVER)).objective,
                                             rel=1e-9, abs=1e-9)


def test_a_row_that_cancels_altogether_is_not_a_facet():
    """x2 = 0 and x3 = x0 + 2 x1 hold implicitly (three rows make them): the projection onto (x0, x1)
    is x0 >= -1. A combination cancelling to round-off, normalised, once made a false facet."""
    A = np.array([[1.0, 2.0, 1.0, -1.0], [0.0, 0.0, -2.0, 0.0], [-1.0, -2.0, 0.0, 1.0],
                  [-1.0, 0.0, 0.0, 0.0]])
    P = poly.Polytope(A, np.array([0.0, 0.0, 0.0, 1.0]))
    assert poly.contains(P, [0.0, -1.0, 0.0, -2.0])
    for method in poly.PROJECTION_METHODS:
        shadow = poly.project(P, 2, method=method)
        assert poly.contains(shadow, [0.0, -1.0]) and poly.contains(shadow, [5.0, -40.0]), method
        assert not poly.contains(shadow, [-1.1, 0.0]), method


def test_small_coefficients_do_not_lose_a_facet():
    """Rows with coefficients of 1e-13 to 5e-11: a coefficient taken for zero inside a step once let the
    adjacency test lose a facet (support 0.619 where the set's is 0.564)."""
    data = np.load(DATA / "small_coefficients.npz")
    P = poly.Polytope(data["A"], data["b"])
    c = np.array([0.99310526, -0.11722602])
    expected = -solve_lp(-np.r_[c, np.zeros(P.dim - 2)], P.A, P.b, door=on(REFERENCE_LP_SOLVER)).objective
    for method in poly.PROJECTION_METHODS:
        shadow = poly.project(P, 2, method=method)
        got = -solve_lp(-c, shadow.A, shadow.b, door=on(REFERENCE_LP_SOLVER)).objective
        assert got == pytest.approx(expected, abs=1e-7), method


def test_a_row_the_equalities_eliminated_is_not_a_facet():
    """A slab (two opposite rows) becomes an equality; the rows that were its multiples are left as
    round-off, which scaled to unit norm made a false facet: the projection, a segment, lost its far
    part. The projection's support function is the set's (HiGHS) in random directions."""
    data = np.load(DATA / "implicit_slab.npz")
    P, keep = poly.Polytope(data["A"], data["b"]), data["keep"].tolist()
    rng = np.random.default_rng(70)
    for method in poly.PROJECTION_METHODS:
        shadow = poly.project(P, keep, method=method)
        for c in rng.normal(size=(8, len(keep))):
            lifted = np.zeros(P.dim)
            lifted[keep] = c
            expected = -solve_lp(-lifted, P.A, P.b, door=on(REFERENCE_LP_SOLVER)).objective
            got = -solve_lp(-c, shadow.A, shadow.b, shadow.A_eq, shadow.b_eq,
                            door=on(REFERENCE_LP_SOLVER)).objective
            assert got == pytest.approx(expected, abs=1e-7), method
