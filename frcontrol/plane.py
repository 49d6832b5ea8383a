r"""A plane of a 3-D robot as a planar robot: the URDF re-expressed so that its links move in x-y.

A 3-D URDF (a quadruped from example-robot-data, say) whose joints that move all turn about one
world axis moves in the planes normal to that axis. :func:`planar_urdf` writes the same robot,
link for link and joint for joint, in the frame of a chosen plane, so that
:class:`~frcontrol.model.PlanarRobot` reads it like any planar URDF.

**The plane.** ``plane = "ab"`` (two distinct letters of x, y, z) maps the 3-D world axis ``a`` to
the planar x and ``b`` to the planar y (up: gravity acts along -b); the plane's normal, the planar
z, is ``e_a x e_b``. ``"xz"`` is the sagittal plane of a robot whose x points forward and z up: its
normal is ``x x z = -y``, so the planar angle theta of the base is *minus* its 3-D pitch about y,
and a joint about +y turns about the planar -z (its angle keeps its sign and its zero). The rows of
:func:`plane_rotation` are the three planar axes in world coordinates: a world vector ``w`` has the
planar coordinates ``P w``.

**The reference pose.** Every joint at 0, except the ``locked`` joints, at their given value [rad]
(or [m]); the robot's root link at the world origin. At that pose each link's new frame has the
old one's origin and the plane's axes: a vector of the link, ``x`` in the old frame, is ``A x`` in
the new, with ``A = P R`` (R: the link's rotation in the world at the reference pose).

**What is written.** Every joint keeps its name, type and parents. A joint's origin becomes the
child's reference position relative to the parent's, in the plane's axes, with no rotation; its
axis becomes ``A`` times the old one (the child's A). Locked joints become ``fixed``. Every link
keeps its mass; its centre of mass ``A c`` and its inertia ``A I A^T`` are the old ones in the new
axes (the full tensor: the planar dynamics read the mass, the in-plane centre of mass and
``I_zz`` about the normal, and the rest changes nothing in the plane). Visuals keep their shapes,
posed in the new frames; meshes are named by absolute ``file://`` paths (a ``package://`` mesh not
found beside the URDF is left out, and the viewer draws that link's fallback box). Collision
elements are left out (frcontrol does not use them).

**Why this is exact.** A joint that turns about the plane's normal turns its subtree about a line
normal to the plane, which keeps every new frame's axes parallel to the plane's: so the written
robot, on the planar base (x, y, theta), moves exactly as the 3-D robot does when its root moves in
the plane (position ``P^T (x, y, 0)``, rotation ``P^T Rz(theta) P``) with the same joint angles.
Its mass matrix is the 3-D one restricted to those motions, ``J^T M_3 J``: the tests check that
against Pinocchio's 3-D model.

**Checks.** Every joint that moves (not fixed, not locked) must turn about the plane's normal
(revolute, continuous) or slide in the plane (prismatic), to :data:`PLANE_NORMAL_TOLERANCE`; one
that does not is an error naming it (lock it, or choose another plane). ``floating`` and
``planar`` joints are errors (frcontrol adds the planar base). The URDF must have one root link.
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from functools import lru_cache
from importlib import metadata
from pathlib import Path

import numpy as np

from .errors import RobotModelError
from .scene_schema import nearest
from .urdf import UrdfDocument, UrdfJoint, UrdfVisual, read_urdf, resolve_mesh

__all__ = [
    "EXAMPLE_ROBOT_DATA_PREFIX",
    "PLANES",
    "PLANE_NORMAL_TOLERANCE",
    "example_robot_data_dir",
    "example_robot_data_robots",
    "example_robot_data_urdf",
    "planar_urdf",
    "plane_rotation",
    "reference_poses",
    "rpy_from_matrix",
]

PLANES = ("xz", "yz", "xy", "zx", "zy", "yx")
"""The planes a 3-D robot may be mapped onto: the world axes that become the planar x and y."""

PLANE_NORMAL_TOLERANCE = 1e-9
"""[-] How far a moving joint's unit axis may lean off the plane's normal (revolute, continuous:
``1 - |a . n|``) or out of the plane (prismatic: ``|a . n|``) at the reference pose."""

EXAMPLE_ROBOT_DATA_PREFIX = "example-robot-data:"
"""A scene's ``robot`` that starts with this names a robot of the example-robot-data package."""

_GIMBAL_LOCK = 1e-12
"""[-] cos(pitch) at or below which roll and yaw are not separable (yaw is then set to 0)."""

_ERD_ROBOTS = "cmeel.prefix/share/example-robot-data/robots"
_CACHE_FOLDER = "frcontrol-planar-urdf"


def plane_rotation(plane: str) -> np.ndarray:
    """P (3x3): its rows are the planar x, y and z (the normal) in the 3-D world's coordinates.

    Raises:
        RobotModelError: ``plane`` is not one of :data:`PLANES`.
    """
    if plane not in PLANES:
        raise RobotModelError("plane", f"unknown plane {plane!r}: expected one of {', '.join(PLANES)} "
                              "(the world axes that become the planar x and y, y up)")
    axes = np.eye(3)
    first, second = axes["xyz".index(plane[0])], axes["xyz".index(plane[1])]
    return np.array([first, second, np.cross(first, second)])


# ------------------------------------------------------------------------------ example-robot-data
def example_robot_data_dir() -> Path:
    """The folder of the example-robot-data package's robots (``share/example-robot-data/robots``).

    Raises:
        RobotModelError: the package is not installed.
    """
    try:
        dist = metadata.distribution("example-robot-data")
    except metadata.PackageNotFoundError as err:
        raise RobotModelError("example-robot-data", "the package is not installed: "
                              "pip install example-robot-data") from err
    folder = Path(str(dist.locate_file(_ERD_ROBOTS)))
    if not folder.is_dir():
        raise RobotModelError("example-robot-data", f"no robots folder at {folder}: reinstall it "
                              "(pip install --force-reinstall example-robot-data)")
    return folder


def example_robot_data_robots() -> dict[str, Path]:
    """Every URDF of example-robot-data by the names a scene may use.

    ``DESCRIPTION/NAME`` always (``solo/solo12``: the folder ``solo_description``, the file
    ``solo12.urdf``), and the bare ``NAME`` when no other folder has a file of that name.
    """
    found: dict[str, Path] = {}
    stems: dict[str, list[Path]] = {}
    for urdf in sorted(example_robot_data_dir().glob("*/*/*.urdf")):
        package = urdf.parent.parent.name.removesuffix("_description")
        found[f"{package}/{urdf.stem}"] = urdf
        stems.setdefault(urdf.stem, []).append(urdf)
    for stem, paths in stems.items():
        if len(paths) == 1 and stem not in found:
            found[stem] = paths[0]
    return found


def example_robot_data_urdf(reference: str) -> Path:
    """The URDF a scene's ``robot = "example-robot-data:NAME"`` names.

    Raises:
        RobotModelError: the package is not installed, or has no robot of that name (the message
            gives the nearest names).
    """
    name = reference.removeprefix(EXAMPLE_ROBOT_DATA_PREFIX)
    robots = example_robot_data_robots()
    if name in robots:
        return robots[name]
    guess = nearest(name, list(robots))
    hint = f"did you mean {EXAMPLE_ROBOT_DATA_PREFIX}{guess}? " if guess else ""
    bare = sorted(n for n in robots if "/" not in n)
    raise RobotModelError(reference, f"example-robot-data has no robot {name!r}; {hint}its robots: "
                          f"{', '.join(bare)} (or DESCRIPTION/NAME, e.g. solo/solo12)")


# ------------------------------------------------------------------------------ the reference pose
def _rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: the rotation by ``angle`` [rad] about the unit ``axis``."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def _joint_motion(joint: UrdfJoint, value: float) -> np.ndarray:
    """The 4x4 motion of a joint at ``value`` [rad or m], in its own frame."""
    motion = np.eye(4)
    if joint.kind in ("revolute", "continuous"):
        motion[:3, :3] = _rotation_about(joint.axis, value)
    elif joint.kind == "prismatic":
        motion[:3, 3] = joint.axis * value
    return motion


def _tree(document: UrdfDocument) -> tuple[str, dict[str, list[UrdfJoint]]]:
    """The root link and each link's child joints.

    Raises:
        RobotModelError: no root link or several, or a floating or planar joint.
    """
    shown = str(document.path)
    children: dict[str, list[UrdfJoint]] = {}
    child_links = set()
    for joint in document.joints:
        if joint.kind in ("floating", "planar"):
            raise RobotModelError(shown, f"joint {joint.name!r} is {joint.kind}: remove it, frcontrol "
                                  "adds the planar base (x, y, theta) itself")
        children.setdefault(joint.parent, []).append(joint)
        child_links.add(joint.child)
    roots = [link for link in document.links if link not in child_links]
    if len(roots) != 1:
        raise RobotModelError(shown, f"expected one root link, found {len(roots)}: {', '.join(roots)}")
    return roots[0], children


def reference_poses(document: UrdfDocument, locked: Mapping[str, float]) -> dict[str, np.ndarray]:
    """Each link's 4x4 pose in the world at the reference pose (joints at 0 but the locked ones).

    Raises:
        RobotModelError: see :func:`_tree`.
    """
    root, children = _tree(document)
    poses = {root: np.eye(4)}
    stack = [root]
    while stack:
        parent = stack.pop()
        for joint in children.get(parent, []):
            value = float(locked.get(joint.name, 0.0))
            poses[joint.child] = poses[parent] @ joint.origin @ _joint_motion(joint, value)
            stack.append(joint.child)
    return poses


def rpy_from_matrix(rotation: np.ndarray) -> tuple[float, float, float]:
    """URDF's (roll, pitch, yaw) [rad] of a rotation, ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    cos_pitch = math.hypot(float(rotation[0, 0]), float(rotation[1, 0]))
    pitch = math.atan2(-float(rotation[2, 0]), cos_pitch)  # accurate near +-pi/2, unlike asin
    if cos_pitch > _GIMBAL_LOCK:
        roll = math.atan2(float(rotation[2, 1]), float(rotation[2, 2]))
        yaw = math.atan2(float(rotation[1, 0]), float(rotation[0, 0]))
    else:  # gimbal lock: only roll - yaw (or roll + yaw) is defined; take yaw = 0
        roll = math.atan2(-float(rotation[1, 2]), float(rotation[1, 1]))
        yaw = 0.0
    return roll, pitch, yaw


# ------------------------------------------------------------------------------ the planar URDF
def _check_joint(shown: str, joint: UrdfJoint, axis: np.ndarray, plane: str) -> None:
    """A moving joint's new axis (planar coordinates) is normal to the plane, or in it (prismatic)."""
    along = abs(float(axis[2]))
    if joint.kind in ("revolute", "continuous") and 1.0 - along > PLANE_NORMAL_TOLERANCE:
        raise RobotModelError(shown, f"joint {joint.name!r} does not turn about the normal of plane "
                              f"{plane!r} (its axis in the plane's x, y, z: {np.round(axis, 6).tolist()}): "
                              f"lock it (plane_locked = {{{joint.name} = ANGLE}}) or choose another plane")
    if joint.kind == "prismatic" and along > PLANE_NORMAL_TOLERANCE:
        raise RobotModelError(shown, f"joint {joint.name!r} does not slide in plane {plane!r} (its axis "
                              f"in the plane's x, y, z: {np.round(axis, 6).tolist()}): lock it "
                              f"(plane_locked = {{{joint.name} = POSITION}}) or choose another plane")


def _numbers(values: np.ndarray | tuple[float, ...]) -> str:
    return " ".join(repr(float(x)) for x in values)


def _origin_element(parent: ET.Element, pose: np.ndarray) -> None:
    ET.SubElement(parent, "origin", xyz=_numbers(pose[:3, 3]), rpy=_numbers(rpy_from_matrix(pose[:3, :3])))


def _visual_element(link: ET.Element, visual: UrdfVisual, to_new: np.ndarray, urdf_dir: Path) -> None:
    """A ``<visual>`` posed in the link's new frame (``to_new``: the old frame in the new, 4x4)."""
    geometry_tag: tuple[str, dict[str, str]]
    if visual.shape == "box":
        geometry_tag = ("box", {"size": _numbers(visual.size)})
    elif visual.shape == "cylinder":
        geometry_tag = ("cylinder", {"radius": repr(float(visual.size[0])),
                                     "length": repr(float(visual.size[1]))})
    elif visual.shape == "sphere":
        geometry_tag = ("sphere", {"radius": repr(float(visual.size[0]))})
    else:
        mesh = resolve_mesh(visual.mesh_filename, urdf_dir)
        if mesh is None:
            return
        geometry_tag = ("mesh", {"filename": mesh.resolve().as_uri(), "scale": _numbers(visual.size)})
    element = ET.SubElement(link, "visual")
    _origin_element(element, to_new @ visual.origin)
    ET.SubElement(ET.SubElement(element, "geometry"), geometry_tag[0], geometry_tag[1])
    if visual.rgba is not None:
        material = ET.SubElement(element, "material", name=f"{visual.link}_color")
        ET.SubElement(material, "color", rgba=_numbers(visual.rgba))


def _link_element(robot: ET.Element, document: UrdfDocument, name: str, turn: np.ndarray) -> None:
    """A link re-expressed in its new frame (``turn``: A, old link axes to the new)."""
    link = ET.SubElement(robot, "link", name=name)
    to_new = np.eye(4)
    to_new[:3, :3] = turn
    inertial = document.inertials.get(name)
    if inertial is not None:
        element = ET.SubElement(link, "inertial")
        pose = to_new @ inertial.origin
        ET.SubElement(element, "origin", xyz=_numbers(pose[:3, 3]), rpy="0 0 0")
        ET.SubElement(element, "mass", value=repr(float(inertial.mass)))
        rotation = pose[:3, :3]
        tensor = rotation @ inertial.inertia @ rotation.T
        entries = {key: repr(float(tensor[i, j])) for key, (i, j) in
                   (("ixx", (0, 0)), ("ixy", (0, 1)), ("ixz", (0, 2)), ("iyy", (1, 1)), ("iyz", (1, 2)),
                    ("izz", (2, 2)))}
        ET.SubElement(element, "inertia", entries)
    for visual in document.visuals.get(name, ()):
        _visual_element(link, visual, to_new, document.path.parent)


def planar_urdf_text(source: str | Path, plane: str, locked: Mapping[str, float] | None = None) -> str:
    """The planar URDF of the 3-D robot at ``source`` in ``plane`` (see the module's docstring).

    Args:
        source: the 3-D URDF.
        plane: one of :data:`PLANES`.
        locked: joints welded at a value [rad or m] before the mapping (by name).

    Raises:
        RobotModelError: the URDF cannot be read, the plane is unknown, a locked joint is unknown or
            fixed, a moving joint is not normal to the plane (named), or the tree is not one tree.
    """
    document = read_urdf(source)
    shown = str(source)
    locked = dict(locked or {})
    movable = [j.name for j in document.movable_joints]
    for name in locked:
        if name not in movable:
            guess = nearest(name, movable)
            hint = f"did you mean {guess!r}? " if guess else ""
            raise RobotModelError(shown, f"cannot lock {name!r}: no joint of that name moves; {hint}"
                                  f"the joints are: {', '.join(movable)}")
    rotation = plane_rotation(plane)
    poses = reference_poses(document, locked)
    turns = {link: rotation @ pose[:3, :3] for link, pose in poses.items()}
    robot = ET.Element("robot", name=f"{document.name}_{plane}")
    for link in document.links:
        if link in poses:
            _link_element(robot, document, link, turns[link])
    for joint in document.joints:
        if joint.parent not in poses:
            continue
        kind = "fixed" if joint.name in locked else joint.kind
        element = ET.SubElement(robot, "joint", name=joint.name, type=kind)
        ET.SubElement(element, "parent", link=joint.parent)
        ET.SubElement(element, "child", link=joint.child)
        offset = rotation @ (poses[joint.child][:3, 3] - poses[joint.parent][:3, 3])
        ET.SubElement(element, "origin", xyz=_numbers(offset), rpy="0 0 0")
        if kind == "fixed":
            continue
        axis = turns[joint.child] @ joint.axis
        _check_joint(shown, joint, axis, plane)
        ET.SubElement(element, "axis", xyz=_numbers(np.round(axis, 12) + 0.0))
        limit = _limit_of(document.path, joint.name)
        if limit is not None:
            element.append(limit)
    ET.indent(robot)
    header = (f"<!-- {document.name} ({Path(source).name}) in plane {plane}, written by frcontrol.plane: "
              f"locked {locked or 'nothing'} -->\n")
    return header + ET.tostring(robot, encoding="unicode") + "\n"


def _limit_of(path: Path, joint: str) -> ET.Element | None:
    """The joint's ``<limit>`` element as the file gives it (Pinocchio needs one on revolute joints)."""
    for element in ET.parse(path).getroot().findall("joint"):
        if element.get("name") == joint:
            return element.find("limit")
    return None


def planar_urdf(source: str | Path, plane: str, locked: Mapping[str, float] | None = None) -> Path:
    """The planar URDF of :func:`planar_urdf_text`, written once to a cache file: its path.

    The file lies in the system's temporary folder, named by a digest of the source's text, the
    plane and the locked joints; it is written atomically (several processes may ask at once).

    ``source`` may be a reference ``example-robot-data:NAME`` (:func:`example_robot_data_urdf`).

    Raises:
        RobotModelError: see :func:`planar_urdf_text` and :func:`example_robot_data_urdf`, or the
            file cannot be written.
    """
    if str(source).startswith(EXAMPLE_ROBOT_DATA_PREFIX):
        source = example_robot_data_urdf(str(source))
    resolved = Path(source).resolve()
    try:
        info = resolved.stat()
    except OSError as err:
        raise RobotModelError(str(source), f"cannot read URDF: {err}") from err
    items = tuple(sorted((str(k), float(v)) for k, v in (locked or {}).items()))
    key = (str(resolved), info.st_mtime_ns, info.st_size, plane, items)
    target = _written(*key)
    if not target.is_file():  # removed since this process wrote it (a cleaned temporary folder)
        _written.cache_clear()
        target = _written(*key)
    return target


@lru_cache(maxsize=32)
def _written(resolved: str, mtime_ns: int, size: int, plane: str, locked: tuple[tuple[str, float], ...]
             ) -> Path:
    text = planar_urdf_text(resolved, plane, dict(locked))
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    folder = Path(tempfile.gettempdir()) / _CACHE_FOLDER
    target = folder / f"{Path(resolved).stem}_{plane}_{digest}.urdf"
    if target.is_file():
        return target
    try:
        folder.mkdir(parents=True, exist_ok=True)
        handle, scratch = tempfile.mkstemp(dir=folder, suffix=".part")
        with os.fdopen(handle, "w", encoding="utf-8") as stream:
            stream.write(text)
        os.replace(scratch, target)
    except OSError as err:
        raise RobotModelError(resolved, f"cannot write the planar URDF to {folder}: {err}") from err
    return target
