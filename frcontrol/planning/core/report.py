"""The report of a task: :class:`PlanResult` and its ``frc plan --json`` document.

``to_dict()`` has the keys every planner result has: ``task`` (the ``[task]`` table as read),
``phases`` (per phase: ``name``, ``start``, ``end``, ``why`` it ended, ``met``, and ``plans``: the
decisions made, each with its time, mode, inputs, objective value and margin), ``outcome``
(``achieved``, ``reason``; when a decision found no plan: ``infeasible`` with the phase, the modes
that could not be made unambiguous and why, and the closest margin found), ``tolerances`` and
``simulation`` (``samples`` in ``frc simulate --json``'s shape, with the per-sample ``modes``). With
``compliant``, ``compliant`` holds the same inputs replayed on the compliant model.

A *short name* (``frc standup``) runs a scene's task exactly as ``frc plan`` does and adds the keys
its command documented before it was one: :func:`with_legacy_keys` is the rule.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ...jsonable import to_jsonable
from ...modes import add_scene_modes
from ...scene import Scene
from ...simulation.compliant import simulate_compliant
from ...simulation.export import sample_modes
from ...simulation.trajectory import Trajectory
from ...solvers import DEFAULT_SETTINGS, SolverSettings
from .decision import CLOSEST_MARGIN_STEPS, TRACK_REGULARIZATION, Decision
from .loop import PhaseRecord, TaskRun, run_task
from .task import Task, read_task
from .timing import PhaseTiming, step_hooks
from .tolerances import REPLAN_GAP_TOLERANCE, REPLAN_VELOCITY_TOLERANCE, SEPARATION_GAP, TORQUE_ROUNDING

__all__ = ["FROM_THE_PLAN", "PlanResult", "plan_task", "schedule_of", "with_legacy_keys"]

FROM_THE_PLAN = frozenset({"phases", "outcome"})
"""The top-level keys of a short name's document that are always ``frc plan``'s, as it gives them."""


@dataclass(frozen=True)
class PlanResult:
    """A task planned along its run, and (optionally) the inputs replayed on the compliant model.

    Attributes:
        task: the task as read.
        run: the rigid closed-loop run.
        trajectory: its trajectory, with the per-sample modes.
        compliant: the compliant replay, or None.
        timings: [s] ``planning``, ``simulation``, ``compliant``, ``total``.
        timing: the task's phase timing (:mod:`.timing`), or None.
    """

    task: Task
    run: TaskRun
    trajectory: Trajectory
    compliant: Trajectory | None
    timings: dict[str, float]
    timing: PhaseTiming | None = None

    @property
    def achieved(self) -> bool:
        """The last phase's ``until`` held within ``max_time``."""
        return self.run.achieved

    def to_dict(self, scene: Scene) -> dict[str, Any]:
        """The ``frc plan --json`` document (see the module's docstring)."""
        document = self.trajectory.to_dict(scene)
        payload: dict[str, Any] = {
            "task": dict(self.task.raw),
            "phases": [_phase_dict(r) for r in self.run.records],
            "outcome": _outcome(self.run),
            "tolerances": {
                "rounding": TORQUE_ROUNDING,
                "separation_gap": SEPARATION_GAP,
                "replan_gap": REPLAN_GAP_TOLERANCE,
                "replan_velocity": REPLAN_VELOCITY_TOLERANCE,
                "closest_margin_steps": CLOSEST_MARGIN_STEPS,
                "track_regularization": TRACK_REGULARIZATION,
            },
            "simulation": {
                "model": "rigid",
                "status": self.trajectory.status,
                "dt": self.run.dt,
                "max_time": self.run.max_time,
                "replan_every": self.run.replan_every,
                "decisions": self.run.decisions,
                "samples": document["samples"],
                "events": document["summary"]["events"],
            },
            "timings": dict(self.timings),
        }
        if self.timing is not None:
            payload["timing"] = {"name": self.task.timing, **self.timing.report(scene, self.trajectory)}
        if self.compliant is not None:
            replay = self.compliant.to_dict(scene)
            payload["compliant"] = {
                "model": "compliant",
                "status": self.compliant.status,
                "samples": replay["samples"],
            }
        return add_scene_modes(to_jsonable(payload), [c.name for c in scene.contacts])


def with_legacy_keys(document: dict[str, Any], legacy: Mapping[str, Any]) -> dict[str, Any]:
    """A short name's document: ``frc plan``'s ``document`` with the command's documented keys merged in.

    The rule: ``phases`` and ``outcome`` (:data:`FROM_THE_PLAN`) are ``frc plan``'s, untouched; every
    other key of ``legacy`` is added, and where both documents hold a table under one key the two are
    merged key by key; on a clash the legacy value is kept, so that a script reads what it read
    before. Keys only ``frc plan`` has are kept. Returns a new document.
    """
    merged = dict(document)
    for key, value in legacy.items():
        if key in FROM_THE_PLAN:
            continue
        here = merged.get(key)
        if isinstance(here, Mapping) and isinstance(value, Mapping):
            merged[key] = {**here, **value}
        else:
            merged[key] = value
    return merged


def _plan_dict(t: float, decision: Decision) -> dict[str, Any]:
    return {"time": t, **decision.to_dict()}


def _phase_dict(record: PhaseRecord) -> dict[str, Any]:
    out = {
        "name": record.name,
        "start": record.start,
        "end": record.end,
        "why": record.why,
        "met": record.met,
        "plans": [_plan_dict(t, d) for t, d in record.decisions],
    }
    if record.largest_scale is not None:
        out["largest_scale"] = record.largest_scale.to_dict()
    return out


def _outcome(run: TaskRun) -> dict[str, Any]:
    """``achieved``, ``reason``, and the first phase whose decision found no plan (``infeasible``)."""
    last = run.records[-1]
    outcome: dict[str, Any] = {
        "achieved": run.achieved,
        "reason": None if run.achieved else f"phase {last.name!r} ended: {last.why}",
    }
    for record in run.records:
        failed = [(t, d) for t, d in record.decisions if not d.found]
        if failed:
            t, d = failed[0]
            outcome["infeasible"] = {
                "phase": record.name,
                "time": t,
                "reason": d.reason,
                "modes": [{"mode": m, "why": why} for m, why in d.tried],
                "closest_margin": d.closest_margin,
                "closest_mode": d.closest_mode,
                "margin": d.margin,
            }
            break
    return outcome


def schedule_of(
    run: TaskRun, trajectory: Trajectory
) -> Callable[[float, np.ndarray, np.ndarray], np.ndarray]:
    """The inputs the rigid run applied, as ``(t, q, v) -> u``, each sample's held over its interval."""
    times = np.asarray(trajectory.times)
    inputs = np.asarray(trajectory.inputs)

    def schedule(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        i = int(np.searchsorted(times, t + 1e-12, side="right")) - 1
        return inputs[min(max(i, 0), len(inputs) - 1)]

    return schedule


def plan_task(
    scene: Scene,
    *,
    dt: float = 1e-3,
    replan_every: int = 10,
    max_time: float | None = None,
    margin: float | None = None,
    compliant: bool = False,
    settings: SolverSettings = DEFAULT_SETTINGS,
    progress: Callable[[float, float], None] | None = None,
) -> PlanResult:
    """Read the scene's task, run it (:func:`~.loop.run_task`) and, with ``compliant``, replay its inputs.

    A task that names a phase timing (``[task] timing``, :mod:`.timing`) runs with it; the result
    keeps it (``timing``).

    Raises:
        SceneError: no task given as phases (:func:`~.task.read_task`).
        InputError: a bad step, time, count or margin.
    """
    start = time.perf_counter()
    task = read_task(scene)
    run = run_task(
        scene,
        task,
        dt=dt,
        replan_every=replan_every,
        max_time=max_time,
        margin=margin,
        settings=settings,
        progress=progress,
    )
    trajectory = run.trajectory
    assert isinstance(trajectory, Trajectory)
    trajectory = replace(
        trajectory,
        modes=tuple(sample_modes(scene, trajectory)),
        info={**trajectory.info, "source": "plan_task"},
    )
    t0 = time.perf_counter()
    replay = None
    if compliant:
        duration = float(trajectory.times[-1])
        hooks = step_hooks(run.timing)  # a timing's stepper scene: the inputs the run applied
        replayed = scene if hooks is None else hooks.stepper_scene(scene)
        replay = (
            simulate_compliant(replayed, schedule_of(run, trajectory), duration, dt) if duration > 0 else None
        )
    timings = {**run.timings, "compliant": time.perf_counter() - t0, "total": time.perf_counter() - start}
    return PlanResult(task, run, trajectory, replay, timings, run.timing)
