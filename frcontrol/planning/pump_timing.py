r"""The pumping flip's phase timing: a plug-in of the planning core (``[task] timing = "pump"``).

The task (``rhex_flip_drives``) has three phases, named ``push``, ``recirculate`` and ``land``; the
core plans the push (its ``modes``, ``margin``, ``maximize``) at every decision, and this module
decides the rest (:class:`~frcontrol.planning.core.timing.PhaseTiming`):

- **push** ends on a mode change the analysis predicts: the best unambiguous plan loads no toe any
  more (the toes lift off), or no plan is made (a plan refused at an impact, a landing, is not an
  end: the legs' loop holds until the next decision). A push's plan may have other rigid
  solutions at its voltages when they differ from the planned mode only on the contacts the
  push allows every letter (:data:`ANY_LETTER`: the toes may separate, stick or slide; a body
  contact apart at the start may touch): those are its ``free`` letters, on the contacts it allows
  every letter (named ``"SFLR"``, or not named). The named contacts keep
  their planned letter (the pivot) or their allowed one (the belly apart: S).
- **recirculate**: the legs are in the air and the body moves on its own. Each leg is driven round
  (one turn on in its pushing direction, :data:`RECIRCULATION_GAIN`) to its touch-down angle, the
  angle it had at the start. It ends, and a new cycle's push starts, when a toe touches the ground
  with the body's pitch rate at most :data:`FALL_PITCH_RATE` (at most ``[task] repeat`` cycles).
- **land**: whenever the push's ``until`` holds (the pitch passes vertical) the legs are driven to
  :data:`STAND_ANGLE` and the body falls right side up; the run ends at rest right side up
  (:data:`REST_SPEED`, :data:`UPRIGHT_TOLERANCE`) or when the land phase's ``until`` (a time:
  1.5 s in the shipped scene) holds. A body that falls back below vertical recirculates and is pumped
  again.

Each phase's record (:class:`PumpPhase`) keeps the modes its decisions planned or predicted
(:func:`predicted_modes` at the legs' voltages) and its free letters, which the samples are
checked against (:meth:`frcontrol.planning.pump.PumpResult.modes_check`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..drives import Drive
from ..engine import solutions_at
from ..errors import FrcontrolError, SceneError
from ..modes import scene_mode
from ..scene import Scene
from ..simulation.rigid import CONTACT_FORCE_TOLERANCE, RigidSettings, RigidStepper
from ..simulation.trajectory import Trajectory
from .core.decision import Decision
from .core.loop import contact_gaps, replanning_model, until_met
from .core.pieces import mode_allowed
from .core.task import Phase, Task
from .core.timing import Switch
from .core.tolerances import (
    FORCED_INPUT_TOLERANCE,
    REPLAN_GAP_TOLERANCE,
    SEPARATION_GAP,
)
from .flip import flip_task

__all__ = [
    "ANY_LETTER",
    "FALL_PITCH_RATE",
    "PHASE_NAMES",
    "PUSH_DIRECTION_TOLERANCE",
    "RECIRCULATION_DAMPING",
    "RECIRCULATION_GAIN",
    "REST_SPEED",
    "STAND_ANGLE",
    "UPRIGHT_TOLERANCE",
    "PumpPhase",
    "PumpTiming",
    "check_pump_scene",
    "leg_contacts",
    "predicted_modes",
    "timing",
]

RECIRCULATION_GAIN = 60.0
"""[V/rad] Proportional gain of a leg's voltage towards its touch-down angle in the air."""

RECIRCULATION_DAMPING = 0.5
"""[V s/rad] Damping of the same loop (added to the motor's own back-EMF damping)."""

FALL_PITCH_RATE = 1e-3
"""[rad/s] A recirculation ends, and the next push starts, once a toe touches the ground and the
body's pitch rate is at most this: the body has come back down onto its legs."""

REST_SPEED = 0.02
"""[m/s or rad/s] The body is at rest when its base velocities (x, y, pitch) are all at most this;
the land phase then ends the run."""

UPRIGHT_TOLERANCE = 0.3
"""[rad] The run ends right side up when its last pitch is within this of upright (vertical + pi/2:
2 pi for RHex, which starts on its back at pi)."""

STAND_ANGLE = math.pi
"""[rad] The hip angle the legs are driven to in the land phase (mod 2 pi): the URDF's zero, a leg
pointing towards the belly, i.e. down once the body is right side up."""

ANY_LETTER = "SFLR"
"""Every contact mode letter: a contact free to take any of them."""

PUSH_DIRECTION_TOLERANCE = 1e-9
"""[V] A planned voltage of at most this size gives no pushing direction (the leg recirculates in
the default, negative, direction)."""

PHASE_NAMES = ("push", "recirculate", "land")
"""The phases the pump's task names, in this order."""


def check_pump_scene(scene: Scene) -> list[Drive]:
    """The drive of each input, in input order.

    Raises:
        SceneError: an input has no drive (the pumping flip plans voltages within the motors'
            limits: every input needs ``[model.drives.JOINT]``), or a drive has an elastic stage
            (its voltage reaches the joint only through the spring: its input column in the
            analysis is 0, so no push has an unambiguous voltage and the phases would only
            alternate without pushing).
    """
    missing = [name for name in scene.inputs.coordinates if name not in scene.drives]
    if missing:
        raise SceneError(str(scene.path), f"model.drives.{missing[0]}",
                         f"the pumping flip needs a DC-motor drive on every input; {', '.join(missing)} "
                         "has none (add [model.drives.JOINT] tables, as the shipped scene "
                         "rhex_flip_drives does)")
    for name in scene.inputs.coordinates:
        drive = scene.drives[name]
        if drive.elastic:
            raise SceneError(str(scene.path), f"model.drives.{name}.stages[{drive.elastic_stages[0]}]",
                             "the pumping flip plans each push in voltage space and needs rigid stages: "
                             "through an elastic stage the voltage does not act on the joint within the "
                             "analysed instant (its input column is 0), so no push can be planned; "
                             "remove 'stiffness' from the stage")
    return [scene.drives[name] for name in scene.inputs.coordinates]


def leg_contacts(scene: Scene, body: Sequence[str]) -> dict[int, list[int]]:
    """Input -> the contacts (not the body's) its coordinate moves, from the contact Jacobians."""
    state = scene.robot.state(scene.q, scene.v)
    jac = np.vstack([state.jacobian_normal, state.jacobian_tangent])
    k = len(scene.contacts)
    body_index = {i for i, c in enumerate(scene.contacts) if c.name in body}
    legs = {}
    for i, j in enumerate(scene.inputs.indices):
        rows = np.nonzero(np.abs(jac[:, j]) > FORCED_INPUT_TOLERANCE)[0]
        toes = sorted({int(r % k) for r in rows} - body_index)
        if toes:
            legs[i] = toes
    return legs


def predicted_modes(scene: Scene, q: np.ndarray, v: np.ndarray, loaded: np.ndarray, inputs: np.ndarray
                    ) -> list[str] | None:
    """The modes of every rigid solution at a simulated state and inputs, on the planning model.

    Each mode has one letter per scene contact, in scene order (:func:`~frcontrol.modes.scene_mode`).
    The core's re-planning model: the contacts within the scene's gap tolerance or loaded by the
    last step (``loaded``, per scene contact) are active, a loaded contact's normal velocity is 0,
    velocities up to ``REPLAN_VELOCITY_TOLERANCE`` are 0. None where the model does not apply (a
    contact moving into its surface: an impact).
    """
    try:
        _, problem = replanning_model(scene, q, v, loaded)
        names = [c.name for c in scene.contacts]
        return [scene_mode(s.mode, problem.contacts, names) for s in solutions_at(problem, inputs)]
    except FrcontrolError:  # ImpactState included: no prediction at this state
        return None


@dataclass(frozen=True)
class PumpPhase:
    """One phase of the pumping flip.

    Attributes:
        kind: ``"push"``, ``"recirculate"`` or ``"land"`` (after vertical).
        cycle: the pumping cycle it belongs to (a cycle starts with a push), from 1.
        start: [s] when it began; end: [s] when it ended.
        modes: the planned modes of a push (one letter per scene contact, in scene order), in
            order, without repeats; empty for a recirculation.
        ended_by: the mode change (or the end of the run) that ended it.
        predicted: for a recirculation or landing, the rigid solutions' modes (one letter per
            scene contact) at each decision's state and voltages (:func:`predicted_modes`),
            without repeats; a decision the acceleration-level model cannot judge adds none.
        unambiguous: every decision of the phase had exactly one rigid solution.
        allowed: the modes the phase's decisions allowed, one letter per scene contact (S for a
            contact a decision did not hold): a push's planned modes, a recirculation's or
            landing's predicted ones.
        free: per scene contact, the letters the phase allows it besides those of ``allowed``
            (the contacts it allows every letter): a sample's mode is allowed when it matches a
            mode of ``allowed`` on every contact but free ones
            (:func:`~frcontrol.planning.core.pieces.mode_allowed`).
    """

    kind: str
    cycle: int
    start: float
    end: float
    modes: tuple[str, ...]
    ended_by: str
    predicted: tuple[str, ...] = ()
    unambiguous: bool = True
    allowed: tuple[str, ...] = ()
    free: Mapping[str, str] = field(default_factory=dict)

    def allows(self, mode: str, contacts: Sequence[str]) -> bool:
        """Whether ``mode`` (one letter per scene contact, ``contacts``) is one the phase allowed."""
        return any(mode_allowed(mode, base, contacts, self.free) for base in self.allowed)


class PumpTiming:
    """The pump's :class:`~frcontrol.planning.core.timing.PhaseTiming` (see the module's docstring)."""

    settings = RigidSettings(max_ambiguity_checks=0)
    """Rigid steps with the impact law at landings (the pump's legs land on their toes each cycle)."""

    def __init__(self, scene: Scene, task: Task) -> None:
        self.drives = check_pump_scene(scene)
        flip = flip_task(scene)
        self.scene = replace(scene, gap_tolerance=REPLAN_GAP_TOLERANCE)
        self.phases = _named_phases(scene, task)
        self.max_cycles = task.repeat
        self.index = np.array(scene.inputs.indices)
        self.pitch_index, self.vertical = flip.pitch_index, flip.vertical
        self.force_tolerance = CONTACT_FORCE_TOLERANCE * scene.robot.weight_scale()
        self.legs = leg_contacts(scene, flip.body_contacts)
        self.touchdown = np.array(scene.q)[self.index]
        self.direction = -np.ones(len(self.index))
        self.target = self.touchdown.copy()
        self.contact_names = tuple(c.name for c in scene.contacts)
        self.record = _Record("push", 1, 0.0)
        self.records: list[PumpPhase] = []
        self.crossed: float | None = None

    # -- the hooks the core's loop calls

    def free(self, phase: Phase) -> dict[str, str]:
        """The contacts the phase allows every letter (named so, or not named): any letter."""
        every = set(ANY_LETTER)
        return {name: ANY_LETTER for name in self.contact_names
                if set(phase.modes.get(name, ANY_LETTER)) == every}

    def drive(self, phase: Phase, stepper: RigidStepper | None) -> np.ndarray | None:
        """The legs' loop in a recirculation or landing (its predicted modes recorded); None: a push."""
        if phase.name == "push":
            return None
        q = self.scene.q if stepper is None else stepper.q
        v = self.scene.v if stepper is None else stepper.v
        volts = self._recirculation(q, v[self.index])
        if stepper is not None:
            loaded = stepper.last_forces[:, 0] > self.force_tolerance
            modes = predicted_modes(self.scene, q, v, loaded, volts)
            if modes is not None:
                self.record.unambiguous &= len(modes) == 1
                for mode in modes:
                    self.record.allow(mode)
                    if mode not in self.record.predicted:
                        self.record.predicted.append(mode)
        return volts

    def before_decision(self, phase: Phase, stepper: RigidStepper) -> Switch | None:
        """Land -> recirculate when the body falls back; recirculate -> push when back on a toe."""
        q, v = stepper.q, stepper.v
        if phase.name == "land" and q[self.pitch_index] < self.vertical and v[self.pitch_index] < 0:
            return self._begin(stepper.t, Switch("the body fell back below vertical", "recirculate"), q)
        if (phase.name == "recirculate" and v[self.pitch_index] <= FALL_PITCH_RATE and self._toes_down(q)
                and self.record.cycle < self.max_cycles):
            return self._begin(stepper.t, Switch("the body is back on a toe", "push"), q)
        return None

    def decided(self, phase: Phase, decision: Decision, stepper: RigidStepper | None
                ) -> tuple[np.ndarray | None, Switch | None]:
        """A push's plan: kept, or the push ends (no plan, or the toes lift off)."""
        q = self.scene.q if stepper is None else stepper.q
        t = 0.0 if stepper is None else stepper.t
        if not decision.found:
            why = str(decision.reason)
            if why.startswith("impact"):  # a landing: the legs' loop until the next decision
                v = self.scene.v if stepper is None else stepper.v
                return self._recirculation(q, v[self.index]), None
            return None, self._begin(t, Switch(f"no plan: {why}", "recirculate"), q)
        mode = scene_mode(str(decision.mode), decision.contacts, self.contact_names)
        toes = {self.contact_names[i] for contacts in self.legs.values() for i in contacts}
        if not any(letter != "S" for c, letter in zip(decision.contacts, str(decision.mode), strict=True)
                   if c in toes):
            why = f"the planned mode {mode} loads no toe: the toes lift off"
            return None, self._begin(t, Switch(why, "recirculate"), q)
        volts = np.array([decision.inputs[name] for name in self.scene.inputs.coordinates])
        pushing = np.abs(volts) > PUSH_DIRECTION_TOLERANCE
        self.direction[pushing] = np.sign(volts[pushing])
        self.record.allow(mode)
        if not self.record.modes or self.record.modes[-1] != mode:
            self.record.modes.append(mode)
        return None, None

    def after_step(self, phase: Phase, stepper: RigidStepper, since: float) -> Switch | None:
        """Vertical passed: land; the land phase ends the run at rest right side up, or at its ``until``."""
        q, v = stepper.q, stepper.v
        if phase.name != "land":
            if until_met(self.scene, self.phases["push"].until, q, since):
                self.crossed = stepper.t if self.crossed is None else self.crossed
                return self._begin(stepper.t, Switch("vertical passed", "land", met=True), q)
            return None
        upright = abs(q[self.pitch_index] - self.vertical - 0.5 * math.pi) < UPRIGHT_TOLERANCE
        if self.at_rest(v) and upright:
            return self._begin(stepper.t, Switch("at rest", None, met=True), q)
        if until_met(self.scene, phase.until, q, since):
            return self._begin(stepper.t, Switch("the settling time's end", None, met=upright), q)
        return None

    def report(self, scene: Scene, trajectory: Trajectory) -> dict[str, Any]:
        """The cycles and each phase's record (the plan document's ``timing``)."""
        phases = self.phases_until(float(trajectory.times[-1]), "the end of the run")
        return {"cycles": sum(p.kind == "push" for p in phases), "crossed": self.crossed,
                "pump_phases": [{"kind": p.kind, "cycle": p.cycle, "start": p.start, "end": p.end,
                                 "ended_by": p.ended_by} for p in phases]}

    # -- the pump's own

    def at_rest(self, v: np.ndarray) -> bool:
        """Whether the base's velocities (the pitch's and the two before it) are within :data:`REST_SPEED`."""
        base = np.asarray(v)[max(self.pitch_index - 2, 0): self.pitch_index + 1]
        return bool(np.all(np.abs(base) <= REST_SPEED))

    def phases_until(self, t: float, why: str) -> tuple[PumpPhase, ...]:
        """The phases' records, the running one (if any) ended at ``t`` by ``why``."""
        if self.record.ended:
            return tuple(self.records)
        return (*self.records, self.record.close(t, why, self._free(self.record.kind)))

    def _begin(self, t: float, switch: Switch, q: np.ndarray) -> Switch:
        """Close the running record, start the switch's phase (its legs' targets set)."""
        self.records.append(self.record.close(t, switch.why, self._free(self.record.kind)))
        if switch.to is None:
            self.record.ended = True
            return switch
        cycle = self.record.cycle + (switch.to == "push")
        self.record = _Record(switch.to, cycle, t)
        if switch.to == "recirculate":
            self.target = self._targets(q, self.touchdown)
        elif switch.to == "land":
            self.target = self._targets(q, np.full(len(self.index), STAND_ANGLE))
        return switch

    def _free(self, kind: str) -> dict[str, str]:
        return self.free(self.phases[kind])

    def _toes_down(self, q: np.ndarray) -> bool:
        gaps = contact_gaps(self.scene, q)
        return any(bool(np.any(gaps[toes] <= SEPARATION_GAP)) for toes in self.legs.values())

    def _targets(self, q: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """Each leg's ``goal`` angle [rad], less than one turn on in its pushing direction."""
        angles = q[self.index]
        turns = np.floor(self.direction * (angles - goal) / (2 * math.pi)) + 1
        return goal + self.direction * 2 * math.pi * turns

    def _recirculation(self, q: np.ndarray, speeds: np.ndarray) -> np.ndarray:
        """[V] The legs' loop towards their targets, within each drive's voltage limit."""
        volts = RECIRCULATION_GAIN * (self.target - q[self.index]) - RECIRCULATION_DAMPING * speeds
        limits = np.array([d.voltage_limit for d in self.drives])
        return np.clip(volts, -limits, limits)


@dataclass
class _Record:
    """The running phase's record (its decisions' modes)."""

    kind: str
    cycle: int
    start: float
    modes: list[str] = field(default_factory=list)
    predicted: list[str] = field(default_factory=list)
    allowed: list[str] = field(default_factory=list)
    unambiguous: bool = True
    ended: bool = False

    def allow(self, mode: str) -> None:
        if mode not in self.allowed:
            self.allowed.append(mode)

    def close(self, t: float, why: str, free: Mapping[str, str]) -> PumpPhase:
        return PumpPhase(self.kind, self.cycle, self.start, t, tuple(self.modes), why, tuple(self.predicted),
                         self.unambiguous, tuple(self.allowed), dict(free))


def _named_phases(scene: Scene, task: Task) -> dict[str, Phase]:
    """The task's phases by name: push, recirculate and land, in this order.

    Raises:
        SceneError: other names, or the push without an objective.
    """
    names = tuple(p.name for p in task.phases)
    if names != PHASE_NAMES:
        raise SceneError(str(scene.path), "task.phases",
                         f"the pump's phases are named {', '.join(PHASE_NAMES)} (in this order), got "
                         f"{', '.join(names)}")
    if task.phases[0].objective.kind == "driven":
        raise SceneError(str(scene.path), "task.phases[0]",
                         "the push is planned: give it maximize = { coordinate = \"theta\" }")
    return {p.name: p for p in task.phases}


def timing(scene: Scene, task: Task) -> PumpTiming:
    """The pump's timing for the scene's task (:func:`frcontrol.planning.core.timing.load_timing` calls it).

    Raises:
        SceneError: see :func:`check_pump_scene` and the phases' names.
    """
    return PumpTiming(scene, task)
