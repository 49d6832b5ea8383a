r"""The RHex flip: hip torques that pitch the body up without a body contact separating (METHOD §6).

**The task.** A robot lies on its back; its body touches the ground at some *body contacts* (the
scene's ``[task] body_contacts``, default: the contacts on the root link) and its hips can push its
toes into the ground. Choose the inputs u (within the scene's limits) that maximise the body's
pitch acceleration, the row ``p`` of ``dv`` that belongs to the ``[task] pitch`` coordinate
(default ``theta``)::

    pitch acceleration  =  e_p^T dv  =  c_u^T u + c_w^T w + c_0,
    (c_u, c_w, c_0) = row p of (X_u, X_w, x_0)        (the mode's affine response, METHOD §3)

subject to: the contact mode keeps every active body contact loaded (F, L or R, never S), and u is
*unambiguous*: the rigid model predicts that mode and no other.

**Candidates.** Every feasible mode whose input domain T_c has an interior and whose body contacts
are not S (a mode whose T_c is flat needs its inputs on a hyperplane: rounding breaks it).

**The unambiguous set, shrunk by a margin.** An LP optimum sits on the boundary of its region,
where the mode meets another: there the model predicts both, and rounding the printed torques may
land in the other. The plan therefore keeps a distance ``margin`` [N m] (a Euclidean distance in
input space) from every set of inputs where another mode also holds: the convex pieces of
:func:`~frcontrol.planning.core.pieces.margin_pieces` (T_c shrunk by the margin except at the
input limits, the overlapping and lower-dimensional modes grown by it and cut out; that module's
docstring gives the polyhedral construction).

**The maximisation.** Per piece P: if the pitch does not depend on w, one LP
``max c_u^T u + c_0 over P``. If it does (``c_w != 0``: the motion itself is ambiguous within the
mode), the plan maximises the worst case ``c_u^T u + c_0 + min { c_w^T w : (u, w) in D_c }``. The
inner minimum is an LP whose right-hand side depends on u; its value ``g(u)`` is *convex* in u
(the value of an LP is convex in its right-hand side), so the outer problem maximises a convex
function: no LP (and no LP duality: the dual's objective is bilinear in u and the multipliers),
but its maximum over a polytope is attained at a vertex. The vertices of P are enumerated (every
choice of m active rows, :data:`MAX_VERTEX_CANDIDATES` at most) and the worst case is evaluated at
each by one LP over w: exact. The best piece over all candidates wins; ties keep the first found.

**Rounding and verification.** The optimum is rounded to :data:`TORQUE_ROUNDING` [N m] (and kept
within the limits); the plan is *verified* by :func:`frcontrol.engine.solutions_at` at the
rounded torques: exactly one rigid solution, in the planned mode, with the planned pitch
acceleration (to :data:`PITCH_TOLERANCE`; for a worst-case plan, the solution's pitch is at least
the worst case). A piece whose optimum fails the check is reported and the next best is tried.

**Inputs the model forces.** An input on a coordinate with no inertia, no bias and no active
contact (a massless leg in the air) is forced to 0 by its dynamics row in every mode
(``0 = u_j``); so is the hip of a leg whose toe is lifting off (``v_N > 0``: S only, every mode's
consistency rows ``E u = e`` fix it). Every T_c is then flat and nothing is a candidate. The
planner fixes such inputs at their forced value (moved into the bias, ``h - S_j^T u_j``), analyses
and plans over the others, and reports them (``forced_inputs``).

**Closed loop.** :func:`frcontrol.planning.flip_loop.simulate_flip` re-plans along a rigid
simulation until the body pitches past vertical (that module's docstring); ``frc flip`` runs the
scene's task through the planning core (:func:`frcontrol.planning.core.plan_task`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .. import polytope as poly
from ..engine import DynamicResponse, analyze
from ..errors import InputError
from ..jsonable import finite_or_none, to_jsonable
from ..modes import VELOCITY_TOLERANCE, ContactProblem, add_scene_modes, scene_mode
from ..scene import Scene
from ..solvers import SolverSettings
from . import DEFAULT_FLIP_MARGIN
from .core.forced import fix_inputs, forced_by_every_mode, massless_inputs, structurally_forced
from .core.pieces import margin_pieces, mode_allowed, shrunk_input_domain
from .core.tolerances import (
    FORCED_INPUT_TOLERANCE,
    INPUT_LIMIT_TOLERANCE,
    REPLAN_GAP_TOLERANCE,
    REPLAN_VELOCITY_TOLERANCE,
    SEPARATION_GAP,
    TORQUE_ROUNDING,
)
from .flip_pitch import (
    MAX_VERTEX_CANDIDATES,
    PITCH_TOLERANCE,
    FlipPiece,
    FlipSettings,
    PieceSearch,
    branch_and_bound,
    candidate_bounds,
    maximise_pitch,
    torque_text,
    worst_case_pitch,
)
from .flip_scene import VERTICAL_TOLERANCE, FlipTask, flip_task

__all__ = [
    "DEFAULT_MARGIN",
    "FLIP_ARMATURE",
    "FORCED_INPUT_TOLERANCE",
    "INPUT_LIMIT_TOLERANCE",
    "MAX_VERTEX_CANDIDATES",
    "PITCH_TOLERANCE",
    "VERTICAL_TOLERANCE",
    "REPLAN_GAP_TOLERANCE",
    "REPLAN_VELOCITY_TOLERANCE",
    "SEPARATION_GAP",
    "TORQUE_ROUNDING",
    "FlipPiece",
    "FlipPlan",
    "FlipSettings",
    "FlipProblem",
    "FlipTask",
    "build_flip",
    "check_flip_inputs",
    "flip_task",
    "margin_pieces",
    "massless_inputs",
    "structurally_forced",
    "mode_allowed",
    "maximise_pitch",
    "plan_flip",
    "shrunk_input_domain",
    "worst_case_pitch",
]

# ---------------------------------------------------------------------------------------------
# tolerances and defaults

DEFAULT_MARGIN = DEFAULT_FLIP_MARGIN
"""[N m] Default distance (in input space) between the plan and every input where another mode
also holds: 500 times :data:`TORQUE_ROUNDING`, and small against RHex's 10 N m hip limits."""



FLIP_ARMATURE = 2e-3
r"""[kg m^2] Default rotor inertia of each massless hip coordinate in the flip's simulation (when
the scene's ``[model]`` gives none). RHex (Saranli, Buehler and Koditschek 2001) drives each leg
with a Maxon 20 W motor (rotor inertia of the order of 1e-6 kg m^2) through a 33:1 gearhead:
reflected, 33^2 x 1e-6 = 1.1e-3 kg m^2 per motor, and each planar hip stands for a pair of legs
(two motors). The simulator's default (1e-4 kg m^2) would let a torque spin a free leg up twenty
times faster."""


# ---------------------------------------------------------------------------------------------
# results

@dataclass(frozen=True)
class FlipPlan:
    """A flip plan at one state: the mode, the torques and what was checked.

    Attributes:
        found: a verified plan exists (then every field below describes it).
        mode: the planned mode, one letter per active contact (of ``contacts``).
        torques: [N m] the rounded input per scene input name (forced inputs at 0).
        pitch_acceleration: [rad/s^2] at the rounded torques (the worst case over w if
            ``worst_case``).
        worst_case: the pitch acceleration depended on w and its worst case was maximised.
        unambiguous: ``solutions_at`` at the rounded torques gives exactly one solution, in
            ``mode``, with that pitch acceleration.
        margin: [N m] the distance kept from every other mode's input set.
        rounding: [N m] the quantum the torques were rounded to.
        candidates: the candidate modes considered.
        bounds: [rad/s^2] per candidate, the best pitch acceleration on its shrunk T_c (an upper
            bound of its pieces'; ``inf`` for a worst-case mode, ``-inf`` if the shrunk T_c is empty).
        explored: the candidates whose pieces were built (in order of decreasing bound; the others
            could not beat the plan).
        pieces: the convex pieces built, with their optima, best first.
        rejected: pieces whose optimum failed the verification (mode and why), in the order tried.
        forced_inputs: [N m] inputs the rigid model forces at this state, with their value (a
            massless leg in the air or lifting off: 0); not planned, applied as they are.
        planned_inputs: the inputs planned over (the scene's, minus the forced ones).
        contacts: the active contacts, in mode-letter order.
        scene_contacts: every contact of the scene, in scene order (the letters of a scene mode,
            :func:`~frcontrol.modes.scene_mode`, as the figures show).
        body_contacts: the active body contacts.
        pitch: the pitch coordinate.
        reason: why no plan was found (None when found).
        timings: [s] ``analysis``, ``unambiguous_sets`` (the margin pieces, with the projections
            they need), ``lps`` (the maximisation), ``verification``, ``total``.
        tolerances: the named tolerances used.
        analysis: the engine's analysis the plan was made on (over ``planned_inputs``).
    """

    found: bool
    mode: str | None
    torques: Mapping[str, float]
    pitch_acceleration: float | None
    worst_case: bool
    unambiguous: bool
    margin: float
    rounding: float
    candidates: tuple[str, ...]
    bounds: Mapping[str, float]
    explored: tuple[str, ...]
    pieces: tuple[FlipPiece, ...]
    rejected: tuple[tuple[str, str], ...]
    forced_inputs: Mapping[str, float]
    planned_inputs: tuple[str, ...]
    contacts: tuple[str, ...]
    body_contacts: tuple[str, ...]
    pitch: str
    reason: str | None
    timings: Mapping[str, float]
    tolerances: Mapping[str, float]
    analysis: DynamicResponse | None = field(default=None, repr=False, compare=False)
    scene_contacts: tuple[str, ...] = ()

    def input_vector(self, inputs: Sequence[str]) -> np.ndarray:
        """The torques as a vector in the order of ``inputs`` (the scene's input names)."""
        return np.array([float(self.torques.get(name, 0.0)) for name in inputs])

    def to_dict(self, simulation: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """The ``frc flip --json`` document of the plan (``simulation``: the closed loop's, when run).

        ``mode``, ``torques``, ``pitch_acceleration``, ``unambiguous``, ``margin`` and ``simulation``
        (``flipped``, ``time_to_vertical``, ``body_contact_kept``, ``steps``) are the contract; the rest
        reports how the plan was found. Without a plan ``mode`` and ``torques`` are null and
        ``simulation.flipped`` is false, with the reason.
        """
        plan = self
        payload: dict[str, Any] = {
            "found": plan.found,
            "mode": plan.mode if plan.found else None,
            "torques": dict(plan.torques) if plan.found else None,
            "pitch_acceleration": finite_or_none(plan.pitch_acceleration) if plan.found else None,
            "unambiguous": plan.unambiguous,
            "margin": plan.margin,
            "worst_case": plan.worst_case,
            "reason": plan.reason,
            "pitch": plan.pitch,
            "contacts": list(plan.contacts),
            "body_contacts": list(plan.body_contacts),
            "planned_inputs": list(plan.planned_inputs),
            "forced_inputs": dict(plan.forced_inputs),
            "candidates": list(plan.candidates),
            "bounds": {name: finite_or_none(value) for name, value in plan.bounds.items()},
            "explored": list(plan.explored),
            "pieces": len(plan.pieces),
            "rejected": [{"mode": mode, "why": why} for mode, why in plan.rejected],
            "rounding": plan.rounding,
            "timings": dict(plan.timings),
            "tolerances": dict(plan.tolerances),
        }
        if not plan.found and plan.mode is not None:
            payload["best"] = {"mode": plan.mode, "torques": dict(plan.torques),
                               "pitch_acceleration": finite_or_none(plan.pitch_acceleration)}
        payload["simulation"] = dict(simulation) if simulation is not None else {
            "flipped": False, "time_to_vertical": None, "body_contact_kept": None, "steps": 0,
            "replans": 0, "simulated": False,
            "reason": plan.reason if not plan.found else "not simulated (--max-time 0)",
        }
        return add_scene_modes(to_jsonable(payload), plan.scene_contacts or plan.contacts)

# ---------------------------------------------------------------------------------------------
# building blocks

def check_flip_inputs(scene: Scene) -> None:
    """Raises InputError when the scene has no inputs, or an input's limits are infinite or empty."""
    inputs = scene.inputs
    if inputs.count == 0:
        raise InputError(f"scene {scene.name!r} ({scene.path}) has no inputs: the flip needs hip torques "
                         "to choose; add an [inputs] table naming the hip joints and their limits")
    for name, lo, hi in zip(inputs.coordinates, inputs.lower, inputs.upper, strict=True):
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise InputError(f"input {name!r} has an infinite limit [{lo:g}, {hi:g}]: the flip planner "
                             "maximises over the torque limits; give finite [inputs] lower and upper")
        if hi - lo <= 0.0:
            raise InputError(f"input {name!r} has the limits [{lo:g}, {hi:g}], an interval without "
                             "interior: no torque is unambiguous with a margin; widen the limits")


def _not_found(reason: str, **fields: Any) -> FlipPlan:
    base: dict[str, Any] = {
        "found": False, "mode": None, "torques": {}, "pitch_acceleration": None, "worst_case": False,
        "unambiguous": False, "margin": 0.0, "rounding": TORQUE_ROUNDING, "candidates": (),
        "bounds": {}, "explored": (), "pieces": (), "rejected": (), "forced_inputs": {},
        "planned_inputs": (), "contacts": (), "body_contacts": (), "pitch": "", "reason": reason,
        "timings": {}, "tolerances": {},
    }
    base.update(fields)
    return FlipPlan(**base)


# ---------------------------------------------------------------------------------------------
# the plan


@dataclass(frozen=True)
class FlipProblem:
    """The flip's formulation at a state, before any solver runs (:func:`build_flip`).

    Attributes:
        task: the scene's ``[task]`` (body contacts, pitch coordinate, vertical).
        full: the contact problem with every input.
        problem: the same with the structurally forced inputs fixed (the inputs to plan).
        forced: index into ``full.inputs`` -> the value the rigid model forces it to (a massless
            coordinate with no contact: 0).
        body_contacts: the task's body contacts that are active at the state.
    """

    task: FlipTask
    full: ContactProblem
    problem: ContactProblem
    forced: Mapping[int, float]
    body_contacts: tuple[str, ...]


def build_flip(scene: Scene, *, velocity_tolerance: float = VELOCITY_TOLERANCE,
               problem: ContactProblem | None = None) -> FlipProblem:
    """The flip's formulation: the task, the contact problem and the inputs the model forces.

    No LP is solved: a test can check it without a solver back-end.

    Raises:
        SceneError: a bad ``[task]`` table. InputError: no inputs, or limits without interior.
    """
    check_flip_inputs(scene)
    task = flip_task(scene)
    full = problem if problem is not None else ContactProblem.from_scene(
        scene, velocity_tolerance=velocity_tolerance)
    forced = structurally_forced(full)
    planned = fix_inputs(full, forced) if forced else full
    return FlipProblem(task, full, planned, forced,
                       tuple(c for c in planned.contacts if c in task.body_contacts))


def plan_flip(
    scene: Scene,
    *,
    margin: float = DEFAULT_MARGIN,
    analysis: DynamicResponse | None = None,
    problem: ContactProblem | None = None,
    settings: FlipSettings | None = None,
) -> FlipPlan:
    """The hip torques that maximise the body's pitch acceleration, unambiguously, at the state.

    See the module's docstring for the maths.

    Args:
        scene: the scene at the state to plan at (``scene.at(q, v)`` along a motion).
        margin: [N m] the distance kept from every input where another mode also holds, >= 0.
        analysis: the engine's analysis of this scene at this state (computed if None).
        problem: the contact problem to plan on (default: the scene's at its state, with
            ``velocity_tolerance``); ignored when ``analysis`` is given.
        settings: rounding, the least pitch acceleration, velocity pruning, exhaustive search,
            free letters and the solver settings
            (:class:`~frcontrol.planning.flip_pitch.FlipSettings`; default: its defaults).

    Returns:
        The plan; ``found=False`` with a ``reason`` when no candidate, piece or verified optimum
        exists, or the best pitch acceleration does not exceed ``min_pitch_acceleration``.

    Raises:
        InputError: the scene has no inputs, an infinite or empty torque interval, a negative or
            non-finite margin or rounding, or no rigid-body solution at all within the limits.
        SceneError: a malformed ``[task]`` table.
        ImpactState: a contact moves into its surface.
    """
    start = time.perf_counter()
    settings = settings if settings is not None else FlipSettings()
    rounding, velocity_tolerance = settings.rounding, settings.velocity_tolerance
    _check_plan_options(margin, rounding)
    timings = {"analysis": 0.0, "unambiguous_sets": 0.0, "lps": 0.0, "verification": 0.0}
    t0 = time.perf_counter()
    built = build_flip(scene, velocity_tolerance=velocity_tolerance,
                       problem=analysis.problem if analysis is not None else problem)
    task = built.task
    full, problem, forced, analysis = _planning_analysis(built, analysis, settings.solvers)
    timings["analysis"] = time.perf_counter() - t0
    forced_values = {full.inputs[i]: forced[i] for i in sorted(forced)}
    common = _plan_fields(task, problem, forced_values, analysis, margin=margin, rounding=rounding,
                          velocity_tolerance=velocity_tolerance)
    common["scene_contacts"] = tuple(c.name for c in scene.contacts)
    ready = _candidates(scene, task, full, problem, forced_values, analysis, common["body_contacts"])
    if isinstance(ready, str):
        timings["total"] = time.perf_counter() - start
        return _not_found(ready, timings=timings, **common)
    analysis, candidates = ready
    common["candidates"] = candidates

    # Branch and bound over the candidates: the LP over the shrunk T_c bounds every piece of it.
    t0 = time.perf_counter()
    bounds = candidate_bounds(analysis, candidates, task.pitch_index, margin,
                              settings.solvers)
    timings["lps"] += time.perf_counter() - t0
    common["bounds"] = bounds
    search = PieceSearch(margin, rounding, settings.exhaustive, settings.solvers, settings.free)
    pieces, explored, rejected, chosen = branch_and_bound(
        analysis, problem, candidates, bounds, task.pitch_index, search, timings)
    pieces.sort(key=lambda p: -p.pitch_acceleration)
    common.update({"pieces": tuple(pieces), "explored": tuple(explored), "rejected": tuple(rejected)})
    timings["total"] = time.perf_counter() - start
    floor = settings.min_pitch_acceleration
    return _chosen_plan(scene, chosen, problem.inputs, forced_values, floor, timings, common)


def _plan_fields(task: FlipTask, problem: ContactProblem, forced_values: Mapping[str, float],
                 analysis: DynamicResponse | None, *, margin: float, rounding: float,
                 velocity_tolerance: float) -> dict[str, Any]:
    """The fields of every plan at this state, found or not (the tolerances used included)."""
    return {"margin": float(margin), "rounding": rounding, "forced_inputs": forced_values,
            "planned_inputs": problem.inputs, "contacts": problem.contacts, "pitch": task.pitch,
            "tolerances": {"rounding": rounding, "pitch": PITCH_TOLERANCE, "velocity": velocity_tolerance,
                           "interior": poly.INTERIOR_TOLERANCE, "input_limit": INPUT_LIMIT_TOLERANCE},
            "analysis": analysis,
            "body_contacts": tuple(c for c in problem.contacts if c in task.body_contacts)}


def _check_plan_options(margin: float, rounding: float) -> None:
    """Raises InputError for a negative or non-finite margin or rounding [N m]."""
    if not (isinstance(margin, (int, float)) and math.isfinite(margin) and margin >= 0):
        raise InputError(f"the margin must be a finite number >= 0 [N m], got {margin!r}")
    if not (isinstance(rounding, (int, float)) and math.isfinite(rounding) and rounding >= 0):
        raise InputError(f"the rounding must be a finite number >= 0 [N m], got {rounding!r}")


def _candidates(scene: Scene, task: FlipTask, full: ContactProblem, problem: ContactProblem,
                forced_values: Mapping[str, float], analysis: DynamicResponse | None,
                active_body: tuple[str, ...]) -> tuple[DynamicResponse, tuple[str, ...]] | str:
    """The analysis and the candidate modes to plan in, or why there is nothing to plan.

    The candidates: the feasible modes with a full-dimensional input domain that keep every active
    body contact loaded (not S).

    Raises:
        InputError: no input within the limits gives a rigid-body solution.
    """
    bad = [name for name, value in forced_values.items()
           if not full.lower[full.inputs.index(name)] <= value <= full.upper[full.inputs.index(name)]]
    if bad:
        return (f"the rigid model forces {', '.join(bad)} to a value outside its limits "
                f"({torque_text({n: forced_values[n] for n in bad})})")
    if problem.m == 0 or analysis is None:  # the analysis exists whenever an input is planned
        return (f"every input is forced at this state ({torque_text(dict(forced_values))}: e.g. "
                "massless legs without ground contact)")
    if not analysis.feasible_modes:
        raise InputError(f"no input within the torque limits gives a rigid-body solution of scene "
                         f"{scene.name!r} at this state (every contact mode's domain is empty): check "
                         "the [inputs] limits")
    if not active_body:
        return f"no body contact ({', '.join(task.body_contacts)}) touches the ground"
    body_index = [problem.contacts.index(c) for c in active_body]
    candidates = tuple(
        m.mode for m in analysis.feasible_modes
        if m.inputs_full_dimensional and all(m.mode[i] != "S" for i in body_index)
    )
    if not candidates:
        return ("no contact mode with a full-dimensional input domain keeps every body "
                f"contact ({', '.join(active_body)}) loaded")
    return analysis, candidates


def _chosen_plan(scene: Scene, chosen: tuple[FlipPiece, np.ndarray, float] | None,
                 planned_inputs: Sequence[str], forced_values: Mapping[str, float],
                 min_pitch_acceleration: float | None, timings: dict[str, float],
                 common: dict[str, Any]) -> FlipPlan:
    """The plan of the chosen piece's rounded torques.

    Not found without pieces, without a verified optimum, or when the best does not start the flip.
    """
    if not common["pieces"]:
        return _not_found(f"no candidate mode ({', '.join(common['candidates'])}) has an unambiguous "
                          f"input {common['margin']:g} N m away from every other mode", timings=timings,
                          **common)
    if chosen is None:
        return _not_found("no piece's optimum gives exactly one rigid solution once rounded "
                          f"(tried {len(common['rejected'])})", timings=timings, **common)
    piece, u, pitch = chosen
    torques = {name: forced_values.get(name, 0.0) for name in scene.inputs.coordinates}
    torques.update({name: float(value) for name, value in zip(planned_inputs, u, strict=True)})
    plan = FlipPlan(found=True, mode=piece.mode, torques=torques, pitch_acceleration=pitch,
                    worst_case=piece.worst_case, unambiguous=True, reason=None, timings=timings,
                    **common)
    if min_pitch_acceleration is not None and not (
            pitch > min_pitch_acceleration + PITCH_TOLERANCE * (1.0 + abs(pitch))):
        return replace(plan, found=False, reason=(
            f"the best unambiguous torques ({torque_text(torques)}, mode "
            f"{scene_mode(piece.mode, common['contacts'], common['scene_contacts'])}) give a pitch "
            f"acceleration of {pitch:.6g} rad/s^2, not above {min_pitch_acceleration:g}: no torque "
            "within the limits starts the flip"))
    return plan


def _planning_analysis(built: FlipProblem, analysis: DynamicResponse | None, solvers: SolverSettings
                       ) -> tuple[ContactProblem, ContactProblem, dict[int, float], DynamicResponse | None]:
    """The problem to plan on and its analysis, with every input the rigid model forces fixed.

    Returns:
        (the full problem, the one without the forced inputs, forced input index -> value, its
        analysis or None when every input is forced).
    """
    full, planned, forced = built.full, built.problem, dict(built.forced)
    if forced:
        analysis = None
    if planned.m and analysis is None:
        analysis = analyze(planned, settings=solvers)
    if analysis is not None and not any(m.inputs_full_dimensional for m in analysis.feasible_modes):
        more = forced_by_every_mode(analysis)
        if more:
            names_left = planned.inputs
            forced.update({full.inputs.index(names_left[i]): value for i, value in more.items()})
            planned = fix_inputs(full, forced)
            analysis = analyze(planned, settings=solvers) if planned.m else None
    return full, planned, forced, analysis

