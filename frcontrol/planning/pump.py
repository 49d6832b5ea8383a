r"""The pumping flip: RHex righted over several leg strokes, within its motors' limits.

Saranli, Rizzi and Koditschek (IJRR 23(9), 2004) right the real RHex, whose hips cannot push the
body past vertical in one stroke, by chaining strokes. The plan here chains *phases*:

- **push**: the toes on the ground push the body up about its front corner. The input is the
  flip plan (:func:`frcontrol.planning.flip.plan_flip`): the torques that maximise the pitch
  acceleration in the *unambiguous set* of a mode keeping every body contact loaded, with the
  input limits of this instant: the motor's torque-speed line at each hip's speed (below). The
  phase ends when the analysis predicts a mode change it cannot plan in: no candidate mode keeps
  a pushing toe loaded (the toes lift off), or no plan pitches the body up.
- **flight / fall** (``recirculate``): the legs are in the air, the body moves on its own. A
  massless leg in the air carries no torque in the rigid analysis (its input is forced to 0 in
  every mode: it cannot change the body's mode), so the legs' voltages only turn their rotors:
  each leg is driven round (one turn in its pushing direction, :data:`RECIRCULATION_GAIN`) to its
  touch-down angle, the angle it had at the start, where its toe meets the ground when the body
  comes back down. The phase ends when a toe touches the ground (the analysis' contact set changes).
- then **push** again: a new cycle.

**Drives.** Each planar hip stands for a pair of DC motors behind a gear (ratio N, efficiency
eta), taken as one equivalent drive. With voltage V [V] and joint speed qdot [rad/s]::

    torque = eta N CM (V - CE N qdot) / R,   |V| <= V_max
    => torque in [eta N CM (-V_max - CE N qdot) / R, eta N CM (V_max - CE N qdot) / R]

(CM [N m/A] the torque constant, CE [V s/rad] the back-EMF constant, R [ohm] the resistance).
The plan picks torques inside that interval, and the voltage that gives them is applied; the
simulation then computes each step's torque from the voltage at the step's joint speed, so
every sample's torque lies on the motor's line by construction (the JSON carries the voltage,
current, motor speed, torque and the limits of every sample: a reader can check).

**Energy drawn.** The electrical energy ``sum_j int V_j I_j dt`` [J] with the pair's current
``I = (V - CE N qdot) / R`` (negative power, braking, counts as returned).

**Verification.** The run is one rigid simulation (velocity-level time stepping with inelastic
impacts). The same voltages, replayed against time, drive the compliant model (Kelvin–Voigt
contacts at the stiffness the speed-accuracy benchmark recommends for trajectories,
:data:`COMPLIANT_STIFFNESS`), each sample's torque again from the drive's line at the compliant
joint speed: the flip must survive both.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import InputError
from ..jsonable import finite_or_none, to_jsonable
from ..scene import Scene
from ..simulation.rigid import CONTACT_FORCE_TOLERANCE, RigidSettings, RigidStepper
from ..simulation.trajectory import Trajectory
from ..solvers import DEFAULT_LP_SOLVER
from .flip import (
    DEFAULT_MARGIN,
    SEPARATION_GAP,
    FlipPlan,
    _body_contacts,
    _gaps,
    _massless_legs,
    _replan,
    _time_to_vertical,
    flip_task,
    sample_modes,
)

__all__ = [
    "COMPLIANT_EXTRA_TIME",
    "COMPLIANT_STIFFNESS",
    "DEFAULT_HIP_DRIVE",
    "FALL_PITCH_RATE",
    "LIMIT_TOLERANCE",
    "RECIRCULATION_DAMPING",
    "RECIRCULATION_GAIN",
    "HipDrive",
    "PumpPhase",
    "PumpResult",
    "drive_current",
    "drive_samples",
    "joint_torque",
    "no_load_speed",
    "pump_flip",
    "pump_payload",
    "scene_drives",
    "simulate_pump",
    "stall_torque",
    "torque_limits",
    "verify_compliant",
    "voltage_for_torque",
]

# ---------------------------------------------------------------------------------------------
# constants

RECIRCULATION_GAIN = 60.0
"""[V/rad] Proportional gain of the legs' voltage towards their touch-down angle in the air."""

RECIRCULATION_DAMPING = 0.5
"""[V s/rad] Damping of the same loop (added to the motor's own back-EMF damping)."""

COMPLIANT_STIFFNESS = 1e6
"""[N/m] Contact stiffness of the compliant check: the middle of the range (1e5-1e7 N/m, Radau,
critical damping) that ``python -m benchmarks.trade`` recommends for trajectories (README,
"Which setting for which purpose")."""

FALL_PITCH_RATE = 1e-3
"""[rad/s] A recirculation ends, and the next push starts, once a toe touches the ground and the
body's pitch rate is at most this: the body has come back down onto its legs."""

COMPLIANT_EXTRA_TIME = 0.2
"""[s] After a rigid flip, the compliant replay runs this much longer (the last voltages held): a
compliant body a few milliseconds behind the rigid one still gets to pass vertical."""

LIMIT_TOLERANCE = 1e-9
"""[-] A sample's torque is within the motor's limits when it exceeds none of them by more than
this times ``1 + |torque|`` (round-off of the line's evaluation)."""

PUSH_DIRECTION_TOLERANCE = 1e-9
"""[N m] A planned torque of at most this size gives no pushing direction (the leg recirculates
in the default, negative, direction)."""


# ---------------------------------------------------------------------------------------------
# the drive: one function gives the torque-speed line


@dataclass(frozen=True)
class HipDrive:
    """A hip's drive: a pair of DC motors behind one gear, as one equivalent motor.

    Attributes:
        resistance: [ohm] the pair's resistance (two windings in parallel).
        torque_constant: [N m/A] CM.
        back_emf_constant: [V s/rad] CE.
        voltage_limit: [V] |V| at most this.
        ratio: [-] gear ratio N (motor turns per joint turn).
        efficiency: [-] the gear's efficiency eta, in (0, 1].
    """

    resistance: float
    torque_constant: float
    back_emf_constant: float
    voltage_limit: float
    ratio: float
    efficiency: float = 1.0


DEFAULT_HIP_DRIVE = HipDrive(resistance=0.75, torque_constant=0.0242, back_emf_constant=0.0242,
                             voltage_limit=24.0, ratio=33.0, efficiency=0.75)
"""A 20 W-class pair: two Maxon-type coreless motors (24 V winding, CM = CE = 0.0242 N m/A,
1.5 ohm each, so 0.75 ohm for the pair) behind 33:1 gearheads of efficiency 0.75, as on RHex
(Saranli, Buehler and Koditschek 2001). Stall torque 19.2 N m per pair (below 20 N m), no-load
joint speed 30 rad/s (RHex's legs turn at up to about 5 Hz when running). Used when the scene
gives no drive."""


def joint_torque(drive: HipDrive, voltage: float | np.ndarray, joint_speed: float | np.ndarray
                 ) -> float | np.ndarray:
    """[N m] ``eta N CM (V - CE N qdot) / R`` at voltage [V] and joint speed [rad/s]."""
    d = drive
    back_emf = d.back_emf_constant * d.ratio * joint_speed
    return d.efficiency * d.ratio * d.torque_constant * (voltage - back_emf) / d.resistance


def torque_limits(drive: HipDrive, joint_speed: float) -> tuple[float, float]:
    """[N m] The torque interval at a joint speed [rad/s]: the line at ``-V_max`` and ``+V_max``."""
    lo = float(joint_torque(drive, -drive.voltage_limit, joint_speed))
    hi = float(joint_torque(drive, drive.voltage_limit, joint_speed))
    return lo, hi


def stall_torque(drive: HipDrive) -> float:
    """[N m] ``eta N CM V_max / R``: the torque at rest and full voltage."""
    return float(joint_torque(drive, drive.voltage_limit, 0.0))


def no_load_speed(drive: HipDrive) -> float:
    """[rad/s] ``V_max / (CE N)``: the joint speed where the torque at full voltage is 0."""
    return drive.voltage_limit / (drive.back_emf_constant * drive.ratio)


def voltage_for_torque(drive: HipDrive, torque: float, joint_speed: float) -> float:
    """[V] The voltage giving ``torque`` [N m] at ``joint_speed`` [rad/s], within the voltage limit."""
    d = drive
    volts = torque * d.resistance / (d.efficiency * d.ratio * d.torque_constant) \
        + d.back_emf_constant * d.ratio * joint_speed
    return float(np.clip(volts, -d.voltage_limit, d.voltage_limit))


def drive_current(drive: HipDrive, voltage: np.ndarray, joint_speed: np.ndarray) -> np.ndarray:
    """[A] The pair's current ``(V - CE N qdot) / R``."""
    return (voltage - drive.back_emf_constant * drive.ratio * joint_speed) / drive.resistance


def _within_drive_limits(scene: Scene, drives: Sequence[HipDrive], speeds: np.ndarray) -> Scene:
    """The scene with its input limits narrowed to the drives' torque-speed limits at ``speeds``.

    The scene's own torque limits still hold where they are narrower.
    """
    limits = np.array([torque_limits(d, float(s)) for d, s in zip(drives, speeds, strict=True)])
    limits = limits.reshape(-1, 2)
    lower = np.maximum(scene.inputs.lower, limits[:, 0])
    upper = np.minimum(scene.inputs.upper, limits[:, 1])
    return replace(scene, inputs=replace(scene.inputs, lower=lower, upper=upper))


def scene_drives(scene: Scene) -> dict[str, HipDrive]:
    """The drive of each input: :data:`DEFAULT_HIP_DRIVE` for every input of the scene."""
    return {name: DEFAULT_HIP_DRIVE for name in scene.inputs.coordinates}


# ---------------------------------------------------------------------------------------------
# results


@dataclass(frozen=True)
class PumpPhase:
    """One phase of the pumping flip.

    Attributes:
        kind: ``"push"`` or ``"recirculate"``.
        cycle: the pumping cycle it belongs to (a cycle starts with a push), from 1.
        start: [s] its first sample's time; end: [s] the time it ended.
        modes: the planned modes of a push (one letter per active contact), in order, without
            repeats; empty for a recirculation (its legs cannot change the body's mode).
        ended_by: the mode change (or the end of the run) that ended it.
    """

    kind: str
    cycle: int
    start: float
    end: float
    modes: tuple[str, ...]
    ended_by: str


@dataclass(frozen=True)
class PumpResult:
    """The simulated pumping flip.

    Attributes:
        trajectory: the rigid run (its ``inputs`` are the applied torques [N m]).
        voltages: [V] per sample, one column per input (the voltage held from that sample on; the
            last sample repeats the last step's).
        drives: the drive of each input.
        phases: the phases in time order.
        flipped: the pitch passed vertical within ``max_time``.
        time_to_vertical: [s] when it did (else None).
        max_pitch: [rad] the largest pitch reached; vertical: [rad] the pitch to pass.
        cycle_max_pitch: [rad] per cycle, the largest pitch reached during it.
        energy_drawn: [J] the electrical energy drawn by every drive (see the module's docstring).
        body_contact_kept: no body contact touching at the start separated (up to the flip).
        plans: ``(time, mode or None, why not)`` of every planning call of a push.
        reason: why it did not flip (None if it did).
        dt: [s] the step; max_time: [s] the simulated time limit; armature: [kg m^2] the legs'.
        margin: [N m] the push plans' margin.
        timings: [s] ``simulation``, ``planning``, ``total``.
        compliant: the compliant check (:func:`verify_compliant`), when made.
    """

    trajectory: Trajectory
    voltages: np.ndarray
    drives: Mapping[str, HipDrive]
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
    armature: float
    margin: float
    timings: Mapping[str, float]
    compliant: Mapping[str, Any] | None = None

    @property
    def cycles(self) -> int:
        """The number of pumping cycles (pushes)."""
        return sum(1 for p in self.phases if p.kind == "push")

    def to_dict(self) -> dict[str, Any]:
        """The pumping part of ``frc flip --json`` (``pump``), and its ``simulation``."""
        phases = [{"kind": p.kind, "cycle": p.cycle, "start": p.start, "end": p.end,
                   "modes": list(p.modes), "ended_by": p.ended_by} for p in self.phases]
        drives = {name: {"resistance": d.resistance, "torque_constant": d.torque_constant,
                         "back_emf_constant": d.back_emf_constant, "voltage_limit": d.voltage_limit,
                         "ratio": d.ratio, "efficiency": d.efficiency, "stall_torque": stall_torque(d),
                         "no_load_speed": no_load_speed(d)} for name, d in self.drives.items()}
        return to_jsonable({
            "cycles": self.cycles,
            "flipped": self.flipped,
            "time_to_flip": finite_or_none(self.time_to_vertical),
            "energy_drawn": self.energy_drawn,
            "max_pitch": self.max_pitch,
            "vertical": self.vertical,
            "cycle_max_pitch": list(self.cycle_max_pitch),
            "phases": phases,
            "drives": drives,
            "margin": self.margin,
            "compliant": None if self.compliant is None else dict(self.compliant),
        })


# ---------------------------------------------------------------------------------------------
# the policy


class _PumpPolicy:
    """The phase machine: voltages from the push plans, or the legs' recirculation loop.

    Called every ``replan_every`` steps with the stepper; returns the voltages to hold.
    """

    def __init__(self, scene: Scene, drives: Mapping[str, HipDrive], margin: float, solver: str) -> None:
        self.scene = scene
        self.names = scene.inputs.coordinates
        self.drives = [drives[name] for name in self.names]
        self.index = np.array(scene.inputs.indices)
        self.margin, self.solver = margin, solver
        self.force_tolerance = CONTACT_FORCE_TOLERANCE * scene.robot.weight_scale()
        self.pitch_index = flip_task(scene).pitch_index
        self.legs = _massless_legs(scene)
        self.touchdown = np.array(scene.q)[self.index]
        self.direction = -np.ones(len(self.names))
        self.target = self.touchdown.copy()
        self.kind, self.cycle, self.start = "push", 1, 0.0
        self.modes: list[str] = []
        self.phases: list[PumpPhase] = []
        self.plans: list[tuple[float, str | None, str | None]] = []
        self.planning_time = 0.0

    def toes_down(self, q: np.ndarray) -> np.ndarray:
        """Per input, whether its leg has a contact on its surface (no leg: True)."""
        gaps = _gaps(self.scene, q)
        down = np.ones(len(self.names), dtype=bool)
        for i, toes in self.legs.items():
            down[i] = bool(np.any(gaps[toes] <= SEPARATION_GAP))
        return down

    def __call__(self, stepper: RigidStepper) -> np.ndarray:
        """The voltages from the stepper's state on."""
        q, v, t = stepper.q, stepper.v, stepper.t
        speeds = v[self.index]
        down = self.toes_down(q)
        falling = v[self.pitch_index] <= FALL_PITCH_RATE
        if self.kind == "recirculate" and falling and np.any(down & self._legged()):
            self._next_phase(t, "push", "the body is back on a toe")
        volts = self._recirculation(q, speeds)
        if self.kind == "push":
            plan, why = self._plan(stepper, speeds)
            self.plans.append((t, plan.mode if plan is not None else None, why))
            if plan is None:
                if why is not None and why.startswith("impact"):
                    return volts  # a landing: the acceleration-level model does not apply yet
                self._next_phase(t, "recirculate", why or "no plan")
                self.target = self._recirculation_targets(q)
                return self._recirculation(q, speeds)
            torques = plan.input_vector(self.names)
            for i, drive in enumerate(self.drives):
                torque = float(torques[i]) if down[i] else 0.0  # a leg in the air coasts
                volts[i] = voltage_for_torque(drive, torque, float(speeds[i]))
                if abs(torques[i]) > PUSH_DIRECTION_TOLERANCE:
                    self.direction[i] = math.copysign(1.0, float(torques[i]))
            if plan.mode is not None and (not self.modes or self.modes[-1] != plan.mode):
                self.modes.append(plan.mode)
        return volts

    def _legged(self) -> np.ndarray:
        mask = np.zeros(len(self.names), dtype=bool)
        mask[list(self.legs)] = True
        return mask

    def _plan(self, stepper: RigidStepper, speeds: np.ndarray) -> tuple[FlipPlan | None, str | None]:
        """The push plan within the torque-speed limits of this instant, or why there is none."""
        scene = _within_drive_limits(self.scene, self.drives, speeds)
        loaded = stepper.last_forces[:, 0] > self.force_tolerance
        start = time.perf_counter()
        result = _replan(scene, stepper.q, stepper.v, loaded, self.margin, self.solver)
        self.planning_time += time.perf_counter() - start
        if isinstance(result, str):
            return None, result
        if not result.found:
            return None, f"no plan: {result.reason}"
        toes = [c for c, letter in zip(result.contacts, result.mode or "", strict=False)
                if c not in result.body_contacts and letter != "S"]
        if not toes:
            return None, f"the planned mode {result.mode} loads no toe: the toes lift off"
        if result.pitch_acceleration is None or result.pitch_acceleration <= 0:
            return None, "no plan pitches the body up"
        return result, None

    def _recirculation_targets(self, q: np.ndarray) -> np.ndarray:
        """Each leg's touch-down angle, one turn on in its pushing direction (at most one turn)."""
        angles = q[self.index]
        turns = np.floor(self.direction * (angles - self.touchdown) / (2 * math.pi)) + 1
        targets = self.touchdown + self.direction * 2 * math.pi * turns
        near = np.abs(angles - self.touchdown) < 1e-3
        return np.where(near, self.touchdown, targets)

    def _recirculation(self, q: np.ndarray, speeds: np.ndarray) -> np.ndarray:
        """[V] The legs' loop towards their targets, within each drive's voltage limit."""
        error = self.target - q[self.index]
        volts = RECIRCULATION_GAIN * error - RECIRCULATION_DAMPING * speeds
        limits = np.array([d.voltage_limit for d in self.drives])
        return np.clip(volts, -limits, limits)

    def _next_phase(self, t: float, kind: str, why: str) -> None:
        self.phases.append(PumpPhase(self.kind, self.cycle, self.start, t, tuple(self.modes), why))
        if kind == "push":
            self.cycle += 1
        self.kind, self.start, self.modes = kind, t, []

    def close(self, t: float, why: str) -> tuple[PumpPhase, ...]:
        """The phases, the last one ended at ``t`` by ``why``."""
        return tuple(self.phases + [PumpPhase(self.kind, self.cycle, self.start, t, tuple(self.modes), why)])


# ---------------------------------------------------------------------------------------------
# the simulated flip


def simulate_pump(
    scene: Scene,
    *,
    dt: float = 1e-3,
    max_time: float = 4.0,
    replan_every: int = 10,
    margin: float = DEFAULT_MARGIN,
    armature: float | None = None,
    solver: str = DEFAULT_LP_SOLVER,
    drives: Mapping[str, HipDrive] | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> PumpResult:
    """Pump the body up, phase by phase, in one rigid simulation until it passes vertical.

    The phases and the drives are defined in the module's docstring. Every ``replan_every`` steps
    the policy chooses the voltages; every step applies the torque the drive gives at that
    voltage and the step's joint speed.

    Args:
        scene: the scene (RHex on its back, its ``[task]`` as for :func:`~.flip.plan_flip`).
        dt: [s] the time step.
        max_time: [s] the longest simulated time.
        replan_every: steps between two decisions, >= 1.
        margin: [N m] the push plans' margin.
        armature: [kg m^2] the massless hips' rotor inertia (default as :func:`~.flip.simulate_flip`).
        solver: LP back-end of the plans.
        drives: the drive of each input (default: :func:`scene_drives`).
        progress: called with (simulated time, max_time) at every decision.

    Raises:
        InputError: a bad step, time, count or armature, or a drive missing for an input.
        SceneError: a malformed ``[task]`` table.
    """
    from .flip import _loop_options

    start = time.perf_counter()
    max_time, dt, arm = _loop_options(scene, dt, max_time, replan_every, armature)
    task = flip_task(scene)
    drives = dict(scene_drives(scene) if drives is None else drives)
    missing = [name for name in scene.inputs.coordinates if name not in drives]
    if missing:
        raise InputError(f"no drive for the input(s) {', '.join(missing)}; the drives given are for "
                         f"{', '.join(drives) or 'no input'}")
    policy = _PumpPolicy(scene, drives, margin, solver)
    stepper = RigidStepper(scene, RigidSettings(max_ambiguity_checks=0), armature=arm)
    volts, voltages = np.zeros(scene.inputs.count), []
    steps = int(math.ceil(max_time / dt - 1e-9))
    for k in range(steps):
        if k % replan_every == 0:
            volts = policy(stepper)
            if progress is not None:
                progress(stepper.t, max_time)
        speeds = stepper.v[policy.index]
        torques = np.array([joint_torque(d, float(V), float(s))
                            for d, V, s in zip(policy.drives, volts, speeds, strict=True)])
        voltages.append(volts.copy())
        if not stepper.step(torques, min(dt, max_time - stepper.t) if k == steps - 1 else dt):
            voltages.pop()
            break
        if stepper.q[task.pitch_index] >= task.vertical:
            break
    trajectory = stepper.trajectory(dt)
    flipped = bool(trajectory.q[-1, task.pitch_index] >= task.vertical)
    trajectory = replace(trajectory, modes=tuple(sample_modes(scene, trajectory)),
                         info={**trajectory.info, "source": "simulate_pump"})
    held = np.array(voltages + voltages[-1:]) if voltages else np.zeros((1, scene.inputs.count))
    end = float(trajectory.times[-1])
    phases = policy.close(end, "vertical passed" if flipped else trajectory.failure.reason
                          if trajectory.failure is not None else "the end of the run")
    separation, _ = _body_contacts(scene, trajectory, task.body_contacts, len(trajectory.times) - 1)
    pitch = trajectory.q[:, task.pitch_index]
    total = time.perf_counter() - start
    return PumpResult(
        trajectory=trajectory, voltages=held, drives=drives, phases=phases, flipped=flipped,
        time_to_vertical=_time_to_vertical(trajectory, task) if flipped else None,
        max_pitch=float(pitch.max()), vertical=task.vertical,
        cycle_max_pitch=_cycle_max_pitch(trajectory.times, pitch, phases),
        energy_drawn=_energy_drawn(trajectory, held, policy),
        body_contact_kept=separation is None, plans=tuple(policy.plans),
        reason=None if flipped else _why_not(trajectory, pitch, task.vertical, max_time),
        dt=dt, max_time=max_time, armature=arm, margin=margin,
        timings={"planning": policy.planning_time, "simulation": total - policy.planning_time,
                 "total": total},
    )


def _why_not(trajectory: Trajectory, pitch: np.ndarray, vertical: float, max_time: float) -> str:
    failure = trajectory.failure
    if failure is not None:
        return f"the simulation {trajectory.status} at t = {failure.time:.4g} s: {failure.reason}"
    return (f"the pitch reached {float(pitch.max()):.4f} rad within {max_time:g} s, short of vertical "
            f"({vertical:.4f} rad)")


def _cycle_max_pitch(times: np.ndarray, pitch: np.ndarray, phases: Sequence[PumpPhase]) -> tuple[float, ...]:
    """[rad] The largest pitch of each cycle's samples."""
    best: dict[int, float] = {}
    for phase in phases:
        inside = (times >= phase.start) & (times <= phase.end)
        if np.any(inside):
            best[phase.cycle] = max(best.get(phase.cycle, -math.inf), float(pitch[inside].max()))
    return tuple(best[c] for c in sorted(best))


def _energy_drawn(trajectory: Trajectory, voltages: np.ndarray, policy: _PumpPolicy) -> float:
    """[J] ``sum_j int V_j I_j dt``, each step's power at its start."""
    speeds = trajectory.v[:, policy.index]
    power = np.zeros(len(trajectory.times))
    for j, drive in enumerate(policy.drives):
        power += voltages[:, j] * drive_current(drive, voltages[:, j], speeds[:, j])
    return float(np.sum(power[:-1] * np.diff(trajectory.times)))


def drive_samples(trajectory: Trajectory, voltages: np.ndarray, drives: Mapping[str, HipDrive],
                  index: Sequence[int]) -> dict[str, Any]:
    """The ``samples`` of a run with drives: ``times``, ``q``, ``v`` (a row per sample) and ``drives``.

    ``drives``: per input, ``voltage`` [V], ``current`` [A], ``motor_speed`` [rad/s, motor side],
    ``torque`` [N m, joint side], and the torque-speed limits ``torque_lower``, ``torque_upper``
    [N m] at the sample's joint speed: what the motor could give there.
    """
    out: dict[str, Any] = {"times": trajectory.times, "q": trajectory.q, "v": trajectory.v, "drives": {}}
    for j, (name, drive) in enumerate(drives.items()):
        speed = trajectory.v[:, index[j]]
        volts = voltages[:, j]
        limits = np.array([torque_limits(drive, float(s)) for s in speed]).reshape(-1, 2)
        out["drives"][name] = {
            "voltage": volts, "current": drive_current(drive, volts, speed),
            "motor_speed": drive.ratio * speed, "torque": joint_torque(drive, volts, speed),
            "torque_lower": limits[:, 0], "torque_upper": limits[:, 1],
        }
    return out


# ---------------------------------------------------------------------------------------------
# the compliant check


def verify_compliant(scene: Scene, result: PumpResult, *, stiffness: float = COMPLIANT_STIFFNESS
                     ) -> dict[str, Any]:
    """The rigid run's voltages, replayed against time, on the compliant model.

    Each sample interval holds the torque the drive gives at the rigid run's voltage and the
    compliant run's joint speed (after a rigid flip, :data:`COMPLIANT_EXTRA_TIME` more with the
    last voltages) (so the torques stay on the motor's line); Radau, critical
    damping, ``stiffness`` [N/m] on every contact (all listed, so the rear corner can land).

    Returns:
        ``stiffness``, ``flipped`` (the pitch passed vertical), ``time_to_vertical`` [s],
        ``max_pitch`` [rad], ``status``, ``wall_time`` [s], and ``torque_within_limits`` (every
        sample's torque within the line's limits at its joint speed, to :data:`LIMIT_TOLERANCE`).
    """
    from ..simulation.compliant import simulate_compliant

    trajectory = result.trajectory
    names = scene.inputs.coordinates
    drives = [result.drives[name] for name in names]
    index = np.array(scene.inputs.indices)
    task = flip_task(scene)
    dt = result.dt
    voltages = result.voltages

    def torques(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        row = voltages[min(int(round(t / dt)), len(voltages) - 1)]
        return np.array([joint_torque(d, float(V), float(v[j]))
                         for d, V, j in zip(drives, row, index, strict=True)])

    start = time.perf_counter()
    duration = float(trajectory.times[-1]) + COMPLIANT_EXTRA_TIME if result.flipped else result.max_time
    unlimited = np.full(scene.inputs.count, np.inf)  # the drive's line is the limit
    free = replace(scene, inputs=replace(scene.inputs, lower=-unlimited, upper=unlimited))
    run = simulate_compliant(free, torques, duration=max(duration, dt), dt=dt, stiffness=stiffness,
                             contacts="all", armature=result.armature)
    pitch = run.q[:, task.pitch_index]
    crossed = np.nonzero(pitch >= task.vertical)[0]
    applied = run.inputs[1:]
    speeds = run.v[:-1, index]
    within = True
    for j, drive in enumerate(drives):
        lo, hi = np.vectorize(lambda s, d=drive: torque_limits(d, float(s)))(speeds[:, j])
        slack = LIMIT_TOLERANCE * (1.0 + np.abs(applied[:, j]))
        within &= bool(np.all((applied[:, j] >= lo - slack) & (applied[:, j] <= hi + slack)))
    return {
        "stiffness": stiffness, "flipped": bool(crossed.size),
        "time_to_vertical": float(run.times[crossed[0]]) if crossed.size else None,
        "max_pitch": float(pitch.max()), "status": run.status, "duration": float(run.times[-1]),
        "torque_within_limits": within, "wall_time": time.perf_counter() - start,
    }


# ---------------------------------------------------------------------------------------------
# frc flip --pump


def pump_flip(scene: Scene, *, margin: float = DEFAULT_MARGIN, max_time: float = 4.0, dt: float = 1e-3,
              replan_every: int = 10, compliant: bool = False,
              progress: Callable[[float, float], None] | None = None) -> tuple[FlipPlan, PumpResult | None]:
    """The first push's plan at the scene's state and, when ``max_time`` > 0, the pumping run.

    The first plan is the flip plan within the drives' stall torques (the torque-speed limits at
    rest); ``compliant`` adds :func:`verify_compliant` to the result.

    Raises:
        InputError, SceneError: see :func:`simulate_pump` and :func:`~.flip.plan_flip`.
    """
    from .flip import plan_flip

    drives = scene_drives(scene)
    speeds = scene.v[list(scene.inputs.indices)]
    plan = plan_flip(_within_drive_limits(scene, [drives[n] for n in scene.inputs.coordinates], speeds),
                     margin=margin)
    if max_time <= 0:
        return plan, None
    result = simulate_pump(scene, dt=dt, max_time=max_time, replan_every=replan_every, margin=margin,
                           drives=drives, progress=progress)
    if compliant:
        result = replace(result, compliant=verify_compliant(scene, result))
    return plan, result


def pump_payload(scene: Scene, plan: FlipPlan, result: PumpResult | None) -> dict[str, Any]:
    """The ``frc flip --pump --json`` document.

    The flip's keys (its first plan), ``simulation`` from the pumping run with ``samples``
    (``times``, ``q``, ``v``, ``drives``), and ``pump`` (cycles, phases, energy drawn).
    """
    payload = plan.to_dict(None)
    if result is None:
        return payload
    traj = result.trajectory
    index = list(scene.inputs.indices)
    within = all(
        bool(np.all((d["torque"] >= d["torque_lower"] - LIMIT_TOLERANCE * (1 + np.abs(d["torque"])))
                    & (d["torque"] <= d["torque_upper"] + LIMIT_TOLERANCE * (1 + np.abs(d["torque"])))))
        for d in drive_samples(traj, result.voltages, result.drives, index)["drives"].values())
    payload["simulation"] = to_jsonable({
        "flipped": result.flipped, "time_to_vertical": finite_or_none(result.time_to_vertical),
        "body_contact_kept": result.body_contact_kept, "steps": len(traj.times) - 1,
        "replans": len(result.plans), "simulated": True, "reason": result.reason,
        "max_pitch": result.max_pitch, "vertical": result.vertical, "dt": result.dt,
        "max_time": result.max_time, "armature": result.armature, "duration": traj.duration,
        "status": traj.status, "events": [e.to_dict() for e in traj.events],
        "torque_within_limits": within, "timings": dict(result.timings),
        "samples": drive_samples(traj, result.voltages, result.drives, index),
    })
    payload["pump"] = result.to_dict()
    return payload
