r"""Per-sample series of a motion, computed from its scene: contact modes and the drives' quantities.

Contact modes
-------------
:func:`sample_modes` names each sample's motion with one letter per scene contact (S, L, R, F),
from the sample's normal force and the contact point's tangential velocity:

- **S** when the normal force is at most ``force_tolerance`` times the robot's weight (1 N
  without gravity);
- else **F** when ``|v_T| <= slip_tolerance`` [m/s], **R** when ``v_T > slip_tolerance`` (along
  +t) and **L** when ``v_T < -slip_tolerance``.

The defaults are :data:`CONTACT_FORCE_TOLERANCE` and :data:`SLIP_VELOCITY_TOLERANCE`, which the
rigid stepper uses too.

Drives
------
:func:`drive_samples` reads, per sample, each drive's::

    voltage u [V]            the input
    motor_speed w_m [rad/s]  the rotor's: N qdot (rigid), rho_0 theta_0' (elastic)
    current i [A]            (u - C_E w_m) / R
    torque tau [N m]         at the joint: eta N C_M i (rigid), eta_e rho_e S_{e-1} (elastic)

and :func:`stage_samples` each stage's deflection [rad] (the spring's twist ``delta``; 0 for a
rigid stage).

A :class:`~.trajectory.Trajectory` reports these series (:meth:`~.trajectory.Trajectory.to_dict`
with its scene), so this module sits below it and reads a trajectory's arrays only.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..drives import motor_current
from ..modes import contact_mode_letter
from ..scene import Scene
from .transmissions import Transmissions

if TYPE_CHECKING:
    from .trajectory import Trajectory

__all__ = [
    "CONTACT_FORCE_TOLERANCE",
    "DRIVE_SAMPLE_NAMES",
    "SLIP_VELOCITY_TOLERANCE",
    "drive_arrays",
    "drive_samples",
    "sample_modes",
    "stage_samples",
]

SLIP_VELOCITY_TOLERANCE = 1e-6
"""[m/s] A loaded contact with |v_T| at most this after the step sticks; above, it slips."""

CONTACT_FORCE_TOLERANCE = 1e-9
"""[-] A contact carries force when its impulse / h exceeds this times the force scale
(the robot's weight, or 1 N without gravity)."""


def _weight(scene: Scene) -> float:
    """The robot's weight [N] (1 N without gravity): the scale of the contact-force threshold."""
    return scene.robot.weight_scale()


def sample_modes(scene: Scene, trajectory: Trajectory, *, slip_tolerance: float = SLIP_VELOCITY_TOLERANCE,
                 force_tolerance: float = CONTACT_FORCE_TOLERANCE) -> tuple[str, ...]:
    """Per sample, one letter per scene contact: S (no load), F, R or L (module docstring)."""
    robot = scene.robot
    threshold = force_tolerance * _weight(scene)
    indices = list(range(len(scene.contacts)))
    out = []
    for q, v, forces in zip(trajectory.q, trajectory.v, trajectory.contact_forces, strict=True):
        vt = robot.state(q, v, indices).tangential_velocities
        out.append("".join(contact_mode_letter(forces[i, 0], vt[i], threshold, slip_tolerance)
                           for i in indices))
    return tuple(out)


DRIVE_SAMPLE_NAMES = ("voltage", "current", "motor_speed", "torque")
"""The per-sample series of each drive, as ``samples["drives"][JOINT]`` names them."""


def _elastic_reports(scene: Scene, trajectory: Trajectory) -> list[dict[str, dict[str, Any]]]:
    """Per sample, :meth:`Transmissions.report` (empty dicts without elastic drives)."""
    record = trajectory.info.get("transmissions")
    T = len(trajectory.times)
    if record is None:
        return [{} for _ in range(T)]
    model = Transmissions(scene)
    inputs = np.asarray(trajectory.inputs, dtype=float).reshape(T, -1)
    states = np.asarray(record["state"], dtype=float)
    return [model.report(trajectory.q[j], trajectory.v[j], states[j], inputs[j]) for j in range(T)]


def drive_samples(scene: Scene, trajectory: Trajectory) -> dict[str, dict[str, np.ndarray]]:
    """Each drive's voltage [V], current [A], motor speed [rad/s] and joint torque [N m] per sample.

    Returns:
        ``{JOINT: {"voltage": (T,), "current": (T,), "motor_speed": (T,), "torque": (T,)}}``, empty
        for a scene without drives.
    """
    out: dict[str, dict[str, np.ndarray]] = {}
    inputs = np.asarray(trajectory.inputs, dtype=float).reshape(len(trajectory.times), -1)
    v = np.asarray(trajectory.v, dtype=float)
    elastic = _elastic_reports(scene, trajectory) if any(d.elastic for d in scene.drives.values()) else []
    for joint, drive in scene.drives.items():
        voltage = inputs[:, list(trajectory.input_names).index(joint)]
        if drive.elastic:
            speed = np.array([r[joint]["motor_speed"] for r in elastic])
            torque = np.array([r[joint]["torque"] for r in elastic])
            current = motor_current(drive, voltage, speed)
        else:
            speed = drive.ratio * v[:, scene.coordinate_names.index(joint)]
            current = motor_current(drive, voltage, speed)
            torque = drive.efficiency * drive.ratio * drive.torque_constant * current
        out[joint] = {"voltage": voltage, "current": current, "motor_speed": speed, "torque": torque}
    return out


def stage_samples(scene: Scene, trajectory: Trajectory) -> dict[str, dict[str, np.ndarray]]:
    """Each elastic drive's stage deflections [rad] and their rates [rad/s] per sample.

    ``{JOINT: {"deflection": (T, p), "deflection_rate": (T, p)}}``: one column per stage of the
    drive, in the scene's order; a rigid stage's column is 0.
    """
    elastic = _elastic_reports(scene, trajectory)
    names = ("deflection", "deflection_rate")
    return {joint: {name: np.array([r[joint][name] for r in elastic]) for name in names}
            for joint, drive in scene.drives.items() if drive.elastic}


def drive_arrays(scene: Scene, trajectory: Trajectory) -> dict[str, Any]:
    """The drives' and stages' samples flat, by dotted name, for ``--out``.

    ``drives.JOINT.current`` (T,) and the like; ``stages.JOINT.deflection`` (T, p).
    """
    out = {f"drives.{joint}.{name}": series
           for joint, table in drive_samples(scene, trajectory).items() for name, series in table.items()}
    stages = stage_samples(scene, trajectory)
    out.update({f"stages.{joint}.{name}": series for joint, table in stages.items()
                for name, series in table.items()})
    return out
