r"""The climb's runs: its plan under sampled disturbances, and ``frc climb``'s report of the task run.

:func:`simulate_climb` runs :func:`~frcontrol.planning.climb.plan_climb`'s constant torques in the
rigid time stepper with disturbance forces ``J_d(q)^T d(t)``, ``d`` drawn from ``conv(V_s)`` and
held for ``hold`` seconds (half the draws a random vertex, half a random convex combination of the
vertices), and reports whether the brace held (every brace contact loaded and sticking throughout,
tangential slip at most ``slip_tolerance``), the largest slip and the head's rise. The default
horizon, :data:`DEFAULT_DURATION` = 0.1 s, is the plan's own time scale.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import InputError
from ..jsonable import to_jsonable
from ..modes import add_scene_modes
from ..polytope import Polytope
from ..scene import Inputs, Scene
from ..simulation.closed_loop import Policy, run_closed_loop
from ..simulation.inputs import check_seed, check_simulation_times
from ..simulation.rigid import RigidSettings, RigidStepper
from ..simulation.trajectory import Trajectory
from . import DEFAULT_CLIMB_DURATION
from .climb import ClimbPlan, ClimbResult
from .climb_problem import load_climb_task, piece_rows
from .core.report import PlanResult, with_legacy_keys
from .disturbances import DEFAULT_HOLD, HOLD_INDEX_ROUNDOFF, PointKinematics, sample_disturbances

__all__ = [
    "BRACE_SLIP_TOLERANCE",
    "DEFAULT_DURATION",
    "BraceVerdict",
    "ClimbCheckSettings",
    "brace_verdict",
    "climb_document",
    "robust_region",
    "simulate_climb",
]

BRACE_SLIP_TOLERANCE = 1e-4
"""[m] Largest tangential displacement of a brace contact for which the brace counts as held."""

DEFAULT_DURATION = DEFAULT_CLIMB_DURATION
"""[s] Simulated time of :func:`simulate_climb` (the constant torques are an instantaneous plan)."""

@dataclass(frozen=True)
class ClimbCheckSettings:
    """How :func:`simulate_climb` runs a plan.

    Attributes:
        duration: [s] simulated time.
        dt: [s] time step.
        hold: [s] each sampled disturbance is held this long (zero-order hold).
        seed: the random generator's seed (an integer >= 0).
        scale: the disturbance scale (None: the plan's).
        slip_tolerance: [m] see :data:`BRACE_SLIP_TOLERANCE`.
    """

    duration: float = DEFAULT_DURATION
    dt: float = 1e-3
    hold: float = DEFAULT_HOLD
    seed: int = 0
    scale: float | None = None
    slip_tolerance: float = BRACE_SLIP_TOLERANCE


def simulate_climb(
    scene: Scene,
    plan: ClimbPlan,
    settings: ClimbCheckSettings | None = None,
    *,
    progress: Callable[[float, float], None] | None = None,
) -> ClimbResult:
    """Simulate the planned torques with disturbances sampled from ``conv(V_s)`` (rigid contact).

    Args:
        scene: the planned scene.
        plan: a found plan.
        settings: the run's time, step, hold, seed, scale and slip tolerance (default: the defaults).
        progress: called with (simulated time [s], duration [s]) after every step.

    Raises:
        InputError: the plan was not found, or a bad duration, step, hold, scale or seed.
    """
    settings = settings or ClimbCheckSettings()
    duration, hold = settings.duration, settings.hold
    s = _check_simulation_request(plan, duration, settings.dt, hold, settings.scale)
    seed = check_seed(settings.seed)
    count = max(1, int(math.ceil(duration / hold)))
    samples = sample_disturbances(plan.disturbances.robust_points(s), count, np.random.default_rng(seed))
    kin = PointKinematics(scene, [(d.name, d.link, d.point_in_link) for d in plan.disturbances.items])
    n = scene.robot.nv
    every = Inputs(scene.coordinate_names, tuple(range(n)), np.full(n, -np.inf), np.full(n, np.inf))
    stepper = RigidStepper(replace(scene, inputs=every), RigidSettings(max_ambiguity_checks=0))
    run = run_closed_loop(stepper, _disturbed_torques(scene, plan, kin, samples, hold), duration, settings.dt,
                          progress=progress)
    task = plan.problem.task
    verdict = brace_verdict(scene, run.trajectory, task.brace_contacts, (task.head_link, task.head_point),
                            settings.slip_tolerance)
    return ClimbResult(
        trajectory=run.trajectory, brace_held=verdict.held, max_slip=verdict.max_slip,
        max_opening=verdict.max_opening, upper_rise=verdict.upper_rise,
        max_upper_rise=verdict.max_upper_rise, duration=float(run.trajectory.duration),
        brace_events=verdict.events, disturbance_times=hold * np.arange(count), disturbance_samples=samples,
        status=run.trajectory.status, slip_tolerance=settings.slip_tolerance, seed=seed)


def _check_simulation_request(plan: ClimbPlan, duration: float, dt: float, hold: float,
                              scale: float | None) -> float:
    """The disturbance scale to simulate, once the plan and the times are checked.

    Raises:
        InputError: the plan was not found, or a bad duration, step, hold or scale.
    """
    if not plan.found:
        raise InputError(f"the climb plan was not found ({plan.reason}): nothing to simulate")
    check_simulation_times(duration, dt)
    if not (isinstance(hold, (int, float)) and math.isfinite(hold) and hold > 0):
        raise InputError(f"hold must be a finite number > 0 [s], got {hold!r}")
    s = plan.scale if scale is None else float(scale)
    if not (math.isfinite(s) and s >= 0):
        raise InputError(f"scale must be a finite number >= 0, got {scale!r}")
    return s


def _disturbed_torques(scene: Scene, plan: ClimbPlan, kin: PointKinematics, samples: np.ndarray,
                       hold: float) -> Policy:
    """The policy of the climb's run: the plan's torques plus the held disturbance sample.

    Its command is the generalized force on every coordinate, ``S^T u + J_d^T d_k`` with ``d_k``
    the sample held at the step's time (sample ``k`` from ``k hold`` on) and ``J_d`` the
    disturbances' point Jacobians at the step's state.
    """
    torque_force = scene.inputs.selection_transpose(scene.robot.nv) @ plan.torque_vector
    n_d = plan.disturbances.dim
    last = len(samples) - 1

    def generalized_force(stepper: RigidStepper) -> np.ndarray:
        k = min(int(stepper.t / hold + HOLD_INDEX_ROUNDOFF), last)
        jac, _, _ = kin.evaluate(stepper.q, stepper.v)
        return torque_force + jac[:n_d].T @ samples[k]

    return generalized_force


@dataclass(frozen=True)
class BraceVerdict:
    """The brace's verdict on a run, read from its samples.

    Attributes:
        held: the run completed, every brace contact was loaded at every step, none opened or
            slipped (events), and none moved along its wall by more than the slip tolerance.
        max_slip: [m] the largest tangential displacement of a brace contact point.
        max_opening: [m] the largest normal displacement away from its wall.
        upper_rise: [m] the head's rise over the run; max_upper_rise: [m] its largest at any sample.
        events: the brace contacts' contact events.
    """

    held: bool
    max_slip: float
    max_opening: float
    upper_rise: float
    max_upper_rise: float
    events: tuple


def brace_verdict(scene: Scene, trajectory: Trajectory, brace: Sequence[str], head: tuple[str, np.ndarray],
                  slip_tolerance: float = BRACE_SLIP_TOLERANCE) -> BraceVerdict:
    """Slip, opening, load and events of the brace contacts over ``trajectory``; the head's rise.

    ``head`` is ``(link, point in the link's frame [m])``.
    """
    index = [trajectory.contacts.index(b) for b in brace]
    moved = trajectory.contact_points[:, index, :] - trajectory.contact_points[0, index, :]
    normals = np.array([scene.contacts[i].point.normal_in_world for i in index])
    tangents = np.array([scene.contacts[i].point.tangent_in_world for i in index])
    slip = np.abs(np.einsum("tkj,kj->tk", moved, tangents))
    opening = np.einsum("tkj,kj->tk", moved, normals)
    loaded = trajectory.contact_forces[1:, index, 0] > 0.0
    events = tuple(e for e in trajectory.events if e.contact in brace)
    bad_events = [e for e in events if e.kind in ("open", "slip")]
    max_slip = float(np.max(slip, initial=0.0))
    held = bool(trajectory.completed and np.all(loaded) and not bad_events and max_slip <= slip_tolerance)
    kin = PointKinematics(scene, [("head", head[0], head[1])])
    heights = np.array([kin.positions(q)[-1, 1] for q in trajectory.q])
    return BraceVerdict(held, max_slip, float(np.max(opening, initial=0.0)), float(heights[-1] - heights[0]),
                        float(np.max(heights) - heights[0]), events)


# ==================================================================== frc climb's report
def climb_document(scene: Scene, result: PlanResult) -> dict[str, Any]:
    """``frc climb --json``: the task run's document (``frc plan``'s) with the climb's keys.

    The climb's contract keys come from the run: ``mode``, ``torques`` and ``robust`` (verified at
    every disturbance vertex) from the first phase's first decision, ``max_disturbance_scale``
    from its ``largest_scale`` search (0 when the phase has none), and in ``simulation`` the
    brace's verdict read from the samples (:func:`brace_verdict`: ``brace_held``, ``max_slip``,
    ``upper_rise``...; ``brace_held`` is None when nothing ran, ``max_time`` 0). The brace and the
    head are the task's (:func:`load_climb_task`). They are merged into ``frc plan``'s document by
    the short names' rule (:func:`~.core.report.with_legacy_keys`).
    """
    task = load_climb_task(scene)
    payload = result.to_dict(scene)
    record = result.run.records[0]
    first = record.decisions[0][1] if record.decisions else None
    found = first is not None and first.found
    largest = record.largest_scale
    verdict = brace_verdict(scene, result.trajectory, task.brace_contacts, (task.head_link, task.head_point))
    if found:
        reason = ("the first plan only (max_time 0)" if len(result.trajectory.times) < 2
                  else f"the brace held over the {result.run.max_time:g} s run" if verdict.held
                  else "the brace did not hold over the run (see simulation)")
    else:
        reason = "no plan at the start: " + str(None if first is None else first.reason)
    legacy: dict[str, Any] = {
        "found": found,
        "mode": first.mode if found and first is not None else None,
        "contacts": list(first.contacts) if first is not None else [],
        "torques": dict(first.inputs) if found and first is not None else {},
        "robust": bool(found and first is not None and first.robust),
        "max_disturbance_scale": 0.0 if largest is None else largest.scale,
        "margin": None if first is None else first.margin,
        "min_head_acceleration": task.min_head_acceleration,
        "brace_contacts": list(task.brace_contacts),
        "reason": reason,
    }
    ran = len(result.trajectory.times) > 1  # max_time 0: the first plan only, no verdict
    legacy["simulation"] = {
        "brace_held": verdict.held if ran else None, "max_slip": verdict.max_slip,
        "max_opening": verdict.max_opening, "upper_rise": verdict.upper_rise,
        "max_upper_rise": verdict.max_upper_rise, "duration": float(result.trajectory.times[-1]),
        "slip_tolerance": BRACE_SLIP_TOLERANCE, "brace_events": [e.to_dict() for e in verdict.events],
    }
    payload = with_legacy_keys(payload, legacy)
    return add_scene_modes(to_jsonable(payload), [c.name for c in scene.contacts])


# ==================================================================== robust region (figures)
def robust_region(plan: ClimbPlan, index: int) -> Polytope:
    """The forces of one disturbance for which the plan's torques stay in their piece.

    With the head's acceleration >= a_min too, for every vertex of the other disturbances (at the
    plan's scale): a 2-D polytope over (fx, fy) of disturbance ``index``, bounded by the analysis
    box.
    """
    cp = plan.problem
    m_u = cp.m_u
    A, b, _ = piece_rows(cp.pieces[plan.piece], m_u)
    c, c0 = cp.head_row
    u = plan.torque_vector
    cols = m_u + 2 * index + np.arange(2)
    others = [d for i, d in enumerate(cp.disturbances.items) if i != index]
    other_cols = [m_u + 2 * i + j for i in range(len(cp.disturbances.items)) if i != index for j in range(2)]
    combos = list(itertools.product(*[plan.scale * d.vertices for d in others])) or [()]
    rows, rhs = [], []
    for combo in combos:
        d_other = np.concatenate(combo) if combo else np.zeros(0)
        rows.append(A[:, cols])
        rhs.append(b - A[:, :m_u] @ u - A[:, other_cols] @ d_other)
        rows.append(-c[None, cols])
        rhs.append(np.array([c[:m_u] @ u + c[other_cols] @ d_other + c0 - cp.min_head_acceleration]))
    return Polytope(np.vstack(rows), np.concatenate(rhs))
