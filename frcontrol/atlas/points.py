"""What an atlas computes at one grid point, and a chunk of points at a time.

At every point, whatever ``what`` is (the same columns for every kind):

- ``count``: the number of rigid-body solutions at the point's inputs (``solutions_at``);
- ``modes``: their modes, sorted;
- ``stable``: each one's stability under compliance (:func:`frcontrol.stability.stability_of`'s
  verdict, as :func:`~frcontrol.stability.stable_verdicts` finds it: the state's work once), in the
  order of ``modes``: true, false, or null (not analysable);
- ``ambiguous``: ``"none"``, ``"between"`` (more than one solution: between modes), ``"within"``
  (one solution whose mode has ambiguity variables, ``ambiguity_dim > 0``) or ``"both"``
  (several solutions, one of them with ambiguity variables);
- ``error``: null, or the message of the typed error the point raised (a bad point never stops the
  sweep; its other columns are null). An exception that is not one of frcontrol's typed errors is
  recorded too, as ``"internal error: TYPE: message"`` (a bug to report, but not one that loses the
  rest of the sweep).

``statics``, ``flip`` and ``climb`` add their own columns (:data:`KIND_COLUMNS`).

A worker loads the scene once per distinct set of the overrides that change its structure (it
keeps the last few), and applies the ones that change only numbers to that loaded scene
(:mod:`frcontrol.scene_numbers`): an axis ``state.q.NAME``, ``state.v.NAME`` or
``contacts.NAME.mu`` moves the state (the contacts placed again as the loader places them) or sets
a friction coefficient, and ``input.NAME`` changes only the input. Each point is made from the
last one where it can: only the numbers that changed are set, and a change of friction alone sets
the problem's coefficients (a solutions atlas then makes no scene for the point); where no contact
can move into or out of touch (none has a ``surface_point``), a solutions atlas makes a new state's
problem from the state alone too. Every other axis (gravity, a
mass, a locked joint's angle, a contact's geometry) loads the scene at each of its values, and so
does a point the numeric path refuses (a penetrating contact, a scene that does not load without
the point's values): that point is loaded with all its overrides, exactly as before, so its error
is the loader's own. ``reload=True`` computes every point that way (the reference the numeric
path is tested against). A scene sent as content is rebuilt from its text
(:class:`~frcontrol.scene_source.SceneSource`).
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from types import ModuleType
from typing import TYPE_CHECKING, Any, Literal, NamedTuple, get_args

from ..errors import FrcontrolError
from ..scene import Scene
from ..scene_numbers import (
    friction_with_numbers,
    is_friction_path,
    is_numeric_path,
    numeric_syntax,
    scene_with_numbers,
    state_with_numbers,
)
from ..scene_source import SceneSource
from .grid import AtlasPlan

if TYPE_CHECKING:
    from ..modes import ContactProblem

COMMON_COLUMNS = ("count", "modes", "stable", "ambiguous", "error")
"""The columns of every kind, in order."""

KIND_COLUMNS: dict[str, tuple[str, ...]] = {
    "solutions": (),
    "statics": ("form_closure", "form_closure_margin", "force_closure", "force_closure_margin",
                "static_equilibrium", "weakly_stable", "strongly_stable"),
    "flip": ("found", "plan_mode", "pitch_acceleration", "margin"),
    "climb": ("found", "plan_mode", "max_disturbance_scale", "robustness_radius"),
}
"""The columns each kind adds: statics' closure and equilibrium flags and margins [N or N m, as
``frc statics``]; the flip's plan (whether one exists, its mode, its pitch acceleration [rad/s^2] and
the margin [N m] it keeps); the climb's (whether one exists, its mode, the largest disturbance scale
and the robustness radius [N m or N])."""

SCENE_CACHE_SIZE = 4
"""Loaded scenes a worker keeps, by their overrides (points of a chunk often share one)."""

AtlasAmbiguity = Literal["none", "between", "within", "both"]
"""A point's ambiguity: none, between modes (several solutions), within a mode (w), or both."""

AMBIGUITY: tuple[AtlasAmbiguity, ...] = get_args(AtlasAmbiguity)
"""The values of the ``ambiguous`` column."""


def columns(what: str) -> tuple[str, ...]:
    """Every column of a kind, in order."""
    return COMMON_COLUMNS + KIND_COLUMNS[what]


@dataclass(frozen=True)
class _Loaded:
    """A scene as loaded, its contact problem, and its coordinates before locking (``[state]``'s order)."""

    scene: Scene
    problem: ContactProblem
    bare_coordinates: tuple[str, ...]
    numeric: dict[frozenset[str], bool] = field(default_factory=dict)  # paths -> all numeric here

    def takes_numbers(self, paths: frozenset[str]) -> bool:
        """Whether every path of ``paths`` is numeric on this scene (found once per set of paths)."""
        known = self.numeric.get(paths)
        if known is None:
            known = self.numeric[paths] = all(is_numeric_path(self.scene, path) for path in paths)
        return known


class _Made(NamedTuple):
    """A point made on the numeric path (a named tuple: one is made per point).

    The source and loaded scene it was made from (with the overrides that were not numbers), its
    numbers (``{path: value}``), its problem, and the last scene made with the numbers it was made
    with.
    """

    source: SceneSource
    template: _Loaded
    structural: dict[str, Any]  # the overrides template was loaded with
    numbers: dict[str, Any]
    scene: Scene  # made with scene_numbers (a friction change alone makes no scene)
    scene_numbers: dict[str, Any]
    problem: ContactProblem  # made with numbers


class _Scenes:
    """The last :data:`SCENE_CACHE_SIZE` scenes loaded (or the typed errors they raised), by overrides.

    And the last point made from one of them (``last``).
    """

    def __init__(self) -> None:
        self.cache: OrderedDict[tuple[SceneSource, tuple[tuple[str, str], ...]], _Loaded | FrcontrolError] = \
            OrderedDict()
        self.loads = 0
        self.last: _Made | None = None

    def get(self, source: SceneSource, overrides: Mapping[str, Any]) -> _Loaded:
        """The scene with ``overrides``, loaded once (a typed error of the load raised again)."""
        key = (source, tuple(sorted((k, repr(v)) for k, v in overrides.items())))
        entry = self.cache.get(key)
        if entry is None:
            entry = self._load(source, overrides)
            self.cache[key] = entry
            if len(self.cache) > SCENE_CACHE_SIZE:
                self.cache.popitem(last=False)
        else:
            self.cache.move_to_end(key)
        if isinstance(entry, FrcontrolError):
            raise entry.with_traceback(None)
        return entry

    def template(self, source: SceneSource, overrides: dict[str, Any]) -> _Loaded:
        """:meth:`get`, or at once the last point's loaded scene when it has these overrides."""
        last = self.last
        if last is not None and (last.source is source or last.source == source) \
                and last.structural.keys() == overrides.keys() \
                and not _changed(last.structural, overrides):
            return last.template
        return self.get(source, overrides)

    def _load(self, source: SceneSource, overrides: Mapping[str, Any]) -> _Loaded | FrcontrolError:
        from ..modes import ContactProblem

        self.loads += 1
        try:
            with source.loaded(overrides) as scene:
                bare = scene.robot.coordinates_before_locking
            return _Loaded(scene, ContactProblem.from_scene(scene), bare)
        except FrcontrolError as err:
            return err


_SCENES = _Scenes()


def numeric_axes(plan: AtlasPlan) -> frozenset[str]:
    """The plan's axis paths that may change only numbers (checked against the scene later)."""
    return frozenset(a.path for a in plan.axes if a.input_name is None and numeric_syntax(a.path))


def scene_at(plan: AtlasPlan, overrides: Mapping[str, Any], numeric_paths: frozenset[str] = frozenset(),
             *, scene_needed: bool = True) -> tuple[Scene | None, ContactProblem]:
    """The scene and its problem with a point's ``overrides`` (module docstring).

    ``numeric_paths``: the paths to apply to the scene loaded without them (:func:`numeric_axes`);
    none: the scene loaded with every override. ``scene_needed``: False when only the problem is
    read (a solutions atlas): the scene may then be None (a point that changes only friction).

    Raises:
        FrcontrolError: the typed error of loading the scene with ``overrides``.
    """
    numeric = {k: v for k, v in overrides.items() if k in numeric_paths}
    if numeric:
        try:
            structural = {k: v for k, v in overrides.items() if k not in numeric}
            template = _SCENES.template(plan.source, structural)
            if template.takes_numbers(frozenset(numeric)):
                return _made_at(plan.source, template, structural, numeric, scene_needed)
        except FrcontrolError:
            pass  # loaded with every override below: the point's own error, as the loader words it
    loaded = _SCENES.get(plan.source, overrides)
    return loaded.scene, loaded.problem


def _made_at(source: SceneSource, template: _Loaded, structural: dict[str, Any], numbers: dict[str, Any],
             scene_needed: bool) -> tuple[Scene | None, ContactProblem]:
    """The scene (if ``scene_needed``) and the problem with ``numbers`` set on ``template``'s scene.

    ``structural``: the overrides ``template`` was loaded with (from ``source``).

    From the last point made, when it was made from the same scene with the same paths: only the
    numbers that differ are set. None differ: the last point's. Friction alone: the last problem
    with the new coefficients (the state's arrays unchanged), and no scene unless one is needed
    (the last scene is kept with its own numbers, and brought up to date when one is). A new state
    where no scene is needed: the template's problem at that state (:func:`_problem_at_state`),
    where it can. Else the scene from the template's.

    Raises:
        FrcontrolError: as :func:`~frcontrol.scene_numbers.scene_with_numbers`.
    """
    problem_from_scene = _query().problem.from_scene
    last = _SCENES.last
    if last is None or last.template is not template or last.numbers.keys() != numbers.keys():
        scene = scene_with_numbers(template.scene, numbers, template.bare_coordinates)
        _SCENES.last = _Made(source, template, structural, numbers, scene, numbers, problem_from_scene(scene))
        return scene, _SCENES.last.problem
    changed = _changed(last.numbers, numbers)
    problem: ContactProblem | None = last.problem
    if changed and all(is_friction_path(path) for path in changed):
        problem = last.problem.with_friction(friction_with_numbers(
            last.scene, {k: v for k, v in numbers.items() if is_friction_path(k)}))
    elif changed:
        problem = None if scene_needed else _problem_at_state(template, numbers)
    scene, scene_numbers = last.scene, last.scene_numbers
    if problem is None or scene_needed:
        stale = _changed(scene_numbers, numbers)
        if stale:
            scene, scene_numbers = scene_with_numbers(scene, stale, template.bare_coordinates), numbers
        if problem is None:
            problem = problem_from_scene(scene)
    _SCENES.last = _Made(source, template, structural, numbers, scene, scene_numbers, problem)
    return (scene if scene_needed else None), problem


def _problem_at_state(template: _Loaded, numbers: dict[str, Any]) -> ContactProblem | None:
    """The problem of ``template``'s scene with ``numbers`` set, from the state alone, or None.

    From the state where no contact moves into or out of touch
    (:func:`~frcontrol.scene_numbers.state_with_numbers`).
    """
    state = state_with_numbers(template.scene, numbers)
    if state is None:
        return None
    q, v, mu = state
    return template.problem.at_state(template.scene, q, v, mu)


def _changed(before: dict[str, Any], after: dict[str, Any]) -> dict[str, Any]:
    """The entries of ``after`` whose number differs from ``before``'s (same keys)."""
    return {k: v for k, v in after.items() if not _same_number(v, before[k])}


@dataclass(frozen=True)
class _Query:
    """The modules a point calls, imported once (``frcontrol.atlas`` loads without them).

    Their functions are looked up at each call (a profiler may wrap them).
    """

    engine: ModuleType
    stability: ModuleType
    problem: type[ContactProblem]


@cache
def _query() -> _Query:
    from .. import engine, stability
    from ..modes import ContactProblem

    return _Query(engine, stability, ContactProblem)


def _same_number(a: Any, b: Any) -> bool:
    """Whether two override values are the same number, to the bit (0.0 and -0.0 differ)."""
    return type(a) is type(b) and a == b and (a != 0 or repr(a) == repr(b))


def solutions_columns(scene: Scene | None, problem: ContactProblem, inputs: Mapping[str, float]
                      ) -> dict[str, Any]:
    """``count``, ``modes``, ``stable`` and ``ambiguous`` at one input (module docstring).

    ``scene`` is not read (``problem`` holds the state); it may be None.
    """
    query = _query()
    found = query.engine.solutions_at(problem, inputs)
    if len(found) > 1:
        found = sorted(found, key=lambda s: s.mode)
    stable = [None if v is None else bool(v) for v in query.stability.stable_verdicts(problem, found)]
    between = len(found) > 1
    within = any(s.ambiguity_dim > 0 for s in found)
    return {"count": len(found), "modes": [s.mode for s in found], "stable": stable,
            "ambiguous": AMBIGUITY[int(between) + 2 * int(within)]}


def _statics_columns(scene: Scene, inputs: Mapping[str, float]) -> dict[str, Any]:
    from ..statics import analyze_statics

    report = analyze_statics(scene, dict(inputs))
    return {"form_closure": bool(report.form_closure.closed),
            "form_closure_margin": float(report.form_closure.margin),
            "force_closure": bool(report.force_closure.closed),
            "force_closure_margin": float(report.force_closure.margin),
            "static_equilibrium": bool(report.equilibrium.exists),
            "weakly_stable": bool(report.weakly_stable),
            "strongly_stable": None if report.strongly_stable is None else bool(report.strongly_stable)}


def _flip_columns(scene: Scene) -> dict[str, Any]:
    from ..planning.flip import plan_flip

    plan = plan_flip(scene)
    return {"found": bool(plan.found), "plan_mode": plan.mode if plan.found else None,
            "pitch_acceleration": float(plan.pitch_acceleration) if plan.found and
            plan.pitch_acceleration is not None else None,
            "margin": float(plan.margin) if plan.found else None}


def _climb_columns(scene: Scene) -> dict[str, Any]:
    from ..planning.climb import plan_climb

    plan = plan_climb(scene)
    return {"found": bool(plan.found), "plan_mode": plan.mode if plan.found else None,
            "max_disturbance_scale": float(plan.max_disturbance_scale) if plan.found else None,
            "robustness_radius": float(plan.robustness_radius) if plan.found else None}


def _kind_columns(what: str, scene: Scene, inputs: Mapping[str, float]) -> dict[str, Any]:
    """The columns ``what`` adds (:data:`KIND_COLUMNS`) at one point."""
    if what == "statics":
        return _statics_columns(scene, inputs)
    if what == "flip":
        return _flip_columns(scene)
    return _climb_columns(scene)


def evaluate_point(plan: AtlasPlan, index: int, *, reload: bool = False,
                   numeric_paths: frozenset[str] | None = None) -> dict[str, Any]:
    """Every column of one grid point (module docstring); a typed error is recorded, not raised.

    ``reload``: load the scene with all the point's overrides (no numeric path).
    ``numeric_paths``: :func:`numeric_axes` of ``plan``, if known.
    """
    overrides, inputs = plan.point(index)
    row: dict[str, Any] = dict.fromkeys(columns(plan.what))
    if reload:
        numeric_paths = frozenset()
    elif numeric_paths is None:
        numeric_paths = numeric_axes(plan)
    try:
        scene, problem = scene_at(plan, overrides, numeric_paths, scene_needed=plan.what != "solutions")
        row.update(solutions_columns(scene, problem, inputs))
        if plan.what != "solutions":
            if scene is None:
                raise RuntimeError("scene_at made no scene where one is needed")
            row.update(_kind_columns(plan.what, scene, inputs))
    except FrcontrolError as err:
        row = dict.fromkeys(columns(plan.what))
        row["error"] = str(err)
    except Exception as err:  # noqa: BLE001 - a point the library did not foresee must not end the sweep
        row = dict.fromkeys(columns(plan.what))
        row["error"] = f"internal error: {type(err).__name__}: {err}"
    return row


def evaluate_chunk(plan: AtlasPlan, chunk: int, *, reload: bool = False) -> dict[str, Any]:
    """The columns of one chunk's points (and how long they took, and the scenes loaded for them).

    The keys: ``chunk``, ``index``, every column, ``seconds``, ``cpu_seconds``, ``scene_loads``.
    ``seconds`` is the chunk's compute time [s] in the process that ran it (wall clock), and
    ``cpu_seconds`` the CPU time that process spent on it (less than ``seconds`` when the process
    waited for a core); ``scene_loads`` the scenes it loaded from the source (the others were kept
    from earlier points, or made by the numeric path). ``reload``: as :func:`evaluate_point`'s.
    """
    start = time.perf_counter()
    cpu = time.process_time()
    loads = _SCENES.loads
    indices = list(plan.chunk_points(chunk))
    paths = frozenset() if reload else numeric_axes(plan)
    rows = [evaluate_point(plan, k, numeric_paths=paths) for k in indices]
    out: dict[str, Any] = {"chunk": chunk, "index": indices}
    for name in columns(plan.what):
        out[name] = [row[name] for row in rows]
    out["seconds"] = time.perf_counter() - start
    out["cpu_seconds"] = time.process_time() - cpu
    out["scene_loads"] = _SCENES.loads - loads
    return out


__all__ = [
    "AMBIGUITY",
    "COMMON_COLUMNS",
    "KIND_COLUMNS",
    "SCENE_CACHE_SIZE",
    "columns",
    "evaluate_chunk",
    "evaluate_point",
    "numeric_axes",
    "scene_at",
    "solutions_columns",
]
