r"""The pumping flip: RHex righted over several leg strokes, within its motors' limits.

Saranli, Rizzi and Koditschek (IJRR 23(9), 2004) right the real RHex, whose hips cannot push the
body past vertical in one stroke, by chaining strokes. The plan here chains *phases*:

- **push**: the toes on the ground push the body up about its front corner. The input is the
  flip plan (:func:`frcontrol.planning.flip.plan_flip`): the hip voltages that maximise the pitch
  acceleration in the *unambiguous set* of a mode keeping every body contact loaded. With DC-motor
  drives (``[model.drives.JOINT]``, :mod:`frcontrol.drives`) the inputs are voltages within
  ``[-u_max, u_max]`` and the motors' electrical damping is in the bias, so the analysis is in
  voltage space at the hips' speeds: the torque-speed line is the shape of every mode domain. The
  phase ends on a mode change the analysis predicts: the best unambiguous mode loads no toe any
  more (the toes lift off), or no mode keeping a toe loaded pitches the body up.
- **recirculate**: the legs are in the air and the body moves on its own (up, then back down).
  Each leg is driven round (one turn on in its pushing direction, :data:`RECIRCULATION_GAIN`) to
  its touch-down angle, the angle it had at the start, where its toe meets the ground when the
  body comes back down. The phase ends when a toe touches the ground with the body's pitch rate at
  most :data:`FALL_PITCH_RATE`: the body has fallen back onto its legs.
- then **push** again: a new cycle.

**Drives.** Each planar hip stands for a pair of motors behind a gear (ratio N, efficiency
eta), one drive. With voltage u [V] and joint speed qdot [rad/s]::

    torque = eta N C_M (u - C_E N qdot) / R,   |u| <= u_max
    => torque in [eta N C_M (-u_max - C_E N qdot) / R, eta N C_M (u_max - C_E N qdot) / R]

(:func:`frcontrol.drives.torque_limits`). The voltages are the simulation's inputs: every sample's
torque lies on the motor's line by construction, and the JSON carries each sample's voltage,
current, motor speed, torque and limits, so a reader can check.

**Energy drawn.** ``sum_j sum_k u_j,k i_j,k (t_k - t_k-1)`` [J], from the samples (the voltage held
over the step ending at sample k and the current at that sample; negative power, braking, counts
as returned).

**Energy budget.** The run reports the body's mechanical energy per cycle against the barrier it
must cross and the pitches up to which the legs reach the ground (:mod:`.flip_budget`). With rigid
massless legs nothing stores energy between pushes: a push after the first starts from the body's
landing on its toes, and the inelastic landing and the back-driven motors take what a push adds,
so the cycles' peaks stop growing below the barrier (docs/rhex-flip.md, "The pumping flip").

**Verification.** The run is one rigid simulation (velocity-level time stepping with inelastic
impacts). The same voltages, replayed against time, drive the compliant model (Kelvin–Voigt
contacts at the stiffness the speed-accuracy benchmark recommends for trajectories,
:data:`COMPLIANT_STIFFNESS`): the flip must survive both.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..drives import Drive, no_load_speed, stall_torque, torque_limits
from ..errors import FrcontrolError, SceneError
from ..jsonable import finite_or_none, to_jsonable
from ..modes import scene_mode
from ..scene import Scene
from ..simulation.energy_audit import EnergyAudit, energy_audit
from ..simulation.export import sample_modes
from ..simulation.rigid import CONTACT_FORCE_TOLERANCE, RigidSettings, RigidStepper
from ..simulation.trajectory import Trajectory
from ..solvers import DEFAULT_LP_SOLVER
from .core.loop import contact_gaps
from .core.pieces import mode_allowed
from .core.tolerances import (
    FORCED_INPUT_TOLERANCE,
    REPLAN_GAP_TOLERANCE,
    REPLAN_VELOCITY_TOLERANCE,
    SEPARATION_GAP,
)
from .flip import DEFAULT_MARGIN, FlipPlan, flip_task
from .flip_budget import FlipBudget, body_energy, energy_shortfall, flip_budget
from .flip_loop import body_contact_events, loop_options, replan_at

__all__ = [
    "COMPLIANT_EXTRA_TIME",
    "COMPLIANT_STIFFNESS",
    "FALL_PITCH_RATE",
    "LIMIT_TOLERANCE",
    "RECIRCULATION_DAMPING",
    "RECIRCULATION_GAIN",
    "PumpPhase",
    "PumpResult",
    "check_pump_scene",
    "energy_drawn",
    "pump_flip",
    "pump_payload",
    "predicted_modes",
    "pump_samples",
    "simulate_pump",
    "verify_compliant",
    "voltage_for_torque",
    "within_limits",
]

# ---------------------------------------------------------------------------------------------
# constants

RECIRCULATION_GAIN = 60.0
"""[V/rad] Proportional gain of a leg's voltage towards its touch-down angle in the air."""

RECIRCULATION_DAMPING = 0.5
"""[V s/rad] Damping of the same loop (added to the motor's own back-EMF damping)."""

FALL_PITCH_RATE = 1e-3
"""[rad/s] A recirculation ends, and the next push starts, once a toe touches the ground and the
body's pitch rate is at most this: the body has come back down onto its legs."""

COMPLIANT_STIFFNESS = 1e6
"""[N/m] Contact stiffness of the compliant check: the middle of the range (1e5-1e7 N/m, Radau,
critical damping) that ``python -m benchmarks.trade`` recommends for trajectories (docs/benchmarks.md,
"Which setting for which purpose")."""

COMPLIANT_EXTRA_TIME = 0.2
"""[s] After a rigid flip, the compliant replay runs this much longer (the last voltages held): a
compliant body a few milliseconds behind the rigid one still gets to pass vertical."""

LIMIT_TOLERANCE = 1e-9
"""[-] A sample's torque is within the motor's limits when it exceeds none of them by more than
this times ``1 + |torque|`` (round-off of the line's evaluation)."""

SETTLE_TIME = 1.5
"""[s] After the pitch passes vertical the run goes on at most this long (the **land** phase): the
body falls right side up onto its legs and comes to rest."""

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

PUSH_FREEDOM = {"toe": ANY_LETTER, "other_body": ANY_LETTER, "pivot": "", "rest": ""}
"""What a push allows besides its planned mode, per contact role (letters): a toe may separate
(the push ends in its lift-off) or stick or slide either way (a pushing toe's slip reverses within
a step as the leg turns), a body contact not touching at the start (RHex's rear corner) may touch
(a graze); the body contacts touching at the start (the pivot, RHex's front corner) keep their
planned letter, and the rest (the belly's corners) stay apart. The push plans' unambiguity
constraint uses exactly this (:func:`~.flip.mode_allowed`): no other rigid solution may hold at
a plan's voltages unless it is so allowed."""

FREE_FREEDOM = {"toe": ANY_LETTER, "other_body": ANY_LETTER, "pivot": ANY_LETTER, "rest": ANY_LETTER}
"""What a recirculation or the land phase allows: any letter on every contact. Neither plans a
contact mode: the legs are driven to angles and the body moves on its own (it rises and falls
back onto its toes and corners, or falls right side up onto its belly)."""

PUSH_DIRECTION_TOLERANCE = 1e-9
"""[V] A planned voltage of at most this size gives no pushing direction (the leg recirculates in
the default, negative, direction)."""


def voltage_for_torque(drive: Drive, torque: float, joint_speed: float) -> float:
    """[V] The voltage giving ``torque`` [N m] at ``joint_speed`` [rad/s], within the voltage limit.

    The inverse of :func:`frcontrol.drives.joint_torque`: ``u = R torque / (eta N C_M) + C_E N qdot``.
    """
    gain = drive.efficiency * drive.ratio * drive.torque_constant / drive.resistance
    volts = torque / gain + drive.back_emf_constant * drive.ratio * joint_speed
    return float(np.clip(volts, -drive.voltage_limit, drive.voltage_limit))


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


def _contact_roles(scene: Scene, body: Sequence[str], legs: Mapping[int, list[int]]) -> dict[str, str]:
    """Each scene contact's role in the pumping flip (the keys of :data:`PUSH_FREEDOM`).

    ``toe`` (moved by a driven leg), ``pivot`` (a body contact touching at the start),
    ``other_body`` (a body contact apart at the start), ``rest`` (every other contact).
    """
    toes = {i for contacts in legs.values() for i in contacts}
    roles = {}
    for i, c in enumerate(scene.contacts):
        if i in toes:
            roles[c.name] = "toe"
        elif c.name in body:
            roles[c.name] = "pivot" if c.active else "other_body"
        else:
            roles[c.name] = "rest"
    return roles


def _leg_contacts(scene: Scene, body: Sequence[str]) -> dict[int, list[int]]:
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


# ---------------------------------------------------------------------------------------------
# results


@dataclass(frozen=True)
class PumpPhase:
    """One phase of the pumping flip.

    Attributes:
        kind: ``"push"``, ``"recirculate"`` or ``"land"`` (after vertical).
        cycle: the pumping cycle it belongs to (a cycle starts with a push), from 1.
        start: [s] when it began; end: [s] when it ended.
        modes: the planned modes of a push (one letter per scene contact, in scene order: the
            touching contacts change from one plan to the next), in order, without repeats;
            empty for a recirculation.
        ended_by: the mode change (or the end of the run) that ended it.
        predicted: for a recirculation, the rigid solutions' modes (one letter per scene contact)
            at each decision's state and
            voltages (:func:`~frcontrol.engine.solutions_at`, the planning model), without
            repeats; a decision the acceleration-level model cannot judge (an impact) adds none.
            A push's decisions are its plans, each verified as the one rigid solution.
        unambiguous: every decision of the phase had exactly one rigid solution.
        allowed: the modes the phase's decisions allowed, one letter per scene contact (S for a
            contact a decision did not hold): a push's planned modes, a recirculation's or
            landing's predicted ones.
        free: per scene contact, the letters the phase allows it besides those of ``allowed``
            (:data:`PUSH_FREEDOM`, :data:`FREE_FREEDOM`): a sample's mode is allowed when it
            matches a mode of ``allowed`` on every contact but free ones
            (:func:`~.flip.mode_allowed`).
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


@dataclass(frozen=True)
class PumpResult:
    """The simulated pumping flip.

    Attributes:
        trajectory: the rigid run; its ``inputs`` are the voltages [V] (row k: the step ending at
            sample k).
        drives: the drive of each input, in input order.
        phases: the phases in time order.
        flipped: the pitch passed vertical within ``max_time``.
        time_to_vertical: [s] when it did (else None).
        max_pitch: [rad] the largest pitch reached; vertical: [rad] the pitch to pass.
        cycle_max_pitch: [rad] per cycle, the largest pitch reached during it.
        energy_drawn: [J] the electrical energy drawn by every drive (see the module's docstring).
        body_contact_kept: no body contact touching at the start separated (up to the flip).
        plans: ``(time, mode or None, why not)`` of every planning call of a push.
        reason: why it did not flip (None if it did).
        dt: [s] the step; max_time: [s] the simulated time limit.
        margin: [V] the push plans' margin.
        timings: [s] ``planning``, ``simulation``, ``total``.
        compliant: the compliant check (:func:`verify_compliant`), when made.
        budget: the flip's energy barrier and the legs' reach (:func:`~.flip_budget.flip_budget`).
        cycle_max_energy: [J] per cycle, the body's largest mechanical energy above the start
            (:func:`~.flip_budget.body_energy`).
        energy_audit: where the run's energy came from and went
            (:func:`~frcontrol.simulation.energy_audit.energy_audit`).
        final_pitch: [rad] the pitch at the run's last sample.
        contacts: the scene's contact names, in order (the modes' letters).
    """

    trajectory: Trajectory
    drives: tuple[Drive, ...]
    phases: tuple[PumpPhase, ...]
    flipped: bool
    time_to_vertical: float | None
    max_pitch: float
    vertical: float
    cycle_max_pitch: tuple[float, ...]
    energy_drawn: float
    body_contact_kept: bool
    plans: tuple[tuple[float, str | None, str | None], ...]
    reason: str | None
    dt: float
    max_time: float
    margin: float
    timings: Mapping[str, float]
    compliant: Mapping[str, Any] | None = None
    budget: FlipBudget | None = None
    cycle_max_energy: tuple[float, ...] = ()
    energy_audit: EnergyAudit | None = None
    final_pitch: float = math.nan
    contacts: tuple[str, ...] = ()

    @property
    def upright_pitch(self) -> float:
        """[rad] Right side up after the flip: vertical + pi/2."""
        return self.vertical + 0.5 * math.pi

    @property
    def right_side_up(self) -> bool:
        """The run ends within :data:`UPRIGHT_TOLERANCE` of :attr:`upright_pitch`."""
        return abs(self.final_pitch - self.upright_pitch) < UPRIGHT_TOLERANCE

    def modes_check(self) -> dict[str, Any]:
        """Every sample's contact modes against the modes its phase's decisions allowed.

        Sample k (the end of the step from k-1) is judged against the modes allowed by the phase
        whose decisions chose that step's voltages (``start <= t_k-1 < end``) and, where a phase
        starts at the sample (a decision made at that very state), by that phase too
        (:meth:`PumpPhase.allows`: its decisions' modes, its free contacts' letters). Returns
        ``within`` (every sample's mode is allowed), ``samples``, ``outside`` (how many are not)
        and ``first`` (``time``, ``mode``, ``phase`` of the first that is not; None).
        """
        times, modes = self.trajectory.times, self.trajectory.modes or ()
        outside, first = 0, None
        for k in range(1, len(times)):
            phase = next((p for p in self.phases if p.start <= times[k - 1] + 1e-12 < p.end), self.phases[-1])
            starting = [p for p in self.phases if abs(p.start - times[k]) <= 1e-12]
            if not phase.allows(modes[k], self.contacts) and \
                    not any(p.allows(modes[k], self.contacts) for p in starting):
                outside += 1
                if first is None:
                    first = {"time": float(times[k]), "mode": modes[k], "phase": phase.kind}
        return {"within": outside == 0, "samples": len(times) - 1, "outside": outside, "first": first}

    @property
    def cycles(self) -> int:
        """The number of pumping cycles (pushes)."""
        return sum(1 for p in self.phases if p.kind == "push")

    def to_dict(self) -> dict[str, Any]:
        """The ``pump`` part of ``frc flip --json``: cycles, time to flip, energy, phases, drives."""
        phases = [{"kind": p.kind, "cycle": p.cycle, "start": p.start, "end": p.end,
                   "modes": list(p.modes), "ended_by": p.ended_by, "predicted": list(p.predicted),
                   "unambiguous": p.unambiguous, "allowed": list(p.allowed),
                   "free": dict(p.free)} for p in self.phases]
        drives = {d.joint: {"resistance": d.resistance, "torque_constant": d.torque_constant,
                            "back_emf_constant": d.back_emf_constant, "voltage_limit": d.voltage_limit,
                            "ratio": d.ratio, "efficiency": d.efficiency, "stall_torque": stall_torque(d),
                            "no_load_speed": finite_or_none(no_load_speed(d))} for d in self.drives}
        return to_jsonable({
            "cycles": self.cycles, "flipped": self.flipped,
            "time_to_flip": finite_or_none(self.time_to_vertical), "energy_drawn": self.energy_drawn,
            "max_pitch": self.max_pitch, "vertical": self.vertical,
            "cycle_max_pitch": list(self.cycle_max_pitch), "phases": phases, "drives": drives,
            "margin": self.margin, "compliant": None if self.compliant is None else dict(self.compliant),
            "budget": None if self.budget is None else self.budget.to_dict(),
            "cycle_max_energy": list(self.cycle_max_energy),
            "max_energy": max(self.cycle_max_energy, default=None),
            "final_pitch": self.final_pitch, "upright_pitch": self.upright_pitch,
            "right_side_up": self.right_side_up, "upright_tolerance": UPRIGHT_TOLERANCE,
            "settle_time": SETTLE_TIME, "rest_speed": REST_SPEED,
            "at_rest": self.phases[-1].ended_by == "at rest", "modes_check": self.modes_check(),
            "energy_audit": None if self.energy_audit is None else self.energy_audit.to_dict(),
        })


# ---------------------------------------------------------------------------------------------
# the policy


class _PumpPolicy:
    """The phase machine: voltages from the push plans, or the legs' recirculation loop.

    Called every ``replan_every`` steps with the stepper; returns the voltages to hold.
    """

    def __init__(self, scene: Scene, drives: Sequence[Drive], margin: float, solver: str) -> None:
        task = flip_task(scene)
        self.scene, self.drives = replace(scene, gap_tolerance=REPLAN_GAP_TOLERANCE), list(drives)
        self.names = scene.inputs.coordinates
        self.index = np.array(scene.inputs.indices)
        self.pitch_index, self.vertical = task.pitch_index, task.vertical
        self.margin, self.solver = margin, solver
        self.force_tolerance = CONTACT_FORCE_TOLERANCE * scene.robot.weight_scale()
        self.legs = _leg_contacts(scene, task.body_contacts)
        self.touchdown = np.array(scene.q)[self.index]
        self.direction = -np.ones(len(self.names))
        self.target = self.touchdown.copy()
        self.kind, self.cycle, self.start = "push", 1, 0.0
        self.modes: list[str] = []  # scene modes (one letter per scene contact)
        self.predicted: list[str] = []
        self.unambiguous = True
        self.phases: list[PumpPhase] = []
        self.plans: list[tuple[float, str | None, str | None]] = []
        self.planning_time = 0.0
        self.allowed: list[str] = []  # this phase's decisions: one letter per scene contact
        self.contact_names = tuple(c.name for c in scene.contacts)
        self.roles = _contact_roles(scene, task.body_contacts, self.legs)

    def land(self, t: float, q: np.ndarray) -> None:
        """The pitch passed vertical: the land phase, the legs driven to :data:`STAND_ANGLE`."""
        self._next_phase(t, "land", "vertical passed")
        self.target = self._recirculation_targets(q, np.full(len(self.names), STAND_ANGLE))

    def _allow(self, contacts: Sequence[str], mode: str) -> None:
        """Record a decision's mode, over the scene's contacts (S for those it did not hold)."""
        letters = dict(zip(contacts, mode, strict=True))
        full = "".join(letters.get(name, "S") for name in self.contact_names)
        if full not in self.allowed:
            self.allowed.append(full)

    def toes_down(self, q: np.ndarray) -> bool:
        """Whether a leg has a contact on its surface."""
        gaps = contact_gaps(self.scene, q)
        return any(bool(np.any(gaps[toes] <= SEPARATION_GAP)) for toes in self.legs.values())

    def __call__(self, stepper: RigidStepper) -> np.ndarray:
        """The voltages from the stepper's state on."""
        q, v, t = stepper.q, stepper.v, stepper.t
        if self.kind == "land" and q[self.pitch_index] < self.vertical and v[self.pitch_index] < 0:
            self._next_phase(t, "recirculate", "the body fell back below vertical")
            self.target = self._recirculation_targets(q, self.touchdown)
        if self.kind == "recirculate" and v[self.pitch_index] <= FALL_PITCH_RATE and self.toes_down(q):
            self._next_phase(t, "push", "the body is back on a toe")
        if self.kind in ("recirculate", "land"):
            return self._checked(stepper, self._recirculation(q, v[self.index]))
        plan, why = self._plan(stepper)
        self.plans.append((t, None if plan is None else plan.mode, why))
        if plan is None:
            if why is not None and why.startswith("impact"):  # a landing: plan at the next call
                return self._recirculation(q, v[self.index])
            self._next_phase(t, "recirculate", why or "no plan")
            self.target = self._recirculation_targets(q, self.touchdown)
            return self._checked(stepper, self._recirculation(q, v[self.index]))
        volts = plan.input_vector(self.names)
        if plan.mode is not None:
            self._allow(plan.contacts, plan.mode)
        pushing = np.abs(volts) > PUSH_DIRECTION_TOLERANCE
        self.direction[pushing] = np.sign(volts[pushing])
        if plan.mode is not None:
            mode = scene_mode(plan.mode, plan.contacts, self.contact_names)
            if not self.modes or self.modes[-1] != mode:
                self.modes.append(mode)
        return volts

    def _plan(self, stepper: RigidStepper) -> tuple[FlipPlan | None, str | None]:
        """The push plan at the stepper's state, or why there is none."""
        loaded = stepper.last_forces[:, 0] > self.force_tolerance
        start = time.perf_counter()
        result = replan_at(self.scene, stepper.q, stepper.v, loaded, self.margin, self.solver,
                         self.freedom("push"))
        self.planning_time += time.perf_counter() - start
        if isinstance(result, str):
            return None, result
        if not result.found:
            return None, f"no plan: {result.reason}"
        toes = [c for c, letter in zip(result.contacts, result.mode or "", strict=False)
                if c not in result.body_contacts and letter != "S"]
        if not toes:
            planned = scene_mode(result.mode or "", result.contacts, self.contact_names)
            return None, f"the planned mode {planned} loads no toe: the toes lift off"
        return result, None

    def _checked(self, stepper: RigidStepper, volts: np.ndarray) -> np.ndarray:
        """``volts``, after recording the rigid solutions they give at the stepper's state."""
        loaded = stepper.last_forces[:, 0] > self.force_tolerance
        start = time.perf_counter()
        modes = predicted_modes(self.scene, stepper.q, stepper.v, loaded, volts)
        self.planning_time += time.perf_counter() - start
        if modes is not None:
            self.unambiguous &= len(modes) == 1
            for mode in modes:
                self._allow(self.contact_names, mode)
                if mode not in self.predicted:
                    self.predicted.append(mode)
        return volts

    def _recirculation_targets(self, q: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """Each leg's ``goal`` angle [rad], less than one turn on in its pushing direction."""
        angles = q[self.index]
        turns = np.floor(self.direction * (angles - goal) / (2 * math.pi)) + 1
        return goal + self.direction * 2 * math.pi * turns

    def _recirculation(self, q: np.ndarray, speeds: np.ndarray) -> np.ndarray:
        """[V] The legs' loop towards their targets, within each drive's voltage limit."""
        volts = RECIRCULATION_GAIN * (self.target - q[self.index]) - RECIRCULATION_DAMPING * speeds
        limits = np.array([d.voltage_limit for d in self.drives])
        return np.clip(volts, -limits, limits)

    def freedom(self, kind: str) -> dict[str, str]:
        """Per scene contact, the letters a phase of ``kind`` allows besides its decisions' modes."""
        table = PUSH_FREEDOM if kind == "push" else FREE_FREEDOM
        return {name: table[role] for name, role in self.roles.items() if table[role]}

    def _phase(self, t: float, why: str) -> PumpPhase:
        return PumpPhase(self.kind, self.cycle, self.start, t, tuple(self.modes), why, tuple(self.predicted),
                         self.unambiguous, tuple(self.allowed), self.freedom(self.kind))

    def _next_phase(self, t: float, kind: str, why: str) -> None:
        self.phases.append(self._phase(t, why))
        if kind == "push":
            self.cycle += 1
        self.kind, self.start, self.modes, self.predicted, self.unambiguous = kind, t, [], [], True
        self.allowed = []

    def close(self, t: float, why: str) -> tuple[PumpPhase, ...]:
        """The phases, the last one ended at ``t`` by ``why``."""
        return tuple([*self.phases, self._phase(t, why)])


def predicted_modes(scene: Scene, q: np.ndarray, v: np.ndarray, loaded: np.ndarray, inputs: np.ndarray
                    ) -> list[str] | None:
    """The modes of every rigid solution at a simulated state and inputs, on the planning model.

    Each mode has one letter per scene contact, in scene order (:func:`~frcontrol.modes.scene_mode`).

    The planning model of :func:`~.flip.simulate_flip`'s re-plans: the contacts within the
    scene's gap tolerance or loaded by the last step (``loaded``, per scene contact) are active, a
    loaded contact's normal velocity is 0, velocities up to :data:`~.flip.REPLAN_VELOCITY_TOLERANCE`
    are 0. None where the model does not apply (a contact moving into its surface: an impact).
    """
    from ..engine import solutions_at
    from ..modes import ContactProblem
    from ..scene import Contact

    here = scene.at(q, v)
    here = replace(here, contacts=tuple(Contact(c.point, c.gap, bool(c.active or loaded[i]))
                                        for i, c in enumerate(here.contacts)))
    try:
        problem = ContactProblem.from_scene(here, velocity_tolerance=REPLAN_VELOCITY_TOLERANCE)
        held = np.array([bool(loaded[i]) for i, c in enumerate(here.contacts) if c.active], dtype=bool)
        if held.size:
            problem = replace(problem, normal_velocities=np.where(held, 0.0, problem.normal_velocities))
        names = [c.name for c in scene.contacts]
        return [scene_mode(s.mode, problem.contacts, names) for s in solutions_at(problem, inputs)]
    except FrcontrolError:  # ImpactState included: no prediction at this state
        return None


# ---------------------------------------------------------------------------------------------
# the simulated flip


def simulate_pump(
    scene: Scene,
    *,
    dt: float = 1e-3,
    max_time: float = 4.0,
    replan_every: int = 10,
    margin: float = DEFAULT_MARGIN,
    solver: str = DEFAULT_LP_SOLVER,
    progress: Callable[[float, float], None] | None = None,
) -> PumpResult:
    """Pump the body up, phase by phase, in one rigid simulation until it passes vertical.

    The phases are defined in the module's docstring. Every ``replan_every`` steps the policy
    chooses the voltages, held until the next decision.

    Args:
        scene: RHex on its back with a DC-motor drive on every input, its ``[task]`` as for
            :func:`~.flip.plan_flip`.
        dt: [s] the time step.
        max_time: [s] the longest simulated time.
        replan_every: steps between two decisions, >= 1.
        margin: [V] the push plans' margin.
        solver: LP back-end of the plans.
        progress: called with (simulated time, max_time) at every decision.

    Raises:
        InputError: a bad step, time or count.
        SceneError: an input without a drive, a malformed ``[task]`` table.
    """
    start = time.perf_counter()
    max_time, dt, _ = loop_options(scene, dt, max_time, replan_every, None)
    task = flip_task(scene)
    drives = check_pump_scene(scene)
    policy = _PumpPolicy(scene, drives, margin, solver)
    stepper = RigidStepper(policy.scene, RigidSettings(max_ambiguity_checks=0))
    crossed = _run(policy, stepper, task, dt, max_time, replan_every, progress)
    trajectory = stepper.trajectory(dt)
    trajectory = replace(trajectory, modes=tuple(sample_modes(scene, trajectory)),
                         info={**trajectory.info, "source": "simulate_pump"})
    flipped = crossed is not None
    failure = trajectory.failure
    end_reason = ("at rest" if _at_rest(trajectory.v[-1], task) else "the settling time's end") if flipped \
        else failure.reason if failure is not None else "the end of the run"
    phases = policy.close(float(trajectory.times[-1]), end_reason)
    last = len(trajectory.times) - 1 if crossed is None else crossed
    separation, _ = body_contact_events(scene, trajectory, task.body_contacts, last)
    pitch = trajectory.q[:, task.pitch_index]
    budget, energy = _budget(scene, trajectory)
    total = time.perf_counter() - start
    return PumpResult(
        trajectory=trajectory, drives=tuple(drives), phases=phases, flipped=flipped,
        time_to_vertical=_crossing_time(trajectory.times, pitch, task.vertical, crossed),
        max_pitch=float(pitch.max()), vertical=task.vertical,
        cycle_max_pitch=_cycle_max(trajectory.times, pitch, phases),
        energy_drawn=energy_drawn(scene, trajectory), body_contact_kept=separation is None,
        plans=tuple(policy.plans),
        reason=None if flipped else _why_not(trajectory, pitch, task.vertical, max_time) + (
            "" if budget is None else f"; {energy_shortfall(budget, energy)}"),
        dt=dt, max_time=max_time, margin=margin,
        timings={"planning": policy.planning_time, "simulation": total - policy.planning_time,
                 "total": total},
        budget=budget, cycle_max_energy=_cycle_max(trajectory.times, energy, phases) if energy.size else (),
        energy_audit=energy_audit(scene, trajectory), final_pitch=float(pitch[-1]),
        contacts=tuple(c.name for c in scene.contacts),
    )


def _run(policy: _PumpPolicy, stepper: RigidStepper, task: Any, dt: float, max_time: float,
         replan_every: int, progress: Callable[[float, float], None] | None) -> int | None:
    """Step the closed loop; return the first sample at or past vertical (None: not reached).

    Until ``max_time`` or, once the pitch has passed vertical (the land phase), until the body is
    at rest right side up or :data:`SETTLE_TIME` has passed since it last did (a body that falls
    back on its back is pumped again).
    """
    volts = np.zeros(len(policy.names))
    end, crossed, k, samples = max_time, None, 0, 0
    while stepper.t < end - 1e-9:
        if k % replan_every == 0:
            volts = policy(stepper)
            if progress is not None:
                progress(stepper.t, end)
        if not stepper.step(volts, min(dt, end - stepper.t)):
            break
        k, samples = k + 1, samples + 1
        pitch = stepper.q[task.pitch_index]
        if policy.kind != "land" and pitch >= task.vertical:
            crossed = samples if crossed is None else crossed
            end = max(end, stepper.t + SETTLE_TIME)
            policy.land(stepper.t, stepper.q)
            k = 0  # decide at once
        elif policy.kind == "land" and _at_rest(stepper.v, task) \
                and abs(pitch - task.vertical - 0.5 * math.pi) < UPRIGHT_TOLERANCE:
            break
    return crossed


def _at_rest(v: np.ndarray, task: Any) -> bool:
    """Whether the base's velocities (the pitch's and the two before it) are all within :data:`REST_SPEED`."""
    base = np.asarray(v)[max(task.pitch_index - 2, 0): task.pitch_index + 1]
    return bool(np.all(np.abs(base) <= REST_SPEED))


def _crossing_time(times: np.ndarray, pitch: np.ndarray, vertical: float, crossed: int | None
                   ) -> float | None:
    """[s] When the pitch crossed vertical (linear between the samples around ``crossed``)."""
    if crossed is None:
        return None
    if crossed == 0:
        return 0.0
    t_a, t_b, p_a, p_b = times[crossed - 1], times[crossed], pitch[crossed - 1], pitch[crossed]
    return float(t_a + (vertical - p_a) / (p_b - p_a) * (t_b - t_a))


def _budget(scene: Scene, trajectory: Trajectory) -> tuple[FlipBudget | None, np.ndarray]:
    """The flip's energy budget and the body's energy [J] per sample.

    (None, empty) where the budget does not apply: no planar floating base, or the body's contacts
    on different surfaces.
    """
    try:
        return flip_budget(scene), body_energy(scene, trajectory)
    except SceneError:
        return None, np.empty(0)


def _why_not(trajectory: Trajectory, pitch: np.ndarray, vertical: float, max_time: float) -> str:
    failure = trajectory.failure
    if failure is not None:
        return f"the simulation {trajectory.status} at t = {failure.time:.4g} s: {failure.reason}"
    return (f"the pitch reached {float(pitch.max()):.4f} rad within {max_time:g} s, short of vertical "
            f"({vertical:.4f} rad)")


def _cycle_max(times: np.ndarray, series: np.ndarray, phases: Sequence[PumpPhase]) -> tuple[float, ...]:
    """The largest value of ``series`` (a pitch [rad], an energy [J]) over each cycle's samples."""
    best: dict[int, float] = {}
    for phase in phases:
        inside = (times >= phase.start) & (times <= phase.end)
        if np.any(inside):
            best[phase.cycle] = max(best.get(phase.cycle, -math.inf), float(series[inside].max()))
    return tuple(best[c] for c in sorted(best))


def energy_drawn(scene: Scene, trajectory: Trajectory) -> float:
    """[J] ``sum_j sum_k u_j,k i_j,k (t_k - t_k-1)`` over the samples (row 0 repeats row 1: skipped)."""
    from ..simulation.drives import drive_samples

    power = sum(table["voltage"] * table["current"] for table in drive_samples(scene, trajectory).values())
    return float(np.sum(np.asarray(power)[1:] * np.diff(trajectory.times)))


def pump_samples(scene: Scene, trajectory: Trajectory) -> dict[str, Any]:
    """The run's ``samples``, as ``frc simulate --json`` has them, with each drive's limits.

    ``times``, ``q``, ``v`` (a row per sample), ``drives`` (per joint ``voltage`` [V], ``current``
    [A], ``motor_speed`` [rad/s, motor side], ``torque`` [N m, joint side]) and the rest of
    :meth:`Trajectory.to_dict`'s samples; each drive adds ``torque_lower`` and ``torque_upper``
    [N m], the torque-speed line's limits at the sample's joint speed.
    """
    samples = dict(trajectory.to_dict(scene)["samples"])
    for joint, table in samples.get("drives", {}).items():
        speed = np.asarray(samples["v"])[:, scene.coordinate_names.index(joint)]
        lo, hi = torque_limits(scene.drives[joint], speed)
        table["torque_lower"], table["torque_upper"] = to_jsonable(lo), to_jsonable(hi)
    return samples


def within_limits(samples: Mapping[str, Any]) -> bool:
    """Every sample's torque within its limits, to :data:`LIMIT_TOLERANCE`."""
    for table in samples.get("drives", {}).values():
        torque = np.asarray(table["torque"], dtype=float)
        slack = LIMIT_TOLERANCE * (1.0 + np.abs(torque))
        if np.any(torque < np.asarray(table["torque_lower"]) - slack) or \
                np.any(torque > np.asarray(table["torque_upper"]) + slack):
            return False
    return True


# ---------------------------------------------------------------------------------------------
# the compliant check


def verify_compliant(scene: Scene, result: PumpResult, *, stiffness: float = COMPLIANT_STIFFNESS,
                     to_end: bool = False) -> dict[str, Any]:
    """The rigid run's voltages, replayed against time, on the compliant model.

    Radau, critical damping, ``stiffness`` [N/m] on every listed contact (so the rear corner can
    land), each sample interval holding the voltage the rigid run held there, up to the rigid
    run's time to vertical plus :data:`COMPLIANT_EXTRA_TIME` (after a rigid flip), else ``max_time``;
    with ``to_end``, up to the rigid run's last sample (the land phase included).

    Returns:
        ``stiffness``, ``flipped`` (the pitch passed vertical), ``time_to_vertical`` [s],
        ``max_pitch`` [rad], ``final_pitch`` [rad], ``right_side_up`` (the final pitch within
        :data:`UPRIGHT_TOLERANCE` of upright), ``status``, ``duration`` [s],
        ``torque_within_limits`` (from the compliant run's own samples) and ``wall_time`` [s].
    """
    from ..simulation.compliant import simulate_compliant

    voltages = result.trajectory.inputs
    dt = result.dt
    task = flip_task(scene)

    def held(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return voltages[min(int(round(t / dt)) + 1, len(voltages) - 1)]

    start = time.perf_counter()
    flip_time = result.time_to_vertical
    duration = flip_time + COMPLIANT_EXTRA_TIME if flip_time is not None else result.max_time
    if to_end:
        duration = float(result.trajectory.times[-1])
    run = simulate_compliant(scene, held, duration=max(duration, dt), dt=dt, stiffness=stiffness,
                             contacts="all")
    pitch = run.q[:, task.pitch_index]
    crossed = np.nonzero(pitch >= task.vertical)[0]
    return {
        "stiffness": stiffness, "flipped": bool(crossed.size),
        "time_to_vertical": float(run.times[crossed[0]]) if crossed.size else None,
        "max_pitch": float(pitch.max()), "final_pitch": float(pitch[-1]),
        "right_side_up": bool(abs(pitch[-1] - result.upright_pitch) < UPRIGHT_TOLERANCE),
        "status": run.status, "duration": float(run.times[-1]),
        "torque_within_limits": within_limits(pump_samples(scene, run)),
        "wall_time": time.perf_counter() - start,
    }


# ---------------------------------------------------------------------------------------------
# frc flip on a scene with drives


def pump_flip(scene: Scene, *, margin: float = DEFAULT_MARGIN, max_time: float = 4.0, dt: float = 1e-3,
              replan_every: int = 10, compliant: bool = False,
              progress: Callable[[float, float], None] | None = None) -> tuple[FlipPlan, PumpResult | None]:
    """The first push's plan at the scene's state and, when ``max_time`` > 0, the pumping run.

    ``compliant`` adds :func:`verify_compliant` to the result, replayed to the rigid run's end.

    Raises:
        InputError, SceneError: see :func:`simulate_pump` and :func:`~.flip.plan_flip`.
    """
    from .flip import plan_flip

    check_pump_scene(scene)
    plan = plan_flip(scene, margin=margin)
    if max_time <= 0:
        return plan, None
    result = simulate_pump(scene, dt=dt, max_time=max_time, replan_every=replan_every, margin=margin,
                           progress=progress)
    if compliant:
        result = replace(result, compliant=verify_compliant(scene, result, to_end=True))
    return plan, result


def pump_payload(scene: Scene, plan: FlipPlan, result: PumpResult | None) -> dict[str, Any]:
    """The ``frc flip --json`` document of the pumping flip.

    The flip's keys (its first push's plan: ``torques`` are then the inputs' values, voltages for
    driven joints, ``input_units`` says), ``simulation`` from the pumping run with ``samples``
    (:func:`pump_samples`), and ``pump`` (:meth:`PumpResult.to_dict`).
    """
    payload = plan.to_dict()
    payload["input_units"] = scene.inputs.unit_map()
    if result is None:
        return payload
    traj = result.trajectory
    samples = pump_samples(scene, traj)
    payload["simulation"] = to_jsonable({
        "flipped": result.flipped, "time_to_vertical": finite_or_none(result.time_to_vertical),
        "body_contact_kept": result.body_contact_kept, "steps": len(traj.times) - 1,
        "replans": len(result.plans), "simulated": True, "reason": result.reason,
        "max_pitch": result.max_pitch, "vertical": result.vertical, "dt": result.dt,
        "max_time": result.max_time, "duration": traj.duration, "status": traj.status,
        "events": [e.to_dict() for e in traj.events], "torque_within_limits": within_limits(samples),
        "timings": dict(result.timings), "samples": samples,
    })
    payload["pump"] = result.to_dict()
    return payload
