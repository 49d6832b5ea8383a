r"""Adapter for HiGHS (simplex / interior point), called through ``highspy`` directly.

HiGHS solves

.. math::

    \min_x c^\top x + \tfrac12 x^\top Q x \quad\text{s.t.}\quad
    r_{lower} \le A x \le r_{upper},\; l \le x \le u,

with ``±inf`` for absent bounds. We pass the rows row-wise (CSR): the inequalities with
``r_lower = -inf``, then the equalities with ``r_lower = r_upper = b_eq``. A Hessian is passed as
its lower triangle, column-wise (``HessianFormat.kTriangular``).

HiGHS is the reference back-end (:data:`frcontrol.solvers.REFERENCE_LP_SOLVER`): slower than DAQP
on small dense problems (0.3-1.6 ms against 7-40 us on this machine) but robust. When presolve
can only tell "infeasible or unbounded", we solve again without presolve to get which; when it
ends on another status ("Unknown"...), we retry with other algorithms (:data:`RETRIES`).

An "Infeasible" verdict is confirmed without presolve: HiGHS 1.15.1's presolve declared the
feasible, unbounded LP ``max a.x`` over 5 rows in 3 free variables (from the polytope tests)
infeasible (simplex and IPM alike); without presolve it answers "Unbounded". Infeasible LPs
therefore cost two solves with HiGHS.

The HiGHS option named ``solver`` cannot be passed through the door (the name is the door's);
the other options are passed by name.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from collections.abc import Iterator

import highspy
import numpy as np

from frcontrol.errors import InputError

from ._common import Adapter, LinearProgram, RawSolution, Status

_STATUS: dict[highspy.HighsModelStatus, Status] = {
    highspy.HighsModelStatus.kOptimal: "optimal",
    highspy.HighsModelStatus.kInfeasible: "infeasible",
    highspy.HighsModelStatus.kUnbounded: "unbounded",
}


def _csr(M: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Compressed sparse row arrays ``(start, index, value)`` of a dense matrix."""
    rows, cols = np.nonzero(M)
    start = np.zeros(M.shape[0] + 1, dtype=np.int32)
    np.cumsum(np.bincount(rows, minlength=M.shape[0]), out=start[1:])
    return start, cols.astype(np.int32), M[rows, cols]


def _build_lp(problem: LinearProgram) -> highspy.HighsLp:
    lp = highspy.HighsLp()
    A = np.vstack([problem.A_ub, problem.A_eq])
    lp.num_col_ = problem.n
    lp.num_row_ = A.shape[0]
    lp.col_cost_ = problem.c
    lp.col_lower_ = problem.lb
    lp.col_upper_ = problem.ub
    lp.row_lower_ = np.concatenate([np.full(problem.A_ub.shape[0], -np.inf), problem.b_eq])
    lp.row_upper_ = np.concatenate([problem.b_ub, problem.b_eq])
    start, index, value = _csr(A)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
    lp.a_matrix_.num_row_ = A.shape[0]
    lp.a_matrix_.num_col_ = problem.n
    lp.a_matrix_.start_ = start
    lp.a_matrix_.index_ = index
    lp.a_matrix_.value_ = value
    return lp


def _hessian(P: np.ndarray) -> highspy.HighsHessian:
    """Lower triangle of ``P``, column-wise, as HiGHS wants it."""
    lower = np.tril(P)
    # column-wise lower triangle = row-wise upper triangle of the transpose
    start, index, value = _csr(lower.T)
    hessian = highspy.HighsHessian()
    hessian.dim_ = P.shape[0]
    hessian.format_ = highspy.HessianFormat.kTriangular
    hessian.start_ = start
    hessian.index_ = index
    hessian.value_ = value
    return hessian


RETRIES: tuple[dict[str, object], ...] = ({"simplex_strategy": 4}, {"solver": "ipm"})
"""Settings tried in turn when HiGHS ends on a status that is not optimal, infeasible or
unbounded (skipped if the caller set the same option). HiGHS 1.15.1's default dual simplex ends
on model status "Unknown" on some small well-scaled LPs (one 15 x 7 support LP of the polytope
tests); its primal simplex (``simplex_strategy=4``) and its IPM solve them."""


_SILENCE_LOCK = threading.RLock()


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Point file descriptors 1 and 2 at /dev/null while HiGHS is constructed and runs.

    HiGHS writes from C, past Python's ``sys.stdout``: 1.16 prints its banner ("Running HiGHS
    1.16.0 ... Copyright") when ``highspy.Highs()`` is constructed, before any option can be set,
    and 1.15.1's postsolve writes debug lines (``HighsPostsolveStack::DuplicateColumn::undo ...``)
    even with ``output_flag`` off. Either would corrupt a ``--json`` document on stdout. The
    redirection is process-wide while it lasts (a thread printing at that moment would be silenced
    too, hence the lock); HiGHS is the reference back-end, not the default one.
    """
    with _SILENCE_LOCK:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
            saved = (os.dup(1), os.dup(2))
        except (OSError, ValueError):  # no usable stdout (closed, or replaced by a non-file)
            yield
            return
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(devnull, 1)
            os.dup2(devnull, 2)
            yield
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            os.close(devnull)


def _attempt(model: highspy.HighsLp | highspy.HighsModel, options: dict) -> tuple:
    with _quiet_stdout():
        highs = highspy.Highs()
        highs.setOptionValue("output_flag", False)
        for name, value in options.items():
            if highs.setOptionValue(name, value) != highspy.HighsStatus.kOk:
                raise InputError(f"HiGHS rejected option {name}={value!r}")
        highs.passModel(model)
        highs.run()
        model_status = highs.getModelStatus()
        if model_status == highspy.HighsModelStatus.kUnboundedOrInfeasible:
            highs.setOptionValue("presolve", "off")
            highs.run()
            model_status = highs.getModelStatus()
    return highs, model_status


def _run(model: highspy.HighsLp | highspy.HighsModel, options: dict) -> RawSolution:
    highs, model_status = _attempt(model, options)
    raw = highs.modelStatusToString(model_status)
    if model_status == highspy.HighsModelStatus.kInfeasible and "presolve" not in options:
        highs, model_status = _attempt(model, {**options, "presolve": "off"})
        raw += f"; without presolve: {highs.modelStatusToString(model_status)}"
    for retry in RETRIES:
        if model_status in _STATUS or set(retry) & set(options):
            continue
        highs, model_status = _attempt(model, {**options, **retry})
        raw += f"; with {retry}: {highs.modelStatusToString(model_status)}"
    status = _STATUS.get(model_status, "error")
    x = np.array(highs.getSolution().col_value, dtype=float) if status == "optimal" else None
    return RawSolution(status, x, raw)


def _solve(H: np.ndarray | None, problem: LinearProgram, options: dict) -> RawSolution:
    """An LP as a ``HighsLp``; a QP as a ``HighsModel`` with the Hessian (an active-set method)."""
    if H is None:
        return _run(_build_lp(problem), options)
    model = highspy.HighsModel()
    model.lp_ = _build_lp(problem)
    model.hessian_ = _hessian(H)
    return _run(model, options)


ADAPTER = Adapter(_solve)
"""HiGHS's adapters; ``**options`` are HiGHS options by name (``time_limit``,
``primal_feasibility_tolerance``...), a rejected one raises :class:`~frcontrol.errors.InputError`."""
solve_lp = ADAPTER.solve_lp
solve_qp = ADAPTER.solve_qp


__all__ = [
    "ADAPTER",
    "RETRIES",
    "solve_lp",
    "solve_qp",
]
