"""Tests of frcontrol.polytope, with HiGHS as the reference wherever DAQP is the default."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from conftest import counted, on, tally
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from frcontrol.errors import InputError
from frcontrol.polytope import (
    CHEBYSHEV_RADIUS_CAP,
    INTERIOR_TOLERANCE,
    REDUNDANCY_TOLERANCE,
    Polytope,
    chebyshev_ball,
    contains,
    interiors_intersect,
    intersect,
    is_empty,
    minimal_representation,
    project,
    set_difference,
    support,
)
from frcontrol.solvers import REFERENCE_LP_SOLVER, solve_lp

REF = REFERENCE_LP_SOLVER
CHECK_TOLERANCE = 1e-7
"""Slack of the brute-force checks [units of x]: looser than the module's tolerances."""


def reference_support(P: Polytope, c: np.ndarray) -> float:
    return support(P, c, solver=REF)


def same_set(P: Polytope, Q: Polytope, tol: float = CHECK_TOLERANCE) -> bool:
    """Each row of one is implied by the other (support function of the other, with HiGHS)."""
    for X, Y in ((P, Q), (Q, P)):
        for a, beta in zip(X.A, X.b, strict=True):
            if reference_support(Y, a) > beta + tol * max(1.0, np.linalg.norm(a)):
                return False
        for a, beta in zip(X.A_eq, X.b_eq, strict=True):
            scale = tol * max(1.0, np.linalg.norm(a))
            if reference_support(Y, a) > beta + scale or -reference_support(Y, -a) < beta - scale:
                return False
    return True


def random_polytope(rng, d, m, *, offset=0.0, extra=""):
    """Rows through a point x0 with positive slack, plus decorations (dup/scaled/weak/far)."""
    A = rng.standard_normal((m, d))
    x0 = rng.uniform(-1, 1, d) * offset
    b = A @ x0 + rng.uniform(0.2, 1.0, m)
    rows, rhs = [A], [b]
    if "dup" in extra:  # duplicated and scaled copies, one looser
        rows += [A[:2], 3.0 * A[2:3], A[3:4]]
        rhs += [b[:2], 3.0 * b[2:3], b[3:4] + 0.5]
    if "far" in extra:  # strictly redundant rows
        far = rng.standard_normal((3, d))
        rows.append(far)
        rhs.append(far @ x0 + 50.0 * np.linalg.norm(far, axis=1))
    P = Polytope(np.vstack(rows), np.concatenate(rhs))
    if "weak" in extra:  # rows through a vertex: weakly redundant
        res = solve_lp(rng.standard_normal(d), P.A, P.b, door=on(REF))
        if res.found:
            vertex = res.x
            weak = rng.standard_normal((2, d))
            # tilt them so that they only touch the polytope at the vertex: use cone combos
            active = np.flatnonzero(np.abs(P.A @ vertex - P.b) < 1e-8)
            weak = rng.uniform(0.1, 1.0, (2, active.size)) @ P.A[active]
            P = Polytope(np.vstack([P.A, weak]), np.concatenate([P.b, weak @ vertex]))
    return P


# closed forms -----------------------------------------------------------------------------------


def test_box():
    box = Polytope.from_box([0.0, 0.0], [0.4, 1.0])
    ball = chebyshev_ball(box)
    assert ball.found and ball.full_dimensional and not ball.capped
    assert ball.radius == pytest.approx(0.2)
    assert ball.center[0] == pytest.approx(0.2) and 0.2 - 1e-9 <= ball.center[1] <= 0.8 + 1e-9
    assert support(box, [1.0, 1.0]) == pytest.approx(1.4)
    assert support(box, [-1.0, 0.0]) == pytest.approx(0.0)
    minimal = minimal_representation(box)
    assert minimal.A.shape == (4, 2) and same_set(minimal, box)
    assert contains(box, [0.4, 1.0]) and not contains(box, [0.41, 0.5])
    assert not is_empty(box)


def test_big_box_radius_is_capped():
    ball = chebyshev_ball(Polytope.from_box([-5.0] * 3, [5.0] * 3))
    assert ball.capped and ball.radius == pytest.approx(CHEBYSHEV_RADIUS_CAP)


@pytest.mark.parametrize("d", [2, 3, 5])
def test_simplex(d):
    A = np.vstack([-np.eye(d), np.ones((1, d))])
    simplex = Polytope(A, np.concatenate([np.zeros(d), [1.0]]))
    ball = chebyshev_ball(simplex)
    radius = 1.0 / (d + np.sqrt(d))  # equidistant from the d facets x_i = 0 and sum x = 1
    assert ball.radius == pytest.approx(radius)
    np.testing.assert_allclose(ball.center, np.full(d, radius), atol=1e-8)
    assert minimal_representation(simplex).A.shape[0] == d + 1
    for i in range(d):
        assert support(simplex, np.eye(d)[i]) == pytest.approx(1.0)


def test_triangle_with_redundant_rows():
    # x >= 0, y >= 0, x + y <= 1; x <= 5 strictly redundant; x + 2y <= 2 touches (0, 1) only
    A = np.array([[-1.0, 0.0], [0.0, -1.0], [1.0, 1.0], [1.0, 0.0], [1.0, 2.0]])
    triangle = Polytope(A, np.array([0.0, 0.0, 1.0, 5.0, 2.0]))
    for use_minrep in (True, False):
        minimal = minimal_representation(triangle, use_minrep=use_minrep)
        assert minimal.A.shape[0] == 3
        assert same_set(minimal, triangle)
        normals = {tuple(np.round(row * np.sqrt(2) if abs(row[0] - row[1]) < 1e-9 else row, 6))
                   for row in minimal.A}
        assert normals == {(-1.0, 0.0), (0.0, -1.0), (1.0, 1.0)}


def test_duplicated_and_scaled_rows_are_merged():
    A = np.array([[1.0, 0.0], [2.0, 0.0], [3.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    P = Polytope(A, np.array([1.0, 2.0, 4.0, 0.0, 1.0, 0.0]))
    minimal = minimal_representation(P)
    assert minimal.A.shape[0] == 4
    assert support(minimal, [1.0, 0.0]) == pytest.approx(1.0)  # the tightest copy was kept
    np.testing.assert_allclose(np.linalg.norm(minimal.A, axis=1), 1.0)


def test_empty_set():
    P = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([0.0, -1.0]))  # x <= 0, x >= 1
    assert is_empty(P) and is_empty(P, solver=REF)
    assert not chebyshev_ball(P).found
    minimal = minimal_representation(P)
    assert minimal.empty and minimal.dim == 2
    assert support(P, [0.0, 1.0]) == -np.inf
    assert project(P, 1).empty
    assert set_difference(P, []) == []
    assert Polytope.empty_set(3).empty and is_empty(Polytope.empty_set(3))


def test_segment_by_two_opposite_inequalities():
    # 0 <= x <= 1, y <= 0, -y <= 0: a segment in the plane
    A = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    segment = Polytope(A, np.array([1.0, 0.0, 0.0, 0.0]))
    ball = chebyshev_ball(segment)
    assert ball.found and ball.radius == pytest.approx(0.0, abs=1e-12)
    assert not ball.full_dimensional and not is_empty(segment)
    minimal = minimal_representation(segment)
    assert minimal.A_eq.shape[0] == 1 and minimal.A.shape[0] == 2
    np.testing.assert_allclose(np.abs(minimal.A_eq[0]), [0.0, 1.0], atol=1e-12)
    ball = chebyshev_ball(minimal)  # within its affine hull, the line y = 0
    assert ball.affine_dimension == 1 and ball.radius == pytest.approx(0.5)
    np.testing.assert_allclose(ball.center, [0.5, 0.0], atol=1e-9)
    assert same_set(minimal, segment)


def test_set_with_an_equality():
    # the triangle x >= 0, x1 + x2 + x3 = 1 in R^3
    S = Polytope(-np.eye(3), np.zeros(3), np.ones((1, 3)), np.array([1.0]))
    ball = chebyshev_ball(S)
    assert ball.affine_dimension == 2 and ball.full_dimensional
    assert ball.radius == pytest.approx(1.0 / np.sqrt(6.0))  # inradius of that triangle
    np.testing.assert_allclose(ball.center, np.full(3, 1.0 / 3.0), atol=1e-8)
    assert support(S, [1.0, 0.0, 0.0]) == pytest.approx(1.0)
    minimal = minimal_representation(S)
    assert minimal.A_eq.shape[0] == 1 and minimal.A.shape[0] == 3 and same_set(minimal, S)
    assert contains(S, [0.2, 0.3, 0.5]) and not contains(S, [0.2, 0.3, 0.6])


def test_dependent_and_inconsistent_equalities():
    A_eq = np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.0], [0.0, 0.0, 1.0]])
    P = Polytope(-np.eye(3), np.zeros(3), A_eq, np.array([1.0, 2.0, 0.5]))
    minimal = minimal_representation(P)
    assert minimal.A_eq.shape[0] == 2 and same_set(minimal, P)
    Q = Polytope(-np.eye(3), np.zeros(3), A_eq, np.array([1.0, 3.0, 0.5]))
    assert is_empty(Q) and minimal_representation(Q).empty


def test_unbounded_set():
    cone = Polytope(np.array([[-1.0, 0.0], [0.0, -1.0]]), np.zeros(2))  # the positive quadrant
    ball = chebyshev_ball(cone)
    assert ball.capped and ball.radius == pytest.approx(CHEBYSHEV_RADIUS_CAP)
    assert contains(cone, ball.center - CHEBYSHEV_RADIUS_CAP + 1e-9)
    assert support(cone, [1.0, 0.0]) == np.inf
    assert support(cone, [-1.0, -1.0]) == pytest.approx(0.0)
    assert minimal_representation(cone).A.shape[0] == 2
    strip = project(Polytope(np.array([[-1.0, 0.0], [1.0, -1.0]]), np.zeros(2)), 1)  # y >= x >= 0
    assert reference_support(strip, [1.0]) == np.inf
    assert reference_support(strip, [-1.0]) == pytest.approx(0.0)


def test_intersections():
    P = Polytope.from_box([0.0, 0.0], [1.0, 1.0])
    touching = Polytope.from_box([1.0, 0.0], [2.0, 1.0])
    overlapping = Polytope.from_box([0.5, 0.5], [2.0, 2.0])
    assert not interiors_intersect(P, touching)
    assert not is_empty(intersect(P, touching))
    assert interiors_intersect(P, overlapping)
    # two segments of the same line: interiors in the common affine hull (the line)
    line = dict(A_eq=np.array([[0.0, 1.0]]), b_eq=np.array([0.0]))
    s1 = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([1.0, 0.0]), **line)
    s2 = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([2.0, -0.5]), **line)
    s3 = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([2.0, -1.0]), **line)
    assert interiors_intersect(s1, s2) and not interiors_intersect(s1, s3)


def test_bad_input():
    with pytest.raises(InputError, match=re.escape("A must have shape (m, d), got (2,)")):
        Polytope(np.array([1.0, 2.0]), np.array([1.0]))
    with pytest.raises(InputError, match="A must be finite"):
        Polytope(np.array([[1.0, np.nan]]), np.array([1.0]))
    with pytest.raises(InputError, match=re.escape("b must have shape (1,), got (2,)")):
        Polytope(np.array([[1.0, 0.0]]), np.array([1.0, 2.0]))
    with pytest.raises(InputError, match=re.escape("A_eq must have shape (m, 2), got (1, 3)")):
        Polytope(np.eye(2), np.ones(2), np.ones((1, 3)), np.ones(1))
    with pytest.raises(InputError, match="A_eq and b_eq must be given together"):
        Polytope(np.eye(2), np.ones(2), np.ones((1, 2)), None)
    box = Polytope.from_box([0.0, 0.0], [1.0, 1.0])
    with pytest.raises(InputError, match="must keep between 0 and 2 coordinates"):
        project(box, 3)
    with pytest.raises(InputError, match="distinct coordinates"):
        project(box, [0, 0])
    with pytest.raises(InputError, match="unknown projection method 'vertex'"):
        project(box, 1, method="vertex")
    with pytest.raises(InputError, match=re.escape("x must have shape (2,), got (1,)")):
        contains(box, [1.0])
    with pytest.raises(InputError, match="polytopes of dimensions 2 and 1"):
        intersect(box, Polytope.from_box([0.0], [1.0]))
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign to field 'A'"):
        box.A = np.eye(2)  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        box.A[0, 0] = 3.0  # read-only arrays


# minimal representation, brute force ------------------------------------------------------------


@pytest.mark.parametrize("extra", ["", "dup", "far", "weak", "dup far weak"])
def test_minimal_representation_brute_force(extra):
    """Each row kept is irredundant and the set is unchanged, checked with HiGHS."""
    rng = np.random.default_rng(sum(map(ord, extra)))
    for trial in range(6):
        d = 2 + trial % 5
        P = random_polytope(rng, d, 3 * d + 4, offset=trial % 2 * 3.0, extra=extra)
        minimal = minimal_representation(P)
        assert same_set(minimal, P)
        for i in range(minimal.A.shape[0]):  # irredundant: dropping row i enlarges the set
            others = np.arange(minimal.A.shape[0]) != i
            without = Polytope(minimal.A[others], minimal.b[others], minimal.A_eq, minimal.b_eq)
            assert reference_support(without, minimal.A[i]) > minimal.b[i] + REDUNDANCY_TOLERANCE
        # every row of P was either kept or is redundant: implied by the result (same_set)
        assert minimal.A.shape[0] == minimal_representation(P, use_minrep=False).A.shape[0]


def test_minimal_representation_with_equalities_brute_force():
    rng = np.random.default_rng(5)
    for trial in range(6):
        d = 3 + trial % 4
        P = random_polytope(rng, d, 3 * d, extra="dup")
        x0 = solve_lp(np.zeros(d), P.A, P.b, door=on(REF)).x
        A_eq = rng.standard_normal((1 + trial % 2, d))
        P = Polytope(P.A, P.b, A_eq, A_eq @ x0)
        minimal = minimal_representation(P)
        assert same_set(minimal, P)
        np.testing.assert_allclose(minimal.A @ minimal.A_eq.T, 0.0, atol=1e-9)
        for i in range(minimal.A.shape[0]):
            others = np.arange(minimal.A.shape[0]) != i
            without = Polytope(minimal.A[others], minimal.b[others], minimal.A_eq, minimal.b_eq)
            assert reference_support(without, minimal.A[i]) > minimal.b[i] + REDUNDANCY_TOLERANCE


# projection -------------------------------------------------------------------------------------


def test_projection_closed_forms():
    cube = Polytope.from_box([-1.0, -2.0, -3.0], [1.0, 2.0, 3.0])
    square = project(cube, [2, 0])
    assert square.A.shape[0] == 4 and same_set(square, Polytope.from_box([-3.0, -1.0], [3.0, 1.0]))
    # the simplex {x >= 0, sum = 1} of R^3 projects onto the triangle {y >= 0, y1 + y2 <= 1}
    S = Polytope(-np.eye(3), np.zeros(3), np.ones((1, 3)), np.array([1.0]))
    triangle = Polytope(np.array([[-1.0, 0.0], [0.0, -1.0], [1.0, 1.0]]), np.array([0, 0, 1.0]))
    assert same_set(project(S, 2), triangle)
    # a segment through 3-D, projected on one axis
    line = Polytope(
        np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]),
        np.array([1.0, 1.0]),
        np.array([[1.0, -1.0, 0.0], [0.0, 1.0, 2.0]]),
        np.array([0.0, 1.0]),
    )
    shadow = project(line, [2])  # x3 = (1 - x1) / 2 for x1 in [-1, 1]
    assert reference_support(shadow, [1.0]) == pytest.approx(1.0)
    assert reference_support(shadow, [-1.0]) == pytest.approx(0.0)


def test_projection_support_functions():
    """h_proj(c) = max over P of c . x[keep], checked with HiGHS in random directions."""
    rng = np.random.default_rng(42)
    cases = [(d, e) for d in (3, 4, 5, 6, 8) for e in (1, 2, 3, 4) if e < d]
    for d, eliminated in cases:
        with_equality = (d + eliminated) % 3 == 0
        P = random_polytope(rng, d, 2 * d + 2, offset=1.0)
        if with_equality:
            x0 = solve_lp(np.zeros(d), P.A, P.b, door=on(REF)).x
            a = rng.standard_normal((1, d))
            P = Polytope(P.A, P.b, a, a @ x0)
        keep = sorted(rng.choice(d, d - eliminated, replace=False).tolist())
        if d % 2:
            keep = keep[::-1]  # any order
        shadow = project(P, keep)
        assert shadow.dim == len(keep)
        for _ in range(8):
            c = rng.standard_normal(len(keep))
            lifted = np.zeros(d)
            lifted[keep] = c
            expected = reference_support(P, lifted)
            got = reference_support(shadow, c)
            assert got == pytest.approx(expected, rel=1e-6, abs=1e-6), (d, keep, c)


def test_support_on_the_lean_path_is_the_doors():
    """support with a lean LP path (support_lps) on a polytope's read-only arrays: the door's answer
    field for field, bounded, unbounded (+inf) and empty (-inf) alike."""
    from frcontrol.polytope import support, support_lps
    from frcontrol.solvers import DEFAULT_SETTINGS

    rng = np.random.default_rng(7)
    lps = support_lps(DEFAULT_SETTINGS)
    half = Polytope(np.array([[1.0, 0.0]]), np.array([1.0]))  # x <= 1: unbounded below and in y
    empty = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([-1.0, -1.0]))
    shapes = [random_polytope(rng, d, 2 * d + 2, offset=1.0) for d in (2, 3, 5, 8)] + [half, empty]
    answers = set()
    for P in shapes:
        assert not P.A.flags.writeable and not P.b.flags.writeable
        for _ in range(6):
            c = rng.standard_normal(P.dim)
            lean, door = support(P, c, lps=lps), support(P, c)
            assert lean == door, (P.dim, c)
            answers.add("inf" if lean == np.inf else "-inf" if lean == -np.inf else "finite")
    assert answers == {"finite", "inf", "-inf"}


def test_projection_of_empty_and_of_a_point():
    point = Polytope(np.zeros((0, 3)), np.zeros(0), np.eye(3), np.array([1.0, 2.0, 3.0]))
    shadow = project(point, [1])
    assert reference_support(shadow, [1.0]) == pytest.approx(2.0)
    assert reference_support(shadow, [-1.0]) == pytest.approx(-2.0)
    assert project(Polytope.empty_set(4), 2).empty


# set difference ---------------------------------------------------------------------------------


def strictly_inside(P: Polytope, x: np.ndarray, margin: float = 1e-7) -> bool:
    norms = np.linalg.norm(P.A, axis=1)
    return bool(np.all(P.A @ x - P.b < -margin * norms))


def check_difference(P, others, pieces, rng, samples=400):
    lo = np.array([-reference_support(P, -e) for e in np.eye(P.dim)])
    hi = np.array([reference_support(P, e) for e in np.eye(P.dim)])
    for x in rng.uniform(lo, hi, (samples, P.dim)):
        if not strictly_inside(P, x):
            continue
        in_others = [contains(Q, x, tolerance=1e-7) for Q in others]
        inside_pieces = [contains(R, x, tolerance=1e-7) for R in pieces]
        if any(strictly_inside(Q, x) for Q in others):
            assert not any(strictly_inside(R, x) for R in pieces)
        elif not any(in_others):
            assert sum(inside_pieces) == 1, x


@pytest.mark.parametrize("seed", range(4))
def test_set_difference_sampled(seed):
    rng = np.random.default_rng(seed)
    d = 2 + seed % 2
    P = Polytope.from_box(-np.ones(d), np.ones(d))
    others = [random_polytope(rng, d, d + 3, offset=0.8) for _ in range(1 + seed % 3)]
    pieces = set_difference(P, others)
    for piece in pieces:
        assert chebyshev_ball(piece, solver=REF).radius > INTERIOR_TOLERANCE
        assert same_set(intersect(piece, P), piece)  # pieces lie in P
    check_difference(P, others, pieces, rng)


def test_set_difference_special_cases():
    P = Polytope.from_box([0.0, 0.0], [1.0, 1.0])
    assert set_difference(P, [Polytope.from_box([-1.0, -1.0], [2.0, 2.0])]) == []
    far = Polytope.from_box([5.0, 5.0], [6.0, 6.0])
    (whole,) = set_difference(P, [far])
    assert same_set(whole, P)
    flat = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([1.0, 0.0]),
                    np.array([[0.0, 1.0]]), np.array([0.5]))  # a segment across P: no volume
    (whole,) = set_difference(P, [flat])
    assert same_set(whole, P)
    # within an affine hull: a segment minus a sub-segment, minus a box
    line = dict(A_eq=np.array([[0.0, 1.0]]), b_eq=np.array([0.0]))
    segment = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([1.0, 0.0]), **line)
    middle = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([0.7, -0.3]), **line)
    ends = sorted((-reference_support(R, [-1.0, 0.0]), reference_support(R, [1.0, 0.0]))
                  for R in set_difference(segment, [middle]))
    np.testing.assert_allclose(ends, [[0.0, 0.3], [0.7, 1.0]], atol=1e-9)
    (rest,) = set_difference(segment, [Polytope.from_box([0.5, -1.0], [2.0, 1.0])])
    assert reference_support(rest, [1.0, 0.0]) == pytest.approx(0.5)
    half = Polytope.from_box([0.5, -1.0], [2.0, 2.0])
    (left,) = set_difference(P, [half])
    assert same_set(left, Polytope.from_box([0.0, 0.0], [0.5, 1.0]))
    ring = set_difference(P, [Polytope.from_box([0.25, 0.25], [0.75, 0.75])])
    assert len(ring) == 4
    area = sum(np.prod([reference_support(R, e) + reference_support(R, -e) for e in np.eye(2)])
               for R in ring if R.A.shape[0] == 4)
    assert area == pytest.approx(0.75)  # the four pieces are boxes here


# properties -------------------------------------------------------------------------------------

polytopes = st.integers(min_value=0, max_value=2**32 - 1).map(
    lambda seed: random_polytope(np.random.default_rng(seed), 2 + seed % 3, 4 + seed % 5,
                                 offset=1.0, extra=("dup", "", "weak")[seed % 3])
)
points = st.lists(st.floats(-3.0, 3.0), min_size=4, max_size=4)


@counted
@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(P=polytopes, coords=points)
def test_minimal_representation_keeps_membership(P, coords):
    tally().example()
    x = np.array(coords[: P.dim])
    minimal = minimal_representation(P)
    if strictly_inside(P, x, margin=1e-6):
        tally().check()
        assert contains(minimal, x)
    slack = (P.A @ x - P.b) / np.linalg.norm(P.A, axis=1)
    if np.max(slack) > 1e-6:
        tally().check()
        assert not contains(minimal, x)


@counted
@settings(max_examples=30, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(P=polytopes, coords=points, keep_first=st.booleans())
def test_projection_agrees_with_lp_feasibility(P, coords, keep_first):
    tally().example()
    d = P.dim
    keep = [0] if keep_first else list(range(1, d))
    shadow = project(P, keep)
    x = np.array(coords[:d])
    if contains(P, x):  # a point of P projects into the shadow
        assert contains(shadow, x[keep], tolerance=1e-7)
    y = x[keep]
    if strictly_inside(shadow, y, margin=1e-6):  # a point of the shadow lifts into P
        tally().check()
        lift = solve_lp(np.zeros(d), P.A, P.b, np.eye(d)[keep], y, door=on(REF))
        assert lift.found
    elif not contains(shadow, y, tolerance=1e-6):
        tally().check()
        lift = solve_lp(np.zeros(d), P.A, P.b, np.eye(d)[keep], y, door=on(REF))
        assert not lift.found


# facts about daqp.minrep, and the fallbacks ---------------------------------------------------


def test_daqp_minrep_facts():
    """minrep drops strictly redundant rows only, and misjudges empty sets (why it is checked)."""
    daqp = pytest.importorskip("daqp")
    box_plus = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.0, 1.0], [1.0, 0.0]])
    b = np.array([1.0, 1.0, 0.0, 0.0, 2.0, 1.0])  # x + y <= 2 touches (1, 1); x <= 1 twice
    assert list(daqp.minrep(box_plus, b)) == [0, 0, 0, 0, 0, 0]  # weakly redundant rows kept
    assert minimal_representation(Polytope(box_plus, b)).A.shape[0] == 4
    empty = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]])
    assert list(daqp.minrep(empty, np.array([0.0, -1.0, 1.0]))) == [1, 0, 0]  # "redundant"
    assert minimal_representation(Polytope(empty, np.array([0.0, -1.0, 1.0]))).empty


def test_lower_dimensional_set_without_explicit_equality():
    # x3 <= x1, x3 <= -x1, x3 >= 0 force x1 = x3 = 0: a segment along x2 (|x2| <= 1)
    A = np.array([[-1.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0],
                  [0.0, -1.0, 0.0], [0.0, 1.0, 1.0], [-2.0, 0.0, 1.0]])
    P = Polytope(A, np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0]))
    assert not chebyshev_ball(P).full_dimensional and not is_empty(P)
    minimal = minimal_representation(P)  # no interior point: row-by-row LPs
    assert same_set(minimal, P)
    for i in range(minimal.A.shape[0]):
        others = np.arange(minimal.A.shape[0]) != i
        without = Polytope(minimal.A[others], minimal.b[others], minimal.A_eq, minimal.b_eq)
        assert reference_support(without, minimal.A[i]) > minimal.b[i] + REDUNDANCY_TOLERANCE


def test_lp_second_opinion_on_a_false_unbounded(monkeypatch):
    """An 'unbounded' from the default back-end is checked with HiGHS (DAQP 0.11 gave one)."""
    import frcontrol.solvers as door
    from frcontrol.solvers import RawSolution

    def pessimist(problem, **options):  # DAQP's adapter, answering as DAQP 0.11 once did
        return RawSolution("unbounded", None, "exitflag=-3 (unbounded, as DAQP 0.11 once said)")

    monkeypatch.setitem(door._LP_SOLVERS, "daqp", pessimist)
    box = Polytope.from_box([0.0, 0.0], [0.4, 1.0])
    assert support(box, [1.0, 1.0]) == pytest.approx(1.4)
    assert chebyshev_ball(box).radius == pytest.approx(0.2)
    assert minimal_representation(box).A.shape[0] == 4


# ------------------------------------------------------------- vertices and hulls (one home)


@pytest.mark.parametrize("d", [2, 3])
def test_vertices_from_halfspaces_match_qhull_on_random_polytopes(d):
    """Random bounded polytopes (a box and random cuts through a point inside): the vertices
    equal scipy's HalfspaceIntersection's, as sets, and none is missed or spurious."""
    import scipy.spatial

    from frcontrol.polytope import vertices_from_halfspaces

    rng = np.random.default_rng(11 + d)
    for _ in range(20):
        rows = np.vstack([np.eye(d), -np.eye(d), rng.normal(size=(4, d))])
        rhs = np.concatenate([np.ones(2 * d), rng.uniform(0.2, 1.0, 4)])
        ours = vertices_from_halfspaces(rows, rhs)
        qhull = scipy.spatial.HalfspaceIntersection(np.hstack([rows, -rhs[:, None]]), np.zeros(d))
        theirs = np.unique(np.round(qhull.intersections, 9), axis=0)
        assert len(ours) == len(theirs) > d
        for v in theirs:
            assert np.min(np.max(np.abs(ours - v), axis=1)) < 1e-8
        if d == 2:  # counter-clockwise: positive signed area
            x, y = ours[:, 0], ours[:, 1]
            assert np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) > 0


def test_vertices_from_halfspaces_edge_cases():
    from frcontrol.errors import InputError
    from frcontrol.polytope import vertices_from_halfspaces

    empty = vertices_from_halfspaces(np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]),
                                     np.array([-1.0, 0.0, 1.0, 1.0]))  # x <= -1 and x >= 0
    assert empty.shape == (0, 2)
    point = vertices_from_halfspaces(np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]),
                                     np.array([0.0, 0.0, 0.0, 0.0]))
    np.testing.assert_allclose(point, [[0.0, 0.0]], atol=1e-12)
    scaled = vertices_from_halfspaces(1e6 * np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]),
                                      1e6 * np.ones(4))
    assert len(scaled) == 4  # row scaling does not matter
    with pytest.raises(InputError, match="vertex candidates"):
        vertices_from_halfspaces(np.ones((30, 3)), np.ones(30), max_candidates=100)


def test_hull_from_points_against_qhull_and_on_degenerate_sets():
    import scipy.spatial

    from frcontrol.polytope import hull_from_points

    rng = np.random.default_rng(5)
    for _ in range(20):
        points = rng.normal(size=(40, 2)) * rng.uniform(1e-3, 1e3)
        ours = hull_from_points(points)
        theirs = points[scipy.spatial.ConvexHull(points).vertices]
        assert len(ours) == len(theirs)
        for v in theirs:
            assert np.min(np.linalg.norm(ours - v, axis=1)) < 1e-9 * np.max(np.abs(points))
    np.testing.assert_allclose(hull_from_points([[1.0, 2.0]] * 3), [[1.0, 2.0]])
    segment = hull_from_points([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [0.5, 0.5]])
    np.testing.assert_allclose(segment, [[0.0, 0.0], [2.0, 2.0]])
