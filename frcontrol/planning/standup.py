r"""Standing up: a task for :mod:`frcontrol.planning.core`, judged from its samples.

**The task.** A legged robot lies on the ground with its feet on the ground beside its body. Its
scene's ``[task]`` is an ordinary task as phases (``solo_standup``): the first phase holds the feet
in mode F (they may not slip) and lets every other contact only leave (S), and *tracks* the base's
(x, y, theta) towards a goal whose y is the stand height, with critically damped PD targets
(least squares, :mod:`frcontrol.planning.core.objective`). The core plans it: at each decision the
inputs in the feet-fixed mode's unambiguous set (at least the phase's margin from every input where
another mode also holds) closest to the targets, rounded and verified with ``solutions_at``,
re-planned along a rigid run (:func:`frcontrol.planning.core.plan_task`).

:func:`standup_task` reads what the stand-up's verdict needs from that task: the *feet* (the
contacts the first phase allows only F) and the *stand height* (its track's target for y).

**The verdict**, from the samples alone (:func:`judge_standup`): the robot *stood* when the base
ends within :data:`STAND_TOLERANCE` of the height and :data:`PITCH_TOLERANCE` of its goal pitch,
and the feet *held* when every foot touched the ground at every sample (gap at most
:data:`~frcontrol.planning.flip.SEPARATION_GAP`) and moved along it by at most
:data:`SLIP_DISTANCE`. ``frc standup`` is a short name for ``frc plan`` on such a scene: its JSON is
``frc plan``'s with the stand-up's own keys merged in
(:func:`frcontrol.planning.core.report.with_legacy_keys`).

**The former keys.** A scene whose ``[task]`` still gives the stand-up's former keys, ``feet`` and
``stand_height``, runs as the phase they meant (:func:`stand_up_as_phases`): the feet F and every
other contact S, tracking (x, theta as they start, y = ``stand_height``) with stiffness
``omega^2`` and damping ``2 omega`` (``omega`` = :data:`STAND_FREQUENCY`: critically damped), the
pitch's error weighted by :data:`PITCH_LENGTH`, for :data:`STAND_DURATION`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..engine import analyze, solutions_at
from ..errors import SceneError
from ..jsonable import finite_or_none, to_jsonable
from ..modes import ContactProblem, add_scene_modes
from ..scene import Scene
from ..simulation.trajectory import Trajectory
from ..solvers import DEFAULT_SETTINGS, SolverSettings
from .core import PlanResult, Task, plan_task, read_task
from .core.objective import objective_rows
from .core.report import with_legacy_keys
from .core.task import DEFAULT_PHASE_MARGIN
from .flip import SEPARATION_GAP, TORQUE_ROUNDING

__all__ = [
    "PITCH_LENGTH",
    "PITCH_TOLERANCE",
    "SLIP_DISTANCE",
    "STAND_DURATION",
    "STAND_FREQUENCY",
    "STAND_TOLERANCE",
    "StandUpResult",
    "StandUpTask",
    "judge_standup",
    "simulate_standup",
    "stand_up_as_phases",
    "standup_task",
]

STAND_TOLERANCE = 0.01
"""[m] The robot stood when its base ends within this of the stand height."""

PITCH_TOLERANCE = 0.05
"""[rad] ... and its pitch within this of the goal's."""

SLIP_DISTANCE = 1e-3
"""[m] Largest distance a foot may move along the ground over the run for the feet to have held
(the time stepper's sticking contacts creep by far less)."""

STAND_FREQUENCY = 6.0
"""[rad/s] The former keys' phase: natural frequency of its critically damped targets (the base
reaches its goal in about ``5 / STAND_FREQUENCY`` seconds when the torques allow)."""

PITCH_LENGTH = 0.2
"""[m] The former keys' phase: weight of the pitch's error against the x and y errors (a pitch
acceleration error of 1 rad/s^2 counts as much as 0.2 m/s^2 at the body's ends)."""

STAND_DURATION = 1.2
"""[s] The former keys' phase: its ``until`` time and the task's ``max_time``."""

_BASE = ("x", "y", "theta")


def stand_up_as_phases(scene: Scene) -> Scene:
    """The scene, its ``[task] feet`` and ``stand_height`` (the former keys) given as the phase they meant.

    A scene without the former keys is returned as it is. See the module's docstring.

    Raises:
        SceneError: a foot that names no contact, a stand height missing or not above the base.
    """
    raw = scene.raw.get("task")
    if not isinstance(raw, Mapping) or "feet" not in raw:
        return scene
    names = [c.name for c in scene.contacts]
    for i, name in enumerate(raw["feet"]):
        if name not in names:
            raise SceneError(str(scene.path), f"task.feet[{i}]", f"unknown contact {name!r}; the contacts "
                             f"are: {', '.join(names)}")
    start = {n: float(scene.q[scene.coordinate_names.index(n)]) for n in _BASE if n in scene.coordinate_names}
    height = raw.get("stand_height")
    if not isinstance(height, (int, float)) or ("y" in start and not height > start["y"]):
        raise SceneError(str(scene.path), "task.stand_height", "expected the base's goal height [m], above "
                         f"its {start.get('y', 0.0):g} m at the scene's state, got {height!r}")
    phase = {
        "name": "stand", "margin": DEFAULT_PHASE_MARGIN, "until": {"time": STAND_DURATION},
        "modes": {name: "F" if name in raw["feet"] else "S" for name in names},
        "track": {"coordinates": {**start, "y": float(height)}, "stiffness": STAND_FREQUENCY**2,
                  "damping": 2.0 * STAND_FREQUENCY, "weights": {"theta": PITCH_LENGTH}},
    }
    return replace(scene, raw={**scene.raw, "task": {"max_time": STAND_DURATION, "phases": [phase]}})


@dataclass(frozen=True)
class StandUpTask:
    """What the stand-up's verdict reads from the scene's task.

    Attributes:
        feet: the contacts the first phase allows only F, in scene order.
        stand_height: [m] the base's goal height y (the first phase's track target for y).
        base_indices: indices of x, y and theta in the minimal coordinates.
        goal: [m, m, rad] the base's goal (a coordinate the track does not name: where it starts).
    """

    feet: tuple[str, ...]
    stand_height: float
    base_indices: tuple[int, int, int]
    goal: np.ndarray


def standup_task(scene: Scene, task: Task | None = None) -> StandUpTask:
    """The stand-up of a scene's task: its first phase's feet and its track's height, validated.

    Raises:
        SceneError: no task as phases (:func:`~frcontrol.planning.core.read_task`), no planar base,
            a first phase that does not track y, allows no contact only F, or aims no higher than
            the base at the scene's state.
    """
    task = task if task is not None else read_task(scene)
    path, phase = str(scene.path), task.phases[0]
    if scene.robot.base != "planar":
        raise SceneError(path, "base", "standing up lifts a floating base: the scene needs base = 'planar'")
    where = "task.phases[0].track.coordinates.y"
    if phase.objective.kind != "track" or "y" not in phase.objective.targets:
        raise SceneError(path, where, "missing: frc standup reads the stand height from the first phase's "
                         "track of y (track = { coordinates = { y = ... } }); run other tasks with frc plan")
    feet = tuple(c.name for c in scene.contacts if phase.modes.get(c.name) == "F")
    if not feet:
        raise SceneError(path, "task.phases[0].modes", "frc standup needs feet: contacts the first phase "
                         f"allows only F (from {', '.join(c.name for c in scene.contacts)})")
    indices = tuple(scene.coordinate_names.index(name) for name in _BASE)
    start = scene.q[list(indices)]
    height = float(phase.objective.targets["y"])
    if not height > start[1]:
        raise SceneError(path, where, f"expected a height above the base's {start[1]:g} m at the scene's "
                         f"state, got {height:g}")
    goal = np.array([float(phase.objective.targets.get(n, s)) for n, s in zip(_BASE, start, strict=True)])
    return StandUpTask(feet, height, indices, goal)  # type: ignore[arg-type]


@dataclass(frozen=True)
class StandUpResult:
    """The stand-up's run (a task run of the core) and its verdict, read from the samples.

    Attributes:
        run: the task run (``frc plan``'s result).
        task: the stand-up read from the scene's task.
        stood: the base ended within :data:`STAND_TOLERANCE` of the height and
            :data:`PITCH_TOLERANCE` of its goal pitch.
        time_to_stand: [s] the first sample from which the base stays within the height tolerance,
            or None.
        feet_held: every foot touched at every sample and moved along the ground by at most
            :data:`SLIP_DISTANCE`.
        foot_travel: [m] per foot, the largest distance its contact point moved along the ground.
        lift_off: [s] the first sample at which no other contact touches, or None.
        final_base: [m, m, rad] the base's (x, y, theta) at the end.
        peak_torques: [N m] the largest |torque| applied, per input.
        peak_speeds: [rad/s or m/s] the largest |velocity| of each input's coordinate.
        reason: why it did not stand (None if it did).
    """

    run: PlanResult
    task: StandUpTask
    stood: bool
    time_to_stand: float | None
    feet_held: bool
    foot_travel: dict[str, float]
    lift_off: float | None
    final_base: np.ndarray
    peak_torques: dict[str, float]
    peak_speeds: dict[str, float]
    reason: str | None

    @property
    def trajectory(self) -> Trajectory:
        """The rigid run."""
        return self.run.trajectory

    def legacy_keys(self, scene: Scene) -> dict[str, Any]:
        """The keys ``frc standup --json`` documented before it was a short name for ``frc plan``.

        The first plan (``found``, ``mode``, ``torques``, ``accelerations`` and ``targets`` of the
        base, ``unambiguous``, ``margin``, ``contacts``, ``reason``), ``task`` (``feet``,
        ``stand_height``), ``tolerances``, ``limits`` and the verdict under ``simulation``.
        """
        decisions = [d for _, d in self.run.run.records[0].decisions]
        trajectory = self.trajectory
        simulation = {
            "simulated": len(trajectory.times) > 1, "stood": self.stood,
            "time_to_stand": finite_or_none(self.time_to_stand), "feet_held": self.feet_held,
            "foot_travel": self.foot_travel, "lift_off": self.lift_off,
            "final_base": dict(zip(_BASE, self.final_base.tolist(), strict=True)),
            "peak_torques": self.peak_torques, "peak_speeds": self.peak_speeds,
            "replans": self.run.run.decisions - 1,
            "held": sum(not d.found for r in self.run.run.records for _, d in r.decisions),
            "reason": self.reason, "duration": self.run.run.max_time,
            "timings": {"replanning": self.run.timings["planning"],
                        "simulation": self.run.timings["simulation"], "total": self.run.timings["total"]},
        }
        payload = {
            **_first_plan(scene, self.run, decisions[0]),
            "task": {"feet": list(self.task.feet), "stand_height": self.task.stand_height},
            "tolerances": {"stand": STAND_TOLERANCE, "pitch": PITCH_TOLERANCE, "slip": SLIP_DISTANCE,
                           "separation_gap": SEPARATION_GAP, "rounding": TORQUE_ROUNDING},
            "limits": {"lower": scene.inputs.lower, "upper": scene.inputs.upper},
            "simulation": simulation,
        }
        return add_scene_modes(to_jsonable(payload), [c.name for c in scene.contacts])

    def to_dict(self, scene: Scene) -> dict[str, Any]:
        """The ``frc standup --json`` document: ``frc plan``'s with :meth:`legacy_keys` merged in."""
        return with_legacy_keys(self.run.to_dict(scene), self.legacy_keys(scene))


def _first_plan(scene: Scene, run: PlanResult, decision: Any) -> dict[str, Any]:
    """The first decision as ``frc standup`` reported it: the base's accelerations and targets named."""
    phase = run.task.phases[0]
    rows = objective_rows(scene, phase.objective, scene.q, scene.v)
    targets = {n: float(a) for n, a in zip(rows.names, rows.targets, strict=True) if n in _BASE}
    accelerations: dict[str, float] = {}
    if decision.found:
        u = np.array([decision.inputs[name] for name in scene.inputs.coordinates])
        solutions = solutions_at(analyze(ContactProblem.from_scene(scene)), u)
        if len(solutions) == 1:
            dv = solutions[0].dv
            accelerations = {n: float(dv[scene.coordinate_names.index(n)]) for n in _BASE}
    return {"found": decision.found, "mode": decision.mode,
            "torques": dict(decision.inputs) if decision.found else None, "accelerations": accelerations,
            "targets": targets, "unambiguous": decision.found, "margin": decision.margin,
            "contacts": list(decision.contacts), "reason": decision.reason}


def judge_standup(scene: Scene, run: PlanResult, task: StandUpTask | None = None) -> StandUpResult:
    """The stand-up's verdict on a task run, from its samples alone (see the module's docstring)."""
    task = task if task is not None else standup_task(scene, run.task)
    trajectory = run.trajectory
    names = [c.name for c in scene.contacts]
    normals = np.array([c.point.normal_in_world for c in scene.contacts]).reshape(-1, 2)
    surfaces = np.array([c.point.surface_point_in_world for c in scene.contacts]).reshape(-1, 2)
    points = trajectory.contact_points
    gaps = np.einsum("kj,tkj->tk", normals, points - surfaces[None])
    tangents = np.stack([normals[:, 1], -normals[:, 0]], axis=1)
    travel, touching = {}, True
    for name in task.feet:
        i = names.index(name)
        travel[name] = float(np.max(np.abs((points[:, i] - points[0, i]) @ tangents[i])))
        touching = touching and bool(np.all(gaps[:, i] <= SEPARATION_GAP))
    others = [i for i, name in enumerate(names) if name not in task.feet and gaps[0, i] <= SEPARATION_GAP]
    off = np.all(gaps[:, others] > SEPARATION_GAP, axis=1) if others else np.ones(len(gaps), dtype=bool)
    base = trajectory.q[:, list(task.base_indices)]
    within = np.abs(base[:, 1] - task.stand_height) <= STAND_TOLERANCE
    time_to_stand = None
    if within[-1]:
        last_out = np.nonzero(~within)[0]
        time_to_stand = float(trajectory.times[last_out[-1] + 1 if last_out.size else 0])
    stood = bool(within[-1] and abs(base[-1, 2] - task.goal[2]) <= PITCH_TOLERANCE
                 and trajectory.status == "completed")
    reason = None
    if not stood:
        reason = (f"the simulation {trajectory.status}" if trajectory.status != "completed" else
                  f"the base ends at y = {base[-1, 1]:.4f} m, theta = {base[-1, 2]:.4f} rad (goal "
                  f"{task.stand_height:g} m within {STAND_TOLERANCE:g} m, {task.goal[2]:.4f} rad within "
                  f"{PITCH_TOLERANCE:g} rad)")
    peak = np.max(np.abs(trajectory.inputs), axis=0)
    speeds = np.max(np.abs(trajectory.v[:, list(scene.inputs.indices)]), axis=0)
    return StandUpResult(
        run, task, stood, time_to_stand, bool(touching and max(travel.values()) <= SLIP_DISTANCE), travel,
        float(trajectory.times[int(np.argmax(off))]) if np.any(off) else None, base[-1].copy(),
        dict(zip(trajectory.input_names, peak.tolist(), strict=True)),
        dict(zip(trajectory.input_names, speeds.tolist(), strict=True)), reason)


def simulate_standup(
    scene: Scene,
    *,
    duration: float | None = None,
    dt: float = 2e-3,
    replan_every: int = 10,
    margin: float | None = None,
    settings: SolverSettings = DEFAULT_SETTINGS,
    progress: Callable[[float, float], None] | None = None,
) -> StandUpResult:
    """Run the scene's stand-up task (:func:`~frcontrol.planning.core.plan_task`) and judge it.

    Args:
        scene: the scene (a robot lying with its feet on the ground, its task a stand-up).
        duration: [s] the simulated time (default: the task's ``max_time``; 0: the first plan only).
        dt: [s] the time step.
        replan_every: steps between plans, >= 1.
        margin: [N m] every plan's margin (default: the phase's).
        settings: the solver settings of every plan's LPs.
        progress: called with (simulated time, duration) every ``replan_every`` steps.

    Raises:
        SceneError: the task is no stand-up (:func:`standup_task`). InputError: a bad margin, step,
            duration or count.
    """
    scene = stand_up_as_phases(scene)
    task = standup_task(scene)
    run = plan_task(scene, dt=dt, replan_every=replan_every, max_time=duration, margin=margin,
                    settings=settings, progress=progress)
    return judge_standup(scene, run, task)
