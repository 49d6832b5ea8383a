"""The plane geometry of a scene: poses, contact surfaces as lines, friction cones, hulls.

Coordinates are the world plane's: x horizontal, y up, z out of the plane toward the viewer; a
link's pose is ``(origin [m], angle [rad])`` as returned by
:meth:`~frcontrol.model.PlanarRobot.link_poses`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from frcontrol.geometry import hull_from_points
from frcontrol.model import ContactPoint

__all__ = ["LINE_MERGE_TOLERANCE", "SurfaceLine", "convex_hull", "friction_cone_directions", "pose_matrix",
           "surface_lines", "surface_segments"]

LINE_MERGE_TOLERANCE = 1e-6
"""Two contact surfaces are drawn as one line when their unit normals are parallel within this
(|n1 x n2| <= tol [-]) and each line's point lies on the other within this distance [m]."""


def pose_matrix(origin: ArrayLike, angle: float, z: float = 0.0) -> np.ndarray:
    """The 4x4 homogeneous transform of a planar pose.

    A rotation by ``angle`` [rad] about z, then the translation ``(origin[0], origin[1], z)`` [m].
    """
    c, s = math.cos(angle), math.sin(angle)
    matrix = np.eye(4)
    matrix[:2, :2] = [[c, -s], [s, c]]
    x, y = np.asarray(origin, dtype=float)[:2]
    matrix[:3, 3] = [x, y, z]
    return matrix


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Convex hull of 2-D points, counter-clockwise: :func:`frcontrol.geometry.hull_from_points`."""
    return hull_from_points(points)


@dataclass(frozen=True)
class SurfaceLine:
    """A fixed contact surface: the line through ``point`` with unit ``normal`` (toward the robot).

    Attributes:
        point: a point of the line [m] (the first contact's surface point).
        normal: unit normal [-], pointing at the robot.
        contacts: the names of the contacts against this line.
    """

    point: np.ndarray
    normal: np.ndarray
    contacts: tuple[str, ...]

    @property
    def tangent(self) -> np.ndarray:
        """Unit tangent ``t = (n_y, -n_x)`` [-]."""
        return np.array([self.normal[1], -self.normal[0]])

    def foot(self, point: np.ndarray) -> np.ndarray:
        """The orthogonal projection [m] of ``point`` onto the line."""
        p = np.asarray(point, dtype=float)
        return p - float(self.normal @ (p - self.point)) * self.normal


def surface_lines(
    contacts: Iterable[ContactPoint], tolerance: float = LINE_MERGE_TOLERANCE
) -> list[SurfaceLine]:
    """The distinct surface lines of some contacts: coinciding lines are merged.

    Two lines coincide when their normals are parallel (either sign) within ``tolerance`` and each
    one's point lies on the other within ``tolerance`` [m]. The merged line keeps the first
    contact's point and normal.
    """
    lines: list[SurfaceLine] = []
    for contact in contacts:
        n = np.asarray(contact.normal_in_world, dtype=float)
        s = np.asarray(contact.surface_point_in_world, dtype=float)
        for i, line in enumerate(lines):
            parallel = abs(float(line.normal[0] * n[1] - line.normal[1] * n[0])) <= tolerance
            if parallel and abs(float(line.normal @ (s - line.point))) <= tolerance:
                lines[i] = SurfaceLine(line.point, line.normal, line.contacts + (contact.name,))
                break
        else:
            lines.append(SurfaceLine(s.copy(), n.copy(), (contact.name,)))
    return lines


def surface_segments(
    lines: Sequence[SurfaceLine], center: ArrayLike, half_length: float
) -> list[tuple[np.ndarray, np.ndarray]]:
    """The part of each surface line to draw: a segment (start, end) [m] along its tangent.

    Each line is cut to ``half_length`` [m] either side of the foot of ``center``, then, for
    every other line that crosses it, to the side outside that line's obstacle (the half-plane
    behind a line, ``n . (x - s) < 0``): two walls of a wedge end where they meet, as they
    would if the obstacles were the union of the half-planes (a wedge, a channel, a corner). A
    cut that would leave nothing is not made.
    """
    segments = []
    for i, line in enumerate(lines):
        foot, t = line.foot(np.asarray(center, dtype=float)), line.tangent
        low, high = -float(half_length), float(half_length)
        for j, other in enumerate(lines):
            if j == i:
                continue
            rate = float(other.normal @ t)  # d/dtau of n_j . (foot + tau t - s_j)
            if abs(rate) <= LINE_MERGE_TOLERANCE:
                continue
            tau0 = -float(other.normal @ (foot - other.point)) / rate  # where the lines cross
            new_low, new_high = (max(low, tau0), high) if rate > 0 else (low, min(high, tau0))
            if new_high - new_low > 1e-9:
                low, high = new_low, new_high
        segments.append((foot + low * t, foot + high * t))
    return segments


def friction_cone_directions(normal: ArrayLike, mu: float) -> tuple[np.ndarray, np.ndarray]:
    """The two unit edge directions of a planar friction cone.

    They are ``n cos(a) -+ t sin(a)``, with ``a = atan(mu)`` the half opening angle [rad] and
    ``t = (n_y, -n_x)``. The first edge leans toward -t (the force of a contact sliding right,
    mode R), the second toward +t (mode L).
    """
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n)
    t = np.array([n[1], -n[0]])
    a = math.atan(max(0.0, float(mu)))
    return n * math.cos(a) - t * math.sin(a), n * math.cos(a) + t * math.sin(a)
