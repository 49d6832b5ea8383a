r"""Whether a simulated run stayed inside its model's validity, checked on every run.

A simulator can finish ("completed") on a run that has left the model behind: a constant torque
on a nearly massless leg spins it at 30,000 rad/s, its toe strikes the ground at hundreds of m/s
and sinks centimetres into a 1e5 N/m contact. :func:`assess` checks every sample of a trajectory
against four documented limits, all derived from the scene:

- **Non-finite state** (NaN or infinity in ``q``, ``v``, the forces or the energy): the run
  *diverged*.
- **Energy.** With ``E`` the mechanical energy (kinetic + gravitational, + elastic for the
  compliant model), ``W(t)`` the work of the inputs (generalized forces ``S^T u`` along ``v``,
  trapezoidal rule) and, for the rigid stepper, the work of its penetration stabilization,
  contacts and dampers only remove energy, so the *excess* ``E(t) - E(0) - W(t)`` must stay below

  .. math:: \epsilon_E \left(\max_{s \le t} |E(s) - E(0)| + A(t)\right) + \epsilon_0\, m g L,

  where ``A(t)`` is the work of the inputs in absolute value, ``m`` the robot's mass, ``L`` the
  scene's length below, :math:`\epsilon_E` = :data:`ENERGY_TOLERANCE` and :math:`\epsilon_0` =
  :data:`ENERGY_FLOOR`. Beyond :data:`DIVERGENCE_FACTOR` times
  :math:`|E(0)| + A(t) + m g L` the energy came from nowhere: the run *diverged* (a blow-up).
  Between the two: a warning.
- **Penetration.** Compliant: at most :data:`PENETRATION_FACTOR` times the static deflection
  ``F / k`` of the softest contact under the load ``F = m g + max_t |u(t)|_inf / min(1, L)``
  (forces [N]; torques [N m] over the length). Rigid: at most one step at the free-fall speed,
  ``sqrt(2 g L) dt``, plus the gap tolerance.
- **Speed of every contact point** (finite differences of the samples): at most
  :data:`SPEED_FACTOR` times the free-fall speed over the scene, ``sqrt(2 g L)`` (at least
  :data:`MIN_REFERENCE_SPEED`).

``L`` is the scene's length: the largest distance between the base's origin and the contact
points at the initial state (at least :data:`MIN_LENGTH`).

A divergence ends the run at the last sample before it (``status = "diverged"``, ``failure``
with the time, the reason and a hint); every other violation is a :class:`SimulationWarning`
(time, kind, detail), the first of each kind. The limits used are reported in
``info["validity"]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..scene import Scene
from .trajectory import SimulationFailure, SimulationWarning, Trajectory, WarningKind

__all__ = [
    "DIVERGENCE_FACTOR",
    "ENERGY_FLOOR",
    "ENERGY_TOLERANCE",
    "MIN_LENGTH",
    "MIN_REFERENCE_SPEED",
    "PENETRATION_FACTOR",
    "SPEED_FACTOR",
    "ValidityLimits",
    "assess",
    "validity_limits",
]

ENERGY_TOLERANCE = 0.05
"""[-] Relative energy excess (beyond the inputs' work) tolerated before a warning: integrators and
time steppers are not exactly energy-consistent."""

ENERGY_FLOOR = 1e-3
"""[-] Absolute energy excess tolerated, as a fraction of ``m g L`` [J]."""

DIVERGENCE_FACTOR = 10.0
"""[-] An energy excess above this times ``|E(0)| + A(t) + m g L`` is a blow-up: the run diverged."""

PENETRATION_FACTOR = 10.0
"""[-] A compliant contact may sink this many times its static deflection under the load."""

SPEED_FACTOR = 10.0
"""[-] A contact point may move at this many times the free-fall speed over the scene."""

MIN_LENGTH = 0.01
"""[m] Least length ``L`` of a scene (a single contact at the base's origin)."""

MIN_REFERENCE_SPEED = 0.1
"""[m/s] Least reference speed (a scene without gravity)."""

HINT = ("try a smaller --dt, or the compliant model's stiff integrator (--integrator radau) or a "
        "softer contact (--stiffness)")
"""What a diverged run suggests to the user."""


@dataclass(frozen=True)
class ValidityLimits:
    """The limits a run was checked against (reported in ``info["validity"]``).

    Attributes:
        length: ``L`` [m], the scene's length.
        mass: ``m`` [kg], the robot's mass.
        energy_scale: ``m g L`` [J].
        max_speed: [m/s] of a contact point.
        max_penetration: [m].
        energy_tolerance: :data:`ENERGY_TOLERANCE` [-].
        divergence_factor: :data:`DIVERGENCE_FACTOR` [-].
    """

    length: float
    mass: float
    energy_scale: float
    max_speed: float
    max_penetration: float
    energy_tolerance: float = ENERGY_TOLERANCE
    divergence_factor: float = DIVERGENCE_FACTOR

    def report(self) -> dict[str, float]:
        """The limits as a JSON-ready dict."""
        return {"length": self.length, "mass": self.mass, "energy_scale": self.energy_scale,
                "max_speed": self.max_speed, "max_penetration": self.max_penetration,
                "energy_tolerance": self.energy_tolerance, "divergence_factor": self.divergence_factor}


def validity_limits(
    scene: Scene, trajectory: Trajectory, *, stiffness: float | None, dt: float
) -> ValidityLimits:
    """The limits of one run (module docstring).

    Args:
        scene: the simulated scene.
        trajectory: the run (its inputs set the load).
        stiffness: [N/m] the softest normal contact stiffness (compliant), or None (rigid).
        dt: [s] the time step (rigid) or sample interval.
    """
    robot = scene.robot
    q0 = trajectory.q[0] if len(trajectory.q) else scene.q
    points = robot.contact_points_in_world(q0).reshape(-1, 2)
    origin = q0[:2] if robot.base == "planar" else np.zeros(2)
    cloud = np.vstack([origin[None, :], points])
    spread = float(np.max(np.linalg.norm(cloud[:, None, :] - cloud[None, :, :], axis=2)))
    length = max(MIN_LENGTH, spread)
    mass = float(sum(inertia.mass for inertia in robot.model.inertias))
    g = robot.gravity
    energy_scale = max(mass * g * length, 1e-12)
    v_ref = max(math.sqrt(2.0 * g * length), MIN_REFERENCE_SPEED)
    if stiffness is not None:
        u_max = float(np.max(np.abs(trajectory.inputs))) if trajectory.inputs.size else 0.0
        load = mass * g + u_max / min(1.0, length)
        max_penetration = PENETRATION_FACTOR * load / stiffness + scene.gap_tolerance
    else:
        max_penetration = v_ref * dt + scene.gap_tolerance
    return ValidityLimits(length, mass, energy_scale, SPEED_FACTOR * v_ref, max_penetration)


def _input_work(scene: Scene, trajectory: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """Cumulative work of the inputs ``W`` and its absolute counterpart ``A`` [J], per sample."""
    T = len(trajectory.times)
    if T < 2 or not trajectory.inputs.size:
        return np.zeros(T), np.zeros(T)
    forces = trajectory.inputs @ scene.inputs.selection_transpose(scene.robot.nv).T  # (T, n)
    v_mid = 0.5 * (trajectory.v[1:] + trajectory.v[:-1])
    power_dt = np.einsum("ij,ij->i", forces[1:], v_mid) * np.diff(trajectory.times)
    return (np.concatenate([[0.0], np.cumsum(power_dt)]),
            np.concatenate([[0.0], np.cumsum(np.abs(power_dt))]))


def _first(mask: np.ndarray) -> int | None:
    hits = np.flatnonzero(mask)
    return int(hits[0]) if hits.size else None


def _warnings(trajectory: Trajectory, limits: ValidityLimits, energy: np.ndarray, penetration: np.ndarray,
              work: np.ndarray, excess: np.ndarray, allowed: np.ndarray, finite: np.ndarray,
              end: int) -> list[SimulationWarning]:
    """The first energy, penetration and speed violation before sample ``end``, in time order."""
    times = trajectory.times
    T = len(times)
    warnings: list[SimulationWarning] = []

    def warn(index: int | None, kind: WarningKind, detail: str) -> None:
        if index is not None and index < end:
            warnings.append(SimulationWarning(float(times[index]), kind, detail))

    with np.errstate(invalid="ignore"):
        i = _first((excess > allowed) & finite)
    if i is not None and i < end:
        warn(i, "energy", f"the energy rose {excess[i]:.4g} J beyond the inputs' work ({work[i]:.4g} J); "
             f"tolerated {allowed[i]:.4g} J")
    i = _first(penetration > limits.max_penetration)
    if i is not None and i < end:
        deepest = int(np.nanargmax(np.where(np.isfinite(penetration[:end]), penetration[:end], -np.inf)))
        warn(i, "penetration", f"a contact sank {penetration[deepest] * 100:.3g} cm (at t = "
             f"{times[deepest]:.4g} s), beyond {limits.max_penetration * 100:.3g} cm")
    if T >= 2 and trajectory.contact_points.size:
        step = np.diff(trajectory.contact_points, axis=0) / np.diff(times)[:, None, None]
        speed = np.linalg.norm(step, axis=2)  # (T-1, k)
        fastest = np.max(np.where(np.isfinite(speed), speed, 0.0), axis=1)
        i = _first(fastest > limits.max_speed)
        if i is not None and i + 1 < end:
            top = int(np.argmax(fastest[: end - 1]))
            contact = trajectory.contacts[int(np.argmax(speed[top]))]
            warn(i + 1, "speed", f"contact {contact!r} moved at {fastest[top]:.4g} m/s (at t = "
                 f"{times[top + 1]:.4g} s), beyond {limits.max_speed:.4g} m/s, {SPEED_FACTOR:g} x "
                 f"the free-fall speed over the scene's {limits.length:.3g} m")
    warnings.sort(key=lambda w: w.time)
    return warnings


def assess(
    scene: Scene,
    trajectory: Trajectory,
    *,
    energy: np.ndarray,
    penetration: np.ndarray,
    stiffness: float | None,
    dt: float,
    extra_work: np.ndarray | None = None,
) -> Trajectory:
    """Check a finished run against the limits; cut it at a divergence and attach the warnings.

    Args:
        scene: the simulated scene.
        trajectory: the run as the simulator produced it.
        energy: [J] mechanical energy per sample (with the springs' for the compliant model).
        penetration: [m] the deepest penetration per sample.
        stiffness: [N/m] the softest normal contact stiffness (compliant) or None (rigid).
        dt: [s] the time step or sample interval.
        extra_work: [J] cumulative work of other sources per sample (the rigid stepper's
            stabilization), counted like the inputs'.

    Returns:
        The trajectory with ``warnings``, ``info["validity"]`` and, if it diverged, cut at the
        last good sample with ``status = "diverged"`` and a ``failure``.
    """
    limits = validity_limits(scene, trajectory, stiffness=stiffness, dt=dt)
    times = trajectory.times
    T = len(times)
    energy = np.asarray(energy, dtype=float)[:T]
    penetration = np.asarray(penetration, dtype=float)[:T]
    work, absolute = _input_work(scene, trajectory)
    if extra_work is not None:
        extra = np.asarray(extra_work, dtype=float)[:T]
        work, absolute = work + extra, absolute + np.abs(extra)

    finite = (np.all(np.isfinite(trajectory.q.reshape(T, -1)), axis=1)
              & np.all(np.isfinite(trajectory.v.reshape(T, -1)), axis=1)
              & np.all(np.isfinite(trajectory.contact_forces.reshape(T, -1)), axis=1)
              & np.isfinite(energy))
    with np.errstate(invalid="ignore"):
        change = energy - energy[0]
        excess = change - work
        swing = np.maximum.accumulate(np.where(np.isfinite(change), np.abs(change), 0.0))
        allowed = ENERGY_TOLERANCE * (swing + absolute) + ENERGY_FLOOR * limits.energy_scale
        blow_up = excess > DIVERGENCE_FACTOR * (abs(energy[0]) + absolute + limits.energy_scale)

    info: dict[str, Any] = dict(trajectory.info)
    info["validity"] = limits.report()
    info["input_work"] = work
    bad, reason = _divergence(finite, blow_up, energy, work)
    end = T if bad is None else max(bad, 1)
    warnings = _warnings(trajectory, limits, energy, penetration, work, excess, allowed, finite, end)
    if bad is None:
        return replace(trajectory, info=info, warnings=tuple(warnings))
    return _cut(trajectory, info, tuple(warnings), end, SimulationFailure(float(times[bad]), reason, HINT))


def _divergence(finite: np.ndarray, blow_up: np.ndarray, energy: np.ndarray, work: np.ndarray
                ) -> tuple[int | None, str]:
    """The first diverged sample (a non-finite state first, else an energy blow-up) and why."""
    bad = _first(~finite)
    if bad is not None:
        return bad, "the state became NaN or infinite"
    bad = _first(blow_up)
    if bad is None:
        return None, ""
    return bad, (f"energy blow-up: {energy[bad]:.6g} J from {energy[0]:.6g} J with {work[bad]:.6g} J of "
                 f"input work (more than {DIVERGENCE_FACTOR:g} x the run's energy scale)")


def _cut_series(info: dict[str, Any], count: int, end: int) -> dict[str, Any]:
    """``info`` with every per-sample array (``count`` rows), nested ones included, cut at ``end``."""
    out: dict[str, Any] = {}
    for key, value in info.items():
        if isinstance(value, np.ndarray) and value.shape[:1] == (count,):
            value = value[:end]
        elif isinstance(value, dict):  # the contact zones' and the transmissions' series
            value = _cut_series(value, count, end)
        out[key] = value
    return out


def _cut(trajectory: Trajectory, info: dict[str, Any], warnings: tuple[SimulationWarning, ...], end: int,
         failure: SimulationFailure) -> Trajectory:
    """The run up to sample ``end`` (excluded), diverged: every per-sample array of ``info`` cut too."""
    info = _cut_series(info, len(trajectory.times), end)
    times = trajectory.times
    return replace(
        trajectory, times=times[:end], q=trajectory.q[:end], v=trajectory.v[:end],
        inputs=trajectory.inputs[:end], contact_forces=trajectory.contact_forces[:end],
        contact_points=trajectory.contact_points[:end],
        events=tuple(e for e in trajectory.events if e.time <= times[end - 1]),
        modes=None if trajectory.modes is None else trajectory.modes[:end],
        info=info, warnings=warnings, status="diverged", failure=failure)
