"""An atlas's grid and its chunks: a pure plan, built and checked without solving anything.

``frc atlas SCENE --vary PATH=START:STOP:N ...`` sweeps a scene over a grid. Each axis varies one
path: a scene field in the ``--set`` grammar (``contacts.tip.mu``, ``gravity``, ``model.stiffness``,
one coordinate ``state.q.theta`` / ``state.v.x``), or an input's value, ``input.NAME``. An axis's
values are ``numpy.linspace(START, STOP, N)``; value ``i`` alone is computed in O(1) as
``START + i * ((STOP - START) / (N - 1))``, the last one exactly ``STOP`` (bit for bit what
``numpy.linspace`` gives: :meth:`Axis.value`). The grid is the product of the axes, the first axis
the outermost: point ``k`` of a grid of shape ``(n_0, n_1, ...)`` sits at the multi-index
``numpy.unravel_index(k, shape)`` (C order), and every array of the result is nested that way. A
grid of more than ``max_points`` points (:data:`MAX_ATLAS_POINTS` unless raised) is refused before
the scene is loaded.

The points go in chunks of consecutive indices, the unit of work of every executor and of the
output file. The chunk size depends on the grid alone (never on the workers), so a run resumed with
other workers finds the same chunks. The plan's *fingerprint* (a SHA-256 of frcontrol's version,
the scene file, its URDF, the kind, the axes, the fixed inputs and overrides, and the chunk size)
tells whether stored chunks belong to it.

The scene is a :class:`~frcontrol.scene_source.SceneSource`: a file or a shipped scene's name (the
command's SCENE), or the scene's content (``frc serve``'s ``POST /atlas``), which every worker
rebuilds from text; the fingerprint covers the content and the URDF texts sent with it.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np

from ..errors import CoordinateNotFound, InputError, SceneError
from ..scene import Scene, parse_input_assignments
from ..scene_schema import apply_override, nearest
from ..scene_source import SceneSource

WHATS = ("solutions", "statics", "flip", "climb")
"""What an atlas computes at every point (``--what``)."""

INPUT_PREFIX = "input."
"""An axis path ``input.NAME`` varies the input NAME (as ``--input NAME=VALUE`` sets it)."""

TARGET_CHUNKS = 256
"""The number of chunks a grid is cut into when its points allow (enough to balance many workers
and to lose little work to an interruption)."""

MAX_CHUNK_POINTS = 64
"""The most points in one chunk (a rod point costs about 2 ms: a chunk of 64, about 0.15 s)."""

MAX_ATLAS_POINTS = 100_000
"""[points] The point budget of one atlas: the most grid points :func:`build_atlas` accepts unless
its ``max_points`` raises it (``frc atlas --max-points``); ``frc serve``'s ``POST /atlas`` takes at
most this many (a finished job keeps its result in the server's memory, a few megabytes at this
size). At about 2 ms a point, a grid at the budget is a few minutes of one core."""

FORMAT_VERSION = 1
"""The version of the stored chunks and of the fingerprint's recipe."""


@dataclass(frozen=True)
class Axis:
    """One varied path: ``numpy.linspace(start, stop, count)``.

    Attributes:
        path: a scene path (``contacts.tip.mu``, ``state.q.theta``) or ``input.NAME``.
        start, stop: the first and last values, in the field's units (radians for angles).
        count: the number of values, >= 1.
    """

    path: str
    start: float
    stop: float
    count: int

    @property
    def values(self) -> np.ndarray:
        """The axis's values, ``numpy.linspace(start, stop, count)``."""
        return np.linspace(self.start, self.stop, self.count)

    def value(self, i: int) -> float:
        """The axis's value ``i`` in O(1): ``start + i * step``, ``step = (stop - start) / (count - 1)``.

        The same float as ``values[i]`` (numpy's recipe: the last value is ``stop`` itself, and a
        step that underflows to 0 is replaced by ``(i / (count - 1)) * (stop - start)``).

        Raises:
            InputError: ``i`` is not in ``range(count)``.
        """
        if not 0 <= i < self.count:
            raise InputError(f"value {i} of --vary {self.path}: the axis has {self.count} values")
        delta = self.stop - self.start
        if self.count == 1:
            return float(0.0 * delta + self.start)
        if i == self.count - 1:
            return float(self.stop)
        div = self.count - 1
        step = delta / div
        if step == 0.0:
            return float(float(i) / div * delta + self.start)
        return float(float(i) * step + self.start)

    @cached_property
    def input_name(self) -> str | None:
        """The input this axis varies, or None for a scene path (found once)."""
        return self.path[len(INPUT_PREFIX):] if self.path.startswith(INPUT_PREFIX) else None

    def to_dict(self) -> dict[str, Any]:
        """``{"path", "start", "stop", "count", "values"}`` as JSON values."""
        return {"path": self.path, "start": self.start, "stop": self.stop, "count": self.count,
                "values": self.values.tolist()}


def parse_axis(text: str) -> Axis:
    """``"contacts.tip.mu=0:2:101"`` -> :class:`Axis` (the ``--vary`` grammar).

    Raises:
        InputError: not ``PATH=START:STOP:N``, a bound that is not a finite number, or N not an
            integer >= 1.
    """
    path, sep, spec = text.partition("=")
    path = path.strip()
    parts = spec.split(":")
    if not sep or not path or len(parts) != 3:
        raise InputError(f"--vary expects PATH=START:STOP:N, got {text!r}")
    try:
        start, stop = float(parts[0]), float(parts[1])
    except ValueError as err:
        raise InputError(f"--vary {text!r}: START and STOP must be numbers") from err
    if not (math.isfinite(start) and math.isfinite(stop)):
        raise InputError(f"--vary {text!r}: START and STOP must be finite")
    try:
        count = int(parts[2])
    except ValueError as err:
        raise InputError(f"--vary {text!r}: N must be an integer, got {parts[2]!r}") from err
    if count < 1:
        raise InputError(f"--vary {text!r}: N must be >= 1, got {count}")
    if not math.isfinite(stop - start):
        raise InputError(f"--vary {text!r}: STOP - START overflows a float; sweep a narrower range")
    return Axis(path, start, stop, count)


def check_point_budget(shape: Sequence[int], max_points: int) -> None:
    """Refuse a grid of more than ``max_points`` points (:data:`MAX_ATLAS_POINTS` by default).

    Raises:
        InputError: ``max_points`` < 1, or more points than it, with the budget in the message.
    """
    if max_points < 1:
        raise InputError(f"the point budget must be >= 1, got {max_points}")
    points = math.prod(shape)
    if points > max_points:
        grid = " x ".join(str(n) for n in shape)
        raise InputError(f"the grid has {points} points ({grid}), more than the budget of {max_points} "
                         "points: sweep fewer points, or raise the budget with --max-points")


def default_chunk_size(points: int) -> int:
    """Points per chunk for a grid of ``points``.

    :data:`TARGET_CHUNKS` chunks, at most :data:`MAX_CHUNK_POINTS` points each.
    """
    return max(1, min(MAX_CHUNK_POINTS, math.ceil(points / TARGET_CHUNKS)))


@dataclass(frozen=True)
class AtlasPlan:
    """A sweep to run: the scene, the kind, the axes, what stays fixed, and the chunks.

    Attributes:
        scene: the scene as given (a path or a shipped scene's name; for content, ``"scene"``).
        source: where the workers load it from (a file, a shipped name or the content).
        what: one of :data:`WHATS`.
        axes: the varied paths, the first the outermost.
        inputs: the fixed inputs ``{name: value}`` (``--input``).
        overrides: the fixed scene overrides ``{path: value}`` (``--set``).
        chunk_size: points per chunk.
        fingerprint: SHA-256 of everything the results depend on (module docstring).
        max_points: the point budget the plan was checked against (:data:`MAX_ATLAS_POINTS`).
    """

    scene: str
    source: SceneSource
    what: str
    axes: tuple[Axis, ...]
    inputs: Mapping[str, float] = field(default_factory=dict)
    overrides: Mapping[str, Any] = field(default_factory=dict)
    chunk_size: int = 1
    fingerprint: str = ""
    max_points: int = MAX_ATLAS_POINTS

    @cached_property
    def shape(self) -> tuple[int, ...]:
        """The grid's shape, one entry per axis (found once: a plan is not changed)."""
        return tuple(a.count for a in self.axes)

    @cached_property
    def size(self) -> int:
        """The number of grid points (found once)."""
        return math.prod(self.shape)

    @property
    def chunk_count(self) -> int:
        """The number of chunks."""
        return math.ceil(self.size / self.chunk_size)

    def chunk_points(self, chunk: int) -> range:
        """The flat indices of a chunk's points."""
        if not 0 <= chunk < self.chunk_count:
            raise InputError(f"chunk {chunk} is out of range: the plan has {self.chunk_count} chunks")
        return range(chunk * self.chunk_size, min(self.size, (chunk + 1) * self.chunk_size))

    def point(self, index: int) -> tuple[dict[str, Any], dict[str, float]]:
        """The scene overrides and the inputs at the flat index ``index`` (the last axis varies fastest).

        Raises:
            InputError: ``index`` is not in ``range(size)``.
        """
        if not 0 <= index < self.size:
            raise InputError(f"point {index} is out of range: the plan has {self.size} points")
        overrides = dict(self.overrides)
        inputs = dict(self.inputs)
        positions = [0] * len(self.axes)  # numpy.unravel_index(index, shape), in C order
        for d in range(len(self.axes) - 1, -1, -1):
            index, positions[d] = divmod(index, self.axes[d].count)
        for axis, i in zip(self.axes, positions, strict=True):
            value = axis.value(i)
            name = axis.input_name
            if name is None:
                overrides[axis.path] = value
            else:
                inputs[name] = value
        return overrides, inputs

    @classmethod
    def from_dict(cls, document: Mapping[str, Any], source: SceneSource) -> AtlasPlan:
        """The plan whose :meth:`to_dict` is ``document``, on ``source``.

        Nothing is checked again: ``document`` comes from a plan :func:`build_atlas` built on the
        same source (in another process: ``frc serve`` checks a request in a worker, then runs it).
        """
        axes = tuple(Axis(str(a["path"]), float(a["start"]), float(a["stop"]), int(a["count"]))
                     for a in document["axes"])
        return cls(str(document["scene"]), source, str(document["what"]), axes,
                   {str(k): float(v) for k, v in document["inputs"].items()}, dict(document["set"]),
                   int(document["chunk_size"]), str(document["fingerprint"]),
                   int(document.get("max_points", MAX_ATLAS_POINTS)))

    @property
    def varies_scene(self) -> bool:
        """Whether some axis changes the scene (else every point shares one loaded scene)."""
        return any(a.input_name is None for a in self.axes)

    def to_dict(self) -> dict[str, Any]:
        """The plan as JSON values (stored beside the chunks)."""
        return {"scene": self.scene, "what": self.what, "axes": [a.to_dict() for a in self.axes],
                "inputs": dict(self.inputs), "set": dict(self.overrides), "shape": list(self.shape),
                "points": self.size, "max_points": self.max_points, "chunk_size": self.chunk_size,
                "chunks": self.chunk_count, "fingerprint": self.fingerprint}


def _check_axes(axes: Sequence[Axis], inputs: Mapping[str, float], overrides: Mapping[str, Any]) -> None:
    paths = [a.path for a in axes]
    for path in paths:
        if paths.count(path) > 1:
            raise InputError(f"--vary {path} is given twice")
        if path in overrides:
            raise InputError(f"--vary {path} is also set by --set {path}=...: give one of them")
        if path.startswith(INPUT_PREFIX) and path[len(INPUT_PREFIX):] in inputs:
            raise InputError(f"--vary {path} is also given by --input {path[len(INPUT_PREFIX):]}=...")


def _check_path(scene_path: str, axis: Axis, raw: dict[str, Any], coordinates: Sequence[str],
                inputs: Sequence[str]) -> None:
    """Raise the typed error of an axis path that names nothing (the nearest valid one in it)."""
    name = axis.input_name
    if name is not None:
        if name not in inputs:
            err = CoordinateNotFound(name, inputs)
            guess = nearest(name, inputs)
            hint = f" (did you mean {INPUT_PREFIX}{guess}?)" if guess else ""
            raise InputError(f"--vary {axis.path}: {err}{hint}")
        return
    parts = axis.path.split(".")
    if len(parts) == 3 and parts[0] == "state" and parts[1] in ("q", "v") and not parts[2].isdigit():
        if parts[2] not in coordinates:
            guess = nearest(parts[2], coordinates)
            hint = f"did you mean 'state.{parts[1]}.{guess}'? " if guess else ""
            raise SceneError(scene_path, axis.path, f"unknown coordinate {parts[2]!r}; {hint}"
                             f"the coordinates are: {', '.join(coordinates)}")
        return
    problems = apply_override(copy.deepcopy(raw), axis.path, axis.start)
    if problems:
        raise SceneError(scene_path, problems[0].field, problems[0].reason)


def _numbers_as_floats(value: Any) -> Any:
    """``-1`` and ``-1.0`` set the same scene: one fingerprint."""
    if isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, list):
        return [_numbers_as_floats(v) for v in value]
    if isinstance(value, dict):
        return {k: _numbers_as_floats(v) for k, v in value.items()}
    return value


def _file_digest(path: Any) -> str:
    from pathlib import Path

    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def check_scene_for(scene: Scene, what: str) -> None:
    """Refuse, before a sweep starts, a scene that lacks what ``what`` reads (a flip's ``[task]``).

    Raises:
        SceneError: the planner's own refusal (``frc flip``/``frc climb`` on the same scene).
    """
    if what == "flip":
        from ..planning.flip import flip_task

        flip_task(scene)
    elif what == "climb":
        from ..planning.climb_problem import load_climb_task

        load_climb_task(scene)


def build_atlas(
    scene: str | SceneSource,
    vary: Sequence[Axis | str],
    *,
    what: str = "solutions",
    inputs: Mapping[str, float] | None = None,
    overrides: Mapping[str, Any] | None = None,
    chunk_size: int | None = None,
    max_points: int = MAX_ATLAS_POINTS,
) -> AtlasPlan:
    """Check a sweep's arguments and build its plan (the scene is loaded once; nothing is solved).

    Args:
        scene: a scene file or the name of a shipped scene, or a
            :class:`~frcontrol.scene_source.SceneSource` (a scene sent as content).
        vary: the axes, as :class:`Axis` or ``"PATH=START:STOP:N"``; the first is the outermost.
        what: one of :data:`WHATS`.
        inputs: fixed input values ``{name: value}`` (others 0, or the axis's value).
        overrides: fixed scene overrides ``{path: value}`` (the ``--set`` grammar).
        chunk_size: points per chunk (default :func:`default_chunk_size`).
        max_points: the point budget (:data:`MAX_ATLAS_POINTS`): a larger grid is refused at once.

    Raises:
        InputError: no axis, a malformed axis, an unknown ``what``, a path varied twice or also
            fixed, an unknown input (with the nearest), a fixed input outside its limits, a
            chunk size < 1, or a grid of more than ``max_points`` points.
        SceneError: the scene or a ``--set`` override is invalid, an axis path names no field
            (with the nearest valid one), or the scene lacks what ``what`` needs (a flip's or a
            climb's ``[task]``).
    """
    if what not in WHATS:
        raise InputError(f"unknown --what {what!r}; valid: {', '.join(WHATS)}")
    axes = tuple(parse_axis(a) if isinstance(a, str) else a for a in vary)
    if not axes:
        raise InputError("an atlas needs at least one --vary PATH=START:STOP:N")
    fixed_inputs = {str(k): float(v) for k, v in (inputs or {}).items()}
    fixed = dict(overrides or {})
    _check_axes(axes, fixed_inputs, fixed)
    check_point_budget([a.count for a in axes], max_points)
    source = scene if isinstance(scene, SceneSource) else SceneSource.file(scene)
    with source.loaded(fixed) as base:
        parse_input_assignments(base, fixed_inputs)
        check_scene_for(base, what)  # a flip sweep of a scene with no [task] is refused at once
        raw = dict(base.raw)
        full = base.robot.coordinates_before_locking
        robot_digest = _file_digest(base.robot.urdf_path)
    for axis in axes:
        _check_path(str(base.path), axis, raw, full, base.inputs.coordinates)
    size = math.prod(a.count for a in axes)
    if chunk_size is None:
        chunk_size = default_chunk_size(size)
    if chunk_size < 1:
        raise InputError(f"the chunk size must be >= 1, got {chunk_size}")
    plan = AtlasPlan(source.label, source, what, axes, fixed_inputs, fixed, int(chunk_size),
                     max_points=max_points)
    from .. import __version__

    recipe = {"format": FORMAT_VERSION, "frcontrol": __version__, "scene": source.digest(),
              "robot": robot_digest, "what": what,
              "axes": [[a.path, a.start, a.stop, a.count] for a in axes],
              "inputs": sorted(fixed_inputs.items()),
              "set": sorted((k, repr(_numbers_as_floats(v))) for k, v in fixed.items()),
              "chunk_size": plan.chunk_size}
    digest = hashlib.sha256(json.dumps(recipe, sort_keys=True).encode()).hexdigest()
    return replace(plan, fingerprint=digest)


__all__ = [
    "FORMAT_VERSION",
    "INPUT_PREFIX",
    "MAX_ATLAS_POINTS",
    "MAX_CHUNK_POINTS",
    "TARGET_CHUNKS",
    "WHATS",
    "AtlasPlan",
    "Axis",
    "build_atlas",
    "check_point_budget",
    "default_chunk_size",
    "parse_axis",
]
