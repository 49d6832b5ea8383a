r"""H-polytopes: emptiness, Chebyshev balls, minimal representations, projection, set difference.

A :class:`Polytope` is the set

.. math::

    P = \{x \in \mathbb{R}^d : A x \le b,\ A_{eq} x = b_{eq}\},

bounded or not (the name is kept for brevity: every function here works on polyhedra, and says so
where boundedness matters). Every LP goes through the door (its internal path
:func:`frcontrol.solvers.solve_lp_prepared`, which skips re-validating arrays built here but keeps
the residual check; the Chebyshev LP is :func:`frcontrol.geometry.max_margin`), with the solver
settings a function is given (``settings=``, or ``solver=`` a back-end name), by default DAQP;
an LP on which the chosen back-end fails (``"error"``) or that it calls unbounded is solved again
by a second back-end (HiGHS, or DAQP when HiGHS was chosen), and
:class:`~frcontrol.solvers.SolverFailed` is raised only when neither gives a usable answer. A
redundancy LP's "infeasible" is confirmed by the second back-end too (it runs over rows of a set
already found non-empty).

**Scale.** The tolerances below are absolute *distances* in the units of ``x``: every row is
normalised to unit Euclidean norm (within the affine hull of the equalities) before a tolerance
is applied to it. Problems whose coordinates have wildly different units should be scaled first.

**Empty sets.** An empty set is represented canonically by :meth:`Polytope.empty_set`: the single
row ``0 . x <= -1`` and no equality. :attr:`Polytope.empty` recognises that representation (any
row ``0 . x <= b`` with ``b < 0``); it is a syntactic test, exact on everything this module
returns (:func:`minimal_representation`, :func:`project`, :func:`set_difference` return the
canonical empty set when the set is empty). For an arbitrary polytope use :func:`is_empty`
(one LP).

**Implicit equalities.** An equality written as two opposite inequalities is recognised by
:func:`minimal_representation` and turned into an equality. Equalities implied only by several
rows together are not detected: such a set keeps its inequalities and has Chebyshev radius 0.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
import scipy.linalg

from frcontrol.errors import InputError
from frcontrol.geometry import (
    CAPPED_FRACTION,
    CHEBYSHEV_RADIUS_CAP,
    VERTEX_TOLERANCE,
    ZERO_TOLERANCE,
    chebyshev_rows,
    clip_polygon,
    hull_from_points,
    max_margin,
    row_norms,
    vertices_from_halfspaces,
)
from frcontrol.kernel import Backend, backend, extension_function, twin
from frcontrol.solvers import (
    DoorOptions,
    Fallback,
    InequalityLPs,
    LPResult,
    SolverSettings,
    must_solve,
    settings_from,
    solve_lp_prepared,
)

try:  # daqp.minrep exists in daqp >= 0.5 (checked: 0.11); the module works without it
    from daqp import minrep as _daqp_minrep
except ImportError:  # pragma: no cover - depends on the environment
    _daqp_minrep = None

__all__ = [
    "CHEBYSHEV_RADIUS_CAP",
    "CONTAINMENT_TOLERANCE",
    "DUPLICATE_TOLERANCE",
    "EQUALITY_TOLERANCE",
    "CANCELLATION_TOLERANCE",
    "EXTREME_RAY_MAX_ROWS",
    "EXTREME_RAY_PAIR_CHUNK",
    "INTERIOR_TOLERANCE",
    "PROJECTION_METHODS",
    "RANK_TOLERANCE",
    "RAY_TIE_ABSOLUTE",
    "RAY_TIE_RELATIVE",
    "REDUNDANCY_TOLERANCE",
    "ZERO_TOLERANCE",
    "ChebyshevBall",
    "Polytope",
    "chebyshev_ball",
    "contains",
    "interiors_intersect",
    "intersect",
    "is_empty",
    "VERTEX_TOLERANCE",
    "clip_polygon",
    "hull_from_points",
    "minimal_representation",
    "project",
    "set_difference",
    "support",
    "support_lps",
    "vertices_from_halfspaces",
]

# ---------------------------------------------------------------------------------------------
# tolerances

RANK_TOLERANCE = 1e-10
"""Relative rank threshold: a singular value (or QR/elimination pivot) of a matrix of unit rows
counts as zero when it is below ``RANK_TOLERANCE`` times the largest one. Dimensionless. Default
``1e-10``. Decides which equalities are linearly independent and the affine hull's dimension."""

EQUALITY_TOLERANCE = 1e-9
"""Largest residual of unit-norm equalities ``|a x0 - b|`` at their least-squares solution for
which they are declared consistent [units of ``x``]. Default ``1e-9``."""

DUPLICATE_TOLERANCE = 1e-9
"""Two unit rows ``a, a'`` are duplicates when ``a . a' >= 1 - DUPLICATE_TOLERANCE`` (angle below
about ``sqrt(2e-9) = 4.5e-5`` rad), opposite when ``a . a' <= -1 + DUPLICATE_TOLERANCE``
[dimensionless]. Default ``1e-9``."""

REDUNDANCY_TOLERANCE = 1e-9
"""A unit row ``a x <= b`` is redundant when ``max a x`` over the other rows is at most
``b + REDUNDANCY_TOLERANCE`` [units of ``x``]. Default ``1e-9``. Also the slack within which two
opposite rows ``a x <= b``, ``-a x <= b'`` with ``b + b' <= REDUNDANCY_TOLERANCE`` make an
equality (or, below ``-REDUNDANCY_TOLERANCE``, an empty set)."""

INTERIOR_TOLERANCE = 1e-8
"""A set is full-dimensional (in the affine hull of its equalities) when its Chebyshev radius
exceeds ``INTERIOR_TOLERANCE`` [units of ``x``]. Default ``1e-8``; used by
:func:`interiors_intersect` and :func:`set_difference` to drop pieces of zero volume."""

CONTAINMENT_TOLERANCE = 1e-9
"""Largest violation of a unit-norm row accepted by :func:`contains` and in emptiness tests of
zero rows [units of ``x``]. Default ``1e-9``."""


# ---------------------------------------------------------------------------------------------
# the polytope


def _matrix(name: str, value: Any, columns: int | None) -> np.ndarray:
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise InputError(f"{name} is not an array of numbers: {error}") from error
    if array.ndim != 2 or (columns is not None and array.shape[1] != columns):
        expected = f"(m, {columns})" if columns is not None else "(m, d)"
        raise InputError(f"{name} must have shape {expected}, got {array.shape}")
    if not np.isfinite(array).all():
        raise InputError(f"{name} must be finite (no NaN or inf)")
    return array


def _vector(name: str, value: Any, length: int) -> np.ndarray:
    try:
        array = np.array(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as error:
        raise InputError(f"{name} is not an array of numbers: {error}") from error
    if array.shape != (length,):
        raise InputError(f"{name} must have shape ({length},), got {array.shape}")
    if not np.isfinite(array).all():
        raise InputError(f"{name} must be finite (no NaN or inf)")
    return array


@dataclass(frozen=True, eq=False)
class Polytope:
    r"""The set :math:`\{x \in \mathbb{R}^d : A x \le b,\ A_{eq} x = b_{eq}\}`.

    The arrays are copied, validated (shapes, finite) and made read-only.

    Attributes:
        A: inequality rows, shape ``(m, d)`` (``m`` may be 0).
        b: inequality right-hand side, shape ``(m,)``.
        A_eq: equality rows, shape ``(m_eq, d)``; ``None`` means no equality (0 rows).
        b_eq: equality right-hand side, shape ``(m_eq,)``; ``None`` with ``A_eq``.
    """

    A: np.ndarray
    b: np.ndarray
    A_eq: np.ndarray = None  # type: ignore[assignment]  # replaced by a (0, d) array
    b_eq: np.ndarray = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        A = _matrix("A", self.A, None)
        d = A.shape[1]  # d = 0 is R^0, the one point: the domain of a mode with no input and no w
        b = _vector("b", self.b, A.shape[0])
        if self.A_eq is None and self.b_eq is None:
            A_eq, b_eq = np.zeros((0, d)), np.zeros(0)
        elif self.A_eq is None or self.b_eq is None:
            raise InputError("A_eq and b_eq must be given together")
        else:
            A_eq = _matrix("A_eq", self.A_eq, d)
            b_eq = _vector("b_eq", self.b_eq, A_eq.shape[0])
        for name, array in (("A", A), ("b", b), ("A_eq", A_eq), ("b_eq", b_eq)):
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    @property
    def dim(self) -> int:
        """Dimension ``d`` of the ambient space."""
        return int(self.A.shape[1])

    @property
    def empty(self) -> bool:
        """Whether the representation is syntactically empty (a row ``0 . x <= b < 0``).

        Exact on the results of this module (which return :meth:`empty_set` for empty sets);
        use :func:`is_empty` for an arbitrary representation.
        """
        zero_rows = ~np.any(self.A, axis=1)
        return bool(np.any(self.b[zero_rows] < 0))

    @classmethod
    def empty_set(cls, dim: int) -> Polytope:
        """The canonical empty set of ``R^dim``: the single row ``0 . x <= -1``."""
        return cls(np.zeros((1, dim)), np.array([-1.0]))

    @classmethod
    def from_box(cls, lower: Any, upper: Any) -> Polytope:
        """The box ``lower <= x <= upper`` (rows ``x_i <= upper_i`` then ``-x_i <= -lower_i``)."""
        lower = np.atleast_1d(np.array(lower, dtype=np.float64))
        upper = np.atleast_1d(np.array(upper, dtype=np.float64))
        if lower.shape != upper.shape or lower.ndim != 1:
            raise InputError(f"box bounds of shapes {lower.shape} and {upper.shape}")
        d = lower.shape[0]
        return cls(np.vstack([np.eye(d), -np.eye(d)]), np.concatenate([upper, -lower]))

    def __repr__(self) -> str:
        return (
            f"Polytope(dim={self.dim}, inequalities={self.A.shape[0]}, "
            f"equalities={self.A_eq.shape[0]}{', empty' if self.empty else ''})"
        )


@dataclass(frozen=True, eq=False)
class ChebyshevBall:
    """The largest ball inside a polytope, within the affine hull of its equalities.

    Attributes:
        found: whether the polytope is non-empty (``False``: ``center`` is ``None``).
        center: the centre, shape ``(d,)``, a point of the polytope.
        radius: the radius in ``[0, radius_cap]`` (0 if the hull is a point); ``nan`` if empty.
        full_dimensional: ``radius > tolerance``: the set has an interior in its affine hull.
        affine_dimension: dimension of the affine hull of the equalities (``d`` without any).
        capped: the radius reached ``radius_cap`` (the set may hold a larger ball).
        radius_cap: the cap imposed on the radius (:data:`CHEBYSHEV_RADIUS_CAP`).
        tolerance: the threshold of ``full_dimensional`` (:data:`INTERIOR_TOLERANCE`).
        solver: the back-end that solved the LP (``""`` when none was needed).
    """

    found: bool
    center: np.ndarray | None
    radius: float
    full_dimensional: bool
    affine_dimension: int
    capped: bool
    radius_cap: float
    tolerance: float
    solver: str


# ---------------------------------------------------------------------------------------------
# helpers


_BOUNDED_LP = must_solve("an LP of the polytope module", bounded=True)
r"""The fallback policy of this module's bounded LPs (the Chebyshev LP): the second back-end
(HiGHS, or DAQP when HiGHS was chosen) solves the LP again when the first returns ``"error"`` or
``"unbounded"`` (DAQP 0.11 reported a bounded, very degenerate LP of 951 rows as unbounded); an
``"unbounded"`` answer counts as a failure (:class:`~frcontrol.solvers.SolverFailed`).
``"infeasible"`` is trusted here (HiGHS's are confirmed without presolve by its adapter); the
redundancy LPs confirm it (:data:`_REDUNDANCY_LP`)."""

_REDUNDANCY_LP = Fallback(retry_on=frozenset({"error", "unbounded", "infeasible"}),
                          accept=frozenset({"optimal", "infeasible"}),
                          failure="a redundancy LP of the polytope module")
"""The fallback policy of the redundancy LPs (:func:`_is_redundant`): as :data:`_BOUNDED_LP`, and an
``"infeasible"`` verdict is confirmed by the second back-end too. A redundancy LP runs over rows of a
set the Chebyshev LP found non-empty, so "infeasible" contradicts it: DAQP 0.11 called such an LP of
28 rows in 10 variables infeasible (HiGHS: optimal), and the projection of a mode of the 12-contact
snake with a Chebyshev radius of 1 came out empty. Costs a second LP only where the first said
infeasible; both saying it means the set is numerically empty."""

_LP = must_solve("an LP of the polytope module", bounded=False)
"""The fallback policy of this module's LPs that may be unbounded (:func:`support`): as
:data:`_BOUNDED_LP`, with ``"unbounded"`` an answer."""


@dataclass(frozen=True, eq=False)
class _Hull:
    """The affine hull ``{x0 + N z}`` of consistent equalities (``N`` orthonormal, ``d x k``)."""

    x0: np.ndarray
    N: np.ndarray


def _affine_hull(A_eq: np.ndarray, b_eq: np.ndarray, d: int) -> _Hull | None:
    """Parametrise ``A_eq x = b_eq`` as ``x = x0 + N z`` by an SVD; ``None`` if inconsistent."""
    if A_eq.shape[0] == 0:
        return _Hull(np.zeros(d), np.eye(d))
    norms = row_norms(A_eq)
    zero = norms <= 0.0
    if np.any(np.abs(b_eq[zero]) > EQUALITY_TOLERANCE):
        return None
    A_unit = A_eq[~zero] / norms[~zero, None]
    b_unit = b_eq[~zero] / norms[~zero]
    if A_unit.shape[0] == 0:
        return _Hull(np.zeros(d), np.eye(d))
    U, s, Vt = np.linalg.svd(A_unit)
    rank = int(np.sum(s > RANK_TOLERANCE * s[0]))
    x0 = Vt[:rank].T @ ((U[:, :rank].T @ b_unit) / s[:rank])
    if np.max(np.abs(A_unit @ x0 - b_unit)) > EQUALITY_TOLERANCE:
        return None
    return _Hull(x0, np.ascontiguousarray(Vt[rank:].T))


def _independent_equalities(A_eq: np.ndarray, b_eq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit-norm, linearly independent equality rows (QR with column pivoting on ``A_eq^T``)."""
    norms = row_norms(A_eq)
    nonzero = norms > 0.0
    A_unit = A_eq[nonzero] / norms[nonzero, None]
    b_unit = b_eq[nonzero] / norms[nonzero]
    if A_unit.shape[0] == 0:
        return A_unit, b_unit
    _, R, pivots = scipy.linalg.qr(A_unit.T, mode="economic", pivoting=True, check_finite=False)  # finite
    diagonal = np.abs(np.diag(R))
    rank = int(np.sum(diagonal > RANK_TOLERANCE * diagonal[0]))
    rows = np.sort(pivots[:rank])
    return A_unit[rows], b_unit[rows]


def _r0(empty: bool) -> Polytope:
    """``R^0`` (no row) or its empty set."""
    return Polytope.empty_set(0) if empty else Polytope(np.zeros((0, 0)), np.zeros(0))


def _holds_in_r0(P: Polytope) -> bool:
    """Whether the point of ``R^0`` satisfies ``P``: ``0 <= b`` and ``0 = b_eq``, within tolerance.

    The tolerance is :data:`CONTAINMENT_TOLERANCE`, as for a point of any other dimension.
    """
    tol = CONTAINMENT_TOLERANCE
    return bool(np.all(P.b >= -tol) and np.all(np.abs(P.b_eq) <= tol))


def _check_same_dim(P: Polytope, Q: Polytope) -> None:
    if P.dim != Q.dim:
        raise InputError(f"polytopes of dimensions {P.dim} and {Q.dim}")


# ---------------------------------------------------------------------------------------------
# queries


def chebyshev_ball(P: Polytope, *, solver: str | None = None,
                   settings: SolverSettings | None = None) -> ChebyshevBall:
    r"""Largest ball inside ``P`` within the affine hull of its equalities.

    The equalities are parametrised as :math:`x = x_0 + N z` (SVD; :math:`N` an orthonormal basis
    of the null space of :math:`A_{eq}`, rank threshold :data:`RANK_TOLERANCE`). With
    :math:`g_i = N^\top a_i` and :math:`h_i = b_i - a_i^\top x_0`, the LP is

    .. math::

        \max_{z, r}\ r \quad\text{s.t.}\quad \frac{g_i^\top z + \|g_i\| r}{\|g_i\|}
        \le \frac{h_i}{\|g_i\|},\quad 0 \le r \le r_{cap} = \texttt{CHEBYSHEV\_RADIUS\_CAP}.

    The cap keeps the LP bounded on unbounded sets. Rows with :math:`g_i = 0` (constant on the
    hull) are checked directly: :math:`h_i < -\texttt{CONTAINMENT\_TOLERANCE}\,\|a_i\|` means
    ``P`` is empty. A hull of dimension 0 (a point) gives radius 0.

    Args:
        P: the polytope.
        solver: LP back-end (a name: :func:`~frcontrol.solvers.settings_from`).
        settings: the solver settings (default :data:`~frcontrol.solvers.DEFAULT_SETTINGS`).

    Returns:
        The ball; ``found=False`` if ``P`` is empty.
    """
    d = P.dim
    if d == 0:  # R^0: the point, if every (constant) row holds; it is its own interior
        if _holds_in_r0(P):
            return ChebyshevBall(True, np.zeros(0), CHEBYSHEV_RADIUS_CAP, True, 0, True,
                                 CHEBYSHEV_RADIUS_CAP, INTERIOR_TOLERANCE, "")
        return _no_ball(d)
    hull = _affine_hull(P.A_eq, P.b_eq, d)
    if hull is None:
        return _no_ball(d)
    k = hull.N.shape[1]
    G = P.A @ hull.N
    h = P.b - P.A @ hull.x0
    a_norms = row_norms(P.A)
    g_norms = row_norms(G)
    flat = g_norms <= ZERO_TOLERANCE * a_norms
    if np.any(h[flat] < -CONTAINMENT_TOLERANCE * np.maximum(a_norms[flat], 1e-300)):
        return _no_ball(k)
    G, h, g_norms = G[~flat], h[~flat], g_norms[~flat]
    if k == 0 or G.shape[0] == 0:  # a point, or the whole hull
        radius = 0.0 if k == 0 else CHEBYSHEV_RADIUS_CAP
        return ChebyshevBall(True, hull.x0, radius, radius > INTERIOR_TOLERANCE, k, k > 0,
                             CHEBYSHEV_RADIUS_CAP, INTERIOR_TOLERANCE, "")
    return _ball_in_hull(G / g_norms[:, None], h / g_norms, hull, settings_from(solver, settings))


def _no_ball(dimension: int) -> ChebyshevBall:
    """The answer for an empty set (``dimension``: of the space, or of the equalities' hull)."""
    return ChebyshevBall(False, None, float("nan"), False, dimension, False, CHEBYSHEV_RADIUS_CAP,
                         INTERIOR_TOLERANCE, "")


def _ball_in_hull(G: np.ndarray, h: np.ndarray, hull: _Hull, settings: SolverSettings) -> ChebyshevBall:
    """The Chebyshev LP of :func:`chebyshev_ball` on unit rows ``G z <= h`` in the hull's coordinates."""
    k = G.shape[1]
    result = max_margin(chebyshev_rows(G), h, settings=settings, fallback=_BOUNDED_LP)
    if result.status == "infeasible" or result.x is None:
        return _no_ball(k)
    radius = float(min(max(result.x[-1], 0.0), CHEBYSHEV_RADIUS_CAP))
    return ChebyshevBall(
        found=True,
        center=hull.x0 + hull.N @ result.x[:-1],
        radius=radius,
        full_dimensional=radius > INTERIOR_TOLERANCE,
        affine_dimension=k,
        capped=radius >= CHEBYSHEV_RADIUS_CAP * (1.0 - CAPPED_FRACTION),
        radius_cap=CHEBYSHEV_RADIUS_CAP,
        tolerance=INTERIOR_TOLERANCE,
        solver=result.solver,
    )


def is_empty(P: Polytope, *, solver: str | None = None, settings: SolverSettings | None = None) -> bool:
    """Whether ``P`` is empty (one Chebyshev LP; see :func:`chebyshev_ball`)."""
    return P.empty or not chebyshev_ball(P, solver=solver, settings=settings).found


def support(P: Polytope, direction: Any, *, solver: str | None = None,
            settings: SolverSettings | None = None, lps: InequalityLPs | None = None) -> float:
    r"""Support function :math:`h_P(c) = \max_{x \in P} c^\top x`.

    Args:
        P: the polytope.
        direction: ``c``, shape ``(d,)``.
        solver: LP back-end (a name).
        settings: the solver settings (instead of ``solver``).
        lps: the lean LP path of a caller taking many support functions (:func:`support_lps`),
            used when ``P`` has no equalities; its settings are the ones that count (the same
            answers as ``settings``' door when made from them).

    Returns:
        The maximum; ``+inf`` if ``P`` is unbounded in ``c``, ``-inf`` if ``P`` is empty.
    """
    c = _vector("direction", direction, P.dim)
    if lps is not None and not P.A_eq.shape[0]:
        result = lps.solve(-c, P.A, P.b)
    else:
        A_eq = P.A_eq if P.A_eq.shape[0] else None
        b_eq = P.b_eq if P.A_eq.shape[0] else None
        door = DoorOptions(settings_from(solver, settings), fallback=_LP, check=backend().lp_check)
        result = solve_lp_prepared(-c, P.A, P.b, A_eq, b_eq, door=door)
    if result.status == "infeasible":
        return -np.inf
    if result.status == "unbounded":
        return np.inf
    return -result.objective


def support_lps(settings: SolverSettings) -> InequalityLPs:
    """The lean LP path of many :func:`support` calls with these ``settings``, made once."""
    return InequalityLPs(settings=settings, fallback=_LP, check=backend().lp_check)


def contains(P: Polytope, x: Any, tolerance: float = CONTAINMENT_TOLERANCE) -> bool:
    r"""Whether ``x`` lies in ``P``, up to ``tolerance``.

    Row ``i`` may be violated by ``tolerance`` times its norm:
    :math:`a_i^\top x - b_i \le \text{tol}\,\|a_i\|` and
    :math:`|a_{eq,j}^\top x - b_{eq,j}| \le \text{tol}\,\|a_{eq,j}\|` (a distance in the units of
    ``x`` when the row is not zero).

    Args:
        P: the polytope.
        x: the point, shape ``(d,)``.
        tolerance: slack [units of ``x``]; default :data:`CONTAINMENT_TOLERANCE`.
    """
    point = _vector("x", x, P.dim)
    slack = tolerance * row_norms(P.A)
    if np.any(P.A @ point - P.b > slack):
        return False
    slack_eq = tolerance * row_norms(P.A_eq)
    return bool(np.all(np.abs(P.A_eq @ point - P.b_eq) <= slack_eq))


def intersect(P: Polytope, Q: Polytope) -> Polytope:
    """``P ∩ Q``: the rows of both, stacked (not reduced; see :func:`minimal_representation`)."""
    _check_same_dim(P, Q)
    return Polytope(
        np.vstack([P.A, Q.A]),
        np.concatenate([P.b, Q.b]),
        np.vstack([P.A_eq, Q.A_eq]),
        np.concatenate([P.b_eq, Q.b_eq]),
    )


def interiors_intersect(P: Polytope, Q: Polytope, *, solver: str | None = None,
                        settings: SolverSettings | None = None) -> bool:
    """Whether ``P ∩ Q`` holds a ball of radius > :data:`INTERIOR_TOLERANCE` in its affine hull.

    The hull is the one of both sets' equalities together: two segments of the same line have
    intersecting interiors when they overlap on a length, not when they merely touch.
    """
    return chebyshev_ball(intersect(P, Q), solver=solver, settings=settings).full_dimensional


# ---------------------------------------------------------------------------------------------
# minimal representation


_DUPLICATE_GRID = 1e-6
"""Grid on which unit rows are rounded to find candidate duplicates (then checked exactly)."""


_DENSE_PAIRS_MAX_ROWS = 512
"""Up to this many rows, near pairs are found from all dot products at once (exact; m^2 numbers);
beyond it, by sorting rows rounded to :data:`_DUPLICATE_GRID`."""


GRAM_BLOCK_PRODUCTS = 131072
"""[multiply-adds] :func:`_gram` computes ``X @ X.T`` in blocks of rows of at most about this many
multiply-adds each: below OpenBLAS's threshold for threads (4 x 65536), so each block runs on the
calling thread. On a machine whose cores are busy, threads woken for a product of a few hundred
rows cost milliseconds instead of tens of microseconds."""


def _gram(X: np.ndarray) -> np.ndarray:
    """``X @ X.T``, in blocks of rows small enough for BLAS to stay on the calling thread."""
    rows, columns = X.shape
    block = max(1, GRAM_BLOCK_PRODUCTS // max(1, rows * columns))
    if block >= rows:
        return X @ X.T
    out = np.empty((rows, rows))
    for start in range(0, rows, block):
        np.matmul(X[start:start + block], X.T, out=out[start:start + block])
    return out


def _near_pairs(unit: np.ndarray, threshold: float, sign: float,
                gram: np.ndarray | None = None) -> np.ndarray:
    """Pairs ``(p, q)``, ``p < q``, of unit rows with ``sign * (u_p . u_q) >= threshold``.

    Up to :data:`_DENSE_PAIRS_MAX_ROWS` rows every pair is checked (one matrix product, ``gram``
    ``= unit @ unit.T`` when the caller has it: the duplicates and the opposite pairs share it). Beyond,
    candidates are the rows whose coordinates, rounded to :data:`_DUPLICATE_GRID`, coincide (for
    ``sign = -1``: coincide with the other row negated); each candidate pair is then checked
    exactly. Found by sorting, in O(m log m): two near-duplicates rounded to different grid
    points are missed, which is harmless (the redundancy LPs drop one of them later; an implicit
    equality then stays as two inequalities).
    """
    m = unit.shape[0]
    if m <= _DENSE_PAIRS_MAX_ROWS:
        if gram is None:
            gram = _gram(unit)
        # sign * g >= threshold, exactly (negation is exact), without the product; row-major order
        found = np.argwhere(gram >= threshold if sign > 0 else gram <= -threshold)
        return found[found[:, 0] < found[:, 1]]
    return _near_pairs_sorted(unit, threshold, sign)


def _near_pairs_sorted(unit: np.ndarray, threshold: float, sign: float) -> np.ndarray:
    """:func:`_near_pairs` for many rows, by sorting rounded rows."""
    keys = np.round(unit / _DUPLICATE_GRID).astype(np.int64)
    if sign < 0:
        keys = np.vstack([keys, -keys])  # row p + m stands for -u_p
    _, group = np.unique(keys, axis=0, return_inverse=True)
    group = group.reshape(-1)
    order = np.argsort(group, kind="stable")
    boundaries = np.flatnonzero(np.diff(group[order])) + 1
    m = unit.shape[0]
    pairs = []
    for members in np.split(order, boundaries):
        if members.size < 2:
            continue
        for position, p in enumerate(members):
            for q in members[position + 1 :]:
                i, j = int(p) % m, int(q) % m
                if i != j and sign * float(unit[i] @ unit[j]) >= threshold:
                    pairs.append((min(i, j), max(i, j)))
    return np.unique(np.array(pairs, dtype=int).reshape(-1, 2), axis=0)


def _normalise_and_merge(
    G: np.ndarray, h: np.ndarray, a_norms: np.ndarray, tolerance: float
) -> tuple[np.ndarray | None, list[tuple[int, int]]]:
    """Unit rows, zero rows dropped, duplicates merged; opposite pairs that make equalities.

    Args:
        G: the rows in hull coordinates.
        h: their right-hand sides.
        a_norms: norms of the original rows (the scale of "zero").
        tolerance: redundancy tolerance [units of x].

    Returns:
        ``(kept, pairs)``: indices of the rows kept (``None`` if a row proves the set empty),
        and the pairs ``(i, j)`` of kept opposite rows that make an equality.
    """
    g_norms = row_norms(G)
    zero = g_norms <= ZERO_TOLERANCE * a_norms
    if np.any(h[zero] < -CONTAINMENT_TOLERANCE * np.maximum(a_norms[zero], 1e-300)):
        return None, []
    candidates = np.flatnonzero(~zero)
    if candidates.size == 0:
        return candidates, []
    unit = G[candidates] / g_norms[candidates, None]
    offsets = h[candidates] / g_norms[candidates]
    keep = np.ones(candidates.size, dtype=bool)
    gram = _gram(unit) if unit.shape[0] <= _DENSE_PAIRS_MAX_ROWS else None  # for both searches
    duplicates = _near_pairs(unit, 1.0 - DUPLICATE_TOLERANCE, 1.0, gram)
    if duplicates.shape[0]:
        neighbours: dict[int, list[int]] = {}
        for p, q in duplicates:
            neighbours.setdefault(int(p), []).append(int(q))
            neighbours.setdefault(int(q), []).append(int(p))
        rank = np.empty(candidates.size, dtype=int)
        rank[np.argsort(offsets, kind="stable")] = np.arange(candidates.size)
        for i in sorted(neighbours, key=lambda i: rank[i]):  # tightest first: it wins
            if any(keep[j] and rank[j] < rank[i] for j in neighbours[i]):
                keep[i] = False
    pairs: list[tuple[int, int]] = []
    paired: set[int] = set()
    for p, q in _near_pairs(unit, 1.0 - DUPLICATE_TOLERANCE, -1.0, gram):
        if not (keep[p] and keep[q]) or p in paired or q in paired:
            continue
        gap = offsets[p] + offsets[q]  # width of the slab between the two rows
        if gap < -tolerance:
            return None, []
        if gap <= tolerance:
            pairs.append((int(candidates[p]), int(candidates[q])))
            paired.update((int(p), int(q)))
    return candidates[keep], pairs


class _EmptySet(Exception):
    """Raised inside :func:`minimal_representation` when a redundancy LP is infeasible.

    The Chebyshev LP found the set non-empty, within its tolerance; a redundancy LP (rows of
    unit norm, one of them relaxed) then found it empty: the set is numerically empty.
    """


@dataclass(frozen=True, eq=False)
class _RedundancyLPs:
    """The redundancy LPs of one pruning: the door's lean path and buffers for their rows.

    Attributes:
        lps: the door's lean path, with :data:`_REDUNDANCY_LP`.
        rows: ``(m + 1, d)``: the LP's rows are its leading rows (C-contiguous, as DAQP needs).
        rhs: ``(m + 1,)``: their right-hand sides.
    """

    lps: InequalityLPs
    rows: np.ndarray
    rhs: np.ndarray

    @classmethod
    def for_rows(cls, unit: np.ndarray, settings: SolverSettings) -> _RedundancyLPs:
        """Buffers for LPs over at most every row of ``unit`` plus one."""
        m, d = unit.shape
        lps = InequalityLPs(settings=settings, fallback=_REDUNDANCY_LP, check=backend().lp_check)
        return cls(lps, np.empty((m + 1, d)), np.empty(m + 1))


def _is_redundant(
    unit: np.ndarray, offsets: np.ndarray, i: int, status: np.ndarray, against_all: bool, tolerance: float,
    lps: _RedundancyLPs, kernel: Backend,
) -> tuple[bool, LPResult]:
    r"""Whether row ``i`` is implied by the other rows, by one LP.

    The others: the rows known irredundant (``status == 1``), or with ``against_all`` every row not
    removed (``status != -1``) but row ``i`` (gathered by the kernel's ``redundancy_rows``).
    :math:`\max g_i z` s.t. :math:`g_j z \le h_j` (``j`` among the others) and
    :math:`g_i z \le h_i + 1` (so that the LP is bounded); redundant iff the maximum is at most
    :math:`h_i + \text{tolerance}`.
    """
    k = kernel.redundancy_rows(unit, offsets, status, i, against_all, lps.rows, lps.rhs)
    result = lps.lps.solve(-unit[i], lps.rows[:k + 1], lps.rhs[:k + 1])
    if not result.found:  # only "infeasible" is left: the set is empty after all
        raise _EmptySet
    return bool(-result.objective <= offsets[i] + tolerance), result


def _redundancy_rows_numpy(unit: np.ndarray, offsets: np.ndarray, status: np.ndarray, i: int,
                           against_all: bool, rows: np.ndarray, rhs: np.ndarray) -> int:
    """The redundancy LP of row ``i`` gathered into ``rows`` and ``rhs`` (:func:`_is_redundant`).

    The other rows in order, then row ``i`` with right side ``offsets[i] + 1``; returns their count
    before row ``i``. The NumPy twin of the compiled kernel's ``redundancy_rows``.
    """
    if against_all:
        others = status != -1
        others[i] = False
    else:
        others = status == 1
    k = int(np.count_nonzero(others))
    unit.compress(others, axis=0, out=rows[:k])  # the method: np.compress's own, without its wrapper
    rows[k] = unit[i]
    offsets.compress(others, out=rhs[:k])
    rhs[k] = offsets[i] + 1.0
    return k


RAY_TIE_RELATIVE = 1e-9
"""[-] Clarkson's ray meets two rows at once (a lower-dimensional face, :func:`_irredundant_rows`) when
the second exit along it is within this fraction of the first (plus :data:`RAY_TIE_ABSOLUTE`)."""

RAY_TIE_ABSOLUTE = 1e-15
"""[units of the ray's parameter, 1 from the interior point to the LP's optimum] The absolute part of
the tie between two exits of Clarkson's ray (:data:`RAY_TIE_RELATIVE`)."""


def _ray_exit_numpy(unit: np.ndarray, slack: np.ndarray, status: np.ndarray, x: np.ndarray,
                    center: np.ndarray, tie_relative: float, tie_absolute: float) -> int:
    """The first row the ray from ``center`` through ``x`` crosses, or -1 (see :func:`_irredundant_rows`).

    Over the rows ahead (speed ``unit_j (x - center) > 0``) not removed (``status != -1``): the row
    of the least exit ``slack_j / speed_j``; -1 when it is known irredundant or a second exit ties
    with it (``<= exit (1 + tie_relative) + tie_absolute``). The NumPy twin of the compiled kernel's
    ``ray_exit``.
    """
    m = unit.shape[0]
    speeds = unit @ (x - center)
    exits = np.full(m, np.inf)
    ahead = (speeds > 0) & (status != -1)
    exits[ahead] = slack[ahead] / speeds[ahead]
    j = int(np.argmin(exits)) if m else 0
    second = np.partition(exits, 1)[1] if m > 1 else np.inf
    if m == 0 or status[j] == 1 or second <= exits[j] * (1.0 + tie_relative) + tie_absolute:
        return -1
    return j


twin("redundancy_rows", numpy=_redundancy_rows_numpy, compiled=extension_function("redundancy_rows"))
twin("ray_exit", numpy=_ray_exit_numpy, compiled=extension_function("ray_exit"))


IMPLIED_RESIDUAL = 1e-13
"""[-] A unit row ``g_i`` is a combination ``alpha g_j + beta g_k`` of two others (:func:`_implied_by_pairs`)
when no coefficient of the difference exceeds this: round-off of the Fourier-Motzkin sums, far below
what would move a bound by :data:`REDUNDANCY_TOLERANCE` on the sets met here."""


def _implied_by_pairs(unit: np.ndarray, offsets: np.ndarray, ancestors: np.ndarray,
                      tolerance: float) -> dict[int, list[tuple[int, int]]]:
    r"""Rows implied by two other rows, certified without an LP: ``{i: [(j, k), ...]}``.

    Row :math:`i` is implied by rows :math:`j, k` when :math:`g_i = \alpha g_j + \beta g_k` with
    :math:`\alpha, \beta \ge 0` (to :data:`IMPLIED_RESIDUAL`) and :math:`\alpha h_j + \beta h_k \le
    h_i +` ``tolerance``: then :math:`g_i z \le h_i + \text{tolerance}` wherever rows j and k hold,
    which is the redundancy LP's verdict. The pairs tried are the rows whose ancestors (the rows of an
    earlier system they combine, :class:`_Ancestry`) are among row i's, for the rows i of three
    ancestors or more: Fourier-Motzkin's redundant rows are mostly such sums.
    """
    counts = np.count_nonzero(ancestors, axis=1)
    if unit.shape[0] < 3 or int(counts.max(initial=0)) < 3:  # two starting rows or fewer: no such sums
        return {}
    weights = ancestors.astype(np.float64)
    within = _gram(weights) >= counts[None, :] - 0.5  # [i, j]: row j's ancestors among row i's
    np.fill_diagonal(within, False)
    within[counts < 3] = False
    rows, first, second = _pairs_within(within)
    if rows.size == 0:
        return {}
    gram = _gram(unit)
    g_j, g_k, g_jk = gram[rows, first], gram[rows, second], gram[first, second]
    det = 1.0 - g_jk * g_jk
    np.maximum(det, 1e-300, out=det)
    alpha, beta = (g_j - g_jk * g_k) / det, (g_k - g_jk * g_j) / det
    near = np.flatnonzero((det > 1e-12) & (alpha >= 0.0) & (beta >= 0.0)
                          & (alpha * offsets[first] + beta * offsets[second] <= offsets[rows] + tolerance))
    rows, first, second, alpha, beta = rows[near], first[near], second[near], alpha[near], beta[near]
    residual = np.abs(unit[rows] - alpha[:, None] * unit[first] - beta[:, None] * unit[second]).max(
        axis=1, initial=0.0)
    holds = residual <= IMPLIED_RESIDUAL
    implied: dict[int, list[tuple[int, int]]] = {}
    for i, j, k in zip(rows[holds].tolist(), first[holds].tolist(), second[holds].tolist(), strict=True):
        implied.setdefault(i, []).append((j, k))
    return implied


@lru_cache(maxsize=256)
def _pair_indices(count: int) -> np.ndarray:
    """Every pair ``a < b`` of ``range(count)``: a (2, count (count - 1) / 2) array (shared: read only)."""
    pairs = np.array(np.triu_indices(count, 1))
    pairs.setflags(write=False)
    return pairs


def _pairs_within(within: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The triples ``(i, j, k)``, ``j < k``, with ``within[i, j]`` and ``within[i, k]``, as three arrays."""
    rows, columns = np.nonzero(within)  # by row, then column
    if rows.size < 2:
        return rows[:0], rows[:0], rows[:0]
    starts = np.flatnonzero(np.concatenate([[True], rows[1:] != rows[:-1]]))
    sizes = np.diff(np.append(starts, rows.size))
    parts = [start + _pair_indices(size) for start, size in zip(starts.tolist(), sizes.tolist(), strict=True)
             if size >= 2]
    if not parts:
        return rows[:0], rows[:0], rows[:0]
    first, second = np.concatenate(parts, axis=1)
    return rows[first], columns[first], columns[second]


def _irredundant_rows(
    unit: np.ndarray,
    offsets: np.ndarray,
    center: np.ndarray | None,
    tolerance: float,
    settings: SolverSettings,
    implied: dict[int, list[tuple[int, int]]] | None = None,
) -> np.ndarray:
    r"""Mask of the irredundant rows of :math:`\{z : g_i z \le h_i\}` (unit rows, non-empty).

    With an interior point ``center`` (Clarkson's method): row :math:`i` is tested by an LP over
    the rows *already known* irredundant only (few, so the LPs are small). If it is redundant
    for them, it is redundant. Otherwise the LP optimum :math:`z^*` lies outside the set, and the
    ray from ``center`` to :math:`z^*` leaves the set through a facet: the first row it crosses
    is irredundant (if it is the only one crossed there); it joins the known rows and row
    :math:`i` is tested again. At most (rows + facets) LPs. When the ray meets several rows at
    once (a lower-dimensional face) or without an interior point, row :math:`i` is tested
    against all the rows not yet found redundant (sequential removal: of two weakly redundant
    rows one stays). Each LP depends on the verdicts before it, so they run one by one, on the
    door's lean path with reused buffers (:class:`_RedundancyLPs`). ``implied``: pairs of rows that
    imply a row (:func:`_implied_by_pairs`); a row with such a pair, both not removed, is removed
    without an LP (sequential removal still: each row removed is implied by rows present then).
    """
    m = unit.shape[0]
    status = np.zeros(m, dtype=np.int8)  # 0 unknown, 1 irredundant, -1 redundant
    lps = _RedundancyLPs.for_rows(unit, settings)
    kernel = backend()
    implied = implied or {}

    def by_a_pair(i: int) -> bool:
        return i in implied and any(status[j] != -1 and status[k] != -1 for j, k in implied[i])

    def against_all_others(i: int) -> int:
        if by_a_pair(i):
            return -1
        return -1 if _is_redundant(unit, offsets, i, status, True, tolerance, lps, kernel)[0] else 1

    if center is None:
        for i in range(m):
            status[i] = against_all_others(i)
        return status == 1
    slack = offsets - unit @ center
    status[_facets_hit_along_normals(unit, slack, tolerance)] = 1
    for i in range(m):
        if status[i] == 0 and i in implied and by_a_pair(i):
            status[i] = -1
        while status[i] == 0:
            redundant, result = _is_redundant(unit, offsets, i, status, False, tolerance, lps, kernel)
            if redundant:
                status[i] = -1
                break
            j = kernel.ray_exit(unit, slack, status, result.x, center, RAY_TIE_RELATIVE, RAY_TIE_ABSOLUTE)
            if j < 0:
                status[i] = against_all_others(i)  # the ray meets a lower-dimensional face
            else:
                status[j] = 1
    return status == 1


def _facets_hit_along_normals(unit: np.ndarray, slack: np.ndarray, tolerance: float) -> np.ndarray:
    """Rows certified irredundant without an LP: the first hit by a ray from an interior point.

    From the interior point (``slack > 0`` on every row), the ray along each row's normal leaves
    the set through the row ``j`` it meets first. If the next row is met only a distance ``gap``
    farther along the ray, removing row ``j`` lets the set grow by at least ``gap`` times the
    ray's speed towards row ``j`` in that row's normal direction: more than ``tolerance`` means
    the redundancy LP of :func:`_is_redundant` would find row ``j`` irredundant, so it is marked
    so here. One matrix product tests every normal; Clarkson's loop then spends LPs on the rest.
    """
    if unit.shape[0] < 2:  # one row alone bounds a non-empty set: a facet
        return np.ones(unit.shape[0], dtype=bool)
    speeds = _gram(unit)  # [ray i, row j]: how fast the ray along normal i approaches row j
    with np.errstate(divide="ignore", invalid="ignore"):
        exits = np.where(speeds > 0, slack[None, :] / speeds, np.inf)
    rays = np.arange(unit.shape[0])
    first = np.argmin(exits, axis=1)
    two = np.partition(exits, 1, axis=1)[:, :2]
    growth = (two[:, 1] - two[:, 0]) * speeds[rays, first]
    alone = np.isfinite(two[:, 0]) & (growth > tolerance)
    hit = np.zeros(unit.shape[0], dtype=bool)
    hit[first[alone]] = True
    return hit


def minimal_representation(
    P: Polytope,
    *,
    tolerance: float = REDUNDANCY_TOLERANCE,
    solver: str | None = None,
    settings: SolverSettings | None = None,
    use_minrep: bool = True,
    ball: ChebyshevBall | None = None,
) -> Polytope:
    r"""An irredundant representation of ``P`` (the same set, no redundant row).

    Stages, cheapest first:

    1. Equalities: the linearly independent ones (QR with column pivoting, threshold
       :data:`RANK_TOLERANCE`), unit norm. Inconsistent equalities: the empty set.
    2. Emptiness: one Chebyshev LP (:func:`chebyshev_ball`); empty: :meth:`Polytope.empty_set`.
    3. In the affine hull :math:`x = x_0 + N z` of the equalities: rows :math:`g_i = N^\top a_i`
       normalised to unit norm; zero rows dropped (or, if violated, the set is empty); duplicate
       rows merged, keeping the tightest (:data:`DUPLICATE_TOLERANCE`); two opposite rows
       enclosing a slab of width :math:`\le` ``tolerance`` become one equality (and stage 1 is
       run again with it).
    4. ``daqp.minrep``: drops the strictly redundant rows (the hyperplane :math:`g_i z = h_i`
       misses the set). It keeps weakly redundant rows and misbehaves on empty sets (it calls a
       row of an empty set redundant), so its drops are trusted only after stage 2, and its keeps
       are checked by:
    5. One LP per surviving row: row :math:`i` is redundant iff
       :math:`\max\{g_i z : g_j z \le h_j\ (j \ne i \text{ kept}),\ g_i z \le h_i + 1\}
       \le h_i + \text{tolerance}`; redundant rows are removed as they are found. With the
       Chebyshev centre as interior point, Clarkson's method keeps these LPs small (only the rows
       already known irredundant, see :func:`_irredundant_rows`).

    The inequality rows of the result are expressed in the affine hull: unit norm, orthogonal
    to the equality rows (:math:`a_i' = N g_i / \|g_i\|`). An empty ``P`` gives
    :meth:`Polytope.empty_set`.

    Args:
        P: the polytope.
        tolerance: redundancy slack [units of x]; default :data:`REDUNDANCY_TOLERANCE`.
        solver: LP back-end (a name).
        settings: the solver settings (instead of ``solver``).
        use_minrep: run stage 4 (when ``daqp.minrep`` is installed).
        ball: ``chebyshev_ball(P, settings=settings)`` when the caller has it already (stage 2 then
            reuses it instead of solving the same LP again).

    Returns:
        The irredundant representation.
    """
    return _minimal(P, tolerance, settings_from(solver, settings), use_minrep, ball)[0]


def _minimal(P: Polytope, tolerance: float, settings: SolverSettings, use_minrep: bool = True,
             ball: ChebyshevBall | None = None, ancestors: np.ndarray | None = None
             ) -> tuple[Polytope, np.ndarray | None]:
    """:func:`minimal_representation`, and which rows of ``P`` its inequality rows are (in order).

    The second item is None where the rows were not kept one for one: ``P`` empty or in ``R^0``, or
    opposite rows turned into equalities. ``ancestors``: per row of ``P``, the rows of an earlier
    system it combines (:class:`_Ancestry`), which proposes the pairs of rows that may imply a row
    (:func:`_implied_by_pairs`).
    """
    if P.dim == 0:
        return _r0(not _holds_in_r0(P)), None
    d = P.dim
    if P.empty:
        return Polytope.empty_set(d), None
    A_eq, b_eq = _independent_equalities(P.A_eq, P.b_eq)
    hull = _affine_hull(A_eq, b_eq, d)
    if ball is None:
        ball = chebyshev_ball(P, settings=settings)
    if hull is None or not ball.found:
        return Polytope.empty_set(d), None
    G = P.A @ hull.N
    h = P.b - P.A @ hull.x0
    kept, pairs = _normalise_and_merge(G, h, row_norms(P.A), tolerance)
    if kept is None:
        return Polytope.empty_set(d), None
    if pairs:  # new equalities: start again with them
        return minimal_representation(_slabs_as_equalities(P, A_eq, b_eq, pairs), tolerance=tolerance,
                                      settings=settings, use_minrep=use_minrep), None
    g_norms = row_norms(G[kept])
    unit = np.ascontiguousarray(G[kept] / g_norms[:, None])
    offsets = np.ascontiguousarray(h[kept] / g_norms)
    center = hull.N.T @ (ball.center - hull.x0) if ball.full_dimensional else None
    try:
        survivors = _without_redundant_rows(unit, offsets, center, tolerance, settings, use_minrep,
                                            None if ancestors is None else ancestors[kept])
    except _EmptySet:
        return Polytope.empty_set(d), None
    A_out = unit[survivors] @ hull.N.T
    A_out[np.abs(A_out) < ZERO_TOLERANCE] = 0.0  # round-off of the change of coordinates
    b_out = offsets[survivors] + A_out @ hull.x0
    return Polytope(A_out, b_out, A_eq, b_eq), kept[survivors]


def _without_redundant_rows(unit: np.ndarray, offsets: np.ndarray, center: np.ndarray | None,
                            tolerance: float, settings: SolverSettings, use_minrep: bool,
                            ancestors: np.ndarray | None = None) -> np.ndarray:
    """Stages 4 and 5 of :func:`minimal_representation` on unit rows ``unit z <= offsets``: the rows kept.

    ``daqp.minrep``'s drops (strictly redundant rows), then one LP per surviving row
    (:func:`_irredundant_rows`, from the interior point ``center`` when there is one), except the
    rows two others imply (:func:`_implied_by_pairs`, with the rows' ``ancestors`` when known).

    Raises:
        _EmptySet: an LP found the set empty.
    """
    rows = np.arange(unit.shape[0])
    if use_minrep and _daqp_minrep is not None and unit.shape[0] > 1 and unit.shape[1] > 0:
        rows = np.flatnonzero(np.asarray(_daqp_minrep(unit, offsets)) != 1)
        unit, offsets = unit[rows], offsets[rows]
    if unit.shape[0] > 1:
        implied = None if ancestors is None else _implied_by_pairs(unit, offsets, ancestors[rows], tolerance)
        rows = rows[_irredundant_rows(unit, offsets, center, tolerance, settings, implied)]
    return rows


def _slabs_as_equalities(P: Polytope, A_eq: np.ndarray, b_eq: np.ndarray,
                         pairs: Sequence[tuple[int, int]]) -> Polytope:
    """``P`` with each pair of opposite rows enclosing a thin slab replaced by one equality."""
    first = [i for i, _ in pairs]
    paired = {i for pair in pairs for i in pair}
    rest = [i for i in range(P.A.shape[0]) if i not in paired]
    return Polytope(P.A[rest], P.b[rest], np.vstack([A_eq, P.A[first]]), np.concatenate([b_eq, P.b[first]]))


# ---------------------------------------------------------------------------------------------
# projection


def _keep_indices(keep: int | Sequence[int], d: int) -> list[int]:
    if isinstance(keep, (int, np.integer)):
        if not 0 <= int(keep) <= d:
            raise InputError(f"keep={keep}: must keep between 0 and {d} coordinates")
        return list(range(int(keep)))
    indices = [int(i) for i in keep]
    if len(set(indices)) != len(indices) or not all(0 <= i < d for i in indices):
        raise InputError(f"keep={list(keep)}: distinct coordinates in [0, {d}) expected")
    return indices


def _eliminate_with_equalities(
    A: np.ndarray, b: np.ndarray, A_eq: np.ndarray, b_eq: np.ndarray, n_keep: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    r"""Gaussian elimination of the columns ``n_keep:`` that the equalities can express.

    Pivot: the largest ``|A_eq[r, j]|`` over the equality rows (unit norm) and the eliminated
    columns; once it is below :data:`RANK_TOLERANCE`, the remaining equalities do not involve
    the eliminated columns (their coefficients there are set to 0). Column ``j`` is substituted
    out of every row, :math:`x_j = (b_r - \sum_{k \ne j} a_{rk} x_k) / a_{rj}`, and dropped.

    Returns:
        The reduced ``(A, b, A_eq, b_eq)`` (eliminated columns still last), or ``None`` if the
        equalities reduce to a violated ``0 = b``.
    """
    while A_eq.shape[0]:
        norms = row_norms(A_eq)
        zero = norms <= ZERO_TOLERANCE
        if np.any(np.abs(b_eq[zero]) > EQUALITY_TOLERANCE):
            return None
        A_eq, b_eq = A_eq[~zero] / norms[~zero, None], b_eq[~zero] / norms[~zero]
        if A_eq.shape[0] == 0 or A.shape[1] == n_keep:
            break
        block = np.abs(A_eq[:, n_keep:])
        r, j = np.unravel_index(np.argmax(block), block.shape)
        if block[r, j] <= RANK_TOLERANCE:
            A_eq = A_eq.copy()
            A_eq[:, n_keep:] = 0.0
            break
        c = int(j) + n_keep
        pivot_row, pivot_b = A_eq[r] / A_eq[r, c], b_eq[r] / A_eq[r, c]
        others = np.arange(A_eq.shape[0]) != r
        A, b = A - np.outer(A[:, c], pivot_row), b - A[:, c] * pivot_b
        A_eq, b_eq = A_eq[others], b_eq[others]
        A_eq, b_eq = A_eq - np.outer(A_eq[:, c], pivot_row), b_eq - A_eq[:, c] * pivot_b
        A, A_eq = np.delete(A, c, axis=1), np.delete(A_eq, c, axis=1)
    return A, b, A_eq, b_eq


def _scaled_to_unit(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``A x <= b`` with every non-zero row scaled to unit norm (zero rows as they are)."""
    norms = row_norms(A)
    norms[norms == 0.0] = 1.0
    return A / norms[:, None], b / norms


def _fourier_motzkin_step(
    A: np.ndarray, b: np.ndarray, n_keep: int
) -> tuple[np.ndarray, np.ndarray, int, np.ndarray]:
    r"""Eliminate one of the columns ``n_keep:`` of ``A x <= b``.

    Rows are first scaled to unit norm. The column eliminated is the one giving the fewest new
    rows: the smallest product of its positive and negative counts. Each pair of a row with
    :math:`a_{pj} > 0` and one with :math:`a_{nj} < 0` gives
    :math:`a_p / a_{pj} + a_n / |a_{nj}| \le b_p / a_{pj} + b_n / |a_{nj}|` (the :math:`x_j`
    terms cancel); rows with :math:`a_j = 0` are kept as they are. Coefficients below
    :data:`ZERO_TOLERANCE` count as zero.

    Returns:
        ``(A', b', j, parents)``: the new rows without column ``j``, ``j``, and each new row's rows of
        ``A`` (a (rows, 2) array: a kept row is its own two parents).
    """
    A, b = _scaled_to_unit(A, b)
    coefficients = A[:, n_keep:]
    positive = coefficients > ZERO_TOLERANCE
    negative = coefficients < -ZERO_TOLERANCE
    scores = positive.sum(axis=0) * negative.sum(axis=0)
    j = n_keep + int(np.argmin(scores))
    pos, neg = positive[:, j - n_keep], negative[:, j - n_keep]
    zero = ~(pos | neg)
    scale_p = 1.0 / A[pos, j]
    scale_n = -1.0 / A[neg, j]
    rows_p, rhs_p = A[pos] * scale_p[:, None], b[pos] * scale_p
    rows_n, rhs_n = A[neg] * scale_n[:, None], b[neg] * scale_n
    combined = (rows_p[:, None, :] + rows_n[None, :, :]).reshape(-1, A.shape[1])
    combined_rhs = (rhs_p[:, None] + rhs_n[None, :]).reshape(-1)
    new_A = np.vstack([A[zero], combined])
    kept, p_rows, n_rows = np.flatnonzero(zero), np.flatnonzero(pos), np.flatnonzero(neg)
    parents = np.vstack([np.column_stack([kept, kept]),
                         np.column_stack([np.repeat(p_rows, n_rows.size), np.tile(n_rows, p_rows.size)])])
    return np.delete(new_A, j, axis=1), np.concatenate([b[zero], combined_rhs]), j, parents


EXTREME_RAY_MAX_ROWS = 2048
"""[rows] :func:`project`'s default method runs Fourier-Motzkin steps without LPs while the
system has at most this many rows after a step; past it, the rows are pruned by LP
(:func:`minimal_representation`) and the elimination goes on from the pruned system. Bounds the
memory of a projection whose intermediate systems grow: the pairs a step tests are at most the
square of this (in chunks, :data:`EXTREME_RAY_PAIR_CHUNK`), the rows it makes at most as many."""

PROJECTION_METHODS = ("extreme_rays", "fourier_motzkin")
""":func:`project`'s methods: ``"extreme_rays"`` (the default) keeps, at every Fourier-Motzkin step,
only the rows that are extreme rays of the projection cone and prunes by LP once, at the end;
``"fourier_motzkin"`` prunes by LP after every step (the former rule, kept as the reference)."""


_ROWS_WITHIN_MIN_BLOCK = 64
"""[unions] :func:`_rows_within`'s smallest block: with many current rows a block of one union per
product would cost a Python call per pair."""


def _rows_within(support: np.ndarray, unions: np.ndarray) -> np.ndarray:
    """How many current rows' supports lie within each union of starting rows.

    ``support``: (rows, start) bool; ``unions``: (pairs, start) bool. Matrix products in blocks small
    enough for BLAS to stay on the calling thread (see :func:`_gram`).
    """
    S = support.astype(np.float64)
    sizes = S.sum(axis=1) - 0.5  # a row lies within a union when all of its support is in it
    block = max(_ROWS_WITHIN_MIN_BLOCK, GRAM_BLOCK_PRODUCTS // max(1, S.size))
    counts = np.empty(unions.shape[0], dtype=np.int64)
    for start in range(0, unions.shape[0], block):
        U = unions[start:start + block].astype(np.float64)
        counts[start:start + block] = np.count_nonzero(U @ S.T > sizes, axis=1)
    return counts


EXTREME_RAY_PAIR_CHUNK = 65536
"""[pairs] :func:`_extreme_ray_step` forms and tests the pairs of a step in chunks of about this many,
so that its memory stays bounded (a step of 2,000 rows has up to a million pairs)."""


def _adjacent_pairs(support: np.ndarray, pos: np.ndarray, neg: np.ndarray, steps: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The adjacent pairs ``(p, n)`` of rows ``pos`` x ``neg`` that pass Chernikov's rule.

    With the unions of their supports (see :func:`_extreme_ray_step`); formed in chunks of pairs.
    """
    chunk = max(1, EXTREME_RAY_PAIR_CHUNK // max(1, neg.size))
    found_p, found_n, found_unions = [], [], []
    for start in range(0, pos.size, chunk):
        these = pos[start:start + chunk]
        p_rows, n_rows = np.repeat(these, neg.size), np.tile(neg, these.size)
        unions = support[p_rows] | support[n_rows]
        short = np.count_nonzero(unions, axis=1) <= steps + 1
        p_rows, n_rows, unions = p_rows[short], n_rows[short], unions[short]
        adjacent = _rows_within(support, unions) == 2
        found_p.append(p_rows[adjacent])
        found_n.append(n_rows[adjacent])
        found_unions.append(unions[adjacent])
    if not found_p:
        return pos[:0], neg[:0], np.zeros((0, support.shape[1]), dtype=bool)
    return np.concatenate(found_p), np.concatenate(found_n), np.vstack(found_unions)


def _extreme_ray_step(
    A: np.ndarray, b: np.ndarray, support: np.ndarray, n_keep: int, steps: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""One Fourier-Motzkin step of :func:`_fourier_motzkin_step` that keeps only extreme rays.

    A row of the system after ``steps`` eliminations (this one included) is a non-negative
    combination :math:`\lambda^\top [A\ b]` of the starting rows, with :math:`\lambda` in the cone
    :math:`C = \{\lambda \ge 0 : \lambda^\top A_{\text{eliminated}} = 0\}`; ``support`` says which
    starting rows each current row combines. The rows that are extreme rays of :math:`C` imply all
    the others, and each extreme ray of the next cone is either a current one with a zero coefficient
    in the eliminated column or the combination of an *adjacent* pair, one with a positive and one
    with a negative coefficient (the double description method). A pair is adjacent when no other
    current row's support lies within the union of theirs (the combinatorial test, exact when the
    current rows are the extreme rays of :math:`C`, which holds from the start, where they are the
    starting rows themselves). Chernikov's rule, a union of more than ``steps + 1`` rows, discards most
    pairs before that test. Every pair kept gives one new row, with no LP (and, in the cone, no
    duplicate).

    The test needs every zero coefficient to be one in the cone's arithmetic, not a small number
    taken for zero: the starting rows' small coefficients are set to zero once
    (:func:`_eliminate_by_extreme_rays`), a coefficient here is zero only when it is exactly 0, and
    a new row's coefficients that cancel to round-off (within :data:`CANCELLATION_TOLERANCE` of the
    two terms summed) are set to exactly 0. A new row that cancels altogether, ``0 <= b'``, is
    dropped when ``b' >= 0`` (it never combines again, so the other rows stay exact) and kept as
    ``0 <= -1`` when ``b' < 0`` (the set is empty).

    Returns:
        ``(A', b', support')``, without the eliminated column.
    """
    A, b = _scaled_to_unit(A, b)
    coefficients = A[:, n_keep:]
    positive, negative = coefficients > 0.0, coefficients < 0.0
    j = n_keep + int(np.argmin(positive.sum(axis=0) * negative.sum(axis=0)))
    pos, neg = np.flatnonzero(positive[:, j - n_keep]), np.flatnonzero(negative[:, j - n_keep])
    zero = ~(positive[:, j - n_keep] | negative[:, j - n_keep])
    p_rows, n_rows, unions = _adjacent_pairs(support, pos, neg, steps)
    scale_p, scale_n = 1.0 / A[p_rows, j], -1.0 / A[n_rows, j]
    combined = A[p_rows] * scale_p[:, None] + A[n_rows] * scale_n[:, None]
    combined_rhs = b[p_rows] * scale_p + b[n_rows] * scale_n
    combined, combined_rhs, kept = _without_cancelled(
        combined, combined_rhs, np.abs(A[p_rows]) * scale_p[:, None] + np.abs(A[n_rows]) * scale_n[:, None],
        np.abs(b[p_rows]) * scale_p + np.abs(b[n_rows]) * scale_n)
    new_A = np.delete(np.vstack([A[zero], combined]), j, axis=1)
    return new_A, np.concatenate([b[zero], combined_rhs]), np.vstack([support[zero], unions[kept]])


CANCELLATION_TOLERANCE = 1e-13
"""[-] A coefficient (or right side) of a row :func:`_extreme_ray_step` combines is round-off, and set
to exactly 0, when it is at most this fraction of the sum of its two terms' magnitudes: about 500
times the double precision's unit round-off, the error of a few steps' sums."""


def _without_cancelled(rows: np.ndarray, rhs: np.ndarray, magnitude: np.ndarray, rhs_magnitude: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """New rows with their round-off set to 0 and the rows ``0 <= b`` (b >= 0) dropped.

    ``magnitude``: per entry, the sum of the two terms' magnitudes (:data:`CANCELLATION_TOLERANCE`).
    A row ``0 <= b`` with ``b < 0`` is kept as ``0 <= -1``. Returns the rows, their right sides and
    which new rows were kept.
    """
    rows = np.where(np.abs(rows) <= CANCELLATION_TOLERANCE * magnitude, 0.0, rows)
    rhs = np.where(np.abs(rhs) <= CANCELLATION_TOLERANCE * rhs_magnitude, 0.0, rhs)
    cancelled = ~np.any(rows != 0.0, axis=1)
    rhs[cancelled & (rhs < 0.0)] = -1.0
    kept = ~cancelled | (rhs < 0.0)
    return rows[kept], rhs[kept], kept


def _eliminate_by_extreme_rays(
    A: np.ndarray, b: np.ndarray, n_keep: int, max_rows: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Fourier-Motzkin steps of :func:`_extreme_ray_step` from ``A x <= b``, its rows the starting rows.

    Until the columns ``n_keep:`` are gone or the system has more than ``max_rows`` rows (default
    :data:`EXTREME_RAY_MAX_ROWS`). The starting rows are scaled to unit norm and their coefficients
    of at most :data:`ZERO_TOLERANCE` set to 0: the elimination is then exact for that system (see
    :func:`_extreme_ray_step`). A starting row of norm at most :data:`ZERO_TOLERANCE` (relative to
    the largest; the remains of a row the equalities eliminated) is ``0 <= b``: dropped, or, with
    ``b`` below ``-CONTAINMENT_TOLERANCE``, the set is empty (one row ``0 <= -1``).

    Returns:
        ``(A', b')``: rows implying every combination of the starting rows that cancels the
        eliminated columns (the rows of the projection, redundant ones among them), with the columns
        not yet eliminated still last.
    """
    max_rows = EXTREME_RAY_MAX_ROWS if max_rows is None else max_rows
    norms = row_norms(A)
    zero = norms <= ZERO_TOLERANCE * max(1.0, float(norms.max(initial=0.0)))
    if np.any(b[zero] < -CONTAINMENT_TOLERANCE):  # 0 <= b < 0: the set is empty
        return np.zeros((1, n_keep)), np.array([-1.0])
    A, b = A[~zero] / norms[~zero, None], b[~zero] / norms[~zero]  # the rows 0 <= b, b >= 0: nothing
    A[np.abs(A) <= ZERO_TOLERANCE] = 0.0  # small coefficients: zero, once
    support = np.eye(A.shape[0], dtype=bool)
    steps = 0
    while A.shape[1] > n_keep:  # at least one step per call: the caller's pruning cannot stall it
        steps += 1
        A, b, support = _extreme_ray_step(A, b, support, n_keep, steps)
        if A.shape[0] > max_rows:
            break
    return A, b


@dataclass(frozen=True)
class _Ancestry:
    """Which rows of the start of a run of Fourier-Motzkin steps each current row combines.

    A row that combines a superset of another's starting rows is often implied by two such rows
    (Chernikov's rule), which makes them the candidates :func:`_implied_by_pairs` checks. The run
    restarts whenever equalities take part (they mix every row).

    Attributes:
        ancestors: (rows, starting rows) whether a row combines a starting row.
    """

    ancestors: np.ndarray

    @classmethod
    def start(cls, parents: np.ndarray) -> _Ancestry:
        """After the first step, whose rows combine the starting rows ``parents`` (rows, 2)."""
        ancestors = np.zeros((parents.shape[0], int(parents.max(initial=-1)) + 1), dtype=bool)
        rows = np.arange(parents.shape[0])
        ancestors[rows, parents[:, 0]] = True
        ancestors[rows, parents[:, 1]] = True
        return cls(ancestors)

    def step(self, parents: np.ndarray) -> _Ancestry:
        """After one more step, whose rows combine the current rows ``parents`` (rows, 2)."""
        return _Ancestry(self.ancestors[parents[:, 0]] | self.ancestors[parents[:, 1]])

    def keep(self, rows: np.ndarray) -> _Ancestry:
        """Only the rows ``rows``, in that order (those the pruning kept)."""
        return _Ancestry(self.ancestors[rows])


def project(
    P: Polytope,
    keep: int | Sequence[int],
    *,
    method: str = "extreme_rays",
    tolerance: float = REDUNDANCY_TOLERANCE,
    solver: str | None = None,
    settings: SolverSettings | None = None,
    ball: ChebyshevBall | None = None,
    minimal: bool = False,
) -> Polytope:
    r"""Projection :math:`\{y : \exists x \in P,\ y = (x_k)_{k \in 	ext{keep}}\}`.

    The other coordinates are eliminated, equalities first: Gaussian elimination pivoting on the
    largest coefficient (:func:`_eliminate_with_equalities`), then Fourier-Motzkin one variable
    at a time (the one with the smallest product of positive and negative counts). By the default
    method, ``"extreme_rays"``, each step keeps only the new rows that are extreme rays of the
    projection cone (:func:`_extreme_ray_step`: Chernikov's rule and the combinatorial adjacency
    test, no LP), and the rows are pruned by :func:`minimal_representation` once, at the end (or
    whenever the system passes :data:`EXTREME_RAY_MAX_ROWS` rows, after which the elimination goes
    on from the pruned system). By ``"fourier_motzkin"`` the rows are pruned after every step
    (unit rows, duplicates merged, redundant rows dropped by LP, opposite pairs turned into
    equalities, which are eliminated in turn). Both give the same set in minimal form, to the
    tolerances (:data:`ZERO_TOLERANCE`, :data:`CANCELLATION_TOLERANCE`); the first
    needs far fewer LPs and bounded memory where intermediate systems grow (the snake on the
    ground with 12 contacts: a mode with 9 variables to eliminate). Works for unbounded polyhedra
    too.

    Args:
        P: the polytope.
        keep: the coordinates kept, in that order (an ``int`` ``k`` keeps the first ``k``).
        method: one of :data:`PROJECTION_METHODS`: ``"extreme_rays"`` (the default) or
            ``"fourier_motzkin"`` (pruned by LP after every step).
        tolerance: redundancy slack of the pruning [units of x].
        solver: LP back-end of the pruning (a name).
        settings: the solver settings (instead of ``solver``).
        ball: a Chebyshev ball of the set ``P`` (of any H-representation of it) when the caller
            has one: the first pruning reuses it instead of solving its LP again, when ``keep``
            is ``P``'s leading coordinates in order (so the coordinates are not permuted).
        minimal: ``P`` is already a result of :func:`minimal_representation`: when ``keep`` is its
            leading coordinates in order, the first pruning (which would find ``P`` again, at the
            cost of its redundancy LPs) is skipped.

    Returns:
        The projection, in minimal representation, in ``R^len(keep)``; the canonical empty set if
        ``P`` is empty.

    Raises:
        InputError: bad ``keep`` or an unknown ``method``.
    """
    if method not in PROJECTION_METHODS:
        known = ", ".join(repr(name) for name in PROJECTION_METHODS)
        raise InputError(f"unknown projection method {method!r}; known: {known}")
    kept = _keep_indices(keep, P.dim)
    n_keep = len(kept)
    settings = settings_from(solver, settings)
    if n_keep == 0:  # onto R^0: the point if P is non-empty
        return _r0(not chebyshev_ball(P, settings=settings).found)
    order = kept + [i for i in range(P.dim) if i not in kept]
    in_order = order == list(range(P.dim))
    current = P if minimal and in_order else minimal_representation(
        Polytope(P.A[:, order], P.b, P.A_eq[:, order], P.b_eq), tolerance=tolerance, settings=settings,
        ball=ball if in_order else None)
    return _eliminate(current, n_keep, method, tolerance, settings)


def _eliminate(current: Polytope, n_keep: int, method: str, tolerance: float,
               settings: SolverSettings) -> Polytope:
    """:func:`project`'s elimination of the coordinates ``n_keep:`` of the minimal ``current``."""
    history: _Ancestry | None = None
    while True:
        if current.empty:
            return Polytope.empty_set(n_keep)
        reduced = _eliminate_with_equalities(
            current.A, current.b, current.A_eq, current.b_eq, n_keep
        )
        if reduced is None:
            return Polytope.empty_set(n_keep)
        A, b, A_eq, b_eq = reduced
        if A.shape[1] == n_keep:
            return minimal_representation(
                Polytope(A, b, A_eq, b_eq), tolerance=tolerance, settings=settings
            )
        if method == "extreme_rays":
            current = _extreme_rays_then_pruned(A, b, A_eq, b_eq, n_keep, tolerance, settings)
            if current.dim == n_keep:
                return current
            continue
        if A_eq.shape[0] or A.shape[1] != current.dim:  # equalities mix the rows: count afresh after them
            history = None
        A, b, j, parents = _fourier_motzkin_step(A, b, n_keep)
        A_eq = np.delete(A_eq, j, axis=1)  # zero in the eliminated columns
        if not A_eq.shape[0]:
            history = _Ancestry.start(parents) if history is None else history.step(parents)
        current, survivors = _minimal(Polytope(A, b, A_eq, b_eq), tolerance, settings,
                                      ancestors=None if history is None else history.ancestors)
        history = None if history is None or survivors is None else history.keep(survivors)
        if current.dim == n_keep:
            return current


def _extreme_rays_then_pruned(A: np.ndarray, b: np.ndarray, A_eq: np.ndarray, b_eq: np.ndarray,
                              n_keep: int, tolerance: float, settings: SolverSettings) -> Polytope:
    """:func:`_eliminate_by_extreme_rays` on ``A x <= b``, then the result pruned by LP.

    The equalities (zero in the eliminated columns) are carried along. Returns the projection when
    every column went, else the pruned system to go on from.
    """
    A, b = _eliminate_by_extreme_rays(A, b, n_keep)
    A_eq = np.hstack([A_eq[:, :n_keep], np.zeros((A_eq.shape[0], A.shape[1] - n_keep))])
    return _minimal(Polytope(A, b, A_eq, b_eq), tolerance, settings)[0]


# ---------------------------------------------------------------------------------------------
# set difference


def _subtract(R: Polytope, Q: Polytope, settings: SolverSettings) -> list[Polytope]:
    r"""``R`` minus ``Q`` (both in minimal representation, ``R`` full-dimensional in its hull).

    If ``R ∩ Q`` has no interior in ``R``'s affine hull, ``R`` is returned whole. Otherwise, for
    the rows :math:`q_k x \le \beta_k` of ``Q``, piece ``k`` is
    :math:`R \cap \{q_k x \ge \beta_k\} \cap \{q_j x \le \beta_j,\ j < k\}`; the pieces
    cover :math:`R \setminus Q`, have disjoint interiors, and the ones with no interior are dropped.
    """
    common = chebyshev_ball(intersect(R, Q), settings=settings)
    own = chebyshev_ball(R, settings=settings)
    if not common.full_dimensional or common.affine_dimension < own.affine_dimension:
        return [R]
    pieces: list[Polytope] = []
    A, b = R.A, R.b
    for row, rhs in zip(Q.A, Q.b, strict=True):
        piece = Polytope(np.vstack([A, -row]), np.append(b, -rhs), R.A_eq, R.b_eq)
        if chebyshev_ball(piece, settings=settings).full_dimensional:
            pieces.append(minimal_representation(piece, settings=settings))
        A, b = np.vstack([A, row]), np.append(b, rhs)
    return pieces


def set_difference(
    P: Polytope, others: Sequence[Polytope], *, solver: str | None = None,
    settings: SolverSettings | None = None,
) -> list[Polytope]:
    r"""``P`` minus the union of ``others``, as convex pieces with non-empty interior.

    The standard recursive region difference: the pieces of :math:`P \setminus Q_1` are computed
    facet by facet of :math:`Q_1` (:func:`_subtract`), then each piece minus :math:`Q_2`, and so
    on. Interiors are taken in the affine hull of ``P``'s equalities, and pieces whose Chebyshev
    radius is at most :data:`INTERIOR_TOLERANCE` (zero volume) are dropped.

    The pieces are **closed**: a piece and an ``others[i]`` may share a boundary, and two pieces
    may share a facet. Up to those boundaries (a set of zero volume), every point of ``P`` that
    lies in no ``others[i]`` lies in exactly one piece, and no point of an ``others[i]`` lies in
    the interior of a piece. A ``Q`` of lower dimension than ``P`` removes nothing.

    Args:
        P: the polytope.
        others: the polytopes to remove (same dimension).
        solver: LP back-end (a name).
        settings: the solver settings (instead of ``solver``).

    Returns:
        The pieces, each in minimal representation; ``[]`` if nothing of positive volume is left.
    """
    for Q in others:
        _check_same_dim(P, Q)
    if P.dim == 0:  # the point minus any set that holds it
        whole = _holds_in_r0(P) and not any(_holds_in_r0(Q) for Q in others)
        return [_r0(False)] if whole else []
    settings = settings_from(solver, settings)
    start = minimal_representation(P, settings=settings)
    if start.empty or not chebyshev_ball(start, settings=settings).full_dimensional:
        return []
    pieces = [start]
    for Q in others:
        reduced = minimal_representation(Q, settings=settings)
        if reduced.empty:
            continue
        pieces = [piece for R in pieces for piece in _subtract(R, reduced, settings)]
        if not pieces:
            break
    return pieces
