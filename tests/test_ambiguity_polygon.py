"""Two ambiguity variables in closed form (frcontrol/ambiguity_polygon.py): the engine's two LPs' answer.

The rule is held to the LPs it replaces (``_admissible_in_w(..., closed_form=False)``: the motion
LP, then the Chebyshev LP, through the solver door) on random polygons and on the RHex scene's
two-variable mode LSS, at random inputs and around its input domain (the point u = 0): the same verdict
everywhere, the same w where the Chebyshev centre is one point, and where it is not (a capped
radius) a centre of the capped ball too, the optimal vertex nearest to w = 0.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from frcontrol import polytope as poly
from frcontrol.ambiguity_polygon import POLYGON_MAX_ROWS, PolygonRule
from frcontrol.engine import (
    DOMAIN_TOLERANCE,
    ZERO_ROW_TOLERANCE,
    _admissible_in_w,
    analyze,
    polygon_rule,
    query_table,
    solutions_at,
)
from frcontrol.scene import load_scene
from frcontrol.solvers import SolverSettings

AGREEMENT = 1e-8
"""[units of w] The rule's w and the LP's agree to this (relative to max(1, |w|)): the LP back-ends
solve to about 1e-9."""


def lp_rule(H_w: np.ndarray, h: np.ndarray, motion: np.ndarray) -> np.ndarray | None:
    """The engine's two LPs (the reference path's rule)."""
    return _admissible_in_w(H_w, h, motion, SolverSettings(lp="daqp"), closed_form=False)


def chebyshev(H_w: np.ndarray, h: np.ndarray) -> poly.ChebyshevBall:
    """The Chebyshev ball of the relaxed set the rule centres (HiGHS: another solver than the rule's LPs)."""
    return poly.chebyshev_ball(poly.Polytope(H_w, h + DOMAIN_TOLERANCE), solver="highs")


def compare(H_w: np.ndarray, h: np.ndarray, motion: np.ndarray, rule: PolygonRule) -> str:
    """Check the rule against the LPs at one right-hand side; say how they agreed."""
    found, expected = rule.decide(h), lp_rule(H_w, h, motion)
    assert (found is None) == (expected is None), f"verdict: rule {found}, LPs {expected}"
    if found is None:
        return "outside"
    ball = chebyshev(H_w, h)
    if ball.found and ball.capped:  # a face of centres: the rule's w is one of them, as the LP's is
        norms = np.linalg.norm(H_w, axis=1)
        slack = (h + DOMAIN_TOLERANCE) - H_w @ found - norms * poly.CHEBYSHEV_RADIUS_CAP
        assert slack.min() >= -1e-7 * max(1.0, float(np.abs(found).max())), "not a capped centre"
        return "capped"
    scale = max(1.0, float(np.abs(expected).max()))
    assert np.abs(found - expected).max() <= AGREEMENT * scale, f"w: rule {found}, LPs {expected}"
    return "inside"


def random_polygon(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows over (u, w) normalised in (u, w), sliced at u: ``H_w`` (rows, 2), ``h``, ``motion``."""
    rows = int(rng.integers(3, POLYGON_MAX_ROWS + 1))
    H = rng.normal(size=(rows, 4))
    if rng.random() < 0.3:  # a row with no w: judged by its right-hand side
        H[0, 2:] = 0.0
    H /= np.linalg.norm(H, axis=1)[:, None]
    centre = rng.normal(size=2) * rng.choice([0.01, 1.0, 10.0])
    h = H[:, 2:] @ centre + rng.uniform(-0.2, 1.5, rows) * rng.choice([1e-3, 0.1, 3.0])
    motion = rng.random(rows) < 0.3
    return H[:, 2:], h, motion


def test_random_polygons_agree_with_the_lps():
    rng = np.random.default_rng(2026)
    seen = {"outside": 0, "inside": 0, "capped": 0}
    for _ in range(300):
        H_w, h, motion = random_polygon(rng)
        rule = polygon_rule(H_w, motion)
        assert rule is not None, "random rows span the plane"
        seen[compare(H_w, h, motion, rule)] += 1
    assert min(seen.values()) >= 15, seen  # every kind of answer was compared


@cache
def rhex():
    scene = load_scene("rhex_flip")
    analysis = analyze(scene, ambiguity=False)
    table = query_table(analysis)
    i = table.modes.index("LSS")
    return analysis, table, i


def random_inputs(count: int, seed: int) -> np.ndarray:
    """Inputs within the limits, a third of them with some entries zeroed."""
    problem = rhex()[0].problem
    rng = np.random.default_rng(seed)
    U = rng.uniform(problem.lower, problem.upper, (count, problem.m))
    U[: count // 3] *= rng.integers(0, 2, (count // 3, problem.m))
    return U


def near_zero(count: int, seed: int) -> np.ndarray:
    """LSS's input domain is the point u = 0 (its consistency E u = e): inputs at it, and at distances
    within and beyond BOUNDARY_TOLERANCE around it."""
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(count, rhex()[0].problem.m))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    sizes = rng.choice([0.0, 1e-9, 0.5 * DOMAIN_TOLERANCE, 2 * DOMAIN_TOLERANCE, 1e-5], size=count)
    return directions * sizes[:, None]


def test_the_rhex_two_variable_mode_agrees_with_the_lps_on_its_slices():
    """LSS's inequalities sliced at random inputs and at inputs around its domain u = 0. Its two rows
    in w make a wedge: its capped centres have one vertex, the apex, which the LPs report too."""
    _, table, i = rhex()
    rule = table.polygons[i]
    H_u, H_w, h_0, norms, motion = table.many_rows[i]
    seen = {"outside": 0, "inside": 0, "capped": 0}
    for u in np.vstack([random_inputs(150, seed=11), near_zero(50, seed=12)]):
        h = (h_0 - H_u @ u) / norms
        seen[compare(H_w, h, motion, rule)] += 1
        found, expected = rule.decide(h), lp_rule(H_w, h, motion)
        if found is not None:
            assert np.abs(found - expected).max() <= AGREEMENT * max(1.0, float(np.abs(expected).max()))
    assert seen["outside"] >= 5 and seen["capped"] >= 5, seen


def test_the_located_query_gives_the_rule_and_the_reference_the_same_modes():
    """``solutions_at(analysis, u)`` (the rule) and the reference path (the LPs) list the same modes,
    with the same accelerations wherever w does not move them, around LSS's domain u = 0."""
    analysis = rhex()[0]
    held = 0
    for u in near_zero(30, seed=5):
        found, reference = solutions_at(analysis, u), solutions_at(analysis, u, method="reference")
        assert [s.mode for s in found] == [s.mode for s in reference]
        for a, b in zip(found, reference, strict=True):
            if a.ambiguous_outputs != "accelerations":
                np.testing.assert_allclose(a.dv, b.dv, rtol=0, atol=1e-8 * (1.0 + np.abs(b.dv).max()))
        held += "LSS" in [s.mode for s in found]
    assert 5 <= held < 30  # LSS held at some of the points, not at all


BOX = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
"""Rows of unit norm in w: ``h`` bounds w1 and w2 above and below."""


@pytest.mark.parametrize("H_w, h, expected", [
    (BOX[[0, 2]], np.array([3.0, 3.0]), [2.0 + DOMAIN_TOLERANCE] * 2),  # a wedge: its centres' one vertex
    (BOX, np.array([10.0, 0.0, 10.0, 0.0]), [1.0 - DOMAIN_TOLERANCE] * 2),  # a square: nearest of four
    (BOX, np.array([10.0, -4.0, 10.0, -5.0]), [5.0 - DOMAIN_TOLERANCE, 6.0 - DOMAIN_TOLERANCE]),
])
def test_the_rule_reports_the_vertex_nearest_to_zero_on_a_capped_face(H_w, h, expected):
    """Every point at distance >= 1 (the cap) inside is a Chebyshev centre: the rule reports the
    vertex of those nearest to w = 0 (each bound relaxed by the tolerance, then moved in by 1)."""
    w = polygon_rule(H_w, np.zeros(H_w.shape[0], dtype=bool)).decide(h)
    np.testing.assert_allclose(w, expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("h, holds", [
    (np.array([0.0, 0.0, 1.0, 1.0]), False),  # a slab of width 0 between the motion rows: no strict motion
    (np.array([0.5 * DOMAIN_TOLERANCE] * 2 + [1.0, 1.0]), False),  # strict by less than the tolerance
    (np.array([1e-3, 1e-3, 1.0, 1.0]), True),
])
def test_the_motion_must_be_strict_by_more_than_the_tolerance(h, holds):
    """Motion rows (w1 <= h1 and -w1 <= h2, both strict): the rule's verdict is the motion LP's."""
    motion = np.array([True, True, False, False])
    rule = polygon_rule(BOX, motion)
    assert (rule.decide(h) is not None) == holds == (lp_rule(BOX, h, motion) is not None)


@pytest.mark.parametrize("H_w, why", [
    (np.array([[1.0, 0.0], [-1.0, 0.0], [2.0, 0.0]]), "parallel rows: the set holds a line"),
    (np.zeros((3, 2)), "no row in w"),
    (np.ones((POLYGON_MAX_ROWS + 1, 2)) * np.arange(1, POLYGON_MAX_ROWS + 2)[:, None] % 3, "too many rows"),
    (np.ones((4, 3)), "three variables"),
])
def test_the_lps_decide_where_the_rule_does_not_apply(H_w, why):
    assert PolygonRule.build(H_w, np.zeros(H_w.shape[0], dtype=bool), domain_tolerance=DOMAIN_TOLERANCE,
                             zero_row_tolerance=ZERO_ROW_TOLERANCE, radius_cap=1.0) is None, why
