"""Problem containers shared by the door (:mod:`frcontrol.solvers`) and the back-end adapters.

The door validates the user's arrays once and hands every adapter the same normalised problem:
C-contiguous ``float64`` arrays, absent blocks replaced by arrays with zero rows, and simple
bounds always present (``-inf`` / ``+inf`` where there is none). An adapter never sees ``None``
and never has to copy for contiguity.

An adapter is a function ``adapter(problem, **options) -> RawSolution``. It maps the back-end's
own status onto the four statuses of the door and returns the primal point when it has one. The
door times the call, computes the objective and the primal residual, and builds the result.
A back-end module writes one function ``solve(H, problem, options)`` (``H`` None for an LP, the
QP's ``P`` otherwise) and gets both adapters from :class:`Adapter`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

Status = Literal["optimal", "infeasible", "unbounded", "error"]
"""Outcome of a solve, common to every back-end."""


@dataclass(frozen=True, eq=False)
class LinearProgram:
    r"""A validated linear program, as every adapter receives it.

    minimise :math:`c^\top x` subject to :math:`A_{ub} x \le b_{ub}`, :math:`A_{eq} x = b_{eq}`,
    :math:`lb \le x \le ub`.

    Attributes:
        c: cost, shape ``(n,)``.
        A_ub: inequality matrix, shape ``(m_ub, n)`` (``m_ub`` may be 0).
        b_ub: inequality right-hand side, shape ``(m_ub,)``, finite.
        A_eq: equality matrix, shape ``(m_eq, n)`` (``m_eq`` may be 0).
        b_eq: equality right-hand side, shape ``(m_eq,)``, finite.
        lb: lower bounds, shape ``(n,)``, entries in ``[-inf, +inf)``.
        ub: upper bounds, shape ``(n,)``, entries in ``(-inf, +inf]``, ``lb <= ub``.
    """

    c: np.ndarray
    A_ub: np.ndarray
    b_ub: np.ndarray
    A_eq: np.ndarray
    b_eq: np.ndarray
    lb: np.ndarray
    ub: np.ndarray

    @property
    def n(self) -> int:
        """Number of variables."""
        return int(self.c.shape[0])

    @property
    def has_bounds(self) -> bool:
        """Whether at least one simple bound is finite (computed once per problem)."""
        # cached by hand: functools.cached_property takes a lock per first access on Python 3.11
        cached = self.__dict__.get("_has_bounds")
        if cached is None:
            cached = bool(np.count_nonzero(np.isfinite(self.lb)) or np.count_nonzero(np.isfinite(self.ub)))
            self.__dict__["_has_bounds"] = cached
        return cached


@dataclass(frozen=True, eq=False, kw_only=True)
class QuadraticProgram(LinearProgram):
    r"""A validated convex quadratic program, as every adapter receives it.

    minimise :math:`\tfrac12 x^\top P x + c^\top x` under the constraints of
    :class:`LinearProgram`.

    Attributes:
        P: symmetric positive semi-definite Hessian, shape ``(n, n)``.
    """

    P: np.ndarray


@dataclass(frozen=True, eq=False)
class RawSolution:
    """What an adapter returns to the door.

    Attributes:
        status: the back-end's outcome mapped onto the door's four statuses.
        x: the primal point the back-end returned (``None`` if it returned none).
        raw_status: the back-end's own status, verbatim (e.g. ``"exitflag=1"``).
    """

    status: Status
    x: np.ndarray | None
    raw_status: str


LPAdapter = Callable[..., RawSolution]
"""Signature of an adapter: ``adapter(problem: LinearProgram, **options) -> RawSolution``."""

QPAdapter = Callable[..., RawSolution]
"""Signature of an adapter: ``adapter(problem: QuadraticProgram, **options) -> RawSolution``."""

LeanAdapter = Callable[
    [np.ndarray, np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None],
    tuple[Status, np.ndarray | None, str]]
"""A back-end's lean LP adapter (optional): ``lean(c, A_ub, b_ub, lb, ub) -> (status, x, raw_status)``
for an LP without equalities, its arrays C-contiguous ``float64`` (``A_ub`` writable), ``lb`` and
``ub`` None when no bound is finite; the same answer as its adapter on the same problem."""

ProgramSolver = Callable[[np.ndarray | None, LinearProgram, dict[str, Any]], RawSolution]
"""A back-end's one solve: ``solve(H, problem, options)``, ``H`` None for an LP, ``P`` for a QP."""


@dataclass(frozen=True)
class Adapter:
    """A back-end's two adapters, both on its one :data:`ProgramSolver`.

    Attributes:
        solve: the back-end's ``solve(H, problem, options)``; it raises
            :class:`~frcontrol.errors.InputError` for an option the back-end does not know.
    """

    solve: ProgramSolver

    def solve_lp(self, problem: LinearProgram, **options: Any) -> RawSolution:
        """Solve an LP: the mapped status, the primal point and the back-end's own status."""
        return self.solve(None, problem, options)

    def solve_qp(self, problem: QuadraticProgram, **options: Any) -> RawSolution:
        """Solve a convex QP (``P`` is the back-end's Hessian), as :meth:`solve_lp`."""
        return self.solve(problem.P, problem, options)


__all__ = [
    "Adapter",
    "LeanAdapter",
    "LinearProgram",
    "ProgramSolver",
    "QuadraticProgram",
    "RawSolution",
]
