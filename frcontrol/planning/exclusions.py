r"""Whether other contact modes hold anywhere on a robust set: one LP per mode (the climb's check 3).

Used by the climb's plan (:mod:`frcontrol.planning.climb`) and the gait's hand-overs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..engine import DOMAIN_TOLERANCE
from ..geometry import constant_rows
from ..modes import ContactProblem, ModeSystem, all_modes, build_mode_system
from ..response import AffineSolution, solve_affine
from ..solvers import (
    CONFIRM_INFEASIBLE,
    DEFAULT_LP_SOLVER,
    RETRY_ERRORS,
    DoorOptions,
    settings_from,
    solve_lp,
)

__all__ = ["CONSTANT_ROW_TOLERANCE", "ROBUSTNESS_CAP", "ModeExclusion", "mode_exclusions", "mode_systems",
           "solve_confirmed"]

ROBUSTNESS_CAP = 1e3
"""[N m or N] Upper bound on the robustness variable t (keeps the LP bounded)."""

CONSTANT_ROW_TOLERANCE = 1e-9
"""[-] A mode's row over ``(z, w)`` whose norm is at most this times ``max(1, the largest row's)``
is constant (it does not depend on the inputs, disturbances or ambiguity): it is set to 0."""

# ============================================================================ exclusion
def solve_confirmed(c: np.ndarray, A_ub: np.ndarray, b_ub: np.ndarray,
                    equality: tuple[np.ndarray, np.ndarray] | None, bounds: tuple[np.ndarray, np.ndarray],
                    solver: str, confirm: bool = True) -> Any:
    """:func:`~frcontrol.solvers.solve_lp`, with a second opinion from the reference back-end.

    ``equality`` is ``(A_eq, b_eq)`` or None; ``bounds`` is ``(lb, ub)``. An error or an unbounded
    answer is always solved again by :data:`REFERENCE_LP_SOLVER`; with ``confirm``, so is an
    infeasible one (a false "infeasible" would drop a plan, or claim that a mode is excluded).
    """
    A_eq, b_eq = (None, None) if equality is None else equality
    door = DoorOptions(settings_from(solver), fallback=CONFIRM_INFEASIBLE if confirm else RETRY_ERRORS)
    return solve_lp(c, A_ub, b_ub, A_eq, b_eq, bounds[0], bounds[1], door=door)


@dataclass(frozen=True)
class ModeExclusion:
    """Whether another mode holds somewhere on ``{u} x conv(V_s)``.

    Attributes:
        mode: the mode.
        held: some disturbance of the robust set (and some w) puts ``(u, d, w)`` in the mode's
            domain, the motion rows strictly: the plan would be ambiguous.
        margin: [N m or N] the LP's ``t*``: the largest margin of the mode's motion rows with its
            force rows held (negative: the distance, in the lifted space, by which the mode misses
            the plan); ``-inf`` when even the force rows cannot hold (or the mode is inconsistent,
            or it misses by more than :data:`ROBUSTNESS_CAP`).
        disturbance: the witness d (when held), else None.
    """

    mode: str
    held: bool
    margin: float
    disturbance: np.ndarray | None = None


def _normalised_rows(
    system: ModeSystem, response: AffineSolution
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The mode's inequalities over ``(z, w)`` as unit rows ``H [z; w] <= h`` (constant rows: 0)."""
    G = system.G
    H = np.hstack([G @ response.X_u, G @ response.X_w])
    h = system.g - G @ response.x_0
    # not geometry.unit_rows: a numerically constant row (CONSTANT_ROW_TOLERANCE) is set to 0, not scaled
    norms, constant = constant_rows(H, CONSTANT_ROW_TOLERANCE)
    norms[constant] = 1.0
    H = H / norms[:, None]
    H[constant] = 0.0
    return H, h / norms, constant


def mode_exclusions(
    problem: ContactProblem,
    target: str,
    torques: np.ndarray,
    points: np.ndarray,
    *,
    systems: Sequence[tuple[ModeSystem, AffineSolution]] | None = None,
    solver: str = DEFAULT_LP_SOLVER,
    confirm: bool = False,
) -> tuple[ModeExclusion, ...]:
    """For every mode but ``target``: does it hold for some ``d in conv(points)``? One LP each.

    With ``d = points^T lam`` (``lam`` in the simplex), maximise ``t`` in [-cap, 1] subject to the
    mode's normalised rows at ``(torques, d, w)``: force rows ``<= h + tol``, motion rows
    ``+ t <= h``, consistency rows ``|E z - e| <= tol`` (tol = :data:`DOMAIN_TOLERANCE`). The
    mode holds somewhere iff ``t* > tol``, the membership rule of
    :func:`~frcontrol.engine.solutions_at`.

    Args:
        problem: the augmented problem (inputs ``(u, d)``).
        target: the planned mode (skipped).
        torques: u, shape (m_u,), the first inputs of the problem.
        points: the robust points V_s, shape (N, dim d).
        systems: prebuilt ``(system, response)`` of every mode (default: built here).
        solver: the LP back-end.
        confirm: have every "infeasible" (mode excluded) confirmed by the reference back-end
            (HiGHS) when ``solver`` is another one.
    """
    u = np.asarray(torques, dtype=float)
    m_u = u.size
    pts = np.asarray(points, dtype=float).reshape(-1, problem.m - m_u)
    if systems is None:
        systems = mode_systems(problem)
    tol = DOMAIN_TOLERANCE
    out = []
    for system, response in systems:
        if system.mode == target:
            continue
        if not response.consistent:
            out.append(ModeExclusion(system.mode, False, -math.inf))
            continue
        H, h, _ = _normalised_rows(system, response)
        p = response.ambiguity_dim
        Hu, Hd, Hw = H[:, :m_u], H[:, m_u:problem.m], H[:, problem.m:]
        rhs = h - Hu @ u
        n_lam = pts.shape[0]
        motion = system.motion.astype(float)
        # variables (lam, w, t)
        A_ub = np.hstack([Hd @ pts.T, Hw, motion[:, None]])
        b_ub = rhs + np.where(system.motion, 0.0, tol)
        E, e = response.E, response.e
        if E.shape[0]:
            Ez = np.hstack([E[:, m_u:] @ pts.T, np.zeros((E.shape[0], p + 1))])
            target_e = e - E[:, :m_u] @ u
            A_ub = np.vstack([A_ub, Ez, -Ez])
            b_ub = np.concatenate([b_ub, target_e + tol, -target_e + tol])
        A_eq = np.concatenate([np.ones(n_lam), np.zeros(p + 1)])[None, :]
        lb = np.concatenate([np.zeros(n_lam), np.full(p, -np.inf), [-ROBUSTNESS_CAP]])
        ub = np.concatenate([np.full(n_lam, np.inf), np.full(p, np.inf), [1.0]])
        c = np.zeros(n_lam + p + 1)
        c[-1] = -1.0
        result = solve_confirmed(c, A_ub, b_ub, (A_eq, np.ones(1)), (lb, ub), solver, confirm)
        if not result.found:
            out.append(ModeExclusion(system.mode, False, -math.inf))
            continue
        t = float(result.x[-1])
        held = t > tol
        out.append(ModeExclusion(system.mode, held, t, pts.T @ result.x[:n_lam] if held else None))
    return tuple(out)


def mode_systems(problem: ContactProblem) -> tuple[tuple[ModeSystem, AffineSolution], ...]:
    """Every mode velocity pruning allows, with its system and affine response."""
    out = []
    for mode in all_modes(problem.allowed_modes()):
        system = build_mode_system(problem, mode)
        response = solve_affine(system.A, system.B, system.c, name=f"the system of mode {mode}")
        out.append((system, response))
    return tuple(out)


