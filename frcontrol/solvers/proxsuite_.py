r"""Adapter for ProxQP (ProxSuite), dense back-end: a proximal augmented-Lagrangian QP solver.

ProxQP solves

.. math::

    \min_x \tfrac12 x^\top H x + g^\top x \quad\text{s.t.}\quad
    A x = b,\; l \le C x \le u,\; l_{box} \le x \le u_{box}.

It is made for QPs. An LP is passed with ``hessian_type=HessianType.Zero`` and ``H=None``.
What we measured on this machine (proxsuite 0.8, seeded random bounded feasible LPs, d = 8,
m = 20-200, see ``tests/test_solvers.py`` and ``benchmarks/solvers.py``):

* With ProxQP's **own default settings** (``eps_abs=1e-5``, ``eps_primal_inf=eps_dual_inf=1e-4``,
  no duality-gap check) it reports ``PROXQP_PRIMAL_INFEASIBLE`` on many *feasible* LPs, the more so
  the larger the box bounds are compared with the constraint offsets (28-30 of 30 LPs whose box is
  ``[-1e3, 1e3]^8``, 0-5 of 30 for a box of 1-100). It may also stop with ``PROXQP_SOLVED`` at a
  point whose objective is wrong by 10 % (``min -x1-x2 s.t. x1+x2 <= 1`` stops at ``x1+x2 = 0.9``)
  because its default termination tests only the primal and dual residuals, not the duality gap.
* With the settings of :data:`DEFAULT_SETTINGS` (tight absolute tolerances, duality gap checked,
  infeasibility thresholds ``1e-8``) it solved all 360 of those LPs to the HiGHS optimum. The cost:
  a truly infeasible LP is only declared infeasible after ``max_iter`` iterations (~0.1-0.3 s), and
  an unbounded LP is never detected (it ends on ``PROXQP_MAX_ITER_REACHED``, status ``error``).

Every option passed to the door overrides :data:`DEFAULT_SETTINGS` (pass ProxQP's defaults to
reproduce the failures). Whatever the settings, a ``PROXQP_SOLVED`` whose reported duality gap
exceeds :data:`DUALITY_GAP_TOLERANCE` is returned as ``error``, and the door checks the primal
residual of every answer.
"""

from __future__ import annotations

import numpy as np
import proxsuite

from frcontrol.errors import InputError

from ._common import Adapter, LinearProgram, RawSolution, Status

PROXQP_INF = 1e20
"""Magnitude that stands for an infinite bound when passed to ProxQP."""

DEFAULT_SETTINGS: dict[str, float | bool] = {
    "eps_abs": 1e-9,
    "eps_rel": 0.0,
    "check_duality_gap": True,
    "eps_duality_gap_abs": 1e-9,
    "eps_duality_gap_rel": 0.0,
    "eps_primal_inf": 1e-8,
    "eps_dual_inf": 1e-8,
}
"""ProxQP settings this adapter uses unless overridden (ProxQP's own defaults: ``eps_abs=1e-5``,
``check_duality_gap=False``, ``eps_primal_inf=eps_dual_inf=1e-4``, which fail on LPs; see the
module docstring)."""

DUALITY_GAP_TOLERANCE = 1e-6
"""Relative duality gap ``|gap| / (1 + |objective|)`` above which a ``PROXQP_SOLVED`` answer is
rejected (status ``error``). Checked only when ``check_duality_gap`` is on. Default ``1e-6``."""

_OUTPUT = proxsuite.proxqp.QPSolverOutput
_STATUS: dict[object, Status] = {
    _OUTPUT.PROXQP_SOLVED: "optimal",
    _OUTPUT.PROXQP_PRIMAL_INFEASIBLE: "infeasible",
    _OUTPUT.PROXQP_DUAL_INFEASIBLE: "unbounded",
}


def _finite(v: np.ndarray) -> np.ndarray:
    return np.clip(v, -PROXQP_INF, PROXQP_INF)


def _solve(H: np.ndarray | None, problem: LinearProgram, options: dict) -> RawSolution:
    dense = proxsuite.proxqp.dense
    n, m_eq, m_in = problem.n, problem.A_eq.shape[0], problem.A_ub.shape[0]
    box = problem.has_bounds
    hessian_type = dense.HessianType.Zero if H is None else dense.HessianType.Dense
    qp = dense.QP(n, m_eq, m_in, box, hessian_type=hessian_type)
    settings = {**DEFAULT_SETTINGS, **options}
    for name, value in settings.items():
        if name.startswith("_") or not hasattr(qp.settings, name):
            raise InputError(f"unknown ProxQP setting {name!r}")
        setattr(qp.settings, name, value)
    inequalities: tuple = (None, None, None)
    if m_in:
        inequalities = (problem.A_ub, np.full(m_in, -PROXQP_INF), problem.b_ub)
    equalities: tuple = (problem.A_eq, problem.b_eq) if m_eq else (None, None)
    bounds: tuple = (_finite(problem.lb), _finite(problem.ub)) if box else ()
    qp.init(H, problem.c, *equalities, *inequalities, *bounds)
    qp.solve()
    info = qp.results.info
    raw = str(info.status).rsplit(".", 1)[-1]
    status = _STATUS.get(info.status, "error")
    x = np.array(qp.results.x, dtype=float)
    if status == "optimal" and settings["check_duality_gap"]:
        objective = float(problem.c @ x + (0.0 if H is None else 0.5 * x @ H @ x))
        if abs(info.duality_gap) > DUALITY_GAP_TOLERANCE * (1.0 + abs(objective)):
            status = "error"
            raw += f" (duality gap {info.duality_gap:.3g} rejected)"
    return RawSolution(status, x if status == "optimal" else None, raw)


ADAPTER = Adapter(_solve)
"""ProxQP's adapters: LPs with a zero Hessian, QPs with ``H = P``; ``**options`` are ProxQP
settings by name, over :data:`DEFAULT_SETTINGS`."""
solve_lp = ADAPTER.solve_lp
solve_qp = ADAPTER.solve_qp


__all__ = [
    "ADAPTER",
    "DEFAULT_SETTINGS",
    "DUALITY_GAP_TOLERANCE",
    "PROXQP_INF",
    "solve_lp",
    "solve_qp",
]
