r"""The climb's problem: its ``[task]``, the lifted brace mode, its pieces and LPs (see :mod:`.climb`).

:func:`build_climb` builds everything the climb's LPs need once (:class:`ClimbProblem`);
:func:`check_scale` decides one disturbance scale; :func:`plan_lp` and :func:`gentle_plan` are
the LPs of :func:`frcontrol.planning.climb.plan_climb` (its module's docstring explains them).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..engine import DOMAIN_TOLERANCE, DynamicResponse, analyze
from ..errors import FrameNotFound, InputError, SceneError
from ..modes import ContactProblem, ModeSystem, build_mode_system
from ..polytope import Polytope
from ..response import AffineSolution, solve_affine
from ..scene import Scene
from ..scene_tables import TaskTable
from ..solvers import DEFAULT_LP_SOLVER
from . import DEFAULT_CLIMB_MARGIN
from .disturbances import DisturbanceSet, PointKinematics, augmented_problem, load_disturbances
from .exclusions import ROBUSTNESS_CAP, ModeExclusion, mode_exclusions, mode_systems, solve_confirmed

__all__ = [
    "ACCELERATION_FLOOR",
    "ACCELERATION_SLACK",
    "ANALYSIS_BOX_GROWTH",
    "DEFAULT_MIN_HEAD_ACCELERATION",
    "OPTIMALITY_SLACK",
    "SCALE_CAP",
    "ClimbProblem",
    "ClimbTask",
    "ScaleCheck",
    "build_climb",
    "check_scale",
    "gentle_plan",
    "load_climb_task",
    "piece_rows",
    "unit_norms",
]

DEFAULT_MIN_HEAD_ACCELERATION = 1.0
"""[m/s^2] a_min, the head's required upward acceleration when ``[task]`` does not say."""

SCALE_CAP = 1e3
"""[-] Largest disturbance scale searched (a disturbance that changes nothing has no largest
scale: it is then reported as this cap, with ``scale_capped``)."""

ANALYSIS_BOX_GROWTH = 0.1
"""[-] The lifted analysis bounds the disturbances by the box of ``conv(0, s_bound P)`` grown on
every side by this fraction of ``max(s_bound, 1)`` times P's extent, plus the margin."""

ACCELERATION_SLACK = 0.1
"""[-] The robustness LP lets the free coordinates' nominal accelerations exceed the gentlest
plan's ``alpha*`` by this fraction (room for a more robust squeeze)."""

ACCELERATION_FLOOR = 1e-3
"""[rad/s^2 or m/s^2] Added to the acceleration bound of the robustness LP (keeps it feasible when
``alpha* = 0``, against the LP's own tolerance)."""

OPTIMALITY_SLACK = 1e-6
"""[-] The least-effort LP keeps ``t >= t* - OPTIMALITY_SLACK (1 + t*)``."""

# ============================================================================ task
@dataclass(frozen=True)
class ClimbTask:
    """What the climb planner needs to know of a scene (its ``[task]`` table).

    Attributes:
        brace_contacts: the contacts held in mode F (all the active contacts).
        head_link: the link of the point that must accelerate upward.
        head_point: that point [m] in the link's frame.
        min_head_acceleration: a_min [m/s^2].
    """

    brace_contacts: tuple[str, ...]
    head_link: str
    head_point: np.ndarray
    min_head_acceleration: float


def load_climb_task(scene: Scene) -> ClimbTask:
    """Read the ``[task]`` table (see the module docstring).

    The table is shared by the planners: keys the climb does not read are ignored.

    Raises:
        SceneError: a missing ``head_link`` or ``head_point``, an unknown or inactive brace
            contact, brace contacts that are not all the active contacts, an unknown head link, a
            bad point or acceleration.
    """
    path = str(scene.path)
    task = scene.task
    phases = scene.raw.get("task", {}).get("phases") if task.head_link is None else None
    if phases:
        task = _task_from_phases(path, phases)
    active = tuple(c.name for c in scene.active_contacts)
    names = tuple(c.name for c in scene.contacts)
    brace = list(task.brace_contacts) if task.brace_contacts is not None else list(active)
    for i, b in enumerate(brace):
        if b not in names:
            raise SceneError(path, f"task.brace_contacts[{i}]", f"unknown contact {b!r}; the contacts "
                             f"are: {', '.join(names)}")
        if b not in active:
            raise SceneError(path, f"task.brace_contacts[{i}]", f"contact {b!r} does not touch at the "
                             "scene's state: a brace contact must be active")
    if set(brace) != set(active) or len(brace) != len(set(brace)):
        raise SceneError(path, "task.brace_contacts", f"expected every active contact once "
                         f"({', '.join(active)}): the climb holds each in mode F; got {brace}")
    for key, what in (("head_link", "the link of the point that must rise"),
                      ("head_point", "that point [m] in the link's frame")):
        if getattr(task, key) is None:
            raise SceneError(path, f"task.{key}", f"missing: the climb needs [task] {key}, {what}")
    links = scene.robot.link_names
    head_link = str(task.head_link)
    if head_link not in links:
        raise SceneError(path, "task.head_link", str(FrameNotFound(head_link, links)))
    head_point = task.head_point
    assert head_point is not None  # checked above
    a_min = (task.min_head_acceleration if task.min_head_acceleration is not None
             else DEFAULT_MIN_HEAD_ACCELERATION)
    ordered = tuple(c for c in active if c in brace)
    return ClimbTask(ordered, head_link, head_point, float(a_min))


def _task_from_phases(path: str, phases: Sequence[Mapping[str, Any]]) -> TaskTable:
    """The climb's brace and head read from a task given as phases.

    The brace: the first phase's contacts allowed only F; the head: the point whose upward
    acceleration it requires (``require``).
    """
    phase = phases[0]
    brace = tuple(name for name, letters in phase.get("modes", {}).items() if set(letters) == {"F"})
    for item in phase.get("require", ()):
        if "link" in item and "at_least" in item and tuple(item["direction"]) == (0.0, 1.0):
            return TaskTable(brace_contacts=brace or None, head_link=str(item["link"]),
                             head_point=np.asarray(item["point"], dtype=float),
                             min_head_acceleration=float(item["at_least"]))
    raise SceneError(path, "task.phases[0].require", "missing: the climb needs its first phase to require "
                     "a point's upward acceleration: require = [{ link = NAME, point = [x, y], "
                     "direction = [0.0, 1.0], at_least = A }]")


# ============================================================================ build
@dataclass(frozen=True, eq=False)
class ClimbProblem:
    """Everything the climb LPs need, built once.

    Attributes:
        scene: the scene.
        task: its ``[task]``.
        disturbances: the polytope P.
        problem: the augmented contact problem (inputs u then d), with the analysis box as the
            disturbances' limits.
        mode: the brace mode (``"F"`` per brace contact).
        m_u: number of torques.
        domain_rows: ``(H, h)`` of ``T_F`` over ``z = (u, d)`` (force rows of the brace mode and
            the torque limits), unnormalised.
        head_row: ``(c, c_0)``: the head's upward acceleration ``a_y = c^T z + c_0`` [m/s^2].
        head_sideways_row: ``(c_x, c_x0)``: its sideways one, ``a_x = c_x^T z + c_x0`` [m/s^2].
        free_coordinates: the coordinates no brace contact row involves (the upper body).
        free_rows: ``(B, b_0)``: their accelerations ``ddq_f = B z + b_0`` [rad/s^2 or m/s^2].
        pieces: the convex pieces of the brace mode's unambiguous set in the lifted space (within
            the analysis box).
        box: ``(lower, upper)`` [N] of the disturbances in the analysis.
        scale_bound: the one-LP upper bound on the scale (``s_bound``); -1 if even s = 0 is infeasible.
        scale_capped: the bound reached :data:`SCALE_CAP`.
        systems: every mode's ``(system, response)`` on the augmented problem.
        analysis: the engine's analysis of the augmented problem (None when not reached).
        obstacle: why no plan can exist (None if the LPs may proceed).
        margin: [N m or N] the required robustness radius.
        min_head_acceleration: a_min [m/s^2].
        timings: [s] per stage.
    """

    scene: Scene
    task: ClimbTask
    disturbances: DisturbanceSet
    problem: ContactProblem
    mode: str
    m_u: int
    domain_rows: tuple[np.ndarray, np.ndarray]
    head_row: tuple[np.ndarray, float]
    head_sideways_row: tuple[np.ndarray, float]
    free_coordinates: tuple[str, ...]
    free_rows: tuple[np.ndarray, np.ndarray]
    pieces: tuple[Polytope, ...]
    box: tuple[np.ndarray, np.ndarray]
    scale_bound: float
    scale_capped: bool
    systems: tuple[tuple[ModeSystem, AffineSolution], ...]
    analysis: DynamicResponse | None
    obstacle: str | None
    margin: float
    min_head_acceleration: float
    solver: str
    timings: Mapping[str, float] = field(default_factory=dict)

    def robust_points(self, scale: float) -> np.ndarray:
        """V_s (see :meth:`DisturbanceSet.robust_points`)."""
        return self.disturbances.robust_points(scale)


def unit_norms(H: np.ndarray) -> np.ndarray:
    """The rows' norms, 1 where a row is zero (to divide by)."""
    norms = np.sqrt(np.sum(H * H, axis=1))
    return np.where(norms > 0, norms, 1.0)


def _scale_bound(domain: tuple[np.ndarray, np.ndarray], head: tuple[np.ndarray, float],
                 sideways: tuple[np.ndarray, float], points: np.ndarray, m_u: int, margin: float,
                 a_min: float, solver: str) -> tuple[float, bool]:
    """The largest scale s for which some u keeps every ``(u, s v)`` in T_F shrunk by the margin.

    With the head's ``a_y >= a_min + margin |c|`` at every ``s v`` and ``a_x(u, 0) = 0``. Returns
    ``(s*, capped)``; ``s* = -1`` when even ``s = 0`` is infeasible.
    """
    H, h = domain
    c, c0 = head
    norms = unit_norms(H)
    c_norm = float(np.linalg.norm(c)) or 1.0
    rows, rhs = [], []
    for v in points:
        rows.append(np.hstack([H[:, :m_u], (H[:, m_u:] @ v)[:, None]]))
        rhs.append(h - margin * norms)
        rows.append(np.hstack([-c[None, :m_u], [[-(c[m_u:] @ v)]]]))
        rhs.append(np.array([c0 - a_min - margin * c_norm]))
    A = np.vstack(rows)
    b = np.concatenate(rhs)
    cost = np.zeros(m_u + 1)
    cost[-1] = -1.0
    lb = np.concatenate([np.full(m_u, -np.inf), [0.0]])
    ub = np.concatenate([np.full(m_u, np.inf), [SCALE_CAP]])
    A_eq = np.concatenate([sideways[0][:m_u], [0.0]])[None, :]
    b_eq = np.array([-sideways[1]])
    result = solve_confirmed(cost, A, b, (A_eq, b_eq), (lb, ub), solver)
    if not result.found:
        return -1.0, False
    s = float(result.x[-1])
    return s, s >= SCALE_CAP * (1 - 1e-9)


def build_climb(
    scene: Scene,
    *,
    margin: float = DEFAULT_CLIMB_MARGIN,
    min_head_acceleration: float | None = None,
    solver: str = DEFAULT_LP_SOLVER,
) -> ClimbProblem:
    """Assemble the climb: disturbances, task, the brace mode's rows, the scale bound, the pieces.

    Raises:
        SceneError: bad ``[[disturbances]]`` or ``[task]`` tables.
        InputError: a negative or non-finite margin or acceleration.
    """
    if not (isinstance(margin, (int, float)) and math.isfinite(margin) and margin >= 0):
        raise InputError(f"margin must be a finite number >= 0 [N m or N], got {margin!r}")
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    task = load_climb_task(scene)
    dist = load_disturbances(scene)
    a_min = task.min_head_acceleration if min_head_acceleration is None else float(min_head_acceleration)
    if not math.isfinite(a_min):
        raise InputError(f"min_head_acceleration must be finite [m/s^2], got {min_head_acceleration!r}")
    base = augmented_problem(scene, dist)
    m_u = scene.inputs.count
    mode = "F" * base.k
    points = dist.robust_points(1.0)

    def result(**kw: Any) -> ClimbProblem:
        timings["build"] = time.perf_counter() - t0
        defaults: dict[str, Any] = {
            "pieces": (), "box": (base.lower[m_u:], base.upper[m_u:]), "scale_bound": -1.0,
            "scale_capped": False, "systems": (), "analysis": None, "obstacle": None,
            "domain_rows": (np.zeros((0, base.m)), np.zeros(0)), "head_row": (np.zeros(base.m), 0.0),
            "head_sideways_row": (np.zeros(base.m), 0.0),
            "free_coordinates": (), "free_rows": (np.zeros((0, base.m)), np.zeros(0))}
        defaults.update(kw)
        return ClimbProblem(scene=scene, task=task, disturbances=dist, mode=mode, m_u=m_u,
                            margin=float(margin), min_head_acceleration=a_min, solver=solver,
                            timings=timings, problem=defaults.pop("problem", base), **defaults)

    brace = _brace_mode(base, mode)
    if isinstance(brace, str):
        return result(obstacle=brace)
    common = _brace_rows(scene, base, *brace, task, m_u)
    timings["rows"] = time.perf_counter() - t0
    (H, h), (c, c0), sideways = common["domain_rows"], common["head_row"], common["head_sideways_row"]
    t1 = time.perf_counter()
    s_bound, capped = _scale_bound((H, h), (c, c0), sideways, points, m_u, margin, a_min, solver)
    timings["scale_bound"] = time.perf_counter() - t1
    if s_bound < 0:
        return result(**common, scale_bound=-1.0, obstacle=(
            f"no torques within the limits keep mode {base.scene_mode(mode)} with margin {margin:g} and "
            f"the head accelerating upward at >= {a_min:g} m/s^2, even without disturbance: widen the torque "
            "limits, lower min_head_acceleration or the margin"))

    t1 = time.perf_counter()
    boxed, analysis, pieces, obstacle, (lower, upper) = _lifted_analysis(scene, dist, s_bound, margin, mode,
                                                                         solver)
    timings["analysis"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    systems = mode_systems(boxed)
    timings["mode_systems"] = time.perf_counter() - t1
    return result(**common, problem=boxed, pieces=tuple(pieces), box=(lower, upper), scale_bound=s_bound,
                  scale_capped=capped, systems=systems, analysis=analysis, obstacle=obstacle)


def _brace_mode(base: ContactProblem, mode: str) -> tuple[ModeSystem, AffineSolution] | str:
    """The brace mode's system and its unique response, or why the brace cannot be certified."""
    if base.k == 0:
        return "the scene has no active contact: there is no brace to hold"
    allowed = base.allowed_modes()
    moving = [c for c, letters in zip(base.contacts, allowed, strict=True) if "F" not in letters]
    if moving:
        return (f"brace contact(s) {', '.join(moving)} move at the scene's state: mode F "
                "is not possible (velocity pruning)")
    system = build_mode_system(base, mode)
    response = solve_affine(system.A, system.B, system.c, name=f"the system of mode {mode}")
    if not response.consistent or response.ambiguity_dim or response.E.shape[0]:
        return (f"mode {base.scene_mode(mode)} has {response.ambiguity_dim} ambiguity variable(s) and "
                f"{response.E.shape[0]} consistency condition(s): the brace's squeeze is not set by the "
                "torques (fewer brace coordinates than brace rows), so no torque can certify it for every "
                "squeeze; give the brace at least as many coordinates as contact rows (METHOD §6)")
    return system, response


def _brace_rows(scene: Scene, base: ContactProblem, system: ModeSystem, response: AffineSolution,
                task: ClimbTask, m_u: int) -> dict[str, Any]:
    """The brace mode's rows over the torques and disturbances, and the head's acceleration rows.

    Returns:
        ``domain_rows`` (H, h): the mode's inequalities and the torque limits; ``head_row`` and
        ``head_sideways_row`` (c, c0): the head's vertical and horizontal acceleration
        ``c z + c0``; ``free_rows`` and ``free_coordinates``: coordinates no brace row involves.
    """
    n = base.n
    G = system.G
    C, d = base.input_bound_rows()
    torque_rows = np.abs(C[:, m_u:]).sum(axis=1) == 0
    H = np.vstack([G @ response.X_u, C[torque_rows]])
    h = np.concatenate([system.g - G @ response.x_0, d[torque_rows]])
    kin = PointKinematics(scene, [("head", task.head_link, task.head_point)])
    jac, drift, _ = kin.evaluate(scene.q, scene.v)
    c = jac[1] @ response.X_u[:n]
    c0 = float(jac[1] @ response.x_0[:n] + drift[1])
    sideways = (jac[0] @ response.X_u[:n], float(jac[0] @ response.x_0[:n] + drift[0]))
    brace_rows = np.abs(np.vstack([base.jacobian_normal, base.jacobian_tangent]))
    free = np.nonzero(np.all(brace_rows <= 1e-12 * max(1.0, float(brace_rows.max())), axis=0))[0]
    return {"domain_rows": (H, h), "head_row": (c, c0), "head_sideways_row": sideways,
            "free_rows": (response.X_u[free], response.x_0[free]),
            "free_coordinates": tuple(base.coordinates[i] for i in free)}


def _lifted_analysis(scene: Scene, dist: DisturbanceSet, s_bound: float, margin: float, mode: str,
                     solver: str) -> tuple[ContactProblem, DynamicResponse, tuple[Polytope, ...], str | None,
                                       tuple[np.ndarray, np.ndarray]]:
    """The analysis over (torques, disturbances), in a box holding every s P the bisection visits.

    Returns:
        (the boxed problem, its analysis, the brace mode's unambiguous pieces, why there is no
        plan or None, the box (lower, upper)).
    """
    extent = dist.upper - dist.lower
    pad = ANALYSIS_BOX_GROWTH * max(s_bound, 1.0) * extent + margin + DOMAIN_TOLERANCE * 10
    lower = np.minimum(0.0, s_bound * dist.lower) - pad
    upper = np.maximum(0.0, s_bound * dist.upper) + pad
    boxed = augmented_problem(scene, dist, lower, upper)
    analysis = analyze(boxed, solver=solver)
    pieces: tuple[Polytope, ...] = ()
    obstacle = None
    try:
        target = analysis.mode(mode)
    except InputError:
        target = None
    if target is None or not target.feasible:
        obstacle = f"mode {boxed.scene_mode(mode)} is infeasible at the scene's state (empty domain)"
    else:
        pieces = analysis.unambiguous_set(mode)
        if not pieces:
            obstacle = (f"mode {boxed.scene_mode(mode)} has no unambiguous inputs: other modes cover its "
                        "whole domain")
    return boxed, analysis, tuple(pieces), obstacle, (lower, upper)


# ============================================================================ the LPs
def piece_rows(piece: Polytope, m_u: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A piece's rows, and per row the norm by which t shrinks it (0 for the analysis-box rows)."""
    A, b = np.asarray(piece.A), np.asarray(piece.b)
    if piece.A_eq.shape[0]:
        A = np.vstack([A, piece.A_eq, -piece.A_eq])
        b = np.concatenate([b, piece.b_eq, -piece.b_eq])
    norms = np.sqrt(np.sum(A * A, axis=1))
    nonzero = np.abs(A) > 1e-12 * np.maximum(norms, 1e-300)[:, None]
    box_row = (nonzero.sum(axis=1) == 1) & ~np.any(nonzero[:, :m_u], axis=1)
    shrink = np.where(box_row, 0.0, norms)
    return A, b, shrink


def _plan_lp(
    cp: ClimbProblem, piece: Polytope, scale: float, objective: str, *,
    alpha_cap: float = math.inf, t_min: float | None = None, solver: str | None = None,
) -> tuple[float, float, np.ndarray | None]:
    """One plan LP on a piece at a scale, over ``(u, t, e_f, e_u)`` (module docstring).

    ``e_f`` bounds the free coordinates' nominal accelerations, ``|B_u u + b_0| <= e_f``, with
    ``alpha = sum(e_f)``; ``e_u`` bounds the torques, ``|u| <= e_u``.

    Args:
        cp: the built climb.
        piece: a convex piece of the unambiguous set.
        scale: the disturbance scale s (V_s).
        objective: ``"robust"`` (maximise t), ``"gentle"`` (minimise alpha) or ``"effort"``
            (minimise ``sum(e_u)``).
        alpha_cap: upper bound on alpha [rad/s^2 or m/s^2].
        t_min: lower bound on t (default: the margin).
        solver: the LP back-end (default: the problem's).

    Returns:
        ``(t, alpha, u)`` at the optimum; u None when infeasible.
    """
    solver = solver or cp.solver
    m_u = cp.m_u
    B, b0 = cp.free_rows
    f = B.shape[0]
    nvar = m_u + 1 + f + m_u
    A_ub, b_ub = _plan_lp_rows(cp, piece, scale, alpha_cap)
    cost = np.zeros(nvar)
    if objective == "robust":
        cost[m_u] = -1.0
    elif objective == "gentle":
        cost[m_u + 1:m_u + 1 + f] = 1.0
    else:
        cost[m_u + 1 + f:] = 1.0
    lower_t = cp.margin if t_min is None else max(cp.margin, t_min)
    lb = np.concatenate([cp.scene.inputs.lower, [lower_t], np.zeros(f + m_u)])
    ub = np.concatenate([cp.scene.inputs.upper, [ROBUSTNESS_CAP], np.full(f + m_u, np.inf)])
    cx, cx0 = cp.head_sideways_row
    A_eq = np.concatenate([cx[:m_u], np.zeros(nvar - m_u)])[None, :]
    b_eq = np.array([-cx0])
    result = solve_confirmed(cost, A_ub, b_ub, (A_eq, b_eq), (lb, ub), solver)
    if not result.found:
        return -math.inf, math.inf, None
    u = result.x[:m_u]
    alpha = float(np.sum(np.abs(B[:, :m_u] @ u + b0))) if f else 0.0
    return float(result.x[m_u]), alpha, u


def _plan_lp_rows(cp: ClimbProblem, piece: Polytope, scale: float, alpha_cap: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The plan LP's inequalities over ``(u, t, e_f, e_u)``.

    Per point of V_s: the piece's rows shrunk by t and the head's acceleration; then the free
    accelerations' bounds ``|B_u u + b_0| <= e_f`` (and ``sum(e_f) <= alpha_cap``) and the
    torques' ``|u| <= e_u``.
    """
    m_u = cp.m_u
    A, b, shrink = piece_rows(piece, m_u)
    c, c0 = cp.head_row
    c_norm = float(np.linalg.norm(c)) or 1.0
    head_rhs = c0 - cp.min_head_acceleration - cp.margin * c_norm
    B, b0 = cp.free_rows
    f = B.shape[0]
    nvar = m_u + 1 + f + m_u
    rows, rhs = [], []

    def row(u_part: np.ndarray, t_part: Any = 0.0, f_part: Any = 0.0, e_part: Any = 0.0) -> np.ndarray:
        count = np.atleast_2d(u_part).shape[0]
        out = np.zeros((count, nvar))
        out[:, :m_u] = u_part
        out[:, m_u] = np.ravel(t_part) if np.ndim(t_part) else t_part
        out[:, m_u + 1:m_u + 1 + f] = f_part
        out[:, m_u + 1 + f:] = e_part
        return out

    for v in cp.robust_points(scale):
        rows.append(row(A[:, :m_u], shrink))
        rhs.append(b - A[:, m_u:] @ v)
        rows.append(row(-c[None, :m_u]))
        rhs.append(np.array([head_rhs + c[m_u:] @ v]))
    if f:
        rows += [row(B[:, :m_u], f_part=-np.eye(f)), row(-B[:, :m_u], f_part=-np.eye(f))]
        rhs += [-b0, b0]
        if math.isfinite(alpha_cap):
            rows.append(row(np.zeros((1, m_u)), f_part=np.ones((1, f))))
            rhs.append(np.array([alpha_cap]))
    eye = np.eye(m_u)
    rows += [row(eye, e_part=-eye), row(-eye, e_part=-eye)]
    rhs += [np.zeros(m_u), np.zeros(m_u)]
    return np.vstack(rows), np.concatenate(rhs)


def _best_piece(
    cp: ClimbProblem, scale: float, solver: str | None = None
) -> tuple[int, float, np.ndarray | None]:
    """The piece with the largest robustness radius at ``scale``: ``(index, t*, u)``."""
    best: tuple[int, float, np.ndarray | None] = (-1, -math.inf, None)
    for i, piece in enumerate(cp.pieces):
        t, _, u = _plan_lp(cp, piece, scale, "robust", solver=solver)
        if u is not None and t > best[1]:
            best = (i, t, u)
    return best


def gentle_plan(cp: ClimbProblem, scale: float) -> tuple[int, float, float, np.ndarray | None]:
    """Objectives 1, 2 and 3 on every piece: ``(index, t, alpha*, u)`` of the gentlest piece."""
    best: tuple[int, float, float, np.ndarray | None] = (-1, -math.inf, math.inf, None)
    for i, piece in enumerate(cp.pieces):
        _, alpha, u = _plan_lp(cp, piece, scale, "gentle")
        if u is None or alpha >= best[2]:
            continue
        cap = (1.0 + ACCELERATION_SLACK) * alpha + ACCELERATION_FLOOR
        t, _, u_robust = _plan_lp(cp, piece, scale, "robust", alpha_cap=cap)
        if u_robust is None:
            best = (i, cp.margin, alpha, u)
            continue
        keep = t - OPTIMALITY_SLACK * (1.0 + abs(t))
        _, _, u_least = _plan_lp(cp, piece, scale, "effort", alpha_cap=cap, t_min=keep)
        best = (i, t, alpha, u_robust if u_least is None else u_least)
    return best


@dataclass(frozen=True, eq=False)
class ScaleCheck:
    """One bisection step: whether robust torques exist at a disturbance scale.

    Attributes:
        scale: the scale s.
        lp_feasible: the robustness LP of some piece is feasible (t >= margin).
        robust: that, and the exact exclusion of every other mode at its torques.
        torques: the most robust torques [N m] (None when the LP is infeasible).
        radius: their robustness radius t* [N m or N] (-inf when infeasible).
        piece: the index of the piece (-1 when infeasible).
        exclusions: the exclusion LPs at the torques (empty when infeasible).
    """

    scale: float
    lp_feasible: bool
    robust: bool
    torques: np.ndarray | None
    radius: float
    piece: int
    exclusions: tuple[ModeExclusion, ...]


def check_scale(cp: ClimbProblem, scale: float, *, solver: str | None = None) -> ScaleCheck:
    """The robustness LP of every piece at ``scale`` (best radius), then the exact exclusion.

    Args:
        cp: the built climb (:func:`build_climb`), without obstacle.
        scale: the disturbance scale s >= 0 (V_s).
        solver: the LP back-end (default: the problem's).
    """
    solver = solver or cp.solver
    index, radius, u = _best_piece(cp, scale, solver=solver)
    if u is None:
        return ScaleCheck(float(scale), False, False, None, -math.inf, -1, ())
    exclusions = mode_exclusions(cp.problem, cp.mode, u, cp.robust_points(scale), systems=cp.systems,
                                 solver=solver)
    robust = not any(e.held for e in exclusions)
    return ScaleCheck(float(scale), True, robust, u, radius, index, exclusions)


