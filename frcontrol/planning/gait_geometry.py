r"""The climbing gait's geometry and reference (:mod:`frcontrol.planning.gait`).

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
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..scene import Scene
from .disturbances import (
    PointKinematics,
)

__all__ = [
    "APPROACH_TIME",
    "DWELL_TIME",
    "EXTEND_TIME",
    "FIRST_VIA_DROP",
    "FIRST_VIA_STANDOFF",
    "HEAD_ANGLE",
    "PRESS",
    "REFERENCE_STEP",
    "RELEASE_TIME",
    "SHAPE_FIELDS",
    "STANDOFF",
    "STROKE",
    "UPPER_SPAN",
    "GaitGeometry",
    "Reference",
    "Segment",
    "configuration_from_points",
    "gait_geometry",
    "knee",
    "phase_reference",
    "points_from_configuration",
]

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

FIRST_VIA_STANDOFF = 0.05
"""[m] The first extension passes through a shape whose upper brace stands this far off the walls
(a straight move in joint space from the scene's state would push j8 through the left wall)."""

FIRST_VIA_DROP = 0.05
"""[m] ... and whose upper brace is this much lower than the extended one."""

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


