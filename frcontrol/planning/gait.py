r"""The snake's climbing gait: alternating braces in the vertical channel (METHOD §6).

The single climb (:mod:`frcontrol.planning.climb`) holds one V-brace while the head rises for an
instant. The gait repeats four phases per cycle, each with its own contact mode:

1. ``extend``: the lower V-brace (the scene's ``[task] brace_contacts``, three contacts, left,
   right, left) holds in mode F; the upper brace's contacts (``[task] upper_brace_contacts``, two
   contacts on upper links against the right and the left wall, separated at the scene's state)
   open (mode S while they still touch) and the upper body extends upward;
2. ``upper_brace``: the lower brace still holds; the upper contacts approach their walls slowly and
   are held in mode F as each one closes;
3. ``pull``: the upper brace holds (F); the lower brace's contacts open (S) and the lower body is
   pulled up by the stroke;
4. ``lower_brace``: the lower contacts close again, higher up, and are held in F.
The reference's geometry is :mod:`frcontrol.planning.gait_geometry`'s, the control step
:mod:`frcontrol.planning.gait_control`'s, the hand-overs' checks :mod:`frcontrol.planning.gait_handover`'s,
the run, a phase timing of the planning core, :mod:`frcontrol.planning.gait_timing`'s, and the
gait as the scene's task ``[task.gait]`` :mod:`frcontrol.planning.gait_run`'s.

Certificates (planning, before the run)
---------------------------------------
- *Each phase* is planned by :func:`~frcontrol.planning.climb.plan_climb` (the robust LP, the
  bisection on the scale and the exact exclusion of every other mode) at the phase's starting
  shape, with its brace contacts as the scene's only contacts and, as the "head", the point the
  phase moves (the upper brace's first point for ``extend`` and ``upper_brace``, the tail for
  ``pull`` and ``lower_brace``) required to accelerate upward by at least
  :data:`PHASE_MIN_RISE_ACCELERATION`. Its largest disturbance scale is the phase's; the weakest
  phase is the one with the smallest. The run's disturbances are sampled at
  ``min(1, weakest scale)``.
- *Each hand-over* (both braces touching, at rest, at the planned shape) is checked for ambiguity:
  the next phase's torques (the tracking LP above at that state) are fixed, and for every other mode
  of all five contacts one LP decides whether it holds for some disturbance of ``conv(V_s)``
  (:func:`~frcontrol.planning.exclusions.mode_exclusions`). A mode that holds and lets a brace contact
  slide (L or R) is a *slip mode*; the check passes when none holds.

The simulation (the core's loop with :class:`~frcontrol.planning.gait_timing.GaitTiming`) runs
the rigid time stepper with the tracking LP's torques plus disturbances ``J_d(q)^T d(t)``, ``d``
sampled in ``conv(V_s)`` (``s``: :data:`~frcontrol.planning.gait_timing.SIMULATION_SCALE` unless given)
and held for :data:`~frcontrol.planning.disturbances.DEFAULT_HOLD`. The reference of each phase starts
from the braces where they closed (:meth:`~frcontrol.planning.gait_geometry.GaitGeometry.measure`). A brace
*slips* when a contact the controller holds (F) slides, over a phase, by more than
:data:`~frcontrol.planning.climb_check.BRACE_SLIP_TOLERANCE`: the slide sums ``|v_T+| h``, the
sliding velocity each step's friction law gave the contact (``v_T+ = J_T(q) v+``). Its
displacement along the wall (``max_drift``) is reported apart: it adds the time stepping's drift,
first order in h.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import InputError, SceneError
from ..jsonable import finite_or_none
from ..scene import Scene
from ..scene_tables import TaskTable
from ..solvers import DEFAULT_LP_SOLVER
from . import DEFAULT_CLIMB_MARGIN
from .climb import ClimbPlan, plan_climb
from .climb_problem import load_climb_task
from .disturbances import (
    DisturbanceSet,
    load_disturbances,
)
from .gait_geometry import STANDOFF, STROKE, GaitGeometry, gait_geometry
from .gait_handover import PHASE_ROLES, HandOver, hand_overs

__all__ = [
    "PHASES",
    "PHASE_MIN_RISE_ACCELERATION",
    "GaitPlan",
    "PhaseCertificate",
    "gait_braces",
    "plan_gait",
]

PHASES = ("extend", "upper_brace", "pull", "lower_brace")
"""The four phases of a cycle, in order."""

PHASE_MIN_RISE_ACCELERATION = 0.0
"""[m/s^2] The upward acceleration each phase's certificate (the climb's LP) requires of the
point the phase moves: the point must not fall."""

@dataclass(frozen=True)
class PhaseCertificate:
    """One phase's plan by the climb's robust LP (module docstring, "Certificates").

    Attributes:
        name: the phase; cycle: its cycle (1-based).
        held, released, closing: the contacts the phase holds (F), opens (S) and closes.
        mover: ``(link, point [m])`` of the point the phase moves (the certificate's head).
        start: the planned configuration at the phase's start.
        plan: the climb plan at that configuration (its brace: ``held``).
    """

    name: str
    cycle: int
    held: tuple[str, ...]
    released: tuple[str, ...]
    closing: tuple[str, ...]
    mover: tuple[str, np.ndarray]
    start: np.ndarray
    plan: ClimbPlan

    @property
    def scale(self) -> float:
        """The phase's largest disturbance scale (0 when no plan was found)."""
        return float(self.plan.max_disturbance_scale) if self.plan.found else 0.0

    def to_dict(self) -> dict[str, Any]:
        """The phase's plan as JSON."""
        plan = self.plan
        return {"name": self.name, "cycle": self.cycle, "mode": plan.mode,
                "contacts": list(plan.problem.problem.contacts), "held": list(self.held),
                "released": list(self.released), "closing": list(self.closing),
                "mover": {"link": self.mover[0], "point": self.mover[1]}, "start_q": self.start,
                "found": plan.found, "robust": plan.robust, "max_disturbance_scale": self.scale,
                "torques": dict(plan.torques), "robustness_radius": finite_or_none(plan.robustness_radius),
                "modes_excluded": sum(not e.held for e in plan.exclusions), "reason": plan.reason}


@dataclass(frozen=True, eq=False)
class GaitPlan:
    """The planned gait: the phases' certificates, the hand-overs' checks and the scale to run.

    Attributes:
        scene: the scene; geometry: the snake and channel.
        cycles: number of cycles.
        lower, upper: the braces' contacts.
        phases: every phase's certificate, in order (4 per cycle).
        hand_overs: the checks at each hand-over, in order (2 per cycle).
        scale: the disturbance scale of the run: ``min(1, weakest phase's scale)``.
        margin: [N m or N] the robustness radius asked.
        disturbances: the polytope P.
        solver: the LP back-end.
        timings: [s] per stage.
    """

    scene: Scene
    geometry: GaitGeometry
    cycles: int
    lower: tuple[str, ...]
    upper: tuple[str, ...]
    phases: tuple[PhaseCertificate, ...]
    hand_overs: tuple[HandOver, ...]
    scale: float
    margin: float
    disturbances: DisturbanceSet
    solver: str
    timings: Mapping[str, float] = field(default_factory=dict)

    @property
    def weakest(self) -> PhaseCertificate:
        """The phase with the smallest largest disturbance scale (the first such)."""
        return min(self.phases, key=lambda p: p.scale)

    @property
    def unambiguous(self) -> bool:
        """Every hand-over passed its check."""
        return all(h.unambiguous for h in self.hand_overs)


def _check_cycles(cycles: int) -> int:
    if isinstance(cycles, bool) or not isinstance(cycles, int) or cycles < 1:
        raise InputError(f"cycles must be an integer >= 1, got {cycles!r}")
    return cycles


def gait_braces(scene: Scene) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The lower brace (the climb's, :func:`~.climb_problem.load_climb_task`) and the upper one.

    The upper brace is ``[task] gait = { upper_brace = [...] }`` beside a task given as phases, or
    ``[task] upper_brace_contacts`` beside the climb's older keys.

    Raises:
        SceneError: no upper brace, an unknown contact in it, one that touches at the scene's
            state, or not two of them (right wall, then left wall).
    """
    path = str(scene.path)
    lower = load_climb_task(scene).brace_contacts
    raw = scene.raw.get("task", {})
    phased = "phases" in raw
    key = "task.gait.upper_brace" if phased else "task.upper_brace_contacts"
    upper = tuple(raw["gait"]["upper_brace"]) if "gait" in raw else scene.task.upper_brace_contacts
    if upper is None:
        hint = "[task] gait = { upper_brace = [...] }" if phased else "[task] upper_brace_contacts"
        raise SceneError(path, key, "missing: the gait (--cycles) needs the upper brace's contacts "
                         f"({hint}), separated at the scene's state")
    by_name = {c.name: c for c in scene.contacts}
    for i, name in enumerate(upper):
        if name not in by_name:
            raise SceneError(path, f"{key}[{i}]", f"unknown contact {name!r}; the "
                             f"contacts are: {', '.join(by_name)}")
        if by_name[name].active:
            raise SceneError(path, f"{key}[{i}]", f"contact {name!r} touches at the "
                             "scene's state: the upper brace must be separated at the start")
    if len(upper) != 2:
        raise SceneError(path, key, f"expected two contacts (j6 on the right wall, "
                         f"j8 on the left wall), got {list(upper)}")
    return lower, tuple(upper)


def _phase_scene(scene: Scene, q: np.ndarray, brace: Sequence[str], mover: tuple[str, np.ndarray]) -> Scene:
    """The scene at ``q`` (at rest) with only ``brace`` active and the mover as the climb's head."""
    at = scene.at(q, np.zeros(scene.robot.nv))
    contacts = tuple(replace(c, active=c.name in brace) for c in at.contacts)
    table = scene.task if isinstance(scene.task, TaskTable) else TaskTable()
    task = replace(table, brace_contacts=tuple(brace),
                   head_link=mover[0], head_point=np.asarray(mover[1], dtype=float),
                   min_head_acceleration=PHASE_MIN_RISE_ACCELERATION)
    return replace(at, contacts=contacts, task=task)


def _phase_starts(plan_geometry: GaitGeometry, scene: Scene, cycles: int
                  ) -> list[tuple[str, int, np.ndarray]]:
    """Every phase's name, cycle and planned starting configuration."""
    d_min, d_max = STROKE
    rise = d_max - d_min
    geo = plan_geometry
    out = []
    for c in range(cycles):
        y, y_next = c * rise, (c + 1) * rise
        out += [("extend", c + 1, scene.q if c == 0 else geo.configuration(geo.nominal(y, d_min))),
                ("upper_brace", c + 1, geo.configuration(geo.nominal(y, d_max, 0.0, STANDOFF))),
                ("pull", c + 1, geo.configuration(geo.nominal(y, d_max))),
                ("lower_brace", c + 1, geo.configuration(geo.nominal(y_next, d_min, STANDOFF, 0.0)))]
    return out


def plan_gait(
    scene: Scene,
    cycles: int,
    *,
    margin: float = DEFAULT_CLIMB_MARGIN,
    solver: str = DEFAULT_LP_SOLVER,
    braces: tuple[tuple[str, ...], tuple[str, ...]] | None = None,
) -> GaitPlan:
    """Plan the gait: each phase's certificate, each hand-over's check, the run's scale.

    The channel is the same at every height, so the phases of cycles 2.. are cycle 2's problems
    shifted up: each distinct problem is planned once (the first extension starts from the scene's
    state and is its own). ``braces`` is ``(lower, upper)``; default: :func:`gait_braces`.

    Raises:
        InputError: a bad number of cycles or margin.
        SceneError: bad ``[task]`` or ``[[disturbances]]`` tables, or a robot or scene the gait is
            not built for (:func:`gait_geometry`, :func:`gait_braces`).
    """
    start = time.perf_counter()
    _check_cycles(cycles)
    lower, upper = gait_braces(scene) if braces is None else braces
    geometry = gait_geometry(scene, lower)
    dist = load_disturbances(scene)
    by_name = {c.name: c.point for c in scene.contacts}
    movers = {"lower": (by_name[lower[0]].link, by_name[lower[0]].point_in_link),
              "upper": (by_name[upper[0]].link, by_name[upper[0]].point_in_link)}
    roles = {"lower": lower, "upper": upper, "": ()}
    done: dict[tuple[str, bool], ClimbPlan] = {}
    phases = []
    for name, cycle, q in _phase_starts(geometry, scene, cycles):
        held, released, closing = (roles[r] for r in PHASE_ROLES[name])
        mover = movers["upper" if name in ("extend", "upper_brace") else "lower"]
        key = (name, name == "extend" and cycle == 1)
        if key not in done:
            done[key] = plan_climb(_phase_scene(scene, q, held, mover), margin=margin, solver=solver)
        phases.append(PhaseCertificate(name, cycle, held, released, closing, mover, q, done[key]))
    timings = {"phases": time.perf_counter() - start}
    scale = min(1.0, min(p.scale for p in phases))
    t0 = time.perf_counter()
    checks = hand_overs(scene, geometry, dist, (lower, upper), cycles, scale, solver=solver)
    timings["hand_overs"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - start
    return GaitPlan(scene, geometry, cycles, lower, upper, tuple(phases), checks, scale, float(margin),
                    dist, solver, timings)


