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

Geometry (the reference)
------------------------
The snake is a chain of ``N + 1`` points ``p_0`` (tail) .. ``p_N`` (head) spaced by the link length
``L``, between walls at ``x_l`` and ``x_r`` (read from the brace contacts' surface lines). A *shape*
``(y, d, s_l, s_u)`` places the brace points on the walls: ``p_0``, ``p_4`` on the left wall at
heights ``y`` and ``y + 2 h_v`` (``h_v`` the lower V's half height, from the scene's state), ``p_2``
on the right one at ``y + h_v``, the upper brace's points ``p_6`` (right) at ``Y = y + 2 h_v + d``
and ``p_8`` (left) at ``Y + e`` (:data:`UPPER_SPAN`), each moved off its wall by the stand-off
``s_l`` (lower) or ``s_u`` (upper); the knees ``p_1, p_3, p_5, p_7`` close each pair of links
(:func:`knee`), the head points up at :data:`HEAD_ANGLE`. The configuration follows from the
points (``theta`` the angle of link 0, each joint the difference of its links' angles). A cycle
moves ``d`` from :data:`STROKE`'s upper end back to its lower end while ``y`` rises by the stroke
(the upper brace stays put), then ``d`` up again while ``y`` stays (the lower brace stays put):
the base rises by ``d_max - d_min`` per cycle. The first ``extend`` starts from the scene's state
and interpolates the free joints to the first extended shape.

Each segment of the reference moves the shape's parameters by a quintic in time (zero velocity and
acceleration at both ends); a contact that must close is aimed :data:`PRESS` beyond its wall, so
that it closes shortly before the segment ends, slowly (``~10^-2`` m/s).

Control (the robust LP along the motion)
----------------------------------------
Every control step, at the simulated state ``(q, v)``, the phase's mode (``F`` for every held
contact that touches, ``S`` for every releasing one that still touches) has the affine response
``x = X z + x_0`` over ``z = (u, d)`` (:func:`~frcontrol.planning.disturbances.augmented_problem`, the
disturbances as inputs) and the domain rows ``H z <= h`` (normalised). The torques solve::

    minimise   sum_i |ddq_i(u, 0) - ddq_ref,i|  +  W sigma
    subject to H (u, v_j) <= h - margin + sigma     for every vertex v_j of s P
               u within the torque limits, 0 <= sigma

with ``ddq_ref = a_ref + K_p (q_ref - q) + K_d (v_ref - v)`` (:data:`TRACKING_STIFFNESS`,
:data:`TRACKING_DAMPING`). The mode's rows use friction cones of ``FRICTION_SAFETY mu``
(:data:`FRICTION_SAFETY`). ``sigma`` is 0 whenever the mode can be held robustly at scale ``s``
with the margin: then, by convexity, every disturbance of ``s P`` keeps the held contacts loaded
inside their (reduced) friction cones and the opening ones opening. The largest ``sigma`` of a run
is reported (``max_deficit``). Contacts that have opened and are within :data:`GUARD_DISTANCE` of
their wall are *guarded* at the zero disturbance: their approach is limited so that they do not
strike the wall (:func:`_guard_rows`; held at every vertex, the guard left the motion no room).
A contact that carried force in the last step is in the mode whatever its gap.

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

The simulation (:func:`simulate_gait`) runs the rigid time stepper with the tracking LP's torques
plus disturbances ``J_d(q)^T d(t)``, ``d`` sampled in ``conv(V_s)`` (``s``: :data:`SIMULATION_SCALE`
unless given) and held for :data:`~frcontrol.planning.disturbances.DEFAULT_HOLD`. The reference of each
phase starts from the braces where they closed (:meth:`GaitGeometry.measure`). A brace *slips*
when a contact the controller holds (F) slides, over a phase, by more than
:data:`~frcontrol.planning.climb_check.BRACE_SLIP_TOLERANCE`: the slide sums ``|v_T+| h``, the sliding
velocity each step's friction law gave the contact (``v_T+ = J_T(q) v+``). Its displacement along
the wall (``max_drift``) is reported apart: it adds the time stepping's drift, first order in h.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import InputError, SceneError
from ..jsonable import finite_or_none, to_jsonable
from ..modes import add_scene_modes, build_mode_system
from ..response import solve_affine
from ..scene import Inputs, Scene
from ..scene_tables import TaskTable
from ..simulation.rigid import RigidSettings, RigidStepper
from ..solvers import DEFAULT_LP_SOLVER, RETRY_ERRORS, solve_lp
from . import DEFAULT_CLIMB_MARGIN
from .climb import ClimbPlan, plan_climb
from .climb_check import BRACE_SLIP_TOLERANCE
from .disturbances import (
    DEFAULT_HOLD,
    HOLD_INDEX_ROUNDOFF,
    DisturbanceSet,
    PointKinematics,
    augmented_problem,
    load_disturbances,
    sample_disturbances,
)
from .exclusions import mode_exclusions, mode_systems

__all__ = [
    "APPROACH_TIME",
    "DEFAULT_DT",
    "DWELL_TIME",
    "EXTEND_TIME",
    "FRICTION_SAFETY",
    "GUARD_DISTANCE",
    "GUARD_GAP",
    "GUARD_RATE",
    "HEAD_ANGLE",
    "PHASES",
    "PHASE_MIN_RISE_ACCELERATION",
    "PRESS",
    "RELEASE_TIME",
    "ROBUSTNESS_PENALTY",
    "SHAPE_FIELDS",
    "SIMULATION_SCALE",
    "STANDOFF",
    "STROKE",
    "TOUCH_GAP",
    "TRACKING_DAMPING",
    "TRACKING_MARGIN",
    "TRACKING_STIFFNESS",
    "UPPER_SPAN",
    "GaitGeometry",
    "GaitPlan",
    "GaitResult",
    "HandOver",
    "PhaseCertificate",
    "PhaseRun",
    "Reference",
    "Segment",
    "TrackingStep",
    "configuration_from_points",
    "gait_braces",
    "gait_geometry",
    "gait_payload",
    "knee",
    "phase_reference",
    "plan_gait",
    "points_from_configuration",
    "simulate_gait",
    "tracking_step",
]

PHASES = ("extend", "upper_brace", "pull", "lower_brace")
"""The four phases of a cycle, in order."""

STROKE = (0.06, 0.25)
"""[m] ``(d_min, d_max)``: the vertical distance between the lower brace's top point ``p_4`` and
the upper brace's first point ``p_6`` when contracted and extended. The base rises by
``d_max - d_min`` per cycle; ``d_max`` stays below the straight connector's
``sqrt((2L)^2 - w^2)`` (0.265 m on the snake)."""

UPPER_SPAN = 0.1
"""[m] Height of the upper brace's left point ``p_8`` above its right point ``p_6``: the squeeze
between them leans atan(0.1 / 0.3) = 18 deg from the horizontal, inside the friction cone (31 deg
at mu = 0.6)."""

HEAD_ANGLE = math.pi / 3
"""[rad] Angle of the head link (from ``p_8``) from the horizontal in the braced shapes."""

STANDOFF = 0.01
"""[m] How far a released brace point moves off its wall before the body moves."""

PRESS = 5e-4
"""[m] A closing contact is aimed this far beyond its wall (it then closes before the segment
ends, at about ``1.9 (STANDOFF + PRESS) / APPROACH_TIME * 0.2`` m/s)."""

RELEASE_TIME = 0.2
"""[s] Duration of a release segment (stand-off 0 -> :data:`STANDOFF`)."""

EXTEND_TIME = 0.8
"""[s] Duration of the stroke (extension or pull)."""

APPROACH_TIME = 0.3
"""[s] Duration of an approach segment (stand-off :data:`STANDOFF` -> ``-PRESS``)."""

DWELL_TIME = 0.1
"""[s] Time at rest after an approach, before the hand-over."""

TRACKING_STIFFNESS = 400.0
"""[1/s^2] K_p of the reference acceleration (a critically damped 20 rad/s loop)."""

TRACKING_DAMPING = 40.0
"""[1/s] K_d of the reference acceleration."""

DEFAULT_DT = 1e-3
"""[s] Time step of the gait's rigid simulation."""

ROBUSTNESS_PENALTY = 1e5
"""[-] Weight W of the robustness deficit sigma against the tracking error in the LP's cost."""

TOUCH_GAP = 1e-5
"""[m] A contact with a gap at most this takes part in the controller's mode."""

PHASE_MIN_RISE_ACCELERATION = 0.0
"""[m/s^2] The upward acceleration each phase's certificate (the climb's LP) requires of the
point the phase moves: the point must not fall."""

FIRST_VIA_STANDOFF = 0.05
"""[m] The first extension passes through a shape whose upper brace stands this far off the walls
(a straight move in joint space from the scene's state would push j8 through the left wall)."""

FIRST_VIA_DROP = 0.05
"""[m] ... and whose upper brace is this much lower than the extended one."""

TRACKING_MARGIN = DEFAULT_CLIMB_MARGIN
"""[N m or N] The robustness radius the tracking LP asks of every vertex (the distance, in the
lifted ``(u, d)`` space, rows normalised, from the mode's boundary)."""

FRICTION_SAFETY = 0.8
"""[-] The tracking LP holds the held contacts inside friction cones of ``FRICTION_SAFETY mu``: a
sticking contact at the edge of its true cone creeps in the time stepper (its discretisation), so
the LP keeps this much of the cone in reserve."""

GUARD_DISTANCE = 0.03
"""[m] An opened contact nearer its wall than this is guarded (its approach is limited)."""

GUARD_GAP = 0.002
"""[m] The gap the guard keeps an opened contact away from."""

GUARD_RATE = 20.0
"""[1/s] alpha of the guard: the gap's approach is critically damped at this rate."""

SIMULATION_SCALE = 0.02
"""[-] Default disturbance scale of the simulated gait (capped by the plan's scale). The phases'
certificates hold at rest up to their largest scales (about 9 on the snake), but along the motion
the disturbances push the open lower body about (the brace disturbance reaches 40 N at j3, twice the
snake's weight), and a lower contact then closes while still moving along its wall: at scale 0.1
the re-closing j2 contact slides up to 1.4 mm before it sticks (5 cycles, seed 0), at 0.3 the
upper brace slides too. At 0.02 every held contact stays within the slip tolerance."""

ROW_NORM_FLOOR = 1e-12
"""[-] A domain row whose norm over ``(u, d)`` is at most this does not depend on them: dropped."""

REFERENCE_STEP = 1e-4
"""[s] Step of the central differences that give the reference's velocity and acceleration."""


# ============================================================================ geometry
SHAPE_FIELDS = ("y0", "y2", "y4", "y6", "y8", "s_lower", "s_upper")
"""The shape's parameters [m]: the heights of the brace points p_0, p_2, p_4 (lower brace), p_6,
p_8 (upper brace), and the stand-offs of the lower and upper braces from their walls."""


def knee(start: np.ndarray, end: np.ndarray, length: float, side: float) -> np.ndarray:
    """The joint between two links of ``length`` [m] from ``start`` to ``end`` (points [m]).

    ``mid + side h n`` with ``n`` the chord's left normal and ``h = sqrt(length^2 - c^2 / 4)``
    (``c`` the chord's length, 0 when the links are straight); ``side`` is +1 or -1.
    """
    chord = end - start
    c = float(np.hypot(*chord))
    normal = np.array([-chord[1], chord[0]]) / c
    h = math.sqrt(max(length * length - 0.25 * c * c, 0.0))
    return 0.5 * (start + end) + side * h * normal


@dataclass(frozen=True)
class GaitGeometry:
    """The snake and its channel, as the gait's reference needs them.

    Attributes:
        link_length: L [m], every link's.
        left_wall: x [m] of the left wall; right_wall: of the right one.
        half_height: h_v [m], the lower V's height from the tail to its right point.
        knee_sides: ``(s_1, s_3)``, the sides of the lower V's knees (as in the scene).
    """

    link_length: float
    left_wall: float
    right_wall: float
    half_height: float
    knee_sides: tuple[float, float]

    def nominal(self, y: float, d: float, s_lower: float = 0.0, s_upper: float = 0.0) -> np.ndarray:
        """The shape (:data:`SHAPE_FIELDS`) with the tail at ``y`` and the connector's rise ``d`` [m]."""
        hv = self.half_height
        y6 = y + 2 * hv + d
        return np.array([y, y + hv, y + 2 * hv, y6, y6 + UPPER_SPAN, s_lower, s_upper])

    def points(self, shape: np.ndarray) -> np.ndarray:
        """The shape's points p_0 .. p_9 [m], shape (10, 2) (module docstring)."""
        L, xl, xr = self.link_length, self.left_wall, self.right_wall
        y0, y2, y4, y6, y8, s_lower, s_upper = (float(x) for x in shape)
        p0, p2, p4 = np.array([xl + s_lower, y0]), np.array([xr - s_lower, y2]), np.array([xl + s_lower, y4])
        p6, p8 = np.array([xr - s_upper, y6]), np.array([xl + s_upper, y8])
        p9 = p8 + L * np.array([math.cos(HEAD_ANGLE), math.sin(HEAD_ANGLE)])
        s1, s3 = self.knee_sides
        return np.array([p0, knee(p0, p2, L, s1), p2, knee(p2, p4, L, s3), p4, knee(p4, p6, L, 1.0),
                         p6, knee(p6, p8, L, -1.0), p8, p9])

    def configuration(self, shape: np.ndarray) -> np.ndarray:
        """The minimal configuration ``[x, y, theta, j1..j8]`` of a shape."""
        return configuration_from_points(self.points(shape))

    def measure(self, q: np.ndarray) -> np.ndarray:
        """The shape parameters of a configuration (the stand-offs those of p_0 and p_6)."""
        p = points_from_configuration(q, self.link_length)
        return np.array([p[0, 1], p[2, 1], p[4, 1], p[6, 1], p[8, 1], p[0, 0] - self.left_wall,
                         self.right_wall - p[6, 0]])


def configuration_from_points(points: np.ndarray) -> np.ndarray:
    """``[x, y, theta, j_1..]`` of a chain through ``points`` [m].

    theta is link 0's angle; each joint the difference of its links' angles, wrapped to [-pi, pi).
    """
    chords = np.diff(points, axis=0)
    angles = np.arctan2(chords[:, 1], chords[:, 0])
    joints = (np.diff(angles) + math.pi) % (2 * math.pi) - math.pi
    return np.concatenate([points[0], [angles[0]], joints])


def points_from_configuration(q: np.ndarray, link_length: float) -> np.ndarray:
    """The chain's points [m] at ``q`` (the inverse of :func:`configuration_from_points`)."""
    angles = q[2] + np.concatenate([[0.0], np.cumsum(q[3:])])
    steps = link_length * np.column_stack([np.cos(angles), np.sin(angles)])
    return np.vstack([q[:2], q[:2] + np.cumsum(steps, axis=0)])


def gait_geometry(scene: Scene, lower: Sequence[str]) -> GaitGeometry:
    """The geometry of the snake and the channel at the scene's state.

    Raises:
        SceneError: the robot is not a planar chain of 9 equal links whose lower brace touches the
            left, right and left walls at p_0, p_2, p_4.
    """
    path = str(scene.path)
    q = scene.q
    links = [name for name in scene.robot.link_names if name.startswith("link")]
    if scene.robot.nv != 11 or len(links) != 9:
        raise SceneError(path, "robot", "the gait is built for a planar snake of 9 links (11 coordinates), "
                         f"got {scene.robot.nv} coordinates")
    kin = PointKinematics(scene, [(name, name, np.zeros(2)) for name in links])
    lengths = np.hypot(*np.diff(kin.positions(q), axis=0).T)
    L = float(lengths[0])
    if not np.allclose(lengths, L, rtol=1e-6):
        raise SceneError(path, "robot", "the gait needs a chain of 9 links of equal length")
    by_name = {c.name: c for c in scene.contacts}
    walls = [float(by_name[n].point.surface_point_in_world[0]) for n in lower]
    points = points_from_configuration(q, L)
    if len(walls) != 3 or not np.allclose(points[[0, 2, 4], 0], walls, atol=1e-6) or walls[0] >= walls[1]:
        raise SceneError(path, "task.brace_contacts", "the gait needs the lower brace at the tail, j2 and "
                         "j4 (p_0, p_2, p_4) against the left, right and left walls")
    sides = []
    for i in (1, 3):
        a, b = points[i - 1], points[i + 1]
        cross = (b - a)[0] * (points[i] - a)[1] - (b - a)[1] * (points[i] - a)[0]
        sides.append(1.0 if cross >= 0 else -1.0)
    return GaitGeometry(L, walls[0], walls[1], float(points[2, 1] - points[0, 1]), (sides[0], sides[1]))


# ============================================================================ reference
@dataclass(frozen=True)
class Segment:
    """One quintic move of the reference.

    Attributes:
        duration: [s].
        start: the shape (:data:`SHAPE_FIELDS`, 7 values) at the start, or a configuration (11
            values) for a move in joint space; end: the same at the end.
    """

    duration: float
    start: np.ndarray
    end: np.ndarray

    def configuration(self, geometry: GaitGeometry, t: float) -> np.ndarray:
        """The reference configuration at ``t`` [s] from the segment's start (clamped)."""
        tau = min(max(t / self.duration, 0.0), 1.0) if self.duration > 0 else 1.0
        blend = tau ** 3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)
        x = self.start + blend * (self.end - self.start)
        return geometry.configuration(x) if x.size == len(SHAPE_FIELDS) else x


@dataclass(frozen=True)
class Reference:
    """The reference of one phase: its segments in a row."""

    geometry: GaitGeometry
    segments: tuple[Segment, ...]

    @property
    def duration(self) -> float:
        """[s] The phase's planned duration."""
        return float(sum(s.duration for s in self.segments))

    @property
    def end_shape(self) -> np.ndarray:
        """The shape at the end."""
        return self.segments[-1].end

    def configuration(self, t: float) -> np.ndarray:
        """The reference configuration at ``t`` [s] from the phase's start."""
        for segment in self.segments:
            if t <= segment.duration:
                return segment.configuration(self.geometry, t)
            t -= segment.duration
        return self.segments[-1].configuration(self.geometry, self.segments[-1].duration)

    def state(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q, v, a)`` of the reference at ``t`` (central differences of :data:`REFERENCE_STEP`)."""
        h = REFERENCE_STEP
        q = self.configuration(t)
        before, after = self.configuration(t - h), self.configuration(t + h)
        return q, (after - before) / (2 * h), (after - 2 * q + before) / (h * h)


def _with(shape: np.ndarray, **values: float) -> np.ndarray:
    out = np.array(shape, dtype=float)
    for key, value in values.items():
        out[SHAPE_FIELDS.index(key)] = value
    return out


def phase_reference(name: str, geometry: GaitGeometry, shape: np.ndarray,
                    q_start: np.ndarray | None = None) -> Reference:
    """The reference of phase ``name`` from ``shape`` (the braces where they are).

    ``q_start``: for the first extension, the scene's configuration (a move in joint space through
    a via shape held :data:`FIRST_VIA_STANDOFF` off the walls, then to the extended shape).
    """
    d_min, d_max = STROKE
    hv = geometry.half_height
    s, p = STANDOFF, -PRESS
    if name == "extend":
        y6 = shape[2] + d_max
        target = _with(shape, y6=y6, y8=y6 + UPPER_SPAN, s_upper=s)
        if q_start is not None:
            low = y6 - FIRST_VIA_DROP
            via = geometry.configuration(_with(target, y6=low, y8=low + UPPER_SPAN,
                                               s_upper=FIRST_VIA_STANDOFF))
            half = 0.5 * (RELEASE_TIME + EXTEND_TIME)
            return Reference(geometry, (Segment(half, np.asarray(q_start), via),
                                        Segment(half, via, geometry.configuration(target)),
                                        Segment(0.0, target, target)))
        released = _with(shape, s_upper=s)
        return Reference(geometry, (Segment(RELEASE_TIME, shape, released),
                                    Segment(EXTEND_TIME, released, target)))
    if name == "pull":
        released = _with(shape, s_lower=s)
        y4 = shape[3] - d_min
        target = _with(released, y0=y4 - 2 * hv, y2=y4 - hv, y4=y4)
        return Reference(geometry, (Segment(RELEASE_TIME, shape, released),
                                    Segment(EXTEND_TIME, released, target)))
    key = "s_upper" if name == "upper_brace" else "s_lower"
    pressed = _with(shape, **{key: p})
    return Reference(geometry, (Segment(APPROACH_TIME, shape, pressed),
                                Segment(DWELL_TIME, pressed, pressed)))


# ============================================================================ control
@dataclass(frozen=True)
class TrackingStep:
    """One solution of the tracking LP.

    Attributes:
        torques: u [N m] in the scene's input order.
        mode: the letters of the contacts in the mode (``contacts``), e.g. ``"FFFS"``.
        contacts: the contacts in the mode.
        deficit: sigma [N m or N], 0 when the mode holds robustly with the margin.
        tracking_error: [rad/s^2 or m/s^2] ``sum |ddq(u, 0) - ddq_ref|``.
    """

    torques: np.ndarray
    mode: str
    contacts: tuple[str, ...]
    deficit: float
    tracking_error: float


def tracking_step(scene: Scene, disturbances: DisturbanceSet, q: np.ndarray, v: np.ndarray,
                  held: Sequence[str], released: Sequence[str], desired: np.ndarray, points: np.ndarray,
                  margin: float, solver: str = DEFAULT_LP_SOLVER, loaded: Sequence[str] = ()) -> TrackingStep:
    """The tracking LP at ``(q, v)`` (module docstring): torques holding the phase's mode robustly.

    Args:
        scene: the gait's scene.
        disturbances: the polytope P.
        q: the configuration.
        v: the velocity.
        held: contacts in mode F (those that touch).
        released: contacts in S (those that touch).
        desired: ddq_ref (n,).
        points: the vertices V_s of the disturbances (N, dim).
        margin: [N m or N] the robustness radius asked of every vertex.
        solver: the LP back-end.
        loaded: contacts that carried force in the last step: in the mode whatever their gap (a
            loaded contact drifts off its wall by a few micrometres in a time step).
    """
    at = scene.at(q, v)
    chosen = [i for i, c in enumerate(at.contacts)
              if (c.name in held or c.name in released) and (c.gap <= TOUCH_GAP or c.name in loaded)]
    local = replace(at, contacts=tuple(replace(c, active=i in chosen) for i, c in enumerate(at.contacts)))
    contacts = local.active_contacts
    problem = augmented_problem(local, disturbances)
    problem = replace(problem, mu=FRICTION_SAFETY * problem.mu)
    mode = "".join("F" if c.name in held else "S" for c in contacts)
    m_u, n = scene.inputs.count, scene.robot.nv
    X, x0, H, h = _mode_rows(problem, mode)
    opened = [c.name for c in at.contacts if c.name in released and c.name not in {k.name for k in contacts}]
    guard = _unit_rows(*_guard_rows(local, X[:n], x0[:n], opened))
    H, h = _unit_rows(H, h)
    # variables (u, e, sigma): the mode's rows at every vertex, the guard's at the zero disturbance
    nvar = m_u + n + 1
    rows, rhs = [], []
    for (A, b), vertices in (((H, h), points), (guard, np.zeros((1, points.shape[1])))):
        for point in vertices:
            block = np.zeros((A.shape[0], nvar))
            block[:, :m_u] = A[:, :m_u]
            block[:, -1] = -1.0
            rows.append(block)
            rhs.append(b - A[:, m_u:] @ point - margin)
    Xq, a0 = X[:n, :m_u], x0[:n] - desired
    for sign in (1.0, -1.0):
        block = np.zeros((n, nvar))
        block[:, :m_u] = sign * Xq
        block[:, m_u:m_u + n] = -np.eye(n)
        rows.append(block)
        rhs.append(-sign * a0)
    cost = np.concatenate([np.zeros(m_u), np.ones(n), [ROBUSTNESS_PENALTY]])
    lb = np.concatenate([scene.inputs.lower, np.zeros(n + 1)])
    ub = np.concatenate([scene.inputs.upper, np.full(n + 1, np.inf)])
    result = solve_lp(cost, np.vstack(rows), np.concatenate(rhs), None, None, lb, ub, solver=solver,
                      fallback=RETRY_ERRORS)
    if not result.found or result.x is None:
        raise InputError(f"the gait's tracking LP found no torques in mode {mode}: {result.status}")
    u = result.x[:m_u]
    return TrackingStep(u, mode, tuple(c.name for c in contacts), float(result.x[-1]),
                        float(np.sum(result.x[m_u:m_u + n])))


def _mode_rows(problem: Any, mode: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(X, x_0, H, h)``: the mode's response ``x = X z + x_0`` and its domain rows ``H z <= h``."""
    if not mode:
        X = np.linalg.solve(problem.mass_matrix, problem.input_map)
        return X, -np.linalg.solve(problem.mass_matrix, problem.bias), np.zeros((0, problem.m)), np.zeros(0)
    system = build_mode_system(problem, mode)
    response = solve_affine(system.A, system.B, system.c, name=f"the system of mode {mode}")
    X, x0 = response.X_u, response.x_0
    return X, x0, system.G @ X, system.g - system.G @ x0


def _unit_rows(H: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows ``H z <= h`` with unit norms (rows that do not depend on z dropped)."""
    norms = np.sqrt(np.sum(H * H, axis=1))
    keep = norms > ROW_NORM_FLOOR
    return H[keep] / norms[keep, None], h[keep] / norms[keep]


def _guard_rows(scene: Scene, X: np.ndarray, x0: np.ndarray, names: Sequence[str]
                ) -> tuple[np.ndarray, np.ndarray]:
    """Rows ``A z <= b`` keeping opened contacts off their walls (module docstring, "Control").

    For each contact of ``names`` within :data:`GUARD_DISTANCE` of its wall, its normal
    acceleration ``a_N(z) = J_N (X z + x_0) + drift`` is kept above
    ``-2 alpha v_N - alpha^2 (gap - GUARD_GAP)`` (``alpha`` = :data:`GUARD_RATE`).
    """
    index = [i for i, c in enumerate(scene.contacts) if c.name in names and c.gap <= GUARD_DISTANCE]
    if not index:
        return np.zeros((0, X.shape[1])), np.zeros(0)
    state = scene.robot.state(scene.q, scene.v, index)
    gaps = np.array([scene.contacts[i].gap for i in index])
    alpha = GUARD_RATE
    floor = -2.0 * alpha * state.normal_velocities - alpha * alpha * (gaps - GUARD_GAP)
    A = -state.jacobian_normal @ X
    b = state.jacobian_normal @ x0 + state.drift_normal - floor
    return A, b


# ============================================================================ the plan
PHASE_ROLES = {
    "extend": ("lower", "upper", ""),
    "upper_brace": ("lower", "", "upper"),
    "pull": ("upper", "lower", ""),
    "lower_brace": ("upper", "", "lower"),
}
"""Per phase: which brace is held (F), which opens (S while it touches), which closes."""

HAND_OVERS = (("upper_brace", "pull"), ("lower_brace", "extend"))
"""The hand-overs between braces: (the phase that closes a brace, the phase that opens the other)."""


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


@dataclass(frozen=True)
class HandOver:
    """The ambiguity check at a hand-over (module docstring, "Certificates").

    Attributes:
        name: ``"<phase>-><phase>"``; cycle: the cycle of the first phase.
        q: the planned configuration (both braces touching, at rest).
        mode: the next phase's mode over ``contacts`` (F held, S opening).
        contacts: the touching contacts.
        torques: [N m] the tracking LP's torques there.
        deficit: [N m or N] its robustness deficit (0: the mode holds with the margin).
        modes_checked: how many other modes were checked.
        held_modes: the other modes that hold for some disturbance of ``conv(V_s)``.
        slip_modes: those of them in which a brace contact slides (L or R).
    """

    name: str
    cycle: int
    q: np.ndarray
    mode: str
    contacts: tuple[str, ...]
    torques: np.ndarray
    deficit: float
    modes_checked: int
    held_modes: tuple[str, ...]
    slip_modes: tuple[str, ...]

    @property
    def unambiguous(self) -> bool:
        """No mode in which a brace contact slides holds anywhere on the robust set."""
        return not self.slip_modes

    def to_dict(self, inputs: Sequence[str]) -> dict[str, Any]:
        """The check as JSON."""
        return {"name": self.name, "cycle": self.cycle, "q": self.q, "contacts": list(self.contacts),
                "mode": self.mode,
                "torques": dict(zip(inputs, self.torques.tolist(), strict=True)), "deficit": self.deficit,
                "modes_checked": self.modes_checked, "held_modes": list(self.held_modes),
                "slip_modes": list(self.slip_modes), "unambiguous": self.unambiguous}


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
    """The lower brace (``[task] brace_contacts``, the active contacts) and the upper one.

    Raises:
        SceneError: no ``[task] upper_brace_contacts``, an unknown one, one that touches at the
            scene's state, or not two of them (right wall, then left wall).
    """
    from .climb_problem import load_climb_task

    path = str(scene.path)
    lower = load_climb_task(scene).brace_contacts
    gait = scene.raw.get("task", {}).get("gait")
    upper = scene.task.upper_brace_contacts if gait is None else tuple(gait["upper_brace"])
    if upper is None:
        raise SceneError(path, "task.upper_brace_contacts", "missing: the gait (--cycles) needs the upper "
                         "brace's contacts, separated at the scene's state")
    by_name = {c.name: c for c in scene.contacts}
    for i, name in enumerate(upper):
        if name not in by_name:
            raise SceneError(path, f"task.upper_brace_contacts[{i}]", f"unknown contact {name!r}; the "
                             f"contacts are: {', '.join(by_name)}")
        if by_name[name].active:
            raise SceneError(path, f"task.upper_brace_contacts[{i}]", f"contact {name!r} touches at the "
                             "scene's state: the upper brace must be separated at the start")
    if len(upper) != 2:
        raise SceneError(path, "task.upper_brace_contacts", f"expected two contacts (j6 on the right wall, "
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
) -> GaitPlan:
    """Plan the gait: each phase's certificate, each hand-over's check, the run's scale.

    The channel is the same at every height, so the phases of cycles 2.. are cycle 2's problems
    shifted up: each distinct problem is planned once (the first extension starts from the scene's
    state and is its own).

    Raises:
        InputError: a bad number of cycles or margin.
        SceneError: bad ``[task]`` or ``[[disturbances]]`` tables, or a robot or scene the gait is
            not built for (:func:`gait_geometry`, :func:`gait_braces`).
    """
    start = time.perf_counter()
    _check_cycles(cycles)
    lower, upper = gait_braces(scene)
    geometry = gait_geometry(scene, lower)
    dist = load_disturbances(scene)
    by_name = {c.name: c.point for c in scene.contacts}
    movers = {"lower": (by_name[lower[0]].link, by_name[lower[0]].point_in_link),
              "upper": (by_name[upper[0]].link, by_name[upper[0]].point_in_link)}
    braces = {"lower": lower, "upper": upper, "": ()}
    done: dict[tuple[str, bool], ClimbPlan] = {}
    phases = []
    for name, cycle, q in _phase_starts(geometry, scene, cycles):
        held, released, closing = (braces[r] for r in PHASE_ROLES[name])
        mover = movers["upper" if name in ("extend", "upper_brace") else "lower"]
        key = (name, name == "extend" and cycle == 1)
        if key not in done:
            done[key] = plan_climb(_phase_scene(scene, q, held, mover), margin=margin, solver=solver)
        phases.append(PhaseCertificate(name, cycle, held, released, closing, mover, q, done[key]))
    timings = {"phases": time.perf_counter() - start}
    scale = min(1.0, min(p.scale for p in phases))
    t0 = time.perf_counter()
    hand_overs = _hand_overs(scene, geometry, dist, lower, upper, cycles, scale, margin, solver)
    timings["hand_overs"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - start
    return GaitPlan(scene, geometry, cycles, lower, upper, tuple(phases), hand_overs, scale, float(margin),
                    dist, solver, timings)


def _hand_overs(scene: Scene, geometry: GaitGeometry, dist: DisturbanceSet, lower: tuple[str, ...],
                upper: tuple[str, ...], cycles: int, scale: float, margin: float, solver: str
                ) -> tuple[HandOver, ...]:
    """The hand-overs' checks (module docstring), each distinct one computed once."""
    d_min, d_max = STROKE
    rise = d_max - d_min
    points = dist.robust_points(scale)
    checks: dict[str, HandOver] = {}
    out = []
    for c in range(cycles):
        for first, second in HAND_OVERS:
            if second == "extend" and c == cycles - 1:
                continue
            y = c * rise + (rise if second == "extend" else 0.0)
            name = f"{first}->{second}"
            if name not in checks:
                shape = geometry.nominal(y, d_max if second == "pull" else d_min)
                held, released, _ = ((lower if r == "lower" else upper if r == "upper" else ())
                                     for r in PHASE_ROLES[second])
                checks[name] = _check_hand_over(scene, dist, geometry.configuration(shape), held, released,
                                                points, margin, solver, name)
            out.append(replace(checks[name], cycle=c + 1, q=checks[name].q + np.array([0.0, y] + [0.0] * 9)))
    return tuple(out)


def _check_hand_over(scene: Scene, dist: DisturbanceSet, q: np.ndarray, held: Sequence[str],
                     released: Sequence[str], points: np.ndarray, margin: float, solver: str,
                     name: str) -> HandOver:
    """Torques of the next phase at the hand-over (at rest), then every other mode's exclusion."""
    n = scene.robot.nv
    rest = np.zeros(n)
    step = tracking_step(scene, dist, q, rest, held, released, rest, points, TRACKING_MARGIN, solver)
    at = scene.at(q, np.zeros(n))
    touching = tuple(replace(c, active=c.name in step.contacts) for c in at.contacts)
    problem = augmented_problem(replace(at, contacts=touching), dist, np.minimum(0.0, points.min(axis=0)),
                                np.maximum(0.0, points.max(axis=0)))
    systems = mode_systems(problem)
    exclusions = mode_exclusions(problem, step.mode, step.torques, points, systems=systems, solver=solver,
                                 confirm=True)
    brace = set(held) | set(released)
    held_modes = tuple(e.mode for e in exclusions if e.held)
    slip = tuple(m for m in held_modes if any(letter in "LR" and contact in brace
                                              for letter, contact in zip(m, step.contacts, strict=True)))
    q0 = q - np.array([0.0, q[1]] + [0.0] * (n - 2))
    return HandOver(name, 0, q0, step.mode, step.contacts, step.torques, step.deficit, len(exclusions),
                    held_modes, slip)


# ============================================================================ simulation
@dataclass(frozen=True)
class PhaseRun:
    """One phase of the simulated gait.

    Attributes:
        name: the phase; cycle: its cycle (1-based).
        start, end: [s] its times; start_index, end_index: its samples.
        max_deficit: [N m or N] the tracking LP's largest robustness deficit in the phase.
        max_slip: [m] the largest slide of a held contact while held (``sum |v_T+| h``).
        slips: [m] each held contact's slide.
        max_drift: [m] the largest displacement of a held contact along its wall while held.
        max_tracking_error: [m or rad] the largest |q_ref - q|.
        base_height: [m] the base's height (the tail's y) at the end.
        closed: the closing contacts that touch at the end.
    """

    name: str
    cycle: int
    start: float
    end: float
    start_index: int
    end_index: int
    max_deficit: float
    max_slip: float
    slips: Mapping[str, float]
    max_drift: float
    max_tracking_error: float
    base_height: float
    closed: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        """The phase's run as JSON."""
        return {"name": self.name, "cycle": self.cycle, "start": self.start, "end": self.end,
                "start_index": self.start_index, "end_index": self.end_index, "max_deficit": self.max_deficit,
                "max_slip": self.max_slip, "slips": dict(self.slips), "max_drift": self.max_drift,
                "max_tracking_error": self.max_tracking_error,
                "base_height": self.base_height, "closed": list(self.closed)}


@dataclass(frozen=True, eq=False)
class GaitResult:
    """The gait in the rigid simulation.

    Attributes:
        trajectory: the run (its inputs: the generalized forces ``S^T u + J_d^T d`` on every coordinate).
        torques: [N m] the torques of every step, shape (T - 1, m).
        modes: the controller's mode of every step (letters of ``mode_contacts``).
        mode_contacts: the contacts of each step's mode.
        phase_of_step: the index into ``phases`` of every step.
        deficits: [N m or N] the tracking LP's robustness deficit sigma of every step.
        phases: every phase's record.
        heights: [m] the base's height at the end of each cycle; rise: the last minus the start.
        brace_held: no held contact slid by more than ``slip_tolerance`` while held, and the run completed.
        max_slip: [m] the largest such slide (``sum |v_T+| h`` while held, ``v_T+`` each step's
            sliding velocity).
        max_drift: [m] the largest displacement of a held contact along its wall while held.
        max_deficit: [N m or N] the largest robustness deficit of the run.
        scale: the disturbance scale sampled; seed: the sampler's seed.
        disturbance_times: [s] start of each held sample; disturbance_samples: [N] (K, dim).
        slip_tolerance: [m]; dt: [s] the step.
        timings: [s].
    """

    trajectory: Any
    torques: np.ndarray
    modes: tuple[str, ...]
    mode_contacts: tuple[tuple[str, ...], ...]
    phase_of_step: np.ndarray
    deficits: np.ndarray
    phases: tuple[PhaseRun, ...]
    heights: tuple[float, ...]
    rise: float
    brace_held: bool
    max_slip: float
    max_drift: float
    max_deficit: float
    scale: float
    seed: int
    disturbance_times: np.ndarray
    disturbance_samples: np.ndarray
    slip_tolerance: float
    dt: float
    timings: Mapping[str, float] = field(default_factory=dict)


class _Run:
    """The closed loop of :func:`simulate_gait`: a stepper, the disturbance samples and the records."""

    def __init__(self, plan: GaitPlan, dt: float, scale: float, seed: int) -> None:
        scene = plan.scene
        n = scene.robot.nv
        every = Inputs(scene.coordinate_names, tuple(range(n)), np.full(n, -np.inf), np.full(n, np.inf))
        self.plan, self.dt, self.scene = plan, dt, scene
        self.stepper = RigidStepper(replace(scene, inputs=every), RigidSettings(max_ambiguity_checks=0))
        self.points = plan.disturbances.robust_points(scale)
        self.kin = PointKinematics(scene, [(d.name, d.link, d.point_in_link)
                                            for d in plan.disturbances.items])
        self.rng = np.random.default_rng(seed)
        self.samples: list[np.ndarray] = []
        self.torque_map = scene.inputs.selection_transpose(n)
        self.torques: list[np.ndarray] = []
        self.modes: list[tuple[str, tuple[str, ...]]] = []
        self.phase_of_step: list[int] = []
        self.deficits: list[float] = []
        self.wall = {c.name: (c.point.normal_in_world, c.point.tangent_in_world) for c in scene.contacts}

    def disturbance(self) -> np.ndarray:
        """The held sample at the stepper's time (drawn as the holds start)."""
        k = int(self.stepper.t / DEFAULT_HOLD + HOLD_INDEX_ROUNDOFF)
        while len(self.samples) <= k:
            self.samples.append(sample_disturbances(self.points, 1, self.rng)[0])
        return self.samples[k]

    def phase(self, index: int, name: str, cycle: int, reference: Reference, roles: tuple) -> PhaseRun | None:
        """Run one phase; None when the stepper failed."""
        held, released, closing = roles
        st = self.stepper
        start, start_index = st.t, len(self.torques)
        anchors: dict[str, np.ndarray] = {}
        slid: dict[str, dict[str, float]] = {}
        worst = {"deficit": 0.0, "slip": 0.0, "drift": 0.0, "error": 0.0}
        steps = max(1, int(round(reference.duration / self.dt)))
        for k in range(steps):
            q_ref, v_ref, a_ref = reference.state(k * self.dt)
            desired = a_ref + TRACKING_STIFFNESS * (q_ref - st.q) + TRACKING_DAMPING * (v_ref - st.v)
            loaded = [name for name, force in zip(st.names, st.last_forces[:, 0], strict=True) if force > 0]
            step = tracking_step(self.scene, self.plan.disturbances, st.q, st.v, held + closing, released,
                                 desired, self.points, TRACKING_MARGIN, self.plan.solver, loaded)
            jac, _, _ = self.kin.evaluate(st.q, st.v)
            force = self.torque_map @ step.torques + jac[:self.plan.disturbances.dim].T @ self.disturbance()
            tangent_rows = st.state.jacobian_tangent.copy()
            if not st.step(force, self.dt):
                return None
            self.torques.append(step.torques)
            self.modes.append((step.mode, step.contacts))
            self.deficits.append(step.deficit)
            self.phase_of_step.append(index)
            worst["deficit"] = max(worst["deficit"], step.deficit)
            worst["error"] = max(worst["error"], float(np.max(np.abs(q_ref - st.q))))
            fixed = [c for letter, c in zip(step.mode, step.contacts, strict=True) if letter == "F"]
            slip, drift = self._slip(slid, anchors, fixed, tangent_rows @ st.v)
            worst["slip"], worst["drift"] = max(worst["slip"], slip), max(worst["drift"], drift)
        touching = {c.name for c in self.scene.at(st.q).contacts if c.gap <= TOUCH_GAP}
        return PhaseRun(name, cycle, start, st.t, start_index, len(self.torques), worst["deficit"],
                        worst["slip"], {k: r["slip"] for k, r in slid.items()}, worst["drift"],
                        worst["error"], float(st.q[1]),
                        tuple(c for c in closing if c in touching))

    def _slip(self, record: dict[str, dict[str, float]], anchors: dict[str, np.ndarray],
              held: Sequence[str], sliding: np.ndarray) -> tuple[float, float]:
        """``(slip, drift)`` [m] of the held contacts so far in the phase (the largest of each).

        The slip of a contact sums ``|v_T+| h`` over the steps it touches while held, with ``v_T+ =
        J_T(q) v+`` the step's own sliding velocity (``sliding``, per contact: the velocity the
        time stepper's friction law sets); its drift is its displacement along the wall from where
        it was first held: the slip plus the time stepping's drift (``q+ = q + h v+`` keeps the
        contact still to first order in h only).
        """
        st = self.stepper
        slip, drift = 0.0, 0.0
        for name in held:
            i = st.names.index(name)
            _, tangent = self.wall[name]
            point = st.state.contact_points[i]
            anchor = anchors.setdefault(name, point.copy())
            slid = record.setdefault(name, {"slip": 0.0})
            slid["slip"] += abs(float(sliding[i])) * self.dt
            slip = max(slip, slid["slip"])
            drift = max(drift, abs(float(tangent @ (point - anchor))))
        return slip, drift



def simulate_gait(
    plan: GaitPlan,
    *,
    dt: float = DEFAULT_DT,
    seed: int = 0,
    scale: float | None = None,
    slip_tolerance: float = BRACE_SLIP_TOLERANCE,
    progress: Callable[[int, int], None] | None = None,
) -> GaitResult:
    """Run the planned gait in the rigid simulation under sampled disturbances (module docstring).

    Args:
        plan: the planned gait.
        dt: [s] the time step (the tracking LP is solved every step).
        seed: the disturbance sampler's seed.
        scale: the disturbance scale (default: :data:`SIMULATION_SCALE`, at most the plan's).
        slip_tolerance: [m] see :data:`~frcontrol.planning.climb_check.BRACE_SLIP_TOLERANCE`.
        progress: called with (phases done, phases) after each phase.

    Raises:
        InputError: a bad step, scale or tolerance.
    """
    if not (isinstance(dt, (int, float)) and math.isfinite(dt) and 0 < dt <= 0.01):
        raise InputError(f"dt must be a number in (0, 0.01] [s], got {dt!r}")
    s = min(plan.scale, SIMULATION_SCALE) if scale is None else scale
    if not (isinstance(s, (int, float)) and math.isfinite(s) and s >= 0):
        raise InputError(f"scale must be a finite number >= 0, got {scale!r}")
    if not (isinstance(slip_tolerance, (int, float)) and slip_tolerance > 0):
        raise InputError(f"slip_tolerance must be > 0 [m], got {slip_tolerance!r}")
    start = time.perf_counter()
    run = _Run(plan, float(dt), float(s), seed)
    braces = {"lower": plan.lower, "upper": plan.upper, "": ()}
    records: list[PhaseRun] = []
    for index, phase in enumerate(plan.phases):
        first = index == 0
        reference = phase_reference(phase.name, plan.geometry, plan.geometry.measure(run.stepper.q),
                                    plan.scene.q if first else None)
        roles = tuple(braces[r] for r in PHASE_ROLES[phase.name])
        record = run.phase(index, phase.name, phase.cycle, reference, roles)
        if progress is not None:
            progress(index + 1, len(plan.phases))
        if record is None:
            break
        records.append(record)
    trajectory = run.stepper.trajectory(float(dt))
    heights = tuple(r.base_height for r in records if r.name == "lower_brace")
    max_slip = max((r.max_slip for r in records), default=0.0)
    complete = trajectory.completed and len(records) == len(plan.phases)
    return GaitResult(
        trajectory=trajectory, torques=np.array(run.torques).reshape(-1, plan.scene.inputs.count),
        modes=tuple(m for m, _ in run.modes), mode_contacts=tuple(c for _, c in run.modes),
        phase_of_step=np.array(run.phase_of_step, dtype=int), deficits=np.array(run.deficits),
        phases=tuple(records), heights=heights, rise=float(trajectory.q[-1, 1] - trajectory.q[0, 1]),
        brace_held=bool(complete and max_slip <= slip_tolerance), max_slip=max_slip,
        max_drift=max((r.max_drift for r in records), default=0.0),
        max_deficit=max((r.max_deficit for r in records), default=0.0), scale=float(s), seed=seed,
        disturbance_times=DEFAULT_HOLD * np.arange(len(run.samples)),
        disturbance_samples=np.array(run.samples).reshape(-1, plan.disturbances.dim),
        slip_tolerance=float(slip_tolerance), dt=float(dt),
        timings={"simulation": time.perf_counter() - start})


def gait_payload(plan: GaitPlan, result: GaitResult | None) -> dict[str, Any]:
    """The ``frc climb --cycles N --json`` document.

    ``cycles``, ``heights`` (the base's height at the end of each cycle [m]), ``phases`` (each
    with its ``max_disturbance_scale``), ``weakest_phase``, ``hand_overs`` and ``simulation``
    (``samples`` as ``frc simulate --json``'s: ``times``, ``q``, ``v``...; plus each step's
    ``torques``, ``phase``, ``mode`` and ``mode_contacts``) are the contract; the rest reports how.
    """
    scene = plan.scene
    weakest = plan.weakest
    payload: dict[str, Any] = {
        "found": True,
        "cycles": plan.cycles,
        "lower_brace": list(plan.lower),
        "upper_brace": list(plan.upper),
        "scale": plan.scale,
        "margin": plan.margin,
        "weakest_phase": {"name": weakest.name, "cycle": weakest.cycle,
                          "max_disturbance_scale": weakest.scale},
        "phases": [p.to_dict() for p in plan.phases],
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
        "solver": plan.solver,
        "heights": [],
        "simulation": None,
        "timings": dict(plan.timings),
    }
    if result is not None:
        payload.update(_result_payload(plan, result))
    return add_scene_modes(to_jsonable(payload), [c.name for c in scene.contacts])


def _result_payload(plan: GaitPlan, result: GaitResult) -> dict[str, Any]:
    """The simulation's part of :func:`gait_payload`."""
    trajectory = result.trajectory
    samples = trajectory.to_dict(plan.scene)["samples"]
    samples.update({"torques": result.torques, "phase": result.phase_of_step,
                    "controller_mode": list(result.modes),
                    "mode_contacts": [list(c) for c in result.mode_contacts], "deficit": result.deficits})
    start = float(trajectory.q[0, 1])
    heights = [h - start for h in result.heights]
    return {
        "heights": heights,
        "rise_per_cycle": np.diff(np.concatenate([[0.0], heights])).tolist(),
        "phase_runs": [r.to_dict() for r in result.phases],
        "simulation": {
            "samples": samples, "rise": result.rise, "brace_held": result.brace_held,
            "max_slip": result.max_slip, "max_drift": result.max_drift,
            "max_deficit": result.max_deficit, "scale": result.scale, "seed": result.seed, "dt": result.dt,
            "status": trajectory.status, "slip_tolerance": result.slip_tolerance,
            "phases_completed": len(result.phases),
            "disturbance_times": result.disturbance_times, "disturbance_samples": result.disturbance_samples,
            "events": [e.to_dict() for e in trajectory.events],
            "timings": dict(result.timings),
        },
    }
