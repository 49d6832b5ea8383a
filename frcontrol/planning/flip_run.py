r"""``frc flip`` as a short name for ``frc plan``: the scene's flip task run by the core, reported as a flip.

:func:`run_flip` runs the scene's task (``[[task.phases]]``; the first phase keeps the body contacts
loaded and maximises the pitch, :func:`~frcontrol.planning.flip.flip_task`) through
:func:`frcontrol.planning.core.plan_task`, the code path of ``frc plan`` and ``POST /plan``, and
reads the flip's verdict from the run's samples (:class:`~frcontrol.planning.flip_loop.FlipResult`):

- ``flipped``: the pitch reached vertical (``FlipTask.vertical``) at a sample; ``time_to_vertical``
  [s] linear between the two samples around the first such sample;
- ``body_contact_kept``: every body contact touching at the start touches at every sample up to
  then (:func:`~frcontrol.planning.flip_loop.body_contact_events`);
- the first plan (``mode``, ``torques``, ``pitch_acceleration``, ``unambiguous``, ``margin``): the
  run's first decision (:class:`~frcontrol.planning.core.decision.Decision`), verified with
  ``solutions_at`` (one rigid solution, in its mode). The core plans no mode whose pitch depends on
  its ambiguity variables, so ``worst_case`` is false; ``candidates`` and ``explored`` list the modes
  the decision tried and the one it chose, ``rejected`` why the others failed; ``bounds`` is empty
  and ``pieces`` 0 (the flip's own branch and bound,
  :func:`~frcontrol.planning.flip.plan_flip`, reports those).

With ``max_time`` 0 the first decision is made and nothing is simulated.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .. import polytope as poly
from ..errors import FrcontrolError
from ..jsonable import to_jsonable
from ..modes import VELOCITY_TOLERANCE, ContactProblem, add_scene_modes
from ..scene import Scene
from ..solvers import DEFAULT_SETTINGS
from .core.decision import Decision, decide
from .core.forced import planning_problem
from .core.report import PlanResult, plan_task, with_legacy_keys
from .core.task import Phase, read_task
from .core.tolerances import INPUT_LIMIT_TOLERANCE, REPLAN_GAP_TOLERANCE, TORQUE_ROUNDING
from .flip import VERTICAL_TOLERANCE, FlipPlan, FlipTask, check_flip_inputs, flip_task
from .flip_loop import FlipResult, body_contact_events

__all__ = ["FlipRun", "first_plan", "flip_document", "flip_result", "plan_only_document", "run_flip"]


@dataclass(frozen=True)
class FlipRun:
    """The flip task run by the core.

    Attributes:
        plan: the core's run (None when nothing was simulated: ``max_time`` 0).
        flip: the flip's verdict read from it, its first plan included.
        document: the ``frc plan --json`` document of the run (its ``outcome`` and ``phases``).
    """

    plan: PlanResult | None
    flip: FlipResult | FlipPlan
    document: dict[str, Any]


def run_flip(
    scene: Scene,
    *,
    margin: float | None = None,
    max_time: float | None = None,
    dt: float = 1e-3,
    replan_every: int = 10,
    progress: Callable[[float, float], None] | None = None,
) -> FlipRun:
    """The scene's flip task through the core (see the module's docstring).

    Args:
        scene: a scene whose ``[task]`` is a flip given as phases.
        margin: [N m] every phase's margin (None: each phase's own).
        max_time: [s] the longest simulated time (None: the task's ``max_time``; 0: plan only).
        dt: [s] the step.
        replan_every: steps between plans.
        progress: called with (simulated time, max_time) along the run.

    Raises:
        SceneError: no task as phases, or not a flip (:func:`~frcontrol.planning.flip.flip_task`).
        InputError: no inputs, an input's limits infinite or empty; a bad step, time, count or margin.
    """
    check_flip_inputs(scene)
    task = flip_task(scene)
    if max_time is not None and max_time <= 0:
        return _plan_only(scene, task, margin)
    result = plan_task(scene, dt=dt, replan_every=replan_every, max_time=max_time, margin=margin,
                       progress=progress)
    first = result.run.records[0].decisions[0][1]
    plan = first_plan(scene, task, first)
    return FlipRun(result, flip_result(scene, task, plan, result), result.to_dict(scene))


def _plan_only(scene: Scene, task: FlipTask, margin: float | None) -> FlipRun:
    """The first decision at the scene's state; nothing simulated."""
    phase = read_task(scene).sequence()[0]
    phase = phase if margin is None else replace(phase, margin=margin)
    decision = decide(replace(scene, gap_tolerance=REPLAN_GAP_TOLERANCE), phase)
    return FlipRun(None, first_plan(scene, task, decision), plan_only_document(scene, phase, decision))


def plan_only_document(scene: Scene, phase: Phase, decision: Decision) -> dict[str, Any]:
    """``outcome`` and ``phases`` when only the first decision is made (``max_time`` 0).

    As :meth:`~frcontrol.planning.core.report.PlanResult.to_dict` has them (modes over every scene
    contact beside the planned ones).
    """
    why = "not simulated (--max-time 0)"
    document = {
        "outcome": {"achieved": False, "reason": why},
        "phases": [{"name": phase.name, "start": 0.0, "end": 0.0, "why": why, "met": False,
                    "plans": [{"time": 0.0, **decision.to_dict()}]}],
    }
    return add_scene_modes(to_jsonable(document), [c.name for c in scene.contacts])


def first_plan(scene: Scene, task: FlipTask, decision: Decision) -> FlipPlan:
    """The core's first decision as the flip's plan (its analysis recomputed for the figure)."""
    tried = tuple(decision.tried)
    modes = tuple(dict.fromkeys([m for m, _ in tried] + ([decision.mode] if decision.mode else [])))
    return FlipPlan(
        found=decision.found, mode=decision.mode,
        torques=dict(decision.inputs) if decision.found else {},
        pitch_acceleration=decision.objective, worst_case=False, unambiguous=decision.found,
        margin=decision.margin, rounding=TORQUE_ROUNDING, candidates=modes, bounds={}, explored=modes,
        pieces=(), rejected=tried, forced_inputs=dict(decision.forced),
        planned_inputs=tuple(n for n in scene.inputs.coordinates if n not in decision.forced),
        contacts=decision.contacts,
        body_contacts=tuple(c for c in decision.contacts if c in task.body_contacts),
        pitch=task.pitch, reason=decision.reason, timings={},
        tolerances={"rounding": TORQUE_ROUNDING, "velocity": VELOCITY_TOLERANCE,
                    "interior": poly.INTERIOR_TOLERANCE, "input_limit": INPUT_LIMIT_TOLERANCE,
                    "vertical": VERTICAL_TOLERANCE},
        analysis=_analysis(scene), scene_contacts=tuple(c.name for c in scene.contacts),
    )


def _analysis(scene: Scene) -> Any:
    """The engine's analysis at the scene's state over the planned inputs (the figure's input space)."""
    here = replace(scene, gap_tolerance=REPLAN_GAP_TOLERANCE)
    try:
        full = ContactProblem.from_scene(here, velocity_tolerance=VELOCITY_TOLERANCE)
        return planning_problem(full, DEFAULT_SETTINGS)[1]
    except FrcontrolError:  # no input space to draw: the figure says so
        return None


def flip_result(scene: Scene, task: FlipTask, plan: FlipPlan, result: PlanResult) -> FlipResult:
    """The flip's verdict read from the run's samples (see the module's docstring)."""
    traj = result.trajectory
    pitch = traj.q[:, task.pitch_index]
    reached = np.nonzero(pitch >= task.vertical)[0]
    crossed = int(reached[0]) if reached.size else None
    end = len(traj.times) - 1 if crossed is None else crossed
    separation, body_events = body_contact_events(scene, traj, task.body_contacts, end)
    decisions = [(t, d) for record in result.run.records for t, d in record.decisions]
    timings = result.timings
    return FlipResult(
        plan=plan, trajectory=traj, flipped=crossed is not None,
        time_to_vertical=None if crossed is None else _crossing(traj.times, pitch, task.vertical, crossed),
        body_contact_kept=separation is None, separation=separation, body_events=body_events,
        steps=len(traj.times) - 1, replans=len(decisions) - 1,
        held=tuple((t, str(d.reason)) for t, d in decisions if not d.found),
        plans=tuple((t, d.mode, dict(d.inputs)) for t, d in decisions), modes=tuple(traj.modes or ()),
        reason=None if crossed is not None else _why_not(result, pitch, task), vertical=task.vertical,
        dt=result.run.dt, max_time=result.run.max_time, armature=float(scene.model.armature),
        timings={"first_plan": 0.0, "simulation": timings["simulation"], "replanning": timings["planning"],
                 "total": timings["total"]},
    )


def _crossing(times: np.ndarray, pitch: np.ndarray, vertical: float, k: int) -> float:
    """[s] When the pitch reached ``vertical``: linear between samples k - 1 and k."""
    if k == 0:
        return 0.0
    t_a, t_b, p_a, p_b = times[k - 1], times[k], pitch[k - 1], pitch[k]
    return float(t_a + (vertical - p_a) / (p_b - p_a) * (t_b - t_a))


def _why_not(result: PlanResult, pitch: np.ndarray, task: FlipTask) -> str:
    failure = getattr(result.trajectory, "failure", None)
    if failure is not None:
        return f"the simulation {result.trajectory.status} at t = {failure.time:.4g} s: {failure.reason}"
    return (f"the pitch reached {float(np.max(pitch)):.4f} rad within {result.run.max_time:g} s, short of "
            f"vertical ({task.vertical:.4f} rad)")


def flip_document(run: FlipRun) -> dict[str, Any]:
    """The ``frc flip --json`` document: the flip's keys, and ``outcome`` and ``phases`` as ``frc plan``'s.

    The short names' one rule (:func:`~frcontrol.planning.core.report.with_legacy_keys`): ``frc plan``'s
    document of the run with the flip's documented keys merged in.
    """
    return with_legacy_keys(run.document, run.flip.to_dict())
