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
input space) from every set of inputs where another mode also holds::

    U_c(margin) = { u : B(u, margin) ⊂ T_c  and  B(u, margin) ∩ T_j = ∅ for every j in O_c },

with B(u, r) the ball of radius r and O_c the modes whose T_j meets T_c in more than a boundary:
the modes that *overlap* T_c (interiors meet, :attr:`DynamicResponse.overlaps`) and the
*lower-dimensional* modes (T_j flat, e.g. a massless leg whose toe separates forces its hip torque
to 0: ``E u = e``). A full-dimensional mode that does not overlap T_c is separated from it by a
hyperplane, so the first condition already keeps B(u, margin) out of it. Polyhedrally:

- ``B(u, m) ⊂ T_c``: every row ``a^T u <= b`` of T_c tightened to ``a^T u <= b - m |a|``, except
  the rows that are input limits (no mode lies beyond a limit: a torque at its limit stays there
  when rounded, so the limits are not shrunk);
- ``B(u, m) ∩ T_j = ∅``: u violates some row of T_j by at least m, ``a^T u >= b + m |a|`` (an
  equality row ``E_r u = e_r`` counts as the two rows ``±(E_r u - e_r) <= 0``: one side or the
  other). This union of half-spaces is the complement of T_j grown by m row by row; it is exact
  away from T_j's corners and conservative near them (where the grown polytope has corners and
  the ball's sum is round).

U_c(m) is built as a union of convex pieces by the region difference (METHOD §5; the same
recursion as :func:`frcontrol.polytope.set_difference`): starting from the shrunk T_c, each piece
R that meets the grown T_j with an interior is replaced by the pieces
``R ∩ {row k of T_j violated by >= m} ∩ {rows i < k violated by <= m}`` (disjoint interiors,
same union); pieces without an interior (Chebyshev radius <= ``INTERIOR_TOLERANCE``) are dropped.
At ``margin = 0`` the pieces cover the engine's unambiguous set (:meth:`unambiguous_set`) with the
lower-dimensional sets cut out; a piece boundary *inside* U_c never shrinks anything (the pieces are
not shrunk one by one), which is why the pieces are built here rather than by shrinking the
engine's pieces (shrinking those would also pull in from their shared facets).

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

**Closed loop.** :func:`simulate_flip` re-plans every ``replan_every`` steps at the simulated state
(:meth:`Scene.at`) and applies the plan's rounded torques to one rigid time stepper
(:class:`frcontrol.simulation.rigid.RigidStepper`: velocity-level time stepping, contacts open and
close, inelastic impacts absorbed by the steps' LCPs: ``impact_law=False``, without the split at
landings and the restitution of :func:`~frcontrol.simulation.rigid.simulate_rigid`, whose
instantaneous impacts can end a flip short of vertical: a toe's impact lifts the front corner)
until the pitch passes vertical or ``max_time``: the re-planning is the
policy of :func:`frcontrol.simulation.closed_loop.run_closed_loop`, which holds the torques between
plans. The run is one trajectory, checked for validity like any rigid simulation.

*Re-planning model:* the scene at the simulated state (:meth:`Scene.at`) with the contacts
within :data:`REPLAN_GAP_TOLERANCE` of their surface or loaded by the last step (a loaded
contact's normal velocity taken as 0, see :func:`_replan`), velocities of at most
:data:`REPLAN_VELOCITY_TOLERANCE` taken as zero, and any sign of pitch acceleration accepted.
When no plan is made the torques are *held* (the reason is recorded in ``held``): at an impact
(a contact moving into its surface: the acceleration-level model does not apply), or when no
candidate or piece exists; inputs the model forces are set to their forced value.

*Legs in the air:* the rigid model forces the torque of a massless leg without ground contact
(or lifting off) to 0, and between plans the loop applies that at every step: an input on a
massless coordinate whose contacts are all more than :data:`SEPARATION_GAP` off their surface
gets 0. With its rotor inertia the leg then coasts at the speed it left the ground with, swings
round and may touch down again (no swing controller is modelled).

*Body contact kept:* every body contact that touches at the start (gap <= :data:`SEPARATION_GAP`)
touches at every sample up to the first sample at or past vertical (or the end). A body contact
that touches down later (the rear corner when the body falls back) does not count, but its
touch-downs and separations are listed in ``body_events``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

import numpy as np

from .. import polytope as poly
from ..engine import DynamicResponse, ModeAnalysis, analyze, solutions_at
from ..errors import FrcontrolError, ImpactState, InputError, SceneError
from ..jsonable import finite_or_none, to_jsonable
from ..modes import VELOCITY_TOLERANCE, ContactProblem, add_scene_modes, scene_mode
from ..response import OUTPUT_TOLERANCE
from ..scene import Scene
from ..simulation.closed_loop import ClosedLoopRun, run_closed_loop
from ..simulation.export import sample_modes
from ..simulation.rigid import CONTACT_FORCE_TOLERANCE, RigidSettings, RigidStepper
from ..simulation.trajectory import Trajectory
from ..solvers import DEFAULT_LP_SOLVER, RETRY_ERRORS, solve_lp
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

__all__ = [
    "DEFAULT_MARGIN",
    "FLIP_ARMATURE",
    "FORCED_INPUT_TOLERANCE",
    "INPUT_LIMIT_TOLERANCE",
    "MAX_VERTEX_CANDIDATES",
    "PITCH_TOLERANCE",
    "REPLAN_GAP_TOLERANCE",
    "REPLAN_VELOCITY_TOLERANCE",
    "SEPARATION_GAP",
    "TORQUE_ROUNDING",
    "AppliedPlan",
    "FlipPiece",
    "FlipPlan",
    "FlipResult",
    "FlipProblem",
    "FlipTask",
    "ReplanningPolicy",
    "build_flip",
    "flip_task",
    "margin_pieces",
    "massless_inputs",
    "structurally_forced",
    "mode_allowed",
    "maximise_pitch",
    "plan_flip",
    "sample_modes",
    "shrunk_input_domain",
    "simulate_flip",
    "worst_case_pitch",
]

# ---------------------------------------------------------------------------------------------
# tolerances and defaults

DEFAULT_MARGIN = DEFAULT_FLIP_MARGIN
"""[N m] Default distance (in input space) between the plan and every input where another mode
also holds: 500 times :data:`TORQUE_ROUNDING`, and small against RHex's 10 N m hip limits."""


PITCH_TOLERANCE = 1e-9
"""[rad/s^2] Relative agreement (times ``1 + |pitch|``) required between the planned pitch
acceleration and the one :func:`~frcontrol.engine.solutions_at` reports at the rounded torques."""


MAX_VERTEX_CANDIDATES = 200_000
"""Most row subsets tried to enumerate a piece's vertices in the worst-case (w-dependent) plan."""




FLIP_ARMATURE = 2e-3
r"""[kg m^2] Default rotor inertia of each massless hip coordinate in the flip's simulation (when
the scene's ``[model]`` gives none). RHex (Saranli, Buehler and Koditschek 2001) drives each leg
with a Maxon 20 W motor (rotor inertia of the order of 1e-6 kg m^2) through a 33:1 gearhead:
reflected, 33^2 x 1e-6 = 1.1e-3 kg m^2 per motor, and each planar hip stands for a pair of legs
(two motors). The simulator's default (1e-4 kg m^2) would let a torque spin a free leg up twenty
times faster."""


# ---------------------------------------------------------------------------------------------
# the task


@dataclass(frozen=True)
class FlipTask:
    """What the flip planner reads from the scene's ``[task]`` table.

    Attributes:
        body_contacts: names of the body's contacts (none may separate), in scene order.
        pitch: the pitch coordinate's name.
        pitch_index: its index in the minimal coordinates.
        initial_pitch: [rad] its value at the scene's state.
        vertical: [rad] the first pitch above ``initial_pitch`` at which the body stands vertical
            (``pi/2 + k pi``): the flip is done when the pitch passes it.
    """

    body_contacts: tuple[str, ...]
    pitch: str
    pitch_index: int
    initial_pitch: float
    vertical: float


def flip_task(scene: Scene) -> FlipTask:
    """The flip task of a scene: its ``[task]`` table, validated.

    ``body_contacts`` is required: a scene without it is not a flip scene (the planner would
    otherwise "flip" whatever touches the ground). ``pitch`` defaults to ``theta``.

    Raises:
        SceneError: ``[task]`` or ``task.body_contacts`` is missing, or ``[task]`` is malformed,
            names an unknown contact or coordinate.
    """
    task = scene.task
    path = str(scene.path)
    names = [c.name for c in scene.contacts]
    phased = _phased_flip(scene)
    if phased is not None:
        body_contacts, pitch_name = phased
        task = replace(task, body_contacts=body_contacts, pitch=pitch_name)
    if task.body_contacts is None:
        raise SceneError(path, "task.body_contacts", "missing: the flip needs [task] body_contacts, "
                         f"the body's contacts (from {', '.join(names) or 'no contact'}), and "
                         "optionally pitch, the body's pitch coordinate")
    body = list(task.body_contacts)
    if not body:
        raise SceneError(path, "task.body_contacts", f"expected a non-empty list of contact names "
                         f"from {names}, got {body!r}")
    for i, name in enumerate(body):
        if name not in names:
            raise SceneError(path, f"task.body_contacts[{i}]",
                             f"unknown contact {name!r}; the contacts are: {', '.join(names)}")
    chosen = set(body)
    pitch = task.pitch if task.pitch is not None else "theta"
    coords = scene.coordinate_names
    if not isinstance(pitch, str) or pitch not in coords:
        raise SceneError(path, "task.pitch", f"expected a coordinate name from {list(coords)}, got {pitch!r}")
    index = coords.index(pitch)
    initial = float(scene.q[index])
    vertical = math.pi / 2 + math.pi * (math.floor((initial - math.pi / 2) / math.pi) + 1)
    return FlipTask(tuple(n for n in names if n in chosen), pitch, index, initial, vertical)


def _phased_flip(scene: Scene) -> tuple[tuple[str, ...], str] | None:
    """``(body_contacts, pitch)`` of a flip given as a task (``[[task.phases]]``), or None.

    The first phase is the push: its body contacts are the contacts it keeps loaded (their
    allowed letters lack S), its pitch the coordinate it maximises.

    Raises:
        SceneError: the first phase does not maximise a coordinate or keeps no contact loaded.
    """
    raw = scene.raw.get("task")
    if not isinstance(raw, Mapping) or "phases" not in raw:
        return None
    first = raw["phases"][0]
    objective = first.get("maximize")
    if not isinstance(objective, Mapping) or "coordinate" not in objective:
        raise SceneError(str(scene.path), "task.phases[0].maximize",
                         "a flip's first phase maximises its pitch coordinate's acceleration "
                         "(maximize = { coordinate = \"theta\" }); frc plan runs any other task")
    body = tuple(str(name) for name, letters in first.get("modes", {}).items() if "S" not in letters)
    if not body:
        raise SceneError(str(scene.path), "task.phases[0].modes",
                         "a flip's first phase keeps its body contacts loaded: give them letters "
                         "without S (modes = { front_corner = \"FLR\" })")
    return body, str(objective["coordinate"])


# ---------------------------------------------------------------------------------------------
# results


@dataclass(frozen=True)
class FlipPiece:
    """One convex piece of a candidate's unambiguous set shrunk by the margin, and its optimum.

    Attributes:
        mode: the candidate mode.
        region: the piece, over the planned inputs (``FlipPlan.planned_inputs``).
        pitch_acceleration: [rad/s^2] the best (worst-case, if ``worst_case``) pitch acceleration
            on the piece, at the unrounded optimum; ``-inf`` if the LP failed.
        optimum: the unrounded optimum (None if the LP failed).
        worst_case: the pitch depends on the mode's ambiguity variables w.
    """

    mode: str
    region: poly.Polytope
    pitch_acceleration: float
    optimum: np.ndarray | None
    worst_case: bool


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

    def to_dict(self, result: FlipResult | None = None) -> dict[str, Any]:
        """The ``frc flip --json`` document.

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
        if result is None or result.trajectory is None:
            payload["simulation"] = {
                "flipped": False, "time_to_vertical": None, "body_contact_kept": None, "steps": 0,
                "replans": 0, "simulated": False,
                "reason": plan.reason if not plan.found else "not simulated (--max-time 0)",
            }
            return add_scene_modes(to_jsonable(payload), plan.scene_contacts or plan.contacts)
        traj = result.trajectory
        payload["simulation"] = {
            "flipped": result.flipped,
            "time_to_vertical": finite_or_none(result.time_to_vertical),
            "body_contact_kept": result.body_contact_kept,
            "steps": result.steps,
            "replans": result.replans,
            "simulated": True,
            "reason": result.reason,
            "separation": (None if result.separation is None
                           else {"time": result.separation[0], "contact": result.separation[1]}),
            "body_events": [{"time": t, "contact": c, "kind": k} for t, c, k in result.body_events],
            "held": len(result.held),
            "max_pitch": float(traj.coordinate(plan.pitch).max()),
            "vertical": result.vertical,
            "dt": result.dt,
            "max_time": result.max_time,
            "armature": result.armature,
            "duration": traj.duration,
            "status": traj.status,
            "events": [e.to_dict() for e in traj.events],
            "timings": dict(result.timings),
        }
        return add_scene_modes(to_jsonable(payload), plan.scene_contacts or plan.contacts)


@dataclass(frozen=True)
class FlipResult:
    """The closed-loop flip: the first plan, the simulated motion and the verdict.

    Attributes:
        plan: the plan at the scene's state (the torques of the first step).
        trajectory: the simulated motion, up to the first sample at or past vertical (None when no
            first plan was found).
        flipped: the pitch passed ``vertical`` within ``max_time``.
        time_to_vertical: [s] when it did (linear interpolation between samples), else None.
        body_contact_kept: no body contact separated up to the flip (or the end): see
            :func:`simulate_flip`.
        separation: the first separation of a body contact touching at the start
            ``(time [s], contact)``, or None.
        body_events: every touch-down and separation of a body contact up to the flip (or the
            end): ``(time [s], contact, "touchdown" | "separation")``.
        steps: time steps simulated.
        replans: plans made after the first one.
        held: re-planning points at which no plan was made and the torques were held, with why.
        plans: ``(time [s], mode or None, torques)`` of every plan applied, in time order.
        modes: per sample, one letter per scene contact (S when not loaded), for the viewers.
        reason: why the robot did not flip (None if it did).
        vertical: [rad] the pitch to pass.
        dt: [s] the time step; max_time: [s] the simulated time limit.
        armature: [kg m^2] the rotor inertia given to the massless hips.
        timings: [s] ``first_plan``, ``simulation``, ``replanning``, ``total``.
    """

    plan: FlipPlan
    trajectory: Any
    flipped: bool
    time_to_vertical: float | None
    body_contact_kept: bool | None
    separation: tuple[float, str] | None
    body_events: tuple[tuple[float, str, str], ...]
    steps: int
    replans: int
    held: tuple[tuple[float, str], ...]
    plans: tuple[tuple[float, str | None, Mapping[str, float]], ...]
    modes: tuple[str, ...]
    reason: str | None
    vertical: float
    dt: float
    max_time: float
    armature: float
    timings: Mapping[str, float]


# ---------------------------------------------------------------------------------------------
# building blocks


def _pitch_row(mode: ModeAnalysis, pitch_index: int) -> tuple[np.ndarray, np.ndarray, float, bool]:
    """``(c_u, c_w, c_0, depends_on_w)``: the pitch row of the mode's response."""
    r = mode.response
    c_u = r.X_u[pitch_index].copy()
    c_w = r.X_w[pitch_index].copy()
    c_0 = float(r.x_0[pitch_index])
    depends = False
    if r.X_w.size:
        scale = float(np.max(np.abs(r.X_w)))
        depends = bool(np.max(np.abs(c_w)) > OUTPUT_TOLERANCE * max(scale, 1e-300))
    if not depends:
        c_w = np.zeros_like(c_w)
    return c_u, c_w, c_0, depends


def _solve_lp(c: np.ndarray, A: np.ndarray, b: np.ndarray, solver: str, **kwargs: Any):
    return solve_lp(c, A, b, solver=solver, fallback=RETRY_ERRORS, **kwargs)


def worst_case_pitch(
    mode: ModeAnalysis, pitch_index: int, u: np.ndarray, *, solver: str = DEFAULT_LP_SOLVER
) -> float:
    """``c_u^T u + c_0 + min { c_w^T w : (u, w) in D_c }``: the least pitch acceleration at u.

    One LP over w on the slice of the mode's domain D_c at u; ``-inf`` if u is outside T_c.
    """
    c_u, c_w, c_0, depends = _pitch_row(mode, pitch_index)
    base = float(c_u @ u) + c_0
    if not depends:
        return base
    D = mode.domain
    if D is None:  # an infeasible mode: no u is in T_c
        return -math.inf
    m = mode.m
    H_u, H_w = D.A[:, :m], D.A[:, m:]
    result = _solve_lp(c_w, H_w, D.b - H_u @ u, solver)
    if not result.found:
        return -math.inf
    return base + float(result.objective)


def maximise_pitch(mode: ModeAnalysis, piece: poly.Polytope, pitch_index: int,
                   solver: str = DEFAULT_LP_SOLVER) -> FlipPiece:
    """The best pitch acceleration of ``mode`` on one piece of inputs.

    ``max c_u^T u + c_0`` over the piece by one LP when the pitch row does not depend on w; else the
    worst case ``c_u^T u + c_0 + g(u)``, ``g(u) = min {c_w^T w : (u, w) in D_c}`` (convex in u), at
    the best vertex of the piece (see the module's docstring).

    Args:
        mode: the mode's analysis (its response ``X_u, X_w, x_0``, its domain D_c over (u, w)).
        piece: a bounded polytope of inputs inside T_c.
        pitch_index: the pitch coordinate's index in ``dv``.
        solver: LP back-end.
    """
    c_u, _, c_0, depends = _pitch_row(mode, pitch_index)
    if not depends:
        result = _solve_lp(-c_u, piece.A, piece.b, solver)
        if not result.found:
            return FlipPiece(mode.mode, piece, -math.inf, None, False)
        return FlipPiece(mode.mode, piece, float(c_u @ result.x) + c_0, result.x.copy(), False)
    reduced = poly.minimal_representation(piece, solver=solver)
    best, best_u = -math.inf, None
    for vertex in poly.vertices_from_halfspaces(reduced.A, reduced.b, max_candidates=MAX_VERTEX_CANDIDATES):
        value = worst_case_pitch(mode, pitch_index, vertex, solver=solver)
        if value > best:
            best, best_u = value, vertex
    return FlipPiece(mode.mode, piece, best, best_u, True)


def _round_inputs(u: np.ndarray, lower: np.ndarray, upper: np.ndarray, quantum: float) -> np.ndarray:
    """Round to multiples of ``quantum`` and keep within the limits.

    A quantum of ``10^-k`` rounds to ``k`` decimals, giving the double nearest to the printed
    decimal (``-1.3072``, not ``-1.3072000000000001``): what a user types back is what was checked.
    """
    if quantum <= 0:
        rounded = u.copy()
    else:
        digits = -math.log10(quantum)
        if abs(digits - round(digits)) < 1e-12 and digits >= 0:
            rounded = np.array([round(float(x), int(round(digits))) for x in u])
        else:
            rounded = np.round(u / quantum) * quantum
    rounded = np.minimum(np.maximum(rounded, lower), upper)
    return rounded + 0.0  # no negative zeros


def _check_inputs(scene: Scene) -> None:
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
    _check_inputs(scene)
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
    solver: str = DEFAULT_LP_SOLVER,
    rounding: float = TORQUE_ROUNDING,
    min_pitch_acceleration: float | None = 0.0,
    velocity_tolerance: float = VELOCITY_TOLERANCE,
    exhaustive: bool = False,
    problem: ContactProblem | None = None,
    free: Mapping[str, str] | None = None,
) -> FlipPlan:
    """The hip torques that maximise the body's pitch acceleration, unambiguously, at the state.

    See the module's docstring for the maths.

    Args:
        scene: the scene at the state to plan at (``scene.at(q, v)`` along a motion).
        margin: [N m] the distance kept from every input where another mode also holds, >= 0.
        analysis: the engine's analysis of this scene at this state (computed if None).
        solver: LP back-end.
        rounding: [N m] the torques are rounded to multiples of this, >= 0.
        min_pitch_acceleration: [rad/s^2] a plan must exceed this by more than
            :data:`PITCH_TOLERANCE` (default 0: it must pitch the body up; a mode that holds the
            body still, with a pitch acceleration of round-off size, does not); None accepts the
            best plan whatever its sign (re-planning mid-flip).
        velocity_tolerance: [m/s] contact velocities at most this count as zero (velocity pruning).
        exhaustive: build the pieces of every candidate (default: only of the candidates whose
            bound, the LP over their shrunk T_c, exceeds the best verified plan so far: the same
            plan, found faster).
        problem: the contact problem to plan on (default: the scene's at its state, with
            ``velocity_tolerance``); ignored when ``analysis`` is given.
        free: per contact name, the letters the plan also allows it (:func:`mode_allowed`,
            ``"S"``: a toe may separate); the unambiguity constraint and the verification accept
            those modes beside the planned one. Default: none (one rigid solution, planned).

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
    _check_plan_options(margin, rounding)
    timings = {"analysis": 0.0, "unambiguous_sets": 0.0, "lps": 0.0, "verification": 0.0}
    t0 = time.perf_counter()
    built = build_flip(scene, velocity_tolerance=velocity_tolerance,
                       problem=analysis.problem if analysis is not None else problem)
    task = built.task
    full, problem, forced, analysis = _planning_analysis(built, analysis, solver)
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
    bounds = _candidate_bounds(analysis, candidates, task.pitch_index, margin, solver)
    timings["lps"] += time.perf_counter() - t0
    common["bounds"] = bounds
    pieces, explored, rejected, chosen = _branch_and_bound(
        analysis, problem, candidates, bounds, task.pitch_index, margin, rounding, exhaustive, solver,
        timings, free)
    pieces.sort(key=lambda p: -p.pitch_acceleration)
    common.update({"pieces": tuple(pieces), "explored": tuple(explored), "rejected": tuple(rejected)})
    timings["total"] = time.perf_counter() - start
    return _chosen_plan(scene, chosen, problem.inputs, forced_values, min_pitch_acceleration, timings, common)


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
                f"({_torque_text({n: forced_values[n] for n in bad})})")
    if problem.m == 0 or analysis is None:  # the analysis exists whenever an input is planned
        return (f"every input is forced at this state ({_torque_text(dict(forced_values))}: e.g. "
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
            f"the best unambiguous torques ({_torque_text(torques)}, mode "
            f"{scene_mode(piece.mode, common['contacts'], common['scene_contacts'])}) give a pitch "
            f"acceleration of {pitch:.6g} rad/s^2, not above {min_pitch_acceleration:g}: no torque "
            "within the limits starts the flip"))
    return plan


def _planning_analysis(built: FlipProblem, analysis: DynamicResponse | None, solver: str
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
        analysis = analyze(planned, solver=solver)
    if analysis is not None and not any(m.inputs_full_dimensional for m in analysis.feasible_modes):
        more = forced_by_every_mode(analysis)
        if more:
            names_left = planned.inputs
            forced.update({full.inputs.index(names_left[i]): value for i, value in more.items()})
            planned = fix_inputs(full, forced)
            analysis = analyze(planned, solver=solver) if planned.m else None
    return full, planned, forced, analysis


def _candidate_bounds(analysis: DynamicResponse, candidates: Sequence[str], pitch_index: int, margin: float,
                      solver: str) -> dict[str, float]:
    """Per candidate mode, an upper bound of its pitch acceleration over its shrunk T_c (one LP).

    ``inf`` when the pitch row depends on w (no cheap bound), ``-inf`` when the shrunk T_c is empty.
    """
    bounds: dict[str, float] = {}
    for name in candidates:
        c_u, _, c_0, depends = _pitch_row(analysis.mode(name), pitch_index)
        if depends:
            bounds[name] = math.inf
            continue
        A, b = shrunk_input_domain(analysis, name, margin)
        result = _solve_lp(-c_u, A, b, solver)
        bounds[name] = float(c_u @ result.x) + c_0 if result.x is not None else -math.inf
    return bounds


def _branch_and_bound(analysis: DynamicResponse, problem: ContactProblem, candidates: Sequence[str],
                      bounds: Mapping[str, float], pitch_index: int, margin: float, rounding: float,
                      exhaustive: bool, solver: str, timings: dict[str, float],
                      free: Mapping[str, str] | None = None
                      ) -> tuple[list[FlipPiece], list[str], list[tuple[str, str]],
                                 tuple[FlipPiece, np.ndarray, float] | None]:
    """The best verified piece, exploring candidates by decreasing bound.

    Returns:
        (every piece found, the modes explored, the rejected optima with why, the chosen
        (piece, rounded inputs, pitch acceleration) or None).
    """
    pieces: list[FlipPiece] = []
    explored: list[str] = []
    rejected: list[tuple[str, str]] = []
    chosen: tuple[FlipPiece, np.ndarray, float] | None = None
    for name in sorted(candidates, key=lambda c: -bounds[c]):
        if bounds[name] == -math.inf:
            break
        if chosen is not None and not exhaustive and bounds[name] <= chosen[0].pitch_acceleration:
            break
        explored.append(name)
        t0 = time.perf_counter()
        regions = margin_pieces(analysis, name, margin, solver=solver, free=free)
        t1 = time.perf_counter()
        found = sorted((maximise_pitch(analysis.mode(name), piece, pitch_index, solver)
                        for piece in regions), key=lambda p: -p.pitch_acceleration)
        t2 = time.perf_counter()
        timings["unambiguous_sets"] += t1 - t0
        timings["lps"] += t2 - t1
        pieces += found
        for piece in found:
            if chosen is not None and piece.pitch_acceleration <= chosen[0].pitch_acceleration:
                break
            if piece.optimum is None:
                rejected.append((piece.mode, "the LP found no optimum"))
                continue
            u = _round_inputs(piece.optimum, problem.lower, problem.upper, rounding)
            verdict, pitch = _verify(analysis, piece, u, pitch_index, solver, free)
            if verdict is None:
                chosen = (piece, u, pitch)
                break
            rejected.append((piece.mode, verdict))
        timings["verification"] += time.perf_counter() - t2
    return pieces, explored, rejected, chosen


def _torque_text(torques: Mapping[str, float]) -> str:
    return ", ".join(f"{name} = {value:.4f} N m" for name, value in torques.items())


def _verify(analysis: DynamicResponse, piece: FlipPiece, u: np.ndarray, pitch_index: int,
            solver: str, free: Mapping[str, str] | None = None) -> tuple[str | None, float]:
    """``(None, pitch)`` if the rigid solutions at u are as the plan allows, else why.

    That is: one solution in the piece's mode and the others only in modes ``free`` allows
    (:func:`mode_allowed`; without ``free``: exactly one solution).
    """
    mode = analysis.mode(piece.mode)
    pitch = worst_case_pitch(mode, pitch_index, u, solver=solver)
    solutions = solutions_at(analysis, u, solver=solver)
    modes = [s.mode for s in solutions]
    contacts = analysis.problem.contacts
    if modes.count(piece.mode) != 1 or not all(mode_allowed(m, piece.mode, contacts, free) for m in modes):
        return f"solutions at the rounded torques: {', '.join(modes) or 'none'}", pitch
    found = float(solutions[modes.index(piece.mode)].dv[pitch_index])
    if piece.worst_case:
        if found < pitch - PITCH_TOLERANCE * (1.0 + abs(pitch)):
            return f"the solution's pitch {found:.9g} is below the worst case {pitch:.9g}", pitch
    elif abs(found - pitch) > PITCH_TOLERANCE * (1.0 + abs(pitch)):
        return f"the solution's pitch {found:.12g} differs from the plan's {pitch:.12g}", pitch
    return None, pitch


# ---------------------------------------------------------------------------------------------
# the closed loop


def _weight(scene: Scene) -> float:
    """The robot's weight [N] (1 N without gravity): the scale of contact-force thresholds."""
    return scene.robot.weight_scale()


def _armature(scene: Scene, armature: float | None) -> float:
    if armature is not None:
        return float(armature)
    if scene.model.armature_given:
        return scene.model.armature
    return FLIP_ARMATURE


def simulate_flip(
    scene: Scene,
    *,
    dt: float = 1e-3,
    max_time: float = 2.0,
    replan_every: int = 10,
    margin: float = DEFAULT_MARGIN,
    armature: float | None = None,
    solver: str = DEFAULT_LP_SOLVER,
    plan: FlipPlan | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> FlipResult:
    """Plan, then re-plan along a rigid simulation until the body pitches past vertical.

    The loop, the re-planning model, the legs in the air and "body contact kept" are defined in
    the module's docstring (**Closed loop**); it runs on
    :func:`~frcontrol.simulation.closed_loop.run_closed_loop` (the massless hips get the rotor
    inertia ``armature``) until the pitch passes ``FlipTask.vertical`` or ``max_time``.

    Args:
        scene: the scene (RHex on its back).
        dt: [s] the time step.
        max_time: [s] the longest simulated time.
        replan_every: steps between plans, >= 1.
        margin: [N m] the plans' margin.
        armature: [kg m^2] rotor inertia of the massless hips (default: the scene's ``[model]``
            armature, else :data:`FLIP_ARMATURE`).
        solver: LP back-end of the plans.
        plan: the first plan, if already made at the scene's state.
        progress: called with (simulated time, max_time) every ``replan_every`` steps.

    Returns:
        The result; with no first plan, ``trajectory=None`` and ``flipped=False`` with the reason.

    Raises:
        InputError: a bad step, time, count or armature; see :func:`plan_flip`.
    """
    start = time.perf_counter()
    max_time, dt, arm = _loop_options(scene, dt, max_time, replan_every, armature)
    task = flip_task(scene)
    t0 = time.perf_counter()
    first = plan if plan is not None else plan_flip(scene, margin=margin, solver=solver)
    timings = {"first_plan": time.perf_counter() - t0, "simulation": 0.0, "replanning": 0.0}
    common = {"vertical": task.vertical, "dt": dt, "max_time": max_time, "armature": arm}
    if not first.found:
        timings["total"] = time.perf_counter() - start
        return FlipResult(plan=first, trajectory=None, flipped=False, time_to_vertical=None,
                          body_contact_kept=None, separation=None, body_events=(), steps=0, replans=0,
                          held=(), plans=(), modes=(), reason=first.reason, timings=timings, **common)

    policy = _Replanner(scene, first, margin, solver)
    run = _closed_loop(scene, policy, task, dt=dt, max_time=max_time, replan_every=replan_every,
                       armature=arm, progress=progress)
    timings["simulation"] += run.timings["simulation"]
    timings["replanning"] += run.timings["policy"]
    trajectory = replace(run.trajectory, info={**run.trajectory.info, "source": "simulate_flip",
                                               "steps": len(run.trajectory.times) - 1})
    separation, body_events = _body_contacts(scene, trajectory, task.body_contacts, len(trajectory.times) - 1)
    modes = sample_modes(scene, trajectory)
    trajectory = replace(trajectory, modes=tuple(modes))
    timings["total"] = time.perf_counter() - start
    return FlipResult(
        plan=first, trajectory=trajectory, flipped=run.stopped,
        time_to_vertical=_time_to_vertical(trajectory, task) if run.stopped else None,
        body_contact_kept=separation is None, separation=separation, body_events=body_events,
        steps=len(trajectory.times) - 1, replans=run.decisions, held=tuple(policy.held),
        plans=tuple(policy.plans), modes=modes,
        reason=_not_flipped_reason(trajectory, task, run.stopped, max_time), timings=timings, **common,
    )


def _loop_options(scene: Scene, dt: float, max_time: float, replan_every: int, armature: float | None
                  ) -> tuple[float, float, float]:
    """``(max_time, dt, armature)`` of the closed loop, checked before any plan is made.

    Raises:
        InputError: a bad step, time, count or armature.
    """
    from ..simulation.inputs import check_simulation_times

    max_time, dt = check_simulation_times(max_time, dt)
    if isinstance(replan_every, bool) or not isinstance(replan_every, int) or replan_every < 1:
        raise InputError(f"replan_every must be an integer >= 1 (steps), got {replan_every!r}")
    arm = _armature(scene, armature)
    if not (math.isfinite(arm) and arm > 0):
        raise InputError(f"the armature must be a positive rotor inertia [kg m^2], got {arm!r}")
    return max_time, dt, arm


def _not_flipped_reason(trajectory: Trajectory, task: FlipTask, crossed: bool, max_time: float) -> str | None:
    """Why the run did not pass vertical (None when it did)."""
    failure = trajectory.failure
    if crossed:
        return None
    if failure is not None:
        return f"the simulation {trajectory.status} at t = {failure.time:.4g} s: {failure.reason}"
    return (f"the pitch reached {float(np.max(trajectory.q[:, task.pitch_index])):.4f} rad within "
            f"{max_time:g} s, short of vertical ({task.vertical:.4f} rad)")


def _time_to_vertical(trajectory: Trajectory, task: FlipTask) -> float:
    """[s] When the pitch crossed vertical, linear between the last two samples.

    The run stops at the first sample at or past vertical.
    """
    pitch = trajectory.q[:, task.pitch_index]
    end = len(pitch) - 1
    if end == 0:
        return 0.0
    t_a, t_b = trajectory.times[end - 1], trajectory.times[end]
    p_a, p_b = pitch[end - 1], pitch[end]
    return float(t_a + (task.vertical - p_a) / (p_b - p_a) * (t_b - t_a))


class AppliedPlan(Protocol):
    """What a closed loop reads of a plan: its mode, torques and input vector."""

    @property
    def mode(self) -> str | None:
        """The plan's contact mode, or None."""

    @property
    def torques(self) -> Mapping[str, float]:
        """The plan's input per input coordinate."""

    def input_vector(self, inputs: Sequence[str]) -> np.ndarray:
        """The plan's inputs in the order of ``inputs``."""


class ReplanningPolicy:
    """A closed loop's plan record: the last command, every plan applied and every hold.

    Subclasses make a plan at the stepper's state in ``__call__`` and :meth:`record` it. It keeps
    every plan applied ``(time, mode or None, torques)`` and every hold ``(time, why)``; the
    stepper runs on ``self.scene``, the scene at :data:`REPLAN_GAP_TOLERANCE`.
    """

    def __init__(self, scene: Scene, first: AppliedPlan, margin: float, solver: str) -> None:
        self.names = scene.inputs.coordinates
        self.scene = replace(scene, gap_tolerance=REPLAN_GAP_TOLERANCE)
        self.force_tolerance = CONTACT_FORCE_TOLERANCE * _weight(scene)
        self.margin, self.solver = margin, solver
        self.command = first.input_vector(self.names)
        self.plans: list[tuple[float, str | None, Mapping[str, float]]] = [
            (0.0, first.mode, dict(first.torques))]
        self.held: list[tuple[float, str]] = []

    def loaded(self, stepper: RigidStepper) -> np.ndarray:
        """Which contacts the stepper's last step loaded (normal force above the tolerance)."""
        return stepper.last_forces[:, 0] > self.force_tolerance

    def record(self, t: float, mode: str | None, why: str | None) -> np.ndarray:
        """Note the command applied from ``t`` (a hold when ``why`` says why); return it."""
        if why is not None:
            self.held.append((t, why))
        self.plans.append((t, mode, dict(zip(self.names, self.command.tolist(), strict=True))))
        return self.command


class _Replanner(ReplanningPolicy):
    """The flip's policy: a plan at the state reached; the torques held when none can be made."""

    def __call__(self, stepper: RigidStepper) -> np.ndarray:
        """The command from the stepper's state on (a contact the last step loaded is planned with)."""
        self.command, mode, why = _replanned(self.scene, stepper, self.loaded(stepper), self.margin,
                                             self.solver, self.command, self.names)
        return self.record(stepper.t, mode, why)


def _closed_loop(scene: Scene, policy: _Replanner, task: FlipTask, *, dt: float, max_time: float,
                 replan_every: int, armature: float, progress: Callable[[float, float], None] | None
                 ) -> ClosedLoopRun:
    """One rigid stepper re-planned every ``replan_every`` steps, until vertical or ``max_time``.

    The stepper runs on the re-planning model's scene (its gap tolerance); a massless leg in the
    air gets no torque (:func:`_free_legs_idle`).
    """
    legs = massless_inputs(scene)
    stepper = RigidStepper(policy.scene, RigidSettings(max_ambiguity_checks=0, impact_law=False),
                           armature=armature)
    return run_closed_loop(
        stepper, policy, max_time, dt, every=replan_every, command=policy.command,
        actuate=lambda command, at: _free_legs_idle(scene, legs, command, at.q, at.state.contact_points),
        stop=lambda at: bool(at.q[task.pitch_index] >= task.vertical), progress=progress)


def _replanned(replan_scene: Scene, stepper: RigidStepper, loaded: np.ndarray, margin: float, solver: str,
               command: np.ndarray, names: Sequence[str]) -> tuple[np.ndarray, str | None, str | None]:
    """A re-plan at the stepper's state.

    Returns:
        (the command to apply, the plan's mode or None, why the torques are held or None).
    """
    result = _replan(replan_scene, stepper.q, stepper.v, loaded, margin, solver)
    if isinstance(result, str):
        return command, None, f"{result}: torques held"
    if result.found:
        return result.input_vector(names), result.mode, None
    held = command.copy()
    for name, value in result.forced_inputs.items():
        held[list(names).index(name)] = value
    return held, None, f"no plan ({result.reason}): torques held"


def _free_legs_idle(scene: Scene, legs: dict[int, list[int]], command: np.ndarray,
                    q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
    """The command with 0 on every massless leg in the air.

    A leg is in the air when none of its contacts is within :data:`SEPARATION_GAP` of its
    surface: the rigid model forces its torque to 0. ``points``: the contact points at ``q``
    when known (a stepper's state holds them), else computed.
    """
    if not legs:
        return command
    gaps = _gaps(scene, q, points).tolist()  # Python numbers: a few tests per leg, every step
    free = [i for i, toes in legs.items() if not any(gaps[j] <= SEPARATION_GAP for j in toes)]
    if not free:
        return command
    out = command.copy()
    out[free] = 0.0
    return out


def _gaps(scene: Scene, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
    """Every contact's gap [m] at q (``points``: the contact points at q, when already known)."""
    if points is None:
        points = scene.robot.contact_points_in_world(q)
    normals = np.array([c.point.normal_in_world for c in scene.contacts]).reshape(-1, 2)
    offset = points - np.array([c.point.surface_point_in_world for c in scene.contacts]).reshape(-1, 2)
    return normals[:, 0] * offset[:, 0] + normals[:, 1] * offset[:, 1]  # n . (p - s), as n @ (p - s) sums it


def _replan(scene: Scene, q: np.ndarray, v: np.ndarray, loaded: np.ndarray, margin: float,
            solver: str, free: Mapping[str, str] | None = None) -> FlipPlan | str:
    """The plan at the simulated state, or why none could be made (an impact, an error).

    The contacts planned with are those within :data:`REPLAN_GAP_TOLERANCE` of their surface and
    those the last step loaded (``loaded``, one flag per scene contact). A loaded contact's normal
    velocity is taken as 0, as the simulator's own ambiguity check does: the velocity-level
    stepper holds ``J_N v+ = -phi / dt`` with the Jacobian of the step's start, so a loaded
    contact on a turning leg ends a step with a normal velocity of order ``dt`` times its
    centripetal acceleration (mm/s here), and a penetration is removed with ``-phi / dt``: both
    would make a pushing toe look separating to the acceleration-level model.
    """
    from ..scene import Contact

    here = scene.at(q, v)
    contacts = tuple(Contact(c.point, c.gap, bool(c.active or loaded[i]))
                     for i, c in enumerate(here.contacts))
    here = replace(here, contacts=contacts)
    try:
        problem = ContactProblem.from_scene(here, velocity_tolerance=REPLAN_VELOCITY_TOLERANCE)
        held_down = np.array([bool(loaded[i]) for i, c in enumerate(contacts) if c.active], dtype=bool)
        if held_down.size:
            problem = replace(problem, normal_velocities=np.where(held_down, 0.0, problem.normal_velocities))
        return plan_flip(here, margin=margin, solver=solver, min_pitch_acceleration=None, problem=problem,
                         free=free)
    except ImpactState as err:
        return f"impact at {err.contact} (v_N = {err.normal_velocity:.3g} m/s)"
    except FrcontrolError as err:
        return f"no plan ({err})"


def _body_contacts(
    scene: Scene, trajectory: Any, body: Sequence[str], end: int
) -> tuple[tuple[float, str] | None, tuple[tuple[float, str, str], ...]]:
    """The first separation of a body contact touching at the start, and every body contact event.

    Up to sample ``end``; the events are ``(time, contact, "touchdown" | "separation")``.
    """
    contacts = [c.name for c in scene.contacts]
    idx = [contacts.index(name) for name in body]
    points = trajectory.contact_points[: end + 1, idx]
    normals = np.array([scene.contacts[i].point.normal_in_world for i in idx]).reshape(-1, 2)
    surfaces = np.array([scene.contacts[i].point.surface_point_in_world for i in idx]).reshape(-1, 2)
    touching = np.einsum("kj,tkj->tk", normals, points - surfaces[None]) <= SEPARATION_GAP
    events = []
    for s in range(1, touching.shape[0]):
        for j in np.nonzero(touching[s] != touching[s - 1])[0]:
            kind = "touchdown" if touching[s, j] else "separation"
            events.append((float(trajectory.times[s]), body[int(j)], kind))
    first = None
    lost = np.nonzero(touching[0] & ~np.all(touching, axis=0))[0]
    if lost.size:
        when = [int(np.argmax(~touching[:, j])) for j in lost]
        earliest = int(np.argmin(when))
        first = (float(trajectory.times[when[earliest]]), body[int(lost[earliest])])
    return first, tuple(events)
