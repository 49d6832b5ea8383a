r"""Drives in a simulation: what each DC motor does along a trajectory.

A drive with rigid stages adds no state: its reflected inertia is in ``M``, its electrical damping
in the bias and its voltage gain in ``S^T`` (:mod:`frcontrol.drives`), so both simulators run it
unchanged. :func:`drive_samples` then reads, per sample, each drive's::

    voltage u [V]            the input
    motor_speed w_m [rad/s]  N qdot (rotor side)
    current i [A]            (u - C_E w_m) / R
    torque tau [N m]         eta N C_M i, at the joint
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..drives import motor_current
from ..scene import Scene
from .trajectory import Trajectory

DRIVE_SAMPLE_NAMES = ("voltage", "current", "motor_speed", "torque")
"""The per-sample series of each drive, as ``samples["drives"][JOINT]`` names them."""


def drive_samples(scene: Scene, trajectory: Trajectory) -> dict[str, dict[str, np.ndarray]]:
    """Each drive's voltage [V], current [A], motor speed [rad/s] and joint torque [N m] per sample.

    Returns:
        ``{JOINT: {"voltage": (T,), "current": (T,), "motor_speed": (T,), "torque": (T,)}}``, empty
        for a scene without drives.
    """
    out: dict[str, dict[str, np.ndarray]] = {}
    inputs = np.asarray(trajectory.inputs, dtype=float).reshape(len(trajectory.times), -1)
    v = np.asarray(trajectory.v, dtype=float)
    for joint, drive in scene.drives.items():
        voltage = inputs[:, list(trajectory.input_names).index(joint)]
        speed = drive.ratio * v[:, scene.coordinate_names.index(joint)]
        current = motor_current(drive, voltage, speed)
        torque = drive.efficiency * drive.ratio * drive.torque_constant * current
        out[joint] = {"voltage": voltage, "current": current, "motor_speed": speed, "torque": torque}
    return out


def drive_arrays(scene: Scene, trajectory: Trajectory) -> dict[str, Any]:
    """The drives' samples flat, by dotted name (``drives.JOINT.current``), for ``--out``."""
    return {f"drives.{joint}.{name}": series
            for joint, table in drive_samples(scene, trajectory).items() for name, series in table.items()}


__all__ = ["DRIVE_SAMPLE_NAMES", "drive_arrays", "drive_samples"]
