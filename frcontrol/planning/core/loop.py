r"""Running a task: decisions along one rigid closed-loop run, phase after phase.

:func:`run_task` plans the first phase at the scene's state (:func:`~.decision.decide`), then steps
one rigid time stepper (:class:`~frcontrol.simulation.rigid.RigidStepper`, inelastic impacts
absorbed by the steps' LCPs as in the flip's loop) and re-plans every ``replan_every`` steps at the
state reached, holding the inputs in between (:func:`~frcontrol.simulation.closed_loop.run_closed_loop`).
After every step the current phase's ``until`` is checked at the new state; when it holds, the phase
ends there and the next one is planned before the next step. The run ends when the last phase's
``until`` holds (the task is *achieved*), at ``max_time``, or when the simulation cannot go on
(``max_time`` 0: the first plan only, and a run of one sample).

*Re-planning model* (the flip's and the stand-up's): the scene at the state reached, with the
contacts within :data:`~.tolerances.REPLAN_GAP_TOLERANCE` of their surface or loaded by
the last step active, a loaded contact's normal velocity taken as 0, and velocities of at most
:data:`~.tolerances.REPLAN_VELOCITY_TOLERANCE` taken as zero. When no plan is made (no
allowed mode can be made unambiguous, or an impact) the inputs are held (the inputs the rigid model
forces at the state set to their forced value) and the decision, with its reason, is kept in the
phase's record. Between plans, every input on a massless coordinate whose contacts are all off
their surface gets 0 (:func:`~.forced.idle_in_the_air`).

*A phase timing* (:class:`PhaseTiming`, named by ``[task] timing``, :mod:`.timing`) plugs into the
loop where a task needs more than ``until`` in order: it ends phases (a :class:`Switch` to a phase
by name, or the end of the run), drives the phases it owns (their inputs, instead of a plan), may
overrule a plan, and gives the letters a plan's other rigid solutions may have (``free``) and the
stepper's settings. With a timing, the timing alone ends phases; the phases' ``until`` are data it
reads. A timing with step hooks (:class:`~.timing.StepHooks`) also gives the scene the stepper runs
on and the inputs of every step.

*Contacts in ``until``*: a contact is *closed* at a sample when its gap is at most
:data:`~.tolerances.SEPARATION_GAP`, else *open*.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from ...errors import FrcontrolError, ImpactState, InputError
from ...modes import VELOCITY_TOLERANCE, ContactProblem
from ...scene import Contact, Scene
from ...simulation.closed_loop import LoopOptions, run_closed_loop
from ...simulation.inputs import check_simulation_times
from ...simulation.rigid import CONTACT_FORCE_TOLERANCE, RigidSettings, RigidStepper
from ...solvers import DEFAULT_SETTINGS, SolverSettings
from .decision import Decision, decide
from .forced import idle_in_the_air, massless_inputs
from .scale import ScaleResult, largest_scale
from .task import Phase, Task, Until
from .timing import PhaseTiming, Switch, load_timing, step_hooks
from .tolerances import REPLAN_GAP_TOLERANCE, REPLAN_VELOCITY_TOLERANCE, SEPARATION_GAP

__all__ = ["PhaseRecord", "TaskRun", "contact_gaps", "replanning_model", "run_task", "until_met"]


@dataclass
class PhaseRecord:
    """One phase as it ran.

    Attributes:
        name: the phase's name.
        start: [s] when it started.
        end: [s] when it ended (None while running).
        why: why it ended (``until``'s condition, ``max_time``, the simulation's failure).
        decisions: ``(time [s], decision)`` of every plan made in it, in order.
        met: its ``until`` held.
        largest_scale: a robust phase with ``largest_scale``: the search at its first decision.
    """

    name: str
    start: float
    end: float | None = None
    why: str | None = None
    decisions: list[tuple[float, Decision]] = field(default_factory=list)
    met: bool = False
    largest_scale: ScaleResult | None = None


def replanning_model(
    scene: Scene, q: np.ndarray, v: np.ndarray, loaded: np.ndarray
) -> tuple[Scene, ContactProblem]:
    """The scene at ``(q, v)`` and its contact problem as a closed loop re-plans on it.

    The contacts within the scene's gap tolerance or loaded by the last step (``loaded``, one flag
    per scene contact) are active; a loaded contact's normal velocity is taken as 0 (the
    velocity-level stepper leaves a loaded contact on a turning leg with a normal velocity of order
    ``dt`` times its centripetal acceleration, and removes a penetration with ``-phi / dt``: both
    would make it look separating); velocities up to :data:`REPLAN_VELOCITY_TOLERANCE` are 0.

    Raises:
        ImpactState: a contact moves into its surface.
    """
    here = scene.at(q, v)
    contacts = tuple(
        Contact(c.point, c.gap, bool(c.active or loaded[i])) for i, c in enumerate(here.contacts)
    )
    here = replace(here, contacts=contacts)
    problem = ContactProblem.from_scene(here, velocity_tolerance=REPLAN_VELOCITY_TOLERANCE)
    down = np.array([bool(loaded[i]) for i, c in enumerate(contacts) if c.active], dtype=bool)
    if down.size:
        problem = replace(problem, normal_velocities=np.where(down, 0.0, problem.normal_velocities))
    return here, problem


def contact_gaps(scene: Scene, q: np.ndarray) -> np.ndarray:
    """Every contact's gap [m] at ``q`` (along its normal, from its surface point)."""
    points = scene.robot.contact_points_in_world(q)
    return np.array(
        [
            c.point.normal_in_world @ (p - c.point.surface_point_in_world)
            for c, p in zip(scene.contacts, points, strict=True)
        ]
    ).reshape(-1)


def until_met(scene: Scene, until: Until, q: np.ndarray, elapsed: float) -> bool:
    """Whether ``until`` holds at the configuration ``q``, ``elapsed`` seconds into the phase."""
    if until.kind == "time":
        assert until.time is not None
        return elapsed >= until.time
    if until.kind == "coordinate":
        value = float(q[list(scene.coordinate_names).index(str(until.coordinate))])
        return value >= until.above if until.above is not None else value <= float(until.below)  # type: ignore[arg-type]
    gaps = contact_gaps(scene, q)
    names = [c.name for c in scene.contacts]
    return all(
        (gaps[names.index(name)] <= SEPARATION_GAP) == (state == "closed")
        for name, state in until.contacts.items()
    )


class _TaskPolicy:
    """The closed loop's policy: the phase's plan at the state reached; phases advance on ``until``."""

    def __init__(
        self, scene: Scene, task: Task, settings: SolverSettings, margin: float | None,
        timing: PhaseTiming | None = None,
    ) -> None:
        self.scene = replace(scene, gap_tolerance=REPLAN_GAP_TOLERANCE)
        self.timing = timing
        self.phases = task.sequence() if timing is None else list(task.phases)
        if margin is not None:
            self.phases = [replace(p, margin=margin) for p in self.phases]
        self.settings = settings
        self.names = scene.inputs.coordinates
        self.force_tolerance = CONTACT_FORCE_TOLERANCE * scene.robot.weight_scale()
        self.command = np.clip(np.zeros(len(self.names)), scene.inputs.lower, scene.inputs.upper)
        self.records = [PhaseRecord(self.phases[0].name, 0.0)]
        self.legs = massless_inputs(scene)
        self.pending = False
        self.done = False
        self.named = {p.name: p for p in self.phases}
        self.hooks = step_hooks(timing)

    @property
    def phase(self) -> Phase:
        """The phase running."""
        if self.timing is not None:
            return self.named[self.records[-1].name]
        return self.phases[len(self.records) - 1]

    def _switch(self, t: float, switch: Switch) -> None:
        """End the running phase at ``t`` (a timing's switch); start the next one, if any."""
        record = self.records[-1]
        record.end, record.why, record.met = t, switch.why, switch.met
        if switch.to is not None:
            self.records.append(PhaseRecord(switch.to, t))

    def _timed(self, stepper: RigidStepper | None) -> np.ndarray | None:
        """A timing's inputs at a decision (its switches made first); None: plan the phase."""
        if self.timing is None:
            return None
        if stepper is not None:
            switch = self.timing.before_decision(self.phase, stepper)
            if switch is not None:
                self._switch(stepper.t, switch)
        driven = self.timing.drive(self.phase, stepper)
        return None if driven is None else np.asarray(driven, dtype=float)

    def plan(self, stepper: RigidStepper | None) -> np.ndarray:
        """Plan the current phase at the stepper's state (the scene's at the start); hold when no plan."""
        t = 0.0 if stepper is None else stepper.t
        driven = self._timed(stepper)
        if driven is not None:
            self.command = driven
            return self.command
        free = None if self.timing is None else self.timing.free(self.phase)
        try:
            here, problem = self._model(stepper)
            decision = decide(here, self.phase, problem=problem, settings=self.settings, free=free)
            if self.phase.largest_scale is not None and not self.records[-1].decisions:
                full = problem or ContactProblem.from_scene(here, velocity_tolerance=VELOCITY_TOLERANCE)
                self.records[-1].largest_scale = largest_scale(here, self.phase, full, settings=self.settings)
        except ImpactState as err:
            decision = _held(self.phase, f"impact at {err.contact} (v_N = {err.normal_velocity:.3g} m/s)")
        except FrcontrolError as err:
            decision = _held(self.phase, str(err))
        self.records[-1].decisions.append((t, decision))
        if self.timing is not None:
            other, switch = self.timing.decided(self.phase, decision, stepper)
            if switch is not None:
                self._switch(t, switch)
                other = self.timing.drive(self.phase, stepper)
            if other is not None:
                self.command = np.asarray(other, dtype=float)
                return self.command
        values = decision.inputs if decision.found else decision.forced
        self.command = np.array([values.get(n, c) for n, c in zip(self.names, self.command, strict=True)])
        return self.command

    def _model(self, stepper: RigidStepper | None) -> tuple[Scene, ContactProblem | None]:
        """The re-planning model at the stepper's state (see the module's docstring)."""
        if stepper is None:
            return self.scene, None
        loaded = stepper.last_forces[:, 0] > self.force_tolerance
        return replanning_model(self.scene, stepper.q, stepper.v, loaded)

    def __call__(self, stepper: RigidStepper) -> np.ndarray:
        """The run's periodic re-plan."""
        return self.plan(stepper)

    def actuate(self, held: np.ndarray, stepper: RigidStepper) -> np.ndarray:
        """Each step's inputs: a new phase planned before its first step; massless inputs in the air: 0."""
        if self.pending:
            self.pending = False
            self.plan(stepper)
        if self.hooks is not None:
            return self.hooks.actuate(self.phase, self.command, stepper)
        if not self.legs:
            return self.command
        return idle_in_the_air(self.legs, contact_gaps(self.scene, stepper.q), self.command)

    def stop(self, stepper: RigidStepper) -> bool:
        """After each step: end the phase when its ``until`` holds; stop after the last phase."""
        record = self.records[-1]
        if self.timing is not None:
            switch = self.timing.after_step(self.phase, stepper, stepper.t - record.start)
            if switch is None:
                return False
            self._switch(stepper.t, switch)
            self.pending = switch.to is not None
            self.done = switch.to is None and switch.met
            return switch.to is None
        if not until_met(self.scene, self.phase.until, stepper.q, stepper.t - record.start):
            return False
        record.end, record.why, record.met = stepper.t, f"until {self.phase.until.describe()}", True
        if len(self.records) == len(self.phases):
            self.done = True
            return True
        self.records.append(PhaseRecord(self.phases[len(self.records)].name, stepper.t))
        self.pending = True
        return False


def _held(phase: Phase, why: str) -> Decision:
    return Decision(False, None, (), {}, None, phase.margin, phase.robust, 0, (), why)


@dataclass(frozen=True)
class TaskRun:
    """A task's closed-loop run: its phases' records and the trajectory (applied inputs included).

    Attributes:
        records: the phases as they ran.
        trajectory: the rigid run.
        achieved: the last phase's ``until`` held within ``max_time``.
        decisions: the plans made (the first included).
        dt: [s] the step; max_time: [s] the longest simulated time; replan_every: steps between plans.
        timings: [s] ``planning``, ``simulation``.
        timing: the task's phase timing (:mod:`.timing`), or None.
    """

    records: tuple[PhaseRecord, ...]
    trajectory: object
    achieved: bool
    decisions: int
    dt: float
    max_time: float
    replan_every: int
    timings: dict[str, float]
    timing: PhaseTiming | None = None


def _first_plan_only(policy: _TaskPolicy, stepper: RigidStepper, dt: float, replan_every: int) -> TaskRun:
    """``max_time = 0``: the first plan at the scene's state, and a run of one sample (no step)."""
    check_simulation_times(dt, dt, scene=policy.scene)  # the step's own checks
    last = policy.records[-1]
    last.end, last.why = 0.0, "max_time 0 s: the first plan only"
    return TaskRun(tuple(policy.records), stepper.trajectory(dt), False, 1, dt, 0.0, replan_every,
                   {"planning": 0.0, "simulation": 0.0})


def run_task(
    scene: Scene,
    task: Task,
    *,
    dt: float = 1e-3,
    replan_every: int = 10,
    max_time: float | None = None,
    margin: float | None = None,
    settings: SolverSettings = DEFAULT_SETTINGS,
    progress: Callable[[float, float], None] | None = None,
) -> TaskRun:
    """Plan and re-plan ``task`` along one rigid run (see the module's docstring).

    Args:
        scene: the scene.
        task: its task (:func:`~.task.read_task`).
        dt: [s] the step.
        replan_every: steps between plans, >= 1.
        max_time: [s] the longest simulated time (default: the task's; 0: the first plan only, a
            run of one sample).
        margin: [input units] every phase's margin (default: each phase's own).
        settings: the solver settings of every plan's LPs.
        progress: called with (simulated time, max_time) every ``replan_every`` steps.

    Raises:
        InputError: a bad step, time, count or margin.
        SceneError: the phase timing's checks of the scene (:func:`~.timing.load_timing`).
    """
    if isinstance(replan_every, bool) or not isinstance(replan_every, int) or replan_every < 1:
        raise InputError(f"replan_every must be an integer >= 1 (steps), got {replan_every!r}")
    if margin is not None and not (np.isfinite(margin) and margin >= 0):
        raise InputError(f"the margin must be a finite number >= 0 [input units], got {margin!r}")
    duration = task.max_time if max_time is None else max_time
    if margin is not None:  # the timing reads the phases the policy plans
        task = replace(task, phases=tuple(replace(p, margin=margin) for p in task.phases))
    timing = load_timing(scene, task)
    policy = _TaskPolicy(scene, task, settings, margin, timing)
    armature = scene.model.armature if scene.model.armature_given else None
    rigid = RigidSettings(max_ambiguity_checks=0, impact_law=False) if timing is None else timing.settings
    hooks = step_hooks(timing)
    stepped = policy.scene if hooks is None else hooks.stepper_scene(scene)
    stepper = RigidStepper(stepped, rigid, armature=armature)
    first = policy.plan(None)
    if duration == 0:  # the first plan only: a run of one sample, at the scene's state
        return _first_plan_only(policy, stepper, dt, replan_every)
    run = run_closed_loop(
        stepper,
        policy,
        duration,
        dt,
        options=LoopOptions(every=replan_every, command=first, actuate=policy.actuate, stop=policy.stop),
        progress=progress,
    )
    last = policy.records[-1]
    if last.end is None:
        last.end = float(run.trajectory.times[-1])
        failure = getattr(run.trajectory, "failure", None)
        last.why = (
            f"the simulation {run.trajectory.status}: {failure.reason}"
            if failure is not None
            else f"max_time {duration:g} s reached"
        )
    return TaskRun(
        tuple(policy.records),
        run.trajectory,
        policy.done,
        run.decisions + 1,
        dt,
        duration,
        replan_every,
        {"planning": run.timings["policy"], "simulation": run.timings["simulation"]},
        timing,
    )
