r"""The snake climb: one set of joint torques that holds a brace in mode F for every disturbance.

The task (METHOD §6; Greenfield's talk, slides 23-25): a planar snake braces its lower part in a
vertical channel at three contacts. Find joint torques ``u`` such that, for every disturbance
force ``d`` in a given polytope, the only rigid-body solution is the brace sticking (mode ``FFF``:
one ``F`` per brace contact) while the upper part accelerates upward; report the largest
disturbance scale for which such torques exist.

Disturbances (the ``[[disturbances]]`` tables of a scene)
---------------------------------------------------------
This format is a contract::

    [[disturbances]]
    name = "head_push"        # unique; components are named "head_push.fx", "head_push.fy"
    link = "link8"            # a URDF link
    point = [0.2, 0.0]        # [m] point of application, in that link's frame
    lower = [-3.0, -3.0]      # [N] a box of forces (fx, fy), world frame ...
    upper = [3.0, 3.0]
    # vertices = [[fx, fy], ...]   # [N] ... or a convex polygon (its convex hull is taken:
    #                              # one point, a segment or a polygon), world frame

Give either ``lower`` and ``upper`` or ``vertices``. The disturbance polytope ``P`` is the product
of the tables' polygons. A force ``d_i`` at point ``p_i`` enters the dynamics as ``J_i^T d_i``
with ``J_i`` the point's linear Jacobian (2 x n, world x-y). Bad tables raise
:class:`~frcontrol.errors.SceneError` naming the field: missing, empty (``lower > upper``, no
vertex), unbounded (an infinite bound), NaN, unknown link or key, a duplicate name.

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

import itertools
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..engine import DOMAIN_TOLERANCE, DynamicResponse, analyze
from ..errors import FrameNotFound, InputError, SceneError
from ..jsonable import finite_or_none, to_jsonable
from ..modes import ContactProblem, ModeSystem, add_scene_modes, all_modes, build_mode_system
from ..polytope import Polytope, hull_from_points
from ..response import AffineSolution, solve_affine
from ..scene import Inputs, Scene
from ..scene_tables import TaskTable
from ..simulation.closed_loop import Policy, run_closed_loop
from ..simulation.inputs import check_seed, check_simulation_times
from ..simulation.rigid import RigidSettings, RigidStepper
from ..simulation.trajectory import Trajectory
from ..solvers import CONFIRM_INFEASIBLE, DEFAULT_LP_SOLVER, RETRY_ERRORS, solve_lp
from . import DEFAULT_CLIMB_DURATION, DEFAULT_CLIMB_MARGIN

__all__ = [
    "ANALYSIS_BOX_GROWTH",
    "BRACE_SLIP_TOLERANCE",
    "DEFAULT_MARGIN",
    "DEFAULT_MIN_HEAD_ACCELERATION",
    "HOLD_INDEX_ROUNDOFF",
    "ACCELERATION_FLOOR",
    "ACCELERATION_SLACK",
    "OPTIMALITY_SLACK",
    "SCALE_CAP",
    "SCALE_TOLERANCE",
    "TORQUE_DECIMALS",
    "ClimbPlan",
    "ClimbProblem",
    "ClimbResult",
    "ClimbTask",
    "Disturbance",
    "DisturbanceSet",
    "ModeExclusion",
    "ScaleCheck",
    "augmented_problem",
    "build_climb",
    "check_scale",
    "load_climb_task",
    "load_disturbances",
    "mode_exclusions",
    "plan_climb",
    "robust_region",
    "simulate_climb",
]

DEFAULT_MARGIN = DEFAULT_CLIMB_MARGIN
"""[N m or N] Required robustness radius: every ``(u, v)``, ``v`` a point of ``V_s``, keeps at
least this distance (in the lifted ``(u, d)`` space, rows normalised) from the boundary of the
brace mode's unambiguous piece, and the head's acceleration row is tightened by it."""

DEFAULT_MIN_HEAD_ACCELERATION = 1.0
"""[m/s^2] a_min, the head's required upward acceleration when ``[task]`` does not say."""

SCALE_TOLERANCE = 1e-3
"""[-] The bisection stops when its bracket is narrower than this times the scale bound."""

SCALE_CAP = 1e3
"""[-] Largest disturbance scale searched (a disturbance that changes nothing has no largest
scale: it is then reported as this cap, with ``scale_capped``)."""

TORQUE_DECIMALS = 3
"""Decimals of the reported torques [N m]; the rounded torques are the ones verified."""

ANALYSIS_BOX_GROWTH = 0.1
"""[-] The lifted analysis bounds the disturbances by the box of ``conv(0, s_bound P)`` grown on
every side by this fraction of ``max(s_bound, 1)`` times P's extent, plus the margin."""

ACCELERATION_SLACK = 0.1
"""[-] The robustness LP lets the free coordinates' nominal accelerations exceed the gentlest
plan's ``alpha*`` by this fraction (room for a more robust squeeze)."""

ACCELERATION_FLOOR = 1e-3
"""[rad/s^2 or m/s^2] Added to the acceleration bound of the robustness LP (keeps it feasible when
``alpha* = 0``, against the LP's own tolerance)."""

OPTIMALITY_SLACK = 1e-6
"""[-] The least-effort LP keeps ``t >= t* - OPTIMALITY_SLACK (1 + t*)``."""

ROBUSTNESS_CAP = 1e3
"""[N m or N] Upper bound on the robustness variable t (keeps the LP bounded)."""

BRACE_SLIP_TOLERANCE = 1e-4
"""[m] Largest tangential displacement of a brace contact for which the brace counts as held."""

DEFAULT_DURATION = DEFAULT_CLIMB_DURATION
"""[s] Simulated time of :func:`simulate_climb` (the constant torques are an instantaneous plan)."""

DEFAULT_HOLD = 0.05
"""[s] How long each sampled disturbance is held in :func:`simulate_climb`."""

HOLD_INDEX_ROUNDOFF = 1e-9
"""[-] In :func:`simulate_climb`, a step starting within this many holds of a hold's end starts the
next hold (``t / hold`` is rounded up over round-off)."""

# ============================================================================ disturbances
@dataclass(frozen=True)
class Disturbance:
    """One disturbance force: a point of a link and a convex polygon of forces.

    Attributes:
        name: the table's name.
        link: the URDF link the force acts on.
        point_in_link: the point of application [m] in the link's frame.
        vertices: the polygon's vertices [N] (fx, fy in the world), counter-clockwise, shape
            (k, 2) with k = 1 (a point), 2 (a segment) or >= 3.
    """

    name: str
    link: str
    point_in_link: np.ndarray
    vertices: np.ndarray

    @property
    def lower(self) -> np.ndarray:
        """[N] Componentwise lower bound of the polygon (its bounding box)."""
        return self.vertices.min(axis=0)

    @property
    def upper(self) -> np.ndarray:
        """[N] Componentwise upper bound of the polygon."""
        return self.vertices.max(axis=0)

    def contains_zero(self) -> bool:
        """Whether the zero force is in the polygon (to :data:`DOMAIN_TOLERANCE` [N])."""
        A, b, A_eq, b_eq = _polygon_rows(self.vertices)
        return bool(np.all(b >= -DOMAIN_TOLERANCE) and np.all(np.abs(b_eq) <= DOMAIN_TOLERANCE))

    def polytope(self, scale: float = 1.0) -> Polytope:
        """The polygon scaled by ``scale`` about the zero force, as a 2-D H-polytope."""
        A, b, A_eq, b_eq = _polygon_rows(scale * self.vertices)
        return Polytope(A, b, A_eq, b_eq)


@dataclass(frozen=True)
class DisturbanceSet:
    """The disturbance polytope P: the product of the disturbances' polygons.

    Attributes:
        items: the disturbances, in file order.
    """

    items: tuple[Disturbance, ...]

    @property
    def names(self) -> tuple[str, ...]:
        """The components' names, two per disturbance: ``"<name>.fx"``, ``"<name>.fy"``."""
        return tuple(f"{d.name}.{axis}" for d in self.items for axis in ("fx", "fy"))

    @property
    def dim(self) -> int:
        """Number of components (2 per disturbance)."""
        return 2 * len(self.items)

    @property
    def lower(self) -> np.ndarray:
        """[N] Lower corner of P's bounding box."""
        return np.concatenate([d.lower for d in self.items]) if self.items else np.zeros(0)

    @property
    def upper(self) -> np.ndarray:
        """[N] Upper corner of P's bounding box."""
        return np.concatenate([d.upper for d in self.items]) if self.items else np.zeros(0)

    def contains_zero(self) -> bool:
        """Whether the zero disturbance is in P."""
        return all(d.contains_zero() for d in self.items)

    def vertices(self, scale: float = 1.0) -> np.ndarray:
        """The vertices of ``scale P`` (every combination of the polygons' vertices), (N, dim)."""
        combos = itertools.product(*[d.vertices for d in self.items])
        return scale * np.array([np.concatenate(c) for c in combos]).reshape(-1, self.dim)

    def robust_points(self, scale: float = 1.0) -> np.ndarray:
        """``V_s``: the vertices of ``scale P``, plus the zero disturbance if P does not hold it."""
        points = self.vertices(scale)
        if not self.contains_zero():
            points = np.vstack([np.zeros((1, self.dim)), points])
        return points


def _polygon_rows(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, b, A_eq, b_eq)`` of the hull of ``vertices`` (k, 2), rows of unit norm.

    The slack form: a point x is in the set iff ``A x <= b`` and ``A_eq x = b_eq``; with x = 0 the
    slacks are ``b`` and ``-b_eq``.
    """
    k = len(vertices)
    if k == 1:
        return np.zeros((0, 2)), np.zeros(0), np.eye(2), vertices[0].copy()
    if k == 2:
        a, b = vertices
        direction = (b - a) / np.linalg.norm(b - a)
        normal = np.array([-direction[1], direction[0]])
        A = np.vstack([direction, -direction])
        return A, np.array([direction @ b, -direction @ a]), normal[None, :], np.array([normal @ a])
    rows, rhs = [], []
    for i in range(k):
        p, q = vertices[i], vertices[(i + 1) % k]
        edge = q - p
        normal = np.array([edge[1], -edge[0]]) / np.linalg.norm(edge)  # outward for ccw order
        rows.append(normal)
        rhs.append(normal @ p)
    return np.array(rows), np.array(rhs), np.zeros((0, 2)), np.zeros(0)


def load_disturbances(scene: Scene, *, required: bool = True) -> DisturbanceSet:
    """Read and validate the scene's ``[[disturbances]]`` tables (format: module docstring).

    Args:
        scene: the loaded scene (its ``disturbances``, read at load).
        required: raise if the scene has none (the climb needs a disturbance polytope).

    Raises:
        SceneError: missing tables (with ``required``), a table that is not a table, an unknown
            key, a missing or duplicate name, an unknown link, a bad point, both or neither of
            bounds and vertices, an empty polytope (``lower > upper``, no vertex), an unbounded
            one (infinite bound or vertex) or a NaN.
    """
    if not scene.disturbances:
        if required:
            raise SceneError(str(scene.path), "disturbances", "missing: the climb needs at least one "
                             "[[disturbances]] table (name, link, point, lower/upper or vertices)")
        return DisturbanceSet(())
    return DisturbanceSet(tuple(Disturbance(d.name, d.link, d.point, hull_from_points(d.corners))
                                for d in scene.disturbances))


# ============================================================================ task
@dataclass(frozen=True)
class ClimbTask:
    """What the climb planner needs to know of a scene (its ``[task]`` table).

    Attributes:
        brace_contacts: the contacts held in mode F (all the active contacts).
        head_link: the link of the point that must accelerate upward.
        head_point: that point [m] in the link's frame.
        min_head_acceleration: a_min [m/s^2].
    """

    brace_contacts: tuple[str, ...]
    head_link: str
    head_point: np.ndarray
    min_head_acceleration: float


def load_climb_task(scene: Scene) -> ClimbTask:
    """Read the ``[task]`` table (see the module docstring).

    The table is shared by the planners: keys the climb does not read are ignored.

    Raises:
        SceneError: a missing ``head_link`` or ``head_point``, an unknown or inactive brace
            contact, brace contacts that are not all the active contacts, an unknown head link, a
            bad point or acceleration.
    """
    path = str(scene.path)
    task = scene.task
    phases = scene.raw.get("task", {}).get("phases") if task.head_link is None else None
    if phases:
        task = _task_from_phases(path, phases)
    active = tuple(c.name for c in scene.active_contacts)
    names = tuple(c.name for c in scene.contacts)
    brace = list(task.brace_contacts) if task.brace_contacts is not None else list(active)
    for i, b in enumerate(brace):
        if b not in names:
            raise SceneError(path, f"task.brace_contacts[{i}]", f"unknown contact {b!r}; the contacts "
                             f"are: {', '.join(names)}")
        if b not in active:
            raise SceneError(path, f"task.brace_contacts[{i}]", f"contact {b!r} does not touch at the "
                             "scene's state: a brace contact must be active")
    if set(brace) != set(active) or len(brace) != len(set(brace)):
        raise SceneError(path, "task.brace_contacts", f"expected every active contact once "
                         f"({', '.join(active)}): the climb holds each in mode F; got {brace}")
    for key, what in (("head_link", "the link of the point that must rise"),
                      ("head_point", "that point [m] in the link's frame")):
        if getattr(task, key) is None:
            raise SceneError(path, f"task.{key}", f"missing: the climb needs [task] {key}, {what}")
    links = scene.robot.link_names
    head_link = str(task.head_link)
    if head_link not in links:
        raise SceneError(path, "task.head_link", str(FrameNotFound(head_link, links)))
    head_point = task.head_point
    assert head_point is not None  # checked above
    a_min = (task.min_head_acceleration if task.min_head_acceleration is not None
             else DEFAULT_MIN_HEAD_ACCELERATION)
    ordered = tuple(c for c in active if c in brace)
    return ClimbTask(ordered, head_link, head_point, float(a_min))


def _task_from_phases(path: str, phases: Sequence[Mapping[str, Any]]) -> TaskTable:
    """The climb's brace and head read from a task given as phases.

    The brace: the first phase's contacts allowed only F; the head: the point whose upward
    acceleration it requires (``require``).
    """
    phase = phases[0]
    brace = tuple(name for name, letters in phase.get("modes", {}).items() if set(letters) == {"F"})
    for item in phase.get("require", ()):
        if "link" in item and "at_least" in item and tuple(item["direction"]) == (0.0, 1.0):
            return TaskTable(brace_contacts=brace or None, head_link=str(item["link"]),
                             head_point=np.asarray(item["point"], dtype=float),
                             min_head_acceleration=float(item["at_least"]))
    raise SceneError(path, "task.phases[0].require", "missing: the climb needs its first phase to require "
                     "a point's upward acceleration: require = [{ link = NAME, point = [x, y], "
                     "direction = [0.0, 1.0], at_least = A }]")


# ============================================================================ kinematics
class _PointKinematics:
    """World Jacobians of a few points of the robot, by :meth:`PlanarRobot.point_kinematics`."""

    def __init__(self, scene: Scene, points: Sequence[tuple[str, str, np.ndarray]]) -> None:
        self.robot = scene.robot
        self.points = [(link, np.asarray(point, dtype=float)) for _, link, point in points]
        for link, _ in self.points:
            if link not in self.robot.link_names:
                raise FrameNotFound(link, self.robot.link_names)

    def evaluate(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The points' Jacobians, drifts and positions at ``(q, v)``.

        Returns:
            ``(J, drift, positions)``: J (2p, n), rows x then y per point; drift (2p,) [m/s^2];
            positions (p, 2) [m].
        """
        kin = self.robot.point_kinematics(q, v, self.points)
        return kin.jacobians.reshape(-1, self.robot.nv), kin.drifts.reshape(-1), kin.positions

    def positions(self, q: np.ndarray) -> np.ndarray:
        """World positions [m] of the points at ``q``, shape (p, 2)."""
        return self.evaluate(q, np.zeros(self.robot.nv))[2]


def augmented_problem(
    scene: Scene,
    disturbances: DisturbanceSet,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
) -> ContactProblem:
    """The scene's contact problem with the disturbance components as extra inputs.

    Inputs ``z = (u, d)``, input map ``[S^T, J_d^T]`` (J_d: the points' world x-y Jacobians at the
    scene's state), limits: the scene's input limits, then ``lower <= d <= upper`` (default: the
    bounding box of ``conv(0, P)``).
    """
    base = ContactProblem.from_scene(scene)
    kin = _PointKinematics(scene, [(d.name, d.link, d.point_in_link) for d in disturbances.items])
    jac, _, _ = kin.evaluate(scene.q, scene.v)
    if lower is None:
        lower = np.minimum(0.0, disturbances.lower)
    if upper is None:
        upper = np.maximum(0.0, disturbances.upper)
    return replace(
        base,
        inputs=base.inputs + disturbances.names,
        input_map=np.hstack([base.input_map, jac.T]),
        lower=np.concatenate([base.lower, np.asarray(lower, dtype=float)]),
        upper=np.concatenate([base.upper, np.asarray(upper, dtype=float)]),
    )


# ============================================================================ exclusion
def _solve(c: np.ndarray, A_ub: np.ndarray, b_ub: np.ndarray, A_eq: np.ndarray | None,
           b_eq: np.ndarray | None, lb: np.ndarray, ub: np.ndarray, solver: str, confirm: bool) -> Any:
    """:func:`~frcontrol.solvers.solve_lp`, with a second opinion from the reference back-end.

    An error or an unbounded answer is always solved again by :data:`REFERENCE_LP_SOLVER`; with
    ``confirm``, so is an infeasible one (a false "infeasible" would drop a plan, or claim that a
    mode is excluded).
    """
    return solve_lp(c, A_ub, b_ub, A_eq, b_eq, lb, ub, solver=solver,
                    fallback=CONFIRM_INFEASIBLE if confirm else RETRY_ERRORS)


@dataclass(frozen=True)
class ModeExclusion:
    """Whether another mode holds somewhere on ``{u} x conv(V_s)``.

    Attributes:
        mode: the mode.
        held: some disturbance of the robust set (and some w) puts ``(u, d, w)`` in the mode's
            domain, the motion rows strictly: the plan would be ambiguous.
        margin: [N m or N] the LP's ``t*``: the largest margin of the mode's motion rows with its
            force rows held (negative: the distance, in the lifted space, by which the mode misses
            the plan); ``-inf`` when even the force rows cannot hold (or the mode is inconsistent,
            or it misses by more than :data:`ROBUSTNESS_CAP`).
        disturbance: the witness d (when held), else None.
    """

    mode: str
    held: bool
    margin: float
    disturbance: np.ndarray | None = None


def _normalised_rows(
    system: ModeSystem, response: AffineSolution
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The mode's inequalities over ``(z, w)`` as unit rows ``H [z; w] <= h`` (constant rows: 0)."""
    G = system.G
    H = np.hstack([G @ response.X_u, G @ response.X_w])
    h = system.g - G @ response.x_0
    norms = np.sqrt(np.sum(H * H, axis=1))
    constant = norms <= 1e-9 * max(1.0, float(np.max(norms, initial=0.0)))
    norms[constant] = 1.0
    H = H / norms[:, None]
    H[constant] = 0.0
    return H, h / norms, constant


def mode_exclusions(
    problem: ContactProblem,
    target: str,
    torques: np.ndarray,
    points: np.ndarray,
    *,
    systems: Sequence[tuple[ModeSystem, AffineSolution]] | None = None,
    solver: str = DEFAULT_LP_SOLVER,
    confirm: bool = False,
) -> tuple[ModeExclusion, ...]:
    """For every mode but ``target``: does it hold for some ``d in conv(points)``? One LP each.

    With ``d = points^T lam`` (``lam`` in the simplex), maximise ``t`` in [-cap, 1] subject to the
    mode's normalised rows at ``(torques, d, w)``: force rows ``<= h + tol``, motion rows
    ``+ t <= h``, consistency rows ``|E z - e| <= tol`` (tol = :data:`DOMAIN_TOLERANCE`). The
    mode holds somewhere iff ``t* > tol``, the membership rule of
    :func:`~frcontrol.engine.solutions_at`.

    Args:
        problem: the augmented problem (inputs ``(u, d)``).
        target: the planned mode (skipped).
        torques: u, shape (m_u,), the first inputs of the problem.
        points: the robust points V_s, shape (N, dim d).
        systems: prebuilt ``(system, response)`` of every mode (default: built here).
        solver: the LP back-end.
        confirm: have every "infeasible" (mode excluded) confirmed by the reference back-end
            (HiGHS) when ``solver`` is another one.
    """
    u = np.asarray(torques, dtype=float)
    m_u = u.size
    pts = np.asarray(points, dtype=float).reshape(-1, problem.m - m_u)
    if systems is None:
        systems = _mode_systems(problem)
    tol = DOMAIN_TOLERANCE
    out = []
    for system, response in systems:
        if system.mode == target:
            continue
        if not response.consistent:
            out.append(ModeExclusion(system.mode, False, -math.inf))
            continue
        H, h, _ = _normalised_rows(system, response)
        p = response.ambiguity_dim
        Hu, Hd, Hw = H[:, :m_u], H[:, m_u:problem.m], H[:, problem.m:]
        rhs = h - Hu @ u
        n_lam = pts.shape[0]
        motion = system.motion.astype(float)
        # variables (lam, w, t)
        A_ub = np.hstack([Hd @ pts.T, Hw, motion[:, None]])
        b_ub = rhs + np.where(system.motion, 0.0, tol)
        E, e = response.E, response.e
        if E.shape[0]:
            Ez = np.hstack([E[:, m_u:] @ pts.T, np.zeros((E.shape[0], p + 1))])
            target_e = e - E[:, :m_u] @ u
            A_ub = np.vstack([A_ub, Ez, -Ez])
            b_ub = np.concatenate([b_ub, target_e + tol, -target_e + tol])
        A_eq = np.concatenate([np.ones(n_lam), np.zeros(p + 1)])[None, :]
        lb = np.concatenate([np.zeros(n_lam), np.full(p, -np.inf), [-ROBUSTNESS_CAP]])
        ub = np.concatenate([np.full(n_lam, np.inf), np.full(p, np.inf), [1.0]])
        c = np.zeros(n_lam + p + 1)
        c[-1] = -1.0
        result = _solve(c, A_ub, b_ub, A_eq, np.ones(1), lb, ub, solver, confirm)
        if not result.found:
            out.append(ModeExclusion(system.mode, False, -math.inf))
            continue
        t = float(result.x[-1])
        held = t > tol
        out.append(ModeExclusion(system.mode, held, t, pts.T @ result.x[:n_lam] if held else None))
    return tuple(out)


def _mode_systems(problem: ContactProblem) -> tuple[tuple[ModeSystem, AffineSolution], ...]:
    """Every mode velocity pruning allows, with its system and affine response."""
    out = []
    for mode in all_modes(problem.allowed_modes()):
        system = build_mode_system(problem, mode)
        response = solve_affine(system.A, system.B, system.c, name=f"the system of mode {mode}")
        out.append((system, response))
    return tuple(out)


# ============================================================================ build
@dataclass(frozen=True, eq=False)
class ClimbProblem:
    """Everything the climb LPs need, built once.

    Attributes:
        scene: the scene.
        task: its ``[task]``.
        disturbances: the polytope P.
        problem: the augmented contact problem (inputs u then d), with the analysis box as the
            disturbances' limits.
        mode: the brace mode (``"F"`` per brace contact).
        m_u: number of torques.
        domain_rows: ``(H, h)`` of ``T_F`` over ``z = (u, d)`` (force rows of the brace mode and
            the torque limits), unnormalised.
        head_row: ``(c, c_0)``: the head's upward acceleration ``a_y = c^T z + c_0`` [m/s^2].
        head_sideways_row: ``(c_x, c_x0)``: its sideways one, ``a_x = c_x^T z + c_x0`` [m/s^2].
        free_coordinates: the coordinates no brace contact row involves (the upper body).
        free_rows: ``(B, b_0)``: their accelerations ``ddq_f = B z + b_0`` [rad/s^2 or m/s^2].
        pieces: the convex pieces of the brace mode's unambiguous set in the lifted space (within
            the analysis box).
        box: ``(lower, upper)`` [N] of the disturbances in the analysis.
        scale_bound: the one-LP upper bound on the scale (``s_bound``); -1 if even s = 0 is infeasible.
        scale_capped: the bound reached :data:`SCALE_CAP`.
        systems: every mode's ``(system, response)`` on the augmented problem.
        analysis: the engine's analysis of the augmented problem (None when not reached).
        obstacle: why no plan can exist (None if the LPs may proceed).
        margin: [N m or N] the required robustness radius.
        min_head_acceleration: a_min [m/s^2].
        timings: [s] per stage.
    """

    scene: Scene
    task: ClimbTask
    disturbances: DisturbanceSet
    problem: ContactProblem
    mode: str
    m_u: int
    domain_rows: tuple[np.ndarray, np.ndarray]
    head_row: tuple[np.ndarray, float]
    head_sideways_row: tuple[np.ndarray, float]
    free_coordinates: tuple[str, ...]
    free_rows: tuple[np.ndarray, np.ndarray]
    pieces: tuple[Polytope, ...]
    box: tuple[np.ndarray, np.ndarray]
    scale_bound: float
    scale_capped: bool
    systems: tuple[tuple[ModeSystem, AffineSolution], ...]
    analysis: DynamicResponse | None
    obstacle: str | None
    margin: float
    min_head_acceleration: float
    solver: str
    timings: Mapping[str, float] = field(default_factory=dict)

    def robust_points(self, scale: float) -> np.ndarray:
        """V_s (see :meth:`DisturbanceSet.robust_points`)."""
        return self.disturbances.robust_points(scale)


def _unit(H: np.ndarray) -> np.ndarray:
    norms = np.sqrt(np.sum(H * H, axis=1))
    return np.where(norms > 0, norms, 1.0)


def _scale_bound(domain: tuple[np.ndarray, np.ndarray], head: tuple[np.ndarray, float],
                 sideways: tuple[np.ndarray, float], points: np.ndarray, m_u: int, margin: float,
                 a_min: float, solver: str) -> tuple[float, bool]:
    """The largest scale s for which some u keeps every ``(u, s v)`` in T_F shrunk by the margin.

    With the head's ``a_y >= a_min + margin |c|`` at every ``s v`` and ``a_x(u, 0) = 0``. Returns
    ``(s*, capped)``; ``s* = -1`` when even ``s = 0`` is infeasible.
    """
    H, h = domain
    c, c0 = head
    norms = _unit(H)
    c_norm = float(np.linalg.norm(c)) or 1.0
    rows, rhs = [], []
    for v in points:
        rows.append(np.hstack([H[:, :m_u], (H[:, m_u:] @ v)[:, None]]))
        rhs.append(h - margin * norms)
        rows.append(np.hstack([-c[None, :m_u], [[-(c[m_u:] @ v)]]]))
        rhs.append(np.array([c0 - a_min - margin * c_norm]))
    A = np.vstack(rows)
    b = np.concatenate(rhs)
    cost = np.zeros(m_u + 1)
    cost[-1] = -1.0
    lb = np.concatenate([np.full(m_u, -np.inf), [0.0]])
    ub = np.concatenate([np.full(m_u, np.inf), [SCALE_CAP]])
    A_eq = np.concatenate([sideways[0][:m_u], [0.0]])[None, :]
    b_eq = np.array([-sideways[1]])
    result = _solve(cost, A, b, A_eq, b_eq, lb, ub, solver, True)
    if not result.found:
        return -1.0, False
    s = float(result.x[-1])
    return s, s >= SCALE_CAP * (1 - 1e-9)


def build_climb(
    scene: Scene,
    *,
    margin: float = DEFAULT_MARGIN,
    min_head_acceleration: float | None = None,
    solver: str = DEFAULT_LP_SOLVER,
) -> ClimbProblem:
    """Assemble the climb: disturbances, task, the brace mode's rows, the scale bound, the pieces.

    Raises:
        SceneError: bad ``[[disturbances]]`` or ``[task]`` tables.
        InputError: a negative or non-finite margin or acceleration.
    """
    if not (isinstance(margin, (int, float)) and math.isfinite(margin) and margin >= 0):
        raise InputError(f"margin must be a finite number >= 0 [N m or N], got {margin!r}")
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    task = load_climb_task(scene)
    dist = load_disturbances(scene)
    a_min = task.min_head_acceleration if min_head_acceleration is None else float(min_head_acceleration)
    if not math.isfinite(a_min):
        raise InputError(f"min_head_acceleration must be finite [m/s^2], got {min_head_acceleration!r}")
    base = augmented_problem(scene, dist)
    m_u = scene.inputs.count
    mode = "F" * base.k
    points = dist.robust_points(1.0)

    def result(**kw: Any) -> ClimbProblem:
        timings["build"] = time.perf_counter() - t0
        defaults: dict[str, Any] = {
            "pieces": (), "box": (base.lower[m_u:], base.upper[m_u:]), "scale_bound": -1.0,
            "scale_capped": False, "systems": (), "analysis": None, "obstacle": None,
            "domain_rows": (np.zeros((0, base.m)), np.zeros(0)), "head_row": (np.zeros(base.m), 0.0),
            "head_sideways_row": (np.zeros(base.m), 0.0),
            "free_coordinates": (), "free_rows": (np.zeros((0, base.m)), np.zeros(0))}
        defaults.update(kw)
        return ClimbProblem(scene=scene, task=task, disturbances=dist, mode=mode, m_u=m_u,
                            margin=float(margin), min_head_acceleration=a_min, solver=solver,
                            timings=timings, problem=defaults.pop("problem", base), **defaults)

    brace = _brace_mode(base, mode)
    if isinstance(brace, str):
        return result(obstacle=brace)
    common = _brace_rows(scene, base, *brace, task, m_u)
    timings["rows"] = time.perf_counter() - t0
    (H, h), (c, c0), sideways = common["domain_rows"], common["head_row"], common["head_sideways_row"]
    t1 = time.perf_counter()
    s_bound, capped = _scale_bound((H, h), (c, c0), sideways, points, m_u, margin, a_min, solver)
    timings["scale_bound"] = time.perf_counter() - t1
    if s_bound < 0:
        return result(**common, scale_bound=-1.0, obstacle=(
            f"no torques within the limits keep mode {base.scene_mode(mode)} with margin {margin:g} and "
            f"the head accelerating upward at >= {a_min:g} m/s^2, even without disturbance: widen the torque "
            "limits, lower min_head_acceleration or the margin"))

    t1 = time.perf_counter()
    boxed, analysis, pieces, obstacle, (lower, upper) = _lifted_analysis(scene, dist, s_bound, margin, mode,
                                                                         solver)
    timings["analysis"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    systems = _mode_systems(boxed)
    timings["mode_systems"] = time.perf_counter() - t1
    return result(**common, problem=boxed, pieces=tuple(pieces), box=(lower, upper), scale_bound=s_bound,
                  scale_capped=capped, systems=systems, analysis=analysis, obstacle=obstacle)


def _brace_mode(base: ContactProblem, mode: str) -> tuple[ModeSystem, AffineSolution] | str:
    """The brace mode's system and its unique response, or why the brace cannot be certified."""
    if base.k == 0:
        return "the scene has no active contact: there is no brace to hold"
    allowed = base.allowed_modes()
    moving = [c for c, letters in zip(base.contacts, allowed, strict=True) if "F" not in letters]
    if moving:
        return (f"brace contact(s) {', '.join(moving)} move at the scene's state: mode F "
                "is not possible (velocity pruning)")
    system = build_mode_system(base, mode)
    response = solve_affine(system.A, system.B, system.c, name=f"the system of mode {mode}")
    if not response.consistent or response.ambiguity_dim or response.E.shape[0]:
        return (f"mode {base.scene_mode(mode)} has {response.ambiguity_dim} ambiguity variable(s) and "
                f"{response.E.shape[0]} consistency condition(s): the brace's squeeze is not set by the "
                "torques (fewer brace coordinates than brace rows), so no torque can certify it for every "
                "squeeze; give the brace at least as many coordinates as contact rows (METHOD §6)")
    return system, response


def _brace_rows(scene: Scene, base: ContactProblem, system: ModeSystem, response: AffineSolution,
                task: ClimbTask, m_u: int) -> dict[str, Any]:
    """The brace mode's rows over the torques and disturbances, and the head's acceleration rows.

    Returns:
        ``domain_rows`` (H, h): the mode's inequalities and the torque limits; ``head_row`` and
        ``head_sideways_row`` (c, c0): the head's vertical and horizontal acceleration
        ``c z + c0``; ``free_rows`` and ``free_coordinates``: coordinates no brace row involves.
    """
    n = base.n
    G = system.G
    C, d = base.input_bound_rows()
    torque_rows = np.abs(C[:, m_u:]).sum(axis=1) == 0
    H = np.vstack([G @ response.X_u, C[torque_rows]])
    h = np.concatenate([system.g - G @ response.x_0, d[torque_rows]])
    kin = _PointKinematics(scene, [("head", task.head_link, task.head_point)])
    jac, drift, _ = kin.evaluate(scene.q, scene.v)
    c = jac[1] @ response.X_u[:n]
    c0 = float(jac[1] @ response.x_0[:n] + drift[1])
    sideways = (jac[0] @ response.X_u[:n], float(jac[0] @ response.x_0[:n] + drift[0]))
    brace_rows = np.abs(np.vstack([base.jacobian_normal, base.jacobian_tangent]))
    free = np.nonzero(np.all(brace_rows <= 1e-12 * max(1.0, float(brace_rows.max())), axis=0))[0]
    return {"domain_rows": (H, h), "head_row": (c, c0), "head_sideways_row": sideways,
            "free_rows": (response.X_u[free], response.x_0[free]),
            "free_coordinates": tuple(base.coordinates[i] for i in free)}


def _lifted_analysis(scene: Scene, dist: DisturbanceSet, s_bound: float, margin: float, mode: str,
                     solver: str) -> tuple[ContactProblem, DynamicResponse, tuple[Polytope, ...], str | None,
                                       tuple[np.ndarray, np.ndarray]]:
    """The analysis over (torques, disturbances), in a box holding every s P the bisection visits.

    Returns:
        (the boxed problem, its analysis, the brace mode's unambiguous pieces, why there is no
        plan or None, the box (lower, upper)).
    """
    extent = dist.upper - dist.lower
    pad = ANALYSIS_BOX_GROWTH * max(s_bound, 1.0) * extent + margin + DOMAIN_TOLERANCE * 10
    lower = np.minimum(0.0, s_bound * dist.lower) - pad
    upper = np.maximum(0.0, s_bound * dist.upper) + pad
    boxed = augmented_problem(scene, dist, lower, upper)
    analysis = analyze(boxed, solver=solver)
    pieces: tuple[Polytope, ...] = ()
    obstacle = None
    try:
        target = analysis.mode(mode)
    except InputError:
        target = None
    if target is None or not target.feasible:
        obstacle = f"mode {boxed.scene_mode(mode)} is infeasible at the scene's state (empty domain)"
    else:
        pieces = analysis.unambiguous_set(mode)
        if not pieces:
            obstacle = (f"mode {boxed.scene_mode(mode)} has no unambiguous inputs: other modes cover its "
                        "whole domain")
    return boxed, analysis, tuple(pieces), obstacle, (lower, upper)


# ============================================================================ the LPs
def _piece_rows(piece: Polytope, m_u: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A piece's rows, and per row the norm by which t shrinks it (0 for the analysis-box rows)."""
    A, b = np.asarray(piece.A), np.asarray(piece.b)
    if piece.A_eq.shape[0]:
        A = np.vstack([A, piece.A_eq, -piece.A_eq])
        b = np.concatenate([b, piece.b_eq, -piece.b_eq])
    norms = np.sqrt(np.sum(A * A, axis=1))
    nonzero = np.abs(A) > 1e-12 * np.maximum(norms, 1e-300)[:, None]
    box_row = (nonzero.sum(axis=1) == 1) & ~np.any(nonzero[:, :m_u], axis=1)
    shrink = np.where(box_row, 0.0, norms)
    return A, b, shrink


def _plan_lp(
    cp: ClimbProblem, piece: Polytope, scale: float, objective: str, *,
    alpha_cap: float = math.inf, t_min: float | None = None, solver: str | None = None,
) -> tuple[float, float, np.ndarray | None]:
    """One plan LP on a piece at a scale, over ``(u, t, e_f, e_u)`` (module docstring).

    ``e_f`` bounds the free coordinates' nominal accelerations, ``|B_u u + b_0| <= e_f``, with
    ``alpha = sum(e_f)``; ``e_u`` bounds the torques, ``|u| <= e_u``.

    Args:
        cp: the built climb.
        piece: a convex piece of the unambiguous set.
        scale: the disturbance scale s (V_s).
        objective: ``"robust"`` (maximise t), ``"gentle"`` (minimise alpha) or ``"effort"``
            (minimise ``sum(e_u)``).
        alpha_cap: upper bound on alpha [rad/s^2 or m/s^2].
        t_min: lower bound on t (default: the margin).
        solver: the LP back-end (default: the problem's).

    Returns:
        ``(t, alpha, u)`` at the optimum; u None when infeasible.
    """
    solver = solver or cp.solver
    m_u = cp.m_u
    B, b0 = cp.free_rows
    f = B.shape[0]
    nvar = m_u + 1 + f + m_u
    A_ub, b_ub = _plan_lp_rows(cp, piece, scale, alpha_cap)
    cost = np.zeros(nvar)
    if objective == "robust":
        cost[m_u] = -1.0
    elif objective == "gentle":
        cost[m_u + 1:m_u + 1 + f] = 1.0
    else:
        cost[m_u + 1 + f:] = 1.0
    lower_t = cp.margin if t_min is None else max(cp.margin, t_min)
    lb = np.concatenate([cp.scene.inputs.lower, [lower_t], np.zeros(f + m_u)])
    ub = np.concatenate([cp.scene.inputs.upper, [ROBUSTNESS_CAP], np.full(f + m_u, np.inf)])
    cx, cx0 = cp.head_sideways_row
    A_eq = np.concatenate([cx[:m_u], np.zeros(nvar - m_u)])[None, :]
    b_eq = np.array([-cx0])
    result = _solve(cost, A_ub, b_ub, A_eq, b_eq, lb, ub, solver, True)
    if not result.found:
        return -math.inf, math.inf, None
    u = result.x[:m_u]
    alpha = float(np.sum(np.abs(B[:, :m_u] @ u + b0))) if f else 0.0
    return float(result.x[m_u]), alpha, u


def _plan_lp_rows(cp: ClimbProblem, piece: Polytope, scale: float, alpha_cap: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The plan LP's inequalities over ``(u, t, e_f, e_u)``.

    Per point of V_s: the piece's rows shrunk by t and the head's acceleration; then the free
    accelerations' bounds ``|B_u u + b_0| <= e_f`` (and ``sum(e_f) <= alpha_cap``) and the
    torques' ``|u| <= e_u``.
    """
    m_u = cp.m_u
    A, b, shrink = _piece_rows(piece, m_u)
    c, c0 = cp.head_row
    c_norm = float(np.linalg.norm(c)) or 1.0
    head_rhs = c0 - cp.min_head_acceleration - cp.margin * c_norm
    B, b0 = cp.free_rows
    f = B.shape[0]
    nvar = m_u + 1 + f + m_u
    rows, rhs = [], []

    def row(u_part: np.ndarray, t_part: Any = 0.0, f_part: Any = 0.0, e_part: Any = 0.0) -> np.ndarray:
        count = np.atleast_2d(u_part).shape[0]
        out = np.zeros((count, nvar))
        out[:, :m_u] = u_part
        out[:, m_u] = np.ravel(t_part) if np.ndim(t_part) else t_part
        out[:, m_u + 1:m_u + 1 + f] = f_part
        out[:, m_u + 1 + f:] = e_part
        return out

    for v in cp.robust_points(scale):
        rows.append(row(A[:, :m_u], shrink))
        rhs.append(b - A[:, m_u:] @ v)
        rows.append(row(-c[None, :m_u]))
        rhs.append(np.array([head_rhs + c[m_u:] @ v]))
    if f:
        rows += [row(B[:, :m_u], f_part=-np.eye(f)), row(-B[:, :m_u], f_part=-np.eye(f))]
        rhs += [-b0, b0]
        if math.isfinite(alpha_cap):
            rows.append(row(np.zeros((1, m_u)), f_part=np.ones((1, f))))
            rhs.append(np.array([alpha_cap]))
    eye = np.eye(m_u)
    rows += [row(eye, e_part=-eye), row(-eye, e_part=-eye)]
    rhs += [np.zeros(m_u), np.zeros(m_u)]
    return np.vstack(rows), np.concatenate(rhs)


def _best_piece(
    cp: ClimbProblem, scale: float, solver: str | None = None
) -> tuple[int, float, np.ndarray | None]:
    """The piece with the largest robustness radius at ``scale``: ``(index, t*, u)``."""
    best: tuple[int, float, np.ndarray | None] = (-1, -math.inf, None)
    for i, piece in enumerate(cp.pieces):
        t, _, u = _plan_lp(cp, piece, scale, "robust", solver=solver)
        if u is not None and t > best[1]:
            best = (i, t, u)
    return best


def _gentle_plan(cp: ClimbProblem, scale: float) -> tuple[int, float, float, np.ndarray | None]:
    """Objectives 1, 2 and 3 on every piece: ``(index, t, alpha*, u)`` of the gentlest piece."""
    best: tuple[int, float, float, np.ndarray | None] = (-1, -math.inf, math.inf, None)
    for i, piece in enumerate(cp.pieces):
        _, alpha, u = _plan_lp(cp, piece, scale, "gentle")
        if u is None or alpha >= best[2]:
            continue
        cap = (1.0 + ACCELERATION_SLACK) * alpha + ACCELERATION_FLOOR
        t, _, u_robust = _plan_lp(cp, piece, scale, "robust", alpha_cap=cap)
        if u_robust is None:
            best = (i, cp.margin, alpha, u)
            continue
        keep = t - OPTIMALITY_SLACK * (1.0 + abs(t))
        _, _, u_least = _plan_lp(cp, piece, scale, "effort", alpha_cap=cap, t_min=keep)
        best = (i, t, alpha, u_robust if u_least is None else u_least)
    return best


@dataclass(frozen=True, eq=False)
class ScaleCheck:
    """One bisection step: whether robust torques exist at a disturbance scale.

    Attributes:
        scale: the scale s.
        lp_feasible: the robustness LP of some piece is feasible (t >= margin).
        robust: that, and the exact exclusion of every other mode at its torques.
        torques: the most robust torques [N m] (None when the LP is infeasible).
        radius: their robustness radius t* [N m or N] (-inf when infeasible).
        piece: the index of the piece (-1 when infeasible).
        exclusions: the exclusion LPs at the torques (empty when infeasible).
    """

    scale: float
    lp_feasible: bool
    robust: bool
    torques: np.ndarray | None
    radius: float
    piece: int
    exclusions: tuple[ModeExclusion, ...]


def check_scale(cp: ClimbProblem, scale: float, *, solver: str | None = None) -> ScaleCheck:
    """The robustness LP of every piece at ``scale`` (best radius), then the exact exclusion.

    Args:
        cp: the built climb (:func:`build_climb`), without obstacle.
        scale: the disturbance scale s >= 0 (V_s).
        solver: the LP back-end (default: the problem's).
    """
    solver = solver or cp.solver
    index, radius, u = _best_piece(cp, scale, solver=solver)
    if u is None:
        return ScaleCheck(float(scale), False, False, None, -math.inf, -1, ())
    exclusions = mode_exclusions(cp.problem, cp.mode, u, cp.robust_points(scale), systems=cp.systems,
                                 solver=solver)
    robust = not any(e.held for e in exclusions)
    return ScaleCheck(float(scale), True, robust, u, radius, index, exclusions)


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
    norms = _unit(H)
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
    index, _, _, u = _gentle_plan(cp, plan_scale)
    if u is None:
        plan_scale = lo
        index, _, _, u = _gentle_plan(cp, lo)
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


# ============================================================================ simulation
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
        status: the simulator's status (``"completed"`` or ``"failed"``).
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
    status: str
    slip_tolerance: float
    seed: int


def _sample_disturbances(points: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """Half the draws a random point of ``points``, half a random convex combination of them."""
    samples = []
    for k in range(count):
        if k % 2 == 0:
            samples.append(points[rng.integers(len(points))])
        else:
            samples.append(rng.dirichlet(np.ones(len(points))) @ points)
    return np.array(samples).reshape(count, points.shape[1])


def simulate_climb(
    scene: Scene,
    plan: ClimbPlan,
    *,
    duration: float = DEFAULT_DURATION,
    dt: float = 1e-3,
    hold: float = DEFAULT_HOLD,
    seed: int = 0,
    scale: float | None = None,
    slip_tolerance: float = BRACE_SLIP_TOLERANCE,
    progress: Callable[[float, float], None] | None = None,
) -> ClimbResult:
    """Simulate the planned torques with disturbances sampled from ``conv(V_s)`` (rigid contact).

    Args:
        scene: the planned scene.
        plan: a found plan.
        duration: [s] simulated time.
        dt: [s] time step.
        hold: [s] each sampled disturbance is held this long (zero-order hold).
        seed: the random generator's seed.
        scale: the disturbance scale (default: the plan's).
        slip_tolerance: [m] see :data:`BRACE_SLIP_TOLERANCE`.
        progress: called with (simulated time [s], duration [s]) after every step.

    Raises:
        InputError: the plan was not found, or a bad duration, step, hold, scale or seed.
    """
    s = _check_simulation_request(plan, duration, dt, hold, scale)
    seed = check_seed(seed)
    count = max(1, int(math.ceil(duration / hold)))
    samples = _sample_disturbances(plan.disturbances.robust_points(s), count, np.random.default_rng(seed))
    kin = _PointKinematics(scene, [(d.name, d.link, d.point_in_link) for d in plan.disturbances.items]
                           + [("head", plan.problem.task.head_link, plan.problem.task.head_point)])
    n = scene.robot.nv
    every = Inputs(scene.coordinate_names, tuple(range(n)), np.full(n, -np.inf), np.full(n, np.inf))
    stepper = RigidStepper(replace(scene, inputs=every), RigidSettings(max_ambiguity_checks=0))
    run = run_closed_loop(stepper, _disturbed_torques(scene, plan, kin, samples, hold), duration, dt,
                          progress=progress)
    return _brace_outcome(scene, plan, run.trajectory, kin, slip_tolerance,
                          disturbance_times=hold * np.arange(count), disturbance_samples=samples, seed=seed)


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


def _disturbed_torques(scene: Scene, plan: ClimbPlan, kin: _PointKinematics, samples: np.ndarray,
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


def _brace_outcome(scene: Scene, plan: ClimbPlan, trajectory: Trajectory, kin: _PointKinematics,
                   slip_tolerance: float, **record: Any) -> ClimbResult:
    """The brace's verdict on a run: slip, opening, load and events of the brace contacts; the rise.

    ``record``: the run's disturbance times, samples and seed, passed through.
    """
    brace = plan.problem.task.brace_contacts
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
    head = np.array([kin.positions(q)[-1] for q in trajectory.q])
    return ClimbResult(
        trajectory=trajectory, brace_held=held, max_slip=max_slip,
        max_opening=float(np.max(opening, initial=0.0)), upper_rise=float(head[-1, 1] - head[0, 1]),
        max_upper_rise=float(np.max(head[:, 1]) - head[0, 1]), duration=float(trajectory.duration),
        brace_events=events, status=trajectory.status, slip_tolerance=slip_tolerance, **record)


# ==================================================================== robust region (figures)
def robust_region(plan: ClimbPlan, index: int) -> Polytope:
    """The forces of one disturbance for which the plan's torques stay in their piece.

    With the head's acceleration >= a_min too, for every vertex of the other disturbances (at the
    plan's scale): a 2-D polytope over (fx, fy) of disturbance ``index``, bounded by the analysis
    box.
    """
    cp = plan.problem
    m_u = cp.m_u
    A, b, _ = _piece_rows(cp.pieces[plan.piece], m_u)
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
