r"""The snake climb: one set of joint torques that holds a brace in mode F for every disturbance.

The task (METHOD §6; Greenfield's talk, slides 23-25): a planar snake braces its lower part in a
vertical channel at three contacts. Find joint torques ``u`` such that, for every disturbance
force ``d`` in a given polytope, the only rigid-body solution is the brace sticking (mode ``FFF``:
one ``F`` per brace contact) while the upper part accelerates upward; report the largest
disturbance scale for which such torques exist.

The disturbances (``[[disturbances]]``) are read by :mod:`frcontrol.planning.disturbances`.

The ``[task]`` table: a task given as phases (``docs/tasks.md``; the shipped ``snake_climb``), whose
first phase names the brace (its contacts allowed only ``F``) and requires the head's upward
acceleration (``require = [{ link, point, direction = [0.0, 1.0], at_least = a_min }]``), or the
dedicated keys (``head_link`` and ``head_point`` required)::

    [task]
    brace_contacts = ["tail", "tip", "top"]   # must be exactly the active contacts (default)
    head_link = "link8"                        # the point whose upward acceleration is required
    head_point = [0.2, 0.0]                    # [m] in head_link's frame
    min_head_acceleration = 1.0                # [m/s^2] a_min (default DEFAULT_MIN_HEAD_ACCELERATION)

A scene without ``head_link`` or ``head_point`` is not a climb scene: the planner refuses it,
naming the missing field. Other keys of ``[task]`` (read by other planners) are ignored.

The lifted problem
------------------
Disturbances act like extra inputs: the *augmented* contact problem has the inputs ``z = (u, d)``
and the input map ``[S^T, J_d^T]`` (:func:`augmented_problem`). Mode ``FFF`` of it has the affine
response ``x = X z + x_0`` (unique: six brace rows on six brace coordinates set the squeeze) and the
domain ``T_F = {z : G (X z + x_0) <= g}`` (forces: ``lam_N >= 0``, friction cones), a polytope of
``(u, d)``. The head's vertical acceleration is affine too: ``a_y(z) = c^T z + c_0``.

A brace mode with ambiguity variables (fewer brace coordinates than brace rows: the squeeze is
statically indeterminate, METHOD §6) or consistency conditions is refused (``found = False`` with
the reason): the rigid model cannot say which squeeze the brace carries, and this planner only
certifies a brace whose squeeze the torques set.

Robustness, exactly
-------------------
Let ``V_s`` be the vertices of ``s P`` together with the zero disturbance (the nominal; it is
added only when ``0`` is not in ``P``), so that the robust set ``conv(V_s)`` grows with ``s``.

1. *Membership.* ``T_F`` is convex, so ``(u, d) in T_F`` for every ``d in conv(V_s)`` iff it
   holds at every point of ``V_s`` (vertex enumeration is exact).
2. *No other mode.* Being outside every other mode's domain at the vertices does not exclude it in
   between. The unambiguous set of ``FFF`` in the lifted space, ``U = T_F minus the union of
   every other T_j`` (:meth:`~frcontrol.engine.DynamicResponse.unambiguous_set` of the
   augmented analysis), is a union of convex pieces ``Q_k``; ``u`` is accepted when
   ``{u} x conv(V_s)`` lies in one piece, i.e. (again by convexity) when every ``(u, v)``,
   ``v in V_s``, is in ``Q_k``: one LP per piece (the robust counterpart). The pieces are
   computed in a box of disturbances that contains every ``s P`` the bisection visits.
3. *Verification.* For the chosen ``u`` and every other mode ``j`` (all 4^k - 1 letter strings,
   not only those feasible in the box), one LP decides whether *some* ``d in conv(V_s)`` and some
   ``w`` put ``(u, d, w)`` in ``D_j`` with the engine's membership rule (the mode's force rows
   within :data:`~frcontrol.engine.DOMAIN_TOLERANCE`, its motion rows strictly, by more than that
   tolerance, and its consistency rows): maximise ``t`` subject to those rows, the motion rows
   tightened by ``t``. The mode holds somewhere iff ``t* > DOMAIN_TOLERANCE``
   (:func:`mode_exclusions`). A candidate that fails counts as infeasible. This also catches
   lower-dimensional modes, which a set difference cannot remove.

So a plan reported ``robust`` gives, at every ``d in conv(V_s)``, exactly one rigid-body solution,
``FFF``, in :func:`~frcontrol.engine.solutions_at` of the augmented problem.

Margin and objective
--------------------
Rows are normalised by their norm over ``z = (u, d)``, so slacks are distances [N m or N] in the
lifted space. The plan at scale ``s`` on a piece ``Q_k = {z : A z <= b}`` must satisfy, for every
``v in V_s``:

- ``A (u, v) + t |A| <= b`` with ``t >= margin`` (the torque limits are rows of ``Q_k`` and
  shrink by ``t`` too; the box in which the pieces were computed does not). ``t`` is the
  *robustness radius*: every ``(u', d')`` within ``t`` of some ``(u, v)`` stays in the piece;
- ``a_y(u, v) >= a_min + margin |c|``: the head rises, with the same kind of margin;
- ``a_x(u, 0) = 0``: at the nominal (zero) disturbance the head accelerates *straight* up.

Among those torques, two LPs choose (objective, in this order):

1. *gentlest*: minimise ``alpha = sum_f |ddq_f(u, 0)|``, the 1-norm of the nominal accelerations
   of the *free* coordinates, those that no brace contact row involves (the upper body: j4..j8 on
   the snake);
2. *most robust*: maximise ``t`` keeping ``alpha <= (1 + ACCELERATION_SLACK) alpha*`` (plus
   :data:`ACCELERATION_FLOOR`): the squeeze of the brace joints is then as robust as it gets;
3. *least effort* (a tie-break): minimise ``sum_i |u_i|`` keeping both, with
   ``t >= t* - OPTIMALITY_SLACK (1 + t*)``. The optimum of 2 is rarely unique (on the snake, j1
   enters only the tail's rows); this makes the plan independent of the LP back-end.

Why not simply "most robust" or "fastest head": the plan is one constant torque vector, valid at
the instant, and the upper chain is a multi-link inverted pendulum. The brace carries the upper
part's reaction, so torques that whip the upper body (which those objectives pick: the reaction of
an accelerating upper body presses the top contact, and in the snake's state, with links 5-8
vertical above j5, the head's vertical acceleration needs large joint accelerations) change the
brace's load within milliseconds; a sideways head acceleration topples the column. With the
conditions and objectives above the simulated brace holds (see :func:`simulate_climb`); without
``a_x = 0`` the top contact slips after about 0.1 s.

The torques are rounded to ``decimals`` (the printed values) and the rounded torques are verified
again by 1-3 above (``robust``): rounding moves ``u`` by at most ``sqrt(m) 10^-decimals / 2``,
well inside ``margin``.

The largest scale
-----------------
``s_bound``: one LP over ``(u, s)`` (the membership and head conditions at ``s V`` are linear in
``(u, s)``) without the exclusion of other modes: an upper bound. Then bisection on ``s`` in
``[0, s_bound]`` (scaled about the zero disturbance), each step the robustness LP of every piece
plus the verification 3, until the bracket is narrower than ``scale_tolerance * s_bound``; the
feasible end is reported. When ``s_bound`` itself is feasible (one piece, nothing lower
dimensional) it is the answer at once. The plan is made at the nominal scale (``scale``, default
1), or at the largest feasible scale if that is smaller (``nominal_feasible = False``).

Simulation
----------
:func:`simulate_climb` runs the rigid time stepper with the planned torques plus disturbance
forces ``J_d(q)^T d(t)``, ``d`` drawn from ``conv(V_s)`` and held for ``hold`` seconds (half the
draws a random vertex, half a random convex combination of the vertices), and reports whether the
brace held (every brace contact loaded and sticking throughout, tangential slip at most
``slip_tolerance``), the largest slip and the head's rise. The default horizon,
:data:`DEFAULT_DURATION` = 0.1 s, is the plan's own time scale: the torques are constant and the
plan is made for the instant; on the snake the head rises for about 0.12 s, then the open-loop
upper column (an inverted pendulum) tips over, while the brace keeps holding to about 0.4 s.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..engine import DOMAIN_TOLERANCE
from ..errors import InputError
from ..jsonable import finite_or_none, to_jsonable
from ..modes import add_scene_modes
from ..scene import Scene
from ..simulation.trajectory import TrajectoryStatus
from ..solvers import DEFAULT_LP_SOLVER
from . import DEFAULT_CLIMB_MARGIN
from .climb_problem import (
    ACCELERATION_FLOOR,
    ACCELERATION_SLACK,
    ANALYSIS_BOX_GROWTH,
    OPTIMALITY_SLACK,
    SCALE_CAP,
    ClimbProblem,
    build_climb,
    check_scale,
    gentle_plan,
    unit_norms,
)
from .disturbances import DisturbanceSet
from .exclusions import ModeExclusion, mode_exclusions

__all__ = [
    "DEFAULT_MARGIN",
    "SCALE_TOLERANCE",
    "TORQUE_DECIMALS",
    "ClimbPlan",
    "ClimbResult",
    "plan_climb",
]

DEFAULT_MARGIN = DEFAULT_CLIMB_MARGIN
"""[N m or N] Required robustness radius: every ``(u, v)``, ``v`` a point of ``V_s``, keeps at
least this distance (in the lifted ``(u, d)`` space, rows normalised) from the boundary of the
brace mode's unambiguous piece, and the head's acceleration row is tightened by it."""

SCALE_TOLERANCE = 1e-3
"""[-] The bisection stops when its bracket is narrower than this times the scale bound."""

TORQUE_DECIMALS = 3
"""Decimals of the reported torques [N m]; the rounded torques are the ones verified."""

@dataclass(frozen=True, eq=False)
class ClimbResult:
    """A simulation of the planned torques under sampled disturbances.

    Attributes:
        trajectory: the rigid simulation (its inputs are the generalized forces on every
            coordinate: ``S^T u + J_d^T d``).
        brace_held: every brace contact stayed closed, loaded and sticking throughout, with
            tangential slip at most ``slip_tolerance``.
        max_slip: [m] the largest tangential displacement of a brace contact point.
        max_opening: [m] the largest normal displacement away from its wall.
        upper_rise: [m] the head's rise over the simulation (its height at the end minus at the
            start).
        max_upper_rise: [m] the head's largest rise at any sample.
        brace_events: the contact events of the brace contacts (open, slip...).
        disturbance_times: [s] the start of each held disturbance; disturbance_samples: [N] the
            values, shape (K, dim).
        status: the simulator's status (:data:`~frcontrol.simulation.trajectory.TrajectoryStatus`).
        slip_tolerance: [m] the threshold used.
        seed: the random seed of the samples.
    """

    trajectory: Any
    brace_held: bool
    max_slip: float
    max_opening: float
    upper_rise: float
    max_upper_rise: float
    duration: float
    brace_events: tuple
    disturbance_times: np.ndarray
    disturbance_samples: np.ndarray
    status: TrajectoryStatus
    slip_tolerance: float
    seed: int



# ============================================================================ the plan
@dataclass(frozen=True, eq=False)
class ClimbPlan:
    """The climb plan: torques that hold the brace for every disturbance of ``conv(V_s)``.

    Attributes:
        found: whether torques were found (else ``reason`` says why; the rest is empty).
        mode: the brace mode at the nominal (zero) disturbance, e.g. ``"FFF"``.
        torques: ``{input: value}`` [N m], rounded to ``decimals``: the verified torques.
        scale: the scale the torques are planned for (1, or the largest feasible if smaller).
        nominal_feasible: the nominal scale is feasible.
        max_disturbance_scale: the largest feasible scale found by bisection (within
            ``scale_tolerance * scale_bound``).
        scale_bracket: ``(feasible, infeasible-or-bound)`` ends of the final bisection bracket.
        scale_bound: the one-LP upper bound (without the exclusion of other modes).
        scale_capped: the bound reached :data:`SCALE_CAP`.
        max_scale_torques: the torques [N m] found at the largest scale (unrounded).
        robust: the rounded torques verified exactly: in the brace mode's domain at every point of
            V_s with the head's acceleration >= a_min, and no other mode holds anywhere on
            ``{u} x conv(V_s)``.
        robustness_radius: [N m or N] the rounded torques' smallest normalised slack over the
            brace mode's rows and the torque limits at the points of V_s (>= margin, up to rounding).
        margin: [N m or N] the required robustness radius.
        head_acceleration: [m/s^2] the head's upward acceleration at the zero disturbance.
        head_sideways_acceleration: [m/s^2] its sideways one there (0 up to the rounding).
        free_accelerations: ``{coordinate: ddq}`` [rad/s^2 or m/s^2] of the free (upper)
            coordinates at the zero disturbance.
        worst_head_acceleration: [m/s^2] its minimum over V_s.
        min_head_acceleration: a_min [m/s^2].
        exclusions: the verification of every other mode at the rounded torques.
        pieces: number of convex pieces of the unambiguous set; piece: the one used.
        bisection: the scales tried and their verdicts, in order.
        disturbances: the polytope P.
        decimals: decimals of the torques.
        reason: a sentence on the outcome.
        timings: [s] per stage and ``total``.
        tolerances: every tolerance that shaped the plan.
        solver: the LP back-end.
        problem: the built problem (for plots and checks).
    """

    found: bool
    mode: str
    torques: Mapping[str, float]
    scale: float
    nominal_feasible: bool
    max_disturbance_scale: float
    scale_bracket: tuple[float, float]
    scale_bound: float
    scale_capped: bool
    max_scale_torques: Mapping[str, float]
    robust: bool
    robustness_radius: float
    margin: float
    head_acceleration: float
    head_sideways_acceleration: float
    free_accelerations: Mapping[str, float]
    worst_head_acceleration: float
    min_head_acceleration: float
    exclusions: tuple[ModeExclusion, ...]
    pieces: int
    piece: int
    bisection: tuple[tuple[float, bool], ...]
    disturbances: DisturbanceSet
    decimals: int
    reason: str
    timings: Mapping[str, float]
    tolerances: Mapping[str, float]
    solver: str
    problem: ClimbProblem = field(repr=False)

    @property
    def closest_mode(self) -> ModeExclusion | None:
        """The other mode that comes closest to holding at the plan (largest margin)."""
        return max(self.exclusions, key=lambda e: e.margin, default=None)

    @property
    def torque_vector(self) -> np.ndarray:
        """The rounded torques as a vector in the scene's input order [N m]."""
        return np.array(list(self.torques.values()), dtype=float)

    def to_dict(self, result: ClimbResult | None = None) -> dict[str, Any]:
        """The ``frc climb --json`` document.

        ``mode``, ``torques``, ``max_disturbance_scale``, ``robust`` and ``simulation`` (``brace_held``,
        ``max_slip``, ``upper_rise``) are the contract; the rest reports how the plan was found.
        """
        plan = self
        closest = plan.closest_mode
        payload: dict[str, Any] = {
            "found": plan.found,
            "mode": plan.mode,
            "contacts": list(plan.problem.problem.contacts),
            "torques": dict(plan.torques),
            "max_disturbance_scale": plan.max_disturbance_scale,
            "robust": plan.robust,
            "simulation": None,
            "scale": plan.scale,
            "nominal_feasible": plan.nominal_feasible,
            "scale_bracket": list(plan.scale_bracket),
            "scale_bound": plan.scale_bound,
            "scale_capped": plan.scale_capped,
            "max_scale_torques": dict(plan.max_scale_torques),
            "margin": plan.margin,
            "robustness_radius": finite_or_none(plan.robustness_radius),
            "head_acceleration": finite_or_none(plan.head_acceleration),
            "head_sideways_acceleration": finite_or_none(plan.head_sideways_acceleration),
            "worst_head_acceleration": finite_or_none(plan.worst_head_acceleration),
            "min_head_acceleration": plan.min_head_acceleration,
            "free_accelerations": dict(plan.free_accelerations),
            "closest_mode": (None if closest is None
                             else {"mode": closest.mode, "margin": finite_or_none(closest.margin)}),
            "modes_excluded": sum(not e.held for e in plan.exclusions),
            "pieces": plan.pieces,
            "bisection": [[s, ok] for s, ok in plan.bisection],
            "disturbances": [
                {"name": d.name, "link": d.link, "point": d.point_in_link, "vertices": d.vertices}
                for d in plan.disturbances.items
            ],
            "reason": plan.reason,
            "solver": plan.solver,
            "timings": dict(plan.timings),
            "tolerances": dict(plan.tolerances),
        }
        if result is not None:
            payload["simulation"] = {
                "brace_held": result.brace_held,
                "max_slip": result.max_slip,
                "upper_rise": result.upper_rise,
                "max_upper_rise": result.max_upper_rise,
                "max_opening": result.max_opening,
                "duration": result.duration,
                "seed": result.seed,
                "status": result.status,
                "slip_tolerance": result.slip_tolerance,
                "brace_events": [e.to_dict() for e in result.brace_events],
            }
        problem = plan.problem.problem
        return add_scene_modes(to_jsonable(payload), problem.scene_contacts or problem.contacts)


def _verify(cp: ClimbProblem, u: np.ndarray, scale: float) -> dict[str, Any]:
    """The exact checks 1-3 at ``u``, with the raw domain rows (independent of the pieces)."""
    H, h = cp.domain_rows
    norms = unit_norms(H)
    c, c0 = cp.head_row
    points = cp.robust_points(scale)
    slacks, accels = [], []
    for v in points:
        z = np.concatenate([u, v])
        slacks.append(np.min((h - H @ z) / norms))
        accels.append(float(c @ z + c0))
    exclusions = mode_exclusions(cp.problem, cp.mode, u, points, systems=cp.systems, solver=cp.solver,
                                 confirm=True)
    radius = float(min(slacks))
    worst = float(min(accels))
    zero = float(c[:cp.m_u] @ u + c0)
    cx, cx0 = cp.head_sideways_row
    B, b0 = cp.free_rows
    free = dict(zip(cp.free_coordinates, (B[:, :cp.m_u] @ u + b0).tolist(), strict=True))
    robust = radius > 0 and worst >= cp.min_head_acceleration and not any(e.held for e in exclusions)
    return {"radius": radius, "worst": worst, "zero": zero, "exclusions": exclusions, "robust": robust,
            "sideways": float(cx[:cp.m_u] @ u + cx0), "free": free}


def plan_climb(
    scene: Scene,
    *,
    margin: float = DEFAULT_MARGIN,
    scale: float = 1.0,
    solver: str = DEFAULT_LP_SOLVER,
    min_head_acceleration: float | None = None,
    scale_tolerance: float = SCALE_TOLERANCE,
    decimals: int = TORQUE_DECIMALS,
) -> ClimbPlan:
    """Plan the climb's torques and find the largest disturbance scale (module docstring).

    Args:
        scene: a scene with ``[[disturbances]]`` (and optionally ``[task]``).
        margin: [N m or N] required robustness radius (see :data:`DEFAULT_MARGIN`).
        scale: the nominal disturbance scale the torques are planned for (>= 0).
        solver: the LP back-end of every LP.
        min_head_acceleration: a_min [m/s^2], overriding the ``[task]`` value.
        scale_tolerance: relative width of the final bisection bracket (> 0).
        decimals: decimals of the reported (and verified) torques.

    Returns:
        The plan; ``found=False`` with a ``reason`` when no torques exist (an infeasible LP is a
        result, not an error).

    Raises:
        SceneError: bad ``[[disturbances]]`` or ``[task]`` tables.
        InputError: a bad margin, scale, tolerance or decimals.
    """
    start = time.perf_counter()
    _check_plan_options(scale, scale_tolerance, decimals)
    cp = build_climb(scene, margin=margin, min_head_acceleration=min_head_acceleration, solver=solver)
    timings = dict(cp.timings)
    record: dict[str, Any] = {"decimals": decimals, "timings": timings, "solver": solver, "problem": cp,
                              "tolerances": _plan_tolerances(cp, scale_tolerance, decimals)}
    if cp.obstacle is not None:
        timings["total"] = time.perf_counter() - start
        return _not_planned(cp, cp.obstacle, float(scale), (), **record)

    # Bisection on the scale in [0, s_bound].
    t0 = time.perf_counter()
    lo, hi, u_lo, steps = _bisect_scale(cp, scale_tolerance)
    if u_lo is None:
        timings["total"] = time.perf_counter() - start
        reason = (f"no torques keep mode {cp.problem.scene_mode(cp.mode)} unambiguous with margin "
                  f"{cp.margin:g} even at the zero disturbance (another mode holds there)")
        return _not_planned(cp, reason, float(scale), steps, **record)
    timings["bisection"] = time.perf_counter() - t0

    # The plan at the nominal scale (or the largest feasible one).
    t0 = time.perf_counter()
    nominal_feasible = scale <= lo
    plan_scale, index, u = _planned_torques(cp, float(scale) if nominal_feasible else lo, lo, u_lo)
    rounded = np.round(u, decimals) + 0.0
    check = _verify(cp, rounded, plan_scale)
    timings["plan"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - start
    names = scene.inputs.coordinates
    return ClimbPlan(
        found=True, mode=cp.mode, torques={name: float(x) for name, x in zip(names, rounded, strict=True)},
        scale=plan_scale, nominal_feasible=nominal_feasible, max_disturbance_scale=lo,
        scale_bracket=(lo, hi), scale_bound=cp.scale_bound, scale_capped=cp.scale_capped,
        max_scale_torques={name: float(x) for name, x in zip(names, u_lo, strict=True)},
        robust=check["robust"], robustness_radius=check["radius"], margin=cp.margin,
        head_acceleration=check["zero"], head_sideways_acceleration=check["sideways"],
        free_accelerations=check["free"], worst_head_acceleration=check["worst"],
        min_head_acceleration=cp.min_head_acceleration, exclusions=check["exclusions"],
        pieces=len(cp.pieces), piece=index, bisection=tuple(steps), disturbances=cp.disturbances,
        reason=_plan_reason(cp, check, plan_scale, lo, scale, nominal_feasible), **record)


def _check_plan_options(scale: float, scale_tolerance: float, decimals: int) -> None:
    """Raises InputError for a bad nominal scale, bisection tolerance or number of decimals."""
    if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale >= 0):
        raise InputError(f"scale must be a finite number >= 0, got {scale!r}")
    if not (isinstance(scale_tolerance, (int, float)) and 0 < scale_tolerance < 1):
        raise InputError(f"scale_tolerance must be in (0, 1), got {scale_tolerance!r}")
    if not isinstance(decimals, int) or decimals < 0:
        raise InputError(f"decimals must be an integer >= 0, got {decimals!r}")


def _plan_tolerances(cp: ClimbProblem, scale_tolerance: float, decimals: int) -> dict[str, float]:
    """The tolerances a plan used, as reported."""
    return {"margin": cp.margin, "scale_tolerance": scale_tolerance, "domain": DOMAIN_TOLERANCE,
            "acceleration_slack": ACCELERATION_SLACK,
            "optimality_slack": OPTIMALITY_SLACK,
            "acceleration_floor": ACCELERATION_FLOOR, "analysis_box_growth": ANALYSIS_BOX_GROWTH,
            "scale_cap": SCALE_CAP, "torque_rounding": 0.5 * 10.0 ** -decimals}


def _not_planned(cp: ClimbProblem, reason: str, scale: float, bisection: Sequence[tuple[float, bool]],
                 **record: Any) -> ClimbPlan:
    """A plan not found, with why; ``record``: decimals, timings, tolerances, solver and problem."""
    return ClimbPlan(
        found=False, mode=cp.mode, torques={}, scale=scale, nominal_feasible=False,
        max_disturbance_scale=0.0, scale_bracket=(0.0, 0.0), scale_bound=max(cp.scale_bound, 0.0),
        scale_capped=cp.scale_capped, max_scale_torques={}, robust=False, robustness_radius=-math.inf,
        margin=cp.margin, head_acceleration=math.nan, head_sideways_acceleration=math.nan,
        free_accelerations={}, worst_head_acceleration=math.nan,
        min_head_acceleration=cp.min_head_acceleration, exclusions=(), pieces=len(cp.pieces), piece=-1,
        bisection=tuple(bisection), disturbances=cp.disturbances, reason=reason, **record)


def _planned_torques(cp: ClimbProblem, plan_scale: float, lo: float, u_lo: np.ndarray
                     ) -> tuple[float, int, np.ndarray]:
    """``(scale, piece, torques)`` of the gentlest plan at ``plan_scale``.

    Only when the nominal scale sits at the bisection's edge is there none: then the plan at the
    largest robust scale ``lo``, else the bisection's own torques there (``u_lo``, piece 0).
    """
    index, _, _, u = gentle_plan(cp, plan_scale)
    if u is None:
        plan_scale = lo
        index, _, _, u = gentle_plan(cp, lo)
    if u is None:
        return plan_scale, 0, u_lo
    return plan_scale, index, u


def _plan_reason(cp: ClimbProblem, check: Mapping[str, Any], plan_scale: float, lo: float, scale: float,
                 nominal_feasible: bool) -> str:
    """What the verified plan guarantees, or why its rounded torques failed the verification."""
    if check["robust"]:
        reason = (f"mode {cp.problem.scene_mode(cp.mode)} holds, unambiguously, for every disturbance in "
                  f"{'P' if plan_scale == 1.0 else f'{plan_scale:.4g} P'}; largest scale {lo:.4g}")
        if not nominal_feasible:
            reason += f" (the nominal scale {scale:g} is infeasible: planned at the largest scale)"
        return reason
    held = [cp.problem.scene_mode(e.mode) for e in check["exclusions"] if e.held]
    return ("the rounded torques failed the verification: "
            + (f"mode(s) {', '.join(held)} also hold" if held else
               f"radius {check['radius']:.3g}, worst head acceleration {check['worst']:.3g} m/s^2"))


def _bisect_scale(cp: ClimbProblem, scale_tolerance: float
                  ) -> tuple[float, float, np.ndarray | None, list[tuple[float, bool]]]:
    """The largest robust disturbance scale in [0, s_bound], by bisection.

    Returns:
        (lo, hi): the bracket (lo robust); the torques at lo (None when not even the zero
        disturbance is robust); every scale tried with its verdict.
    """
    steps: list[tuple[float, bool]] = []
    top = check_scale(cp, cp.scale_bound)
    steps.append((cp.scale_bound, top.robust))
    if top.robust:
        return cp.scale_bound, cp.scale_bound, top.torques, steps
    bottom = check_scale(cp, 0.0)
    steps.append((0.0, bottom.robust))
    if not bottom.robust:
        return 0.0, 0.0, None, steps
    lo, hi, u_lo = 0.0, cp.scale_bound, bottom.torques
    width = scale_tolerance * max(cp.scale_bound, 1e-12)
    while hi - lo > width:
        mid = 0.5 * (lo + hi)
        step = check_scale(cp, mid)
        steps.append((mid, step.robust))
        if step.robust:
            lo, u_lo = mid, step.torques
        else:
            hi = mid
    return lo, hi, u_lo, steps


