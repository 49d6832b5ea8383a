"""Joint springs: a known generalized force on an unactuated joint, like gravity.

A scene's ``[model.springs.JOINT]`` puts a linear spring and damper on one joint's coordinate::

    [model.springs.leg]
    stiffness = 2400.0   # k [N/m] on a prismatic joint, [N m/rad] on a revolute one, >= 0
    damping = 24.0       # c [N s/m] or [N m s/rad], >= 0 (default 0)
    rest = 0.17          # the coordinate's rest value [m] or [rad] (default 0)

Its generalized force on that coordinate at a state is ``f_j = -k (q_j - rest) - c v_j``, a known
force at the state like gravity: it goes into the bias ``h(q, v)`` of ``M dv + h = S^T u + J^T lam``
as ``+k (q_j - rest) + c v_j``, where :meth:`~frcontrol.model.PlanarRobot.state` assembles it, so
that the engine, statics and both simulators see it. Its elastic energy is ``1/2 k (q_j - rest)^2``.
The joint must be a joint of the robot that is not an input (a spring on a driven coordinate would
be an input's offset, not a leg's store) and not locked. With numpy only.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import SceneError
from .scene_schema import nearest

if TYPE_CHECKING:
    from .drives import DrivenJoints

SPRING_KEYS = ("stiffness", "damping", "rest")
"""The keys of a ``[model.springs.JOINT]`` table (``stiffness`` required)."""


@dataclass(frozen=True, eq=False)
class JointSprings:
    """The springs of a robot, one per spring coordinate (none: every array empty).

    Attributes:
        joints: the sprung joints, in the scene's order.
        indices: each joint's index into the minimal coordinates, shape (s,).
        stiffness: k [N/m or N m/rad], >= 0, shape (s,).
        damping: c [N s/m or N m s/rad], >= 0, shape (s,).
        rest: the coordinate's rest value [m or rad], shape (s,).
    """

    joints: tuple[str, ...]
    indices: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    rest: np.ndarray

    def __bool__(self) -> bool:
        """Whether there is a spring."""
        return bool(self.joints)

    def deflection(self, q: np.ndarray) -> np.ndarray:
        """``q_j - rest`` [m or rad] of each spring, for one configuration (n,) or many (T, n)."""
        return np.asarray(q, dtype=float)[..., self.indices] - self.rest

    def force(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``-k (q_j - rest) - c v_j`` [N or N m] on each spring's coordinate, for (n,) or (T, n)."""
        rate = np.asarray(v, dtype=float)[..., self.indices]
        return -self.stiffness * self.deflection(q) - self.damping * rate

    def add_to_bias(self, bias: np.ndarray, q: np.ndarray, v: np.ndarray) -> None:
        """Add the springs to the bias h(q, v) [N, N m] in place: ``h_j -= force_j``."""
        bias[self.indices] -= self.force(q, v)

    def elastic_energy(self, q: np.ndarray) -> Any:
        """``sum 1/2 k (q_j - rest)^2`` [J]: a float for one configuration, (T,) for many."""
        return 0.5 * np.sum(self.stiffness * self.deflection(q) ** 2, axis=-1)

    def samples(self, q: np.ndarray, v: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
        """Per spring, its ``deflection`` [m or rad] and ``force`` [N or N m] over samples (T, n)."""
        deflection, force = self.deflection(q), self.force(q, v)
        return {joint: {"deflection": deflection[:, j], "force": force[:, j]}
                for j, joint in enumerate(self.joints)}

    def report(self, q: np.ndarray, v: np.ndarray) -> dict[str, dict[str, float]]:
        """The springs at one state, as JSON: :meth:`to_dict`'s values, ``deflection`` and ``force``."""
        if not self.joints:
            return {}
        deflection, force = self.deflection(q), self.force(q, v)
        return {joint: {**table, "deflection": float(deflection[j]),
                         "force": float(force[j]) + 0.0}  # (+ 0.0: no -0.0 in the JSON)
                for j, (joint, table) in enumerate(self.to_dict().items())}

    def to_dict(self) -> dict[str, dict[str, float]]:
        """The springs as JSON: ``{JOINT: {"stiffness", "damping", "rest"}}``."""
        return {joint: {"stiffness": float(self.stiffness[j]), "damping": float(self.damping[j]),
                        "rest": float(self.rest[j])} for j, joint in enumerate(self.joints)}


NO_SPRINGS = JointSprings((), np.zeros(0, dtype=int), np.zeros(0), np.zeros(0), np.zeros(0))
"""A robot without springs."""


def _value(path: str, table: Mapping[str, Any], key: str, where: str, default: float | None) -> float:
    if key not in table:
        if default is None:
            raise SceneError(path, f"{where}.{key}", "missing: the spring's stiffness [N/m or N m/rad]")
        return default
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SceneError(path, f"{where}.{key}", f"expected a finite number, got {value!r}")
    if key != "rest" and value < 0:
        raise SceneError(path, f"{where}.{key}", f"expected a value >= 0, got {float(value):g}")
    return float(value)


def _check_joint(path: str, joint: str, where: str, coordinates: Sequence[str], joints: Sequence[str],
                 inputs: Sequence[str], locked: Sequence[str]) -> None:
    """The joint exists, is not locked and is not an input; else a message naming the nearest valid one."""
    if joint in joints and joint not in inputs and joint not in locked:
        return
    valid = [j for j in joints if j not in inputs]
    guess = nearest(joint, valid)
    if guess is None and joint in (*inputs, *locked) and valid:  # a real joint: offer the closest anyway
        guess = difflib.get_close_matches(joint, valid, n=1, cutoff=0.0)[0]
    hint = f"did you mean {guess!r}? " if guess else ""
    listing = f"the unactuated joints are: {', '.join(valid) or '(none)'}"
    if joint in locked:
        raise SceneError(path, where, f"joint {joint!r} is locked (locked_joints): it has no coordinate "
                         f"for a spring; {hint}{listing}")
    if joint in inputs:
        raise SceneError(path, where, f"joint {joint!r} is an input (actuated): a spring goes on an "
                         f"unactuated joint; {hint}{listing}")
    if joint not in joints:
        kind = "coordinate" if joint in coordinates else "joint"
        raise SceneError(path, where, f"unknown {kind} {joint!r} for a spring; {hint}{listing}")


def read_springs(path: str, raw: Any, coordinates: Sequence[str], joints: Sequence[str],
                 inputs: Sequence[str], locked: Sequence[str] = ()) -> JointSprings:
    """The ``[model.springs]`` table as :class:`JointSprings` (None: no spring).

    Args:
        path: the scene file, for messages.
        raw: the parsed table, ``{JOINT: {stiffness, damping, rest}}``.
        coordinates: the robot's minimal coordinates.
        joints: its movable joints (after locking).
        inputs: the input coordinates.
        locked: the locked joints.

    Raises:
        SceneError: an unknown, locked or actuated joint (naming the nearest unactuated joint), an
            unknown key (naming the nearest), a missing stiffness, a negative stiffness or damping,
            a non-finite value.
    """
    if raw is None:
        return NO_SPRINGS
    if not isinstance(raw, Mapping):
        raise SceneError(path, "model.springs", "expected tables [model.springs.JOINT]")
    names, values = [], []
    for joint, table in raw.items():
        where = f"model.springs.{joint}"
        _check_joint(path, str(joint), where, coordinates, joints, inputs, locked)
        if not isinstance(table, Mapping):
            raise SceneError(path, where, f"expected a table, got {table!r}")
        for key in table:
            if key not in SPRING_KEYS:
                guess = nearest(str(key), SPRING_KEYS)
                hint = f"did you mean {guess!r}? " if guess else ""
                raise SceneError(path, f"{where}.{key}",
                                 f"unknown key {key!r}; {hint}valid: {', '.join(SPRING_KEYS)}")
        names.append(str(joint))
        values.append([_value(path, table, "stiffness", where, None),
                       _value(path, table, "damping", where, 0.0), _value(path, table, "rest", where, 0.0)])
    if not names:
        return NO_SPRINGS
    table_values = np.array(values, dtype=float)
    indices = np.array([list(coordinates).index(j) for j in names], dtype=int)
    arrays = (indices, table_values[:, 0].copy(), table_values[:, 1].copy(), table_values[:, 2].copy())
    for array in arrays:
        array.setflags(write=False)
    return JointSprings(tuple(names), *arrays)


@dataclass(frozen=True)
class JointTerms:
    """What a scene adds to its robot's coordinates: drives' inertia and damping, joint springs.

    Attributes:
        inertia: [kg m^2] per minimal coordinate index, added to the diagonal of M (Pinocchio's
            ``armature`` of the robot's own model, which CRBA adds): a drive's reflected inertia.
        damping: [N m s/rad] per minimal coordinate index: ``b v`` added to the bias h(q, v) (a DC
            motor's electrical damping, :mod:`frcontrol.drives`).
        springs: the joint springs, whose force ``k (q - rest) + c v`` is added to h.
    """

    inertia: Mapping[int, float] = field(default_factory=dict)
    damping: Mapping[int, float] = field(default_factory=dict)
    springs: JointSprings = NO_SPRINGS


def read_joint_terms(path: str, raw: Any, coordinates: Sequence[str], joints: Sequence[str],
                     inputs: Sequence[str], locked: Sequence[str], driven: DrivenJoints) -> JointTerms:
    """The :class:`JointTerms` of a scene, by coordinate.

    Its ``[model.springs]`` table (:func:`read_springs`, same arguments) and its drives' terms
    (``driven``, :func:`~frcontrol.drives.read_drives`).

    Raises:
        SceneError: as :func:`read_springs`.
    """
    springs = read_springs(path, raw, coordinates, joints, inputs, locked)
    index = {name: i for i, name in enumerate(coordinates)}
    return JointTerms({index[j]: value for j, value in driven.inertia.items()},
                      {index[j]: value for j, value in driven.damping.items()}, springs)


__all__ = ["JointSprings", "JointTerms", "NO_SPRINGS", "SPRING_KEYS", "read_joint_terms", "read_springs"]
