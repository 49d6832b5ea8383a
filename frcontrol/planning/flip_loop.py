r"""The flip's closed loop: plan, then re-plan along a rigid simulation until the body passes vertical.

:func:`simulate_flip` re-plans (:func:`~frcontrol.planning.flip.plan_flip`) every ``replan_every``
steps at the simulated state (:meth:`Scene.at`) and applies the plan's rounded torques to one rigid
time stepper (:class:`frcontrol.simulation.rigid.RigidStepper`: velocity-level time stepping,
contacts open and close, inelastic impacts absorbed by the steps' LCPs: ``impact_law=False``,
without the split at landings and the restitution of
:func:`~frcontrol.simulation.rigid.simulate_rigid`, whose instantaneous impacts can end a flip short
of vertical: a toe's impact lifts the front corner) until the pitch passes vertical or ``max_time``:
the re-planning is the policy of :func:`frcontrol.simulation.closed_loop.run_closed_loop`, which
holds the torques between plans. The run is one trajectory, checked for validity like any rigid
simulation. ``frc flip`` runs the same loop through the planning core
(:func:`frcontrol.planning.core.plan_task`); this one keeps the flip's own search
(:func:`~frcontrol.planning.flip.plan_flip`: worst-case modes, free letters) for the library and
the benchmarks.

*Re-planning model:* the scene at the simulated state with the contacts within
:data:`~frcontrol.planning.core.tolerances.REPLAN_GAP_TOLERANCE` of their surface or loaded by the
last step (a loaded contact's normal velocity taken as 0, see :func:`replan_at`), velocities of at
most :data:`~frcontrol.planning.core.tolerances.REPLAN_VELOCITY_TOLERANCE` taken as zero, and any
sign of pitch acceleration accepted. When no plan is made the torques are *held* (the reason is
recorded in ``held``): at an impact (a contact moving into its surface: the acceleration-level
model does not apply), or when no candidate or piece exists; inputs the model forces are set to
their forced value.

*Legs in the air:* the rigid model forces the torque of a massless leg without ground contact (or
lifting off) to 0, and between plans the loop applies that at every step: an input on a massless
coordinate whose contacts are all more than
:data:`~frcontrol.planning.core.tolerances.SEPARATION_GAP` off their surface gets 0. With its rotor
inertia the leg then coasts at the speed it left the ground with, swings round and may touch down
again (no swing controller is modelled).

*Body contact kept:* every body contact that touches at the start (gap at most ``SEPARATION_GAP``)
touches at every sample up to the first sample at or past vertical (or the end). A body contact
that touches down later (the rear corner when the body falls back) does not count, but its
touch-downs and separations are listed in ``body_events`` (:func:`body_contact_events`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Protocol

import numpy as np

from ..errors import FrcontrolError, ImpactState, InputError
from ..jsonable import finite_or_none
from ..scene import Scene
from ..simulation.closed_loop import ClosedLoopRun, LoopOptions, run_closed_loop
from ..simulation.export import sample_modes
from ..simulation.inputs import check_simulation_times
from ..simulation.rigid import CONTACT_FORCE_TOLERANCE, RigidSettings, RigidStepper
from ..simulation.trajectory import Trajectory
from ..solvers import DEFAULT_SETTINGS, SolverSettings
from .core.forced import massless_inputs
from .core.loop import replanning_model
from .core.tolerances import REPLAN_GAP_TOLERANCE, SEPARATION_GAP
from .flip import DEFAULT_MARGIN, FLIP_ARMATURE, FlipPlan, FlipTask, flip_task, plan_flip
from .flip_pitch import FlipSettings

__all__ = [
    "AppliedPlan",
    "FlipResult",
    "FlipLoopOptions",
    "ReplanningPolicy",
    "body_contact_events",
    "loop_options",
    "replan_at",
    "simulate_flip",
    "time_to_vertical",
]


@dataclass(frozen=True)
class FlipLoopOptions:
    """The flip loop's settings besides its times and margin.

    Attributes:
        armature: [kg m^2] rotor inertia of the massless hips (None: the scene's ``[model]``
            armature, else :data:`~frcontrol.planning.flip.FLIP_ARMATURE`).
        solvers: the solver settings of the plans.
    """

    armature: float | None = None
    solvers: SolverSettings = DEFAULT_SETTINGS


@dataclass(frozen=True)
class FlipResult:
    """The closed-loop flip: the first plan, the simulated motion and the verdict.

    Attributes:
        plan: the plan at the scene's state (the torques of the first step).
        trajectory: the simulated motion, up to the first sample at or past vertical (None when no
            first plan was found).
        flipped: the pitch passed ``vertical`` within ``max_time``.
        time_to_vertical: [s] when it did (linear interpolation between samples), else None.
        body_contact_kept: no body contact separated up to the flip (or the end): see
            :func:`simulate_flip`.
        separation: the first separation of a body contact touching at the start
            ``(time [s], contact)``, or None.
        body_events: every touch-down and separation of a body contact up to the flip (or the
            end): ``(time [s], contact, "touchdown" | "separation")``.
        steps: time steps simulated.
        replans: plans made after the first one.
        held: re-planning points at which no plan was made and the torques were held, with why.
        plans: ``(time [s], mode or None, torques)`` of every plan applied, in time order.
        modes: per sample, one letter per scene contact (S when not loaded), for the viewers.
        reason: why the robot did not flip (None if it did).
        vertical: [rad] the pitch to pass.
        dt: [s] the time step; max_time: [s] the simulated time limit.
        armature: [kg m^2] the rotor inertia given to the massless hips.
        timings: [s] ``first_plan``, ``simulation``, ``replanning``, ``total``.
    """

    plan: FlipPlan
    trajectory: Any
    flipped: bool
    time_to_vertical: float | None
    body_contact_kept: bool | None
    separation: tuple[float, str] | None
    body_events: tuple[tuple[float, str, str], ...]
    steps: int
    replans: int
    held: tuple[tuple[float, str], ...]
    plans: tuple[tuple[float, str | None, Mapping[str, float]], ...]
    modes: tuple[str, ...]
    reason: str | None
    vertical: float
    dt: float
    max_time: float
    armature: float
    timings: Mapping[str, float]

    def to_dict(self) -> dict[str, Any]:
        """The ``frc flip --json`` document: the plan's keys and the closed loop's ``simulation``."""
        traj = self.trajectory
        if traj is None:
            return self.plan.to_dict()
        return self.plan.to_dict({
            "flipped": self.flipped,
            "time_to_vertical": finite_or_none(self.time_to_vertical),
            "body_contact_kept": self.body_contact_kept,
            "steps": self.steps,
            "replans": self.replans,
            "simulated": True,
            "reason": self.reason,
            "separation": (None if self.separation is None
                           else {"time": self.separation[0], "contact": self.separation[1]}),
            "body_events": [{"time": t, "contact": c, "kind": k} for t, c, k in self.body_events],
            "held": len(self.held),
            "max_pitch": float(traj.coordinate(self.plan.pitch).max()),
            "vertical": self.vertical,
            "dt": self.dt,
            "max_time": self.max_time,
            "armature": self.armature,
            "duration": traj.duration,
            "status": traj.status,
            "events": [e.to_dict() for e in traj.events],
            "timings": dict(self.timings),
        })





def _weight(scene: Scene) -> float:
    """The robot's weight [N] (1 N without gravity): the scale of contact-force thresholds."""
    return scene.robot.weight_scale()


def _armature(scene: Scene, armature: float | None) -> float:
    if armature is not None:
        return float(armature)
    if scene.model.armature_given:
        return scene.model.armature
    return FLIP_ARMATURE


def simulate_flip(
    scene: Scene,
    *,
    dt: float = 1e-3,
    max_time: float = 2.0,
    replan_every: int = 10,
    margin: float = DEFAULT_MARGIN,
    plan: FlipPlan | None = None,
    progress: Callable[[float, float], None] | None = None,
    options: FlipLoopOptions | None = None,
) -> FlipResult:
    """Plan, then re-plan along a rigid simulation until the body pitches past vertical.

    The loop, the re-planning model, the legs in the air and "body contact kept" are defined in
    the module's docstring (**Closed loop**); it runs on
    :func:`~frcontrol.simulation.closed_loop.run_closed_loop` (the massless hips get the rotor
    inertia ``armature``) until the pitch passes ``FlipTask.vertical`` or ``max_time``.

    Args:
        scene: the scene (RHex on its back).
        dt: [s] the time step.
        max_time: [s] the longest simulated time.
        replan_every: steps between plans, >= 1.
        margin: [N m] the plans' margin.
        plan: the first plan, if already made at the scene's state.
        progress: called with (simulated time, max_time) every ``replan_every`` steps.
        options: the hips' rotor inertia and the solver settings (:class:`FlipLoopOptions`).

    Returns:
        The result; with no first plan, ``trajectory=None`` and ``flipped=False`` with the reason.

    Raises:
        InputError: a bad step, time, count or armature; see :func:`plan_flip`.
    """
    start = time.perf_counter()
    options = options if options is not None else FlipLoopOptions()
    solvers = options.solvers
    max_time, dt, arm = loop_options(scene, dt, max_time, replan_every, options.armature)
    task = flip_task(scene)
    t0 = time.perf_counter()
    first = plan if plan is not None else plan_flip(
        scene, margin=margin, settings=FlipSettings(solvers=solvers))
    timings = {"first_plan": time.perf_counter() - t0, "simulation": 0.0, "replanning": 0.0}
    common = {"vertical": task.vertical, "dt": dt, "max_time": max_time, "armature": arm}
    if not first.found:
        timings["total"] = time.perf_counter() - start
        return FlipResult(plan=first, trajectory=None, flipped=False, time_to_vertical=None,
                          body_contact_kept=None, separation=None, body_events=(), steps=0, replans=0,
                          held=(), plans=(), modes=(), reason=first.reason, timings=timings, **common)

    policy = _Replanner(scene, first, margin, solvers)
    run = _closed_loop(scene, policy, task, dt=dt, max_time=max_time, replan_every=replan_every,
                       armature=arm, progress=progress)
    timings["simulation"] += run.timings["simulation"]
    timings["replanning"] += run.timings["policy"]
    trajectory = replace(run.trajectory, info={**run.trajectory.info, "source": "simulate_flip",
                                               "steps": len(run.trajectory.times) - 1})
    end = len(trajectory.times) - 1
    separation, body_events = body_contact_events(scene, trajectory, task.body_contacts, end)
    modes = sample_modes(scene, trajectory)
    trajectory = replace(trajectory, modes=tuple(modes))
    timings["total"] = time.perf_counter() - start
    return FlipResult(
        plan=first, trajectory=trajectory, flipped=run.stopped,
        time_to_vertical=time_to_vertical(trajectory, task) if run.stopped else None,
        body_contact_kept=separation is None, separation=separation, body_events=body_events,
        steps=len(trajectory.times) - 1, replans=run.decisions, held=tuple(policy.held),
        plans=tuple(policy.plans), modes=modes,
        reason=_not_flipped_reason(trajectory, task, run.stopped, max_time), timings=timings, **common,
    )


def loop_options(scene: Scene, dt: float, max_time: float, replan_every: int, armature: float | None
                  ) -> tuple[float, float, float]:
    """``(max_time, dt, armature)`` of the closed loop, checked before any plan is made.

    Raises:
        InputError: a bad step, time, count or armature.
    """
    max_time, dt = check_simulation_times(max_time, dt)
    if isinstance(replan_every, bool) or not isinstance(replan_every, int) or replan_every < 1:
        raise InputError(f"replan_every must be an integer >= 1 (steps), got {replan_every!r}")
    arm = _armature(scene, armature)
    if not (math.isfinite(arm) and arm > 0):
        raise InputError(f"the armature must be a positive rotor inertia [kg m^2], got {arm!r}")
    return max_time, dt, arm


def _not_flipped_reason(trajectory: Trajectory, task: FlipTask, crossed: bool, max_time: float) -> str | None:
    """Why the run did not pass vertical (None when it did)."""
    failure = trajectory.failure
    if crossed:
        return None
    if failure is not None:
        return f"the simulation {trajectory.status} at t = {failure.time:.4g} s: {failure.reason}"
    return (f"the pitch reached {float(np.max(trajectory.q[:, task.pitch_index])):.4f} rad within "
            f"{max_time:g} s, short of vertical ({task.vertical:.4f} rad)")


def time_to_vertical(trajectory: Trajectory, task: FlipTask) -> float:
    """[s] When the pitch crossed vertical, linear between the last two samples.

    The run stops at the first sample at or past vertical.
    """
    pitch = trajectory.q[:, task.pitch_index]
    end = len(pitch) - 1
    if end == 0:
        return 0.0
    t_a, t_b = trajectory.times[end - 1], trajectory.times[end]
    p_a, p_b = pitch[end - 1], pitch[end]
    return float(t_a + (task.vertical - p_a) / (p_b - p_a) * (t_b - t_a))


class AppliedPlan(Protocol):
    """What a closed loop reads of a plan: its mode, torques and input vector."""

    @property
    def mode(self) -> str | None:
        """The plan's contact mode, or None."""

    @property
    def torques(self) -> Mapping[str, float]:
        """The plan's input per input coordinate."""

    def input_vector(self, inputs: Sequence[str]) -> np.ndarray:
        """The plan's inputs in the order of ``inputs``."""


class ReplanningPolicy:
    """A closed loop's plan record: the last command, every plan applied and every hold.

    Subclasses make a plan at the stepper's state in ``__call__`` and :meth:`record` it. It keeps
    every plan applied ``(time, mode or None, torques)`` and every hold ``(time, why)``; the
    stepper runs on ``self.scene``, the scene at :data:`REPLAN_GAP_TOLERANCE`.
    """

    def __init__(self, scene: Scene, first: AppliedPlan, margin: float, settings: SolverSettings) -> None:
        self.names = scene.inputs.coordinates
        self.scene = replace(scene, gap_tolerance=REPLAN_GAP_TOLERANCE)
        self.force_tolerance = CONTACT_FORCE_TOLERANCE * _weight(scene)
        self.margin, self.settings = margin, settings
        self.command = first.input_vector(self.names)
        self.plans: list[tuple[float, str | None, Mapping[str, float]]] = [
            (0.0, first.mode, dict(first.torques))]
        self.held: list[tuple[float, str]] = []

    def loaded(self, stepper: RigidStepper) -> np.ndarray:
        """Which contacts the stepper's last step loaded (normal force above the tolerance)."""
        return stepper.last_forces[:, 0] > self.force_tolerance

    def record(self, t: float, mode: str | None, why: str | None) -> np.ndarray:
        """Note the command applied from ``t`` (a hold when ``why`` says why); return it."""
        if why is not None:
            self.held.append((t, why))
        self.plans.append((t, mode, dict(zip(self.names, self.command.tolist(), strict=True))))
        return self.command


class _Replanner(ReplanningPolicy):
    """The flip's policy: a plan at the state reached; the torques held when none can be made."""

    def __call__(self, stepper: RigidStepper) -> np.ndarray:
        """The command from the stepper's state on (a contact the last step loaded is planned with)."""
        self.command, mode, why = _replanned(self.scene, stepper, self.loaded(stepper), self.margin,
                                             self.settings, self.command, self.names)
        return self.record(stepper.t, mode, why)


def _closed_loop(scene: Scene, policy: _Replanner, task: FlipTask, *, dt: float, max_time: float,
                 replan_every: int, armature: float, progress: Callable[[float, float], None] | None
                 ) -> ClosedLoopRun:
    """One rigid stepper re-planned every ``replan_every`` steps, until vertical or ``max_time``.

    The stepper runs on the re-planning model's scene (its gap tolerance); a massless leg in the
    air gets no torque (:func:`_free_legs_idle`).
    """
    legs = massless_inputs(scene)
    stepper = RigidStepper(policy.scene, RigidSettings(max_ambiguity_checks=0, impact_law=False),
                           armature=armature)
    return run_closed_loop(
        stepper, policy, max_time, dt, options=LoopOptions(
            every=replan_every, command=policy.command,
            actuate=lambda command, at: _free_legs_idle(scene, legs, command, at.q, at.state.contact_points),
            stop=lambda at: bool(at.q[task.pitch_index] >= task.vertical)), progress=progress)


def _replanned(replan_scene: Scene, stepper: RigidStepper, loaded: np.ndarray, margin: float,
               settings: SolverSettings,
               command: np.ndarray, names: Sequence[str]) -> tuple[np.ndarray, str | None, str | None]:
    """A re-plan at the stepper's state.

    Returns:
        (the command to apply, the plan's mode or None, why the torques are held or None).
    """
    result = replan_at(replan_scene, stepper.q, stepper.v, loaded, margin, settings)
    if isinstance(result, str):
        return command, None, f"{result}: torques held"
    if result.found:
        return result.input_vector(names), result.mode, None
    held = command.copy()
    for name, value in result.forced_inputs.items():
        held[list(names).index(name)] = value
    return held, None, f"no plan ({result.reason}): torques held"


def _free_legs_idle(scene: Scene, legs: dict[int, list[int]], command: np.ndarray,
                    q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
    """The command with 0 on every massless leg in the air.

    A leg is in the air when none of its contacts is within :data:`SEPARATION_GAP` of its
    surface: the rigid model forces its torque to 0. ``points``: the contact points at ``q``
    when known (a stepper's state holds them), else computed.
    """
    if not legs:
        return command
    gaps = _gaps(scene, q, points).tolist()  # Python numbers: a few tests per leg, every step
    free = [i for i, toes in legs.items() if not any(gaps[j] <= SEPARATION_GAP for j in toes)]
    if not free:
        return command
    out = command.copy()
    out[free] = 0.0
    return out


def _gaps(scene: Scene, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
    """Every contact's gap [m] at q (``points``: the contact points at q, when already known)."""
    if points is None:
        points = scene.robot.contact_points_in_world(q)
    normals = np.array([c.point.normal_in_world for c in scene.contacts]).reshape(-1, 2)
    offset = points - np.array([c.point.surface_point_in_world for c in scene.contacts]).reshape(-1, 2)
    return normals[:, 0] * offset[:, 0] + normals[:, 1] * offset[:, 1]  # n . (p - s), as n @ (p - s) sums it


def replan_at(scene: Scene, q: np.ndarray, v: np.ndarray, loaded: np.ndarray, margin: float,
            settings: SolverSettings, free: Mapping[str, str] | None = None) -> FlipPlan | str:
    """The plan at the simulated state, or why none could be made (an impact, an error).

    The re-planning model is the core's (:func:`~frcontrol.planning.core.loop.replanning_model`:
    the contacts within :data:`REPLAN_GAP_TOLERANCE` of their surface or loaded by the last step,
    ``loaded``, a loaded contact's normal velocity taken as 0).
    """
    try:
        here, problem = replanning_model(scene, q, v, loaded)
        return plan_flip(here, margin=margin, problem=problem,
                         settings=FlipSettings(min_pitch_acceleration=None, free=free, solvers=settings))
    except ImpactState as err:
        return f"impact at {err.contact} (v_N = {err.normal_velocity:.3g} m/s)"
    except FrcontrolError as err:
        return f"no plan ({err})"


def body_contact_events(
    scene: Scene, trajectory: Any, body: Sequence[str], end: int
) -> tuple[tuple[float, str] | None, tuple[tuple[float, str, str], ...]]:
    """The first separation of a body contact touching at the start, and every body contact event.

    Up to sample ``end``; the events are ``(time, contact, "touchdown" | "separation")``.
    """
    contacts = [c.name for c in scene.contacts]
    idx = [contacts.index(name) for name in body]
    points = trajectory.contact_points[: end + 1, idx]
    normals = np.array([scene.contacts[i].point.normal_in_world for i in idx]).reshape(-1, 2)
    surfaces = np.array([scene.contacts[i].point.surface_point_in_world for i in idx]).reshape(-1, 2)
    touching = np.einsum("kj,tkj->tk", normals, points - surfaces[None]) <= SEPARATION_GAP
    events = []
    for s in range(1, touching.shape[0]):
        for j in np.nonzero(touching[s] != touching[s - 1])[0]:
            kind = "touchdown" if touching[s, j] else "separation"
            events.append((float(trajectory.times[s]), body[int(j)], kind))
    first = None
    lost = np.nonzero(touching[0] & ~np.all(touching, axis=0))[0]
    if lost.size:
        when = [int(np.argmax(~touching[:, j])) for j in lost]
        earliest = int(np.argmin(when))
        first = (float(trajectory.times[when[earliest]]), body[int(lost[earliest])])
    return first, tuple(events)
