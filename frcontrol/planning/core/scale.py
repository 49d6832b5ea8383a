r"""The largest disturbance scale at which a robust phase has a plan: a plug-in of the core.

A robust phase (``robust = true``) holds its allowed modes for every disturbance in the polytope P
of ``[[disturbances]]``. With ``largest_scale = { upper = S }`` the phase's first decision also
finds the largest ``s`` in ``[0, S]`` for which some inputs hold them for every disturbance in
``s P`` (the snake climb's figure of merit). With V the vertices of P (and the zero disturbance
when P does not hold it), the lifted problem's constraints at ``s V`` are linear in ``(u, s)``,
so one LP per convex piece ``A z <= b`` of an allowed mode's unambiguous set (with the margin)
gives it exactly::

    maximise  s   over (u, s)
    s.t.      A_u u + s A_d v <= b                        for every v in V,
              C (X_u u + s X_d v + x_0) + o >= at_least   for every v in V (when the objective has one),
              the phase's ``require`` conditions likewise  for every v in V,
              0 <= s <= S.

The pieces are built once, in a disturbance box that holds ``S P`` (:func:`~.decision.lifted_problem`
at scale S), so the box's own faces, which are input limits of the lifted problem and not shrunk
by the margin, do not cut any ``s P`` with ``s <= S``. The best piece's inputs are rounded and
checked with :func:`~.decision.verify_plan` at every point of ``s V``: exactly one rigid solution,
in the planned mode. When the check fails the scale is lowered by :data:`SCALE_BACKOFF` (relative)
at most :data:`SCALE_BACKOFF_STEPS` times, re-solving the piece's LP each time with ``s`` bounded.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...engine import DynamicResponse
from ...kernel import backend
from ...modes import ContactProblem
from ...scene import Scene
from ...solvers import DEFAULT_SETTINGS, RETRY_ERRORS, DoorOptions, SolverSettings, solve_lp
from ..disturbances import load_disturbances
from .decision import PieceLP, lifted_problem, piece_lp, verify_plan, with_limits
from .forced import planning_problem
from .objective import objective_rows
from .pieces import margin_pieces
from .task import Phase

__all__ = ["SCALE_BACKOFF", "SCALE_BACKOFF_STEPS", "ScaleResult", "largest_scale"]

SCALE_BACKOFF = 1e-3
"""[-] When the rounded inputs of the largest scale fail the check, the scale is lowered by this
fraction of itself and the piece's LP solved again."""

SCALE_BACKOFF_STEPS = 10
"""How many times the scale is lowered before the piece is given up."""


@dataclass(frozen=True)
class ScaleResult:
    """The largest disturbance scale with a plan, at one state.

    Attributes:
        found: some scale in ``[0, upper]`` has a verified plan.
        scale: [-] the largest such scale (0 when none).
        upper: [-] the largest scale searched.
        mode: the plan's mode at that scale, or None.
        inputs: its rounded inputs by name (forced inputs included).
        objective: its objective, worst case over the scaled disturbances, or None.
        reason: why none was found (None when found).
        scene_mode: ``mode`` over every scene contact (:func:`~frcontrol.modes.scene_mode`), as
            every output prints a mode, or None.
    """

    found: bool
    scale: float
    upper: float
    mode: str | None = None
    inputs: dict[str, float] = field(default_factory=dict)
    objective: float | None = None
    reason: str | None = None
    scene_mode: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """The result as JSON-ready values."""
        return {
            "found": self.found,
            "scale": self.scale,
            "upper": self.upper,
            "mode": self.mode,
            "scene_mode": self.scene_mode,
            "inputs": dict(self.inputs),
            "objective": self.objective,
            "reason": self.reason,
            "backoff": SCALE_BACKOFF,
        }


def largest_scale(
    scene: Scene, phase: Phase, full: ContactProblem, *, settings: SolverSettings = DEFAULT_SETTINGS
) -> ScaleResult:
    """The largest scale in ``[0, phase.largest_scale]`` of the disturbances with a verified plan.

    Args:
        scene: the scene at the state.
        phase: a robust phase with ``largest_scale``.
        full: the contact problem at the state (every input).
        settings: the solver settings of its LPs.
    """
    upper = float(phase.largest_scale or 0.0)
    planned, analysis, forced = planning_problem(
        full, settings, lambda p: lifted_problem(scene, p, phase.margin, upper)[0]
    )
    if analysis is None:
        return ScaleResult(False, 0.0, upper, reason="every input is forced at this state")
    m_u = len(full.inputs) - len(forced)
    points = load_disturbances(scene).robust_points()
    rows = with_limits(objective_rows(scene, phase.objective, scene.q, scene.v), scene, phase)
    best: tuple[float, str, np.ndarray, float] | None = None
    for mode in (m.mode for m in analysis.feasible_modes if phase.allows(planned.contacts, m.mode)):
        chosen = analysis.mode(mode)
        if not chosen.inputs_full_dimensional:
            continue
        for piece in margin_pieces(analysis, mode, phase.margin, settings=settings):
            lp = piece_lp(piece.A, piece.b, chosen.response, rows, points, m_u)
            found = _piece_scale(lp, upper, settings)
            if found is None or (best is not None and found[0] <= best[0]):
                continue
            checked = _verified(analysis, mode, found, lp, planned, settings)
            if checked is not None and (best is None or checked[0] > best[0]):
                best = (checked[0], mode, checked[1], checked[2])
    if best is None:
        return ScaleResult(False, 0.0, upper, reason="no allowed mode has a verified plan at any scale")
    scale, mode, u, value = best
    planned_inputs = dict(zip(planned.inputs[:m_u], u.tolist(), strict=True))
    inputs = {name: forced.get(name, planned_inputs.get(name, 0.0)) for name in full.inputs}
    return ScaleResult(True, scale, upper, mode, inputs, value, scene_mode=full.scene_mode(mode))


def _verified(
    analysis: DynamicResponse,
    mode: str,
    found: tuple[float, np.ndarray],
    lp: PieceLP,
    problem: ContactProblem,
    settings: SolverSettings,
) -> tuple[float, np.ndarray, float] | None:
    """``(scale, rounded u, objective)`` verified at ``scale V``, lowering the scale when the check fails."""
    scale, u = found
    for _ in range(SCALE_BACKOFF_STEPS + 1):
        checked = verify_plan(analysis, mode, u, scale * lp.points, lp.rows, problem)
        if not isinstance(checked, str):
            return scale, checked[0], checked[1]
        again = _piece_scale(lp, scale * (1.0 - SCALE_BACKOFF), settings)
        if again is None:
            return None
        scale, u = again
    return None


def _piece_scale(lp: PieceLP, upper: float, settings: SolverSettings) -> tuple[float, np.ndarray] | None:
    """``(s, u)``: the LP of the module's docstring on one piece, or None when it has no solution."""
    (A_u, A_d), (g_u, g_d), at_least, m_u = lp.split(), lp.gains(), lp.rows.at_least, lp.m_u
    blocks, rhs = [], []
    for v in lp.points:
        blocks.append(np.hstack([A_u, (A_d @ v)[:, None]]))
        rhs.append(lp.b)
        if at_least is not None:
            blocks.append(np.hstack([-g_u, -(g_d @ v)[:, None]]))
            rhs.append(lp.bias - at_least)
        limit_u, limit_v, limit = lp.limit_rows(v)
        blocks.append(np.hstack([limit_u, limit_v[:, None]]))
        rhs.append(limit)
    cost = np.concatenate([np.zeros(m_u), [-1.0]])
    lb = np.concatenate([np.full(m_u, -np.inf), [0.0]])
    ub = np.concatenate([np.full(m_u, np.inf), [upper]])
    result = solve_lp(cost, np.vstack(blocks), np.concatenate(rhs), lb=lb, ub=ub,
                      door=DoorOptions(settings, fallback=RETRY_ERRORS, check=backend().lp_check))
    if not result.found or result.x is None:
        return None
    return float(result.x[m_u]), result.x[:m_u].copy()
