"""A simulated (or planned) motion: the common currency of simulators, plots and viewers."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, get_args

import numpy as np

from ..errors import InputError
from ..jsonable import to_jsonable
from .samples import drive_samples, sample_modes, stage_samples

if TYPE_CHECKING:
    from ..scene import Scene


EventKind = Literal["open", "close", "impact", "stick", "slip", "ambiguous"]
"""What happened at a contact (:class:`ContactEvent`)."""

WarningKind = Literal["energy", "penetration", "speed"]
"""Which validity limit a run left (:class:`SimulationWarning`)."""

TrajectoryStatus = Literal["completed", "failed", "diverged"]
"""How a run ended (:attr:`Trajectory.status`)."""

ContactModel = Literal["rigid", "compliant"]
"""The contact model that made a trajectory (:attr:`Trajectory.model`)."""


@dataclass(frozen=True)
class ContactEvent:
    """Something that happened at a contact.

    ``kind`` is ``"open"``, ``"close"``, ``"impact"``, ``"stick"``, ``"slip"`` or ``"ambiguous"``
    (several rigid solutions existed at that instant). ``values`` holds an event's numbers by name
    (an impact's ``impulse_normal`` [N s], ``normal_velocity_before`` [m/s]...).
    """

    time: float
    contact: str
    kind: EventKind
    detail: str = ""
    values: Mapping[str, Any] = field(default_factory=dict, hash=False)

    def to_dict(self) -> dict:
        """The event as JSON: ``{"time", "contact", "kind", "detail"}`` and its ``values``."""
        return {"time": self.time, "contact": self.contact, "kind": self.kind, "detail": self.detail,
                **self.values}


@dataclass(frozen=True)
class SimulationWarning:
    """A run left its model's validity without diverging (:mod:`frcontrol.simulation.validity`).

    Attributes:
        time: [s] when it first happened.
        kind: ``"energy"``, ``"penetration"`` or ``"speed"``.
        detail: what was seen and the limit, in one line.
    """

    time: float
    kind: WarningKind
    detail: str

    def to_dict(self) -> dict:
        """The warning as JSON: ``{"time", "kind", "detail"}``."""
        return {"time": self.time, "kind": self.kind, "detail": self.detail}


@dataclass(frozen=True)
class SimulationFailure:
    """Why a run ended before its duration (:attr:`Trajectory.failure`).

    Attributes:
        time: [s] when it happened (the trajectory is cut at the last good sample).
        reason: what went wrong, in one line.
        hint: what to change (smaller step, stiffer integrator...), or "" when there is none.
    """

    time: float
    reason: str
    hint: str = ""

    def to_dict(self) -> dict:
        """The failure as JSON: ``{"time", "reason"}``, plus ``"hint"`` when there is one."""
        out: dict[str, Any] = {"time": self.time, "reason": self.reason}
        if self.hint:
            out["hint"] = self.hint
        return out


TRAJECTORY_STATUSES: tuple[TrajectoryStatus, ...] = get_args(TrajectoryStatus)
"""The values of :attr:`Trajectory.status`."""


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
        info: the producer's own report: its settings, step counts and per-sample diagnostics
            (energies, penetration...), read by :meth:`to_dict`. Never a status: see below.
        warnings: where the run left its model's validity without diverging, in time order.
        model: the model that produced the run, ``"rigid"`` or ``"compliant"``; None for a
            motion that no simulator produced (a scene's still state).
        status: ``"completed"``, ``"failed"`` (the solver gave up) or ``"diverged"`` (the state
            left the numbers or its energy blew up): one of :data:`TRAJECTORY_STATUSES`.
        failure: why the run ended early; None when it completed.
        modes: per sample, one contact-mode letter (S, L, R, F) per contact, when the producer
            knows them (a planner's closed loop); None otherwise.
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
    model: ContactModel | None = None
    status: TrajectoryStatus = "completed"
    failure: SimulationFailure | None = None
    modes: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        if self.status not in TRAJECTORY_STATUSES:
            raise InputError(f"status must be one of {', '.join(TRAJECTORY_STATUSES)}, got {self.status!r}")
        if (self.failure is None) != (self.status == "completed"):
            raise InputError(f"a {self.status} run must {'not ' if self.status == 'completed' else ''}"
                             "carry a failure")

    @property
    def completed(self) -> bool:
        """Whether the run reached its duration."""
        return self.status == "completed"

    @property
    def duration(self) -> float:
        """Last sample time minus the first [s]."""
        return float(self.times[-1] - self.times[0]) if len(self.times) else 0.0

    def coordinate(self, name: str) -> np.ndarray:
        """The samples of one coordinate."""
        return self.q[:, self.coordinates.index(name)]

    def to_dict(self, scene: Scene | None = None, *, every: int = 1) -> dict[str, Any]:
        """The run as JSON values: the ``frc simulate --json`` document.

        ``every`` > 1 keeps every ``every``-th sample and the last one (:func:`every_nth_sample`;
        ``summary.sample_every`` says which); the summary and the events are the whole run's.

        Its parts are ``summary``, ``samples`` (times, q, v, inputs, forces, energy,
        max_penetration) and ``warnings``.

        With the scene, the samples also carry every contact's mode per sample
        (:func:`~frcontrol.simulation.export.sample_modes`) and each event the mode its contact left
        and entered (``from``, ``to``: the letters of the samples before and at the event), and each
        joint spring's ``deflection`` and ``force`` per sample (``samples.springs.JOINT``). Fields a
        producer did not report (a planner's trajectory has no energy) are null.
        """
        info = self.info
        energy = np.asarray(info["energy"]) if "energy" in info else None
        penetration = np.asarray(info["max_penetration"]) if "max_penetration" in info else None
        summary: dict[str, Any] = {
            "scene": self.scene_name,
            "model": self.model,
            "status": self.status,
            "failure": None if self.failure is None else self.failure.to_dict(),
            "steps": info.get("steps"),
            "dt": info.get("dt"),
            "duration": self.duration,
            "coordinates": list(self.coordinates),
            "contacts": list(self.contacts),
            "inputs": list(self.input_names),
            "final_q": self.q[-1],
            "final_v": self.v[-1],
            "events": [e.to_dict() for e in self.events],
            "energy": None if energy is None else {
                "initial": energy[0], "final": energy[-1],
                "largest_increase": float(np.max(np.diff(energy), initial=0.0))},
            "max_penetration": None if penetration is None else float(np.max(penetration)),
            "armature": info.get("armature"),
            "wall_time": info.get("wall_time"),
        }
        if self.model == "rigid" and "lcp" in info:  # the rigid stepper's own report
            summary["lcp"] = info["lcp"]
            summary["tolerances"] = info["tolerances"]
            summary["ambiguity_checks"] = info["ambiguity_checks"]
            summary["stabilization_work"] = float(info["stabilization_work"][-1])
            summary["impacts"] = info.get("impacts", [])
            summary["restitution"] = info.get("restitution")
        elif self.model == "compliant" and "integrator" in info:
            summary.update({key: info[key] for key in (
                "integrator", "rtol", "atol", "min_step", "max_step_taken", "mean_step", "rhs_evaluations",
                "state_size", "contacts_modelled", "explicit_stability_limit")})
            summary["contact_parameters"] = info["contacts"]
            summary["zones"] = info.get("zones_parameters", {})
            summary["zone_landing_energy"] = info.get("zone_landing_energy", 0.0)
            summary["elastic_energy_final"] = float(info["elastic_energy"][-1])
        if not np.isfinite(summary.get("explicit_stability_limit", 0.0)):
            summary["explicit_stability_limit"] = None
        summary["validity"] = info.get("validity")
        samples: dict[str, Any] = {"times": self.times, "q": self.q, "v": self.v, "inputs": self.inputs,
                                   "forces": self.contact_forces, "energy": energy,
                                   "max_penetration": penetration}
        if info.get("zones"):  # the compliant model's contact zones: deformation [m], force [N]
            samples["zones"] = info["zones"]
        if scene is not None:
            self._add_scene_parts(scene, summary, samples)
        summary["sample_every"] = check_sample_every(every)
        summary["samples_kept"] = len(every_nth_sample(len(self.times), every))
        if every > 1:
            samples = _kept_samples(samples, every_nth_sample(len(self.times), every))
        return to_jsonable({"summary": summary, "samples": samples,
                            "warnings": [w.to_dict() for w in self.warnings]})

    def _add_scene_parts(self, scene: Scene, summary: dict[str, Any], samples: dict[str, Any]) -> None:
        """What :meth:`to_dict` reports with the scene: input units, springs, drives, modes."""
        summary["input_units"] = scene.inputs.unit_map()
        if scene.robot.springs:  # the joint springs: deflection [m or rad], force [N or N m]
            summary["springs"] = scene.robot.springs.to_dict()
            samples["springs"] = scene.robot.springs.samples(self.q, self.v)
        if scene.drives:
            samples["drives"] = drive_samples(scene, self)
            if any(d.elastic for d in scene.drives.values()):
                samples["stages"] = stage_samples(scene, self)

        modes = sample_modes(scene, self)
        samples["modes"] = list(modes)
        for event in summary["events"]:
            if event["contact"] not in self.contacts:
                continue  # an "ambiguous" event names every touching contact, comma-separated
            at = min(int(np.searchsorted(self.times, event["time"] - 1e-12)), len(modes) - 1)
            i = self.contacts.index(event["contact"])
            event["from"], event["to"] = modes[max(at - 1, 0)][i], modes[at][i]


def check_sample_every(every: Any) -> int:
    """``every`` as an int >= 1 (keep every N-th sample).

    Raises:
        InputError: not an integer >= 1.
    """
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise InputError(f"every must be an integer >= 1 (keep every N-th sample), got {every!r}")
    return int(every)


def every_nth_sample(count: int, every: int) -> np.ndarray:
    """The indices of the samples kept: 0, every, 2 every, ... and always the last (count - 1)."""
    kept = np.arange(0, count, check_sample_every(every))
    if count and kept[-1] != count - 1:
        kept = np.append(kept, count - 1)
    return kept


def _kept_samples(node: Any, kept: np.ndarray) -> Any:
    """``node`` (the samples' tables) with every per-sample series cut to the ``kept`` indices.

    A series is an array or list whose first length is the number of samples (``kept[-1] + 1``).
    """
    count = int(kept[-1]) + 1 if kept.size else 0
    if isinstance(node, dict):
        return {key: _kept_samples(value, kept) for key, value in node.items()}
    if isinstance(node, np.ndarray) and node.ndim >= 1 and node.shape[0] == count:
        return node[kept]
    if isinstance(node, (list, tuple)) and len(node) == count:
        return [node[i] for i in kept]
    return node


__all__ = [
    "check_sample_every",
    "every_nth_sample",
    "ContactEvent",
    "SimulationFailure",
    "SimulationWarning",
    "TRAJECTORY_STATUSES",
    "Trajectory",
]
