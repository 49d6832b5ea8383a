"""Seeing it: meshcat scenes and animations, matplotlib figures.

Two modules, imported on demand (each imports its heavy library inside its functions, so
``import frcontrol`` stays light):

- :mod:`frcontrol.viz.meshcat_view`: a scene or a :class:`~frcontrol.simulation.trajectory.Trajectory`
  in meshcat's 3-D viewer, as a self-contained HTML file or on a local server;
- :mod:`frcontrol.viz.plots`: 2-D figures for reports (trajectories, scenes, input-space polygons).

This module holds what both share, with numpy only: the errors, the colours, and the planar
geometry of a scene (link visuals from the URDF, the contact surfaces as lines, friction cones,
bounding boxes). Coordinates are the world plane's: x horizontal, y up, z out of the plane toward
the viewer; a link's pose is ``(origin [m], angle [rad])`` as returned by
:meth:`~frcontrol.model.PlanarRobot.link_poses`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from frcontrol.errors import FrcontrolError
from frcontrol.model import ContactPoint, PlanarRobot

__all__ = [
    "CONE_COLOR",
    "CONTACT_COLOR",
    "DEFAULT_VISUAL_COLOR",
    "FORCE_COLOR",
    "INACTIVE_CONTACT_COLOR",
    "LINE_MERGE_TOLERANCE",
    "MODE_COLORS",
    "SURFACE_COLOR",
    "LinkVisual",
    "OutputFileError",
    "PortInUse",
    "SurfaceLine",
    "ViewerServerError",
    "VizError",
    "convex_hull",
    "friction_cone_directions",
    "link_visuals",
    "hex_color",
    "pose_matrix",
    "rgba_hex",
    "surface_lines",
    "surface_segments",
    "visual_depth",
    "visual_outline",
]

# ----------------------------------------------------------------------------------------- errors


class VizError(FrcontrolError):
    """Base class of the errors raised while drawing, writing or serving a picture."""


class PortInUse(VizError):
    """The port asked for the meshcat server is already taken on this machine.

    Attributes:
        host: the interface the server would listen on.
        port: the port asked for.
    """

    def __init__(self, host: str, port: int) -> None:
        self.host = host
        self.port = int(port)
        super().__init__(
            f"port {port} on {host} is already in use: choose another port, or give none to let "
            "meshcat take the first free one from 7000"
        )


class ViewerServerError(VizError):
    """The meshcat server could not be started (or stopped answering)."""

    def __init__(self, reason: str) -> None:
        self.reason = reason
        super().__init__(f"meshcat server: {reason}")


class OutputFileError(VizError):
    """A picture or page could not be written where asked.

    Attributes:
        path: the file asked for.
        reason: what went wrong.
    """

    def __init__(self, path: str | Path, reason: str) -> None:
        self.path = str(path)
        self.reason = reason
        super().__init__(f"cannot write {self.path}: {reason}")


# ---------------------------------------------------------------------------------------- colours

MODE_COLORS: dict[str, str] = {"S": "#7f7f7f", "F": "#2ca02c", "L": "#1f77b4", "R": "#ff7f0e"}
"""Colour of a contact force drawn in each contact mode: Separate grey, Fixed green, sliding Left
blue, sliding Right orange."""

FORCE_COLOR = "#d62728"
"""Colour of a contact force when no mode is given (red)."""

CONTACT_COLOR = "#ffbf00"
"""Colour of a contact point that touches its surface (amber)."""

INACTIVE_CONTACT_COLOR = "#b0b0b0"
"""Colour of a contact point off its surface (light grey)."""

SURFACE_COLOR = "#8c7a6b"
"""Colour of the fixed contact surfaces (ground, walls)."""

CONE_COLOR = "#6baed6"
"""Colour of the friction cones (drawn translucent)."""

DEFAULT_VISUAL_COLOR = (0.6, 0.6, 0.65, 1.0)
"""RGBA of a link visual whose URDF gives no colour."""

LINE_MERGE_TOLERANCE = 1e-6
"""Two contact surfaces are drawn as one line when their unit normals are parallel within this
(|n1 x n2| <= tol [-]) and each line's point lies on the other within this distance [m]."""


def hex_color(color: str) -> int:
    """``"#rrggbb"`` as the integer ``0xrrggbb`` meshcat takes."""
    return int(color.lstrip("#"), 16)


def rgba_hex(rgba: Sequence[float]) -> str:
    """An RGBA tuple in [0, 1] as ``"#rrggbb"`` (alpha dropped)."""
    r, g, b = (min(255, max(0, round(255 * float(c)))) for c in rgba[:3])
    return f"#{r:02x}{g:02x}{b:02x}"


# ------------------------------------------------------------------------------------ geometry


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


@dataclass(frozen=True, eq=False)
class LinkVisual:
    """One visual shape of a link, in the link's frame.

    Attributes:
        link: the link's name.
        shape: ``"box"``, ``"cylinder"`` (axis along the shape's own z, as in URDF), ``"sphere"`` or
            ``"mesh"``.
        size: box: edge lengths (x, y, z) [m]; cylinder: (radius, length) [m]; sphere: (radius,)
            [m]; mesh: the scale (x, y, z) [-].
        origin: the shape's pose in the link frame, 4x4 [m].
        rgba: colour, each in [0, 1].
        mesh_path: the mesh file (``shape == "mesh"`` only).
        fallback: True when the URDF gives no (usable) visual and frcontrol drew a thin box along
            the link (from its origin to its farthest child joint or contact point).
    """

    link: str
    shape: str
    size: tuple[float, ...]
    origin: np.ndarray
    rgba: tuple[float, float, float, float]
    mesh_path: Path | None = None
    fallback: bool = False


def _resolve_mesh(filename: str, urdf_dir: Path) -> Path | None:
    """A mesh file named by a URDF: ``package://pkg/rel``, ``file://abs`` or a relative path."""
    if filename.startswith("file://"):
        candidate = Path(filename[len("file://"):])
        return candidate if candidate.is_file() else None
    if filename.startswith("package://"):
        rest = Path(filename[len("package://"):])
        tails = [Path(*rest.parts[1:]), rest] if len(rest.parts) > 1 else [rest]
        for folder in (urdf_dir, *urdf_dir.parents):
            for tail in tails:
                if (folder / tail).is_file():
                    return folder / tail
        return None
    candidate = Path(filename) if Path(filename).is_absolute() else urdf_dir / filename
    return candidate if candidate.is_file() else None


def _urdf_visuals(urdf_path: Path) -> tuple[dict, dict]:
    """(visuals by link, child joint origins by link) from :func:`frcontrol.urdf.read_urdf`."""
    from frcontrol.errors import RobotModelError
    from frcontrol.urdf import read_urdf

    try:
        document = read_urdf(urdf_path)
    except RobotModelError as err:
        raise VizError(str(err)) from err
    urdf_dir = Path(document.path).parent
    visuals: dict[str, list[LinkVisual]] = {}
    for link, shapes in document.visuals.items():
        kept = []
        for visual in shapes:
            rgba = visual.rgba if visual.rgba is not None else DEFAULT_VISUAL_COLOR
            mesh_path = None
            if visual.shape == "mesh":
                mesh_path = _resolve_mesh(visual.mesh_filename, urdf_dir)
                if mesh_path is None:
                    continue  # unusable: the link falls back to a thin box if nothing else is left
            kept.append(LinkVisual(link, visual.shape, visual.size, visual.origin, rgba, mesh_path=mesh_path))
        visuals[link] = kept
    children: dict[str, list[np.ndarray]] = {}
    for joint in document.joints:
        children.setdefault(joint.parent, []).append(joint.origin[:2, 3].copy())
    return visuals, children


def link_visuals(
    robot: PlanarRobot, contacts: Iterable[ContactPoint] = ()
) -> dict[str, tuple[LinkVisual, ...]]:
    """The visual shapes of every link of ``robot``, from its URDF (:func:`frcontrol.urdf.read_urdf`).

    Boxes, cylinders, spheres and meshes (resolved relative to the URDF; ``package://`` paths are
    looked up in the URDF's folder and its parents) are kept as the URDF gives them. A link with
    no usable visual gets a *fallback*: a thin box from the link's origin to the farthest of its
    child joints' origins and of the given contact points on it (a 5 cm square if it has none).

    Args:
        robot: the robot.
        contacts: contact points, used to size the fallback boxes.

    Returns:
        link name -> its shapes, for every link of ``robot.link_names``.

    Raises:
        VizError: the URDF cannot be read.
    """
    visuals, children = _urdf_visuals(Path(robot.urdf_path))
    contact_points: dict[str, list[np.ndarray]] = {}
    for contact in contacts:
        contact_points.setdefault(contact.link, []).append(np.asarray(contact.point_in_link, float))
    result: dict[str, tuple[LinkVisual, ...]] = {}
    for link in robot.link_names:
        shapes = visuals.get(link, [])
        if shapes:
            result[link] = tuple(shapes)
            continue
        features = [np.zeros(2)] + children.get(link, []) + contact_points.get(link, [])
        far = max(features, key=lambda p: float(np.hypot(*p)))
        length = float(np.hypot(*far))
        if length < 1e-9:
            result[link] = (LinkVisual(link, "box", (0.05, 0.05, 0.02), np.eye(4),
                                       DEFAULT_VISUAL_COLOR, fallback=True),)
            continue
        width = min(0.03, max(0.005, 0.1 * length))
        origin = pose_matrix(far / 2.0, math.atan2(far[1], far[0]))
        result[link] = (LinkVisual(link, "box", (length, width, width), origin, DEFAULT_VISUAL_COLOR,
                                   fallback=True),)
    return result


def _shape_points(visual: LinkVisual, segments: int = 32) -> np.ndarray:
    """Points (N, 3) of the shape's outline in its own frame (box corners, cylinder rims...)."""
    if visual.shape == "box":
        hx, hy, hz = (s / 2.0 for s in visual.size)
        return np.array([[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    angles = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    if visual.shape == "cylinder":
        radius, length = visual.size
        rim = np.column_stack([radius * np.cos(angles), radius * np.sin(angles)])
        return np.vstack([np.column_stack([rim, np.full(segments, z)]) for z in (-length / 2, length / 2)])
    if visual.shape == "sphere":
        # Any projection of a sphere is a disk: the three great circles cover its outline.
        r = visual.size[0]
        c, s, zero = r * np.cos(angles), r * np.sin(angles), np.zeros(segments)
        return np.vstack([np.column_stack([c, s, zero]), np.column_stack([c, zero, s]),
                          np.column_stack([zero, c, s])])
    if visual.shape == "mesh" and visual.mesh_path is not None:
        import trimesh

        try:
            mesh: Any = trimesh.load(visual.mesh_path, force="mesh")
            return np.asarray(mesh.vertices, dtype=float) * np.asarray(visual.size)
        except Exception as err:  # trimesh raises many kinds on unreadable files
            raise VizError(f"cannot read the mesh {visual.mesh_path}: {err}") from err
    raise VizError(f"link {visual.link!r}: unknown visual shape {visual.shape!r}")


def visual_outline(visual: LinkVisual, link_pose: np.ndarray | None = None) -> np.ndarray:
    """The shape's outline projected onto the plane: a convex polygon (N, 2) [m], counter-clockwise.

    Args:
        visual: the shape.
        link_pose: the link's 4x4 pose in the world (default: the identity, i.e. the link frame).
    """
    points = _shape_points(visual)
    matrix = visual.origin if link_pose is None else link_pose @ visual.origin
    world = points @ matrix[:3, :3].T + matrix[:3, 3]
    return convex_hull(world[:, :2])


def visual_depth(visual: LinkVisual) -> tuple[float, float]:
    """The z range [m] (out of the plane) the shape occupies in its link frame."""
    points = _shape_points(visual)
    z = points @ visual.origin[2, :3] + visual.origin[2, 3]
    return float(z.min()), float(z.max())


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Convex hull of 2-D points, counter-clockwise: :func:`frcontrol.polytope.hull_from_points`."""
    from frcontrol.polytope import hull_from_points

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
