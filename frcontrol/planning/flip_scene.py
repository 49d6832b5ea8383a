r"""What the flip reads from a scene: its body contacts, its pitch and the vertical pitch to pass.

A flip's ``[task]`` is either a task given as phases (``frc plan``'s format: the first phase keeps
its pivot loaded, its letters without S, names the body's other contacts, and maximises the pitch
coordinate's acceleration; a phase ends when the pitch passes vertical) or the dedicated keys
``body_contacts`` and ``pitch`` (default ``theta``). :func:`flip_task` reads either.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

from ..errors import SceneError
from ..scene import Scene

__all__ = ["VERTICAL_TOLERANCE", "FlipTask", "flip_task"]


@dataclass(frozen=True)
class FlipTask:
    """What the flip planner reads from the scene's ``[task]`` table.

    Attributes:
        body_contacts: names of the body's contacts (none may separate), in scene order.
        pitch: the pitch coordinate's name.
        pitch_index: its index in the minimal coordinates.
        initial_pitch: [rad] its value at the scene's state.
        vertical: [rad] the first pitch above ``initial_pitch`` at which the body stands vertical
            (``pi/2 + k pi``): the flip is done when the pitch passes it.
    """

    body_contacts: tuple[str, ...]
    pitch: str
    pitch_index: int
    initial_pitch: float
    vertical: float


def flip_task(scene: Scene) -> FlipTask:
    """The flip task of a scene: its ``[task]`` table, validated.

    ``body_contacts`` is required: a scene without it is not a flip scene (the planner would
    otherwise "flip" whatever touches the ground). ``pitch`` defaults to ``theta``.

    Raises:
        SceneError: ``[task]`` or ``task.body_contacts`` is missing, or ``[task]`` is malformed,
            names an unknown contact or coordinate.
    """
    task = scene.task
    path = str(scene.path)
    names = [c.name for c in scene.contacts]
    phased = _phased_flip(scene)
    if phased is not None:
        body_contacts, pitch_name = phased
        task = replace(task, body_contacts=body_contacts, pitch=pitch_name)
    if task.body_contacts is None:
        raise SceneError(path, "task.body_contacts", "missing: the flip needs [task] body_contacts, "
                         f"the body's contacts (from {', '.join(names) or 'no contact'}), and "
                         "optionally pitch, the body's pitch coordinate")
    body = list(task.body_contacts)
    if not body:
        raise SceneError(path, "task.body_contacts", f"expected a non-empty list of contact names "
                         f"from {names}, got {body!r}")
    for i, name in enumerate(body):
        if name not in names:
            raise SceneError(path, f"task.body_contacts[{i}]",
                             f"unknown contact {name!r}; the contacts are: {', '.join(names)}")
    chosen = set(body)
    pitch = task.pitch if task.pitch is not None else "theta"
    coords = scene.coordinate_names
    if not isinstance(pitch, str) or pitch not in coords:
        raise SceneError(path, "task.pitch", f"expected a coordinate name from {list(coords)}, got {pitch!r}")
    index = coords.index(pitch)
    initial = float(scene.q[index])
    vertical = math.pi / 2 + math.pi * (math.floor((initial - math.pi / 2) / math.pi) + 1)
    if phased is not None:
        _check_ends_at_vertical(scene, pitch, vertical)
    return FlipTask(tuple(n for n in names if n in chosen), pitch, index, initial, vertical)


VERTICAL_TOLERANCE = 1e-6
"""[rad] A task is a flip when a phase ends as its pitch passes vertical: the ``until`` threshold
equals the vertical pitch to this."""


def _check_ends_at_vertical(scene: Scene, pitch: str, vertical: float) -> None:
    """Raises SceneError unless a phase of the task ends when ``pitch`` passes ``vertical``."""
    phases = scene.raw["task"]["phases"]
    for phase in phases:
        until = phase.get("until", {})
        above = until.get("above")
        at_vertical = above is not None and abs(float(above) - vertical) <= VERTICAL_TOLERANCE
        if until.get("coordinate") == pitch and at_vertical:
            return
    raise SceneError(str(scene.path), f"task.phases[{len(phases) - 1}].until",
                     f"a flip ends when its pitch passes vertical: until = {{ coordinate = \"{pitch}\", "
                     f"above = {vertical!r} }} in a phase; frc plan runs any other task")


def _phased_flip(scene: Scene) -> tuple[tuple[str, ...], str] | None:
    """``(body_contacts, pitch)`` of a flip given as a task (``[[task.phases]]``), or None.

    The first phase is the push: its pivots are the contacts it keeps loaded (their allowed letters
    lack S); its body contacts are the contacts it names on a pivot's link, but those it keeps apart
    (S alone); its pitch is the coordinate it maximises.

    Raises:
        SceneError: the first phase does not maximise a coordinate or keeps no contact loaded.
    """
    raw = scene.raw.get("task")
    if not isinstance(raw, Mapping) or "phases" not in raw:
        return None
    first = raw["phases"][0]
    objective = first.get("maximize")
    if not isinstance(objective, Mapping) or "coordinate" not in objective:
        raise SceneError(str(scene.path), "task.phases[0].maximize",
                         "a flip's first phase maximises its pitch coordinate's acceleration "
                         "(maximize = { coordinate = \"theta\" }); frc plan runs any other task")
    modes = first.get("modes", {})
    links = {c.name: c.point.link for c in scene.contacts}
    pivots = {links[str(name)] for name, letters in modes.items() if "S" not in letters}
    body = tuple(str(name) for name, letters in modes.items()
                 if letters != "S" and links[str(name)] in pivots)
    if not body:
        raise SceneError(str(scene.path), "task.phases[0].modes",
                         "a flip's first phase keeps its body contacts loaded: give them letters "
                         "without S (modes = { front_corner = \"FLR\" })")
    return body, str(objective["coordinate"])
