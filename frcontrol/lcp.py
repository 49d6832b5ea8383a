r"""Linear complementarity problems (LCP) and the 2-D frictional contact problem as an LCP.

The LCP
-------
Given a dense square matrix :math:`M \in \mathbb{R}^{n \times n}` and :math:`q \in \mathbb{R}^n`,
find :math:`z` such that

.. math::

    z \ge 0, \qquad w = M z + q \ge 0, \qquad z^\top w = 0 .

A candidate :math:`z` is judged by the *natural-map residual*

.. math::

    \rho(z) = \max_i \lvert \min(z_i, w_i) \rvert ,

which is zero exactly when :math:`z` solves the LCP (a negative :math:`z_i` or :math:`w_i` and a
product :math:`z_i w_i \neq 0` all make it positive). A solution is reported as *found* only when
:math:`\rho(z)` is at most the absolute tolerance :math:`\tau = \text{LCP\_TOLERANCE} \cdot s`,
with the scale :math:`s = \max(\lVert q \rVert_\infty, \max_{ij}\lvert M_{ij}\rvert \,
\lVert z \rVert_\infty)`, the size of the terms that make up :math:`w`. Both :math:`\rho` and
:math:`\tau` are reported on every :class:`LCPSolution`.

Solvers
-------
* **Lemke** (``method="lemke"``): complementary pivoting on the tableau of
  :math:`w - M z - e z_0 = q` with covering vector :math:`e = (1, \dots, 1)` and artificial
  variable :math:`z_0`. Starting from the basis :math:`w`, :math:`z_0` enters and the most
  negative :math:`q_i` leaves; thereafter the complement of the variable that just left enters.
  The leaving row is chosen by the *lexicographic* minimum-ratio rule on the rows of
  :math:`[B^{-1} q,\ B^{-1}] / d_i` (:math:`d` the entering column), which keeps every basis
  lexicographically feasible and so cannot cycle on degenerate problems. :math:`B^{-1}` is
  never formed with an explicit inverse: it is the block of the pivoted tableau under the
  original :math:`w` columns. When the row of :math:`z_0` ties for the minimum ratio it is
  chosen, ending the run. The run ends when :math:`z_0` leaves the basis (a solution,
  recomputed by an LU solve with the final basis matrix and verified), when the entering
  column has no positive entry (a *secondary ray*: no solution was found, which for some
  matrix classes proves none exists, but in general is not a proof), or after ``max_pivots``
  pivots. If a ray or the pivot limit is met while :math:`z_0` is already zero to within the
  tolerance, the current almost-complementary point is a solution and is returned if it
  verifies (this happens on near-degenerate data whose ``q`` has round-off-sized entries).
* **Enumeration** (``method="enumerate"``): every complementary support
  :math:`\alpha \subseteq \{1..n\}` (smallest supports first) gives the candidate
  :math:`z_\alpha = -M_{\alpha\alpha}^{+} q_\alpha`, :math:`z_{\bar\alpha} = 0`, solved by an
  SVD-based least-squares solve; the candidate is kept if it verifies at the data's bound
  ``LCP_TOLERANCE * ||q||_inf`` (not the candidate's: see :data:`LCP_TOLERANCE`). A singular principal
  block (non-isolated solutions) yields its minimum-norm point or, when that point is not
  feasible, a vertex of :math:`\{z_\alpha \ge 0,\ M_{\alpha\alpha} z_\alpha = -q_\alpha,\
  w_{\bar\alpha} \ge 0\}` found by a linear program. Every support is decided, so the search
  is exhaustive (:math:`2^n` supports) and an empty answer proves that no solution exists up to
  the tolerance; it is limited to ``n <= ENUMERATION_MAX_SIZE``.

2-D frictional contact
----------------------
For contacts :math:`i = 1..n_c` with local reaction :math:`r_i = (r_{n,i}, r_{t,i})` and local
velocity :math:`u = W r + q` (interleaved, two entries per contact), the Coulomb problem is

.. math::

    0 \le r_n \perp u_n \ge 0, \qquad \lvert r_t \rvert \le \mu r_n, \qquad
    u_t \ne 0 \Rightarrow r_t = -\mu r_n \operatorname{sign}(u_t) .

Writing :math:`r_t = r_t^+ - r_t^-` and introducing the slip-speed multiplier :math:`\lambda`,
it is the LCP in :math:`z = (r_n, r_t^+, r_t^-, \lambda)` (each a block of :math:`n_c`
entries)

.. math::

    \begin{aligned}
    0 \le r_n &\perp u_n \ge 0, \\
    0 \le r_t^+ &\perp u_t + \lambda \ge 0, \\
    0 \le r_t^- &\perp -u_t + \lambda \ge 0, \\
    0 \le \lambda &\perp \mu r_n - r_t^+ - r_t^- \ge 0 .
    \end{aligned}

The reaction found is checked with Siconos' 2-D error (De Saxcé's natural map
:math:`r - \Pi_K(r - \hat u)` with :math:`\hat u = (u_n + \mu \lvert u_t\rvert, u_t)` and
:math:`K` the friction cone, 2-norm over all contacts) divided by :math:`\lVert q \rVert_2`,
accepted at ``FC2D_TOLERANCE``.

Files
-----
:mod:`frcontrol.siconos` (``read_siconos_lcp``, ``read_siconos_fc2d``) reads the text formats of the Siconos
numerics test suite: dense matrices (storage 0, column-major, one column per text line) and
sparse-block matrices (storage 1, Siconos' ``SparseBlockStructuredMatrix`` dump).
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Iterator
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np
from scipy.linalg.lapack import dgesv

from frcontrol.errors import InputError
from frcontrol.kernel import backend, compiled, twin
from frcontrol.solvers import REFERENCE_LP_SOLVER, RETRY_ERRORS, DoorOptions, SolverSettings, solve_lp

__all__ = [
    "ENUMERATION_MAX_SIZE",
    "FC2D_TOLERANCE",
    "DUPLICATE_TOLERANCE",
    "LCP_TOLERANCE",
    "PIVOT_TOLERANCE",
    "SUPPORT_LP_SETTINGS",
    "TIE_TOLERANCE",
    "FC2DSolution",
    "FrictionContact2D",
    "LCPSolution",
    "enumerate_lcp_solutions",
    "fc2d_error",
    "fc2d_to_lcp",
    "lcp_residual",
    "lcp_enumeration_tolerance",
    "lcp_row_tolerances",
    "lcp_tolerance",
    "siconos_lcp_error",
    "solve_fc2d",
    "solve_lcp",
]

SUPPORT_LP_SETTINGS = SolverSettings(lp=REFERENCE_LP_SOLVER)
"""The solver settings of the enumeration's support LP (a singular principal block whose
minimum-norm point fails: the point of least ``sum(z)``): HiGHS, the reference back-end, whose
simplex answers a vertex; through the door (its residual check), an error retried on DAQP
(:data:`frcontrol.solvers.RETRY_ERRORS`)."""

_SUPPORT_LP_DOOR = DoorOptions(SUPPORT_LP_SETTINGS, fallback=RETRY_ERRORS)
"""How the support LP is solved: :data:`SUPPORT_LP_SETTINGS`, an error retried."""

LCP_TOLERANCE: float = 1e-9
"""Relative bound on the natural-map residual ``|min(z_i, w_i)|`` of an accepted LCP solution.

Dimensionless, and applied **row by row**: row ``i`` of ``w = M z + q`` is accepted when
``|min(z_i, w_i)| <= tau_i`` with ``tau_i = LCP_TOLERANCE * max((|M| |z|)_i, ||q||_inf)``
(:func:`lcp_row_tolerances`), the size of the terms that row sums, floored by ``||q||_inf``. The
bound of one row does not grow with another row's entries: a friction-cone row carrying
``mu = 1e10`` no longer loosens the check of the sliding-acceleration rows (with one scalar bound
``max|M| ||z||`` it did, and the enumeration accepted frictionless sliding for a rod at rest).
The largest row bound is reported as ``LCPSolution.tolerance``.

Enumeration accepts a candidate at one bound set by the data alone, ``LCP_TOLERANCE *
||q||_inf`` (:func:`lcp_enumeration_tolerance`), on its residual and on any negative ``z`` or ``w``
entry: the per-row bounds scale with the candidate's own entries, and a candidate whose entries
cancel (a sticking contact's ``lam_T+ = lam_T- = 3.5e7`` at ``mu = 1e8``) loosened its own check
until non-solutions passed.
"""

DUPLICATE_TOLERANCE: float = 1e-9
"""Relative distance under which two enumerated solutions are one: ``||z - z'||_inf <=
DUPLICATE_TOLERANCE * max(||q||_inf, ||z||_inf)`` (the size of the solution itself, not of ``M``)."""

PIVOT_TOLERANCE: float = 1e-12
"""Relative threshold below which an entry of Lemke's entering column is not a pivot.

Dimensionless: entry ``d_i`` is eligible for the ratio test only if
``d_i > PIVOT_TOLERANCE * max_k |d_k|``. If no entry is eligible the run ends on a ray.
"""

TIE_TOLERANCE: float = 1e-12
"""Relative width of a tie in Lemke's lexicographic minimum-ratio test.

Dimensionless. The ratio rows are ``[B^-1 q, B^-1] / d_i``; an entry ``(B^-1 q)_i`` carries
round-off proportional to ``(|B^-1| |q|)_i`` (units of ``q``) and an entry of ``B^-1`` to the
largest magnitude in its row (dimensionless). Two entries of a column are tied when they differ
by at most ``TIE_TOLERANCE`` times the larger of their two such scales (divided by ``d_i``);
tied rows are compared on the next column.
"""

ENUMERATION_MAX_SIZE: int = 16
"""Largest ``n`` that enumeration accepts by default (``2**16 = 65536`` supports).

Each support costs one small SVD least-squares solve (tens of microseconds), so ``n = 16``
takes a few seconds and every extra unit of ``n`` doubles it. Larger problems raise
:class:`~frcontrol.errors.InputError` unless ``max_size`` is raised explicitly.
"""

FC2D_TOLERANCE: float = 1e-5
"""Bound on Siconos' 2-D frictional contact error divided by ``||q||_2`` (dimensionless).

This is the acceptance threshold of the Siconos test suite for 2-D friction problems; it is
reported as ``FC2DSolution.tolerance``.
"""


LCPStatus = Literal["solved", "ray", "max_pivots", "infeasible", "singular", "inaccurate"]
"""How an LCP solve ended (:class:`LCPSolution`)."""

LCPMethod = Literal["lemke", "enumerate"]
"""The LCP algorithms: Lemke's complementary pivoting, or enumeration of the supports."""


@dataclass(frozen=True)
class LCPSolution:
    """Outcome of an LCP solve.

    Attributes:
        found: True iff a solution was found and its residual is at most ``tolerance``.
        z: the candidate ``z`` (None when the run produced none: ray, max_pivots, infeasible).
        w: ``M z + q`` for that candidate (None when ``z`` is None).
        status: ``"solved"``; ``"ray"`` (Lemke's secondary ray: no solution found, not a wrong
            answer); ``"max_pivots"``; ``"infeasible"`` (enumeration proved none exists);
            ``"singular"`` (Lemke's final basis matrix could not be factorised and the
            tableau's values do not verify);
            ``"inaccurate"`` (a candidate was produced but its residual exceeds the tolerance).
        method: ``"lemke"`` or ``"enumerate"``.
        pivots: pivots performed (Lemke, including the first ``z0`` pivot) or complementary
            supports tried (enumeration).
        residual: natural-map residual ``max|min(z, w)|``; ``inf`` when there is no ``z``.
        tolerance: the absolute tolerance the residual was checked against.
        solve_time: wall-clock seconds spent.
        note: extra information, e.g. that an enumerated solution came from a singular principal
            block (one representative of a non-isolated solution set).
    """

    found: bool
    z: np.ndarray | None
    w: np.ndarray | None
    status: LCPStatus
    method: LCPMethod
    pivots: int
    residual: float
    tolerance: float
    solve_time: float
    note: str = ""


@dataclass(frozen=True)
class FrictionContact2D:
    """A 2-D frictional contact problem in local form ``u = W r + q``.

    Attributes:
        W: the ``(2 nc, 2 nc)`` Delassus matrix; rows and columns interleave ``(n, t)`` per
            contact.
        q: the ``(2 nc,)`` free local velocity.
        mu: the ``(nc,)`` friction coefficients.
        number_of_contacts: ``nc``.
    """

    W: np.ndarray
    q: np.ndarray
    mu: np.ndarray
    number_of_contacts: int

    def __post_init__(self) -> None:
        nc = self.number_of_contacts
        if not isinstance(nc, int | np.integer) or nc < 1:
            raise InputError(f"number_of_contacts must be a positive integer, got {nc!r}")
        if self.W.shape != (2 * nc, 2 * nc):
            raise InputError(f"W must have shape {(2 * nc, 2 * nc)}, got {self.W.shape}")
        if self.q.shape != (2 * nc,):
            raise InputError(f"q must have shape {(2 * nc,)}, got {self.q.shape}")
        if self.mu.shape != (nc,):
            raise InputError(f"mu must have shape {(nc,)}, got {self.mu.shape}")
        for name, value in (("W", self.W), ("q", self.q), ("mu", self.mu)):
            if not np.all(np.isfinite(value)):
                raise InputError(f"{name} contains NaN or infinite entries")
        if np.any(self.mu < 0):
            raise InputError("friction coefficients mu must be non-negative")


@dataclass(frozen=True)
class FC2DSolution:
    """Outcome of a 2-D frictional contact solve.

    Attributes:
        found: True iff the LCP solve found a solution and ``residual <= tolerance``.
        r: reactions, two per contact ``(r_n, r_t)`` (None when no LCP solution was produced).
        u: local velocities ``W r + q`` (None with ``r``).
        status: the status of the underlying LCP solve (see :class:`LCPSolution`).
        residual: Siconos' 2-D error divided by ``||q||_2`` (see :func:`fc2d_error`); ``inf``
            when there is no ``r``.
        tolerance: the bound the residual was checked against (``FC2D_TOLERANCE``).
        method: ``"lemke"`` or ``"enumerate"``.
        lcp: the full result of the underlying LCP solve.
    """

    found: bool
    r: np.ndarray | None
    u: np.ndarray | None
    status: LCPStatus
    residual: float
    tolerance: float
    method: LCPMethod
    lcp: LCPSolution


# --------------------------------------------------------------------------------------------
# Validation and residuals
# --------------------------------------------------------------------------------------------


def _as_lcp(M: object, q: object) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(M, q)`` as float arrays, raising InputError if they are malformed."""
    try:  # read only here: a float64 array goes through as it is
        M_arr = M if type(M) is np.ndarray and M.dtype == np.float64 else np.asarray(M, dtype=float)
        q_arr = q if type(q) is np.ndarray and q.dtype == np.float64 else np.asarray(q, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"M and q must be numeric arrays: {exc}") from exc
    if M_arr.ndim != 2 or M_arr.shape[0] != M_arr.shape[1]:
        raise InputError(f"M must be a square matrix, got shape {M_arr.shape}")
    n = M_arr.shape[0]
    if q_arr.shape != (n,):
        raise InputError(f"q must have shape ({n},) to match M {M_arr.shape}, got {q_arr.shape}")
    if not np.isfinite(M_arr).all():
        raise InputError("M contains NaN or infinite entries")
    if not np.isfinite(q_arr).all():
        raise InputError("q contains NaN or infinite entries")
    return M_arr, q_arr


def _check_tolerance(tolerance: float) -> float:
    if not (isinstance(tolerance, int | float) and math.isfinite(tolerance) and tolerance > 0):
        raise InputError(f"tolerance must be a positive finite number, got {tolerance!r}")
    return float(tolerance)


def lcp_residual(M: np.ndarray, q: np.ndarray, z: np.ndarray) -> float:
    """Natural-map residual ``max_i |min(z_i, (M z + q)_i)|`` of a candidate ``z``.

    Args:
        M: the ``(n, n)`` matrix.
        q: the ``(n,)`` vector.
        z: the ``(n,)`` candidate.

    Returns:
        The residual, in the units of ``w``; zero exactly for a solution, ``inf`` if ``z`` has
        a non-finite entry.

    Raises:
        InputError: if ``M`` or ``q`` is malformed or ``z`` does not match their size.
    """
    M_arr, q_arr = _as_lcp(M, q)
    z_arr = np.asarray(z, dtype=float)
    if z_arr.shape != q_arr.shape:
        raise InputError(f"z must have shape {q_arr.shape}, got {z_arr.shape}")
    if not np.all(np.isfinite(z_arr)):
        return math.inf
    w = M_arr @ z_arr + q_arr
    return float(np.max(np.abs(np.minimum(z_arr, w))))


def lcp_row_tolerances(
    M: np.ndarray, q: np.ndarray, z: np.ndarray | None, tolerance: float = LCP_TOLERANCE
) -> np.ndarray:
    """Absolute residual bound of each row: ``tolerance * max((|M| |z|)_i, ||q||_inf)``.

    Args:
        M: the ``(n, n)`` matrix.
        q: the ``(n,)`` vector.
        z: the candidate, or None (then only ``||q||_inf`` sets the scale).
        tolerance: the relative tolerance (see :data:`LCP_TOLERANCE`).

    Returns:
        The ``(n,)`` bounds in the units of ``w``.
    """
    floor = float(np.max(np.abs(q))) if q.size else 0.0
    if z is None or not z.size:
        return np.full(q.size, tolerance * floor)
    return tolerance * np.maximum(np.abs(M) @ np.abs(z), floor)


def lcp_tolerance(
    M: np.ndarray, q: np.ndarray, z: np.ndarray | None, tolerance: float = LCP_TOLERANCE
) -> float:
    """The largest row bound of :func:`lcp_row_tolerances` (0 for an LCP of size 0).

    Args:
        M: the ``(n, n)`` matrix.
        q: the ``(n,)`` vector.
        z: the candidate, or None (then only ``||q||_inf`` sets the scale).
        tolerance: the relative tolerance.

    Returns:
        The absolute bound in the units of ``w``.
    """
    bounds = lcp_row_tolerances(M, q, z, tolerance)
    return float(np.max(bounds)) if bounds.size else 0.0


def lcp_enumeration_tolerance(q: np.ndarray, tolerance: float = LCP_TOLERANCE) -> float:
    """The absolute bound an enumerated candidate is accepted at: ``tolerance * ||q||_inf``.

    Set by the problem's data alone, never by the candidate: a candidate whose entries cancel
    (a sticking contact's ``lam_T+`` and ``lam_T-`` both near ``mu lam_N / 2``, 3.5e7 at ``mu =
    1e8``) cannot loosen its own check, as it did with the per-row bounds of
    :func:`lcp_row_tolerances` (a tangential force of -11.7 on a contact without normal force was
    accepted at 32.6). A solution set with such a representative also has the one without the
    cancelling split, which enumeration reaches by a smaller support and checks to this bound.

    Args:
        q: the ``(n,)`` vector.
        tolerance: the relative tolerance (see :data:`LCP_TOLERANCE`).

    Returns:
        The bound in the units of ``w`` (and, as for Lemke's check, applied to ``z`` too).
    """
    return tolerance * (float(np.max(np.abs(q))) if q.size else 0.0)


def siconos_lcp_error(M: np.ndarray, q: np.ndarray, z: np.ndarray) -> float:
    """Siconos' relative LCP error ``||z - max(0, z - w)||_2 / ||q||_2``.

    ``z - max(0, z - w) = min(z, w)``, so this is the 2-norm of the natural map over
    ``||q||_2`` (not divided when ``||q||_2`` is below machine epsilon). Siconos' test suite
    accepts a solution when it is at most ``1e-5``.

    Args:
        M: the ``(n, n)`` matrix.
        q: the ``(n,)`` vector.
        z: the candidate.

    Returns:
        The relative error.
    """
    M_arr, q_arr = _as_lcp(M, q)
    z_arr = np.asarray(z, dtype=float)
    error = float(np.linalg.norm(np.minimum(z_arr, M_arr @ z_arr + q_arr)))
    norm_q = float(np.linalg.norm(q_arr))
    return error / norm_q if norm_q > np.finfo(float).eps else error


def _verified(
    M: np.ndarray,
    q: np.ndarray,
    z: np.ndarray | None,
    status: LCPStatus,
    method: LCPMethod,
    pivots: int,
    tolerance: float,
    start: float,
    note: str = "",
) -> LCPSolution:
    """Build an LCPSolution, computing ``w``, the residual and ``found`` from ``z``.

    Lemke's point is checked row by row (:func:`lcp_row_tolerances`), an enumerated one at the
    data's bound (:func:`lcp_enumeration_tolerance`).
    """
    w: np.ndarray | None = None
    if z is None:
        found, residual, bound = False, math.inf, lcp_tolerance(M, q, None, tolerance)
    else:
        w = M @ z + q
        residual, bound, found = backend().lcp_check(M, q, z, w, tolerance, method == "enumerate")
        found = found and status == "solved"
    if status == "solved" and not found and z is not None:
        status = "inaccurate"
    return LCPSolution(found=found, z=z, w=w, status=status, method=method, pivots=pivots, residual=residual,
                       tolerance=bound, solve_time=time.perf_counter() - start, note=note)


def _lcp_check_numpy(M: np.ndarray, q: np.ndarray, z: np.ndarray, w: np.ndarray, tolerance: float,
                     enumerated: bool) -> tuple[float, float, bool]:
    """:func:`_verified`'s check of ``z`` with its ``w = M z + q``, in NumPy.

    The residual max |min(z, w)|, the largest row bound and whether every row is within its bound
    (:func:`lcp_row_tolerances`, or :func:`lcp_enumeration_tolerance` for an ``enumerated``
    candidate). The NumPy twin of the compiled kernel's ``lcp_check`` (the same residual, the
    bounds to round-off).
    """
    natural = np.abs(np.minimum(z, w))
    residual = float(natural.max()) if natural.size else 0.0
    bounds = (np.full(q.size, lcp_enumeration_tolerance(q, tolerance)) if enumerated
              else lcp_row_tolerances(M, q, z, tolerance))
    bound = float(bounds.max()) if bounds.size else 0.0
    return residual, bound, bool((natural <= bounds).all())


def _lcp_check_compiled(M: np.ndarray, q: np.ndarray, z: np.ndarray, w: np.ndarray, tolerance: float,
                        enumerated: bool) -> tuple[float, float, bool]:
    """:func:`_lcp_check_numpy` by the compiled kernel's ``lcp_check``, in one call."""
    kernel: Any = compiled
    return kernel.lcp_check(np.ascontiguousarray(M), np.ascontiguousarray(q),
                            np.ascontiguousarray(z, dtype=float), w, tolerance, enumerated)


# --------------------------------------------------------------------------------------------
# Lemke
# --------------------------------------------------------------------------------------------


def _lexicographic_min_row(
    keys: np.ndarray, widths: np.ndarray, rows: np.ndarray, preferred: int | None
) -> int:
    """Row of ``keys`` (restricted to ``rows``) that is lexicographically smallest.

    Args:
        keys: ``(n, 1 + n)`` ratio rows ``[B^-1 q, B^-1] / d``.
        widths: ``(n, 2)`` tie widths of each row: column 0 for the ``B^-1 q`` entry, column 1
            for the ``B^-1`` entries. Two entries are tied when they differ by at most the
            larger of their two widths.
        rows: indices of the eligible rows.
        preferred: a row to choose whenever it ties on the first column (the row of ``z0``).

    Returns:
        The index of the chosen row.
    """
    for column in range(keys.shape[1]):
        values = keys[rows, column]
        width = widths[rows, min(column, 1)]
        best = int(np.argmin(values))
        rows = rows[values <= values[best] + np.maximum(width, width[best])]
        if column == 0 and preferred is not None and preferred in rows:
            return preferred
        if rows.size == 1:
            break
    return int(rows[0])


class _LemkeTableau:
    """Lemke's tableau ``[I, -M, -1 | q]`` and its basis.

    Columns: w (0..n-1), z (n..2n-1), z0 (2n), then the right-hand side (2n+1); ``basis[i]`` is
    the column basic in row i.
    """

    def __init__(self, M: np.ndarray, q: np.ndarray) -> None:
        n = q.size
        self.n, self.q = n, q
        self.z0, self.rhs = 2 * n, 2 * n + 1
        self.A = np.hstack([np.eye(n), -M, -np.ones((n, 1))])
        self.table = np.hstack([self.A, q[:, None]])
        self.basis = np.arange(n, dtype=np.int64)

    def pivot(self, row: int, column: int) -> None:
        """Make ``column`` basic in ``row``."""
        table = self.table
        table[row] /= table[row, column]
        factors = table[:, column].copy()
        factors[row] = 0.0
        table[:] -= np.outer(factors, table[row])
        self.basis[row] = column

    def choose_row(self, divisor: np.ndarray, rows: np.ndarray, preferred: int | None) -> int:
        """The lexicographic ratio test's row (:func:`_lexicographic_min_row`).

        Ratio rows [B^-1 q, B^-1] / d: B^-1 sits under the original (identity) w columns.
        Round-off in (B^-1 q)_i scales with (|B^-1| |q|)_i, in B^-1 with max_k |B^-1_ik|.
        """
        inverse = self.table[:, :self.n]
        keys = np.hstack([self.table[:, self.rhs : self.rhs + 1], inverse]) / divisor[:, None]
        scales = np.column_stack([np.abs(inverse) @ np.abs(self.q), np.max(np.abs(inverse), axis=1)])
        widths = TIE_TOLERANCE * scales / divisor[:, None]
        return _lexicographic_min_row(keys, widths, rows, preferred)

    def basic_point(self) -> tuple[np.ndarray, bool]:
        """:func:`_basic_point` at the current basis."""
        return _basic_point(self.q, self.basis, self.A[:, self.basis], self.table[:, self.rhs])


@dataclass(frozen=True, eq=False)
class _LemkeBasis:
    """The compiled kernel's end of Lemke's pivots: the basis, its matrix and the right side."""

    n: int
    z0: int
    q: np.ndarray
    basis: np.ndarray
    matrix: np.ndarray  # [I, -M, -1][:, basis]
    rhs: np.ndarray  # the tableau's right side, B^-1 q as pivoted

    def basic_point(self) -> tuple[np.ndarray, bool]:
        """:func:`_basic_point` at the basis."""
        return _basic_point(self.q, self.basis, self.matrix, self.rhs)


def _basic_point(q: np.ndarray, basis: np.ndarray, matrix: np.ndarray, rhs: np.ndarray
                 ) -> tuple[np.ndarray, bool]:
    """``(w, z, z0)`` at a basis, and whether its matrix was singular.

    Recomputed by an LU solve with the basis matrix ``[I, -M, -1][:, basis]`` (fresher than the
    accumulated tableau; LAPACK's ``dgesv``, the routine behind ``numpy.linalg.solve``, called
    without that function's checks); the tableau's right side ``rhs`` if the matrix is singular
    (an exactly zero pivot, where ``numpy.linalg.solve`` raises).
    """
    values = np.zeros(2 * q.size + 1)
    if not q.size:
        return values, False
    _, _, x, info = dgesv(matrix, q)
    if info != 0:
        values[basis] = rhs
        return values, True
    values[basis] = x
    return values, False


LEMKE_STATUSES: tuple[LCPStatus, ...] = ("solved", "ray", "max_pivots")
"""How Lemke's pivots end, by the compiled kernel's code (``LEMKE_SOLVED``, ``LEMKE_RAY``,
``LEMKE_MAX_PIVOTS``): z0 left the basis, no row bounds the entering column, or the pivot limit."""


def _lemke_pivots(M: np.ndarray, q: np.ndarray, max_pivots: int) -> tuple[LCPStatus, int, _LemkeTableau]:
    """Lemke's pivots in NumPy (the reference of the compiled kernel's ``lemke``).

    Returns:
        How they ended (:data:`LEMKE_STATUSES`), the number of pivots and the tableau.
    """
    n = q.size
    tab = _LemkeTableau(M, q)
    # First pivot: z0 enters at the value that makes every w_i = q_i + z0 non-negative.
    row = tab.choose_row(np.ones(n), np.arange(n), None)
    leaving = int(tab.basis[row])
    tab.pivot(row, tab.z0)
    pivots = 1
    while leaving != tab.z0:
        entering = leaving + n if leaving < n else leaving - n
        column = tab.table[:, entering]
        largest = float(np.max(np.abs(column)))
        eligible = (np.flatnonzero(column > PIVOT_TOLERANCE * largest) if largest > 0
                    else np.zeros(0, dtype=int))
        if len(eligible) == 0:
            return "ray", pivots, tab
        if pivots >= max_pivots:
            return "max_pivots", pivots, tab
        z0_rows = np.flatnonzero(tab.basis == tab.z0)
        preferred = int(z0_rows[0]) if z0_rows.size else None
        row = tab.choose_row(np.where(column > 0, column, 1.0), eligible, preferred)
        leaving = int(tab.basis[row])
        tab.pivot(row, entering)
        pivots += 1
    return "solved", pivots, tab


def _lemke_pivots_compiled(M: np.ndarray, q: np.ndarray,
                           max_pivots: int) -> tuple[LCPStatus, int, _LemkeBasis]:
    """:func:`_lemke_pivots` by the compiled kernel: the same pivots, basis and right side."""
    n = q.size
    basis, matrix, rhs = np.empty(n, dtype=np.int64), np.empty((n, n)), np.empty(n)
    kernel: Any = compiled
    code, pivots = kernel.lemke(np.ascontiguousarray(M), np.ascontiguousarray(q), basis, matrix, rhs,
                                max_pivots, PIVOT_TOLERANCE, TIE_TOLERANCE)
    return LEMKE_STATUSES[code], int(pivots), _LemkeBasis(n, 2 * n, q, basis, matrix, rhs)


twin("lemke_pivots", numpy=_lemke_pivots, compiled=_lemke_pivots_compiled)
twin("lcp_check", numpy=_lcp_check_numpy, compiled=_lcp_check_compiled)


def _lemke(M: np.ndarray, q: np.ndarray, tolerance: float, max_pivots: int) -> LCPSolution:
    """Lexicographic Lemke's method; see the module docstring.

    The pivots run in the kernel's ``lemke_pivots`` (:func:`frcontrol.kernel.backend`: compiled, or
    the NumPy reference :func:`_lemke_pivots`); both pivot alike, and the point is recomputed from
    the final basis by the same LU solve.
    """
    start = time.perf_counter()
    n = q.size
    if (q >= 0).all():
        return _verified(M, q, np.zeros(n), "solved", "lemke", 0, tolerance, start)
    tab: _LemkeTableau | _LemkeBasis
    status, pivots, tab = backend().lemke_pivots(M, q, max_pivots)
    if status != "solved":
        return _lemke_stopped(M, q, tab, status, pivots, tolerance, start)
    values, singular = tab.basic_point()
    result = _verified(M, q, values[n : 2 * n].copy(), "solved", "lemke", pivots, tolerance, start)
    if singular and not result.found:
        return replace(result, status="singular")
    return result


def _lemke_stopped(M: np.ndarray, q: np.ndarray, tab: _LemkeTableau | _LemkeBasis, status: LCPStatus,
                   pivots: int, tolerance: float, start: float) -> LCPSolution:
    """Lemke's method ended on a ray or the pivot limit.

    With z0 already at zero (within the tolerance) the almost-complementary point is itself a
    solution: it is accepted if it verifies.
    """
    values, _ = tab.basic_point()
    z = values[tab.n : 2 * tab.n].copy()
    if abs(values[tab.z0]) <= lcp_tolerance(M, q, z, tolerance):
        note = f"{status} met with z0 = {values[tab.z0]:.3g}: the current point is a solution"
        result = _verified(M, q, z, "solved", "lemke", pivots, tolerance, start, note)
        if result.found:
            return result
    return _verified(M, q, None, status, "lemke", pivots, tolerance, start)


# --------------------------------------------------------------------------------------------
# Enumeration
# --------------------------------------------------------------------------------------------


def _check_enumeration_size(n: int, max_size: int | None) -> None:
    limit = ENUMERATION_MAX_SIZE if max_size is None else max_size
    if n > limit:
        raise InputError(
            f"LCP of size n = {n} is too large to enumerate: 2**{n} complementary supports "
            f"exceed the limit n <= {limit} (raise max_size to override)"
        )


def _verifies(M: np.ndarray, q: np.ndarray, z: np.ndarray, tolerance: float) -> bool:
    """Whether ``z`` passes the enumeration check (:func:`lcp_enumeration_tolerance`).

    Every row needs ``z_i, w_i >= -tau`` and ``|min(z_i, w_i)| <= tau``, with ``tau`` set by the
    problem's data alone.
    """
    w = M @ z + q
    bound = lcp_enumeration_tolerance(q, tolerance)
    return bool(np.all(z >= -bound) and np.all(w >= -bound) and np.all(np.abs(np.minimum(z, w)) <= bound))


def _support_candidate(
    M: np.ndarray, q: np.ndarray, support: tuple[int, ...], tolerance: float
) -> tuple[np.ndarray, str]:
    """Candidate ``z`` with ``z_i = 0`` off ``support`` and ``w_i = 0`` on it, and a note.

    A nonsingular principal block gives the unique candidate. A singular block gives an affine
    set of them: its minimum-norm point is tried first and, if it fails the check, a linear
    program looks for the point of the set with ``z >= 0`` and ``w >= 0`` of least ``sum(z)``, so
    that no solution is missed. The least sum picks the representative without a cancelling
    split: a sticking contact's ``(lam_T+, lam_T-)`` enter ``lam_T`` as a difference, and any
    other vertex (up to ``lam_T+ + lam_T- = mu lam_N``, 8.5e8 N at ``mu = 1e8``) loses ``lam_T``'s
    digits in that difference.
    """
    n = q.size
    z = np.zeros(n)
    if not support:
        return z, ""
    alpha = list(support)
    block = M[np.ix_(alpha, alpha)]
    z[alpha], _, rank, _ = np.linalg.lstsq(block, -q[alpha], rcond=None)
    if rank == len(alpha):
        return z, ""
    note = f"singular principal block on support {support} (rank {rank}): "
    if _verifies(M, q, z, tolerance):
        return z, note + "minimum-norm representative of a non-isolated solution set"
    others = [i for i in range(n) if i not in support]
    lp = solve_lp(
        np.ones(len(alpha)),  # the least sum(z): no spurious split lam_T+ + lam_T- = mu lam_N
        -M[np.ix_(others, alpha)] if others else None,
        q[others] if others else None,
        block,
        -q[alpha],
        lb=0.0,
        door=_SUPPORT_LP_DOOR,
    )
    if lp.found and lp.x is not None:
        z[alpha] = lp.x
        return z, note + "vertex found by linear programming (minimum-norm point infeasible)"
    return z, note + "no feasible point"


def _iter_solutions(
    M: np.ndarray, q: np.ndarray, tolerance: float
) -> Iterator[tuple[int, np.ndarray, str]]:
    """Yield ``(supports tried so far, z, note)`` for each verified, not yet seen solution."""
    n = q.size
    tried = 0
    seen: list[np.ndarray] = []
    for size in range(n + 1):
        for support in itertools.combinations(range(n), size):
            tried += 1
            z, note = _support_candidate(M, q, support, tolerance)
            if not _verifies(M, q, z, tolerance):
                continue
            bound = DUPLICATE_TOLERANCE * max(float(np.max(np.abs(q))) if n else 0.0,
                                              float(np.max(np.abs(z))) if n else 0.0)
            if any(float(np.max(np.abs(z - other))) <= bound for other in seen):
                continue
            seen.append(z)
            yield tried, z, note


def enumerate_lcp_solutions(
    M: np.ndarray,
    q: np.ndarray,
    *,
    tolerance: float = LCP_TOLERANCE,
    max_size: int | None = None,
) -> list[LCPSolution]:
    """All solutions of the LCP, one per complementary support that yields a verified solution.

    Supports are visited by increasing size (then lexicographically). For each support ``alpha`` the
    block system ``M[alpha, alpha] z_alpha = -q_alpha`` is solved by SVD least squares; the
    candidate is kept if ``z >= -tol``, ``w >= -tol`` and its natural-map residual is at most ``tol
    = tolerance * ||q||_inf`` (:func:`lcp_enumeration_tolerance`: the problem's data alone, so that
    a candidate's cancelling entries cannot loosen it). Identical solutions (within ``tol``) from
    different supports are reported once. A singular principal block yields one representative of
    its solution set (the minimum-norm point, or a vertex found by a linear program when that point
    is not feasible), noted in ``LCPSolution.note``: a non-isolated solution set is represented, not
    listed. Every support is decided, so an empty list means no solution exists (up to the
    tolerance).

    Args:
        M: the ``(n, n)`` matrix.
        q: the ``(n,)`` vector.
        tolerance: relative tolerance (see ``LCP_TOLERANCE``).
        max_size: largest ``n`` to accept (default ``ENUMERATION_MAX_SIZE``).

    Returns:
        The solutions found (empty if none exists); ``pivots`` of each is the number of
        supports tried up to and including its own.

    Raises:
        InputError: if the input is malformed or ``n`` exceeds the size limit.
    """
    M, q = _as_lcp(M, q)
    tolerance = _check_tolerance(tolerance)
    _check_enumeration_size(q.size, max_size)
    start = time.perf_counter()
    return [
        _verified(M, q, z, "solved", "enumerate", tried, tolerance, start, note)
        for tried, z, note in _iter_solutions(M, q, tolerance)
    ]


def _enumerate_first(
    M: np.ndarray, q: np.ndarray, tolerance: float, max_size: int | None
) -> LCPSolution:
    _check_enumeration_size(q.size, max_size)
    start = time.perf_counter()
    for tried, z, note in _iter_solutions(M, q, tolerance):
        return _verified(M, q, z, "solved", "enumerate", tried, tolerance, start, note)
    return _verified(M, q, None, "infeasible", "enumerate", 2**q.size, tolerance, start)


def solve_lcp(
    M: np.ndarray,
    q: np.ndarray,
    method: str = "lemke",
    *,
    tolerance: float = LCP_TOLERANCE,
    max_pivots: int | None = None,
    max_size: int | None = None,
) -> LCPSolution:
    """Solve the LCP ``z >= 0, w = M z + q >= 0, z^T w = 0``.

    Args:
        M: the ``(n, n)`` matrix.
        q: the ``(n,)`` vector.
        method: ``"lemke"`` (lexicographic Lemke) or ``"enumerate"`` (the first solution in
            the enumeration order of :func:`enumerate_lcp_solutions`, i.e. one of smallest
            support; status ``"infeasible"`` when there is none).
        tolerance: relative tolerance (see ``LCP_TOLERANCE``).
        max_pivots: Lemke's pivot limit (default ``50 n + 100``).
        max_size: enumeration size limit (default ``ENUMERATION_MAX_SIZE``).

    Returns:
        The result; ``found`` is True only for a verified solution.

    Raises:
        InputError: malformed input, unknown method, or enumeration over the size limit.
    """
    M, q = _as_lcp(M, q)
    tolerance = _check_tolerance(tolerance)
    if method in ("lemke", "enumerate") and q.size == 0:  # size 0: z = () solves it, trivially
        named: LCPMethod = "lemke" if method == "lemke" else "enumerate"
        return _verified(M, q, np.zeros(0), "solved", named, 0, tolerance, time.perf_counter())
    if method == "lemke":
        limit = 50 * q.size + 100 if max_pivots is None else max_pivots
        if not isinstance(limit, (int, np.integer)) or limit < 1:
            raise InputError(f"max_pivots must be a positive integer, got {max_pivots!r}")
        return _lemke(M, q, tolerance, int(limit))
    if method == "enumerate":
        return _enumerate_first(M, q, tolerance, max_size)
    raise InputError(f"unknown LCP method {method!r}; use 'lemke' or 'enumerate'")


# --------------------------------------------------------------------------------------------
# 2-D frictional contact
# --------------------------------------------------------------------------------------------


def fc2d_to_lcp(problem: FrictionContact2D) -> tuple[np.ndarray, np.ndarray]:
    """Build the LCP ``(M, q)`` in ``z = (r_n, r_t+, r_t-, lambda)`` equivalent to the problem.

    Args:
        problem: the 2-D frictional contact problem.

    Returns:
        ``M`` of shape ``(4 nc, 4 nc)`` and ``q`` of shape ``(4 nc,)``.
    """
    nc = problem.number_of_contacts
    normal, tangent = slice(0, None, 2), slice(1, None, 2)
    W, qf = problem.W, problem.q
    Wnn, Wnt = W[normal, normal], W[normal, tangent]
    Wtn, Wtt = W[tangent, normal], W[tangent, tangent]
    eye, zero = np.eye(nc), np.zeros((nc, nc))
    M = np.block(
        [
            [Wnn, Wnt, -Wnt, zero],
            [Wtn, Wtt, -Wtt, eye],
            [-Wtn, -Wtt, Wtt, eye],
            [np.diag(problem.mu), -eye, -eye, zero],
        ]
    )
    q = np.concatenate([qf[normal], qf[tangent], -qf[tangent], np.zeros(nc)])
    return M, q


def fc2d_error(problem: FrictionContact2D, r: np.ndarray) -> float:
    """Siconos' 2-D frictional contact error of reactions ``r``, divided by ``||q||_2``.

    Per contact, with ``u = W r + q`` and De Saxcé's modified velocity
    ``(u_n + mu |u_t|, u_t)``, the error term is ``r - Pi_K(r - u_hat)`` with ``K`` the cone
    ``|r_t| <= mu r_n``; the terms are summed in 2-norm and divided by ``||q||_2`` (unless that
    is below machine epsilon). It is zero exactly for a solution of the Coulomb problem.

    Args:
        problem: the problem.
        r: reactions, ``(r_n, r_t)`` per contact.

    Returns:
        The relative error.
    """
    r = np.asarray(r, dtype=float)
    u = problem.W @ r + problem.q
    total = 0.0
    for i, mu in enumerate(problem.mu):
        rn, rt, un, ut = r[2 * i], r[2 * i + 1], u[2 * i], u[2 * i + 1]
        xn, xt = rn - (un + mu * abs(ut)), rt - ut
        if mu * abs(xt) <= -xn:  # in the polar cone: projects to the apex
            pn, pt = 0.0, 0.0
        elif abs(xt) > mu * xn:  # outside the cone: project onto its boundary
            pn = (mu * abs(xt) + xn) / (mu * mu + 1.0)
            pt = mu * pn * np.sign(xt)
        else:  # inside the cone
            pn, pt = xn, xt
        total += (rn - pn) ** 2 + (rt - pt) ** 2
    error = math.sqrt(total)
    norm_q = float(np.linalg.norm(problem.q))
    return error / norm_q if norm_q > np.finfo(float).eps else error


def solve_fc2d(problem: FrictionContact2D, method: str = "lemke") -> FC2DSolution:
    """Solve a 2-D frictional contact problem through its LCP reformulation.

    Args:
        problem: the problem.
        method: ``"lemke"`` or ``"enumerate"`` (the LCP has ``4 nc`` unknowns, so enumeration
            is limited to ``4 nc <= ENUMERATION_MAX_SIZE``).

    Returns:
        The result; ``found`` requires a verified LCP solution and a Siconos error at most
        ``FC2D_TOLERANCE``.

    Raises:
        InputError: unknown method, or enumeration over the size limit.
    """
    M, q = fc2d_to_lcp(problem)
    lcp = solve_lcp(M, q, method)
    if lcp.z is None:
        return FC2DSolution(
            found=False,
            r=None,
            u=None,
            status=lcp.status,
            residual=math.inf,
            tolerance=FC2D_TOLERANCE,
            method=lcp.method,
            lcp=lcp,
        )
    nc = problem.number_of_contacts
    r = np.empty(2 * nc)
    r[0::2] = lcp.z[:nc]
    r[1::2] = lcp.z[nc : 2 * nc] - lcp.z[2 * nc : 3 * nc]
    residual = fc2d_error(problem, r)
    return FC2DSolution(
        found=lcp.found and residual <= FC2D_TOLERANCE,
        r=r,
        u=problem.W @ r + problem.q,
        status=lcp.status,
        residual=residual,
        tolerance=FC2D_TOLERANCE,
        method=lcp.method,
        lcp=lcp,
    )
