"""A simulated (or planned) motion: the common currency of simulators, plots and viewers."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class ContactEvent:
    """Something that happened at a contact.

    ``kind`` is ``"open"``, ``"close"``, ``"impact"``, ``"stick"``, ``"slip"`` or ``"ambiguous"``
    (several rigid solutions existed at that instant).
    """

    time: float
    contact: str
    kind: str
    detail: str = ""


@dataclass(frozen=True)
class SimulationWarning:
    """A run left its model's validity without diverging (:mod:`frcontrol.simulation.validity`).

    Attributes:
        time: [s] when it first happened.
        kind: ``"energy"``, ``"penetration"`` or ``"speed"``.
        detail: what was seen and the limit, in one line.
    """

    time: float
    kind: str
    detail: str

    def to_dict(self) -> dict:
        """The warning as JSON: ``{"time", "kind", "detail"}``."""
        return {"time": self.time, "kind": self.kind, "detail": self.detail}


@dataclass(frozen=True)
class Trajectory:
    """Samples of a motion of a scene's robot.

    Attributes:
        scene_name: the scene's name.
        coordinates: names of the n minimal coordinates.
        contacts: names of ALL the scene's contacts (active or not), in scene order.
        times: sample times [s], shape (T,), increasing.
        q: configurations [m, rad], shape (T, n).
        v: velocities [m/s, rad/s], shape (T, n).
        inputs: applied inputs [N, N m], shape (T, m) (the input held over the step ending at
            that sample; row 0 repeats row 1).
        input_names: the m input coordinates.
        contact_forces: (lambda_n, lambda_t) per contact [N], shape (T, k, 2); zero when open.
            For impulse-based time stepping, the step's impulse divided by its duration.
        contact_points: world position of each contact point [m], shape (T, k, 2).
        events: contact events in time order.
        info: anything else the producer reports (model, step sizes, energy, drift, status...).
        warnings: where the run left its model's validity without diverging, in time order.
    """

    scene_name: str
    coordinates: tuple[str, ...]
    contacts: tuple[str, ...]
    times: np.ndarray
    q: np.ndarray
    v: np.ndarray
    inputs: np.ndarray
    input_names: tuple[str, ...]
    contact_forces: np.ndarray
    contact_points: np.ndarray
    events: tuple[ContactEvent, ...] = ()
    info: dict = field(default_factory=dict)
    warnings: tuple[SimulationWarning, ...] = ()

    @property
    def duration(self) -> float:
        """Last sample time minus the first [s]."""
        return float(self.times[-1] - self.times[0]) if len(self.times) else 0.0

    def coordinate(self, name: str) -> np.ndarray:
        """The samples of one coordinate."""
        return self.q[:, self.coordinates.index(name)]


__all__ = [
    "ContactEvent",
    "SimulationWarning",
    "Trajectory",
]
