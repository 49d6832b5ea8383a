r"""The climbing gait's phase timing: a plug-in of the planning core (``[task] timing = "gait"``).

The gait is a task given as phases (``[task.gait]`` of ``snake_climb``, :mod:`.gait_task`): four
phases per cycle (``extend``, ``upper_brace``, ``pull``, ``lower_brace``), run ``repeat`` times.
Each phase's ``modes`` say which brace it holds (F), which it opens (S) and which it closes (F as
they touch); its ``margin`` is the robustness radius; its ``until = { time = T }`` its length.
The core's loop (:func:`~frcontrol.planning.core.loop.run_task`) runs it; this module is its
:class:`~frcontrol.planning.core.timing.PhaseTiming` with the step hooks
(:class:`~frcontrol.planning.core.timing.StepHooks`):

- *before the run* (:func:`timing`): the gait's certificates and the hand-overs' ambiguity checks
  (:func:`~frcontrol.planning.gait.plan_gait`, :mod:`.gait_handover`), and the disturbance scale
  of the run (``[task] scale``, default :data:`SIMULATION_SCALE` capped by the weakest phase's);
- *every step* (``actuate``): the robust tracking LP (:func:`~.gait_control.tracking_step`) at the
  state reached, towards the phase's reference (:func:`~.gait_geometry.phase_reference`, started
  where the braces are when the phase starts), plus the disturbance forces ``J_d(q)^T d``, ``d``
  sampled in ``conv(V_s)`` (seed ``[task] seed``) and held for
  :data:`~.disturbances.DEFAULT_HOLD`: the stepper runs on the scene with inputs on every
  coordinate (``stepper_scene``);
- *after every step* (``after_step``): the slide of every held contact (``sum |v_T+| h``) and its
  drift along the wall; the phase ends when its ``until`` time has run, and the hand-over check of
  its end (``upper_brace -> pull``, ``lower_brace -> extend``) is given with why it ended (its
  record's ``why``). The run ends,
  achieved, after the last cycle.

A brace *slips* when a contact the controller holds slides, over a phase, by more than
:data:`~.climb_check.BRACE_SLIP_TOLERANCE`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import InputError, SceneError
from ..scene import Inputs, Scene
from ..simulation.rigid import RigidSettings, RigidStepper
from ..simulation.trajectory import Trajectory
from .core.decision import Decision
from .core.task import Phase, Task
from .core.timing import Switch
from .disturbances import DEFAULT_HOLD, HOLD_INDEX_ROUNDOFF, PointKinematics, sample_disturbances
from .gait import PHASES, GaitPlan, plan_gait
from .gait_control import TOUCH_GAP, TRACKING_DAMPING, TRACKING_STIFFNESS, TrackingRequest, tracking_step
from .gait_geometry import Reference, phase_reference
from .gait_handover import PHASE_ROLES

__all__ = [
    "PHASE_END_TOLERANCE",
    "SIMULATION_SCALE",
    "GaitTiming",
    "PhaseRun",
    "gait_braces_of",
    "timing",
]

SIMULATION_SCALE = 0.02
"""[-] Default disturbance scale of the simulated gait (capped by the plan's scale). The phases'
certificates hold at rest up to their largest scales (about 9 on the snake), but along the motion
the disturbances push the open lower body about (the brace disturbance reaches 40 N at j3, twice the
snake's weight), and a lower contact then closes while still moving along its wall: at scale 0.1
the re-closing j2 contact slides up to 1.4 mm before it sticks (5 cycles, seed 0), at 0.3 the
upper brace slides too. At 0.02 every held contact stays within the slip tolerance."""

PHASE_END_TOLERANCE = 1e-9
"""[s] A phase ends at the first step whose time into the phase is at least its ``until`` time
minus this (the steps' sum of floating-point step lengths)."""


@dataclass(frozen=True)
class PhaseRun:
    """One phase of the simulated gait.

    Attributes:
        name: the phase; cycle: its cycle (1-based).
        start, end: [s] its times; start_index, end_index: its samples.
        max_deficit: [N m or N] the tracking LP's largest robustness deficit in the phase.
        max_slip: [m] the largest slide of a held contact while held (``sum |v_T+| h``).
        slips: [m] each held contact's slide.
        max_drift: [m] the largest displacement of a held contact along its wall while held.
        max_tracking_error: [m or rad] the largest |q_ref - q|.
        base_height: [m] the base's height (the tail's y) at the end.
        closed: the closing contacts that touch at the end.
    """

    name: str
    cycle: int
    start: float
    end: float
    start_index: int
    end_index: int
    max_deficit: float
    max_slip: float
    slips: Mapping[str, float]
    max_drift: float
    max_tracking_error: float
    base_height: float
    closed: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        """The phase's run as JSON."""
        return {"name": self.name, "cycle": self.cycle, "start": self.start, "end": self.end,
                "start_index": self.start_index, "end_index": self.end_index, "max_deficit": self.max_deficit,
                "max_slip": self.max_slip, "slips": dict(self.slips), "max_drift": self.max_drift,
                "max_tracking_error": self.max_tracking_error,
                "base_height": self.base_height, "closed": list(self.closed)}


@dataclass
class _Current:
    """The running phase: its index, reference, roles and what it has recorded so far."""

    index: int
    start: float
    start_index: int
    reference: Reference
    roles: tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]
    anchors: dict[str, np.ndarray] = field(default_factory=dict)
    slips: dict[str, float] = field(default_factory=dict)
    worst: dict[str, float] = field(
        default_factory=lambda: dict.fromkeys(("deficit", "slip", "drift", "error"), 0.0))
    step: tuple[np.ndarray, tuple[str, ...], float] | None = None
    """The last step's tangent rows ``J_T(q)``, its held contacts and its start time [s]."""


def gait_braces_of(scene: Scene, task: Task) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """``(lower, upper)``: the first phase's held (F) and opened (S) contacts, in the scene's order.

    Raises:
        SceneError: the phases are not the gait's four in order, a phase's ``until`` is not a time,
            or a phase's ``modes`` do not give its roles (held and closing brace F, opened brace S).
    """
    path = str(scene.path)
    names = tuple(p.name for p in task.phases)
    if names != PHASES:
        raise SceneError(path, "task.gait.phases", f"the gait's phases are {', '.join(PHASES)} in this "
                         f"order (one cycle; repeat sets the cycles), got {', '.join(names)}")
    first = task.phases[0].modes
    order = [c.name for c in scene.contacts]
    lower = tuple(n for n in order if first.get(n) == "F")
    upper = tuple(n for n in order if first.get(n) == "S")
    braces = {"lower": lower, "upper": upper, "": ()}
    for i, phase in enumerate(task.phases):
        held, released, closing = (braces[r] for r in PHASE_ROLES[phase.name])
        expected = {**dict.fromkeys(held + closing, "F"), **dict.fromkeys(released, "S")}
        if dict(phase.modes) != expected:
            raise SceneError(path, f"task.gait.phases[{i}].modes", f"the {phase.name} phase holds "
                             f"{', '.join(held) or 'no brace'} (F), opens {', '.join(released) or 'none'} "
                             f"(S) and closes {', '.join(closing) or 'none'} (F): expected {expected}, got "
                             f"{dict(phase.modes)}")
        if phase.until.kind != "time":
            raise SceneError(path, f"task.gait.phases[{i}].until", "a gait phase runs its reference for a "
                             "time: until = { time = T } [s]")
    return lower, upper


class GaitTiming:
    """The gait's phase timing (module docstring): the plan, the run's records and the step hooks."""

    def __init__(self, scene: Scene, task: Task, plan: GaitPlan, scale: float, seed: int) -> None:
        self.scene, self.task, self.plan, self.scale, self.seed = scene, task, plan, scale, seed
        self.settings = RigidSettings(max_ambiguity_checks=0)
        n = scene.robot.nv
        self.forces = Inputs(scene.coordinate_names, tuple(range(n)), np.full(n, -np.inf), np.full(n, np.inf))
        self.points = plan.disturbances.robust_points(scale)
        points = [(d.name, d.link, d.point_in_link) for d in plan.disturbances.items]
        self.kin = PointKinematics(scene, points)
        self.rng = np.random.default_rng(seed)
        self.samples: list[np.ndarray] = []
        self.torque_map = scene.inputs.selection_transpose(n)
        self.torques: list[np.ndarray] = []
        self.modes: list[tuple[str, tuple[str, ...]]] = []
        self.phase_of_step: list[int] = []
        self.deficits: list[float] = []
        self.records: list[PhaseRun] = []
        self.tangents = {c.name: c.point.tangent_in_world for c in scene.contacts}
        self.braces = {"lower": plan.lower, "upper": plan.upper, "": ()}
        self.current: _Current | None = None
        self.index = 0

    # ---------------------------------------------------------------- the core's hooks
    def stepper_scene(self, scene: Scene) -> Scene:
        """The scene with inputs on every coordinate: the torques' and the disturbances' forces."""
        return replace(scene, inputs=self.forces)

    def free(self, phase: Phase) -> Mapping[str, str] | None:
        """No plan is made (every phase is driven): no free letters."""
        return None

    def drive(self, phase: Phase, stepper: RigidStepper | None) -> np.ndarray | None:
        """Every phase is driven; the command is unused (``actuate`` gives every step's forces)."""
        return np.zeros(self.scene.robot.nv)

    def before_decision(self, phase: Phase, stepper: RigidStepper) -> Switch | None:
        """Phases end after a step (``after_step``), never at a decision."""
        return None

    def decided(self, phase: Phase, decision: Decision, stepper: RigidStepper | None
                ) -> tuple[np.ndarray | None, Switch | None]:
        """Never called with a plan (every phase is driven)."""
        return None, None

    def actuate(self, phase: Phase, command: np.ndarray, stepper: RigidStepper) -> np.ndarray:
        """The step's generalized forces: the tracking LP's torques plus the held disturbance."""
        current = self._running(stepper)
        q_ref, v_ref, a_ref = current.reference.state(stepper.t - current.start)
        desired = a_ref + TRACKING_STIFFNESS * (q_ref - stepper.q) + TRACKING_DAMPING * (v_ref - stepper.v)
        loaded = [n for n, f in zip(stepper.names, stepper.last_forces[:, 0], strict=True) if f > 0]
        held, released, closing = current.roles
        request = TrackingRequest(stepper.q, stepper.v, held + closing, released, desired, self.points,
                                  phase.margin, self.plan.solver,
                                  loaded)
        step = tracking_step(self.scene, self.plan.disturbances, request)
        jac, _, _ = self.kin.evaluate(stepper.q, stepper.v)
        self.torques.append(step.torques)
        self.modes.append((step.mode, step.contacts))
        self.deficits.append(step.deficit)
        self.phase_of_step.append(current.index)
        worst = current.worst
        worst["deficit"] = max(worst["deficit"], step.deficit)
        worst["error"] = max(worst["error"], float(np.max(np.abs(q_ref - stepper.q))))
        fixed = tuple(c for letter, c in zip(step.mode, step.contacts, strict=True) if letter == "F")
        current.step = (stepper.state.jacobian_tangent.copy(), fixed, stepper.t)
        disturbance = jac[:self.plan.disturbances.dim].T @ self._disturbance(stepper.t)
        return np.asarray(self.torque_map @ step.torques + disturbance, dtype=float)

    def after_step(self, phase: Phase, stepper: RigidStepper, since: float) -> Switch | None:
        """Record the held contacts' slide; end the phase when its ``until`` time has run."""
        current = self._running(stepper)
        if current.step is not None:
            rows, fixed, before = current.step
            self._slip(current, stepper, fixed, rows @ stepper.v, stepper.t - before)
        duration = float(self.task.phases[current.index % len(PHASES)].until.time or 0.0)
        if stepper.t - current.start < duration - PHASE_END_TOLERANCE:
            return None
        self._close(current, stepper)
        self.current, self.index = None, current.index + 1
        last = self.index == len(PHASES) * self.task.repeat
        why = f"until {phase.until.describe()}" + (f" (cycle {self.records[-1].cycle} of {self.task.repeat})"
                                                   if phase.name == "lower_brace" else "")
        return Switch(why + self._hand_over(phase.name, self.records[-1].cycle),
                      None if last else PHASES[self.index % len(PHASES)], met=True)

    def _hand_over(self, name: str, cycle: int) -> str:
        """The hand-over check at the end of phase ``name`` of ``cycle``, in words ("" when none)."""
        for check in self.plan.hand_overs:
            if check.cycle == cycle and check.name.startswith(f"{name}->"):
                verdict = "unambiguous" if check.unambiguous else f"slip modes {', '.join(check.slip_modes)}"
                return f"; hand-over {check.name}: {verdict} ({check.modes_checked} other modes checked)"
        return ""

    def report(self, scene: Scene, trajectory: Trajectory) -> dict[str, Any]:
        """The plan document's ``timing``: the run's scale, seed, cycles and phases completed."""
        return {"cycles": self.task.repeat, "scale": self.scale, "seed": self.seed,
                "phases_completed": len(self.records), "phase_end_tolerance": PHASE_END_TOLERANCE,
                "unambiguous_hand_overs": self.plan.unambiguous}

    # ---------------------------------------------------------------- the run's records
    def disturbance_times(self) -> np.ndarray:
        """[s] The start of each held disturbance sample drawn."""
        return DEFAULT_HOLD * np.arange(len(self.samples))

    def _running(self, stepper: RigidStepper) -> _Current:
        """The running phase, started (its reference from the braces where they are) when new."""
        if self.current is None:
            name = PHASES[self.index % len(PHASES)]
            first = self.index == 0
            geometry = self.plan.geometry
            reference = phase_reference(name, geometry, geometry.measure(stepper.q),
                                        self.scene.q if first else None)
            held, released, closing = (tuple(self.braces[r]) for r in PHASE_ROLES[name])
            roles = (held, released, closing)
            self.current = _Current(self.index, stepper.t, len(self.torques), reference, roles)
        return self.current

    def _disturbance(self, t: float) -> np.ndarray:
        """The held sample at time ``t`` (drawn as the holds start)."""
        k = int(t / DEFAULT_HOLD + HOLD_INDEX_ROUNDOFF)
        while len(self.samples) <= k:
            self.samples.append(sample_disturbances(self.points, 1, self.rng)[0])
        return self.samples[k]

    def _slip(self, current: _Current, stepper: RigidStepper, held: Sequence[str], sliding: np.ndarray,
              dt: float) -> None:
        """Add the step's slide ``|v_T+| h`` of each held contact, and its drift from where first held.

        ``sliding`` is ``J_T(q) v+``: the sliding velocity the step's friction law set; the drift is
        the contact's displacement along the wall (the slide plus the time stepping's drift, first
        order in h).
        """
        worst = current.worst
        for name in held:
            i = stepper.names.index(name)
            point = stepper.state.contact_points[i]
            anchor = current.anchors.setdefault(name, point.copy())
            current.slips[name] = current.slips.get(name, 0.0) + abs(float(sliding[i])) * dt
            worst["slip"] = max(worst["slip"], current.slips[name])
            worst["drift"] = max(worst["drift"], abs(float(self.tangents[name] @ (point - anchor))))

    def _close(self, current: _Current, stepper: RigidStepper) -> None:
        """The phase's record, at its end."""
        name = PHASES[current.index % len(PHASES)]
        touching = {c.name for c in self.scene.at(stepper.q).contacts if c.gap <= TOUCH_GAP}
        worst = current.worst
        self.records.append(PhaseRun(
            name, current.index // len(PHASES) + 1, current.start, stepper.t, current.start_index,
            len(self.torques), worst["deficit"], worst["slip"], dict(current.slips), worst["drift"],
            worst["error"], float(stepper.q[1]), tuple(c for c in current.roles[2] if c in touching)))


def timing(scene: Scene, task: Task) -> GaitTiming:
    """The gait's timing for the scene: the gait planned (certificates, hand-overs) before the run.

    ``[task] scale`` (default: :data:`SIMULATION_SCALE`, at most the weakest phase's planned scale)
    and ``[task] seed`` (default 0) set the run's sampled disturbances.

    Raises:
        SceneError: the phases are not the gait's (:func:`gait_braces_of`), or a robot or scene the
            gait is not built for (:func:`~.gait.plan_gait`).
        InputError: a bad scale.
    """
    braces = gait_braces_of(scene, task)
    plan = plan_gait(scene, task.repeat, margin=task.phases[0].margin, braces=braces)
    raw = task.raw
    scale = min(plan.scale, SIMULATION_SCALE) if raw.get("scale") is None else float(raw["scale"])
    if not (math.isfinite(scale) and scale >= 0):
        raise InputError(f"scale must be a finite number >= 0, got {raw.get('scale')!r}")
    return GaitTiming(scene, task, plan, scale, int(raw.get("seed", 0)))
