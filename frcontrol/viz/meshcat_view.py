"""A scene or a trajectory in meshcat's 3-D viewer: a self-contained HTML page or a local server.

**The plane in meshcat's world.** frcontrol's world is the x-y plane with y up (z out of the plane,
toward the viewer); meshcat's world is z-up. :func:`meshcat_from_plane` is the one mapping between
them, the rotation by +90 degrees about x::

    (x, y, z)_plane  ->  (x, -z, y)_meshcat

so the plane's "up" (+y) is meshcat's up (+z), and the viewer, who looks at the plane from +z, sits
on meshcat's -y side looking along +y. Everything is drawn in plane coordinates under one node,
``/meshcat/frcontrol``, whose transform is that rotation after a translation by ``-center`` (the
middle of the drawing): meshcat's orbit camera always turns about meshcat's origin, so the drawing
is moved there rather than the camera. The camera is placed on meshcat's -y axis, far enough to
frame the drawing (see :class:`Drawing`).

**What is drawn** (:func:`draw`): every link with its URDF visual geometry (or a thin box along
the link when the URDF has none, see :func:`frcontrol.viz.link_visuals`); each contact point as a
small sphere (amber when touching at the scene's state, grey otherwise); each contact surface as a
long thin slab on the far side of its line (coinciding lines merged); a translucent friction cone
(half opening angle atan(mu), around the normal) at every contact touching its surface; and each
contact force ``lambda_n n + lambda_t t`` as an arrow (a cylinder and a cone) from the contact
point, its length ``force_scale`` [m/N] times the force's magnitude [N], red, or coloured by contact
mode (:data:`frcontrol.viz.MODE_COLORS`) when modes are given. A trajectory with more than one
sample is animated with meshcat's ``Animation``: one key frame per sample at the sample's time
(links, contact points, cones and arrows), played once when the page opens; the viewer's
"Open Controls > Animations" panel replays, pauses, scrubs and changes its speed.

**Output.** :func:`write_html` writes meshcat's ``static_html()`` page (about 900 kB with the
viewer's JavaScript): it replays the animation offline, with no server. :func:`serve` starts a
meshcat server on localhost, draws into it and returns the page's URL.
"""

from __future__ import annotations

import atexit
import contextlib
import html as html_lib
import io
import math
import socket
import subprocess
import sys
import tempfile
import threading
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from frcontrol.errors import InputError, reason_from_exception
from frcontrol.modes import mode_heading, mode_label
from frcontrol.scene import Scene
from frcontrol.simulation.trajectory import Trajectory

from . import colors
from .picture_errors import OutputFileError, PortInUse, ViewerServerError
from .shapes import friction_cone_directions, pose_matrix, surface_lines, surface_segments
from .visuals import LinkVisual, link_visuals, visual_depth, visual_outline

__all__ = [
    "DEFAULT_FPS",
    "FORCE_ARROW_FRACTION",
    "HOST",
    "MESHCAT_FROM_PLANE",
    "Drawing",
    "PortInUse",
    "ViewerServer",
    "ViewerServerError",
    "check_trajectory",
    "draw",
    "meshcat_from_plane",
    "scene_html",
    "redraw",
    "serve",
    "server_at",
    "start_server",
    "stop_server",
    "trajectory_from_scene",
    "write_html",
]

MESHCAT_FROM_PLANE = np.array(
    [[1.0, 0.0, 0.0, 0.0],
     [0.0, 0.0, -1.0, 0.0],
     [0.0, 1.0, 0.0, 0.0],
     [0.0, 0.0, 0.0, 1.0]]
)
"""The rotation (4x4, +90 degrees about x) taking plane coordinates (x, y up, z toward the viewer)
to meshcat's z-up world: see :func:`meshcat_from_plane`."""

DEFAULT_FPS = 30.0
"""[frames/s] Frame rate of the animation; samples closer than 1/fps are thinned out."""

FORCE_ARROW_FRACTION = 0.3
"""With no ``force_scale`` given, the largest force drawn is this fraction of the robot's size
(the larger side of the box around every pose of the robot and its contact points)."""

HOST = "127.0.0.1"
"""The interface the meshcat server listens on (this machine only)."""

CAMERA_FOV = 30.0
"""[deg] Vertical field of view of the viewer's perspective camera."""

CAMERA_ASPECT = 4.0 / 3.0
"""Width/height of the window the camera distance is chosen for (wider windows show more)."""

CAMERA_MARGIN = 1.15
"""The camera frames the drawing's box enlarged by this factor."""

CAPTION_FRACTION = 0.16
"""Fraction of the view's height, at its top, kept free for the page's caption and controls: the
robot is framed in the part below."""

_HIDDEN = 1e-6
"""Scale of a hidden part (a zero force, a cone of an open contact): three.js needs scale != 0."""


def _import_meshcat() -> Any:
    """``import meshcat``, without the DeprecationWarning its server module triggers in pyzmq."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        import meshcat
        import meshcat.servers.zmqserver  # noqa: F401
    return meshcat


# ------------------------------------------------------------------------------------ mapping


def meshcat_from_plane(points: Any) -> np.ndarray:
    """Plane coordinates to meshcat's world: ``(x, y[, z]) -> (x, -z, y)``.

    The plane is frcontrol's world (x right, y up, z out of the plane toward the viewer); meshcat's
    world is z-up. The mapping is the rotation :data:`MESHCAT_FROM_PLANE` (+90 degrees about x), so
    "up" in the plane is "up" in meshcat and the viewer looks along meshcat's +y. (The drawings of
    :func:`draw` also translate by ``-Drawing.center`` before this rotation, to put the drawing's
    middle at the camera's target.)

    Args:
        points: shape (..., 2) (z = 0) or (..., 3) [m].

    Returns:
        meshcat coordinates, shape (..., 3) [m].

    Raises:
        InputError: the last axis is not 2 or 3.
    """
    p = np.asarray(points, dtype=float)
    if p.ndim == 0 or p.shape[-1] not in (2, 3):
        raise InputError(f"expected points of shape (..., 2) or (..., 3), got {p.shape}")
    if p.shape[-1] == 2:
        p = np.concatenate([p, np.zeros(p.shape[:-1] + (1,))], axis=-1)
    return p @ MESHCAT_FROM_PLANE[:3, :3].T


# --------------------------------------------------------------------------------- trajectories


def trajectory_from_scene(scene: Scene, contact_forces: Mapping[str, Sequence[float]] | None = None
                          ) -> Trajectory:
    """The scene's state as a one-sample trajectory (zero inputs): a still picture.

    Args:
        scene: the scene.
        contact_forces: ``(lambda_n, lambda_t)`` [N] by contact name (e.g. a statics equilibrium);
            contacts not named carry no force.

    Raises:
        InputError: an unknown contact name, or a force that is not two finite numbers.
    """
    k = len(scene.contacts)
    forces = np.zeros((1, k, 2))
    names = [c.name for c in scene.contacts]
    for name, force in (contact_forces or {}).items():
        if name not in names:
            raise InputError(f"no contact named {name!r} (contacts: {', '.join(names)})")
        value = np.asarray(force, dtype=float)
        if value.shape != (2,) or not np.all(np.isfinite(value)):
            raise InputError(f"the force of contact {name!r} must be two finite numbers (lambda_n, lambda_t)")
        forces[0, names.index(name)] = value
    return Trajectory(
        scene_name=scene.name,
        coordinates=tuple(scene.coordinate_names),
        contacts=tuple(c.name for c in scene.contacts),
        times=np.zeros(1),
        q=np.asarray(scene.q, dtype=float)[None, :].copy(),
        v=np.asarray(scene.v, dtype=float)[None, :].copy(),
        inputs=np.zeros((1, scene.inputs.count)),
        input_names=tuple(scene.inputs.coordinates),
        contact_forces=forces,
        contact_points=scene.robot.contact_points_in_world(scene.q).reshape(1, k, 2),
        info={"source": "scene state"},
    )


def check_trajectory(scene: Scene, trajectory: Trajectory) -> None:
    """Check that ``trajectory`` is a motion of ``scene``'s robot, with consistent shapes.

    Raises:
        InputError: coordinates or contacts differ from the scene's, an array has the wrong shape,
            a value is not finite, or the times do not increase.
    """
    coords, contacts = tuple(scene.coordinate_names), tuple(c.name for c in scene.contacts)
    if tuple(trajectory.coordinates) != coords:
        raise InputError(f"the trajectory's coordinates {list(trajectory.coordinates)} are not the "
                         f"scene's {list(coords)}")
    if tuple(trajectory.contacts) != contacts:
        raise InputError(f"the trajectory's contacts {list(trajectory.contacts)} are not the "
                         f"scene's {list(contacts)}")
    times = np.asarray(trajectory.times, dtype=float)
    count, n, k = times.shape[0] if times.ndim == 1 else -1, len(coords), len(contacts)
    expected = {"times": (count,), "q": (count, n), "contact_forces": (count, k, 2),
                "contact_points": (count, k, 2)}
    if count < 1:
        raise InputError(f"the trajectory needs at least one sample; times has shape {times.shape}")
    for name, shape in expected.items():
        value = np.asarray(getattr(trajectory, name), dtype=float)
        if value.shape != shape:
            raise InputError(f"trajectory.{name} has shape {value.shape}, expected {shape}")
        if not np.all(np.isfinite(value)):
            raise InputError(f"trajectory.{name} has non-finite values")
    if np.any(np.diff(times) <= 0):
        raise InputError("trajectory.times must increase strictly")


def _check_modes(modes: Sequence[str] | None, trajectory: Trajectory) -> list[str] | None:
    if modes is None:
        modes = trajectory.modes
        if modes is None:
            return None
    modes = list(modes)
    count, k = len(trajectory.times), len(trajectory.contacts)
    if len(modes) != count:
        raise InputError(f"expected one mode string per sample ({count}), got {len(modes)}")
    for i, mode in enumerate(modes):
        if not isinstance(mode, str) or len(mode) != k or any(ch not in colors.MODE_COLORS for ch in mode):
            raise InputError(
                f"modes[{i}] = {mode!r}: expected {k} letters from S, L, R, F (one per contact "
                f"of the trajectory: {', '.join(trajectory.contacts)})"
            )
    return modes


def _frame_indices(times: np.ndarray, fps: float) -> list[int]:
    """Samples kept for the animation.

    The first, the last, and none closer than 1/fps to the previous one kept.
    """
    kept = [0]
    for i in range(1, len(times)):
        if times[i] - times[kept[-1]] >= 1.0 / fps - 1e-12 or i == len(times) - 1:
            kept.append(i)
    if len(kept) > 2 and times[kept[-1]] - times[kept[-2]] < 1.0 / fps - 1e-12:
        del kept[-2]
    return kept


# ------------------------------------------------------------------------------------- drawing


@dataclass(frozen=True)
class Drawing:
    """What :func:`draw` drew, and how.

    Attributes:
        force_scale: [m/N] arrow length per newton of contact force.
        center: [m] the middle of the robot's box at the first drawn sample (the framed point).
        lower: [m] lower corner of the plane box that the camera frames at the first sample.
        upper: [m] upper corner of that box.
        centers: [m] the framed point at each drawn sample, shape (S, 2): the camera follows the
            robot along x (its centre of mass, offset to its box's middle); y stays fixed.
        targets: [m] the plane point drawn at meshcat's origin (the camera's target) at each drawn
            sample, shape (S, 2): ``centers`` raised so that the robot sits in the part of the view
            below the page's caption (:data:`CAPTION_FRACTION`).
        root_transform: 4x4 transform of the node ``/meshcat/frcontrol`` (plane -> meshcat) at
            the first sample: ``MESHCAT_FROM_PLANE @ translation(-targets[0])``.
        camera_distance: [m] from the camera to its target, along meshcat's -y.
        samples: indices of the trajectory's samples drawn (one: a still picture).
        times: [s] the drawn samples' times, shape (S,).
        sample_modes: the contact mode (one letter per contact) at each drawn sample: the given
            modes, else the trajectory's, else :func:`~frcontrol.simulation.export.sample_modes`
            for an animation; None for a still picture.
        fps: [frames/s] the animation's frame rate.
        modes: whether forces are coloured by contact mode.
    """

    force_scale: float
    center: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    centers: np.ndarray
    targets: np.ndarray
    root_transform: np.ndarray
    camera_distance: float
    samples: tuple[int, ...]
    times: np.ndarray
    sample_modes: tuple[str, ...] | None
    fps: float
    modes: bool

    @property
    def animated(self) -> bool:
        """Whether an animation was set (more than one sample drawn)."""
        return len(self.samples) > 1


def _node(name: str) -> str:
    """A meshcat path element from a user name (no slashes or spaces)."""
    return "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in name) or "_"


def _scale(sx: float, sy: float, sz: float) -> np.ndarray:
    return np.diag([sx, sy, sz, 1.0])


def _translation(x: float, y: float, z: float) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, 3] = [x, y, z]
    return matrix


_CYLINDER_ALONG_Z = np.array(
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)
"""three.js cylinders lie along y; URDF cylinders along z: rotate +90 degrees about x."""


def _visual_object(visual: LinkVisual) -> tuple[Any, np.ndarray]:
    """(meshcat geometry, its transform in the link frame) for one URDF visual."""
    import meshcat.geometry as mg

    if visual.shape == "box":
        return mg.Box(list(visual.size)), visual.origin
    if visual.shape == "cylinder":
        radius, length = visual.size
        return mg.Cylinder(length, radius), visual.origin @ _CYLINDER_ALONG_Z
    if visual.shape == "sphere":
        return mg.Sphere(visual.size[0]), visual.origin
    import trimesh

    try:
        mesh: Any = trimesh.load(visual.mesh_path, force="mesh")
    except Exception as err:  # trimesh raises many kinds on unreadable files
        raise InputError(f"cannot read the mesh {visual.mesh_path}: {err}") from err
    geometry = mg.TriangularMeshGeometry(np.asarray(mesh.vertices, dtype=np.float32),
                                         np.asarray(mesh.faces, dtype=np.uint32))
    return geometry, visual.origin @ _scale(*visual.size)


@dataclass
class _Arrow:
    path: str
    contact: int
    letter: str  # "" when not coloured by mode


def _arrow_parts(force: np.ndarray, scale: float, head: float) -> tuple[float, np.ndarray, np.ndarray]:
    """(angle [rad] of the arrow's local +y, shaft transform, head transform) for one force."""
    magnitude = float(np.hypot(*force))
    length = magnitude * scale
    if length <= 1e-9:
        hidden = _scale(_HIDDEN, _HIDDEN, _HIDDEN)
        return 0.0, hidden, hidden
    angle = math.atan2(force[1], force[0]) - math.pi / 2
    head_length = min(head, 0.5 * length)
    head_scale = head_length / head
    shaft_length = length - head_length
    shaft = _translation(0.0, shaft_length / 2, 0.0) @ _scale(head_scale, shaft_length, head_scale)
    tip = _translation(0.0, shaft_length + head_length / 2, 0.0) @ _scale(head_scale, head_scale,
                                                                           head_scale)
    return angle, shaft, tip


def draw(
    vis: Any,
    scene: Scene,
    trajectory: Trajectory | None = None,
    *,
    force_scale: float | None = None,
    modes: Sequence[str] | None = None,
    fps: float = DEFAULT_FPS,
    cones: bool = True,
) -> Drawing:
    """Draw a scene, and animate a trajectory of it, into a meshcat visualizer.

    Args:
        vis: a ``meshcat.Visualizer`` (a server's, or the page recorder of :func:`scene_html`).
        scene: the scene (robot, contacts, surfaces).
        trajectory: a motion of the scene's robot; default: the scene's state, still.
        force_scale: [m/N] arrow length per newton; default: the largest force drawn is
            :data:`FORCE_ARROW_FRACTION` of the robot's size.
        modes: one string per sample with one letter S, L, R or F per contact of the trajectory
            (all contacts, in scene order), to colour the forces by mode; default:
            ``trajectory.modes`` if present, else every force is red.
        fps: [frames/s] the animation's frame rate (samples closer than 1/fps are thinned out).
        cones: draw the friction cones.

    Returns:
        What was drawn and how (force scale, framing, samples).

    Raises:
        InputError: the trajectory does not match the scene, the modes are malformed, or
            ``force_scale``/``fps`` is not positive and finite.
    """
    _import_meshcat()
    trajectory = trajectory_from_scene(scene) if trajectory is None else trajectory
    check_trajectory(scene, trajectory)
    modes_list = _check_modes(modes, trajectory)
    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and fps > 0):
        raise InputError(f"fps must be a positive number of frames per second, got {fps!r}")
    if force_scale is not None and not (math.isfinite(force_scale) and force_scale > 0):
        raise InputError(f"force_scale must be a positive number of metres per newton, got {force_scale!r}")

    layers = _Layers(vis, scene, trajectory, _frame_indices(np.asarray(trajectory.times, float), float(fps)),
                     force_scale, modes_list, cones)
    framing, samples = layers.framing, layers.samples
    layers.stage()
    layers.surfaces()
    layers.links()
    if cones:
        layers.cones()
    layers.arrows()
    for path, (transform, scale) in layers.transforms_at(samples[0]).items():
        layers.root[path].set_transform(transform if scale is None else transform @ _scale(*scale))
    if len(samples) > 1:
        layers.animate(float(fps))
    center, half = framing.centers[0], framing.half
    return Drawing(
        force_scale=float(framing.force_scale),
        center=center,
        lower=center - CAMERA_MARGIN * half,
        upper=center + CAMERA_MARGIN * half,
        centers=framing.centers,
        targets=framing.targets,
        root_transform=layers.root_transforms[0],
        camera_distance=float(layers.distance),
        samples=tuple(samples),
        times=layers.times[samples],
        sample_modes=_drawn_modes(scene, trajectory, modes_list, samples),
        fps=float(fps),
        modes=modes_list is not None,
    )


class _Layers:
    """What :func:`draw` puts into meshcat, layer by layer, in plane coordinates under the root."""

    def __init__(self, vis: Any, scene: Scene, trajectory: Trajectory, samples: list[int],
                 force_scale: float | None, modes: list[str] | None, cones: bool) -> None:
        import meshcat.geometry as mg

        self.mg, self.vis, self.scene, self.trajectory = mg, vis, scene, trajectory
        self.samples, self.modes, self.with_cones = samples, modes, cones
        robot = scene.robot
        self.points = [c.point for c in scene.contacts]
        self.times = np.asarray(trajectory.times, dtype=float)
        self.contact_xy = np.asarray(trajectory.contact_points, dtype=float)
        normals = np.array([p.normal_in_world for p in self.points]).reshape(-1, 2)
        tangents = np.array([p.tangent_in_world for p in self.points]).reshape(-1, 2)
        surfaces = np.array([p.surface_point_in_world for p in self.points]).reshape(-1, 2)
        forces_nt = np.asarray(trajectory.contact_forces, dtype=float)
        # World force of contact j at sample i: lambda_n n_j + lambda_t t_j.
        self.forces = forces_nt[..., :1] * normals[None] + forces_nt[..., 1:] * tangents[None]
        gaps = np.einsum("kj,tkj->tk", normals, self.contact_xy - surfaces[None])
        self.touching = gaps <= scene.gap_tolerance
        self.visuals = link_visuals(robot, self.points)
        poses = [robot.link_poses(trajectory.q[i]) for i in samples]
        self.framing = _frame(scene, trajectory, samples, poses, self.visuals, self.contact_xy, self.forces,
                              force_scale)
        self.size = self.framing.size
        depths = [visual_depth(v) for shapes in self.visuals.values() for v in shapes]
        self.z_back = min([d[0] for d in depths], default=-0.02)
        self.z_front = max([d[1] for d in depths], default=0.02) + 0.01 * self.size
        tan_half = math.tan(math.radians(CAMERA_FOV) / 2)
        self.distance = self.framing.view_half_height / tan_half + self.z_front
        self.root_transforms = [MESHCAT_FROM_PLANE @ _translation(-c[0], -c[1], 0.0)
                                for c in self.framing.targets]
        self.root = vis["frcontrol"]
        self.head = 0.06 * self.size
        self.arrow_list: list[_Arrow] = []

    def stage(self) -> None:
        """No background (the page's white shows through), no grid or axes, the camera on -y."""
        vis, distance = self.vis, self.distance
        vis["/Background"].set_property("visible", False)
        vis["/Grid"].set_property("visible", False)
        vis["/Axes"].set_property("visible", False)
        camera = vis["/Cameras/default/rotated/<object>"]
        camera.set_property("fov", CAMERA_FOV)
        camera.set_property("near", max(1e-3, distance / 1000))
        camera.set_property("far", max(100.0, 10 * distance))
        # The camera's parent undoes meshcat's z-up rotation: (0, 0, d) there is meshcat's (0, -d, 0).
        camera.set_property("position", [0.0, 0.0, distance])
        self.root.delete()
        self.root.set_transform(self.root_transforms[0])

    def surfaces(self) -> None:
        """Slabs on the far side of each surface line, through the drawing."""
        mg, framing, size = self.mg, self.framing, self.size
        lines = surface_lines(self.points)
        thickness = 0.03 * size
        reach = 2.0 * max(float(np.max(framing.upper - framing.lower)), size) + framing.travel
        segments = surface_segments(lines, framing.centers[0], reach)
        for i, (line, (start, end)) in enumerate(zip(lines, segments, strict=True)):
            t = line.tangent
            slab = self.root["surfaces"][f"line{i}"]
            slab.set_object(mg.Box([float(np.hypot(*(end - start))), thickness, self.z_front - self.z_back]),
                            mg.MeshLambertMaterial(color=colors.hex_color(colors.SURFACE_COLOR)))
            slab.set_transform(pose_matrix((start + end) / 2, math.atan2(t[1], t[0]))
                               @ _translation(0.0, -thickness / 2, (self.z_front + self.z_back) / 2))

    def links(self) -> None:
        """Every link's visuals, and each contact point as a small sphere on its link."""
        mg = self.mg
        for link, shapes in self.visuals.items():
            node = self.root["robot"][_node(link)]
            for i, visual in enumerate(shapes):
                geometry, transform = _visual_object(visual)
                material = mg.MeshLambertMaterial(color=colors.hex_color(colors.rgba_hex(visual.rgba)),
                                                  opacity=float(visual.rgba[3]))
                node[f"visual{i}"].set_object(geometry, material)
                node[f"visual{i}"].set_transform(transform)
        radius = 0.012 * self.size
        for point, contact in zip(self.points, self.scene.contacts, strict=True):
            node = self.root["robot"][_node(point.link)][f"contact_{_node(point.name)}"]
            color = colors.CONTACT_COLOR if contact.active else colors.INACTIVE_CONTACT_COLOR
            node.set_object(mg.Sphere(radius), mg.MeshLambertMaterial(color=colors.hex_color(color)))
            node.set_transform(_translation(point.point_in_link[0], point.point_in_link[1], self.z_front))

    def cones(self) -> None:
        """Friction cones: apex at the contact point, fixed in the world."""
        mg = self.mg
        cone_length = 0.12 * self.size
        for point in self.points:
            e1, e2 = friction_cone_directions(point.normal_in_world, point.mu)
            vertices = np.array([[0.0, 0.0, 0.0], [*(cone_length * e1), 0.0], [*(cone_length * e2), 0.0]])
            node = self.root["cones"][_node(point.name)]
            node["fan"].set_object(
                mg.TriangularMeshGeometry(vertices.astype(np.float32), np.array([[0, 1, 2]], np.uint32)),
                mg.MeshBasicMaterial(color=colors.hex_color(colors.CONE_COLOR), opacity=0.3),
            )
            node["edges"].set_object(mg.LineSegments(
                mg.PointsGeometry(vertices[[0, 1, 0, 2]].T.astype(np.float32)),
                mg.LineBasicMaterial(color=colors.hex_color("#2171b5")),
            ))

    def arrows(self) -> None:
        """Force arrows: one per contact, or one per contact and mode letter that occurs."""
        mg = self.mg
        shaft_radius = 0.008 * self.size
        for j, point in enumerate(self.points):
            letters = [""] if self.modes is None else sorted({self.modes[i][j] for i in self.samples})
            for letter in letters:
                path_name = _node(point.name) + (f"_{letter}" if letter else "")
                arrow_color = colors.hex_color(colors.MODE_COLORS[letter] if letter else colors.FORCE_COLOR)
                node = self.root["forces"][path_name]
                material = mg.MeshLambertMaterial(color=arrow_color)
                node["shaft"].set_object(mg.Cylinder(1.0, shaft_radius), material)
                cone = mg.Cylinder(self.head, radiusTop=0.0, radiusBottom=2.5 * shaft_radius)
                node["head"].set_object(cone, mg.MeshLambertMaterial(color=arrow_color))
                self.arrow_list.append(_Arrow(path_name, j, letter))

    def transforms_at(self, i: int) -> dict[str, tuple[np.ndarray, np.ndarray | None]]:
        """Node path -> (transform, scale or None) at sample i."""
        out: dict[str, tuple[np.ndarray, np.ndarray | None]] = {}
        pose = self.scene.robot.link_poses(self.trajectory.q[i])
        for link in self.visuals:
            origin, angle = pose[link]
            out[f"robot/{_node(link)}"] = (pose_matrix(origin, angle), None)
        xy = self.contact_xy
        if self.with_cones:
            for j, point in enumerate(self.points):
                shown = 1.0 if self.touching[i, j] else _HIDDEN
                apex = _translation(xy[i, j, 0], xy[i, j, 1], self.z_front - 0.005 * self.size)
                out[f"cones/{_node(point.name)}"] = (apex, np.full(3, shown))
        for arrow in self.arrow_list:
            j = arrow.contact
            shown = self.modes is None or self.modes[i][j] == arrow.letter
            force = self.forces[i, j] if shown else np.zeros(2)
            angle, shaft, tip = _arrow_parts(force, self.framing.force_scale, self.head)
            out[f"forces/{arrow.path}"] = (pose_matrix(xy[i, j], angle, self.z_front), None)
            out[f"forces/{arrow.path}/shaft"] = (_translation(*shaft[:3, 3]), np.diag(shaft)[:3])
            out[f"forces/{arrow.path}/head"] = (_translation(*tip[:3, 3]), np.diag(tip)[:3])
        return out

    def animate(self, fps: float) -> None:
        """One key frame per drawn sample at its time; the camera follows the robot along x."""
        from meshcat.animation import Animation

        animation = Animation(default_framerate=fps)
        first = self.times[self.samples[0]]
        for number, i in enumerate(self.samples):
            with animation.at_frame(self.vis, (self.times[i] - first) * fps) as frame:
                if self.framing.travel > 0:
                    frame["frcontrol"].set_transform(self.root_transforms[number])
                for path, (transform, scale) in self.transforms_at(i).items():
                    frame[f"frcontrol/{path}"].set_transform(transform)
                    if scale is not None:
                        frame[f"frcontrol/{path}"].set_property("scale", "vector3", [float(s) for s in scale])
        self.vis.set_animation(animation, play=True, repetitions=1)


def _drawn_modes(scene: Scene, trajectory: Trajectory, modes: list[str] | None,
                 samples: Sequence[int]) -> tuple[str, ...] | None:
    """The contact modes at the drawn samples of an animation (None for a still picture)."""
    if len(samples) < 2:
        return None
    if modes is None:
        from frcontrol.simulation.samples import sample_modes

        modes = list(sample_modes(scene, trajectory))
    return tuple(modes[i] for i in samples)


@dataclass(frozen=True)
class _Framing:
    force_scale: float  # [m/N]
    size: float  # [m] the larger side of the box around every drawn pose
    centers: np.ndarray  # (S, 2) the framed point per drawn sample
    targets: np.ndarray  # (S, 2) the camera's target per drawn sample
    half: np.ndarray  # [m] half sides of the box framed around each centre
    lower: np.ndarray  # [m] the box around every drawn pose, contact and surface foot
    upper: np.ndarray
    travel: float  # [m] how far the framed point moves along x
    view_half_height: float  # [m] half the height the camera shows at the drawing's plane


def _frame(scene: Scene, trajectory: Trajectory, samples: Sequence[int], poses: Sequence[dict],
           visuals: dict, contact_xy: np.ndarray, forces: np.ndarray, force_scale: float | None) -> _Framing:
    """Where the camera looks at each drawn sample, and how far it stands.

    Each drawn sample's box holds the robot's link outlines, its contact points and the tips of its
    force arrows. Along x the camera follows the robot: the framed point is the centre of mass
    plus the median offset from it to the box's middle (smooth, unlike the box's middle when a leg
    swings; a massless robot follows its box). Along y the framed point stays at the middle of the
    box around every sample and the surfaces' feet under the first sample's contact points. The
    camera's half-height covers the widest box around its framed point and that height, enlarged by
    :data:`CAMERA_MARGIN`, in the view below the caption (:data:`CAPTION_FRACTION`).
    """
    boxes = []
    for i, pose in zip(samples, poses, strict=True):
        outline = [np.zeros((0, 2)), contact_xy[i].reshape(-1, 2)]
        for link, shapes in visuals.items():
            origin, angle = pose[link]
            outline += [visual_outline(v, pose_matrix(origin, angle)) for v in shapes]
        boxes.append(np.vstack(outline))
    points = [c.point for c in scene.contacts]
    feet = [np.array([line.foot(p) for p in contact_xy[samples[0]]]).reshape(-1, 2)
            for line in surface_lines(points)]
    everything = np.vstack(boxes + feet)
    size = max(float(np.max(everything.max(axis=0) - everything.min(axis=0))), 0.1)
    peak = float(np.max(np.hypot(forces[samples, :, 0], forces[samples, :, 1]), initial=0.0))
    if force_scale is None:
        force_scale = FORCE_ARROW_FRACTION * size / peak if peak > 0 else 0.01
    boxes = [np.vstack([box, (contact_xy[i] + force_scale * forces[i]).reshape(-1, 2)])
             for i, box in zip(samples, boxes, strict=True)]
    everything = np.vstack(boxes + feet)
    lower, upper = everything.min(axis=0), everything.max(axis=0)
    middles = np.array([(box.min(axis=0)[0] + box.max(axis=0)[0]) / 2 for box in boxes])
    if scene.robot.total_mass > 0:
        com_x = np.array([scene.robot.center_of_mass(trajectory.q[i])[0] for i in samples])
        x = com_x + float(np.median(middles - com_x))
    else:
        x = middles
    y = (lower[1] + upper[1]) / 2
    centers = np.column_stack([x, np.full(len(x), y)])
    half_x = max(float(max(np.max(box[:, 0]) - c, c - np.min(box[:, 0])))
                 for box, c in zip(boxes, x, strict=True))
    half = np.array([half_x, (upper[1] - lower[1]) / 2])
    view = CAMERA_MARGIN * max(half[1] / (1.0 - CAPTION_FRACTION), half[0] / CAMERA_ASPECT, 0.05)
    targets = centers + np.array([0.0, CAPTION_FRACTION * view])
    return _Framing(float(force_scale), size, centers, targets, half, lower, upper,
                    float(np.max(x) - np.min(x)), view)


# ------------------------------------------------------------------------------ static pages


class _PageRecorder:
    """Stands in for meshcat's server: keeps the scene tree and builds ``static_html()``.

    It runs meshcat's own server code (``ZMQWebSocketBridge.handle_zmq``) on a duck-typed bridge
    with no sockets, so the page is byte for byte the one a server's ``static_html()`` returns,
    without starting a process or opening a port.
    """

    def __init__(self) -> None:
        from meshcat.servers.tree import SceneTree

        _import_meshcat()
        self.tree = SceneTree()
        self.websocket_pool: set = set()
        self.zmq_socket = self
        self._reply: bytes = b""

    # the bridge's socket and websocket hooks
    def send(self, data: Any) -> None:
        """As the bridge's ZMQ socket: keep the reply; as the Visualizer's window: run a command."""
        if isinstance(data, bytes):
            self._reply = data
            return
        import umsgpack
        from meshcat.servers.zmqserver import ZMQWebSocketBridge

        lowered = data.lower()
        frames = [lowered["type"].encode("utf-8"), lowered["path"].encode("utf-8"),
                  umsgpack.packb(lowered)]
        ZMQWebSocketBridge.handle_zmq(self, frames)
        if self._reply != b"ok":
            raise ViewerServerError(f"the page recorder refused a command: {self._reply!r}")

    def forward_to_websockets(self, frames: Any) -> None:
        """No browser is connected to a recorder."""

    def get_scene(self) -> str:
        """The page meshcat's ``static_html()`` makes of what was drawn."""
        from meshcat.servers.zmqserver import ZMQWebSocketBridge

        ZMQWebSocketBridge.handle_zmq(self, [b"get_scene"])
        return self._reply.decode("utf-8")


def _legend(scene: Scene, drawing: Drawing, contacts: Sequence[str]) -> str:
    """A small caption for the page: scene, force scale, colours; for an animation, its controls."""
    force = f"forces: {drawing.force_scale * 1000:.3g} mm per N ({drawing.force_scale:.3g} m/N)"
    if drawing.modes:
        swatches = " ".join(f'<span style="color:{color}">&#9632;</span>&nbsp;{letter}'
                            for letter, color in colors.MODE_COLORS.items())
        force += f" &middot; modes: {swatches}"
    else:
        force = f'<span style="color:{colors.FORCE_COLOR}">&#9632;</span> ' + force
    if drawing.animated:
        motion = html_lib.escape(mode_heading(contacts)) if contacts else "no contacts"
    else:
        motion = "still: the scene's state"
    return (
        '<div id="frcontrol-legend" style="position:absolute;left:8px;top:8px;'
        'font:12px sans-serif;color:#222;background:rgba(255,255,255,0.8);padding:4px 6px;">'
        f"<b>{html_lib.escape(scene.name)}</b><br>{force}<br>"
        f'<span style="color:{colors.CONE_COLOR}">&#9650;</span> friction cones &middot; '
        f'<span style="color:{colors.CONTACT_COLOR}">&#9679;</span> contacts &middot; {motion}'
        f"{_controls(drawing, contacts) if drawing.animated else ''}</div>"
    )


_CONTROLS_SCRIPT = """
(function () {
  const data = %s;
  const button = document.getElementById("frcontrol-play");
  const slider = document.getElementById("frcontrol-time");
  const readout = document.getElementById("frcontrol-readout");
  const animator = () => (typeof viewer !== "undefined" ? viewer.animator : null);
  function modeAt(t) {
    let i = 0;
    while (i + 1 < data.times.length && data.times[i + 1] <= t + 1e-9) i++;
    return data.modes ? data.modes[i] : null;
  }
  button.addEventListener("click", () => {
    const a = animator();
    if (!a) return;
    if (a.playing) { a.pause(); return; }
    if (a.time >= a.duration - 1e-9) a.reset();
    a.play();
  });
  slider.addEventListener("input", () => {
    const a = animator();
    if (!a) return;
    const t = parseFloat(slider.value);
    if (a.playing) a.pause();
    a.seek(t);
    a.display_progress(t);
  });
  function tick() {
    const a = animator();
    if (a) {
      const t = Math.min(Math.max(a.time, 0), data.duration);
      const mode = modeAt(t);
      button.textContent = a.playing ? "pause" : "play";
      if (document.activeElement !== slider) slider.value = t;
      readout.textContent = "t = " + (data.start + t).toFixed(3) + " s of " +
        (data.start + data.duration).toFixed(3) + " s" + (mode === null ? "" : " \u00b7 mode " + mode);
    }
    requestAnimationFrame(tick);
  }
  requestAnimationFrame(tick);
})();
"""


def _controls(drawing: Drawing, contacts: Sequence[str]) -> str:
    """Play/pause, a time slider, and the time and contact mode as text (reads meshcat's animator).

    The mode reads as every output prints it: each contact's name beside its letter
    (:func:`frcontrol.modes.mode_label`).
    """
    import json

    times = drawing.times - drawing.times[0]
    named = (None if drawing.sample_modes is None or len(contacts) != len(drawing.sample_modes[0])
             else [mode_label(mode, contacts) for mode in drawing.sample_modes])
    data = {"times": times.tolist(), "start": float(drawing.times[0]), "duration": float(times[-1]),
            "modes": None if drawing.sample_modes is None else (named or list(drawing.sample_modes))}
    script = _CONTROLS_SCRIPT % json.dumps(data).replace("</", "<\\/")
    return (
        '<div id="frcontrol-controls" style="margin-top:4px;display:flex;align-items:center;gap:6px;">'
        '<button id="frcontrol-play" type="button" style="width:52px;">pause</button>'
        f'<input id="frcontrol-time" type="range" min="0" max="{float(times[-1])!r}" step="any" value="0" '
        'style="width:200px;" aria-label="time">'
        '<span id="frcontrol-readout" style="font-family:monospace;"></span></div>'
        f"<script>{script}</script>"
    )


def scene_html(
    scene: Scene,
    trajectory: Trajectory | None = None,
    *,
    legend: bool = True,
    **options: Any,
) -> tuple[str, Drawing]:
    """The self-contained HTML page (meshcat's ``static_html()``) of a scene or trajectory.

    Args:
        scene: the scene.
        trajectory: its motion (default: the scene's state, still).
        legend: add a caption (scene name, force scale in m/N, colours) at the bottom left.
        **options: passed to :func:`draw` (``force_scale``, ``modes``, ``fps``, ``cones``).

    Returns:
        (the page, what was drawn).
    """
    meshcat = _import_meshcat()
    recorder = _PageRecorder()
    vis = meshcat.Visualizer(window=recorder)
    drawing = draw(vis, scene, trajectory, **options)
    page = recorder.get_scene()
    if legend:
        end = page.rfind("</body>")
        contacts = trajectory.contacts if trajectory is not None else ()
        page = page[:end] + _legend(scene, drawing, contacts) + page[end:]
    return page, drawing


def write_html(scene: Scene, trajectory: Trajectory | None, path: str | Path, **options: Any) -> Path:
    """Write the self-contained HTML viewer of a scene or trajectory: it replays offline.

    Args:
        scene: the scene.
        trajectory: its motion (None: the scene's state, still).
        path: the file to write (its folder must exist).
        **options: passed to :func:`scene_html` and :func:`draw`.

    Returns:
        The path written.

    Raises:
        InputError: see :func:`draw`.
        OutputFileError: the file cannot be written.
    """
    page, _ = scene_html(scene, trajectory, **options)
    target = Path(path)
    try:
        target.write_text(page, encoding="utf-8")
    except OSError as err:
        raise OutputFileError(target, reason_from_exception(err)) from err
    return target


# ------------------------------------------------------------------------------------- servers

_SERVER_SCRIPT = r"""
import sys
from meshcat.servers.zmqserver import ZMQWebSocketBridge


class LocalBridge(ZMQWebSocketBridge):
    # meshcat's bridge listens on every interface; this one on 127.0.0.1 only.
    def make_app(self):
        app = super().make_app()
        listen = app.listen

        def listen_on_localhost(port, **kwargs):
            return listen(port, address="127.0.0.1", **kwargs)

        app.listen = listen_on_localhost
        return app


port = int(sys.argv[1]) if sys.argv[1] else None
bridge = LocalBridge(host="127.0.0.1", port=port)
print("zmq_url=" + bridge.zmq_url, flush=True)
print("web_url=" + bridge.web_url, flush=True)
bridge.run()
"""


@dataclass(eq=False)
class ViewerServer:
    """A meshcat server process on localhost, started by :func:`start_server`.

    Attributes:
        url: the viewer's page (``http://127.0.0.1:<port>/static/``).
        zmq_url: where the server takes drawing commands.
        port: the page's port.
        process: the server process.
    """

    url: str
    zmq_url: str
    port: int
    process: subprocess.Popen
    _log: Any = None
    _vis: Any = None

    def visualizer(self) -> Any:
        """A ``meshcat.Visualizer`` drawing into this server."""
        if self._vis is None:
            meshcat = _import_meshcat()
            with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints the URL
                self._vis = meshcat.Visualizer(zmq_url=self.zmq_url)
        return self._vis

    def static_html(self) -> str:
        """The server's ``static_html()`` of what it holds."""
        return str(self.visualizer().static_html())

    @property
    def running(self) -> bool:
        """Whether the server process is alive."""
        return self.process.poll() is None

    def stop(self) -> None:
        """Stop the server process (and forget the connection)."""
        if self._vis is not None:
            with contextlib.suppress(Exception):
                self._vis.window.zmq_socket.close(linger=0)
            self._vis = None
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=5)
        if self.process.stdout is not None:
            self.process.stdout.close()
        if self._log is not None:
            self._log.close()
            self._log = None


_SERVERS: dict[str, ViewerServer] = {}
_ATEXIT_REGISTERED = False


def _check_port_free(host: str, port: int) -> None:
    """Raise PortInUse if something listens on (host, port)."""
    probe = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as tornado does
        probe.bind((host, port))
    except OSError as err:
        raise PortInUse(host, port) from err
    finally:
        probe.close()


def start_server(port: int | None = None, *, timeout: float = 30.0) -> ViewerServer:
    """Start a meshcat server on localhost.

    Args:
        port: the page's port; None lets meshcat take the first free port from 7000.
        timeout: [s] how long to wait for the server to come up.

    Returns:
        The running server (stop it with :meth:`ViewerServer.stop`).

    Raises:
        InputError: ``port`` is not an integer in 1..65535.
        PortInUse: ``port`` is taken.
        ViewerServerError: the server did not start.
    """
    if port is not None and (isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535):
        raise InputError(f"port must be an integer from 1 to 65535, got {port!r}")
    if port is not None:
        _check_port_free(HOST, port)
    log = tempfile.TemporaryFile(mode="w+b")
    process = subprocess.Popen(
        [sys.executable, "-u", "-c", _SERVER_SCRIPT, "" if port is None else str(port)],
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=log, start_new_session=True,
    )
    urls: dict[str, str] = {}

    def read_urls() -> None:
        if process.stdout is None:
            return
        for raw in process.stdout:
            line = raw.decode("utf-8", "replace").strip()
            key, _, value = line.partition("=")
            if key in ("zmq_url", "web_url"):
                urls[key] = value
            if "web_url" in urls:
                return

    reader = threading.Thread(target=read_urls, daemon=True)
    reader.start()
    reader.join(timeout)
    if "web_url" not in urls or "zmq_url" not in urls:
        if process.poll() is None:
            process.kill()
        process.wait(timeout=5)
        log.seek(0)
        errors = log.read().decode("utf-8", "replace")
        log.close()
        if process.stdout is not None:
            process.stdout.close()
        if port is not None and "Address already in use" in errors:
            raise PortInUse(HOST, port)
        last = errors.strip().splitlines()[-1] if errors.strip() else "no message"
        raise ViewerServerError(
            f"the server did not start within {timeout:g} s (exit code {process.returncode}): {last}"
        )
    url = urls["web_url"]
    try:
        actual_port = int(url.rsplit(":", 1)[1].split("/", 1)[0])
    except (IndexError, ValueError):
        actual_port = port or 0
    global _ATEXIT_REGISTERED
    if not _ATEXIT_REGISTERED:
        atexit.register(stop_server)
        _ATEXIT_REGISTERED = True
    server = ViewerServer(url=url, zmq_url=urls["zmq_url"], port=actual_port, process=process, _log=log)
    _SERVERS[url] = server
    return server


def serve(
    scene: Scene,
    trajectory: Trajectory | None = None,
    port: int | None = None,
    *,
    timeout: float = 30.0,
    **options: Any,
) -> str:
    """Start a meshcat server on localhost, draw (and animate) into it, and return its URL.

    The server runs in a child process until :func:`stop_server` is called or this Python
    process exits.

    Args:
        scene: the scene.
        trajectory: its motion (default: the scene's state, still).
        port: the page's port; None lets meshcat take the first free port from 7000.
        timeout: [s] how long to wait for the server to come up.
        **options: passed to :func:`draw`.

    Returns:
        The viewer's URL, e.g. ``http://127.0.0.1:7000/static/``.

    Raises:
        InputError: see :func:`draw`; a bad port.
        PortInUse: ``port`` is taken.
        ViewerServerError: the server did not start.
    """
    check_trajectory(scene, trajectory_from_scene(scene) if trajectory is None else trajectory)
    server = start_server(port, timeout=timeout)
    try:
        draw(server.visualizer(), scene, trajectory, **options)
    except BaseException:
        stop_server(server.url)
        raise
    return server.url


def redraw(url: str, scene: Scene, trajectory: Trajectory | None = None, **options: Any) -> Drawing:
    """Draw a scene again into the server at ``url`` (started here), replacing what it showed.

    This is what ``frc view --view --watch`` does when the scene file changes.

    Raises:
        ViewerServerError: no server started here has that URL.
        InputError: see :func:`draw`.
    """
    return draw(server_at(url).visualizer(), scene, trajectory, **options)


def server_at(url: str) -> ViewerServer:
    """The running server started here whose page is at ``url``.

    Raises:
        ViewerServerError: no server started here has that URL, or it has stopped.
    """
    server = _SERVERS.get(url)
    if server is None or not server.running:
        raise ViewerServerError(f"no running viewer server started here at {url}")
    return server


def stop_server(url: str | None = None) -> None:
    """Stop the meshcat server at ``url`` started here (None: every one); unknown URLs are ignored."""
    for key in list(_SERVERS) if url is None else [url]:
        server = _SERVERS.pop(key, None)
        if server is not None:
            server.stop()
