"""The one URDF reader of frcontrol: joints in document order, links, visuals and materials.

A URDF file is parsed once per version (cached by its resolved path, modification time and size)
with the standard library's ElementTree: :mod:`frcontrol.model` takes the movable joints' order
and axes from it (Pinocchio builds the dynamics from the same file), and :mod:`frcontrol.viz`
takes the visuals. Only what frcontrol reads is parsed; a malformed value raises
:class:`~frcontrol.errors.RobotModelError` naming the file, the element and the value.

Poses follow URDF: ``<origin xyz="x y z" rpy="roll pitch yaw"/>`` is the 4x4 transform
``T(xyz) Rz(yaw) Ry(pitch) Rx(roll)``; a missing origin is the identity.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from .errors import RobotModelError

__all__ = ["BASE_COORDINATES", "INERTIA_TOLERANCE", "RobotOutline", "UrdfDocument", "UrdfInertial",
           "UrdfJoint", "UrdfVisual", "read_urdf", "resolve_mesh", "robot_outline"]

BASE_COORDINATES = ("x", "y", "theta")
"""Names of the planar base's coordinates: position [m] of the root link's frame and its angle
[rad], counter-clockwise from the world x axis."""

INERTIA_TOLERANCE = 1e-9
"""How far [-, relative to the largest eigenvalue's magnitude] the smallest eigenvalue of a link's
rotational inertia may fall below zero (round-off of a rotated tensor) before the link is rejected
as having an indefinite inertia. A zero mass (a massless link) and a zero I_zz (a point mass) are
physical; a negative mass or a negative eigenvalue is not."""


@dataclass(frozen=True, eq=False)
class UrdfJoint:
    """A joint as the file gives it.

    Attributes:
        name: the joint's name.
        kind: ``revolute``, ``continuous``, ``prismatic``, ``fixed``, ``floating`` or ``planar``.
        parent: the parent link's name.
        child: the child link's name.
        origin: the child frame's pose in the parent's, 4x4 [m].
        axis: the unit axis (3,) in the joint frame (``1 0 0`` when the file gives none).
    """

    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray


@dataclass(frozen=True, eq=False)
class UrdfVisual:
    """One ``<visual>`` of a link.

    Attributes:
        link: the link's name.
        shape: ``box``, ``cylinder``, ``sphere`` or ``mesh``.
        size: box (x, y, z) [m]; cylinder (radius, length) [m]; sphere (radius,) [m]; mesh: its
            scale (x, y, z).
        origin: the shape's pose in the link frame, 4x4 [m].
        rgba: its colour (inline, or the named material's), or None.
        mesh_filename: the mesh's file name as written (``shape == "mesh"``), else "".
    """

    link: str
    shape: str
    size: tuple[float, ...]
    origin: np.ndarray
    rgba: tuple[float, float, float, float] | None
    mesh_filename: str = ""


@dataclass(frozen=True, eq=False)
class UrdfInertial:
    """The ``<inertial>`` of a link.

    Attributes:
        link: the link's name.
        mass: [kg].
        origin: the inertial frame's pose in the link frame, 4x4 [m] (its origin is the centre of
            mass).
        inertia: the rotational inertia about the centre of mass, in the inertial frame, 3x3
            [kg m^2].
    """

    link: str
    mass: float
    origin: np.ndarray
    inertia: np.ndarray


@dataclass(frozen=True, eq=False)
class UrdfDocument:
    """What frcontrol reads from a URDF file.

    Attributes:
        path: the file.
        name: the robot's name.
        links: link names, in document order.
        joints: every joint, in document order.
        visuals: link name -> its visuals, in document order.
        inertials: link name -> its inertial (links without one are absent).
    """

    path: Path
    name: str
    links: tuple[str, ...]
    joints: tuple[UrdfJoint, ...]
    visuals: dict[str, tuple[UrdfVisual, ...]]
    inertials: dict[str, UrdfInertial] = field(default_factory=dict)

    @property
    def movable_joints(self) -> tuple[UrdfJoint, ...]:
        """The joints that are not fixed, in document order."""
        return tuple(j for j in self.joints if j.kind != "fixed")


@dataclass(frozen=True)
class RobotOutline:
    """The names a URDF, a base and locked joints give a robot: what a scene is checked against.

    The robot's model (:class:`~frcontrol.model.PlanarRobot`) has the same coordinates and joints
    in the same order; reading them here builds no model.

    Attributes:
        joint_names: the movable joints, in document order.
        coordinate_names: the minimal coordinates: the base's (x, y, theta), then the joints.
        link_names: the links, in document order.
        force_units: the unit of a generalized force on each coordinate: ``"N"`` on x, y and a
            prismatic joint, ``"N m"`` on theta and a revolute one.
    """

    joint_names: tuple[str, ...]
    coordinate_names: tuple[str, ...]
    link_names: tuple[str, ...]
    force_units: tuple[str, ...]


def robot_outline(path: str | Path, base: str = "planar") -> RobotOutline:
    """The :class:`RobotOutline` of the URDF at ``path`` on a ``"planar"`` or ``"fixed"`` base.

    No joint is locked (a scene's loader leaves out the joints it locks).

    Args:
        path: the URDF.
        base: ``"planar"`` (the coordinates x, y, theta first) or ``"fixed"``.

    Raises:
        RobotModelError: the file cannot be read or parsed (:func:`read_urdf`).
    """
    document = read_urdf(path)
    joints = [j for j in document.joints if j.kind != "fixed"]
    names = tuple(j.name for j in joints)
    units = tuple("N" if j.kind == "prismatic" else "N m" for j in joints)
    if base == "planar":
        return RobotOutline(names, BASE_COORDINATES + names, document.links, ("N", "N", "N m") + units)
    return RobotOutline(names, names, document.links, units)


def read_urdf(path: str | Path) -> UrdfDocument:
    """The URDF at ``path``, parsed once per version of the file.

    Raises:
        RobotModelError: the file cannot be read or parsed, its root is not ``<robot>``, a
            value frcontrol reads is malformed (an axis, an origin, a size, a colour), or a link's
            mass is negative or its inertia indefinite (:func:`_check_inertial`).
    """
    resolved = Path(path).resolve()
    try:
        info = resolved.stat()
    except OSError as err:
        raise RobotModelError(str(path), f"cannot read URDF: {err}") from err
    return _read(str(resolved), info.st_mtime_ns, info.st_size, str(path))


@lru_cache(maxsize=64)
def _read(resolved: str, mtime_ns: int, size: int, shown: str) -> UrdfDocument:
    try:
        root = ET.parse(resolved).getroot()
    except (ET.ParseError, OSError) as err:
        raise RobotModelError(shown, f"cannot read URDF: {err}") from err
    if root.tag != "robot":
        raise RobotModelError(shown, f"root element is <{root.tag}>, expected <robot>")
    materials = {}
    for material in root.findall("material"):
        rgba = _color(material, shown)
        if material.get("name") and rgba is not None:
            materials[material.get("name")] = rgba
    links, visuals, inertials = [], {}, {}
    for link in root.findall("link"):
        name = link.get("name", "")
        links.append(name)
        visuals[name] = tuple(v for v in (_visual(name, element, materials, shown)
                                          for element in link.findall("visual")) if v is not None)
        if (inertial := link.find("inertial")) is not None:
            inertials[name] = _inertial(name, inertial, shown)
    joints = []
    for joint in root.findall("joint"):
        name = joint.get("name", "")
        axis_element = joint.find("axis")
        text = axis_element.get("xyz", "1 0 0") if axis_element is not None else "1 0 0"
        axis = _numbers(text, 3, shown, f"joint {name!r}: bad axis {text!r}")
        if np.linalg.norm(axis) == 0.0:
            raise RobotModelError(shown, f"joint {name!r}: bad axis {text!r}")
        parent, child = joint.find("parent"), joint.find("child")
        joints.append(UrdfJoint(
            name=name, kind=joint.get("type", ""),
            parent="" if parent is None else parent.get("link", ""),
            child="" if child is None else child.get("link", ""),
            origin=_origin(joint.find("origin"), shown, f"joint {name!r}"),
            axis=axis / np.linalg.norm(axis),
        ))
    return UrdfDocument(Path(resolved), root.get("name", ""), tuple(links), tuple(joints), visuals,
                        inertials)


def _inertial(link: str, element: ET.Element, shown: str) -> UrdfInertial:
    """An ``<inertial>``: mass (0 when absent), origin and inertia (zeros when absent)."""
    where = f"link {link!r} inertial"
    mass_element = element.find("mass")
    text = "0" if mass_element is None else mass_element.get("value", "0")
    mass = float(_numbers(text, 1, shown, f"{where}: bad mass {text!r}")[0])
    inertia = np.zeros((3, 3))
    if (tensor := element.find("inertia")) is not None:
        keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        text = " ".join(tensor.get(key, "0") for key in keys)
        ixx, ixy, ixz, iyy, iyz, izz = _numbers(text, 6, shown, f"{where}: bad inertia {text!r}")
        inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    _check_inertial(link, mass, inertia, shown)
    return UrdfInertial(link, mass, _origin(element.find("origin"), shown, where), inertia)


def _check_inertial(link: str, mass: float, inertia: np.ndarray, shown: str) -> None:
    """Reject a link whose mass is negative or whose inertia tensor has a negative eigenvalue.

    The planar dynamics see the mass and the inertia about the plane's normal; both must be >= 0
    for M(q) to be positive semi-definite. A zero mass is a massless link and a zero inertia a
    point mass, both supported (M may then be singular: :mod:`frcontrol.response`). The whole
    tensor is checked, to :data:`INERTIA_TOLERANCE`, so that its z component is >= 0 in any frame.

    Raises:
        RobotModelError: naming the link and the offending value.
    """
    if mass < 0.0:
        raise RobotModelError(shown, f"link {link!r} has mass {mass:g} kg; a link's mass must be "
                              ">= 0 (0 for a massless link)")
    eigenvalues = np.linalg.eigvalsh(inertia)
    if eigenvalues[0] < -INERTIA_TOLERANCE * float(np.abs(eigenvalues).max()):
        raise RobotModelError(shown, f"link {link!r} has an indefinite inertia (smallest eigenvalue "
                              f"{eigenvalues[0]:.6g} kg m^2, izz {inertia[2, 2]:g} kg m^2); a link's "
                              "inertia must be positive semi-definite (all zeros for a massless link)")


def _numbers(text: str, count: int, shown: str, message: str) -> np.ndarray:
    try:
        values = np.array([float(s) for s in text.split()], dtype=float)
    except ValueError as err:
        raise RobotModelError(shown, message) from err
    if values.shape != (count,) or not np.all(np.isfinite(values)):
        raise RobotModelError(shown, message)
    return values


def _origin(element: ET.Element | None, shown: str, where: str) -> np.ndarray:
    """The 4x4 pose of an ``<origin>`` (identity when absent)."""
    matrix = np.eye(4)
    if element is None:
        return matrix
    xyz_text, rpy_text = element.get("xyz", "0 0 0"), element.get("rpy", "0 0 0")
    xyz = _numbers(xyz_text, 3, shown, f"{where}: bad origin xyz {xyz_text!r}")
    roll, pitch, yaw = _numbers(rpy_text, 3, shown, f"{where}: bad origin rpy {rpy_text!r}")
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    matrix[:3, :3] = [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                      [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                      [-sp, cp * sr, cp * cr]]
    matrix[:3, 3] = xyz
    return matrix


def _color(material: ET.Element | None, shown: str) -> tuple[float, float, float, float] | None:
    if material is None:
        return None
    color = material.find("color")
    if color is None or color.get("rgba") is None:
        return None
    text = color.get("rgba", "")
    values = _numbers(text, 4, shown, f"material {material.get('name', '')!r}: bad rgba {text!r}")
    return (float(values[0]), float(values[1]), float(values[2]), float(values[3]))


def _visual(link: str, element: ET.Element, materials: dict, shown: str) -> UrdfVisual | None:
    """A ``<visual>``, or None when it has no geometry frcontrol knows."""
    geometry = element.find("geometry")
    if geometry is None:
        return None
    where = f"link {link!r} visual"
    origin = _origin(element.find("origin"), shown, where)
    material = element.find("material")
    rgba = _color(material, shown)
    if rgba is None and material is not None:
        rgba = materials.get(material.get("name", ""))
    if (box := geometry.find("box")) is not None:
        size = _numbers(box.get("size", ""), 3, shown, f"{where}: bad box size {box.get('size')!r}")
        return UrdfVisual(link, "box", tuple(float(s) for s in size), origin, rgba)
    if (cylinder := geometry.find("cylinder")) is not None:
        radius = _numbers(cylinder.get("radius", ""), 1, shown, f"{where}: bad cylinder radius")
        length = _numbers(cylinder.get("length", ""), 1, shown, f"{where}: bad cylinder length")
        return UrdfVisual(link, "cylinder", (float(radius[0]), float(length[0])), origin, rgba)
    if (sphere := geometry.find("sphere")) is not None:
        radius = _numbers(sphere.get("radius", ""), 1, shown, f"{where}: bad sphere radius")
        return UrdfVisual(link, "sphere", (float(radius[0]),), origin, rgba)
    if (mesh := geometry.find("mesh")) is not None:
        text = mesh.get("scale")
        scale: tuple[float, ...] = (1.0, 1.0, 1.0)
        if text is not None:
            values = [float(v) for v in _numbers(text, len(text.split()), shown, f"{where}: bad mesh scale")]
            if len(values) not in (1, 3):
                raise RobotModelError(shown, f"{where}: bad mesh scale {text!r}")
            scale = tuple(values * 3) if len(values) == 1 else tuple(values)
        return UrdfVisual(link, "mesh", scale, origin, rgba, mesh.get("filename", ""))
    return None


def resolve_mesh(filename: str, urdf_dir: Path) -> Path | None:
    """A mesh file named by a URDF, or None when it is not found.

    ``package://pkg/rel`` is looked up beside the URDF and in its parents, without and then with
    ``pkg``; ``file://abs`` and paths relative to the URDF are taken as they are.
    """
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
