r"""The climbing gait as a task: ``[task.gait]``, the scene run with it, and ``frc climb --cycles``'s keys.

A scene's ``[task]`` may hold, beside its own phases, a second task in the same format: the gait,
``[task.gait]`` (``timing = "gait"``, ``repeat`` cycles of the four phases, ``upper_brace``,
``seed``, ``scale``; :mod:`.gait_timing`). ``frc plan SCENE --cycles N`` and ``frc climb SCENE
--cycles N`` run it through the planning core with ``repeat = N`` (:func:`gait_scene`). A scene
that gives only the gait's upper brace (``[task] gait = { upper_brace = [...] }`` beside the
climb's phases, or the climb's older ``upper_brace_contacts``) gets the shipped phases
(:func:`default_gait_table`): the lower brace is then the climb's.

``frc climb --cycles N --json`` is ``frc plan``'s document with the keys the gait documented before
(:func:`gait_keys`, merged by :func:`~.core.report.with_legacy_keys`): ``phases`` and ``outcome``
are ``frc plan``'s; each phase's certificate is in ``certificates``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from ..errors import FrcontrolError
from ..jsonable import to_jsonable
from ..modes import add_scene_modes
from ..scene import Scene
from . import DEFAULT_CLIMB_MARGIN
from .climb_check import BRACE_SLIP_TOLERANCE
from .core.report import PlanResult
from .gait import PHASES, gait_braces
from .gait_control import ROBUSTNESS_PENALTY, TOUCH_GAP
from .gait_geometry import (
    APPROACH_TIME,
    DWELL_TIME,
    EXTEND_TIME,
    PRESS,
    RELEASE_TIME,
    STANDOFF,
    STROKE,
    UPPER_SPAN,
)
from .gait_handover import PHASE_ROLES
from .gait_timing import GaitTiming

__all__ = [
    "GAIT_CYCLE_TIME",
    "GAIT_TIME_MARGIN",
    "PHASE_TIMES",
    "cycled_scene",
    "default_gait_table",
    "gait_keys",
    "gait_scene",
]

PHASE_TIMES = {"extend": RELEASE_TIME + EXTEND_TIME, "upper_brace": APPROACH_TIME + DWELL_TIME,
               "pull": RELEASE_TIME + EXTEND_TIME, "lower_brace": APPROACH_TIME + DWELL_TIME}
"""[s] Each phase's length: its reference's (:func:`~.gait_geometry.phase_reference`)."""

GAIT_CYCLE_TIME = sum(PHASE_TIMES.values())
"""[s] One cycle of the shipped phases."""

GAIT_TIME_MARGIN = 1.0
"""[s] ``max_time`` of a gait run is its cycles' time plus this (the timing ends it at the last cycle)."""


def default_gait_table(scene: Scene) -> dict[str, Any]:
    """The gait's task table from its braces alone: the shipped four phases, one cycle.

    Raises:
        SceneError: no upper brace, or a bad one (:func:`~.gait.gait_braces`).
    """
    lower, upper = gait_braces(scene)
    braces = {"lower": lower, "upper": upper, "": ()}
    phases = []
    for name in PHASES:
        held, released, closing = (braces[r] for r in PHASE_ROLES[name])
        modes = {**dict.fromkeys(held + closing, "F"), **dict.fromkeys(released, "S")}
        phases.append({"name": name, "modes": modes, "margin": DEFAULT_CLIMB_MARGIN, "robust": True,
                       "until": {"time": PHASE_TIMES[name]}})
    return {"timing": "gait", "repeat": 1, "upper_brace": list(upper), "phases": phases}


def gait_scene(scene: Scene, *, cycles: int | None = None, seed: int | None = None,
               scale: float | None = None, margin: float | None = None) -> Scene:
    """The scene whose ``[task]`` is its gait (module docstring), with the given overrides.

    ``cycles`` sets ``repeat`` (and ``max_time`` to the cycles' time plus
    :data:`GAIT_TIME_MARGIN` when the table gives none), ``seed`` and ``scale`` the run's sampled
    disturbances, ``margin`` every phase's robustness radius.

    Raises:
        SceneError: the scene has no gait (:func:`default_gait_table`).
    """
    raw = scene.raw.get("task")
    given = raw.get("gait") if isinstance(raw, Mapping) else None
    table = dict(given) if isinstance(given, Mapping) and "phases" in given else default_gait_table(scene)
    if cycles is not None:
        table["repeat"] = cycles
    for key, value in (("seed", seed), ("scale", scale)):
        if value is not None:
            table[key] = value
    if margin is not None:
        table["phases"] = [{**p, "margin": margin} for p in table["phases"]]
    table.setdefault("timing", "gait")
    table.setdefault("max_time", int(table.get("repeat", 1)) * GAIT_CYCLE_TIME + GAIT_TIME_MARGIN)
    return replace(scene, raw={**scene.raw, "task": table})


def cycled_scene(scene: Scene, cycles: int) -> Scene:
    """``--cycles N``: the scene's gait run ``cycles`` times when it has one, else its ``[task]``'s phases.

    A scene has a gait when its ``[task]`` gives ``gait`` or ``upper_brace_contacts``
    (:func:`gait_scene`); otherwise ``cycles`` sets its task's ``repeat``.
    """
    raw = scene.raw.get("task")
    if isinstance(raw, Mapping) and ("gait" in raw or "upper_brace_contacts" in raw):
        return gait_scene(scene, cycles=cycles)
    table = dict(raw) if isinstance(raw, Mapping) else {}
    return replace(scene, raw={**scene.raw, "task": {**table, "repeat": cycles}})


def gait_keys(scene: Scene, result: PlanResult) -> dict[str, Any]:
    """The keys ``frc climb --cycles N --json`` documented, read from the core's run of the gait.

    ``cycles``, ``heights`` (the base's height at the end of each cycle [m]), ``certificates``
    (each phase's plan, with its ``max_disturbance_scale``), ``weakest_phase``, ``hand_overs`` and
    in ``simulation``: ``samples`` plus each step's ``torques``, ``phase``, ``controller_mode``,
    ``mode_contacts`` and ``deficit``; ``rise``, ``brace_held``, ``max_slip``...
    """
    timing = result.timing
    if not isinstance(timing, GaitTiming):
        raise FrcontrolError("the gait's keys need a run of the gait's task ([task] timing = \"gait\")")
    plan = timing.plan
    weakest = plan.weakest
    keys = {
        "found": True, "cycles": plan.cycles, "lower_brace": list(plan.lower),
        "upper_brace": list(plan.upper), "scale": plan.scale, "margin": plan.margin,
        "weakest_phase": {"name": weakest.name, "cycle": weakest.cycle,
                          "max_disturbance_scale": weakest.scale},
        "certificates": [p.to_dict() for p in plan.phases],
        "hand_overs": [h.to_dict(scene.inputs.coordinates) for h in plan.hand_overs],
        "unambiguous_hand_overs": plan.unambiguous,
        "limits": {"inputs": list(scene.inputs.coordinates), "lower": scene.inputs.lower,
                   "upper": scene.inputs.upper},
        "geometry": {"link_length": plan.geometry.link_length, "walls": [plan.geometry.left_wall,
                     plan.geometry.right_wall], "stroke": list(STROKE), "upper_span": UPPER_SPAN,
                     "standoff": STANDOFF, "press": PRESS},
        "disturbances": [{"name": d.name, "link": d.link, "point": d.point_in_link, "vertices": d.vertices}
                         for d in plan.disturbances.items],
        "tolerances": {"margin": plan.margin, "touch_gap": TOUCH_GAP, "slip": BRACE_SLIP_TOLERANCE,
                       "robustness_penalty": ROBUSTNESS_PENALTY},
        "solver": plan.solver, "timings": dict(plan.timings), **_run_keys(scene, result, timing),
    }
    return add_scene_modes(to_jsonable(keys), [c.name for c in scene.contacts])


def _run_keys(scene: Scene, result: PlanResult, timing: GaitTiming) -> dict[str, Any]:
    """The run's part of :func:`gait_keys`: heights, the phases' runs and the simulation's verdict."""
    trajectory = result.trajectory
    records = timing.records
    samples = trajectory.to_dict(scene)["samples"]
    samples.update({"torques": np.array(timing.torques).reshape(-1, scene.inputs.count),
                    "phase": np.array(timing.phase_of_step, dtype=int),
                    "controller_mode": [m for m, _ in timing.modes],
                    "mode_contacts": [list(c) for _, c in timing.modes],
                    "deficit": np.array(timing.deficits)})
    start = float(trajectory.q[0, 1])
    heights = [r.base_height - start for r in records if r.name == "lower_brace"]
    max_slip = max((r.max_slip for r in records), default=0.0)
    complete = trajectory.completed and len(records) == len(PHASES) * timing.task.repeat
    return {
        "heights": heights,
        "rise_per_cycle": np.diff(np.concatenate([[0.0], heights])).tolist(),
        "phase_runs": [r.to_dict() for r in records],
        "simulation": {
            "samples": samples, "rise": float(trajectory.q[-1, 1] - trajectory.q[0, 1]),
            "brace_held": bool(complete and max_slip <= BRACE_SLIP_TOLERANCE), "max_slip": max_slip,
            "max_drift": max((r.max_drift for r in records), default=0.0),
            "max_deficit": max((r.max_deficit for r in records), default=0.0), "scale": timing.scale,
            "seed": timing.seed, "status": trajectory.status, "slip_tolerance": BRACE_SLIP_TOLERANCE,
            "phases_completed": len(records),
            "disturbance_times": timing.disturbance_times(),
            "disturbance_samples": np.array(timing.samples).reshape(-1, timing.plan.disturbances.dim),
            "timings": dict(result.run.timings),
        },
    }
