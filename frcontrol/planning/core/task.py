"""A task as data: the ``[task]`` table with ``max_time``, ``repeat`` and ``[[task.phases]]``.

The format (``robots/scene.schema.json`` holds every key; ``docs/tasks.md`` explains it)::

    [task]
    max_time = 2.0                      # [s] of simulated time
    repeat = 1                          # the phases run this many times, in order
    [[task.phases]]
    name = "push"
    modes = { front_corner = "F" }      # allowed letters per contact (S, L, R, F); not named: any
    margin = 0.05                       # [input units] inside the allowed modes' unambiguous set
    robust = false                      # hold the modes at every vertex of every [[disturbances]]
    # largest_scale = { upper = 20.0 }  # robust: also the largest disturbance scale with a plan
    maximize = { coordinate = "theta" } # or minimize = ..., or track = { coordinates = {...}, ... }
    # maximize = { ..., at_least = 1.0 } # a plan's objective must reach this
    # require = [{ link = "link8", point = [0.2, 0.0], direction = [0.0, 1.0], at_least = 1.0 }]
    #                                   # conditions on accelerations every plan must meet
    until = { coordinate = "theta", above = 4.712 }   # or below, time, contact = { NAME = "closed" }

A task may name a *phase timing* (``timing = "pump"``, :mod:`.timing`): a small module that ends
the phases (the phases' ``until`` are then data it reads) and drives the phases that give no
objective (their inputs are its own, not a plan); ``repeat`` is then the most cycles it runs.

The scene loader has already checked the keys, the types and the names (unknown contacts, links and
coordinates name the nearest valid one); :func:`read_task` turns the table into records and
refuses what the schema cannot say (a scene without phases, robustness without disturbances).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import SceneError
from ...scene import Scene
from .. import DEFAULT_FLIP_MARGIN

__all__ = [
    "DEFAULT_MAX_TIME",
    "DEFAULT_PHASE_MARGIN",
    "Objective",
    "Phase",
    "Requirement",
    "Task",
    "Until",
    "read_task",
]

DEFAULT_MAX_TIME = 2.0
"""[s] Simulated time of a task whose ``[task]`` gives no ``max_time``."""

DEFAULT_PHASE_MARGIN = DEFAULT_FLIP_MARGIN
"""[input units] Margin of a phase that gives none: the distance (in input space) kept between a
plan and every input where a mode not allowed also holds."""

LETTERS = "SLRF"
"""The mode letters: S separate, L / R slide, F fixed."""


@dataclass(frozen=True)
class Objective:
    """What a phase optimises.

    Attributes:
        kind: ``"maximize"``, ``"minimize"``, ``"track"``, or ``"driven"`` (no objective: the task's
            phase timing gives the inputs).
        coordinate: the coordinate whose acceleration is optimised (maximize/minimize), or None.
        link, point, direction: the point (link frame [m]) whose world acceleration along
            ``direction`` is optimised, when no coordinate is given.
        targets: track: [m or rad] the target of each named coordinate.
        stiffness: track: [1/s^2] the PD target's stiffness.
        damping: track: [1/s] the PD target's damping.
        at_least: maximize/minimize: a plan's objective (worst case when robust) must be at least
            this, or None.
        weights: track: [-] each coordinate's error is multiplied by its weight before it is squared
            (a length turns an angular error into a distance).
    """

    kind: str
    coordinate: str | None = None
    link: str | None = None
    point: tuple[float, float] | None = None
    direction: tuple[float, float] | None = None
    targets: Mapping[str, float] = field(default_factory=dict)
    stiffness: float = 0.0
    damping: float = 0.0
    weights: Mapping[str, float] = field(default_factory=dict)
    at_least: float | None = None


@dataclass(frozen=True)
class Requirement:
    """A condition every plan of a phase meets: an acceleration within bounds (``require``).

    The quantity is a coordinate's acceleration, or a point's world acceleration along a
    direction (as for ``maximize``); a robust phase meets it at every disturbance vertex.

    Attributes:
        quantity: the quantity (an :class:`Objective` of kind ``"require"``).
        at_least: [m/s^2 or rad/s^2] its floor, or None.
        at_most: [m/s^2 or rad/s^2] its ceiling, or None.
    """

    quantity: Objective
    at_least: float | None = None
    at_most: float | None = None


@dataclass(frozen=True)
class Until:
    """When a phase ends: the first sample at which the condition holds.

    Attributes:
        kind: ``"coordinate"``, ``"time"`` or ``"contact"``.
        coordinate: the coordinate compared; ``above`` / ``below`` its threshold.
        time: [s] after the phase's start.
        contacts: per contact, ``"closed"`` or ``"open"``: every one must hold.
    """

    kind: str
    coordinate: str | None = None
    above: float | None = None
    below: float | None = None
    time: float | None = None
    contacts: Mapping[str, str] = field(default_factory=dict)

    def describe(self) -> str:
        """The condition in words (``theta above 4.712``)."""
        if self.kind == "coordinate":
            side, value = ("above", self.above) if self.above is not None else ("below", self.below)
            return f"{self.coordinate} {side} {value:g}"
        if self.kind == "time":
            return f"{self.time:g} s into the phase"
        return ", ".join(f"{name} {state}" for name, state in self.contacts.items())


@dataclass(frozen=True)
class Phase:
    """One phase of a task (see the module's docstring).

    Attributes:
        name: its name.
        modes: allowed letters per named contact (a contact not named allows every letter).
        margin: [input units] the distance kept from the inputs where another mode also holds.
        robust: hold the allowed modes at every vertex of the disturbance polytope.
        objective: what to optimise.
        until: when the phase ends.
        largest_scale: robust phases: the largest disturbance scale searched for at the phase's
            first decision (:mod:`~frcontrol.planning.core.scale`), or None.
        requires: conditions on the accelerations every plan meets (``require``).
    """

    name: str
    modes: Mapping[str, str]
    margin: float
    robust: bool
    objective: Objective
    until: Until
    largest_scale: float | None = None
    requires: tuple[Requirement, ...] = ()

    def allows(self, contacts: tuple[str, ...], mode: str) -> bool:
        """Whether ``mode`` (one letter per contact of ``contacts``) has only allowed letters."""
        return all(
            letter in self.modes.get(name, LETTERS) for name, letter in zip(contacts, mode, strict=True)
        )


@dataclass(frozen=True)
class Task:
    """A task: its phases, run in order ``repeat`` times within ``max_time``.

    Attributes:
        max_time: [s] the longest simulated time.
        repeat: how many times the phases run.
        phases: the phases, in order.
        raw: the ``[task]`` table as read (the report's ``task``).
        timing: the phase timing's name (``[task] timing``), or None.
    """

    max_time: float
    repeat: int
    phases: tuple[Phase, ...]
    raw: Mapping[str, Any]
    timing: str | None = None

    def sequence(self) -> list[Phase]:
        """Every phase the task runs, in order (``repeat`` times the phases)."""
        return list(self.phases) * self.repeat


def read_task(scene: Scene) -> Task:
    """The scene's ``[task]`` as a :class:`Task`.

    Raises:
        SceneError: no ``[task]`` or no ``phases`` (a dedicated planner's scene: the message says
            which command runs it), a robust phase in a scene without ``[[disturbances]]``, a mode
            letter set that allows no letter of a contact's allowed set.
    """
    path = str(scene.path)
    raw = scene.raw.get("task")
    if not isinstance(raw, Mapping) or "phases" not in raw:
        hint = _dedicated_hint(raw)
        raise SceneError(
            path,
            "task.phases",
            "missing: frc plan runs a task given as [[task.phases]] "
            f"(name, modes, margin, maximize/minimize/track, until){hint}",
        )
    timing = None if raw.get("timing") is None else str(raw["timing"])
    phases = tuple(_phase(scene, p, f"task.phases[{i}]", timing) for i, p in enumerate(raw["phases"]))
    return Task(
        float(raw.get("max_time", DEFAULT_MAX_TIME)), int(raw.get("repeat", 1)), phases, dict(raw), timing
    )


def _dedicated_hint(raw: Any) -> str:
    if not isinstance(raw, Mapping):
        return ""
    for key, command in (
        ("body_contacts", "frc flip"),
        ("head_link", "frc climb"),
        ("brace_contacts", "frc climb"),
        ("feet", "frc standup"),
    ):
        if key in raw:
            return f"; this scene's [task] is for {command}"
    return ""


def _phase(scene: Scene, raw: Mapping[str, Any], where: str, timing: str | None = None) -> Phase:
    kind = next((k for k in ("maximize", "minimize", "track") if k in raw), "driven")
    if kind == "driven" and timing is None:
        raise SceneError(
            str(scene.path),
            where,
            "a phase needs one of maximize, minimize, track (a phase without one is driven by the "
            "task's phase timing: [task] timing)",
        )
    if raw.get("robust", False) and not scene.disturbances:
        raise SceneError(
            str(scene.path),
            f"{where}.robust",
            "a robust phase needs [[disturbances]] "
            "(their vertices are the disturbances it must hold for); the scene has none",
        )
    if "largest_scale" in raw and not raw.get("robust", False):
        raise SceneError(
            str(scene.path),
            f"{where}.largest_scale",
            "the largest scale is that of the [[disturbances]] a robust phase holds for: add robust = true",
        )
    modes = {str(k): "".join(sorted(set(v), key=LETTERS.index)) for k, v in raw.get("modes", {}).items()}
    return Phase(
        str(raw["name"]),
        modes,
        float(raw.get("margin", DEFAULT_PHASE_MARGIN)),
        bool(raw.get("robust", False)),
        Objective("driven") if kind == "driven" else _objective(kind, raw[kind]),
        _until(raw["until"]),
        None if "largest_scale" not in raw else float(raw["largest_scale"]["upper"]),
        tuple(_requirement(r) for r in raw.get("require", ())),
    )


def _requirement(raw: Mapping[str, Any]) -> Requirement:
    quantity = _objective("require", {k: v for k, v in raw.items() if k not in ("at_least", "at_most")})
    return Requirement(
        quantity,
        None if "at_least" not in raw else float(raw["at_least"]),
        None if "at_most" not in raw else float(raw["at_most"]),
    )


def _objective(kind: str, raw: Mapping[str, Any]) -> Objective:
    if kind == "track":
        return Objective(
            kind,
            targets={str(k): float(v) for k, v in raw["coordinates"].items()},
            stiffness=float(raw.get("stiffness", 0.0)),
            damping=float(raw.get("damping", 0.0)),
            weights={str(k): float(v) for k, v in raw.get("weights", {}).items()},
        )
    at_least = None if "at_least" not in raw else float(raw["at_least"])
    if "coordinate" in raw:
        return Objective(kind, coordinate=str(raw["coordinate"]), at_least=at_least)
    direction = np.asarray(raw["direction"], dtype=float)
    return Objective(
        kind,
        link=str(raw["link"]),
        point=(float(raw["point"][0]), float(raw["point"][1])),
        direction=(float(direction[0]), float(direction[1])),
        at_least=at_least,
    )


def _until(raw: Mapping[str, Any]) -> Until:
    if "coordinate" in raw:
        return Until(
            "coordinate",
            coordinate=str(raw["coordinate"]),
            above=None if "above" not in raw else float(raw["above"]),
            below=None if "below" not in raw else float(raw["below"]),
        )
    if "time" in raw:
        return Until("time", time=float(raw["time"]))
    return Until("contact", contacts={str(k): str(v) for k, v in raw["contact"].items()})
