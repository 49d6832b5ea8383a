"""Link visuals: each link's shapes from its URDF (:mod:`frcontrol.urdf`), their outlines in the plane.

A link with no usable visual gets a fallback: a thin box along the link.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from frcontrol.errors import RobotModelError
from frcontrol.model import ContactPoint, PlanarRobot
from frcontrol.urdf import read_urdf, resolve_mesh

from .picture_errors import VizError
from .shapes import convex_hull, pose_matrix

__all__ = ["DEFAULT_VISUAL_COLOR", "LinkVisual", "link_visuals", "visual_depth", "visual_outline"]

DEFAULT_VISUAL_COLOR = (0.6, 0.6, 0.65, 1.0)
"""RGBA of a link visual whose URDF gives no colour."""


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


def _urdf_visuals(urdf_path: Path) -> tuple[dict, dict]:
    """(visuals by link, child joint origins by link) from :func:`frcontrol.urdf.read_urdf`."""
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
                mesh_path = resolve_mesh(visual.mesh_filename, urdf_dir)
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
