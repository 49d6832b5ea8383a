r"""Polyhedral geometry on arrays: unit rows, the max-margin (Chebyshev) LP, vertices, hulls, polygons.

The one home of the small geometric steps the engine, the polytope module, statics, the planners
and the figures share:

- :func:`row_norms`, :func:`unit_rows`, :func:`constant_rows`: each row's 2-norm, rows scaled to
  unit norm, the numerically constant rows;
- :func:`max_margin`: the LP :math:`\max t` s.t. :math:`H z + w\,t \le h` (``w`` a weight per row),
  :math:`A_{eq} z = b_{eq}`, :math:`0 \le t \le t_{cap}`, through the door
  (:mod:`frcontrol.solvers`) with the caller's fallback policy. With unit rows and ``w = 1`` it
  is the Chebyshev LP (the largest ball; :func:`chebyshev_rows`), with the row norms on the
  motion rows the engine's motion margin;
- :func:`vertices_from_halfspaces`, :func:`clip_polygon`: the vertices of ``{x : A x <= b}``;
- :func:`hull_from_points` (2-D, Andrew's monotone chain), :func:`hull_facets` (any dimension,
  Qhull through ``scipy.spatial.ConvexHull``), :func:`polygon_rows` (a convex polygon's
  H-representation from its vertices).

Speed on the engine's tiny cases (measured here, 2-D points, one call): the monotone chain takes
about 50 us for 4 points where ``scipy.spatial.ConvexHull`` takes about 100 us (the Qhull set-up
dominates), and they are even near 8 points; the planners' disturbance polygons have 4 corners,
so the chain stays. In 3-D (the closure margin's wrench hull) there is no hand-made rival: Qhull.
:func:`vertices_from_halfspaces` tries every choice of ``d`` rows, all at once (stacked
determinants and solves: 50-100 us for 6 to 12 rows in 2-D, 0.6-1 ms for 8 to 12 in 3-D, where one
choice at a time took 0.6-7 ms, with bitwise the same vertices). ``scipy.spatial.HalfspaceIntersection``
takes 20-60 us but needs a point strictly inside (one more LP) and fails on sets without one, which
the choices handle exactly; so the choices stay.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

from frcontrol.errors import InputError
from frcontrol.kernel import backend, extension_function, twin
from frcontrol.solvers import (
    DoorOptions,
    Fallback,
    InequalityLPs,
    LPResult,
    SolverSettings,
    lp_check,
    solve_lp_prepared,
)

__all__ = [
    "CAPPED_FRACTION",
    "CHEBYSHEV_RADIUS_CAP",
    "VERTEX_TOLERANCE",
    "ZERO_TOLERANCE",
    "chebyshev_rows",
    "clip_polygon",
    "constant_rows",
    "hull_facets",
    "hull_from_points",
    "max_margin",
    "polygon_rows",
    "row_norms",
    "unit_rows",
    "vertices_from_halfspaces",
]

ZERO_TOLERANCE = 1e-12
"""A row (or a coefficient of a unit row) is zero when its norm is below ``ZERO_TOLERANCE`` times
the norm of the row it came from [dimensionless]; a choice of unit rows is singular when its
determinant is below it. Default ``1e-12``."""

VERTEX_TOLERANCE = 1e-9
"""A candidate vertex of ``A x <= b`` is kept when every unit row is violated by at most this
[units of x]; vertices closer than this (relative to the set's scale) are one. Default ``1e-9``."""

CHEBYSHEV_RADIUS_CAP = 1.0
"""Upper bound imposed on the Chebyshev radius and on the motion margin [units of ``x``], so that
the max-margin LP is never unbounded (a half-space has no largest ball). A set containing a ball
of radius 1 reports radius 1 (flag ``ChebyshevBall.capped``). Default ``1.0``."""

CAPPED_FRACTION = 1e-12
"""[-] A Chebyshev radius within this fraction of :data:`CHEBYSHEV_RADIUS_CAP` is capped (the set may
hold a larger ball: its centre is one of many)."""


# ---------------------------------------------------------------------------------------------
# rows


def row_norms(X: np.ndarray) -> np.ndarray:
    """Each row's 2-norm: ``np.linalg.norm(X, axis=1)``'s own sum, without its wrapper (bitwise equal)."""
    return np.sqrt(np.add.reduce(X * X, axis=1))


def unit_rows(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``A x <= b`` with every row scaled to unit norm (zero rows kept as they are)."""
    norms = row_norms(A)
    scale = np.where(norms > 0, norms, 1.0)
    return A / scale[:, None], b / scale


def constant_rows(H: np.ndarray, zero_row_tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """Row norms, and the mask of numerically constant rows (norm <= tolerance * max(1, largest))."""
    norms = row_norms(H)
    largest = float(norms.max()) if norms.shape[0] else 0.0
    return norms, norms <= zero_row_tolerance * max(1.0, largest)


# ---------------------------------------------------------------------------------------------
# the max-margin LP


_MARGIN_BOUNDS: dict[tuple[int, float], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
""":func:`margin_bounds` by dimension and cap, built once. The bounds are read-only (the door's lean
path reads a read-only pair once per run of LPs); the cost stays writable, because DAQP's binding
takes writable buffers only (it does not write them)."""


def margin_bounds(d: int, cap: float = CHEBYSHEV_RADIUS_CAP) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The max-margin LP's cost (maximise t) and bounds (z free, ``0 <= t <= cap``) over ``(z, t)``."""
    key = (d, cap)
    if key not in _MARGIN_BOUNDS:
        cost = np.zeros(d + 1)
        cost[-1] = -1.0
        lb = np.full(d + 1, -np.inf)
        ub = np.full(d + 1, np.inf)
        lb[-1], ub[-1] = 0.0, cap
        lb.flags.writeable = ub.flags.writeable = False
        _MARGIN_BOUNDS[key] = (cost, lb, ub)
    return _MARGIN_BOUNDS[key]


def max_margin(rows: np.ndarray, rhs: np.ndarray, *, settings: SolverSettings, fallback: Fallback,
               A_eq: np.ndarray | None = None, b_eq: np.ndarray | None = None,
               cap: float = CHEBYSHEV_RADIUS_CAP, lps: InequalityLPs | None = None) -> LPResult:
    r"""The max-margin LP: :math:`\max t` s.t. ``rows @ (z, t) <= rhs``, :math:`0 \le t \le` ``cap``.

    ``rows`` holds ``[H, w]``: the constraint rows and, last, each row's weight of the margin
    ``t`` (1 on unit rows: the Chebyshev LP, :func:`chebyshev_rows`; a row's norm: the margin is a
    distance; 0: the row is not tightened). Equalities ``A_eq z = b_eq`` go on the door's general
    path; without them the LP takes its lean path (:class:`~frcontrol.solvers.InequalityLPs`, the
    same answer). Arrays built by frcontrol (not re-validated; the residual check runs). ``lps``:
    the lean path made once by a caller solving many such LPs with these ``settings`` and
    ``fallback`` (the engine's motion LPs), instead of one per LP.

    Returns:
        The door's result; ``x[-1]`` is the margin t*.
    """
    d = rows.shape[1] - 1
    cost, lb, ub = margin_bounds(d, cap)
    if A_eq is not None and A_eq.shape[0]:
        A = np.zeros((A_eq.shape[0], d + 1))
        A[:, :d] = A_eq
        return solve_lp_prepared(cost, rows, rhs, A, b_eq, lb, ub,
                                 door=DoorOptions(settings, fallback=fallback, check=backend().lp_check))
    if lps is None:
        lps = InequalityLPs(settings=settings, fallback=fallback, check=backend().lp_check)
    return lps.solve(cost, rows, rhs, lb, ub)


# the LP door's check of an answer (the door does not import the kernel): its callers hand it the backend's
twin("lp_check", numpy=lp_check, compiled=extension_function("lp_check"))


def chebyshev_rows(G: np.ndarray) -> np.ndarray:
    """The rows ``[G, 1]`` of the Chebyshev LP of unit rows ``G`` (:func:`max_margin`)."""
    return np.hstack([G, np.ones((G.shape[0], 1))])


# ---------------------------------------------------------------------------------------------
# vertices and hulls


def vertices_from_halfspaces(A: Any, b: Any, *, tolerance: float = VERTEX_TOLERANCE,
                             max_candidates: int | None = None) -> np.ndarray:
    """The vertices of the bounded polytope ``{x in R^d : A x <= b}``.

    Every choice of d rows whose matrix is regular (``|det| > ZERO_TOLERANCE`` of the unit rows)
    gives a candidate, kept when it satisfies every row up to ``tolerance``; duplicates are merged.
    In 2-D the vertices come counter-clockwise.

    Args:
        A: rows, shape (m, d).
        b: right-hand sides, shape (m,).
        tolerance: see :data:`VERTEX_TOLERANCE`.
        max_candidates: refuse more than this many choices of d rows (None: no limit).

    Returns:
        The vertices, shape (V, d) (V = 0 for an empty set).

    Raises:
        InputError: bad shapes, or more candidates than ``max_candidates``.
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float).reshape(-1)
    if A.ndim != 2 or b.shape != (A.shape[0],):
        raise InputError(f"expected A of shape (m, d) and b of shape (m,), got {A.shape} and {b.shape}")
    count, d = A.shape
    if max_candidates is not None and math.comb(count, d) > max_candidates:
        raise InputError(f"{count} rows in {d} dimensions give {math.comb(count, d)} vertex candidates, "
                         f"more than {max_candidates}")
    norms = row_norms(A)
    keep = norms > 0
    unit_A = np.divide(A, norms[:, None], out=np.zeros_like(A), where=keep[:, None])
    unit_b = np.divide(b, norms, out=np.zeros_like(b), where=keep)
    if np.any(~keep & (b < -tolerance)):
        return np.zeros((0, d))
    found: list[np.ndarray] = []
    for point in _candidate_points(unit_A, unit_b, keep, tolerance):
        scale = max(1.0, float(np.max(np.abs(point))))
        point[np.abs(point) <= ZERO_TOLERANCE * scale] = 0.0  # no 1e-16 noise around zero
        if not any(np.max(np.abs(point - v)) <= tolerance * scale for v in found):
            found.append(point)
    vertices = np.array(found).reshape(-1, d)
    if d == 2 and len(vertices) >= 3:
        centre = vertices.mean(axis=0)
        vertices = vertices[np.argsort(np.arctan2(vertices[:, 1] - centre[1], vertices[:, 0] - centre[0]))]
    return vertices


def _candidate_points(unit_A: np.ndarray, unit_b: np.ndarray, keep: np.ndarray, tolerance: float
                      ) -> np.ndarray:
    """The points where d rows (of the rows ``keep``) meet, regular and feasible, in combination order.

    All choices at once: the determinants and the solves are LAPACK's per matrix of a stack (each
    the one call on one matrix would make), the feasibility test one product.
    """
    d = unit_A.shape[1]
    choices = np.array(list(itertools.combinations(np.flatnonzero(keep), d)), dtype=np.intp).reshape(-1, d)
    matrices = unit_A[choices]
    regular = np.abs(np.linalg.det(matrices)) > ZERO_TOLERANCE
    if not np.any(regular):
        return np.zeros((0, d))
    points = np.linalg.solve(matrices[regular], unit_b[choices[regular]][..., None])[..., 0]
    return points[np.all(points @ unit_A.T <= unit_b + tolerance, axis=1)]


def hull_from_points(points: Any) -> np.ndarray:
    """Convex hull of 2-D points, counter-clockwise, without repeated or collinear vertices.

    Andrew's monotone chain (faster than Qhull on the few points it gets; see the module
    docstring), with points equal to 12 digits merged and turns smaller than ``1e-12 scale^2``
    (scale: the largest coordinate) counted as straight. Degenerate input gives one point, or the
    two ends of a segment.
    """
    unique = np.unique(np.round(np.asarray(points, dtype=float).reshape(-1, 2), 12), axis=0)
    if len(unique) <= 2:
        return unique
    scale = float(np.max(np.abs(unique))) or 1.0
    tol = 1e-12 * scale * scale

    def cross(o: np.ndarray, a: np.ndarray, c: np.ndarray) -> float:
        return float((a[0] - o[0]) * (c[1] - o[1]) - (a[1] - o[1]) * (c[0] - o[0]))

    def chain(sequence: Any) -> list[np.ndarray]:
        out: list[np.ndarray] = []
        for p in sequence:
            while len(out) >= 2 and cross(out[-2], out[-1], p) <= tol:
                out.pop()
            out.append(p)
        return out

    lower, upper = chain(unique), chain(unique[::-1])
    hull = lower[:-1] + upper[:-1]
    if len(hull) < 3:  # collinear: the two ends
        return np.array([unique[0], unique[-1]])
    return np.array(hull)


def hull_facets(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The facets ``normals @ x <= offsets`` of the convex hull of ``points`` (n, d), full-dimensional.

    Qhull (``scipy.spatial.ConvexHull``): unit outward normals, shape (f, d), and offsets (f,), the
    facets' signed distances from the origin.

    Raises:
        InputError: the points span less than ``d`` dimensions (Qhull's error, wrapped).
    """
    import scipy.spatial  # here: its import (some 60 ms) is paid only where a hull is asked for

    try:
        hull = scipy.spatial.ConvexHull(points)
    except scipy.spatial.QhullError as error:
        raise InputError(f"the convex hull of {len(points)} points is not full-dimensional: {error}"
                         ) from error
    return hull.equations[:, :-1], -hull.equations[:, -1]


def polygon_rows(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, b, A_eq, b_eq)`` of the convex polygon of ``vertices`` (k, 2), counter-clockwise, unit rows.

    A point x is in the polygon iff ``A x <= b`` and ``A_eq x = b_eq``: one row per edge (outward
    normals) for ``k >= 3``; a segment (``k = 2``) is two rows along it and one equality across;
    a point (``k = 1``) is two equalities.
    """
    k = len(vertices)
    if k == 1:
        return np.zeros((0, 2)), np.zeros(0), np.eye(2), vertices[0].copy()
    if k == 2:
        a, b = vertices
        direction = (b - a) / np.linalg.norm(b - a)
        normal = np.array([-direction[1], direction[0]])
        A = np.vstack([direction, -direction])
        return A, np.array([direction @ b, -direction @ a]), normal[None, :], np.array([normal @ a])
    rows, rhs = [], []
    for i in range(k):
        p, q = vertices[i], vertices[(i + 1) % k]
        edge = q - p
        normal = np.array([edge[1], -edge[0]]) / np.linalg.norm(edge)  # outward for ccw order
        rows.append(normal)
        rhs.append(normal @ p)
    return np.array(rows), np.array(rhs), np.zeros((0, 2)), np.zeros(0)


def clip_polygon(A: Any, b: Any, box: Any, tolerance: float = VERTEX_TOLERANCE) -> np.ndarray:
    """Vertices of ``{x in R^2 : A x <= b}`` inside a box ``(xmin, xmax, ymin, ymax)``, counter-clockwise.

    The box is clipped by each half-plane in turn (Sutherland-Hodgman on a convex polygon): exact
    up to ``tolerance``, no LP. Rows are normalised first; a zero row ``0 . x <= b_i`` empties the
    set if ``b_i < -tolerance`` and is ignored otherwise. Vertices closer than ``tolerance`` merge.

    Returns:
        The vertices, shape (V, 2): V = 0 for an empty set, 1 or 2 for a point or a segment
        (a set of empty interior), 3 or more for a polygon.

    Raises:
        InputError: wrong shapes, non-finite values, or an empty or inverted box.
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float).reshape(-1)
    if A.ndim != 2 or A.shape[1] != 2 or b.shape != (A.shape[0],):
        raise InputError(f"expected A of shape (m, 2) and b of shape (m,), got {A.shape} and {b.shape}")
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(b))):
        raise InputError("A and b must be finite")
    xmin, xmax, ymin, ymax = (float(v) for v in box)
    if not (xmin < xmax and ymin < ymax) or not all(map(math.isfinite, (xmin, xmax, ymin, ymax))):
        raise InputError(f"box must be (xmin, xmax, ymin, ymax) with min < max, got {tuple(box)}")
    polygon = [np.array(v) for v in ((xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax))]
    norms = row_norms(A)
    for row, rhs, norm in zip(A, b, norms, strict=True):
        if norm <= tolerance:
            if rhs < -tolerance:
                return np.zeros((0, 2))
            continue
        a, c = row / norm, rhs / norm
        clipped: list[np.ndarray] = []
        for i, current in enumerate(polygon):
            previous = polygon[i - 1]
            s_cur, s_prev = float(a @ current) - c, float(a @ previous) - c
            cur_in, prev_in = s_cur <= tolerance, s_prev <= tolerance
            if cur_in != prev_in:
                clipped.append(previous + (s_prev / (s_prev - s_cur)) * (current - previous))
            if cur_in:
                clipped.append(current)
        polygon = _merge_close(clipped, tolerance)
        if not polygon:
            return np.zeros((0, 2))
    return np.array(polygon).reshape(-1, 2)


def _merge_close(vertices: list[np.ndarray], tolerance: float) -> list[np.ndarray]:
    """Drop vertices within ``tolerance`` of the previous one kept (cyclically)."""
    kept: list[np.ndarray] = []
    for v in vertices:
        if not kept or np.linalg.norm(v - kept[-1]) > tolerance:
            kept.append(v)
    while len(kept) > 1 and np.linalg.norm(kept[0] - kept[-1]) <= tolerance:
        kept.pop()
    return kept
