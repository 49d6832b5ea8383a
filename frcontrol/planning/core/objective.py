r"""The objective builders: a phase's objective as rows over the accelerations ``dv``.

Every objective is affine in ``dv``, and in a mode ``dv = X_u u + x_0`` is affine in the inputs:

- ``maximize`` / ``minimize = { coordinate = NAME }``: the row ``e_i`` (the coordinate's acceleration);
- ``maximize`` / ``minimize = { link, point, direction }``: the point's world acceleration along the
  unit direction ``n``, ``n^T (J dv + drift)`` (J and drift from
  :meth:`~frcontrol.model.PlanarRobot.point_kinematics` at the state);
- ``track = { coordinates, stiffness, damping, weights }``: the rows ``e_i`` of the named
  coordinates and their PD targets ``a*_i = k (target_i - q_i) - d v_i``; the plan minimises the
  weighted least-squares error ``sum_i (w_i (dv_i - a*_i))^2`` (one QP).

A phase's ``require`` list (conditions every plan meets) is built the same way, one row per
condition, into :class:`LimitRows` (``lower <= rows dv + offset <= upper``).

An :class:`ObjectiveRows` holds ``(rows, offset, targets, weights, sign)``: for maximise/minimise
one row with ``sign`` +1 / -1 (the plan maximises ``sign (rows dv + offset)``); for track the rows and
their targets.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...scene import Scene
from .task import Objective, Requirement

__all__ = ["LimitRows", "ObjectiveRows", "limit_rows", "objective_rows"]


@dataclass(frozen=True)
class ObjectiveRows:
    """A phase's objective at one state, over ``dv``.

    Attributes:
        kind: ``"maximize"``, ``"minimize"`` or ``"track"``.
        rows: (k, n) the rows C: the objective's quantities are ``C dv + offset``.
        offset: (k,) [m/s^2 or rad/s^2] (a point's drift along the direction; 0 otherwise).
        targets: (k,) track: the target accelerations a*; else empty.
        weights: (k,) track: each error's scale before it is squared; else empty.
        names: the quantities' names (coordinates, or ``link@point``).
        at_least: maximize/minimize: the floor of the quantity (worst case when robust), or None.
        limits: the phase's ``require`` conditions at the state, or None.
    """

    kind: str
    rows: np.ndarray
    offset: np.ndarray
    targets: np.ndarray
    weights: np.ndarray
    names: tuple[str, ...]
    at_least: float | None = None
    limits: LimitRows | None = None

    @property
    def sign(self) -> float:
        """+1 when larger is better (maximize), -1 for minimize (track has no sign: 0)."""
        return {"maximize": 1.0, "minimize": -1.0}.get(self.kind, 0.0)

    def value(self, dv: np.ndarray) -> float:
        """The objective at ``dv``: the quantity (maximize/minimize) or the weighted squared error (track)."""
        quantities = self.rows @ dv + self.offset
        if self.kind == "track":
            return float(np.sum((self.weights * (quantities - self.targets)) ** 2))
        return float(quantities[0])


def objective_rows(scene: Scene, objective: Objective, q: np.ndarray, v: np.ndarray) -> ObjectiveRows:
    """The objective's rows over ``dv`` at the state ``(q, v)`` (see the module's docstring)."""
    coords = list(scene.coordinate_names)
    n = scene.robot.nv
    if objective.kind == "track":
        names = tuple(objective.targets)
        idx = [coords.index(name) for name in names]
        rows = np.eye(n)[idx]
        goal = np.array([objective.targets[name] for name in names])
        targets = objective.stiffness * (goal - q[idx]) - objective.damping * v[idx]
        weights = np.array([objective.weights.get(name, 1.0) for name in names])
        return ObjectiveRows("track", rows, np.zeros(len(idx)), targets, weights, names)
    if objective.coordinate is not None:
        row = np.eye(n)[coords.index(objective.coordinate)][None, :]
        return ObjectiveRows(
            objective.kind,
            row,
            np.zeros(1),
            np.zeros(0),
            np.zeros(0),
            (objective.coordinate,),
            objective.at_least,
        )
    assert objective.link is not None and objective.point is not None and objective.direction is not None
    kin = scene.robot.point_kinematics(q, v, [(objective.link, np.asarray(objective.point))])
    direction = np.asarray(objective.direction, dtype=float)
    direction = direction / np.linalg.norm(direction)
    row = (direction @ kin.jacobians[0])[None, :]
    offset = np.array([float(direction @ kin.drifts[0])])
    name = f"{objective.link}@({objective.point[0]:g}, {objective.point[1]:g})"
    return ObjectiveRows(objective.kind, row, offset, np.zeros(0), np.zeros(0), (name,), objective.at_least)


@dataclass(frozen=True)
class LimitRows:
    """A phase's ``require`` at one state: ``lower <= rows dv + offset <= upper``.

    Attributes:
        rows: (k, n) one row per condition, over ``dv``.
        offset: (k,) [m/s^2 or rad/s^2] (a point's drift along the direction; 0 otherwise).
        lower: (k,) the floors (-inf where none).
        upper: (k,) the ceilings (+inf where none).
        names: the quantities' names.
    """

    rows: np.ndarray
    offset: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    names: tuple[str, ...]

    def violation(self, dv: np.ndarray) -> str | None:
        """The first condition ``dv`` breaks, in words, or None."""
        values = self.rows @ dv + self.offset
        for name, value, low, high in zip(self.names, values, self.lower, self.upper, strict=True):
            if not low <= value <= high:
                return f"{name}'s acceleration {value:.6g} is outside [{low:g}, {high:g}]"
        return None


def limit_rows(scene: Scene, requires: tuple[Requirement, ...], q: np.ndarray, v: np.ndarray) -> LimitRows:
    """The ``require`` conditions' rows over ``dv`` at the state ``(q, v)``."""
    built = [objective_rows(scene, r.quantity, q, v) for r in requires]
    n = scene.robot.nv
    return LimitRows(
        np.vstack([b.rows for b in built]) if built else np.zeros((0, n)),
        np.concatenate([b.offset for b in built]) if built else np.zeros(0),
        np.array([-np.inf if r.at_least is None else r.at_least for r in requires], dtype=float),
        np.array([np.inf if r.at_most is None else r.at_most for r in requires], dtype=float),
        tuple(b.names[0] for b in built),
    )
