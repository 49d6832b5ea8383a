r"""One decision: the inputs, in an allowed mode's unambiguous set, that best serve a phase's objective.

At a state the engine gives every contact mode c its affine response ``dv = X_u u + x_0`` and its
input domain T_c (METHOD §3). A phase allows some letters per contact; the candidate modes are the
feasible modes made of allowed letters only. For each, :func:`~.pieces.margin_pieces`
builds the inputs at least ``margin`` from every input where another mode also holds (a union of
convex pieces), and one LP (maximize, minimize) or QP (track) per piece optimises the objective
(:mod:`~frcontrol.planning.core.objective`)::

    maximise   t                              (maximize: t <= C dv + o;  minimize: t <= -(C dv + o))
    minimise   |W (C dv + o - a*)|^2 + eps |u|^2   (track: least squares, W = diag(w))
    s.t.       u in the piece,  dv = X_u u + x_0.

The track's QP goes through :func:`frcontrol.solvers.solve_qp` (the door checks its primal
residual like an LP's); its Hessian ``2 G^T W^2 G`` (``G = C X_u``) is singular when fewer
quantities are tracked than there are inputs, so ``eps`` = :data:`TRACK_REGULARIZATION` times its
largest diagonal entry makes it definite and picks, among equally good inputs, the smallest.

**Conditions.** A phase's ``require`` conditions (:class:`~.objective.LimitRows`: an acceleration
between bounds) are rows of every LP and QP above, once per point of V, each bound tightened by the
most the rounding can move its quantity (:meth:`PieceLP.limit_rows`); the check at the rounded
inputs refuses a plan that breaks one.

**Robust phases.** With ``robust = true`` the disturbances of ``[[disturbances]]`` are extra inputs
``d`` (the lifted problem of :func:`frcontrol.planning.disturbances.augmented_problem`: input map
``[S^T, J_d^T]``), the analysis and the pieces are over ``z = (u, d)``, and every constraint of the
LP above is written once per point ``v`` of ``V`` (the vertices of the disturbance polytope, and the
zero disturbance when the polytope does not hold it): ``(u, v)`` in the same piece for every v, which
by convexity puts ``{u} x conv(V)`` in it, and the objective is the worst case over V (track: the
QP minimises the mean squared error over V, and the decision reports the worst).

**Rounding and verification.** The optima, best first, are rounded to
:data:`~.tolerances.TORQUE_ROUNDING` (within the limits) and checked with
:func:`frcontrol.engine.solutions_at` at the rounded inputs (at every v of V when robust): exactly
one rigid solution, in the planned mode. The first that passes is the plan. A mode whose objective
quantities depend on its ambiguity variables w is no candidate (the motion is not determined).

**No plan.** When no candidate has a piece at the margin, the decision reports the allowed modes
that were tried and why each failed (an allowed mode the analysis found infeasible within the
input limits, or pruned, is listed with that reason), and the *closest margin*: the largest margin
in ``[0, margin]`` at which some allowed mode still has unambiguous inputs, with that mode; None
when no allowed mode has any. It is found by halving the margin until a mode has pieces (at most
:data:`CLOSEST_MARGIN_HALVINGS` times: a smaller margin is reported as 0), then
:data:`CLOSEST_MARGIN_STEPS` bisection steps between that margin and its double.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ...engine import DynamicResponse, solutions_at
from ...kernel import backend
from ...modes import VELOCITY_TOLERANCE, ContactProblem
from ...response import OUTPUT_TOLERANCE
from ...scene import Scene
from ...solvers import (
    DEFAULT_SETTINGS,
    REFERENCE_LP_SOLVER,
    RETRY_ERRORS,
    DoorOptions,
    SolverSettings,
    qp_problem,
    solve_lp,
    solve_qp,
)
from ..disturbances import load_disturbances
from .forced import planning_problem
from .objective import ObjectiveRows, limit_rows, objective_rows
from .pieces import margin_pieces, mode_allowed
from .task import LETTERS, Phase
from .tolerances import TORQUE_ROUNDING

__all__ = [
    "CLOSEST_MARGIN_HALVINGS",
    "CLOSEST_MARGIN_STEPS",
    "INFEASIBLE_MODES_LISTED",
    "DISTURBANCE_PAD",
    "TRACK_REGULARIZATION",
    "Decision",
    "PieceLP",
    "decide",
    "lifted_problem",
    "piece_lp",
    "verify_plan",
    "with_limits",
]

CLOSEST_MARGIN_STEPS = 8
"""Bisection steps of the closest margin reported when no plan is found (the margin is then known
to ``1 / 2^8`` of itself)."""

INFEASIBLE_MODES_LISTED = 16
"""When no allowed mode is feasible and the enumeration evaluated none of them, the decision lists
the allowed letter combinations when there are at most this many."""

CLOSEST_MARGIN_HALVINGS = 40
"""Halvings of the margin asked for while looking for the closest margin: below ``margin / 2^40``
the closest margin is reported as 0."""

DISTURBANCE_PAD = 1e-3
"""[N] The lifted problem's disturbance box is the disturbance polytope's bounding box grown by this
(plus the margin), so that the box's own faces are not where a mode's domain ends."""


TRACK_REGULARIZATION = 1e-9
"""[-] The track's QP adds ``eps |u|^2`` with ``eps`` this times the largest diagonal entry of its
Hessian: the Hessian becomes definite (DAQP needs it), and of inputs with the same error the
smallest is chosen; relative 1e-9 moves the optimum's error by far less than the rounding does."""


@dataclass(frozen=True)
class PieceLP:
    """One convex piece ``A z <= b`` (z = (u, d)) of a mode's unambiguous set and the objective on it.

    Attributes:
        A, b: the piece's rows.
        gain: (k, m) the objective quantities' gain on z in the mode: ``C X_z``.
        bias: (k,) their value at z = 0: ``C x_0 + o``.
        rows: the objective.
        points: the disturbance points V (rows; one empty row when not robust).
        m_u: how many of z's entries are inputs (the rest are disturbances).
        limit_gain, limit_bias: the ``require`` quantities' (``rows.limits``) gain on z in the mode
            and value at z = 0 (None without conditions).
    """

    A: np.ndarray
    b: np.ndarray
    gain: np.ndarray
    bias: np.ndarray
    rows: ObjectiveRows
    points: np.ndarray
    m_u: int
    limit_gain: np.ndarray | None = None
    limit_bias: np.ndarray | None = None

    def split(self) -> tuple[np.ndarray, np.ndarray]:
        """``(A_u, A_d)``: the piece's columns on the inputs and on the disturbances."""
        return self.A[:, : self.m_u], self.A[:, self.m_u :]

    def gains(self) -> tuple[np.ndarray, np.ndarray]:
        """``(G_u, G_d)``: the gain's columns on the inputs and on the disturbances."""
        return self.gain[:, : self.m_u], self.gain[:, self.m_u :]

    def limit_rows(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(L_u, l_v, l)``: the ``require`` conditions at the disturbance ``v`` as ``L_u u + l_v <= l``.

        Each bound is tightened by the most the rounding of the inputs can move its quantity
        (``|row|_1`` times half of :data:`~frcontrol.planning.flip.TORQUE_ROUNDING`), so that the
        rounded plan meets it too; ``l_v`` is the part that scales with the disturbance.
        """
        limits = self.rows.limits
        if limits is None or self.limit_gain is None or self.limit_bias is None:
            return np.zeros((0, self.m_u)), np.zeros(0), np.zeros(0)
        g_u, g_d = self.limit_gain[:, : self.m_u], self.limit_gain[:, self.m_u :]
        slack = 0.5 * TORQUE_ROUNDING * np.sum(np.abs(g_u), axis=1)
        low, high = np.isfinite(limits.lower), np.isfinite(limits.upper)
        rows = np.vstack([-g_u[low], g_u[high]])
        moving = np.concatenate([-(g_d @ v)[low], (g_d @ v)[high]])
        bound = np.concatenate([
            self.limit_bias[low] - limits.lower[low] - slack[low],
            limits.upper[high] - self.limit_bias[high] - slack[high],
        ])
        return rows, moving, bound


def piece_lp(
    A: np.ndarray, b: np.ndarray, response: Any, rows: ObjectiveRows, points: np.ndarray, m_u: int
) -> PieceLP:
    """The piece ``A z <= b`` of a mode with its objective's gains on z.

    ``response`` is the mode's (``dv = X_u z + x_0``); the ``require`` conditions' gains come too.
    """
    n = rows.rows.shape[1]  # the response's first n outputs are dv
    gain = rows.rows @ response.X_u[:n]
    bias = rows.rows @ response.x_0[:n] + rows.offset
    limits = rows.limits
    if limits is None or not len(limits.names):
        return PieceLP(A, b, gain, bias, rows, points, m_u)
    limit_gain = limits.rows @ response.X_u[:n]
    limit_bias = limits.rows @ response.x_0[:n] + limits.offset
    return PieceLP(A, b, gain, bias, rows, points, m_u, limit_gain, limit_bias)


@dataclass(frozen=True)
class Decision:
    """The inputs chosen at one state of one phase.

    Attributes:
        found: a verified plan exists.
        mode: the planned mode (one letter per contact of ``contacts``), or None.
        contacts: the active contacts, in mode-letter order.
        inputs: the rounded inputs by scene input name (empty when none was found).
        objective: the objective at the rounded inputs (worst case over V when robust): the
            acceleration (maximize/minimize) or the weighted squared error (track); None without a
            plan.
        margin: [input units] the margin asked for.
        robust: the plan holds at every disturbance vertex.
        vertices: how many disturbance points were checked (1 when not robust).
        tried: per allowed mode tried and not chosen, why.
        reason: why no plan was made (None when found).
        closest_margin: when no allowed mode had unambiguous inputs at the margin: the largest
            margin at which one has (None when none has any, or when a plan was found).
        closest_mode: the mode reaching ``closest_margin``.
        forced: the inputs the rigid model forces at this state, and their values (fixed, not
            planned: :mod:`~frcontrol.planning.core.forced`); included in ``inputs`` when found.
    """

    found: bool
    mode: str | None
    contacts: tuple[str, ...]
    inputs: dict[str, float]
    objective: float | None
    margin: float
    robust: bool
    vertices: int
    tried: tuple[tuple[str, str], ...]
    reason: str | None
    closest_margin: float | None = None
    closest_mode: str | None = None
    forced: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The decision as JSON-ready values."""
        return {
            "found": self.found,
            "mode": self.mode,
            "contacts": list(self.contacts),
            "inputs": dict(self.inputs),
            "objective": self.objective,
            "margin": self.margin,
            "robust": self.robust,
            "vertices": self.vertices,
            "tried": [{"mode": m, "why": why} for m, why in self.tried],
            "reason": self.reason,
            "closest_margin": self.closest_margin,
            "closest_mode": self.closest_mode,
            "forced_inputs": dict(self.forced),
        }


def lifted_problem(
    scene: Scene, problem: ContactProblem, margin: float, scale: float = 1.0
) -> tuple[ContactProblem, np.ndarray]:
    """The problem over ``z = (u, d)`` and the points V (rows) of ``scale`` times the disturbances."""
    dist = load_disturbances(scene)
    points = dist.robust_points(scale)
    kin = scene.robot.point_kinematics(scene.q, scene.v, [(d.link, d.point_in_link) for d in dist.items])
    jac = kin.jacobians.reshape(-1, scene.robot.nv)
    pad = DISTURBANCE_PAD + margin
    lifted = replace(
        problem,
        inputs=problem.inputs + dist.names,
        input_map=np.hstack([problem.input_map, jac.T]),
        lower=np.concatenate([problem.lower, points.min(axis=0) - pad]),
        upper=np.concatenate([problem.upper, points.max(axis=0) + pad]),
    )
    return lifted, points


def decide(
    scene: Scene,
    phase: Phase,
    *,
    problem: ContactProblem | None = None,
    settings: SolverSettings = DEFAULT_SETTINGS,
    free: Mapping[str, str] | None = None,
) -> Decision:
    """The phase's plan at the scene's state (see the module's docstring).

    Args:
        scene: the scene at the state to plan at.
        phase: the phase (its allowed modes, margin, robustness and objective).
        problem: the contact problem to plan on (default: the scene's at its state).
        settings: the solver settings of its LPs and QPs.
        free: per contact, letters another rigid solution at the plan's inputs may have beside the
            planned mode's (:func:`~.pieces.mode_allowed`; a phase timing's, such as the pump's push:
            the toes may separate or slip). Default: none, exactly one rigid solution.

    Raises:
        ImpactState: a contact moves into its surface (the acceleration-level model does not apply).
    """
    full = (
        problem
        if problem is not None
        else ContactProblem.from_scene(scene, velocity_tolerance=VELOCITY_TOLERANCE)
    )
    lift = None if not phase.robust else (lambda p: lifted_problem(scene, p, phase.margin)[0])
    problem, ready, forced = planning_problem(full, settings, lift)
    m_u = len(full.inputs) - len(forced)
    points = load_disturbances(scene).robust_points() if phase.robust else np.zeros((1, 0))
    common: dict[str, Any] = {
        "contacts": problem.contacts,
        "margin": phase.margin,
        "robust": phase.robust,
        "vertices": len(points),
        "forced": forced,
    }
    why = _absent_contacts(scene, phase, problem.contacts) or _forced_outside(full, forced)
    if why is None and ready is None:
        why = "every input is forced at this state (" + _inputs_text(forced) + ")"
    if why is not None or ready is None:
        return Decision(False, None, inputs={}, objective=None, tried=(), reason=why, **common)
    analysis = ready
    rows = with_limits(objective_rows(scene, phase.objective, scene.q, scene.v), scene, phase)
    allowed = [m.mode for m in analysis.feasible_modes if phase.allows(problem.contacts, m.mode)]
    tried: list[tuple[str, str]] = []
    optima: list[tuple[float, str, np.ndarray]] = []
    for mode in allowed:
        found = _mode_optima(analysis, mode, phase.margin, rows, points, m_u, settings, free)
        if isinstance(found, str):
            tried.append((mode, found))
        else:
            optima += [(cost, mode, u) for cost, u in found]
    optima.sort(key=lambda item: item[0])
    for _, mode, u in optima:
        checked = verify_plan(analysis, mode, u, points, rows, problem, free)
        if isinstance(checked, str):
            tried.append((mode, checked))
            continue
        planned = dict(zip(problem.inputs[:m_u], checked[0].tolist(), strict=True))
        return Decision(
            True,
            mode,
            inputs={name: forced.get(name, planned.get(name, 0.0)) for name in full.inputs},
            objective=checked[1],
            tried=tuple(tried),
            reason=None,
            **common,
        )
    return _no_plan(
        analysis, phase, problem.contacts, allowed, bool(optima), tuple(tried), rows, settings, common
    )


def with_limits(rows: ObjectiveRows, scene: Scene, phase: Phase) -> ObjectiveRows:
    """The objective's rows with the phase's ``require`` conditions at the scene's state."""
    if not phase.requires:
        return rows
    return replace(rows, limits=limit_rows(scene, phase.requires, scene.q, scene.v))


def _no_plan(
    analysis: DynamicResponse,
    phase: Phase,
    contacts: tuple[str, ...],
    allowed: list[str],
    optimised: bool,
    tried: tuple[tuple[str, str], ...],
    rows: ObjectiveRows,
    settings: SolverSettings,
    common: dict[str, Any],
) -> Decision:
    """The decision without a plan: why, and the closest margin when no allowed mode had a piece."""
    if not allowed:
        reason = "no feasible mode has only the allowed letters " + _letters(phase, contacts)
        tried = _infeasible_allowed(analysis, phase, contacts)
    elif optimised:
        reason = "no optimum gives exactly one rigid solution in its mode once rounded"
    elif any(why == _BELOW_FLOOR for _, why in tried):
        reason = f"no allowed mode's unambiguous inputs reach at_least = {rows.at_least:g}"
    else:
        reason = f"no allowed mode has unambiguous inputs {phase.margin:g} away from every other mode"
    closest = None
    if allowed and not optimised:
        closest = _closest_margin(analysis, allowed, phase.margin, settings)
    return Decision(
        False,
        None,
        inputs={},
        objective=None,
        tried=tried,
        reason=reason,
        closest_margin=None if closest is None else closest[0],
        closest_mode=None if closest is None else closest[1],
        **common,
    )


_BELOW_FLOOR = "no unambiguous input reaches the objective's at_least"


def _infeasible_allowed(
    analysis: DynamicResponse, phase: Phase, contacts: tuple[str, ...]
) -> tuple[tuple[str, str], ...]:
    """The allowed modes, none feasible, and why each is not: as evaluated, or pruned before that.

    The modes the enumeration pruned before evaluating them are listed when the phase allows at
    most :data:`INFEASIBLE_MODES_LISTED` letter combinations.
    """
    evaluated = {m.mode: m for m in analysis.modes if phase.allows(contacts, m.mode)}
    letters = [phase.modes.get(name, LETTERS) for name in contacts]
    if evaluated or math.prod(len(x) for x in letters) > INFEASIBLE_MODES_LISTED:
        combinations = list(evaluated)
    else:
        combinations = ["".join(m) for m in itertools.product(*letters)]
    why = {"freedom": "no solution moves as the mode says"}
    return tuple(
        (
            mode,
            why.get(str(evaluated[mode].pruned), "infeasible within the input limits")
            if mode in evaluated
            else "pruned by the enumeration: no solution within the input limits moves as it says",
        )
        for mode in combinations
    )


def _letters(phase: Phase, contacts: tuple[str, ...]) -> str:
    return "(" + ", ".join(f"{name} {phase.modes[name]}" for name in contacts if name in phase.modes) + ")"


def _inputs_text(values: dict[str, float]) -> str:
    return ", ".join(f"{name} = {value:g}" for name, value in values.items())


def _forced_outside(full: ContactProblem, forced: dict[str, float]) -> str | None:
    """Why no plan exists when the model forces an input outside its limits (None when none is)."""
    bad = {
        name: value
        for name, value in forced.items()
        if not full.lower[full.inputs.index(name)] <= value <= full.upper[full.inputs.index(name)]
    }
    return f"the rigid model forces {_inputs_text(bad)}, outside the limits" if bad else None


def _absent_contacts(scene: Scene, phase: Phase, active: tuple[str, ...]) -> str | None:
    """Why the phase cannot be planned when a contact that may not separate does not touch."""
    for contact in scene.contacts:
        letters = phase.modes.get(contact.name)
        if letters is not None and "S" not in letters and contact.name not in active:
            return f"contact {contact.name} does not touch, and the phase allows it only {letters}"
    return None


def _mode_optima(
    analysis: DynamicResponse,
    mode: str,
    margin: float,
    rows: ObjectiveRows,
    points: np.ndarray,
    m_u: int,
    settings: SolverSettings,
    free: Mapping[str, str] | None = None,
) -> list[tuple[float, np.ndarray]] | str:
    """``(cost, u)`` of every piece's optimum of ``mode`` (cost: lower is better), or why none."""
    chosen = analysis.mode(mode)
    if not chosen.inputs_full_dimensional:
        return "its input domain is flat (inputs on a hyperplane)"
    response, n = chosen.response, rows.rows.shape[1]  # the response's first n outputs are dv
    if response.X_w.size:
        coupling = rows.rows @ response.X_w[:n]
        if np.max(np.abs(coupling)) > OUTPUT_TOLERANCE * max(float(np.max(np.abs(response.X_w))), 1e-300):
            return "the objective depends on the mode's ambiguity variables w"
    pieces = margin_pieces(analysis, mode, margin, settings=settings, free=free)
    if not pieces:
        return f"no unambiguous input {margin:g} away from every other mode"
    out = []
    for piece in pieces:
        found = _piece_optimum(piece_lp(piece.A, piece.b, response, rows, points, m_u), settings)
        if found is not None:
            out.append(found)
    if not out and rows.at_least is not None:
        return _BELOW_FLOOR
    return out if out else "no piece's LP has a solution"


def _piece_optimum(lp: PieceLP, settings: SolverSettings) -> tuple[float, np.ndarray] | None:
    """The piece's optimum ``(cost, u)`` (cost: lower is better), every constraint once per point of V.

    maximize/minimize: one LP over ``(u, t)``; track: the least-squares QP over u (:func:`_piece_qp`).
    """
    if lp.rows.kind == "track":
        return _piece_qp(lp, settings)
    (A_u, A_d), (g_u, g_d), bias, rows, m_u = lp.split(), lp.gains(), lp.bias, lp.rows, lp.m_u
    blocks, rhs = [], []
    for v in lp.points:
        blocks.append(np.hstack([A_u, np.zeros((A_u.shape[0], 1))]))
        rhs.append(lp.b - A_d @ v)
        blocks.append(np.hstack([-rows.sign * g_u, np.ones((1, 1))]))
        rhs.append(rows.sign * (bias + g_d @ v))
        if rows.at_least is not None:
            blocks.append(np.hstack([-g_u, np.zeros((1, 1))]))
            rhs.append(bias + g_d @ v - rows.at_least)
        limit_u, limit_v, limit = lp.limit_rows(v)
        blocks.append(np.hstack([limit_u, np.zeros((len(limit), 1))]))
        rhs.append(limit - limit_v)
    cost = np.concatenate([np.zeros(m_u), [-1.0]])
    result = solve_lp(cost, np.vstack(blocks), np.concatenate(rhs),
                      door=DoorOptions(settings, fallback=RETRY_ERRORS, check=backend().lp_check))
    if not result.found or result.x is None:
        return None
    return float(result.objective), result.x[:m_u].copy()


def _piece_qp(lp: PieceLP, settings: SolverSettings) -> tuple[float, np.ndarray] | None:
    """The track's least squares on a piece: mean over V of ``|W (G u + r_v)|^2`` plus the regularization.

    ``G`` is the gain on u, ``r_v = bias + G_d v - a*``; the cost returned is the mean squared error
    (without the regularization). A back-end error is retried once on the reference back-end.
    """
    (A_u, A_d), (g_u, g_d), rows, m_u = lp.split(), lp.gains(), lp.rows, lp.m_u
    weighted = rows.weights[:, None] * g_u
    residuals = [rows.weights * (lp.bias + g_d @ v - rows.targets) for v in lp.points]
    hessian = 2.0 * weighted.T @ weighted
    hessian += 2.0 * TRACK_REGULARIZATION * max(float(np.max(np.diag(hessian))), 1.0) * np.eye(m_u)
    linear = 2.0 * weighted.T @ np.mean(residuals, axis=0)
    limits = [lp.limit_rows(v) for v in lp.points]
    A_ub = np.vstack([A_u] * len(lp.points) + [rows_u for rows_u, _, _ in limits])
    b_ub = np.concatenate(
        [lp.b - A_d @ v for v in lp.points] + [bound - moving for _, moving, bound in limits]
    )
    problem = qp_problem(hessian, linear, A_ub, b_ub)
    result = solve_qp(problem, settings=settings)
    if result.status == "error" and settings.qp != REFERENCE_LP_SOLVER:
        result = solve_qp(problem, settings=replace(settings, qp=REFERENCE_LP_SOLVER))
    if not result.found or result.x is None:
        return None
    u = result.x.copy()
    cost = float(np.mean([np.sum((weighted @ u + r) ** 2) for r in residuals]))
    return cost, u


def _round(u: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Rounded to :data:`TORQUE_ROUNDING` (the double nearest the printed decimal), within the limits."""
    decimals = round(-math.log10(TORQUE_ROUNDING))
    rounded = np.array([round(float(x), decimals) for x in u])
    return np.minimum(np.maximum(rounded, lower), upper) + 0.0


def verify_plan(
    analysis: DynamicResponse,
    mode: str,
    u: np.ndarray,
    points: np.ndarray,
    rows: ObjectiveRows,
    problem: ContactProblem,
    free: Mapping[str, str] | None = None,
) -> tuple[np.ndarray, float] | str:
    """``(rounded u, objective)`` when ``solutions_at`` gives only ``mode`` at every point, else why not.

    With ``free``, other solutions are accepted when :func:`~.pieces.mode_allowed` allows them
    (``mode`` must be among them; the objective is its solution's).
    """
    m_u = len(u)
    rounded = _round(u, problem.lower[:m_u], problem.upper[:m_u])
    values = []
    for v in points:
        solutions = solutions_at(analysis, np.concatenate([rounded, v]))
        modes = [s.mode for s in solutions]
        allowed = free is not None and mode in modes and all(
            mode_allowed(m, mode, problem.contacts, free) for m in modes
        )
        if modes != [mode] and not allowed:
            found = ", ".join(modes) or "none"
            return f"at the rounded inputs the rigid solutions are {found}, not only {mode}"
        solution = solutions[modes.index(mode)]
        broken = None if rows.limits is None else rows.limits.violation(solution.dv[: rows.rows.shape[1]])
        if broken is not None:
            return f"at the rounded inputs {broken} (require)"
        values.append(rows.value(solution.dv))
    worst = max(values) if rows.kind in ("track", "minimize") else min(values)
    if rows.at_least is not None and not worst >= rows.at_least:
        return f"at the rounded inputs the objective {worst:.6g} is below at_least = {rows.at_least:g}"
    return rounded, worst


def _closest_margin(
    analysis: DynamicResponse, modes: list[str], margin: float, settings: SolverSettings
) -> tuple[float, str] | None:
    """The largest margin in [0, margin] at which one of ``modes`` has unambiguous inputs, and the mode."""
    best: tuple[float, str] | None = None
    for mode in modes:
        if not analysis.mode(mode).inputs_full_dimensional or not margin_pieces(
            analysis, mode, 0.0, settings=settings
        ):
            continue
        low, high = 0.5 * margin, margin
        for _ in range(CLOSEST_MARGIN_HALVINGS):
            if margin_pieces(analysis, mode, low, settings=settings):
                break
            low, high = 0.5 * low, low
        else:
            low = high = 0.0
        for _ in range(CLOSEST_MARGIN_STEPS if high > 0 else 0):
            middle = 0.5 * (low + high)
            low, high = (
                (middle, high) if margin_pieces(analysis, mode, middle, settings=settings) else (low, middle)
            )
        if best is None or low > best[0]:
            best = (low, mode)
    return best
