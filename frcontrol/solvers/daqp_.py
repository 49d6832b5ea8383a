r"""Adapter for DAQP, a dual active-set solver for small dense QPs and LPs (Arnström et al.).

DAQP solves

.. math::

    \min_x \tfrac12 x^\top H x + f^\top x \quad\text{s.t.}\quad
    b_{lower} \le \begin{bmatrix} I_{m_s} & 0 \\ A \end{bmatrix} x \le b_{upper},

called as ``daqp.solve(H, f, A, bupper, blower, sense)``. What we found in its documentation and
source (``interfaces/daqp-python/daqp.pyx``, ``docs/parameters``) and checked on daqp 0.11:

* **LPs** are passed with ``H=None``; DAQP then runs proximal-point iterations (its default
  ``eps_prox=-1e-6`` selects the regularisation automatically). A zero matrix also works, but the
  reported objective then carries the proximal term's round-off.
* **Simple bounds**: when ``bupper``/``blower`` have more entries than ``A`` has rows, the first
  ``m_s = len(bupper) - A.shape[0]`` entries bound ``x[0:m_s]`` directly. We pass all ``n`` bounds
  whenever one of them is finite, with infinities replaced by ``±DAQP_INF`` (``1e30``).
* **Equalities**: DAQP's encoding is ``sense[i] = 5`` (active + immutable) with
  ``blower[i] = bupper[i] = b_eq[i]``; plain inequalities have ``sense = 0`` and
  ``blower = -DAQP_INF``. **In LP mode (``H=None``) that encoding is unreliable in daqp 0.11**:
  ``min -x1 - 2 x2 s.t. x >= 0, x1 + x2 = 1`` ends on exit flag -3 ("unbounded") while returning
  the optimum (0, 1). On 12 000 seeded random LPs (n = 2-9, 0-2 equalities, HiGHS as reference)
  10 optima were reported unbounded and 4 infeasible LPs ended on -6. Forcing ``eq_reduction=1``
  or passing ``H = 0`` fixed the first failure but not the second; a single range row
  (``blower = bupper``, ``sense = 0``) fails like ``sense = 5``; passing each equality as the
  two opposite rows ``a x <= b_eq`` and ``-a x <= -b_eq`` gave **no** failure on the same LPs and
  was the fastest. This adapter therefore passes LP equalities as pairs of opposite rows (each
  met to DAQP's ``primal_tol``), and QP equalities with ``sense = 5`` (DAQP's native case).
* **Exit flags**: ``1`` optimal, ``2`` soft optimal, ``-1`` infeasible, ``-2`` cycling, ``-3``
  unbounded, ``-4`` iteration limit, ``-5`` non-convex, ``-6`` initial working set
  overdetermined (we get it for *inconsistent* equalities: we then check them by least squares and
  report ``infeasible`` if they are, ``error`` otherwise), ``-7`` time limit, ``-8`` unsupported.
* **Contiguity**: the Python wrapper takes typed memoryviews and passes ``&f[0]`` to C, so a
  strided ``f`` (e.g. a column slice) is read as if it were contiguous: DAQP then solves another
  problem and returns exit flag 1 with a wrong optimum. The door hands every adapter C-contiguous
  ``float64`` arrays; this adapter builds its own stacked arrays, contiguous by construction.
"""

from __future__ import annotations

import daqp
import numpy as np

from frcontrol.errors import InputError

from ._common import Adapter, LinearProgram, RawSolution, Status

DAQP_INF = 1e30
"""DAQP's infinity: bounds at or beyond ``±1e30`` are inactive (``DAQP_INF`` in its C source)."""

SENSE_INEQUALITY = 0
"""DAQP sense flag of an inequality constraint."""

SENSE_EQUALITY = 5
"""DAQP sense flag of an equality constraint (1 = active + 4 = immutable)."""

EXIT_FLAGS: dict[int, str] = {
    2: "soft optimal",
    1: "optimal",
    -1: "infeasible",
    -2: "cycling detected",
    -3: "unbounded",
    -4: "iteration limit reached",
    -5: "nonconvex problem",
    -6: "initial working set overdetermined",
    -7: "time limit reached",
    -8: "unsupported problem",
}
"""DAQP exit flags and their meaning (DAQP documentation, "Parameters" page)."""

SETTINGS = frozenset(
    {
        "primal_tol",
        "dual_tol",
        "zero_tol",
        "pivot_tol",
        "progress_tol",
        "cycle_tol",
        "iter_limit",
        "fval_bound",
        "eps_prox",
        "eta_prox",
        "rho_soft",
        "rel_subopt",
        "abs_subopt",
        "sing_tol",
        "refactor_tol",
        "time_limit",
        "eq_reduction",
    }
)
"""DAQP settings an adapter call may override through ``**options``."""

EQUALITY_CONSISTENCY_TOLERANCE = 1e-9
"""Relative least-squares residual ``|A_eq x - b_eq| / (1 + |b_eq|)`` above which equalities are
declared inconsistent after DAQP's exit flag -6. Default ``1e-9``."""


def _stack(
    problem: LinearProgram, equalities_as_pairs: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Build DAQP's ``A, bupper, blower, sense`` from a validated problem.

    Rows: ``n`` simple bounds (only if one is finite), the inequalities, then the equalities,
    either as ``sense = 5`` rows or as the pairs ``A_eq x <= b_eq``, ``-A_eq x <= -b_eq``.
    """
    n = problem.n
    m_s = n if problem.has_bounds else 0
    m_ub, m_eq = problem.A_ub.shape[0], problem.A_eq.shape[0]
    pairs = equalities_as_pairs and m_eq > 0
    rows = m_ub + (2 * m_eq if pairs else m_eq)
    bupper = np.empty(m_s + rows)
    blower = np.empty(m_s + rows)
    blower.fill(-DAQP_INF)
    sense = np.zeros(m_s + rows, dtype=np.intc)  # SENSE_INEQUALITY
    if m_s:
        np.minimum(problem.ub, DAQP_INF, out=bupper[:m_s])
        np.maximum(problem.lb, -DAQP_INF, out=blower[:m_s])
    bupper[m_s : m_s + m_ub] = problem.b_ub
    if rows == m_ub and problem.A_ub.flags.writeable:
        # inequalities only: the door's C-contiguous float64 A_ub as it is (DAQP reads it through
        # a writable typed memoryview, hence the flag, and does not write it)
        return problem.A_ub, bupper, blower, sense
    A = np.empty((rows, n))
    A[:m_ub] = problem.A_ub
    if pairs:
        A[m_ub : m_ub + m_eq] = problem.A_eq
        A[m_ub + m_eq :] = -problem.A_eq
        bupper[m_s + m_ub : m_s + m_ub + m_eq] = problem.b_eq
        bupper[m_s + m_ub + m_eq :] = -problem.b_eq
    elif m_eq:
        A[m_ub:] = problem.A_eq
        bupper[m_s + m_ub :] = problem.b_eq
        blower[m_s + m_ub :] = problem.b_eq
        sense[m_s + m_ub :] = SENSE_EQUALITY
    return A, bupper, blower, sense


def _equalities_consistent(problem: LinearProgram) -> bool:
    """Whether ``A_eq x = b_eq`` has a solution (least squares, relative residual)."""
    if problem.A_eq.shape[0] == 0:
        return True
    x, *_ = np.linalg.lstsq(problem.A_eq, problem.b_eq, rcond=None)
    residual = np.max(np.abs(problem.A_eq @ x - problem.b_eq))
    scale = 1.0 + np.max(np.abs(problem.b_eq))
    return bool(residual <= EQUALITY_CONSISTENCY_TOLERANCE * scale)


def _solve(H: np.ndarray | None, problem: LinearProgram, options: dict) -> RawSolution:
    unknown = set(options) - SETTINGS if options else None
    if unknown:
        raise InputError(f"unknown DAQP option(s) {sorted(unknown)}; known: {sorted(SETTINGS)}")
    A, bupper, blower, sense = _stack(problem, equalities_as_pairs=H is None)
    x, _, exitflag, _ = daqp.solve(H, problem.c, A, bupper, blower, sense, **options)
    exitflag = int(exitflag)
    raw = f"exitflag={exitflag} ({EXIT_FLAGS.get(exitflag, 'unknown')})"
    status: Status
    if exitflag == 1:
        status = "optimal"
    elif exitflag == -1:
        status = "infeasible"
    elif exitflag == -3:
        status = "unbounded"
    elif exitflag == -6 and not _equalities_consistent(problem):
        status = "infeasible"
    else:
        status = "error"
    return RawSolution(status, np.array(x, dtype=float) if status == "optimal" else None, raw)


_RAW_STATUS = {flag: f"exitflag={flag} ({meaning})" for flag, meaning in EXIT_FLAGS.items()}
"""The raw status string of each known exit flag, as :func:`_solve` writes it."""

_STATUS_OF_FLAG: dict[int, Status] = {1: "optimal", -1: "infeasible", -3: "unbounded"}
"""The door's status of an exit flag (every other flag, but -6 with inconsistent equalities, is an error)."""


def solve_inequalities(c: np.ndarray, A_ub: np.ndarray, b_ub: np.ndarray, lb: np.ndarray | None,
                       ub: np.ndarray | None) -> tuple[Status, np.ndarray | None, str]:
    """The LP adapter for ``min c x s.t. A_ub x <= b_ub, lb <= x <= ub`` (no equality), without objects.

    The door's lean path (:class:`frcontrol.solvers.InequalityLPs`): the same DAQP call as
    :func:`_solve` on the same arrays (``c``, ``A_ub``, ``b_ub`` C-contiguous ``float64``,
    ``A_ub`` writable; ``lb``/``ub`` None or with a finite entry), so the same answer, returned
    as ``(status, x, raw_status)``.
    """
    rows = A_ub.shape[0]
    m_s = 0 if lb is None or ub is None else c.shape[0]
    blower = np.empty(m_s + rows)
    blower.fill(-DAQP_INF)
    if lb is None or ub is None:
        bupper = b_ub
    else:
        bupper = np.empty(m_s + rows)
        np.minimum(ub, DAQP_INF, out=bupper[:m_s])
        bupper[m_s:] = b_ub
        np.maximum(lb, -DAQP_INF, out=blower[:m_s])
    x, _, exitflag, _ = daqp.solve(None, c, A_ub, bupper, blower, np.zeros(m_s + rows, dtype=np.intc))
    exitflag = int(exitflag)
    raw = _RAW_STATUS.get(exitflag) or f"exitflag={exitflag} (unknown)"
    status = _STATUS_OF_FLAG.get(exitflag, "error")
    return status, np.array(x, dtype=float) if status == "optimal" else None, raw


ADAPTER = Adapter(_solve)
"""DAQP's adapters: LPs with ``H=None``, QPs with ``H = P``; ``**options`` are DAQP settings
(:data:`SETTINGS`)."""
solve_lp = ADAPTER.solve_lp
solve_qp = ADAPTER.solve_qp


__all__ = [
    "ADAPTER",
    "DAQP_INF",
    "EQUALITY_CONSISTENCY_TOLERANCE",
    "EXIT_FLAGS",
    "SENSE_EQUALITY",
    "SENSE_INEQUALITY",
    "SETTINGS",
    "solve_inequalities",
    "solve_lp",
    "solve_qp",
]
