r"""One door for linear programs and small quadratic programs, several back-ends.

.. math::

    \text{LP:}\quad \min_x c^\top x \qquad
    \text{QP:}\quad \min_x \tfrac12 x^\top P x + q^\top x \qquad
    \text{s.t.}\quad A_{ub} x \le b_{ub},\; A_{eq} x = b_{eq},\; lb \le x \le ub.

:func:`solve_lp` and :func:`qp_problem` (whose QP :func:`solve_qp` solves) validate the arrays
once (shapes, NaN, infinities; a malformed input raises :class:`~frcontrol.errors.InputError`),
convert every one of them to a C-contiguous ``float64`` array (DAQP silently solves another
problem when handed a strided vector, see :mod:`frcontrol.solvers.daqp_`), call the back-end's
adapter, and build a frozen result. The door never trusts a success flag alone: it computes the
primal residual of every answer (:func:`primal_residual`) and downgrades an "optimal" answer whose
residual exceeds :data:`FEASIBILITY_TOLERANCE` (relative, see there) to ``status="error"``.

The back-ends, their options and the residual tolerance travel as one frozen
:class:`~frcontrol.solvers.settings.SolverSettings`; a back-end name is turned into settings by
:func:`~frcontrol.solvers.settings.settings_from`. What happens when an answer is not usable is a
:class:`Fallback` policy named at each call. :func:`solve_lp` takes both, with the residual check,
as one frozen :class:`DoorOptions` (``door=``): ``solve_lp(c, A_ub, b_ub, door=DoorOptions(
settings_from("highs"), RETRY_ERRORS))``.

An infeasible or unbounded problem is a *result* (``found=False``), not an exception. An unknown or
uninstalled back-end raises :class:`~frcontrol.errors.SolverNotFound`.

Back-ends (registered at import when their package imports, qpsolvers-style):

======================  ===========================================================================
``"daqp"`` (default)    DAQP, dual active set; 7-40 us per small dense LP here, no failure seen.
``"highs"`` (reference) HiGHS through ``highspy``; 0.3-1.6 ms per small LP; robust.
``"proxsuite"``         ProxQP dense; made for QPs. On LPs it needs tight settings (the adapter's
                        defaults); with ProxQP's own it falsely reports infeasibility on many
                        feasible LPs. See :mod:`frcontrol.solvers.proxsuite_`.
======================  ===========================================================================
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from frcontrol.errors import FrcontrolError, InputError, SolverNotFound

from ._common import LeanAdapter, LinearProgram, QPAdapter, QuadraticProgram, RawSolution, Status
from .settings import (
    DEFAULT_LP_SOLVER,
    DEFAULT_SETTINGS,
    FEASIBILITY_TOLERANCE,
    LP_SOLVER_ENVIRONMENT_VARIABLE,
    SolverSettings,
    settings_from,
)

__all__ = [
    "CONFIRM_INFEASIBLE",
    "DEFAULT_DOOR",
    "DEFAULT_LP_SOLVER",
    "DEFAULT_SETTINGS",
    "FEASIBILITY_TOLERANCE",
    "DoorOptions",
    "InequalityLPs",
    "KNOWN_SOLVERS",
    "LP_SOLVER_ENVIRONMENT_VARIABLE",
    "Fallback",
    "LinearProgram",
    "NO_FALLBACK",
    "RETRY_ERRORS",
    "QuadraticProgram",
    "RawSolution",
    "LPResult",
    "QPResult",
    "REFERENCE_LP_SOLVER",
    "SolverFailed",
    "SolverSettings",
    "Status",
    "available_solvers",
    "lp_check",
    "lp_problem",
    "ResidualCheck",
    "must_solve",
    "primal_residual",
    "qp_problem",
    "solve",
    "solve_lp",
    "solve_lp_prepared",
    "solve_qp",
    "settings_from",
]

REFERENCE_LP_SOLVER = "highs"
"""Back-end used as the reference in tests and as the fallback of the polytope module."""

KNOWN_SOLVERS = ("daqp", "highs", "proxsuite")
"""Every back-end the door has an adapter for (installed or not)."""

_SYMMETRY_TOLERANCE = 1e-9
"""Relative asymmetry ``max|P - P^T| / (1 + max|P|)`` above which a Hessian is rejected."""

_CONVEXITY_TOLERANCE = 1e-9
"""Relative negative eigenvalue ``-min eig(P) / (1 + max|eig(P)|)`` above which a Hessian is
rejected as non-convex."""


class SolverFailed(FrcontrolError):
    """Every back-end tried failed on a problem that should be solvable (numerical trouble)."""

    def __init__(self, what: str, statuses: dict[str, str]) -> None:
        self.what = what
        self.statuses = dict(statuses)
        details = "; ".join(f"{name}: {status}" for name, status in self.statuses.items())
        super().__init__(f"{what} failed with every back-end tried ({details})")


@dataclass(frozen=True, eq=False)
class LPResult:
    """Outcome of :func:`solve_lp`.

    Attributes:
        found: ``True`` iff ``status == "optimal"``: ``x`` is an optimum whose primal residual
            passed the door's check.
        status: ``"optimal"``, ``"infeasible"``, ``"unbounded"`` or ``"error"`` (the back-end
            failed, or claimed an optimum the door rejected).
        x: the optimum, shape ``(n,)``, or ``None`` when not found.
        objective: ``c @ x`` at the optimum; ``+inf`` if infeasible, ``-inf`` if unbounded,
            ``nan`` on error.
        solver: name of the back-end.
        solve_time: wall-clock time of the back-end call (set-up and solve) [s].
        raw_status: the back-end's own status, verbatim, plus the door's verdict if it overrode it.
        primal_residual: largest constraint violation at the point the back-end returned
            (``nan`` if it returned none), in the units of the constraints.
        residual_tolerance: the absolute residual the door accepted for this problem (see
            :data:`FEASIBILITY_TOLERANCE`).
    """

    found: bool
    status: Status
    x: np.ndarray | None
    objective: float
    solver: str
    solve_time: float
    raw_status: str
    primal_residual: float
    residual_tolerance: float


@dataclass(frozen=True, eq=False)
class QPResult(LPResult):
    r"""Outcome of :func:`solve_qp`.

    As :class:`LPResult`, with ``objective`` :math:`= \tfrac12 x^\top P x + q^\top x`.
    """


_LP_SOLVERS: dict[str, QPAdapter] = {}
_QP_SOLVERS: dict[str, QPAdapter] = {}
_LEAN_LP_SOLVERS: dict[str, tuple[QPAdapter, LeanAdapter]] = {}
"""Back-ends with a lean form of their LP adapter (:class:`InequalityLPs`): name -> (the LP adapter
it stands for, the lean one). Used only while that adapter is the one registered."""

try:
    from . import daqp_

    _LP_SOLVERS["daqp"] = daqp_.solve_lp
    _LEAN_LP_SOLVERS["daqp"] = (daqp_.solve_lp, daqp_.solve_inequalities)
    _QP_SOLVERS["daqp"] = daqp_.solve_qp
except ImportError:  # pragma: no cover - depends on the environment
    pass

try:
    from . import highs_

    _LP_SOLVERS["highs"] = highs_.solve_lp
    _QP_SOLVERS["highs"] = highs_.solve_qp
except ImportError:  # pragma: no cover
    pass

try:
    from . import proxsuite_

    _LP_SOLVERS["proxsuite"] = proxsuite_.solve_lp
    _QP_SOLVERS["proxsuite"] = proxsuite_.solve_qp
except ImportError:  # pragma: no cover
    pass


def available_solvers() -> list[str]:
    """Names of the installed back-ends, in the order of :data:`KNOWN_SOLVERS`."""
    return [name for name in KNOWN_SOLVERS if name in _LP_SOLVERS]


# ---------------------------------------------------------------------------------------------
# validation


def _array(name: str, value: Any, ndim: int, shape: str, finite: bool) -> np.ndarray:
    """``value`` as a C-contiguous float64 array of ``ndim`` dimensions, without NaN.

    ``shape`` is the expected shape as messages show it, e.g. ``"(m_ub, 3)"``.
    """
    try:
        array = np.ascontiguousarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise InputError(f"{name} is not an array of numbers (expected shape {shape}): {error}") from error
    if array.ndim != ndim:
        raise InputError(f"{name} must have shape {shape}, got shape {array.shape}")
    if finite and not np.isfinite(array).all():
        raise InputError(f"{name} must be finite (no NaN or inf)")
    if not finite and np.isnan(array).any():
        raise InputError(f"{name} contains NaN")
    return array


def _block(name: str, A: Any, b: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``A_name x (<= or =) b_name``: both or neither, ``A`` of shape ``(m, n)``, ``b`` of shape ``(m,)``."""
    if A is None and b is None:
        return np.zeros((0, n)), np.zeros(0)
    if A is None or b is None:
        given, missing = (f"A_{name}", f"b_{name}") if b is None else (f"b_{name}", f"A_{name}")
        raise InputError(f"{given} is given without {missing}: give both (A_{name} of shape (m_{name}, {n}), "
                         f"b_{name} of shape (m_{name},)) or neither")
    A = _array(f"A_{name}", A, 2, f"(m_{name}, {n})", finite=True)
    if A.shape[1] != n:
        raise InputError(f"A_{name} must have shape (m_{name}, {n}), one column per entry of c, got shape "
                         f"{A.shape}")
    b = _array(f"b_{name}", b, 1, f"({A.shape[0]},)", finite=True)
    if b.shape[0] != A.shape[0]:
        raise InputError(f"b_{name} must have shape ({A.shape[0]},), one entry per row of A_{name}, got "
                         f"shape {b.shape}")
    return A, b


def _bound(name: str, value: Any, n: int, default: float) -> np.ndarray:
    """A lower (``default`` -inf) or upper (+inf) bound: a scalar or shape ``(n,)``; None: no bound."""
    if value is None:
        return np.full(n, default)
    if np.ndim(value) == 0:
        try:
            scalar = float(value)
        except (TypeError, ValueError) as error:
            raise InputError(f"{name} is not a number (expected a scalar or shape ({n},)): {error}") \
                from error
        if scalar != scalar or scalar == -default:
            raise InputError(f"{name} must be finite or {default:+} (no bound), got {scalar}")
        return np.full(n, scalar)
    bound = _array(name, value, 1, f"({n},)", finite=False)
    if bound.shape != (n,):
        raise InputError(f"{name} must be a scalar or have shape ({n},), one entry per entry of c, got shape "
                         f"{bound.shape}")
    if (bound == -default).any():
        raise InputError(f"{name} must not contain {-default:+} (entry {int(np.argmax(bound == -default))})")
    return bound


def _validate_lp(
    c: Any, A_ub: Any, b_ub: Any, A_eq: Any, b_eq: Any, lb: Any, ub: Any
) -> LinearProgram:
    c = _array("c", c, 1, "(n,)", finite=True)
    n = c.shape[0]
    if n == 0:
        raise InputError("c must have shape (n,) with n >= 1 (one cost per variable), got shape (0,)")
    A_ub, b_ub = _block("ub", A_ub, b_ub, n)
    A_eq, b_eq = _block("eq", A_eq, b_eq, n)
    lb = _bound("lb", lb, n, -np.inf)
    ub = _bound("ub", ub, n, np.inf)
    return LinearProgram(c, A_ub, b_ub, A_eq, b_eq, lb, ub)


def _validate_qp(P: Any, problem: LinearProgram) -> np.ndarray:
    n = problem.n
    P = _array("P", P, 2, f"({n}, {n})", finite=True)
    if P.shape != (n, n):
        raise InputError(f"P must be a finite ({n}, {n}) matrix, got shape {P.shape}")
    size = 1.0 + np.max(np.abs(P))
    if np.max(np.abs(P - P.T)) > _SYMMETRY_TOLERANCE * size:
        raise InputError("P is not symmetric")
    P = np.ascontiguousarray(0.5 * (P + P.T))
    eigenvalues = np.linalg.eigvalsh(P)
    if eigenvalues[0] < -_CONVEXITY_TOLERANCE * (1.0 + np.max(np.abs(eigenvalues))):
        raise InputError(f"P is not positive semi-definite (eigenvalue {eigenvalues[0]:.3g})")
    return P


def primal_residual(problem: LinearProgram, x: np.ndarray) -> float:
    r"""Largest violation of the constraints of ``problem`` at ``x`` (0 if ``x`` is feasible).

    .. math::

        \max\big(0,\ \max(A_{ub}x - b_{ub}),\ \max|A_{eq}x - b_{eq}|,\
        \max(lb - x),\ \max(x - ub)\big)
    """
    worst = 0.0
    if problem.A_ub.shape[0]:
        worst = max(worst, float((problem.A_ub @ x - problem.b_ub).max()))
    if problem.A_eq.shape[0]:
        worst = max(worst, float(np.abs(problem.A_eq @ x - problem.b_eq).max()))
    if problem.has_bounds and x.shape[0]:
        # max(lb - x) and max(x - ub) in one reduction (the same largest entry)
        worst = max(worst, float(np.maximum(problem.lb - x, x - problem.ub).max()))
    return worst


def _largest(values: np.ndarray, where: np.ndarray | bool = True) -> float:
    """The largest entry (where ``where``), at least 0: one reduction, no wrapper."""
    return float(np.maximum.reduce(values, where=where, initial=0.0))


def _residual_tolerance(problem: LinearProgram, x: np.ndarray | None,
                        tolerance: float = FEASIBILITY_TOLERANCE) -> float:
    """``tolerance`` times the scale of the terms (see :data:`FEASIBILITY_TOLERANCE`)."""
    return tolerance * _residual_scale(problem, x)


def _residual_scale(problem: LinearProgram, x: np.ndarray | None) -> float:
    """The scale of the terms that the feasibility tolerance multiplies."""
    # the finite right-hand sides (an unvalidated problem may hold inf), in one reduction
    parts = (problem.b_ub, problem.b_eq, problem.lb, problem.ub) if problem.has_bounds else (
        problem.b_ub, problem.b_eq)
    magnitude = np.abs(np.concatenate(parts))
    scale = 1.0 + _largest(magnitude, where=magnitude < np.inf)
    if x is not None and x.shape[0]:
        size = float(np.abs(x).max())
        for A in (problem.A_ub, problem.A_eq):
            if A.shape[0]:
                scale += float(np.add.reduce(np.abs(A), axis=1).max()) * size
    return scale


ResidualCheck = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                          np.ndarray | None, bool], tuple[float, float]]
"""How an answer is checked: ``(A_ub, b_ub, A_eq, b_eq, lb, ub, x, has_bounds) -> (residual, scale)``
(:func:`lp_check`, or the compiled kernel's, which its callers hand to the door)."""


def lp_check(A_ub: np.ndarray, b_ub: np.ndarray, A_eq: np.ndarray, b_eq: np.ndarray, lb: np.ndarray,
             ub: np.ndarray, x: np.ndarray | None, has_bounds: bool) -> tuple[float, float]:
    """:func:`primal_residual` (NaN without ``x``) and the scale the feasibility tolerance multiplies.

    The door's check of an answer, in NumPy; the compiled kernel's ``lp_check`` (the backend's,
    :func:`frcontrol.kernel.backend`) computes the same sums in another order (equal to round-off,
    see tests/test_kernel.py).
    """
    problem = LinearProgram(np.zeros(A_ub.shape[1]), A_ub, b_ub, A_eq, b_eq, lb, ub)
    problem.__dict__["_has_bounds"] = bool(has_bounds)  # as the caller decided it (LinearProgram.has_bounds)
    residual = float("nan") if x is None else primal_residual(problem, x)
    return residual, _residual_scale(problem, x)


def _check(problem: LinearProgram, x: np.ndarray | None, tolerance: float,
           check: ResidualCheck = lp_check) -> tuple[float, float]:
    """:func:`primal_residual` (NaN without ``x``) and :func:`_residual_tolerance`, by ``check``."""
    if check is lp_check:  # NumPy's, on the problem as it is
        residual = float("nan") if x is None else primal_residual(problem, x)
        return residual, _residual_tolerance(problem, x, tolerance)
    residual, scale = check(problem.A_ub, problem.b_ub, problem.A_eq, problem.b_eq, problem.lb, problem.ub, x,
                            problem.has_bounds)
    return residual, tolerance * scale


def _adapter(registry: dict[str, QPAdapter], solver: str) -> QPAdapter:
    if solver not in registry:
        if solver == os.environ.get(LP_SOLVER_ENVIRONMENT_VARIABLE, "").strip().lower():
            raise SolverNotFound(solver, available_solvers(), LP_SOLVER_ENVIRONMENT_VARIABLE)
        raise SolverNotFound(solver, available_solvers())
    return registry[solver]


def _finish(
    result_type: type[LPResult],
    problem: LinearProgram,
    raw: RawSolution,
    solver: str,
    solve_time: float,
    P: np.ndarray | None,
    tolerance: float,
    check: ResidualCheck = lp_check,
) -> LPResult:
    """The door's result of a back-end's answer ``raw`` to ``problem`` (:func:`_result`)."""
    return _result(result_type, problem.c, raw.status, raw.raw_status, raw.x, solver, solve_time, P,
                   lambda x: _check(problem, x, tolerance, check))


def _result(
    result_type: type[LPResult],
    c: np.ndarray,
    status: Status,
    raw_status: str,
    x: np.ndarray | None,
    solver: str,
    solve_time: float,
    P: np.ndarray | None,
    check: Callable[[np.ndarray | None], tuple[float, float]],
) -> LPResult:
    """The result of an answer: ``x`` checked (shape, finite, then ``check``'s residual and tolerance).

    An "optimal" answer whose residual exceeds its tolerance becomes ``"error"``: the back-end's
    flag alone is never trusted.
    """
    if x is not None:
        x = np.ascontiguousarray(x, dtype=np.float64).reshape(-1)
        if x.shape != c.shape or np.count_nonzero(np.isfinite(x)) < x.shape[0]:
            status, raw_status, x = "error", raw_status + "; door: x malformed or not finite", None
    residual, tolerance = check(x)
    if status == "optimal" and not residual <= tolerance:
        status = "error"
        raw_status += f"; door: primal residual {residual:.3g} > {tolerance:.3g}, rejected"
    if status != "optimal":
        x = None
    objective = _OBJECTIVE_WITHOUT_OPTIMUM.get(status, np.nan)
    if x is not None:
        objective = float(c.dot(x))  # c @ x's BLAS dot, without the matmul ufunc's overhead
        if P is not None:
            objective += 0.5 * float(x @ P @ x)
    # the frozen dataclass's fields set at once (its __init__ sets them one object.__setattr__ each)
    result = _new_object(result_type)
    result.__dict__.update(
        found=status == "optimal",
        status=status,
        x=x,
        objective=float(objective),
        solver=solver,
        solve_time=solve_time,
        raw_status=raw_status,
        primal_residual=residual,
        residual_tolerance=tolerance,
    )
    return result


_new_object = object.__new__


_OBJECTIVE_WITHOUT_OPTIMUM = {"infeasible": np.inf, "unbounded": -np.inf}
"""The objective reported without an optimum, by status (``nan`` for an error)."""


def _bounds_crossed(problem: LinearProgram) -> RawSolution | None:
    if np.count_nonzero(problem.lb > problem.ub):  # infinite bounds never cross
        return RawSolution("infeasible", None, "door: lb > ub")
    return None


# ---------------------------------------------------------------------------------------------
# the door


@dataclass(frozen=True)
class Fallback:
    """What the door does when the chosen back-end's answer is not usable.

    One policy object, instead of a "retry with HiGHS" wrapper per module.

    Attributes:
        retry_on: statuses of the first answer that send the problem to the second back-end:
            :data:`REFERENCE_LP_SOLVER`, or :data:`DEFAULT_LP_SOLVER` when the first one was the
            reference (two opinions, never the same back-end twice).
        accept: statuses that count as an answer. The second back-end's answer is preferred
            when it counts, then the first's.
        failure: when neither answer counts: raise :class:`SolverFailed` naming this
            computation; None returns the last answer as it is.
    """

    retry_on: frozenset[str] = frozenset()
    accept: frozenset[str] = frozenset({"optimal", "infeasible", "unbounded", "error"})
    failure: str | None = None


NO_FALLBACK = Fallback()
"""The first back-end's answer, whatever it is."""

RETRY_ERRORS = Fallback(retry_on=frozenset({"error", "unbounded"}))
"""An error or an "unbounded" answer (DAQP 0.11 called a bounded, very degenerate LP of 951 rows
unbounded) is solved again by the other back-end, whose answer is returned."""

CONFIRM_INFEASIBLE = Fallback(retry_on=frozenset({"error", "unbounded", "infeasible"}))
"""As :data:`RETRY_ERRORS`, and an "infeasible" verdict is confirmed too (where a false one
would drop a plan or claim that a mode is excluded)."""


def must_solve(what: str, *, bounded: bool = True, retry_unbounded: bool = True) -> Fallback:
    """A policy for an LP that must have an answer, or :class:`SolverFailed` naming ``what``.

    Errors (and "unbounded", when ``bounded``) are not answers; the other back-end is asked.

    Args:
        what: the computation, for the error message.
        bounded: the LP is known to be bounded, so "unbounded" is a failure.
        retry_unbounded: ask the other back-end after an "unbounded" answer too.
    """
    accept = {"optimal", "infeasible"} | (set() if bounded else {"unbounded"})
    retry = {"error"} | ({"unbounded"} if retry_unbounded else set())
    return Fallback(retry_on=frozenset(retry), accept=frozenset(accept), failure=what)


def lp_problem(
    c: Any,
    A_ub: Any = None,
    b_ub: Any = None,
    A_eq: Any = None,
    b_eq: Any = None,
    lb: Any = None,
    ub: Any = None,
    *,
    validate: bool = True,
) -> LinearProgram:
    """The door's problem object for an LP (see :func:`solve_lp` for its form).

    Args:
        c: cost, shape ``(n,)``.
        A_ub: inequality matrix, shape ``(m_ub, n)``, or ``None``.
        b_ub: inequality right-hand side, shape ``(m_ub,)``, or ``None``.
        A_eq: equality matrix, shape ``(m_eq, n)``, or ``None``.
        b_eq: equality right-hand side, shape ``(m_eq,)``, or ``None``.
        lb: lower bounds, a scalar or shape ``(n,)``, ``-inf`` allowed; ``None`` = no bound.
        ub: upper bounds, a scalar or shape ``(n,)``, ``+inf`` allowed; ``None`` = no bound.
        validate: check shapes and values (False: arrays frcontrol built itself, of consistent
            shapes with no NaN; they are only made C-contiguous float64, which DAQP and the
            compiled check need).

    Raises:
        InputError: malformed arrays (shapes, NaN, infinite entries in matrices), when validated.
    """
    if validate:
        return _validate_lp(c, A_ub, b_ub, A_eq, b_eq, lb, ub)
    n = c.shape[0]

    def contiguous(array: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(array, dtype=np.float64)  # no copy for float64 already contiguous

    return LinearProgram(
        contiguous(c),
        contiguous(A_ub) if A_ub is not None else np.zeros((0, n)),
        contiguous(b_ub) if b_ub is not None else np.zeros(0),
        contiguous(A_eq) if A_eq is not None else np.zeros((0, n)),
        contiguous(b_eq) if b_eq is not None else np.zeros(0),
        contiguous(lb) if lb is not None else np.full(n, -np.inf),
        contiguous(ub) if ub is not None else np.full(n, np.inf),
    )


def solve(problem: LinearProgram, *, solver: str | None = None, settings: SolverSettings | None = None,
          fallback: Fallback = NO_FALLBACK, check: ResidualCheck = lp_check, **options: Any) -> LPResult:
    """The door: solve an LP with the chosen back-end, then as ``fallback`` says.

    The back-end is ``settings.lp`` (or ``solver``, a name: :func:`settings_from`). Every answer's
    primal residual is checked (an "optimal" answer above ``settings.feasibility_tolerance``, by
    default :data:`FEASIBILITY_TOLERANCE`, becomes ``"error"``). ``options`` go to the chosen
    back-end, over its options in ``settings``; a second back-end runs with its own options in
    ``settings`` (none by default). ``check`` computes the residual and its scale (:func:`lp_check`,
    or the compiled kernel's twin, which callers that use the kernel hand in: the door does not
    import the kernel).

    Raises:
        SolverNotFound: the back-end is unknown or not installed.
        SolverFailed: no answer counts and ``fallback.failure`` names the computation.
        InputError: ``solver`` contradicts ``settings``.
    """
    chosen = settings_from(solver, settings)
    if chosen.options:
        options = {**chosen.options_for(chosen.lp), **options}
    first = _solve_once(problem, chosen.lp, options, chosen.feasibility_tolerance, check)
    return _settle(problem, first, chosen, fallback, check)


def _settle(problem: LinearProgram, first: LPResult, settings: SolverSettings,
            fallback: Fallback, check: ResidualCheck = lp_check) -> LPResult:
    """:func:`solve` after the first back-end's answer ``first``: the fallback policy."""
    solver = settings.lp
    if first.status not in fallback.retry_on:
        if first.status in fallback.accept or fallback.failure is None:
            return first
        raise SolverFailed(fallback.failure, {solver: first.raw_status})
    second_name = REFERENCE_LP_SOLVER if solver != REFERENCE_LP_SOLVER else DEFAULT_LP_SOLVER
    if second_name == solver or second_name not in _LP_SOLVERS:
        answers = [first]
    else:
        answers = [_solve_once(problem, second_name, settings.options_for(second_name),
                               settings.feasibility_tolerance, check), first]
    for answer in answers:
        if answer.status in fallback.accept:
            return answer
    if fallback.failure is None:
        return answers[0]
    raise SolverFailed(fallback.failure, {a.solver: a.raw_status for a in reversed(answers)})


def _solve_once(problem: LinearProgram, solver: str, options: dict[str, Any], tolerance: float,
                check: ResidualCheck = lp_check) -> LPResult:
    return _timed(_adapter(_LP_SOLVERS, solver), problem, solver, options, LPResult, tolerance, check)


def _timed(adapter: QPAdapter, problem: LinearProgram, solver: str, options: dict[str, Any],
           result_type: type[LPResult], tolerance: float, check: ResidualCheck = lp_check) -> LPResult:
    """One back-end's answer, timed and checked by :func:`_finish` (crossed bounds answer alone)."""
    start = time.perf_counter()
    raw = _bounds_crossed(problem) or adapter(problem, **options)
    elapsed = time.perf_counter() - start
    P = problem.P if isinstance(problem, QuadraticProgram) else None
    return _finish(result_type, problem, raw, solver, elapsed, P, tolerance, check)


@dataclass(frozen=True)
class DoorOptions:
    """How :func:`solve_lp` and :func:`solve_lp_prepared` solve: the door's keywords as one record.

    Attributes:
        settings: the back-ends, their options (``settings.options``, e.g. DAQP's ``primal_tol``:
            :meth:`SolverSettings.with_options`) and the residual tolerance
            (:class:`SolverSettings`). A back-end name becomes settings by :func:`settings_from`.
        fallback: what to do when the answer is not usable (:class:`Fallback`), named at the call
            (:data:`NO_FALLBACK`, :data:`RETRY_ERRORS`, :data:`CONFIRM_INFEASIBLE`,
            :func:`must_solve`).
        check: how an answer is checked (:data:`ResidualCheck`; :func:`lp_check`, or the compiled
            kernel's twin, which callers that use the kernel hand in: the door does not import it).
    """

    settings: SolverSettings = DEFAULT_SETTINGS
    fallback: Fallback = NO_FALLBACK
    check: ResidualCheck = lp_check

    def __post_init__(self) -> None:
        if not isinstance(self.settings, SolverSettings):
            raise InputError(f"DoorOptions.settings must be a SolverSettings (a back-end name becomes one by "
                             f"settings_from), got {self.settings!r}")
        if not isinstance(self.fallback, Fallback):
            raise InputError(f"DoorOptions.fallback must be a Fallback, got {self.fallback!r}")
        if not callable(self.check):
            raise InputError(f"DoorOptions.check must be a residual check (lp_check), got {self.check!r}")


DEFAULT_DOOR = DoorOptions()
"""The door's defaults: :data:`DEFAULT_SETTINGS`, :data:`NO_FALLBACK`, :func:`lp_check`."""


def solve_lp(
    c: Any,
    A_ub: Any = None,
    b_ub: Any = None,
    A_eq: Any = None,
    b_eq: Any = None,
    lb: Any = None,
    ub: Any = None,
    *,
    door: DoorOptions = DEFAULT_DOOR,
) -> LPResult:
    r"""Solve a linear program: :func:`solve` of :func:`lp_problem`, the arrays validated.

    minimise :math:`c^\top x` s.t. :math:`A_{ub}x \le b_{ub}`, :math:`A_{eq}x = b_{eq}`,
    :math:`lb \le x \le ub`.

    Args:
        c: cost, shape ``(n,)``.
        A_ub: inequality matrix, shape ``(m_ub, n)``, or ``None``.
        b_ub: inequality right-hand side, shape ``(m_ub,)``, or ``None``.
        A_eq: equality matrix, shape ``(m_eq, n)``, or ``None``.
        b_eq: equality right-hand side, shape ``(m_eq,)``, or ``None``.
        lb: lower bounds, a scalar or shape ``(n,)``, ``-inf`` allowed; ``None`` = no bound.
        ub: upper bounds, a scalar or shape ``(n,)``, ``+inf`` allowed; ``None`` = no bound.
        door: the back-ends with their options and tolerance, the fallback policy and the
            residual check (:class:`DoorOptions`); default :data:`DEFAULT_DOOR`.

    Returns:
        The result; an infeasible or unbounded LP gives ``found=False`` and the status.

    Raises:
        InputError: malformed arrays (shapes, NaN, infinite entries in matrices) or options.
        SolverNotFound: ``door.settings.lp`` is unknown or not installed.
        SolverFailed: see :func:`solve`.
    """
    return _solve_with(lp_problem(c, A_ub, b_ub, A_eq, b_eq, lb, ub), door)


def solve_lp_prepared(
    c: np.ndarray,
    A_ub: np.ndarray | None = None,
    b_ub: np.ndarray | None = None,
    A_eq: np.ndarray | None = None,
    b_eq: np.ndarray | None = None,
    lb: np.ndarray | None = None,
    ub: np.ndarray | None = None,
    *,
    door: DoorOptions = DEFAULT_DOOR,
) -> LPResult:
    """:func:`solve_lp` without validation: for arrays frcontrol built itself (see :func:`lp_problem`).

    Internal hot paths (domains, projections, overlaps) use this; user-facing calls go through
    :func:`solve_lp`. The residual check is the door's usual one.
    """
    return _solve_with(lp_problem(c, A_ub, b_ub, A_eq, b_eq, lb, ub, validate=False), door)


def _solve_with(problem: LinearProgram, door: DoorOptions) -> LPResult:
    if not isinstance(door, DoorOptions):
        raise InputError(f"door must be a DoorOptions (settings, fallback, check), got {door!r}")
    return solve(problem, settings=door.settings, fallback=door.fallback, check=door.check)


_NO_CONSTRAINTS: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
"""Per number of variables n: an empty equality block ``(0, n)``, ``(0,)`` and the absent bounds
``-inf``, ``+inf`` of shape ``(n,)``, read-only, for the residual check of :class:`InequalityLPs`."""


def _no_constraints(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    if n not in _NO_CONSTRAINTS:
        arrays = (np.zeros((0, n)), np.zeros(0), np.full(n, -np.inf), np.full(n, np.inf))
        for array in arrays:
            array.flags.writeable = False
        _NO_CONSTRAINTS[n] = arrays
    return _NO_CONSTRAINTS[n]


class InequalityLPs:
    r"""The door's lean path for many small LPs without equalities, on arrays frcontrol built itself.

    The LPs: :math:`\min c^\top x` s.t. :math:`A_{ub} x \le b_{ub}`, :math:`lb \le x \le ub`.
    Made once for a run of LPs (the redundancy LPs of a pruning, a Chebyshev LP, the engine's
    motion LPs): the back-end, its options and the fallback policy are looked up once, not per LP;
    ``check`` checks each answer (:func:`lp_check`, or the compiled kernel's twin of it, which the
    callers that use the kernel hand in: the door does not import the kernel). Each
    :meth:`solve` then returns what ``solve_lp_prepared(c, A_ub, b_ub, lb=lb, ub=ub,
    door=DoorOptions(settings, fallback, check))`` returns, field for field (the time aside): the
    same back-end call on the same arrays, the same residual check of every answer (an
    "optimal" answer above :data:`FEASIBILITY_TOLERANCE` becomes ``"error"``), the same fallback.
    It skips the general door's per-call work: no problem object, no option handling, DAQP's
    arrays built directly (the back-end's lean adapter, ``LeanAdapter``). A back-end without a
    lean adapter, a replaced adapter, options, crossed bounds or a retry take the general door.

    Raises:
        SolverNotFound: ``solver`` is unknown or not installed (when made).
        SolverFailed: see :func:`solve` (from :meth:`solve`).
    """

    __slots__ = ("solver", "settings", "fallback", "options", "_lean", "_check", "_fixed_bounds")

    def __init__(self, *, solver: str | None = None, settings: SolverSettings | None = None,
                 fallback: Fallback = NO_FALLBACK, check: ResidualCheck = lp_check, **options: Any) -> None:
        chosen = settings_from(solver, settings)
        solver = chosen.lp
        if chosen.options:
            options = {**chosen.options_for(solver), **options}
        adapter = _adapter(_LP_SOLVERS, solver)
        lean = _LEAN_LP_SOLVERS.get(solver)
        self.solver, self.settings, self.fallback, self.options = solver, chosen, fallback, options
        self._lean = lean[1] if lean is not None and lean[0] is adapter and not options else None
        self._check = check
        # the last read-only (lb, ub) pair and whether it has a finite entry and crosses: a run of
        # LPs over the same fixed bounds (e.g. geometry.margin_bounds') reads them once
        self._fixed_bounds: tuple[np.ndarray, np.ndarray, bool, bool] | None = None

    def _bounds_read(self, lb: np.ndarray, ub: np.ndarray, no_lb: np.ndarray, no_ub: np.ndarray
                     ) -> tuple[bool, bool]:
        """Whether ``lb``/``ub`` have a finite entry, and whether they cross (``lb > ub`` somewhere).

        Read-only bounds that own their data are taken as constant: the same pair as the last
        call's is not read again (a read-only view of data written elsewhere is read every time).
        """
        fixed = self._fixed_bounds
        if fixed is not None and lb is fixed[0] and ub is fixed[1]:
            return fixed[2], fixed[3]
        has_bounds = lb is not no_lb or ub is not no_ub
        if has_bounds:
            has_bounds = bool(np.count_nonzero(np.isfinite(lb)) or np.count_nonzero(np.isfinite(ub)))
        crossed = has_bounds and bool(np.count_nonzero(lb > ub))
        if not (lb.flags.writeable or ub.flags.writeable) and lb.base is None and ub.base is None:
            self._fixed_bounds = (lb, ub, has_bounds, crossed)
        return has_bounds, crossed

    def solve(self, c: np.ndarray, A_ub: np.ndarray, b_ub: np.ndarray, lb: np.ndarray | None = None,
              ub: np.ndarray | None = None) -> LPResult:
        """:func:`solve_lp_prepared` of the LP (``lb``/``ub``: shape ``(n,)`` or None, infinities allowed)."""
        c = np.ascontiguousarray(c, dtype=np.float64)
        A_ub = np.ascontiguousarray(A_ub, dtype=np.float64)
        b_ub = np.ascontiguousarray(b_ub, dtype=np.float64)
        n = c.shape[0]
        A_eq, b_eq, no_lb, no_ub = _no_constraints(n)
        lb = no_lb if lb is None else np.ascontiguousarray(lb, dtype=np.float64)
        ub = no_ub if ub is None else np.ascontiguousarray(ub, dtype=np.float64)
        has_bounds, crossed = self._bounds_read(lb, ub, no_lb, no_ub)
        if self._lean is None or crossed:
            return solve(LinearProgram(c, A_ub, b_ub, A_eq, b_eq, lb, ub), settings=self.settings,
                         fallback=self.fallback, check=self._check, **self.options)
        # DAQP's binding takes writable buffers (it does not write them)
        c, A_ub, b_ub = (a if a.flags.writeable else a.copy() for a in (c, A_ub, b_ub))
        start = time.perf_counter()
        status, x, raw = self._lean(c, A_ub, b_ub, lb if has_bounds else None, ub if has_bounds else None)
        elapsed = time.perf_counter() - start

        tolerance = self.settings.feasibility_tolerance

        def check(x: np.ndarray | None) -> tuple[float, float]:
            residual, scale = self._check(A_ub, b_ub, A_eq, b_eq, lb, ub, x, has_bounds)
            return residual, tolerance * scale

        first = _result(LPResult, c, status, raw, x, self.solver, elapsed, None, check)
        fallback = self.fallback
        if first.status not in fallback.retry_on and (
                first.status in fallback.accept or fallback.failure is None):
            return first
        return _settle(LinearProgram(c, A_ub, b_ub, A_eq, b_eq, lb, ub), first, self.settings, fallback,
                       self._check)


def qp_problem(
    P: Any,
    q: Any,
    A_ub: Any = None,
    b_ub: Any = None,
    A_eq: Any = None,
    b_eq: Any = None,
    lb: Any = None,
    ub: Any = None,
) -> QuadraticProgram:
    r"""The door's problem object for a QP, validated.

    Minimise :math:`\tfrac12 x^\top P x + q^\top x` under the constraints of :func:`solve_lp`.

    Args:
        P: symmetric positive semi-definite Hessian, shape ``(n, n)``.
        q: linear cost, shape ``(n,)``.
        A_ub: inequality matrix, shape ``(m_ub, n)``, or ``None``.
        b_ub: inequality right-hand side, or ``None``.
        A_eq: equality matrix, shape ``(m_eq, n)``, or ``None``.
        b_eq: equality right-hand side, or ``None``.
        lb: lower bounds (scalar or ``(n,)``), or ``None``.
        ub: upper bounds (scalar or ``(n,)``), or ``None``.

    Raises:
        InputError: malformed arrays, a non-symmetric or non-convex ``P``.
    """
    lp = _validate_lp(q, A_ub, b_ub, A_eq, b_eq, lb, ub)
    P = _validate_qp(P, lp)
    return QuadraticProgram(lp.c, lp.A_ub, lp.b_ub, lp.A_eq, lp.b_eq, lp.lb, lp.ub, P=P)


def solve_qp(problem: QuadraticProgram, *, solver: str | None = None,
             settings: SolverSettings | None = None) -> QPResult:
    r"""Solve a QP built by :func:`qp_problem` (build, then solve).

    Args:
        problem: the QP (:func:`qp_problem`).
        solver: back-end name (see :func:`available_solvers`); default ``settings.qp``.
        settings: the back-ends, their options (``settings.options``, passed on verbatim) and the
            residual tolerance (:class:`SolverSettings`); default :data:`DEFAULT_SETTINGS`.

    Returns:
        The result (``found=False`` with the status if infeasible or unbounded).

    Raises:
        InputError: ``problem`` is not a :class:`QuadraticProgram`, ``solver`` contradicts
            ``settings``, bad options.
        SolverNotFound: ``solver`` is unknown or not installed.
    """
    if not isinstance(problem, QuadraticProgram):
        raise InputError(f"solve_qp takes the problem that qp_problem(P, q, ...) builds, got "
                         f"{type(problem).__name__}")
    chosen = settings or DEFAULT_SETTINGS
    if solver is not None and settings is not None and solver != settings.qp:
        raise InputError(f"solver={solver!r} contradicts settings.qp={settings.qp!r}; give one of them")
    solver = chosen.qp if solver is None else solver
    adapter = _adapter(_QP_SOLVERS, solver)
    return cast(QPResult, _timed(adapter, problem, solver, chosen.options_for(solver), QPResult,
                                 chosen.feasibility_tolerance))
