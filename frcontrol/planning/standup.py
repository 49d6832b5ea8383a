r"""Standing up: joint torques that lift the body onto its feet, unambiguously, along a rigid run.

**The task.** A legged robot lies on the ground with its feet (the scene's ``[task] feet``) on the
ground beside its body. It must lift its base to the height ``[task] stand_height`` [m] (the base
coordinate y), keep its x and its pitch theta where they start, and never let a foot slip: every
foot stays in mode F, every other active contact (the body) is in mode S, leaving the ground.

**One plan.** At a state, the target accelerations of the base are a critically damped return to
the goal, ``a* = omega^2 (goal - q_b) - 2 omega v_b`` for ``q_b = (x, y, theta)``
(``omega`` = :data:`STAND_FREQUENCY`). The mode c (F for the feet, S for the rest) has the affine
response ``dv = X_u u + x_0`` (METHOD §3); the plan chooses u in c's unambiguous set shrunk by a
margin (:func:`frcontrol.planning.flip.margin_pieces`: at least ``margin`` from every input where
another mode also holds), closest to the targets in the weighted L1 norm::

    minimise  sum_i w_i e_i   over (u, e)
    s.t.      -e <= B (X_u u + x_0) - a* <= e,   u in a piece of the unambiguous set,

with B the rows of x, y and theta and ``w = (1, 1, PITCH_LENGTH)``: one LP per convex piece. The
best piece's optimum is rounded to :data:`TORQUE_ROUNDING` and checked with
:func:`frcontrol.engine.solutions_at`: exactly one rigid solution, in mode c. A mode whose base
motion depends on its ambiguity variables w (a statically indeterminate brace whose motion is not
determined) is no plan.

**The closed loop.** :func:`simulate_standup` re-plans every ``replan_every`` steps at the state a
rigid time stepper (:class:`frcontrol.simulation.rigid.RigidStepper`) reached, with the
re-planning model of the flip (contacts within :data:`~frcontrol.planning.flip.REPLAN_GAP_TOLERANCE`
of their surface or loaded by the last step are active; a loaded contact's normal velocity is
taken as 0) and holds the torques when no plan is made (the reason is kept). It runs for the whole
``duration`` and then checks the run from its samples alone: the robot *stood* when the base
ends within :data:`STAND_TOLERANCE` of the height and :data:`PITCH_TOLERANCE` of its pitch, and
the feet *held* when every foot touched the ground at every sample (gap at most
:data:`~frcontrol.planning.flip.SEPARATION_GAP`) and moved along it by at most
:data:`SLIP_DISTANCE`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .. import polytope as poly
from ..engine import DynamicResponse, analyze, solutions_at
from ..errors import FrcontrolError, ImpactState, InputError, SceneError
from ..jsonable import finite_or_none, to_jsonable
from ..modes import VELOCITY_TOLERANCE, ContactProblem, add_scene_modes
from ..response import OUTPUT_TOLERANCE
from ..scene import Contact, Scene
from ..simulation.closed_loop import run_closed_loop
from ..simulation.rigid import RigidSettings, RigidStepper
from ..simulation.trajectory import Trajectory
from ..solvers import DEFAULT_LP_SOLVER, RETRY_ERRORS, solve_lp
from . import DEFAULT_FLIP_MARGIN, DEFAULT_STANDUP_DURATION
from .flip import (
    REPLAN_VELOCITY_TOLERANCE,
    SEPARATION_GAP,
    TORQUE_ROUNDING,
    margin_pieces,
)
from .flip_loop import ReplanningPolicy

__all__ = [
    "DEFAULT_MARGIN",
    "PITCH_LENGTH",
    "PITCH_TOLERANCE",
    "SLIP_DISTANCE",
    "STAND_FREQUENCY",
    "STAND_TOLERANCE",
    "StandUpPlan",
    "StandUpResult",
    "StandUpTask",
    "plan_standup",
    "simulate_standup",
    "standup_task",
    "target_accelerations",
]

DEFAULT_MARGIN = DEFAULT_FLIP_MARGIN
"""[N m] Default distance (in input space) between a plan and every input where another mode holds."""

STAND_FREQUENCY = 6.0
"""[rad/s] Natural frequency of the base's target accelerations (critically damped): the base
reaches its goal in about ``5 / STAND_FREQUENCY`` seconds when the torques allow."""

PITCH_LENGTH = 0.2
"""[m] Weight of the pitch error against the x and y errors in the plan's L1 objective (a pitch
acceleration error of 1 rad/s^2 counts as much as 0.2 m/s^2 at the body's ends)."""

STAND_TOLERANCE = 0.01
"""[m] The robot stood when its base ends within this of ``stand_height``."""

PITCH_TOLERANCE = 0.05
"""[rad] ... and its pitch within this of where it started."""

SLIP_DISTANCE = 1e-3
"""[m] Largest distance a foot may move along the ground over the run for the feet to have held
(the time stepper's sticking contacts creep by far less)."""

_BASE = ("x", "y", "theta")
_DECIMALS = round(-math.log10(TORQUE_ROUNDING))


@dataclass(frozen=True)
class StandUpTask:
    """What the stand-up reads from the scene's ``[task]`` table, and the goal it sets.

    Attributes:
        feet: the contacts held in mode F, in scene order.
        stand_height: [m] the base's goal height y.
        base_indices: indices of x, y and theta in the minimal coordinates.
        goal: [m, m, rad] the base's goal (x and theta as they start, y = ``stand_height``).
    """

    feet: tuple[str, ...]
    stand_height: float
    base_indices: tuple[int, int, int]
    goal: np.ndarray


def standup_task(scene: Scene) -> StandUpTask:
    """The stand-up task of a scene: ``[task] feet`` and ``stand_height``, validated.

    Raises:
        SceneError: no planar base, ``[task]``, ``task.feet`` or ``task.stand_height`` missing, an
            unknown contact, or a height not above the base's height at the scene's state.
        InputError: the scene has no inputs or an input without finite limits.
    """
    path = str(scene.path)
    raw = scene.raw.get("task")
    names = [c.name for c in scene.contacts]
    if not isinstance(raw, Mapping) or "feet" not in raw or "stand_height" not in raw:
        raise SceneError(path, "task.feet" if not isinstance(raw, Mapping) or "feet" not in raw
                         else "task.stand_height",
                         "missing: standing up needs [task] feet, the contacts held in mode F (from "
                         f"{', '.join(names) or 'no contact'}), and stand_height, the base's goal "
                         "height [m]")
    if scene.robot.base != "planar":
        raise SceneError(path, "base", "standing up lifts a floating base: the scene needs base = 'planar'")
    feet = list(raw["feet"])
    for i, name in enumerate(feet):
        if name not in names:
            raise SceneError(path, f"task.feet[{i}]", f"unknown contact {name!r}; the contacts are: "
                             f"{', '.join(names)}")
    indices = tuple(scene.coordinate_names.index(name) for name in _BASE)
    height = float(raw["stand_height"])
    start = scene.q[list(indices)]
    if not height > start[1]:
        raise SceneError(path, "task.stand_height", f"expected a height above the base's {start[1]:g} m "
                         f"at the scene's state, got {height:g}")
    inputs = scene.inputs
    if inputs.count == 0 or not (np.all(np.isfinite(inputs.lower)) and np.all(np.isfinite(inputs.upper))):
        raise InputError(f"scene {scene.name!r} ({scene.path}) needs joint torques with finite limits "
                         "to stand up: give [inputs] coordinates, lower and upper")
    goal = np.array([start[0], height, start[2]])
    chosen = set(feet)
    return StandUpTask(tuple(n for n in names if n in chosen), height, indices, goal)  # type: ignore[arg-type]


def target_accelerations(task: StandUpTask, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``a* = omega^2 (goal - q_b) - 2 omega v_b`` [m/s^2, m/s^2, rad/s^2] for the base (x, y, theta)."""
    idx = list(task.base_indices)
    omega = STAND_FREQUENCY
    return omega**2 * (task.goal - q[idx]) - 2.0 * omega * v[idx]


@dataclass(frozen=True)
class StandUpPlan:
    """The torques at one state.

    Attributes:
        found: a verified plan exists.
        mode: the planned mode (F for the feet, S for the other active contacts), one letter per
            contact of ``contacts``.
        torques: [N m] the rounded input per scene input name.
        accelerations: [m/s^2, m/s^2, rad/s^2] the base's (x, y, theta) at the torques.
        targets: [m/s^2, m/s^2, rad/s^2] the target accelerations a*.
        unambiguous: ``solutions_at`` at the torques gives exactly one solution, in ``mode``.
        margin: [N m] the distance kept from every other mode's inputs.
        contacts: the active contacts, in mode-letter order.
        pieces: convex pieces of the mode's unambiguous set searched.
        reason: why no plan was found (None when found).
        timings: [s] ``analysis``, ``lps``, ``total``.
    """

    found: bool
    mode: str | None
    torques: Mapping[str, float]
    accelerations: Mapping[str, float]
    targets: Mapping[str, float]
    unambiguous: bool
    margin: float
    contacts: tuple[str, ...]
    pieces: int
    reason: str | None
    timings: Mapping[str, float] = field(default_factory=dict)

    def input_vector(self, inputs: Sequence[str]) -> np.ndarray:
        """The torques in the order of ``inputs``."""
        return np.array([float(self.torques.get(name, 0.0)) for name in inputs])


def plan_standup(
    scene: Scene,
    *,
    task: StandUpTask | None = None,
    margin: float = DEFAULT_MARGIN,
    solver: str = DEFAULT_LP_SOLVER,
    problem: ContactProblem | None = None,
) -> StandUpPlan:
    """The torques, in the feet-fixed mode's unambiguous set, closest to the base's targets.

    See the module's docstring.

    Args:
        scene: the scene at the state to plan at.
        task: its task (default: :func:`standup_task`).
        margin: [N m] the distance kept from every input where another mode also holds, >= 0.
        solver: LP back-end.
        problem: the contact problem to plan on (default: the scene's at its state).

    Raises:
        SceneError, InputError: a bad task or margin. ImpactState: a contact moves into its surface.
    """
    start = time.perf_counter()
    if not (isinstance(margin, (int, float)) and math.isfinite(margin) and margin >= 0):
        raise InputError(f"the margin must be a finite number >= 0 [N m], got {margin!r}")
    task = task if task is not None else standup_task(scene)
    problem = problem if problem is not None else ContactProblem.from_scene(
        scene, velocity_tolerance=VELOCITY_TOLERANCE)
    targets = target_accelerations(task, scene.q, scene.v)
    mode = "".join("F" if name in task.feet else "S" for name in problem.contacts)
    common: dict[str, Any] = {"targets": dict(zip(_BASE, targets.tolist(), strict=True)),
                              "margin": float(margin), "contacts": problem.contacts}
    if "F" not in mode:
        return _none("no foot touches the ground", common, start)
    analysis = analyze(problem, solver=solver)
    t_analysis = time.perf_counter() - start
    if mode not in [m.mode for m in analysis.feasible_modes]:
        return _none(f"mode {problem.scene_mode(mode)} (feet fixed, the rest leaving) is infeasible within "
                     "the torque limits", common, start)
    chosen = _best_torques(analysis, mode, task, targets, margin, solver)
    if isinstance(chosen, str):
        return _none(chosen, common, start)
    u, dv, count = chosen
    torques = dict(zip(scene.inputs.coordinates, u.tolist(), strict=True))
    accelerations = dict(zip(_BASE, dv[list(task.base_indices)].tolist(), strict=True))
    total = time.perf_counter() - start
    return StandUpPlan(True, mode, torques, accelerations, unambiguous=True, pieces=count, reason=None,
                       timings={"analysis": t_analysis, "lps": total - t_analysis, "total": total},
                       **common)


def _none(reason: str, common: Mapping[str, Any], start: float) -> StandUpPlan:
    return StandUpPlan(False, None, {}, {}, unambiguous=False, pieces=0, reason=reason,
                       timings={"total": time.perf_counter() - start}, **common)


def _best_torques(analysis: DynamicResponse, mode: str, task: StandUpTask, targets: np.ndarray,
                  margin: float, solver: str) -> tuple[np.ndarray, np.ndarray, int] | str:
    """(rounded torques, their dv, pieces searched): the best verified piece optimum, or why none."""
    chosen = analysis.mode(mode)
    named = analysis.problem.scene_mode(mode)  # as every output prints it
    if not chosen.inputs_full_dimensional:
        return f"mode {named} needs its torques on a hyperplane (its input domain is flat)"
    response = chosen.response
    rows = response.X_u[list(task.base_indices)]
    offset = response.x_0[list(task.base_indices)]
    if response.X_w.size:
        coupling = response.X_w[list(task.base_indices)]
        if np.max(np.abs(coupling)) > OUTPUT_TOLERANCE * max(float(np.max(np.abs(response.X_w))), 1e-300):
            return f"the base's motion in mode {named} is ambiguous (it depends on the mode's w)"
    pieces = margin_pieces(analysis, mode, margin, solver=solver)
    if not pieces:
        return f"mode {named} has no unambiguous input {margin:g} N m away from every other mode"
    found = (_closest(piece, rows, offset, targets, solver) for piece in pieces)
    optima = sorted((o for o in found if o is not None), key=lambda o: o[0])
    problem = analysis.problem
    for _, u in optima:
        rounded = np.minimum(np.maximum([round(float(x), _DECIMALS) for x in u], problem.lower),
                             problem.upper) + 0.0  # the double nearest the printed decimal
        solutions = solutions_at(analysis, rounded, solver=solver)
        if [s.mode for s in solutions] == [mode]:
            return rounded, solutions[0].dv, len(pieces)
    return f"no piece's optimum gives exactly one rigid solution in mode {named} once rounded"


def _closest(piece: poly.Polytope, rows: np.ndarray, offset: np.ndarray, targets: np.ndarray,
             solver: str) -> tuple[float, np.ndarray] | None:
    """``(weighted L1 error, u)`` of the inputs of ``piece`` closest to the targets (one LP)."""
    m = rows.shape[1]
    weights = np.array([1.0, 1.0, PITCH_LENGTH])
    cost = np.concatenate([np.zeros(m), weights])
    minus = -np.eye(3)
    A = np.vstack([np.hstack([piece.A, np.zeros((piece.A.shape[0], 3))]),
                   np.hstack([rows, minus]), np.hstack([-rows, minus])])
    b = np.concatenate([piece.b, targets - offset, offset - targets])
    result = solve_lp(cost, A, b, solver=solver, fallback=RETRY_ERRORS)
    if not result.found or result.x is None:
        return None
    return float(result.objective), result.x[:m].copy()


# ---------------------------------------------------------------------------------------------
# the closed loop


@dataclass(frozen=True)
class StandUpResult:
    """The closed-loop stand-up and its verdict, read from the samples.

    Attributes:
        plan: the plan at the scene's state (the first torques).
        trajectory: the simulated run (None when no first plan was found).
        stood: the base ended within :data:`STAND_TOLERANCE` of the height and
            :data:`PITCH_TOLERANCE` of its starting pitch.
        time_to_stand: [s] the first sample from which the base stays within the height tolerance,
            or None.
        feet_held: every foot touched at every sample and moved along the ground by at most
            :data:`SLIP_DISTANCE`.
        foot_travel: [m] per foot, the largest distance its contact point moved along the ground.
        lift_off: [s] the first sample at which no other contact touches (the body is off the
            ground), or None.
        final_base: [m, m, rad] the base's (x, y, theta) at the end.
        peak_torques: [N m] the largest |torque| applied, per input.
        peak_speeds: [rad/s or m/s] the largest |velocity| of each input's coordinate.
        replans: plans made after the first.
        held: re-planning points at which no plan was made and the torques were held, with why.
        plans: ``(time [s], mode or None, torques)`` of every plan applied.
        reason: why it did not stand (None if it did).
        dt: [s] the step; duration: [s] the simulated time.
        timings: [s] ``first_plan``, ``simulation``, ``replanning``, ``total``.
    """

    plan: StandUpPlan
    trajectory: Trajectory | None
    stood: bool
    time_to_stand: float | None
    feet_held: bool | None
    foot_travel: Mapping[str, float]
    lift_off: float | None
    final_base: np.ndarray | None
    peak_torques: Mapping[str, float]
    peak_speeds: Mapping[str, float]
    replans: int
    held: tuple[tuple[float, str], ...]
    plans: tuple[tuple[float, str | None, Mapping[str, float]], ...]
    reason: str | None
    dt: float
    duration: float
    timings: Mapping[str, float]

    def to_dict(self, scene: Scene) -> dict[str, Any]:
        """The ``frc standup --json`` document: the first plan and ``simulation`` with ``samples``.

        ``simulation.samples`` has the shape of ``frc simulate --json``'s (``times``, ``q``, ``v``,
        ``inputs``, ``forces``, ``modes``...): a reader can check the height, the torque limits and
        the feet from them alone.
        """
        plan, task = self.plan, standup_task(scene)
        payload: dict[str, Any] = {
            "found": plan.found, "mode": plan.mode, "torques": dict(plan.torques) if plan.found else None,
            "accelerations": dict(plan.accelerations), "targets": dict(plan.targets),
            "unambiguous": plan.unambiguous, "margin": plan.margin, "contacts": list(plan.contacts),
            "reason": plan.reason,
            "task": {"feet": list(task.feet), "stand_height": task.stand_height},
            "tolerances": {"stand": STAND_TOLERANCE, "pitch": PITCH_TOLERANCE, "slip": SLIP_DISTANCE,
                           "separation_gap": SEPARATION_GAP, "rounding": TORQUE_ROUNDING},
            "limits": {"lower": scene.inputs.lower, "upper": scene.inputs.upper},
        }
        simulation: dict[str, Any] = {
            "simulated": self.trajectory is not None, "stood": self.stood,
            "time_to_stand": finite_or_none(self.time_to_stand), "feet_held": self.feet_held,
            "foot_travel": dict(self.foot_travel), "lift_off": self.lift_off,
            "final_base": None if self.final_base is None else dict(zip(_BASE, self.final_base.tolist(),
                                                                         strict=True)),
            "peak_torques": dict(self.peak_torques), "peak_speeds": dict(self.peak_speeds),
            "replans": self.replans, "held": len(self.held),
            "reason": self.reason, "dt": self.dt, "duration": self.duration, "timings": dict(self.timings),
        }
        if self.trajectory is not None:
            document = self.trajectory.to_dict(scene)
            simulation.update({"status": self.trajectory.status, "samples": document["samples"],
                               "events": document["summary"]["events"]})
        payload["simulation"] = simulation
        return add_scene_modes(to_jsonable(payload), [c.name for c in scene.contacts])


def simulate_standup(
    scene: Scene,
    *,
    duration: float = DEFAULT_STANDUP_DURATION,
    dt: float = 2e-3,
    replan_every: int = 10,
    margin: float = DEFAULT_MARGIN,
    solver: str = DEFAULT_LP_SOLVER,
    progress: Callable[[float, float], None] | None = None,
) -> StandUpResult:
    """Plan, then re-plan along a rigid run for ``duration``; judge the run from its samples.

    Args:
        scene: the scene (a robot lying with its feet on the ground).
        duration: [s] the simulated time (0: the first plan only).
        dt: [s] the time step.
        replan_every: steps between plans, >= 1.
        margin: [N m] the plans' margin.
        solver: LP back-end.
        progress: called with (simulated time, duration) every ``replan_every`` steps.

    Raises:
        SceneError, InputError: a bad task, margin, step, duration or count.
    """
    start = time.perf_counter()
    task = standup_task(scene)
    if isinstance(replan_every, bool) or not isinstance(replan_every, int) or replan_every < 1:
        raise InputError(f"replan_every must be an integer >= 1 (steps), got {replan_every!r}")
    first = plan_standup(scene, task=task, margin=margin, solver=solver)
    timings = {"first_plan": time.perf_counter() - start, "simulation": 0.0, "replanning": 0.0}
    if not first.found or duration <= 0:
        timings["total"] = time.perf_counter() - start
        why = first.reason if not first.found else "not simulated (duration 0)"
        return StandUpResult(first, None, False, None, None, {}, None, None, {}, {}, 0, (), (), why, dt,
                             float(duration), timings)
    policy = _Replanner(scene, task, first, margin, solver)
    stepper = RigidStepper(policy.scene, RigidSettings(max_ambiguity_checks=0))
    run = run_closed_loop(stepper, policy, duration, dt, every=replan_every, command=policy.command,
                          progress=progress)
    timings["simulation"], timings["replanning"] = run.timings["simulation"], run.timings["policy"]
    trajectory = replace(run.trajectory, info={**run.trajectory.info, "source": "simulate_standup",
                                               "steps": len(run.trajectory.times) - 1})
    verdict = _judge(scene, task, trajectory)
    timings["total"] = time.perf_counter() - start
    return StandUpResult(first, trajectory, replans=run.decisions, held=tuple(policy.held),
                         plans=tuple(policy.plans), dt=dt, duration=float(duration), timings=timings,
                         **verdict)


def _judge(scene: Scene, task: StandUpTask, trajectory: Trajectory) -> dict[str, Any]:
    """The verdict fields of :class:`StandUpResult`, from the samples alone."""
    names = [c.name for c in scene.contacts]
    normals = np.array([c.point.normal_in_world for c in scene.contacts]).reshape(-1, 2)
    surfaces = np.array([c.point.surface_point_in_world for c in scene.contacts]).reshape(-1, 2)
    points = trajectory.contact_points
    gaps = np.einsum("kj,tkj->tk", normals, points - surfaces[None])
    tangents = np.stack([normals[:, 1], -normals[:, 0]], axis=1)
    travel = {}
    touching = True
    for name in task.feet:
        i = names.index(name)
        along = (points[:, i] - points[0, i]) @ tangents[i]
        travel[name] = float(np.max(np.abs(along)))
        touching = touching and bool(np.all(gaps[:, i] <= SEPARATION_GAP))
    others = [i for i, name in enumerate(names) if name not in task.feet and gaps[0, i] <= SEPARATION_GAP]
    off = np.all(gaps[:, others] > SEPARATION_GAP, axis=1) if others else np.ones(len(gaps), dtype=bool)
    lift_off = float(trajectory.times[int(np.argmax(off))]) if np.any(off) else None
    base = trajectory.q[:, list(task.base_indices)]
    within = np.abs(base[:, 1] - task.stand_height) <= STAND_TOLERANCE
    time_to_stand = None
    if within[-1]:
        last_out = np.nonzero(~within)[0]
        time_to_stand = float(trajectory.times[last_out[-1] + 1 if last_out.size else 0])
    pitch_ok = abs(base[-1, 2] - task.goal[2]) <= PITCH_TOLERANCE
    stood = bool(within[-1] and pitch_ok and trajectory.status == "completed")
    held = touching and max(travel.values()) <= SLIP_DISTANCE
    reason = None
    if not stood:
        reason = (f"the simulation {trajectory.status}" if trajectory.status != "completed" else
                  f"the base ends at y = {base[-1, 1]:.4f} m, theta = {base[-1, 2]:.4f} rad (goal "
                  f"{task.stand_height:g} m within {STAND_TOLERANCE:g} m, {task.goal[2]:.4f} rad within "
                  f"{PITCH_TOLERANCE:g} rad)")
    peak = np.max(np.abs(trajectory.inputs), axis=0)
    speeds = np.max(np.abs(trajectory.v[:, list(scene.inputs.indices)]), axis=0)
    return {"stood": stood, "time_to_stand": time_to_stand, "feet_held": bool(held), "foot_travel": travel,
            "lift_off": lift_off, "final_base": base[-1].copy(), "reason": reason,
            "peak_torques": dict(zip(trajectory.input_names, peak.tolist(), strict=True)),
            "peak_speeds": dict(zip(trajectory.input_names, speeds.tolist(), strict=True))}


class _Replanner(ReplanningPolicy):
    """The stand-up's policy: a plan at the state reached; the torques held when none is made."""

    def __init__(self, scene: Scene, task: StandUpTask, first: StandUpPlan, margin: float,
                 solver: str) -> None:
        super().__init__(scene, first, margin, solver)
        self.task = task

    def __call__(self, stepper: RigidStepper) -> np.ndarray:
        """The command from the stepper's state on."""
        loaded = self.loaded(stepper)
        here = self.scene.at(stepper.q, stepper.v)
        contacts = tuple(Contact(c.point, c.gap, bool(c.active or loaded[i]))
                         for i, c in enumerate(here.contacts))
        here = replace(here, contacts=contacts)
        try:
            problem = ContactProblem.from_scene(here, velocity_tolerance=REPLAN_VELOCITY_TOLERANCE)
            down = np.array([bool(loaded[i]) for i, c in enumerate(contacts) if c.active], dtype=bool)
            if down.size:
                problem = replace(problem, normal_velocities=np.where(down, 0.0, problem.normal_velocities))
            plan = plan_standup(here, task=self.task, margin=self.margin, solver=self.solver, problem=problem)
            why = None if plan.found else f"no plan ({plan.reason}): torques held"
        except ImpactState as err:
            plan, why = None, f"impact at {err.contact} (v_N = {err.normal_velocity:.3g} m/s): torques held"
        except FrcontrolError as err:
            plan, why = None, f"no plan ({err}): torques held"
        if plan is not None and plan.found:
            self.command = plan.input_vector(self.names)
        return self.record(stepper.t, plan.mode if plan is not None else None, why)
