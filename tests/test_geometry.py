"""frcontrol.geometry: the one home of row norms, the max-margin LP, vertices, hulls and polygons.

Oracles nobody here wrote: NumPy's norm, Qhull (scipy.spatial) for hulls and half-space
intersections, and the polytope module's Chebyshev ball for the max-margin LP.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.spatial

from frcontrol import geometry
from frcontrol.errors import InputError
from frcontrol.polytope import Polytope, chebyshev_ball
from frcontrol.solvers import DEFAULT_SETTINGS, RETRY_ERRORS, SolverSettings


def test_unit_rows_have_unit_norm_and_zero_rows_stay():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(7, 3)) * 10.0 ** rng.uniform(-6, 6, size=(7, 1))
    A[2] = 0.0
    b = rng.normal(size=7)
    unit, offsets = geometry.unit_rows(A, b)
    norms = np.linalg.norm(unit, axis=1)
    assert np.allclose(np.delete(norms, 2), 1.0, rtol=0, atol=1e-15)
    assert np.array_equal(unit[2], np.zeros(3)) and offsets[2] == b[2]
    assert np.allclose(np.delete(offsets * np.linalg.norm(A, axis=1), 2), np.delete(b, 2), rtol=1e-14, atol=0)


def test_constant_rows_are_the_rows_below_the_tolerance_of_the_largest():
    H = np.array([[3.0, 4.0], [1e-12, 0.0], [0.0, 0.0], [1e-3, 0.0]])
    norms, constant = geometry.constant_rows(H, 1e-9)
    assert np.array_equal(norms, np.linalg.norm(H, axis=1))
    assert constant.tolist() == [False, True, True, False]


@pytest.mark.parametrize("solver", ["daqp", "highs"])
def test_the_max_margin_lp_on_unit_rows_is_the_chebyshev_ball(solver):
    """Random bounded polytopes around the origin: the radius of max_margin(chebyshev_rows) is the
    Chebyshev ball's, and its centre is a point of the set that far from every facet."""
    rng = np.random.default_rng(7)
    settings = SolverSettings(lp=solver)
    for _ in range(20):
        d = int(rng.integers(2, 5))
        A = rng.normal(size=(3 * d + 2, d))
        b = rng.uniform(0.05, 2.0, size=A.shape[0])
        unit, offsets = geometry.unit_rows(A, b)
        result = geometry.max_margin(geometry.chebyshev_rows(unit), offsets, settings=settings,
                                     fallback=RETRY_ERRORS)
        ball = chebyshev_ball(Polytope(A, b), settings=settings)
        assert result.found and ball.found and result.solver == solver
        radius, centre = result.x[-1], result.x[:-1]
        assert radius == pytest.approx(ball.radius, abs=1e-7)
        assert np.all(unit @ centre + radius <= offsets + 1e-7)


def test_the_max_margin_lp_keeps_its_equalities_and_its_cap():
    """The segment x + y = 1, 0 <= x, y inside the plane: the margin of x >= 0, y >= 0 is at most
    1/2 (at x = y = 1/2); a set without rows reports the cap."""
    rows = np.array([[-1.0, 0.0, 1.0], [0.0, -1.0, 1.0]])
    result = geometry.max_margin(rows, np.zeros(2), A_eq=np.array([[1.0, 1.0]]), b_eq=np.array([1.0]),
                                 settings=DEFAULT_SETTINGS, fallback=RETRY_ERRORS)
    assert result.found and result.x == pytest.approx([0.5, 0.5, 0.5], abs=1e-9)
    free = geometry.max_margin(np.zeros((0, 3)), np.zeros(0), settings=DEFAULT_SETTINGS,
                               fallback=RETRY_ERRORS, cap=0.25)
    assert free.found and free.x[-1] == pytest.approx(0.25, abs=1e-12)


def test_hull_from_points_has_qhulls_vertices_counter_clockwise():
    rng = np.random.default_rng(11)
    for n in (3, 4, 8, 30):
        points = rng.normal(size=(n, 2))
        hull = geometry.hull_from_points(points)
        expected = points[scipy.spatial.ConvexHull(points).vertices]
        assert sorted(map(tuple, np.round(hull, 12))) == sorted(map(tuple, np.round(expected, 12)))
        edges = np.roll(hull, -1, axis=0) - hull
        following = np.roll(edges, -1, axis=0)
        turns = edges[:, 0] * following[:, 1] - edges[:, 1] * following[:, 0]
        assert np.all(turns > 0)


def test_vertices_from_halfspaces_are_qhulls_halfspace_intersection():
    rng = np.random.default_rng(13)
    for d in (2, 3):
        for _ in range(5):
            A = rng.normal(size=(4 * d, d))
            b = rng.uniform(0.5, 1.5, size=A.shape[0])
            found = geometry.vertices_from_halfspaces(A, b)
            qhull = scipy.spatial.HalfspaceIntersection(np.hstack([A, -b[:, None]]), np.zeros(d))
            expected = np.unique(np.round(qhull.intersections, 9), axis=0)
            assert sorted(map(tuple, np.round(found, 9))) == sorted(map(tuple, expected))


def test_polygon_rows_describe_the_polygon_they_come_from():
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
    A, b, A_eq, b_eq = geometry.polygon_rows(square)
    assert A_eq.shape == (0, 2) and np.allclose(np.linalg.norm(A, axis=1), 1.0)
    corners = geometry.vertices_from_halfspaces(A, b)
    assert sorted(map(tuple, np.round(corners, 12))) == sorted(map(tuple, square))
    assert np.all(A @ square.mean(axis=0) < b)  # outward normals: the centre is inside
    A, b, A_eq, b_eq = geometry.polygon_rows(square[:2])  # a segment: along it, and across it
    assert np.allclose(A @ [1.0, 0.0], [1.0, -1.0]) and np.allclose(A @ [1.0, 0.0] - b, [-1.0, -1.0])
    assert np.allclose(A_eq @ [1.0, 0.0], b_eq)
    A, b, A_eq, b_eq = geometry.polygon_rows(square[2:3])  # a point: two equalities
    assert A.shape == (0, 2) and np.array_equal(A_eq, np.eye(2)) and np.array_equal(b_eq, [2.0, 1.0])


def test_hull_facets_of_a_cube_are_its_six_faces():
    cube = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-2.0, 2.0) for z in (-3.0, 3.0)])
    normals, offsets = geometry.hull_facets(cube)
    faces = {tuple(np.round(n, 12)): round(float(o), 12) for n, o in zip(normals, offsets, strict=True)}
    assert faces == {(1.0, 0.0, 0.0): 1.0, (-1.0, 0.0, 0.0): 1.0, (0.0, 1.0, 0.0): 2.0,
                     (0.0, -1.0, 0.0): 2.0, (0.0, 0.0, 1.0): 3.0, (0.0, 0.0, -1.0): 3.0}


def test_hull_facets_of_a_flat_set_is_an_input_error():
    with pytest.raises(InputError, match="not full-dimensional"):
        geometry.hull_facets(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]))
