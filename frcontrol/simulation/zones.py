r"""Contact zones of the compliant model: lumped contact elastodynamics (V-P 1999, §5, Fig. 6).

Vukobratović and Potkonjak (1999), section 5.

A contact's ``[model.contacts.NAME] zone`` chooses how the compliant model deforms it along its
normal (V-P neglect the coupling between directions; the tangential direction keeps the
spring-damper and Coulomb slider of :mod:`.compliant`):

- ``"compliant"`` (Fig. 6c, the massless simplification): the Kelvin–Voigt law of :mod:`.compliant`.
- ``"one_stage"`` (Fig. 6b): a contact mass ``m'_r`` [kg] on the robot's point through the internal
  spring-damper ``(k''_r, b''_r)``, against a rigid surface: no external deformation.
- ``"two_stage"`` (Fig. 6a, Figs. 4-5): on each side a contact mass (``m'_r``, ``m'_e``) on its
  internal spring-damper (``k''_r, b''_r`` to the robot's point, ``k''_e, b''_e`` to the fixed
  surface), and between the two masses the external deformation: the two external spring-dampers
  ``(k'_r, b'_r)`` and ``(k'_e, b'_e)`` in series, which touch only when pressed (unilateral).
- ``"rigid"``: no deformation; only the rigid model (:mod:`.rigid`) simulates it.

Coordinates: heights along the contact's normal ``n`` above the undeformed surface. The robot's
point is at ``s = phi(q)`` (the gap), moving at ``ds/dt = v_N``. The robot-side mass is at ``y_r``
(velocity ``w_r``), neutral at ``y_r = s``; the environment-side mass at ``y_e <= 0`` (``w_e``),
neutral at 0. The deformations (positive when compressed) and forces, with ``g_n = g . n`` the
gravity along the normal [m/s^2]::

    internal, robot side:        c_r = y_r - s          F_r = k''_r c_r + b''_r dc_r/dt   (on the robot, +n)
    internal, environment side:  c_e = -y_e             F_e = k''_e c_e + b''_e dc_e/dt
    external (two-stage):        x' = y_e - y_r         F   = max(0, k' x' + b' dx'/dt) if x' > 0, else 0
    two-stage masses:            m'_r dw_r/dt = F - F_r + m'_r g_n,      m'_e dw_e/dt = F_e - F

with ``k' = k'_r k'_e / (k'_r + k'_e)`` and ``b' = b'_r b'_e / (b'_r + b'_e)`` (0 if either is 0):
two Kelvin–Voigt elements in series with no mass between them act as one, exactly when their time
constants ``b/k`` agree (V-P count the external deformation as one degree of freedom). The
robot-side mass feels gravity (it moves with the robot: with V-P's relative accelerations it
would need the point's acceleration); the environment-side one rests on a surface in equilibrium
with its weight at zero deformation, as V-P assume.

One stage: the mass touches the rigid surface at ``y_r = 0``. It is *pinned* while
``y_r <= 0``, ``w_r <= 0`` and its load pushes it down (``F_r - m'_r g_n >= 0``): then
``dy_r/dt = dw_r/dt = 0`` and the surface carries ``R = F_r - m'_r g_n``; else it moves freely,
``m'_r dw_r/dt = -F_r + m'_r g_n``. When it lands the surface stops it at once (V-P's infinite
impact force of the one-stage model): between the integrator's steps :meth:`ContactZones.switch`
sets ``y_r = 0`` and ``w_r = 0`` and pins it, or releases a pinned one whose load turned negative,
and the integrator restarts from there (the right-hand side stays smooth within a step); the
mass's kinetic energy is lost at landing (reported). Pinned, the
robot sees ``F_r = k''_r delta + b''_r d delta/dt`` on its penetration ``delta = -s``: the
Kelvin–Voigt law, so a robot of mass m resting on it sinks ``m g / k''_r`` and oscillates at
``sqrt(k''_r / m)``; in flight the mass rides on its spring.

The normal force on the robot is ``F_r`` (it may pull, a little, while a mass swings back: the
internal springs are fastened); the friction limit is ``mu max(0, F_r)`` while the zone's
interface is closed (``F > 0``, or the one-stage mass pinned), else 0. The state adds 2 entries
per one-stage zone (and its pinned flag) and 4 per two-stage zone; samples carry each zone's deformation
``c_r + max(0, x') + c_e`` [m] and force ``F_r`` [N].
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError
from ..scene import Scene

ZONE_STATE_SIZE = {"one_stage": 3, "two_stage": 4}
"""State entries a zone adds: (y_r, w_r, pinned) for one stage (``pinned``, 1 or 0, constant
between the integrator's switches), (y_r, w_r, y_e, w_e) for two."""


def _series(a: float, b: float) -> float:
    """Two elements in series: ``a b / (a + b)`` (0 when either is 0)."""
    return a * b / (a + b) if a > 0 and b > 0 else 0.0


@dataclass(frozen=True)
class ZoneForces:
    """The zones' forces at a state (arrays over the zones).

    Attributes:
        robot_force: F_r [N], the normal force on the robot's point.
        interface_force: F [N] (two-stage) or the surface's reaction R [N] (one-stage, pinned).
        closed: whether the interface carries force (friction acts only then).
        deformation: c_r + max(0, x') + c_e [m].
        rates: d/dt of the zones' state.
    """

    robot_force: np.ndarray
    interface_force: np.ndarray
    closed: np.ndarray
    deformation: np.ndarray
    rates: np.ndarray


@dataclass(frozen=True)
class ContactZones:
    """The modelled contacts' zones (arrays over the zones, in the modelled contacts' order).

    Attributes:
        names: the zones' contacts; kinds: ``"one_stage"`` or ``"two_stage"``.
        slots: each zone's index among the modelled contacts.
        offsets: where each zone's state starts in the zones' state vector; size: its length.
        mass_robot, stiffness_internal_robot, damping_internal_robot: m'_r [kg], k''_r [N/m],
            b''_r [N s/m].
        mass_environment, stiffness_internal_environment, damping_internal_environment: m'_e,
            k''_e, b''_e (0 for one stage).
        stiffness_external, damping_external: the series k' [N/m], b' [N s/m] (0 for one stage).
        gravity_normal: g . n [m/s^2] of each zone's contact.
    """

    names: tuple[str, ...]
    kinds: tuple[str, ...]
    slots: tuple[int, ...]
    offsets: tuple[int, ...]
    size: int
    mass_robot: np.ndarray
    stiffness_internal_robot: np.ndarray
    damping_internal_robot: np.ndarray
    mass_environment: np.ndarray
    stiffness_internal_environment: np.ndarray
    damping_internal_environment: np.ndarray
    stiffness_external: np.ndarray
    damping_external: np.ndarray
    gravity_normal: np.ndarray

    @property
    def count(self) -> int:
        """Number of zones."""
        return len(self.names)

    def _split(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(y_r, w_r, y_e, w_e, two-stage mask) per zone from the zones' state (one stage: y_e = w_e = 0)."""
        off = np.array(self.offsets, dtype=int)
        two = np.array([k == "two_stage" for k in self.kinds], dtype=bool)
        y_r, w_r = z[off], z[off + 1]
        y_e = np.where(two, z[np.minimum(off + 2, len(z) - 1)], 0.0)
        w_e = np.where(two, z[np.minimum(off + 3, len(z) - 1)], 0.0)
        return y_r, w_r, y_e, w_e, two

    def _pinned(self, z: np.ndarray) -> np.ndarray:
        """The one-stage masses' flag: pinned on the surface (two-stage zones: False)."""
        off = np.array(self.offsets, dtype=int)
        one = np.array([k == "one_stage" for k in self.kinds], dtype=bool)
        return one & (z[np.minimum(off + 2, len(z) - 1)] > 0.5)

    def _load(self, z: np.ndarray, gaps: np.ndarray, normal_velocities: np.ndarray) -> np.ndarray:
        """[N] What pushes each robot-side mass into the surface: ``F_r - m'_r g_n``."""
        slots = list(self.slots)
        y_r, w_r, _, _, _ = self._split(z)
        f_r = self.stiffness_internal_robot * (y_r - gaps[slots]) \
            + self.damping_internal_robot * (w_r - normal_velocities[slots])
        return f_r - self.mass_robot * self.gravity_normal

    def initial_state(self, gaps: np.ndarray, normal_velocities: np.ndarray) -> np.ndarray:
        """The zones undeformed: ``y_r = max(s, 0)``, ``w_r = v_N`` (0 on the surface), ``y_e = w_e = 0``.

        Args:
            gaps: s [m] of the modelled contacts.
            normal_velocities: v_N [m/s] of the modelled contacts.
        """
        z = np.zeros(self.size)
        for slot, off in zip(self.slots, self.offsets, strict=True):
            z[off] = max(float(gaps[slot]), 0.0)
            z[off + 1] = float(normal_velocities[slot]) if gaps[slot] > 0 else 0.0
        load = self._load(z, gaps, normal_velocities)
        for j, (kind, off) in enumerate(zip(self.kinds, self.offsets, strict=True)):
            if kind == "one_stage":
                z[off + 2] = float(z[off] <= 0.0 and load[j] >= 0.0)
        return z

    def forces(self, z: np.ndarray, gaps: np.ndarray, normal_velocities: np.ndarray) -> ZoneForces:
        """The module docstring's forces and rates.

        Args:
            z: the zones' state.
            gaps: s [m] of the modelled contacts.
            normal_velocities: v_N [m/s] of the modelled contacts.
        """
        slots = list(self.slots)
        s, sdot = gaps[slots], normal_velocities[slots]
        y_r, w_r, y_e, w_e, two = self._split(z)
        c_r, cd_r = y_r - s, w_r - sdot
        f_r = self.stiffness_internal_robot * c_r + self.damping_internal_robot * cd_r
        f_e = self.stiffness_internal_environment * -y_e + self.damping_internal_environment * -w_e
        overlap, overlap_rate = y_e - y_r, w_e - w_r
        f_ext = np.where(two & (overlap > 0.0), np.maximum(
            0.0, self.stiffness_external * overlap + self.damping_external * overlap_rate), 0.0)
        load = f_r - self.mass_robot * self.gravity_normal  # what pushes the one-stage mass down
        pinned = self._pinned(z)
        accel_r = np.where(two, f_ext - f_r, -f_r) / self.mass_robot + self.gravity_normal
        rates = np.zeros(self.size)
        off = np.array(self.offsets, dtype=int)
        rates[off] = np.where(pinned, 0.0, w_r)
        rates[off + 1] = np.where(pinned, 0.0, accel_r)
        for j in np.nonzero(two)[0]:
            rates[off[j] + 2] = w_e[j]
            rates[off[j] + 3] = (f_e[j] - f_ext[j]) / self.mass_environment[j]
        # one stage: the pinned flag's rate is 0 (it changes only in switch)
        interface = np.where(two, f_ext, np.where(pinned, load, 0.0))
        deformation = c_r + np.maximum(overlap, 0.0) * two + np.where(two, -y_e, 0.0)
        return ZoneForces(f_r, interface, interface > 0.0, deformation, rates)

    def switch(self, z: np.ndarray, gaps: np.ndarray, normal_velocities: np.ndarray
               ) -> tuple[np.ndarray, float] | None:
        """Land or release the one-stage masses, between the integrator's steps.

        A free mass that went through its surface (``y_r < 0``, or ``y_r = 0`` moving down) is
        stopped on it and pinned; a pinned one whose load ``F_r - m'_r g_n`` turned negative is
        released.

        Args:
            z: the zones' state.
            gaps: s [m] of the modelled contacts.
            normal_velocities: v_N [m/s] of the modelled contacts.

        Returns:
            ``(z, energy)``, the kinetic energy [J] the landings took, or None when nothing changed.
        """
        out, lost = z.copy(), 0.0
        load = self._load(z, gaps, normal_velocities)
        for j, (kind, off, mass) in enumerate(zip(self.kinds, self.offsets, self.mass_robot, strict=True)):
            if kind != "one_stage":
                continue
            if z[off + 2] > 0.5 and load[j] < 0.0:
                out[off + 2] = 0.0
            elif z[off + 2] <= 0.5 and (z[off] < 0.0 or (z[off] == 0.0 and z[off + 1] < 0.0)):
                lost += 0.5 * float(mass) * float(min(z[off + 1], 0.0)) ** 2
                out[off], out[off + 1], out[off + 2] = 0.0, 0.0, 1.0
        return None if np.array_equal(out, z) else (out, lost)

    def elastic_energy(self, z: np.ndarray, gaps: np.ndarray) -> float:
        """[J] The springs' energy: ``k''_r c_r^2 / 2 + k''_e c_e^2 / 2 + k' max(0, x')^2 / 2``."""
        s = gaps[list(self.slots)]
        y_r, _, y_e, _, two = self._split(z)
        overlap = np.where(two, np.maximum(y_e - y_r, 0.0), 0.0)
        return float(0.5 * np.sum(self.stiffness_internal_robot * (y_r - s) ** 2
                                  + self.stiffness_internal_environment * y_e ** 2
                                  + self.stiffness_external * overlap ** 2))

    def kinetic_energy(self, z: np.ndarray) -> float:
        """[J] The zone masses' kinetic energy (absolute velocities)."""
        _, w_r, _, w_e, _ = self._split(z)
        return float(0.5 * np.sum(self.mass_robot * w_r ** 2 + self.mass_environment * w_e ** 2))

    def report(self) -> dict:
        """The ``info["zones_parameters"]`` entry: each zone's kind and parameters."""
        return {
            name: {"zone": self.kinds[j], "mass_robot": self.mass_robot[j],
                   "stiffness_internal_robot": self.stiffness_internal_robot[j],
                   "damping_internal_robot": self.damping_internal_robot[j],
                   "mass_environment": self.mass_environment[j],
                   "stiffness_internal_environment": self.stiffness_internal_environment[j],
                   "damping_internal_environment": self.damping_internal_environment[j],
                   "stiffness_external": self.stiffness_external[j],
                   "damping_external": self.damping_external[j], "state_size": ZONE_STATE_SIZE[self.kinds[j]]}
            for j, name in enumerate(self.names)
        }


class ImpactPhases:
    """The compliant model's impacts, from closing to the end of their transition phase.

    An impact (a contact closing faster than the impact velocity) starts its phase; the phase ends
    when the contact opens again, or when its point, having rebounded (``v_N > 0``), stops moving
    out (``v_N <= 0``) while still touching. Each impact event's values then hold ``peak_force``
    [N] (the largest normal force on the robot seen at the integrator's steps), ``duration`` [s],
    ``impulse_normal`` [N s] (the normal force integrated by the trapezoidal rule over the steps)
    and ``normal_velocity_after`` [m/s] (at the phase's end); they are None while the phase lasts
    (a run that ends in it).
    """

    def __init__(self) -> None:
        self._open: dict[int, tuple[dict[str, Any], dict[str, float]]] = {}

    def start(self, slot: int, t: float, normal_velocity: float, normal_force: float) -> dict[str, Any]:
        """Open a phase for the contact at ``slot``; returns the event's values (filled at its end)."""
        values: dict[str, Any] = {"normal_velocity_before": float(normal_velocity),
                                  "peak_force": float(normal_force), "duration": None,
                                  "impulse_normal": None, "normal_velocity_after": None}
        self._open[slot] = (values, {"start": t, "last": t, "force": float(normal_force),
                                     "impulse": 0.0, "rebounding": 0.0})
        return values

    def update(self, t: float, normal_force: np.ndarray, normal_velocity: np.ndarray,
               touching: np.ndarray) -> None:
        """Account for one integrator step ending at ``t`` [s] (arrays over the modelled contacts)."""
        for slot in list(self._open):
            values, phase = self._open[slot]
            force = float(normal_force[slot])
            phase["impulse"] += 0.5 * (force + phase["force"]) * (t - phase["last"])
            phase["last"], phase["force"] = t, force
            values["peak_force"] = max(values["peak_force"], force)
            vn = float(normal_velocity[slot])
            if vn > 0.0:
                phase["rebounding"] = 1.0
            if not touching[slot] or (phase["rebounding"] and vn <= 0.0):
                values.update(duration=t - phase["start"], impulse_normal=phase["impulse"],
                              normal_velocity_after=vn)
                del self._open[slot]


def contact_zones(scene: Scene, names: Sequence[str]) -> ContactZones | None:
    """The zones of the modelled contacts ``names`` (None when none has a massive zone).

    Raises:
        InputError: a modelled contact's zone is ``"rigid"`` (only the rigid model simulates it).
    """
    model = scene.model
    rows, kinds, slots, offsets, zone_names, size = [], [], [], [], [], 0
    by_name = {c.name: c for c in scene.contacts}
    for slot, name in enumerate(names):
        params = model.parameters(name)
        if params.zone == "rigid":
            raise InputError(f"contact {name!r} has zone = 'rigid': only the rigid model simulates it; "
                             "use --model rigid, or give it a 'compliant', 'one_stage' or 'two_stage' zone")
        if params.zone not in ZONE_STATE_SIZE:
            continue
        two = params.zone == "two_stage"
        p = {key: float(value) for key, value in params.zone_parameters.items()}
        if not two:  # one stage: the robot side's mass and internal stage only
            p = {key: value for key, value in p.items()
                 if key.endswith("internal_robot") or key == "mass_robot"}
        normal = by_name[name].point.normal_in_world
        rows.append((p.get("mass_robot", 0.0), p.get("stiffness_internal_robot", 0.0),
                     p.get("damping_internal_robot", 0.0), p.get("mass_environment", 0.0),
                     p.get("stiffness_internal_environment", 0.0), p.get("damping_internal_environment", 0.0),
                     _series(p.get("stiffness_external_robot", 0.0),
                             p.get("stiffness_external_environment", 0.0)),
                     _series(p.get("damping_external_robot", 0.0),
                             p.get("damping_external_environment", 0.0)),
                     -scene.robot.gravity * float(normal[1])))
        kinds.append(params.zone)
        slots.append(slot)
        offsets.append(size)
        zone_names.append(name)
        size += ZONE_STATE_SIZE[params.zone]
    if not rows:
        return None
    arr = np.array(rows, dtype=float)
    return ContactZones(tuple(zone_names), tuple(kinds), tuple(slots), tuple(offsets), size, *arr.T)


__all__ = ["ZONE_STATE_SIZE", "ContactZones", "ImpactPhases", "ZoneForces", "contact_zones"]
