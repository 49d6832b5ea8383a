"""Where a scene comes from, in a form that another process (or machine) can load again.

Work that loads a scene elsewhere (an atlas's chunks in worker processes or on a Dask cluster)
carries a :class:`SceneSource` instead of a loaded :class:`~frcontrol.scene.Scene`: text only, so
that it crosses a process boundary as strings, and every process rebuilds the same scene from it.
A source is one of:

- ``file``: a scene file, or a shipped scene's name (``frc atlas SCENE``); loaded exactly as
  :func:`~frcontrol.scene.load_scene` loads it, its robot next to the file or shipped. Only a
  program's own arguments make one: never a request.
- ``shipped``: a shipped scene's name, checked against the list of shipped scenes (a name is never
  used as a path); loaded as a document, so that its robot stays a shipped URDF whatever the
  overrides say.
- ``toml`` or ``json``: the scene's content (its TOML text, or the JSON text of its tables), with
  URDF texts it may name as its robot by bare file name; loaded with
  :func:`~frcontrol.scene.scene_from_document`. The URDFs are written to a private temporary folder
  for the time of the load (Pinocchio reads files) and removed after it; nothing is read from a
  path the content names.
"""

from __future__ import annotations

import hashlib
import json
import tempfile
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import SceneError
from .scene import (
    Scene,
    load_scene,
    read_scene_document,
    resolve_scene_path,
    scene_from_document,
    scene_toml,
    shipped_robots_dir,
    shipped_scene_names,
)
from .scene_schema import nearest

CONTENT_SOURCE = "scene"
"""What a scene sent as content is called in messages and results (it has no file name)."""

KINDS = ("file", "shipped", "toml", "json")
"""The kinds of :class:`SceneSource`."""


@dataclass(frozen=True)
class SceneSource:
    """A scene to load (module docstring): its kind, its text, and URDF texts sent with it.

    Attributes:
        kind: one of :data:`KINDS`.
        text: the file's path (``file``), the shipped scene's name (``shipped``), or the content.
        label: what a result calls the scene: the argument as given, or :data:`CONTENT_SOURCE`.
        robots: ``(file name, URDF text)`` pairs a content scene may name as its ``robot``.
    """

    kind: str
    text: str
    label: str
    robots: tuple[tuple[str, str], ...] = ()

    @classmethod
    def file(cls, name_or_path: str | Path) -> SceneSource:
        """A scene file, or a shipped scene's name, as ``frc`` commands take it.

        Raises:
            SceneError: no such file and no shipped scene of that name (the nearest is named).
        """
        return cls("file", str(resolve_scene_path(name_or_path)), str(name_or_path))

    @classmethod
    def shipped(cls, name: str) -> SceneSource:
        """A shipped scene by name (``rod_on_table`` or ``rod_on_table.toml``), never a path.

        Raises:
            SceneError: no shipped scene of that name (the nearest and the list in the message).
        """
        stem = name.removesuffix(".toml")
        names = shipped_scene_names()
        if stem not in names:  # checked against the list: a name is never used as a path
            guess = nearest(stem, names)
            hint = f"did you mean {guess!r}? " if guess else ""
            raise SceneError(name, "", f"no shipped scene of that name (a scene is sent by a shipped "
                             f"scene's name or as content); {hint}shipped scenes: {', '.join(names)}")
        return cls("shipped", stem, name)

    @classmethod
    def content(cls, *, toml: str | None = None, document: Mapping[str, Any] | None = None,
                robots: Mapping[str, str] | None = None) -> SceneSource:
        """A scene's content: its TOML text or its tables (the JSON form), and URDF texts by file name.

        Raises:
            SceneError: neither or both forms given, malformed TOML, tables that are not JSON, or a
                URDF name that is not a bare ``*.urdf`` file name.
        """
        if (toml is None) == (document is None):
            raise SceneError(CONTENT_SOURCE, "", "give the scene as exactly one of its TOML text or its "
                             "tables")
        pairs = tuple(sorted((robots or {}).items()))
        for name, _ in pairs:
            if not name.endswith(".urdf") or name != Path(name).name or name.startswith("."):
                raise SceneError(CONTENT_SOURCE, "robot", f"{name!r} is not a URDF file name (a bare name "
                                 "ending in .urdf)")
        if toml is not None:
            _parse_toml(toml)
            return cls("toml", toml, CONTENT_SOURCE, pairs)
        try:
            text = json.dumps(dict(document or {}), allow_nan=False)
        except (TypeError, ValueError) as err:
            raise SceneError(CONTENT_SOURCE, "", f"the scene's tables are not JSON: {err}") from err
        return cls("json", text, CONTENT_SOURCE, pairs)

    def digest(self) -> str:
        """SHA-256 of what the scene is made of: the file's bytes, or the content and URDF texts."""
        if self.kind in ("file", "shipped"):
            return hashlib.sha256(self._path().read_bytes()).hexdigest()
        parts = [self.kind, self.text, *(f"{name}\n{urdf}" for name, urdf in self.robots)]
        return hashlib.sha256("\0".join(parts).encode("utf-8")).hexdigest()

    def _path(self) -> Path:
        if self.kind == "file":
            return Path(self.text)

        return shipped_robots_dir() / "scenes" / f"{self.text}.toml"

    @contextmanager
    def loaded(self, overrides: Mapping[str, Any] | None = None) -> Iterator[Scene]:
        """The validated scene with ``overrides`` (the ``--set`` grammar), its URDF there until the end.

        Raises:
            SceneError: everything :func:`~frcontrol.scene.load_scene` (a file) or
                :func:`~frcontrol.scene.scene_from_document` (a shipped name, content) refuses.
        """
        if self.kind == "file":
            yield load_scene(self.text, overrides=overrides)
            return
        if self.kind == "shipped":
            path = self._path()
            yield scene_from_document(read_scene_document(path), source=str(path), overrides=overrides)
            return
        document = _parse_toml(self.text) if self.kind == "toml" else json.loads(self.text)
        if not self.robots:
            yield scene_from_document(document, source=CONTENT_SOURCE, overrides=overrides)
            return
        with tempfile.TemporaryDirectory(prefix="frc-scene-") as folder:
            files = {}
            for name, urdf in self.robots:
                files[name] = Path(folder) / name
                files[name].write_text(urdf, encoding="utf-8")
            yield scene_from_document(document, source=CONTENT_SOURCE, robot_files=files, overrides=overrides)

    def load(self, overrides: Mapping[str, Any] | None = None) -> Scene:
        """The validated scene with ``overrides`` (as :meth:`loaded`; its URDF may be gone after)."""
        with self.loaded(overrides) as scene:
            return scene


def _parse_toml(text: str) -> dict[str, Any]:

    return scene_toml(text, CONTENT_SOURCE)


__all__ = [
    "CONTENT_SOURCE",
    "KINDS",
    "SceneSource",
]
