"""Overrides that change only numbers, applied to a loaded scene without loading it again.

Loading a scene (:func:`~frcontrol.scene.load_scene`) reads the TOML, checks it against the schema,
builds the robot's Pinocchio model and places its contacts: about half a millisecond for the rod,
twenty times one ``solutions_at``. A sweep that changes only a number of the scene from point to
point (an atlas's ``--vary state.q.theta=...``) does not need all of it. :func:`scene_with_numbers`
gives the scene that :func:`~frcontrol.scene.load_scene` gives with the same overrides, from a scene
already loaded without them, for the *numeric* overrides (:func:`is_numeric_path`):

- ``state.q.NAME`` and ``state.v.NAME``: one coordinate of the state, by name. The contacts are
  placed again at the new state exactly as the loader places them: a contact without
  ``surface_point`` follows its contact point (gap 0), the others get their gap and activity at
  the new state, and a contact penetrating deeper than the scene's gap tolerance is the loader's
  :class:`~frcontrol.errors.SceneError`.
- ``contacts.NAME.mu``: one contact's Coulomb coefficient [-] (>= 0, as the schema requires).

Anything else (a locked joint's coordinate, a mass, gravity, a contact's geometry, a list by
index) changes the model or its structure: it is not numeric here, and a caller loads the scene
with it. The arrays the override touches are the only ones made again; the robot is the scene
given's, or where a contact's surface point or friction changed, the same robot with the new
contacts (:meth:`~frcontrol.model.PlanarRobot.with_contact_points`: the Pinocchio model and data
are shared, a workspace each call overwrites).
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Mapping
from functools import lru_cache
from typing import Any

import numpy as np

from .model import ContactPoint
from .records import replaced
from .scene import Contact, Scene, _contacts_at_state, _coordinate_path, _Reader

MU_PATH_FIELD = "mu"
"""The contact field :func:`is_numeric_path` takes as a number (``contacts.NAME.mu``)."""


@lru_cache(maxsize=1024)
def _contact_mu_name(path: str) -> str | None:
    """``"tip"`` for ``contacts.tip.mu`` (a contact by name), else None.

    Kept per path: an atlas asks for the same few at every point.
    """
    parts = path.split(".")
    if len(parts) == 3 and parts[0] == "contacts" and parts[2] == MU_PATH_FIELD and "[" not in path \
            and not parts[1].isdigit():
        return parts[1]
    return None


def numeric_syntax(path: str) -> bool:
    """Whether ``path`` has the form of a numeric override, whatever the scene.

    The forms: ``state.q.NAME``, ``state.v.NAME``, ``contacts.NAME.mu`` (:func:`is_numeric_path`
    checks the names against a scene).
    """
    return _coordinate_path(path) is not None or _contact_mu_name(path) is not None


def is_friction_path(path: str) -> bool:
    """Whether ``path`` sets a contact's Coulomb coefficient by name (``contacts.NAME.mu``)."""
    return _contact_mu_name(path) is not None


def is_numeric_path(scene: Scene, path: str) -> bool:
    """Whether :func:`scene_with_numbers` can apply an override of ``path`` to ``scene``.

    True for ``state.q.NAME`` and ``state.v.NAME`` with NAME one of the scene's coordinates (not a
    locked joint) and for ``contacts.NAME.mu`` with NAME one of its contacts.
    """
    coordinate = _coordinate_path(path)
    if coordinate is not None:
        return coordinate[1] in scene.coordinate_names
    name = _contact_mu_name(path)
    return name is not None and any(c.name == name for c in scene.contacts)


def scene_with_numbers(scene: Scene, overrides: Mapping[str, Any], bare_coordinates: tuple[str, ...]
                       ) -> Scene:
    """The scene :func:`~frcontrol.scene.load_scene` gives with ``overrides`` on top of ``scene``'s own.

    Args:
        scene: a loaded scene (its own overrides already applied).
        overrides: numeric overrides only (:func:`is_numeric_path`), ``{path: number}``.
        bare_coordinates: the robot's coordinates before locking, the order of ``[state]``'s lists
            (the scene's own when no joint is locked).

    Raises:
        SceneError: a value that is not a finite number, a negative ``mu``, a path that is not
            numeric, or a contact penetrating its surface at the new state (the loader's message).
    """
    reader = _Reader(scene.path)
    q, v = scene.q, scene.v
    raw = dict(scene.raw)
    index = {c.name: i for i, c in enumerate(scene.contacts)}
    mu = [c.mu for c in scene.contacts]
    for path, value in overrides.items():
        number = reader.number(value, path)
        place = _state_place(path, scene.coordinate_names)
        name = _contact_mu_name(path)
        if place is not None:
            q, v = _with_coordinate(q, v, place, number)
            _set_raw_state(raw, place[0], bare_coordinates, scene.coordinate_names[place[1]], number)
        elif name is not None and name in index:
            _check_friction(reader, path, number)
            mu[index[name]] = number
            _set_raw_mu(raw, index[name], number)
        else:
            raise reader.fail(path, "not a numeric override of this scene (load the scene with it)")
    points = [c.point if c.mu == m else _point(c.point, c.point.surface_point_in_world, m)
              for c, m in zip(scene.contacts, mu, strict=True)]
    if q is not scene.q:
        points, contacts = _placed_at(reader, scene, points, q)
    else:
        contacts = [c if c.point is p else Contact(p, c.gap, c.active)
                    for c, p in zip(scene.contacts, points, strict=True)]
    robot = scene.robot
    if any(p is not c for p, c in zip(points, robot.contacts, strict=True)):
        robot = robot.with_contact_points(points)
    return replaced(scene, q=q, v=v, contacts=tuple(contacts), raw=raw, robot=robot)


def friction_with_numbers(scene: Scene, overrides: Mapping[str, Any]) -> np.ndarray:
    """The active contacts' Coulomb coefficients [-] with ``overrides`` set, as a problem holds them.

    ``np.array([c.mu for c in active], dtype=float)`` of :func:`scene_with_numbers`'s scene, without
    making it: friction changes no other number of the scene's problem (its state, its contacts'
    places and activity stay). Values that are plain finite floats >= 0 on the scene's contacts are
    set at once (an atlas's points); any other goes through the loader's checks, which say what is
    wrong.

    Args:
        scene: a scene (its own overrides applied).
        overrides: ``{contacts.NAME.mu: number}`` only (:func:`is_friction_path`).

    Raises:
        SceneError: as :func:`scene_with_numbers`: a value that is not a finite number, a negative
            ``mu``, a path that is not a friction override of this scene.
    """
    places = _FRICTION_PLACES.get(scene)
    if places is None:
        places = _FRICTION_PLACES[scene] = _friction_places(scene)
    by_name, active_mu = places
    mu = active_mu.copy()
    for path, value in overrides.items():
        place = by_name.get(_contact_mu_name(path), None)  # type: ignore[arg-type]  # None: no contact
        if place is None or type(value) is not float or not 0.0 <= value < math.inf:
            return _checked_friction(scene, overrides)
        if place >= 0:
            mu[place] = value
    return mu


def state_with_numbers(scene: Scene, overrides: Mapping[str, Any]
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None] | None:
    """The state ``(q, v)`` and the active contacts' coefficients with ``overrides`` set, or None.

    The coefficients are None where no friction is set (the scene's).

    A contact whose table gives no ``surface_point`` touches a surface through its own point at any
    state (the loader places it there): when every contact is such, a state moves no contact into
    or out of touch, so the problem at another state needs the state alone, not the scene made
    with it (:func:`scene_with_numbers`). None for a scene with a contact on a fixed surface, a
    value that is not a plain finite float, or a path that is not a coordinate's or a contact's
    friction: :func:`scene_with_numbers` then makes the scene, with the loader's checks and errors.
    """
    follows = _FOLLOWS_STATE.get(scene)
    if follows is None:
        follows = _FOLLOWS_STATE[scene] = all(_pending_surfaces(scene))
    if not follows:
        return None
    q, v = scene.q, scene.v
    friction: dict[str, Any] = {}
    for path, value in overrides.items():
        if type(value) is not float or not math.isfinite(value):
            return None
        place = _state_place(path, scene.coordinate_names)
        if place is not None:
            q, v = _with_coordinate(q, v, place, value)
        elif is_friction_path(path):
            friction[path] = value
        else:
            return None
    return q, v, (friction_with_numbers(scene, friction) if friction else None)


@lru_cache(maxsize=1024)
def _state_place(path: str, coordinates: tuple[str, ...]) -> tuple[str, int] | None:
    """``("q", 2)`` for ``state.q.theta`` where ``theta`` is ``coordinates[2]``, else None (kept per path)."""
    coordinate = _coordinate_path(path)
    if coordinate is None or coordinate[1] not in coordinates:
        return None
    return coordinate[0], coordinates.index(coordinate[1])


def _with_coordinate(q: np.ndarray, v: np.ndarray, place: tuple[str, int], number: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """``(q, v)`` with the coordinate at ``place`` (:func:`_state_place`) set to ``number`` (in a copy)."""
    vector, index = place
    target = q.copy() if vector == "q" else v.copy()
    target[index] = number
    return (target, v) if vector == "q" else (q, target)


_FOLLOWS_STATE: weakref.WeakKeyDictionary[Scene, bool] = weakref.WeakKeyDictionary()
"""Per scene: whether every contact's surface follows the state (:func:`state_with_numbers`)."""


def _friction_places(scene: Scene) -> tuple[dict[str, int], np.ndarray]:
    """Per contact name its place among the active contacts (-1: inactive), and their coefficients."""
    active = [c for c in scene.contacts if c.active]
    places = {c.name: -1 for c in scene.contacts}
    places.update({c.name: i for i, c in enumerate(active)})
    return places, np.array([c.mu for c in active], dtype=float)


_FRICTION_PLACES: weakref.WeakKeyDictionary[Scene, tuple[dict[str, int], np.ndarray]] = \
    weakref.WeakKeyDictionary()
""":func:`_friction_places` of the scenes friction was last set on (a scene is hashed by identity)."""


def _checked_friction(scene: Scene, overrides: Mapping[str, Any]) -> np.ndarray:
    """:func:`friction_with_numbers` with every value read by the loader's rules (and its errors)."""
    reader = _Reader(scene.path)
    mu = {c.name: c.mu for c in scene.contacts}
    for path, value in overrides.items():
        number = reader.number(value, path)
        name = _contact_mu_name(path)
        if name is None or name not in mu:
            raise reader.fail(path, "not a friction override of this scene (contacts.NAME.mu)")
        _check_friction(reader, path, number)
        mu[name] = number
    return np.array([mu[c.name] for c in scene.contacts if c.active], dtype=float)


def _check_friction(reader: _Reader, path: str, number: float) -> None:
    """Refuse a negative Coulomb coefficient (the schema's rule)."""
    if number < 0:
        raise reader.fail(path, f"friction coefficient must be >= 0, got {number}")


def _placed_at(reader: _Reader, scene: Scene, points: list[ContactPoint], q: np.ndarray
               ) -> tuple[list[ContactPoint], list[Contact]]:
    """The contact points and contacts at ``q``, as the loader places them (module docstring)."""
    world = scene.robot.contact_points_in_world(q)
    pending = _pending_surfaces(scene)
    points = [_point(p, world[i].copy(), p.mu) if pending[i] else p for i, p in enumerate(points)]
    return points, _contacts_at_state(reader, points, world, scene.gap_tolerance)


def _point(point: ContactPoint, surface_point_in_world: np.ndarray, mu: float) -> ContactPoint:
    """``point`` with another surface point [m] and Coulomb coefficient [-]."""
    return ContactPoint(point.name, point.link, point.point_in_link, point.normal_in_world,
                        surface_point_in_world, mu)


def _pending_surfaces(scene: Scene) -> list[bool]:
    """For each contact, whether its table gives no ``surface_point`` (it follows the state)."""
    tables = scene.raw.get("contacts", [])
    return [isinstance(t, Mapping) and "surface_point" not in t for t in tables]


def _set_raw_state(raw: dict[str, Any], vector: str, bare_coordinates: tuple[str, ...], name: str,
                   number: float) -> None:
    """``raw["state"][vector]`` with the coordinate ``name`` set (new tables: ``raw`` is a copy)."""
    state = dict(raw.get("state", {}))
    values = list(state.get(vector, [0.0] * len(bare_coordinates)))
    values[bare_coordinates.index(name)] = number
    state[vector] = values
    raw["state"] = state


def _set_raw_mu(raw: dict[str, Any], index: int, number: float) -> None:
    """``raw["contacts"]`` with contact ``index``'s ``mu`` set (new tables: ``raw`` is a copy)."""
    raw["contacts"] = [{**t, "mu": number} if i == index else t for i, t in enumerate(raw["contacts"])]


__all__ = [
    "MU_PATH_FIELD",
    "friction_with_numbers",
    "is_friction_path",
    "is_numeric_path",
    "numeric_syntax",
    "scene_with_numbers",
    "state_with_numbers",
]
