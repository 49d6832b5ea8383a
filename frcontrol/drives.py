r"""Drives: DC motors behind gear stages, as a scene's ``[model.drives.JOINT]`` turns them on.

The model is Vukobratović and Potkonjak's (Mechanism and Machine Theory 34, 1999, §6, eqs. 39-44).
A joint ``j`` is driven by a DC motor with voltage input ``u`` [V], resistance ``R`` [ohm], torque
constant ``C_M`` [N m/A], back-EMF constant ``C_E`` [V s/rad] and rotor inertia ``J_r`` [kg m^2].
Its electrical time constant is neglected (their eq. 42), so the current is
``i = (u - C_E w_m) / R`` [A] and the motor's torque, the first stage's input, is::

    M_1 = C_M i = (C_M / R) u - (C_M C_E / R) w_m                                     (42)

with ``w_m`` [rad/s] the rotor's speed. Between the rotor and the joint lie ``p`` stages; stage
``n`` is a gear pair (ratio ``N_n`` = input speed / output speed, input and output gear
inertias ``I'_n``, ``I''_n`` [kg m^2]) followed by a torsion element (stiffness ``c_n``
[N m/rad], damping ``d_n`` [N m s/rad]) that joins the gear's output to the next stage's input
(the last stage's: to the joint). A stage without ``stiffness`` has a rigid torsion element.

Rigid stages (eqs. 39-40)
-------------------------
With every stage rigid, the rotor turns at ``w_m = N qdot`` (``N`` = the product of the ratios)
and the joint receives, with ``eta`` the product of the stages' efficiencies::

    tau = eta N M_1 = eta N (C_M / R) u - eta N^2 (C_M C_E / R) qdot                    (40)

and the transmission's inertia reflected to the joint, ``J_refl = N^2 J_r + sum_n (I'_n
(N_n ... N_p)^2 + I''_n (N_{n+1} ... N_p)^2)``, adds to the joint's diagonal of ``M``. The joint
torque is affine in ``u``: an input gain ``eta N C_M / R`` [N m/V] and a viscous term of
coefficient ``eta N^2 C_M C_E / R`` [N m s/rad] (the motor's electrical damping) that the
dynamics carry in the bias ``h(q, v)``. The torque-speed line of the drive is
``tau in [tau(-u_max, qdot), tau(u_max, qdot)]``, from the stall torque ``eta N C_M u_max / R``
at rest to zero at the no-load speed ``u_max / (C_E N)``.

The efficiency is V-P's constant factor on the torque passed through the gears (their eq.
40): it scales the *driving* torque (the motor's, or an upstream spring's) and not the inertial
or spring reactions, so that ``M`` stays symmetric. It is exact for power flowing from the motor
to the joint; a back-driven gear gains ``(1 - eta)`` of the power in this model rather than
losing it. ``efficiency = 1`` (the default) is lossless.

Elastic stages (eqs. 41, 43, 44)
--------------------------------
Each elastic stage adds one coordinate, the angle ``theta`` [rad] of its gear's output, which is
the spring's motor-side end. The stages between two elastic ones, and from the motor to the first
elastic stage, turn rigidly with it (a *cluster*); the stages after the last elastic stage turn
rigidly with the joint. :func:`clusters` lists them with their inertias reflected to their
coordinate; :mod:`frcontrol.simulation.transmissions` integrates them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .errors import SceneError
from .scene_schema import nearest

DRIVE_KINDS = ("dc_motor",)
"""The kinds of drive a scene's ``[model.drives.JOINT]`` may name."""

DRIVE_KEYS = ("kind", "resistance", "torque_constant", "back_emf_constant", "rotor_inertia",
              "voltage_limit", "stages")
"""The keys of a ``[model.drives.JOINT]`` table."""

STAGE_KEYS = ("ratio", "efficiency", "inertia_in", "inertia_out", "stiffness", "damping", "deflection")
"""The keys of a ``[[model.drives.JOINT.stages]]`` table."""


@dataclass(frozen=True)
class Stage:
    """One transmission stage: a gear pair, then a torsion element (rigid without ``stiffness``).

    Attributes:
        ratio: N [-], input speed over output speed (> 0; 33 for a 33:1 reduction).
        efficiency: eta [-], in (0, 1]: the factor on the driving torque passed through the gears.
        inertia_in: I' [kg m^2], the input gear's inertia (turns at the stage's input speed).
        inertia_out: I'' [kg m^2], the output gear's inertia (turns at the input speed / N).
        stiffness: c [N m/rad] of the torsion element after the gears, > 0; None: rigid.
        damping: d [N m s/rad] of the torsion element, >= 0 (ignored when rigid).
        deflection: [rad] the torsion element's twist at the scene's state (ignored when rigid):
            the analysis's spring torque and the simulation's initial condition.
    """

    ratio: float = 1.0
    efficiency: float = 1.0
    inertia_in: float = 0.0
    inertia_out: float = 0.0
    stiffness: float | None = None
    damping: float = 0.0
    deflection: float = 0.0

    @property
    def elastic(self) -> bool:
        """Whether the stage has a torsion spring (and so a coordinate of its own)."""
        return self.stiffness is not None


@dataclass(frozen=True)
class Drive:
    """A DC motor and its transmission, driving one joint (Vukobratović and Potkonjak 1999, §6).

    Attributes:
        joint: the driven joint's name.
        resistance: R [ohm], > 0.
        torque_constant: C_M [N m/A], > 0.
        back_emf_constant: C_E [V s/rad], >= 0.
        rotor_inertia: J_r [kg m^2], >= 0.
        voltage_limit: u_max [V], > 0: the voltage lies in [-u_max, u_max].
        stages: the transmission, motor side first (none: the motor drives the joint directly).
        kind: ``"dc_motor"``.
    """

    joint: str
    resistance: float
    torque_constant: float
    back_emf_constant: float
    rotor_inertia: float
    voltage_limit: float
    stages: tuple[Stage, ...] = ()
    kind: str = "dc_motor"

    @property
    def ratio(self) -> float:
        """N [-]: the product of the stages' ratios (rotor speed / joint speed when rigid)."""
        return math.prod(s.ratio for s in self.stages)

    @property
    def efficiency(self) -> float:
        """Eta [-]: the product of the stages' efficiencies."""
        return math.prod(s.efficiency for s in self.stages)

    @property
    def elastic(self) -> bool:
        """Whether any stage is elastic (the transmission then has coordinates of its own)."""
        return any(s.elastic for s in self.stages)

    @property
    def elastic_stages(self) -> tuple[int, ...]:
        """Indices of the elastic stages, motor side first."""
        return tuple(i for i, s in enumerate(self.stages) if s.elastic)

    @property
    def motor_gain(self) -> float:
        """C_M / R [N m/V]: the motor torque per volt at rest."""
        return self.torque_constant / self.resistance

    @property
    def motor_damping(self) -> float:
        """C_M C_E / R [N m s/rad]: the motor torque lost per rad/s of rotor speed."""
        return self.torque_constant * self.back_emf_constant / self.resistance

    @property
    def input_gain(self) -> float:
        """[N m/V] eta N C_M / R: the joint torque per volt at rest.

        0 with an elastic stage: the voltage then reaches the joint only through the spring.
        """
        return 0.0 if self.elastic else self.efficiency * self.ratio * self.motor_gain

    @property
    def joint_damping(self) -> float:
        """[N m s/rad] eta N^2 C_M C_E / R: the motor's electrical damping seen at the joint.

        0 with an elastic stage (the motor is then not rigidly coupled to the joint).
        """
        return 0.0 if self.elastic else self.efficiency * self.ratio ** 2 * self.motor_damping

    @property
    def reflected_inertia(self) -> float:
        """[kg m^2] added to the joint's diagonal of M: the inertia turning rigidly with the joint.

        Everything for rigid stages; the stages after the last elastic one otherwise.
        """
        return clusters(self)[-1].inertia


@dataclass(frozen=True)
class Cluster:
    """Bodies of a transmission that turn rigidly together, reduced to one coordinate.

    Attributes:
        stages: the indices of the stages whose gears belong to it, motor side first.
        inertia: [kg m^2] their inertia (and the rotor's, in the first cluster) reflected to the
            cluster's coordinate: the last stage's output gear angle, or the joint angle.
        input_ratio: speed of the cluster's input (the rotor, or its first stage's input gear)
            over the coordinate's speed: the product of its stages' ratios.
        input_efficiency: the product of its stages' efficiencies (applied to the driving torque
            entering at its input).
        has_motor: whether the rotor belongs to it (the first cluster).
    """

    stages: tuple[int, ...]
    inertia: float
    input_ratio: float
    input_efficiency: float
    has_motor: bool


def clusters(drive: Drive) -> tuple[Cluster, ...]:
    """The transmission's rigid clusters, motor side first; the last one turns with the joint.

    An elastic stage ends a cluster (its output gear is the cluster's coordinate, the spring's
    motor-side end); a drive with e elastic stages has e + 1 clusters.
    """
    out: list[Cluster] = []
    current: list[int] = []
    for i, stage in enumerate(drive.stages):
        current.append(i)
        if stage.elastic:
            out.append(_cluster(drive, tuple(current), not out))
            current = []
    out.append(_cluster(drive, tuple(current), not out))
    return tuple(out)


def _cluster(drive: Drive, stages: tuple[int, ...], has_motor: bool) -> Cluster:
    """One cluster: inertias reflected to its output, ``I (speed ratio to the output)^2``."""
    inertia = 0.0
    downstream = 1.0  # speed of the current stage's output over the cluster's output speed
    for i in reversed(stages):
        stage = drive.stages[i]
        inertia += stage.inertia_out * downstream ** 2
        downstream *= stage.ratio
        inertia += stage.inertia_in * downstream ** 2
    if has_motor:
        inertia += drive.rotor_inertia * downstream ** 2
    efficiency = math.prod(drive.stages[i].efficiency for i in stages)
    return Cluster(stages, inertia, downstream, efficiency, has_motor)


# ------------------------------------------------------------------------- closed forms (rigid)
def motor_current(drive: Drive, voltage: Any, motor_speed: Any) -> Any:
    """[A] The current i = (u - C_E w_m) / R at voltage ``u`` [V] and rotor speed ``w_m`` [rad/s]."""
    back_emf = drive.back_emf_constant * np.asarray(motor_speed, dtype=float)
    return (np.asarray(voltage, dtype=float) - back_emf) / drive.resistance


def joint_torque(drive: Drive, voltage: Any, joint_speed: Any) -> Any:
    """[N m] The joint torque of a rigid transmission, eta N (C_M / R) (u - C_E N qdot).

    ``voltage`` [V] and ``joint_speed`` qdot [rad/s] broadcast (floats or arrays). For a drive
    with elastic stages this is the steady-state torque (the springs at rest relative to each
    other); the instantaneous torque is the last spring's.
    """
    speed = np.asarray(joint_speed, dtype=float)
    current = motor_current(drive, voltage, drive.ratio * speed)
    out = drive.efficiency * drive.ratio * drive.torque_constant * current
    return float(out) if np.ndim(out) == 0 else out


def torque_limits(drive: Drive, joint_speed: Any) -> tuple[Any, Any]:
    """[N m] (lo, hi): the torque-speed line's band at ``joint_speed`` [rad/s].

    The joint torques at ``-voltage_limit`` and ``+voltage_limit`` (:func:`joint_torque`).
    """
    u = drive.voltage_limit
    return joint_torque(drive, -u, joint_speed), joint_torque(drive, u, joint_speed)


def stall_torque(drive: Drive) -> float:
    """[N m] The joint torque at rest at the voltage limit, eta N C_M u_max / R."""
    return float(drive.efficiency * drive.ratio * drive.motor_gain * drive.voltage_limit)


def no_load_speed(drive: Drive) -> float:
    """[rad/s] The joint speed u_max / (C_E N) at which the torque falls to zero (inf if C_E = 0)."""
    if drive.back_emf_constant == 0.0:
        return math.inf
    return float(drive.voltage_limit / (drive.back_emf_constant * drive.ratio))


def mechanical_time_constant(drive: Drive, load_inertia: float = 0.0) -> float:
    """[s] R J_total / (C_M C_E): the spin-up time constant of a motor on a free inertia.

    ``J_total = (J_refl + load_inertia) / N^2`` is referred to the rotor, ``load_inertia``
    [kg m^2] at the joint. Rigid stages of efficiency 1 (with eta < 1 the joint's damping is eta
    times lower and the time constant 1 / eta times longer).
    """
    total = (drive.reflected_inertia + load_inertia) / drive.ratio ** 2
    return float(drive.resistance * total / (drive.torque_constant * drive.back_emf_constant))


def drives_report(drives: Mapping[str, Drive], joint_speeds: Mapping[str, float]
                  ) -> dict[str, dict[str, Any]]:
    """Each drive's constants and its torque band at the joint speeds [rad/s] (``frc analyze``).

    Per joint: ``input_gain`` [N m/V], ``joint_damping`` [N m s/rad], ``reflected_inertia``
    [kg m^2], ``stall_torque`` [N m], ``no_load_speed`` [rad/s] (null when infinite),
    ``voltage_limit`` [V], ``elastic_stages`` (their count) and ``torque_limits`` [N m] (the
    torque-speed line at the joint's speed).
    """
    out = {}
    for joint, drive in drives.items():
        lo, hi = torque_limits(drive, joint_speeds.get(joint, 0.0))
        speed = no_load_speed(drive)
        out[joint] = {
            "kind": drive.kind, "voltage_limit": drive.voltage_limit, "ratio": drive.ratio,
            "efficiency": drive.efficiency, "input_gain": drive.input_gain,
            "joint_damping": drive.joint_damping, "reflected_inertia": drive.reflected_inertia,
            "stall_torque": stall_torque(drive), "no_load_speed": speed if math.isfinite(speed) else None,
            "elastic_stages": len(drive.elastic_stages), "torque_limits": [float(lo), float(hi)],
        }
    return out


def resting_joint_torques(drives: Mapping[str, Drive], coordinate_names: Sequence[str]) -> np.ndarray:
    """[N m] per coordinate: the elastic transmissions' torques at rest, eta_e rho_e c delta.

    The last spring of each drive with elastic stages, twisted by its stage's ``deflection`` and
    not moving relative to the joint: what :class:`~frcontrol.modes.ContactProblem` takes as the
    known generalized force of an elastic drive at the scene's state (its voltage acts on the
    motor's cluster only and does not reach the joint within the instant analysed).
    """
    out = np.zeros(len(coordinate_names))
    for joint, drive in drives.items():
        if drive.elastic:
            last = clusters(drive)[-1]
            spring = drive.stages[drive.elastic_stages[-1]]
            torque = float(spring.stiffness or 0.0) * spring.deflection
            out[list(coordinate_names).index(joint)] += last.input_efficiency * last.input_ratio * torque
    return out


# ------------------------------------------------------------------------------------ scene table
@dataclass(frozen=True)
class DrivenJoints:
    """A scene's drives and what each adds to its joint, found once when the scene is read.

    Attributes:
        drives: the drives, by joint.
        inertia: [kg m^2] each drive's reflected inertia (:attr:`Drive.reflected_inertia`), by joint.
        damping: [N m s/rad] each drive's electrical damping at the joint (:attr:`Drive.joint_damping`).
        gains: [N m/V] each drive's input gain (:attr:`Drive.input_gain`).
    """

    drives: Mapping[str, Drive]
    inertia: Mapping[str, float]
    damping: Mapping[str, float]
    gains: Mapping[str, float]


# ------------------------------------------------------------------------------------ scene table
def read_drives(path: str, raw: Any, joint_names: Sequence[str], locked: Sequence[str] = ()
                ) -> DrivenJoints:
    """The ``[model.drives]`` table as drives by joint (None: none), with their terms.

    The schema has checked the keys and types; this checks what it cannot: the joint exists and
    is not locked, and the physical ranges.

    Raises:
        SceneError: an unknown or locked joint (naming the nearest joint), a missing key, a
            non-positive resistance, torque constant, voltage limit, ratio or stiffness, a negative
            back-EMF constant, inertia or damping, an efficiency outside (0, 1].
    """
    if raw is None:
        return DrivenJoints({}, {}, {}, {})
    if not isinstance(raw, Mapping):
        raise SceneError(path, "model.drives", "expected tables [model.drives.JOINT]")
    out: dict[str, Drive] = {}
    for joint, table in raw.items():
        where = f"model.drives.{joint}"
        if joint in locked:
            raise SceneError(path, where, f"joint {joint!r} is locked (locked_joints): it cannot be driven")
        if joint not in joint_names:
            guess = nearest(str(joint), list(joint_names))
            hint = f"did you mean {guess!r}? " if guess else ""
            raise SceneError(path, where, f"unknown joint {joint!r}; {hint}the joints are: "
                             f"{', '.join(joint_names) or '(none)'}")
        if not isinstance(table, Mapping):
            raise SceneError(path, where, f"expected a table, got {table!r}")
        out[str(joint)] = _read_drive(path, str(joint), table, where)
    return DrivenJoints(out, {j: d.reflected_inertia for j, d in out.items()},
                        {j: d.joint_damping for j, d in out.items()},
                        {j: d.input_gain for j, d in out.items()})


def _value(path: str, table: Mapping[str, Any], key: str, where: str, *, default: float | None = None,
           positive: bool = False, unit: str = "") -> float:
    if key not in table:
        if default is None:
            raise SceneError(path, f"{where}.{key}", f"missing: the drive's {key.replace('_', ' ')} {unit}")
        return default
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SceneError(path, f"{where}.{key}", f"expected a finite number {unit}, got {value!r}")
    x = float(value)
    if (positive and x <= 0) or x < 0:
        bound = "> 0" if positive else ">= 0"
        raise SceneError(path, f"{where}.{key}", f"expected a value {bound} {unit}, got {x:g}")
    return x


def _read_drive(path: str, joint: str, table: Mapping[str, Any], where: str) -> Drive:
    unknown = sorted(set(table) - set(DRIVE_KEYS))
    if unknown:
        raise SceneError(path, f"{where}.{unknown[0]}", f"unknown key; known keys: {', '.join(DRIVE_KEYS)}")
    kind = table.get("kind", "dc_motor")
    if kind not in DRIVE_KINDS:
        raise SceneError(path, f"{where}.kind", f"expected one of {', '.join(map(repr, DRIVE_KINDS))}, "
                         f"got {kind!r}")
    stages_raw = table.get("stages", [])
    if not isinstance(stages_raw, list):
        raise SceneError(path, f"{where}.stages", "expected an array of tables [[...stages]]")
    stages = tuple(_read_stage(path, s, f"{where}.stages[{i}]") for i, s in enumerate(stages_raw))
    drive = Drive(
        joint=joint,
        resistance=_value(path, table, "resistance", where, positive=True, unit="[ohm]"),
        torque_constant=_value(path, table, "torque_constant", where, positive=True, unit="[N m/A]"),
        back_emf_constant=_value(path, table, "back_emf_constant", where, unit="[V s/rad]"),
        rotor_inertia=_value(path, table, "rotor_inertia", where, unit="[kg m^2]"),
        voltage_limit=_value(path, table, "voltage_limit", where, positive=True, unit="[V]"),
        stages=stages, kind=str(kind),
    )
    for cluster in clusters(drive)[:-1]:
        if cluster.inertia <= 0.0:
            raise SceneError(path, f"{where}.stages[{cluster.stages[-1]}]", "the elastic stage's motor side "
                             "has no inertia (rotor_inertia, inertia_in, inertia_out all 0 up to the "
                             "previous elastic stage): give it one, or make the stage rigid")
    return drive


def _read_stage(path: str, table: Any, where: str) -> Stage:
    if not isinstance(table, Mapping):
        raise SceneError(path, where, f"expected a table, got {table!r}")
    unknown = sorted(set(table) - set(STAGE_KEYS))
    if unknown:
        raise SceneError(path, f"{where}.{unknown[0]}", f"unknown key; known keys: {', '.join(STAGE_KEYS)}")
    efficiency = _value(path, table, "efficiency", where, default=1.0, positive=True, unit="[-]")
    if efficiency > 1.0:
        raise SceneError(path, f"{where}.efficiency", f"expected a value in (0, 1] [-], got {efficiency:g}")
    stiffness = (None if "stiffness" not in table
                 else _value(path, table, "stiffness", where, positive=True, unit="[N m/rad]"))
    return Stage(
        ratio=_value(path, table, "ratio", where, default=1.0, positive=True, unit="[-]"),
        efficiency=efficiency,
        inertia_in=_value(path, table, "inertia_in", where, default=0.0, unit="[kg m^2]"),
        inertia_out=_value(path, table, "inertia_out", where, default=0.0, unit="[kg m^2]"),
        stiffness=stiffness,
        damping=_value(path, table, "damping", where, default=0.0, unit="[N m s/rad]"),
        deflection=_signed(path, table, "deflection", where),
    )


def _signed(path: str, table: Mapping[str, Any], key: str, where: str) -> float:
    value = table.get(key, 0.0)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SceneError(path, f"{where}.{key}", f"expected a finite number [rad], got {value!r}")
    return float(value)


__all__ = [
    "Cluster",
    "DRIVE_KEYS",
    "DRIVE_KINDS",
    "Drive",
    "DrivenJoints",
    "STAGE_KEYS",
    "Stage",
    "clusters",
    "drives_report",
    "joint_torque",
    "mechanical_time_constant",
    "motor_current",
    "no_load_speed",
    "read_drives",
    "resting_joint_torques",
    "stall_torque",
    "torque_limits",
]
