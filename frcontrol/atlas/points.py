"""What an atlas computes at one grid point, and a chunk of points at a time.

At every point, whatever ``what`` is (the same columns for every kind):

- ``count``: the number of rigid-body solutions at the point's inputs (``solutions_at``);
- ``modes``: their modes, sorted;
- ``stable``: each one's stability under compliance (:func:`frcontrol.stability.stability_of`),
  in the order of ``modes``: true, false, or null (not analysable);
- ``ambiguous``: ``"none"``, ``"between"`` (more than one solution: between modes), ``"within"``
  (one solution whose mode has ambiguity variables, ``ambiguity_dim > 0``) or ``"both"``
  (several solutions, one of them with ambiguity variables);
- ``error``: null, or the message of the typed error the point raised (a bad point never stops the
  sweep; its other columns are null). An exception that is not one of frcontrol's typed errors is
  recorded too, as ``"internal error: TYPE: message"`` (a bug to report, but not one that loses the
  rest of the sweep).

``statics``, ``flip`` and ``climb`` add their own columns (:data:`KIND_COLUMNS`).

The scene is loaded once per distinct set of scene overrides (a worker keeps the last few): a
sweep over inputs only loads it once; a varied state reloads it, so that a contact without
``surface_point`` follows its contact point (gap 0), exactly as :func:`frcontrol.load_scene` does.
A scene sent as content is rebuilt from its text (:class:`~frcontrol.scene_source.SceneSource`).
"""

from __future__ import annotations

import json
import time
from collections import OrderedDict
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ..errors import FrcontrolError
from ..scene import Scene
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

AMBIGUITY = ("none", "between", "within", "both")
"""The values of the ``ambiguous`` column."""


def columns(what: str) -> tuple[str, ...]:
    """Every column of a kind, in order."""
    return COMMON_COLUMNS + KIND_COLUMNS[what]


class _Scenes:
    """The last :data:`SCENE_CACHE_SIZE` scenes loaded, with their contact problems."""

    def __init__(self) -> None:
        self.cache: OrderedDict[tuple[SceneSource, str], tuple[Scene, ContactProblem]] = OrderedDict()

    def get(self, source: SceneSource, overrides: Mapping[str, Any]) -> tuple[Scene, ContactProblem]:
        from ..modes import ContactProblem

        key = (source, json.dumps(sorted((k, repr(v)) for k, v in overrides.items())))
        if key in self.cache:
            self.cache.move_to_end(key)
            return self.cache[key]
        loaded = source.load(overrides)
        entry = (loaded, ContactProblem.from_scene(loaded))
        self.cache[key] = entry
        if len(self.cache) > SCENE_CACHE_SIZE:
            self.cache.popitem(last=False)
        return entry


_SCENES = _Scenes()


def solutions_columns(scene: Scene, problem: ContactProblem, inputs: Mapping[str, float]) -> dict[str, Any]:
    """``count``, ``modes``, ``stable`` and ``ambiguous`` at one input (module docstring)."""
    from ..engine import solutions_at
    from ..stability import stability_of

    found = sorted(solutions_at(problem, inputs), key=lambda s: s.mode)
    stable = []
    for solution in found:
        verdict = stability_of(problem, solution).stable
        stable.append(None if verdict is None else bool(verdict))
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


def check_scene_for(scene: Scene, what: str) -> None:
    """Refuse, before a sweep starts, a scene that lacks what ``what`` reads (a flip's ``[task]``).

    Raises:
        SceneError: the planner's own refusal (``frc flip``/``frc climb`` on the same scene).
    """
    if what == "flip":
        from ..planning.flip import flip_task

        flip_task(scene)
    elif what == "climb":
        from ..planning.climb import load_climb_task

        load_climb_task(scene)


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


def evaluate_point(plan: AtlasPlan, index: int) -> dict[str, Any]:
    """Every column of one grid point (module docstring); a typed error is recorded, not raised."""
    overrides, inputs = plan.point(index)
    row: dict[str, Any] = dict.fromkeys(columns(plan.what))
    try:
        scene, problem = _SCENES.get(plan.source, overrides)
        row.update(solutions_columns(scene, problem, inputs))
        if plan.what == "statics":
            row.update(_statics_columns(scene, inputs))
        elif plan.what == "flip":
            row.update(_flip_columns(scene))
        elif plan.what == "climb":
            row.update(_climb_columns(scene))
    except FrcontrolError as err:
        row = dict.fromkeys(columns(plan.what))
        row["error"] = str(err)
    except Exception as err:  # noqa: BLE001 - a point the library did not foresee must not end the sweep
        row = dict.fromkeys(columns(plan.what))
        row["error"] = f"internal error: {type(err).__name__}: {err}"
    return row


def evaluate_chunk(plan: AtlasPlan, chunk: int) -> dict[str, Any]:
    """The columns of one chunk's points: ``{"chunk", "index", column..., "seconds", "cpu_seconds"}``.

    ``seconds`` is the chunk's compute time [s] in the process that ran it (wall clock), and
    ``cpu_seconds`` the CPU time that process spent on it (less than ``seconds`` when the process
    waited for a core).
    """
    start = time.perf_counter()
    cpu = time.process_time()
    indices = list(plan.chunk_points(chunk))
    rows = [evaluate_point(plan, k) for k in indices]
    out: dict[str, Any] = {"chunk": chunk, "index": indices}
    for name in columns(plan.what):
        out[name] = [row[name] for row in rows]
    out["seconds"] = time.perf_counter() - start
    out["cpu_seconds"] = time.process_time() - cpu
    return out


__all__ = [
    "AMBIGUITY",
    "COMMON_COLUMNS",
    "KIND_COLUMNS",
    "SCENE_CACHE_SIZE",
    "columns",
    "evaluate_chunk",
    "evaluate_point",
    "solutions_columns",
]
