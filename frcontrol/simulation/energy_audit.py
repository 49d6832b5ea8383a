r"""Where a rigid run's energy comes from and where it goes: an audit from its samples.

The robot's mechanical energy (the rigid stepper's ``info["energy"]``) is
``E = 1/2 v^T M v + V(q) + sum 1/2 k (q_j - rest)^2``: kinetic (the rotors' reflected inertia and
any armature included), gravity's potential and the joint springs' elastic energy. The stepper
(:mod:`.rigid`) advances ``(M + h D)(v+ - v) = h (G u - D v - h(q, v)) + J^T p`` with the drives'
damping ``D`` taken at the step's end, so over a step the kinetic energy changes by exactly::

    1/2 v+^T M v+ - 1/2 v^T M v = h tau . v+ + p . J v+ - h h(q, v) . v+ - 1/2 |v+ - v|_M^2

with ``tau = G u - D v+`` the drives' joint torques. The audit sums, step by step, every term
(energies [J]; a loss is negative):

- ``drawn``: ``sum u i h``, the electrical energy from the supplies (negative when braking returns
  more than the motors take);
- ``resistance``: ``-sum i^2 R h``, heat in the windings (R of each drive);
- ``conversion``: ``-sum (u i - i^2 R - tau qdot) h``, what the gearheads' efficiency keeps from
  the joints (and, where the motor's torque and back-EMF constants differ, their mismatch);
- ``spring_damping``: ``sum f_d . v+ h`` with ``f_d = -c v`` the springs' dampers at the step's start;
- ``slip``: ``sum p_T . J_T v+``, the friction impulses' work on sliding contacts (Coulomb: <= 0);
- ``contact_normal``: ``sum p_N . J_N v+``, the normal impulses' work outside impacts (0 up to
  the gap stabilisation);
- ``landings``: the kinetic energy each impact took (``kinetic_energy_after - _before`` of the
  impact law's records);
- ``time_stepping``: ``-1/2 |v+ - v|_M^2`` over the steps without an impact, the implicit step's
  own dissipation;
- ``stored_in_springs``: the springs' elastic energy at the end less at the start (part of the
  change, reported beside it).

Then ``change = E(end) - E(start)`` [J] is measured, and ``residual = change - (drawn + resistance
+ conversion + spring_damping + slip + contact_normal + landings + time_stepping)``: the
time-stepping error of the potentials (gravity's and the springs' forces are taken at the step's
start, ``V`` at its end) and of ``M(q)`` changing along the step. ``closes`` says whether
``|residual| <= AUDIT_TOLERANCE x scale`` with ``scale`` the largest term's magnitude.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..scene import Scene
from .armature import massless_armature
from .samples import drive_samples
from .trajectory import Trajectory

__all__ = ["AUDIT_TERMS", "AUDIT_TOLERANCE", "EnergyAudit", "energy_audit"]

AUDIT_TOLERANCE = 0.01
"""[-] The audit closes when its residual [J] is at most this fraction of its largest term's
magnitude (the energy drawn, in a driven run)."""

AUDIT_TERMS = ("drawn", "resistance", "conversion", "spring_damping", "slip", "contact_normal",
               "landings", "time_stepping")
"""The audited terms [J], in the order they are reported; their sum plus the residual is the change."""


@dataclass(frozen=True)
class EnergyAudit:
    """A rigid run's energy audit (module docstring).

    Attributes:
        times: [s] the samples' times, (T,).
        cumulative: per term of :data:`AUDIT_TERMS`, its running sum [J] at each sample, (T,).
        mechanical: [J] the robot's mechanical energy at each sample, (T,).
        spring_energy: [J] the joint springs' elastic energy at each sample, (T,).
        tolerance: :data:`AUDIT_TOLERANCE`.
    """

    times: np.ndarray
    cumulative: Mapping[str, np.ndarray]
    mechanical: np.ndarray
    spring_energy: np.ndarray
    tolerance: float = AUDIT_TOLERANCE

    @property
    def terms(self) -> dict[str, float]:
        """Each term's total [J] over the run."""
        return {name: float(series[-1]) for name, series in self.cumulative.items()}

    @property
    def change(self) -> float:
        """[J] The mechanical energy at the end less at the start."""
        return float(self.mechanical[-1] - self.mechanical[0])

    @property
    def residual(self) -> float:
        """[J] The change less the sum of the terms."""
        return self.change - sum(self.terms.values())

    @property
    def scale(self) -> float:
        """[J] The largest term's magnitude (the residual's yardstick)."""
        return max((abs(x) for x in self.terms.values()), default=0.0)

    @property
    def closes(self) -> bool:
        """``|residual| <= tolerance x scale``."""
        return abs(self.residual) <= self.tolerance * self.scale

    def to_dict(self) -> dict[str, Any]:
        """As JSON: the terms, ``stored_in_springs``, ``change``, ``residual`` [J], and more.

        Also ``relative_residual`` (``|residual| / scale``), ``tolerance`` and ``closes``.
        """
        scale = self.scale
        return {**self.terms, "stored_in_springs": float(self.spring_energy[-1] - self.spring_energy[0]),
                "change": self.change, "residual": self.residual,
                "relative_residual": abs(self.residual) / scale if scale > 0 else 0.0,
                "tolerance": self.tolerance, "closes": self.closes}


def _drive_terms(scene: Scene, trajectory: Trajectory, h: np.ndarray) -> dict[str, np.ndarray]:
    """Per step (T-1,): ``drawn``, ``resistance`` and ``conversion`` [J] of every drive together."""
    drawn, heat, joint = np.zeros(len(h)), np.zeros(len(h)), np.zeros(len(h))
    for name, table in drive_samples(scene, trajectory).items():
        drive = scene.drives[name]
        speed = trajectory.v[1:, scene.coordinate_names.index(name)]
        current = table["current"][1:]
        drawn += table["voltage"][1:] * current * h
        heat += drive.resistance * current**2 * h
        joint += table["torque"][1:] * speed * h
    return {"drawn": drawn, "resistance": -heat, "conversion": -(drawn - heat - joint)}


def _step_terms(scene: Scene, trajectory: Trajectory, h: np.ndarray) -> dict[str, np.ndarray]:
    """Per step (T-1,): the springs' dampers, slip, normal work and the implicit step's dissipation."""
    robot, springs = scene.robot, scene.robot.springs
    q, v = trajectory.q, trajectory.v
    forces = np.asarray(trajectory.contact_forces, dtype=float)
    impacts = np.asarray(trajectory.info.get("impact_impulses", np.zeros_like(forces)), dtype=float)
    armature = massless_armature(scene, robot.mass_matrix(q[0]), scene.model.armature)
    steps = len(h)
    damper, slip, normal, stepping = (np.zeros(steps) for _ in range(4))
    for k in range(steps):
        state = robot.state(q[k], v[k])
        p = forces[k + 1] * h[k] - impacts[k + 1]
        slip[k] = float(p[:, 1] @ (state.jacobian_tangent @ v[k + 1]))
        normal[k] = float(p[:, 0] @ (state.jacobian_normal @ v[k + 1]))
        if springs:
            rates = v[k, springs.indices] * v[k + 1, springs.indices]
            damper[k] = -h[k] * float(np.sum(springs.damping * rates))
        if not np.any(impacts[k + 1]):
            jump = v[k + 1] - v[k]
            stepping[k] = -0.5 * float(jump @ armature.apply(state.mass_matrix) @ jump)
    return {"spring_damping": damper, "slip": slip, "contact_normal": normal, "time_stepping": stepping}


def energy_audit(scene: Scene, trajectory: Trajectory) -> EnergyAudit:
    """The audit of a rigid run (:class:`~.rigid.RigidStepper`'s trajectory) of ``scene``.

    Each step k (from sample k-1 to k) is read from the samples: the voltage held over it and the
    current, torque and velocity at its end, the contact impulses it recorded (``contact_forces``
    times its length, less ``info["impact_impulses"]``), the Jacobians at its start, and the impact
    law's records (``info["impacts"]``) for the landings.
    """
    times = np.asarray(trajectory.times, dtype=float)
    h = np.diff(times)
    per_step = {**_drive_terms(scene, trajectory, h), **_step_terms(scene, trajectory, h)}
    landing = np.zeros(len(h))
    for record in trajectory.info.get("impacts", []):
        k = min(max(int(np.searchsorted(times, record["time"] - 1e-12)) - 1, 0), len(h) - 1)
        landing[k] += record["kinetic_energy_after"] - record["kinetic_energy_before"]
    per_step["landings"] = landing
    cumulative = {name: np.concatenate([[0.0], np.cumsum(per_step[name])]) for name in AUDIT_TERMS}
    springs = np.asarray(trajectory.info.get("spring_energy", np.zeros(len(times))), dtype=float)
    return EnergyAudit(times, cumulative, np.asarray(trajectory.info["energy"], dtype=float), springs)
