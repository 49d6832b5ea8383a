r"""The pumping flip: RHex righted over several leg strokes, within its motors' limits.

Saranli, Rizzi and Koditschek (IJRR 23(9), 2004) right the real RHex, whose hips cannot push the
body past vertical in one stroke, by chaining strokes. The plan here chains *phases*. The task is
data (``rhex_flip_drives``'s ``[task]``: phases ``push``, ``recirculate`` and ``land``,
``timing = "pump"``) and runs on the planning core (:func:`frcontrol.planning.core.plan_task`, the
path of ``frc plan`` and ``frc flip``): the core plans every push (the hip voltages that maximise
the pitch acceleration in the unambiguous set of the push's allowed modes) and
:mod:`frcontrol.planning.pump_timing` ends the phases and drives the legs between pushes. With
DC-motor drives (``[model.drives.JOINT]``, :mod:`frcontrol.drives`) the inputs are voltages within
``[-u_max, u_max]`` and the motors' electrical damping is in the bias, so the analysis is in voltage
space at the hips' speeds: the torque-speed line is the shape of every mode domain. This module
reads the run (:func:`simulate_pump`, :class:`PumpResult`): cycles, time to vertical, energy,
limits, the compliant check.

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

**Verification.** The run is one rigid simulation (velocity-level time stepping, inelastic impacts
by the impact law at landings). The same voltages, replayed against time, drive the compliant model
(Kelvin–Voigt contacts at the stiffness the speed-accuracy benchmark recommends for trajectories,
:data:`COMPLIANT_STIFFNESS`): the flip must survive both.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..drives import Drive, no_load_speed, stall_torque, torque_limits
from ..errors import SceneError
from ..jsonable import finite_or_none, to_jsonable
from ..modes import scene_mode
from ..scene import Scene
from ..simulation.compliant import CompliantSettings, simulate_compliant
from ..simulation.energy_audit import EnergyAudit, energy_audit
from ..simulation.samples import drive_samples
from ..simulation.trajectory import Trajectory
from .core.decision import decide
from .core.report import PlanResult, plan_task
from .core.task import read_task
from .core.tolerances import REPLAN_GAP_TOLERANCE
from .flip import FlipPlan, flip_task
from .flip_budget import FlipBudget, body_energy, energy_shortfall, flip_budget
from .flip_loop import body_contact_events
from .flip_run import first_plan, plan_only_document
from .pump_timing import (
    FALL_PITCH_RATE,
    RECIRCULATION_DAMPING,
    RECIRCULATION_GAIN,
    REST_SPEED,
    UPRIGHT_TOLERANCE,
    PumpPhase,
    PumpTiming,
    check_pump_scene,
    predicted_modes,
)

__all__ = [
    "COMPLIANT_EXTRA_TIME",
    "COMPLIANT_STIFFNESS",
    "FALL_PITCH_RATE",
    "LIMIT_TOLERANCE",
    "RECIRCULATION_DAMPING",
    "RECIRCULATION_GAIN",
    "REST_SPEED",
    "UPRIGHT_TOLERANCE",
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


def voltage_for_torque(drive: Drive, torque: float, joint_speed: float) -> float:
    """[V] The voltage giving ``torque`` [N m] at ``joint_speed`` [rad/s], within the voltage limit.

    The inverse of :func:`frcontrol.drives.joint_torque`: ``u = R torque / (eta N C_M) + C_E N qdot``.
    """
    gain = drive.efficiency * drive.ratio * drive.torque_constant / drive.resistance
    volts = torque / gain + drive.back_emf_constant * drive.ratio * joint_speed
    return float(np.clip(volts, -drive.voltage_limit, drive.voltage_limit))


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
        settle_time: [s] the land phase's ``until`` time: the longest the run goes on past vertical.
        plan: the first push's plan (the core's first decision).
        run: the core's run (its ``outcome`` and ``phases`` are the document's).
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
    settle_time: float | None = None
    plan: FlipPlan | None = None
    run: PlanResult | None = None

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
            "settle_time": self.settle_time, "rest_speed": REST_SPEED,
            "at_rest": self.phases[-1].ended_by == "at rest", "modes_check": self.modes_check(),
            "energy_audit": None if self.energy_audit is None else self.energy_audit.to_dict(),
        })


def simulate_pump(
    scene: Scene,
    *,
    dt: float = 1e-3,
    max_time: float | None = None,
    replan_every: int = 10,
    margin: float | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> PumpResult:
    """The scene's pump task run by the planning core, and read as a pumping flip.

    :func:`frcontrol.planning.core.plan_task` with the pump's timing
    (:class:`~frcontrol.planning.pump_timing.PumpTiming`): every ``replan_every`` steps the push is
    planned or the legs' loop chooses the voltages, held until the next decision.

    Args:
        scene: RHex on its back with a DC-motor drive on every input and the pump's ``[task]``.
        dt: [s] the time step.
        max_time: [s] the longest simulated time (None: the task's ``max_time``).
        replan_every: steps between two decisions, >= 1.
        margin: [V] the push plans' margin (None: the push phase's).
        progress: called with (simulated time, max_time) at every decision.

    Raises:
        InputError: a bad step, time or count.
        SceneError: an input without a drive, a ``[task]`` that is not the pump's.
    """
    check_pump_scene(scene)
    if read_task(scene).timing != "pump":
        raise SceneError(str(scene.path), "task.timing", 'the pumping flip is a task with timing = "pump" '
                         "(as rhex_flip_drives's)")
    run = plan_task(scene, dt=dt, replan_every=replan_every, max_time=max_time, margin=margin,
                    progress=progress)
    assert isinstance(run.timing, PumpTiming)
    return pump_result(scene, run, run.timing)


def pump_result(scene: Scene, run: PlanResult, timing: PumpTiming) -> PumpResult:
    """The pumping flip read from the core's run: cycles, vertical, energy, the phases' records."""
    task = flip_task(scene)
    trajectory = replace(run.trajectory, info={**run.trajectory.info, "source": "simulate_pump"})
    pitch = trajectory.q[:, task.pitch_index]
    reached = np.nonzero(pitch >= task.vertical)[0]
    crossed = int(reached[0]) if reached.size else None
    flipped = crossed is not None
    failure = trajectory.failure
    end_reason = ("at rest" if timing.at_rest(trajectory.v[-1]) else "the settling time's end") if flipped \
        else failure.reason if failure is not None else "the end of the run"
    phases = timing.phases_until(float(trajectory.times[-1]), end_reason)
    last = len(trajectory.times) - 1 if crossed is None else crossed
    separation, _ = body_contact_events(scene, trajectory, task.body_contacts, last)
    budget, energy = _budget(scene, trajectory)
    push = timing.phases["push"]
    names = tuple(c.name for c in scene.contacts)
    plans = tuple((t, None if d.mode is None else scene_mode(d.mode, d.contacts, names), d.reason)
                  for record in run.run.records if record.name == "push" for t, d in record.decisions)
    return PumpResult(
        trajectory=trajectory, drives=tuple(timing.drives), phases=phases, flipped=flipped,
        time_to_vertical=_crossing_time(trajectory.times, pitch, task.vertical, crossed),
        max_pitch=float(pitch.max()), vertical=task.vertical,
        cycle_max_pitch=_cycle_max(trajectory.times, pitch, phases),
        energy_drawn=energy_drawn(scene, trajectory), body_contact_kept=separation is None,
        plans=plans,
        reason=None if flipped else _why_not(trajectory, pitch, task.vertical, run.run.max_time) + (
            "" if budget is None else f"; {energy_shortfall(budget, energy)}"),
        dt=run.run.dt, max_time=run.run.max_time, margin=float(push.margin),
        timings={"planning": run.timings["planning"], "simulation": run.timings["simulation"],
                 "total": run.timings["total"]},
        budget=budget, cycle_max_energy=_cycle_max(trajectory.times, energy, phases) if energy.size else (),
        energy_audit=energy_audit(scene, trajectory), final_pitch=float(pitch[-1]), contacts=names,
        settle_time=timing.phases["land"].until.time,
        plan=first_plan(scene, task, run.run.records[0].decisions[0][1]), run=run,
    )


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
    run = simulate_compliant(scene, held, settings=CompliantSettings(stiffness=stiffness, contacts="all"),
                             duration=max(duration, dt), dt=dt)
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


def pump_flip(scene: Scene, *, margin: float | None = None, max_time: float | None = None, dt: float = 1e-3,
              replan_every: int = 10, compliant: bool = False,
              progress: Callable[[float, float], None] | None = None
              ) -> tuple[FlipPlan, PumpResult | dict[str, Any]]:
    """The first push's plan at the scene's state and, unless ``max_time`` is 0, the pumping run.

    The first plan is the core's first decision of the push (the run's own, or made alone when
    nothing is simulated: then the second item is the ``outcome`` and ``phases`` of that decision).
    ``compliant`` adds :func:`verify_compliant` to the result, replayed to the rigid run's end.

    Raises:
        InputError, SceneError: see :func:`simulate_pump`.
    """
    check_pump_scene(scene)
    task = flip_task(scene)
    if max_time is not None and max_time <= 0:
        timing = PumpTiming(scene, read_task(scene))
        push = timing.phases["push"]
        push = push if margin is None else replace(push, margin=margin)
        decision = decide(replace(scene, gap_tolerance=REPLAN_GAP_TOLERANCE), push, free=timing.free(push))
        return first_plan(scene, task, decision), plan_only_document(scene, push, decision)
    result = simulate_pump(scene, dt=dt, max_time=max_time, replan_every=replan_every, margin=margin,
                           progress=progress)
    if compliant:
        result = replace(result, compliant=verify_compliant(scene, result, to_end=True))
    assert result.plan is not None  # the run's first decision is a push's
    return result.plan, result


def pump_payload(scene: Scene, plan: FlipPlan, result: PumpResult | Mapping[str, Any]) -> dict[str, Any]:
    """The ``frc flip --json`` document of the pumping flip.

    The flip's keys (its first push's plan: ``torques`` are then the inputs' values, voltages for
    driven joints, ``input_units`` says), ``outcome`` and ``phases`` as ``frc plan`` has them,
    ``simulation`` from the pumping run with ``samples`` (:func:`pump_samples`), and ``pump``
    (:meth:`PumpResult.to_dict`). ``result``: the run, or (nothing simulated) the document of the
    first decision alone.
    """
    payload = plan.to_dict()
    payload["input_units"] = scene.inputs.unit_map()
    if not isinstance(result, PumpResult):
        payload.update(outcome=result["outcome"], phases=result["phases"])
        return payload
    if result.run is not None:
        document = result.run.to_dict(scene)
        payload.update(outcome=document["outcome"], phases=document["phases"])
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
