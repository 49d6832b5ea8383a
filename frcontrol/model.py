"""The planar multi-rigid-body model on Pinocchio, and contact kinematics at a state.

One :class:`PlanarRobot` owns a Pinocchio model and its data, built from a URDF whose links move in
the world's x-y plane (y up, revolute axes along z) on either a floating planar base or a fixed
base. Its coordinates are *minimal*: ``q = [x, y, theta, joints...]`` for a planar base (theta
counter-clockwise), ``q = [joints...]`` for a fixed one, and ``v = dq/dt``. The equations of motion
(docs/maths.md, *Equations of motion*) are::

    M(q) dv + h(q, v) = S^T u + J_N^T lam_N + J_T^T lam_T

Contact ``i`` is a point ``p_i`` fixed in a link, against a fixed line with unit normal ``n_i``
(pointing at the robot) and tangent ``t_i = (n_y, -n_x)``. Its gap is ``phi_i = n_i . (p_i - s_i)``
with ``s_i`` a point of the line; its rows are ``J_N,i = n_i^T J_p,i`` and ``J_T,i = t_i^T J_p,i``
and its contact accelerations ``a_N = J_N dv + dJ_N v``, ``a_T = J_T dv + dJ_T v``, where the drift
``dJ v`` is the classical acceleration of the point at ``dv = 0``.

The planar base is three one-degree-of-freedom joints (prismatic x, prismatic y, revolute z) in a
Pinocchio composite joint, so that Pinocchio's velocity equals ``dq/dt`` in the world (a
``JointModelPlanar`` would express it in the body frame). URDF ``continuous`` joints, which
Pinocchio's URDF reader makes unbounded joints of ``(cos, sin)`` pairs, are rebuilt as revolute
joints of the angle (same kinematics): Pinocchio's q is then the minimal q, in Pinocchio's order.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from .errors import FrameNotFound, InputError, KernelError, RobotModelError
from .kernel import COMPILED, backend, compiled
from .springs import JointSprings, JointTerms
from .urdf import BASE_COORDINATES, read_urdf, robot_outline

SKELETON_CACHE_SIZE = 64
"""How many built Pinocchio models (by URDF content, base and locked joints) are kept for reuse."""

PLANE_AXIS_TOLERANCE = 1e-9
"""How far [unit vector components] a revolute axis may lean off the world z axis, or a prismatic
axis out of the x-y plane, before the URDF is rejected as non-planar."""


@dataclass(frozen=True)
class ContactPoint:
    """A point of a link that may touch a fixed line of the world.

    Attributes:
        name: the contact's name (unique in a scene).
        link: the URDF link the point is fixed in.
        point_in_link: the point [m] in that link's frame (x, y).
        normal_in_world: unit normal [-] of the surface line, pointing at the robot.
        surface_point_in_world: a point [m] of the surface line.
        mu: Coulomb friction coefficient [-], >= 0.
    """

    name: str
    link: str
    point_in_link: np.ndarray
    normal_in_world: np.ndarray
    surface_point_in_world: np.ndarray
    mu: float

    @property
    def tangent_in_world(self) -> np.ndarray:
        """Unit tangent ``t = (n_y, -n_x)`` [-]: sliding "right" (mode R) is along +t."""
        n = self.normal_in_world
        return np.array([n[1], -n[0]])


@dataclass(frozen=True)
class _ContactLayout:
    """A subset of k contacts, laid out once for :meth:`PlanarRobot.state`.

    Attributes:
        frames: the contacts' Pinocchio frame ids.
        jacobian_projection: (2k, 6k): rows n_i^T and t_i^T, applied to the frames' stacked 6 x n
            Jacobians (world-aligned, at the point: linear rows first), give ``[J_N; J_T]``.
        motion_projection: (5k, 9k + 1): applied to ``[a_1 .. a_k, p_1 .. p_k, 1]`` (the frames'
            6-D classical accelerations, their 3-D positions, a one) it gives ``[n^T a; t^T a;
            n^T (p - s); p_x, p_y interleaved]``: drifts, gaps and the points.
        lines: each contact's ``n_x, n_y, t_x, t_y, n . s`` (5k floats), what the compiled assembly
            (:func:`frcontrol._kernel.robot_state`) reads in place of the two projections.
        positions: each frame's ``data.oMf[frame].translation`` [m], a view of the Pinocchio data's
            storage, which ``updateFramePlacement`` overwrites in place: the compiled assembly reads
            the position there, with no conversion of the call's result.
    """

    frames: tuple[int, ...]
    jacobian_projection: np.ndarray
    motion_projection: np.ndarray
    lines: tuple[float, ...]
    positions: tuple[np.ndarray, ...]


def _contact_layout(frames: Sequence[int], normals: np.ndarray, tangents: np.ndarray,
                    surface_points: np.ndarray, positions: Sequence[np.ndarray]) -> _ContactLayout:
    """The :class:`_ContactLayout` of contacts with these (k, 2) lines and position views."""
    k = len(frames)
    jacobian = np.zeros((2 * k, 6 * k))
    motion = np.zeros((5 * k, 9 * k + 1))
    for i, (normal, tangent, surface) in enumerate(zip(normals, tangents, surface_points, strict=True)):
        acc, pos = 6 * i, 6 * k + 3 * i  # columns of contact i's acceleration and position
        jacobian[i, acc:acc + 2] = motion[i, acc:acc + 2] = normal
        jacobian[k + i, acc:acc + 2] = motion[k + i, acc:acc + 2] = tangent
        motion[2 * k + i, pos:pos + 2] = normal
        motion[2 * k + i, -1] = -(normal @ surface)
        motion[3 * k + 2 * i, pos] = motion[3 * k + 2 * i + 1, pos + 1] = 1.0
    lines = np.column_stack([normals, tangents, -motion[2 * k:3 * k, -1]]).reshape(k, 5)
    return _ContactLayout(tuple(frames), jacobian, motion, tuple(lines.ravel().tolist()), tuple(positions))


def _resurfaced(layout: _ContactLayout, normals: np.ndarray, surface_points: np.ndarray) -> _ContactLayout:
    """``layout`` at other (k, 2) surface points: :func:`_contact_layout`'s, bit for bit.

    Only the gaps' constants ``-n . s`` (the motion projection's last column) and the lines' ``n . s``
    depend on the surface points; the rest is shared with ``layout``.
    """
    k = len(layout.frames)
    motion = layout.motion_projection.copy()
    lines = list(layout.lines)
    for i, (normal, surface) in enumerate(zip(normals, surface_points, strict=True)):
        motion[2 * k + i, -1] = -(normal @ surface)
        lines[5 * i + 4] = -float(motion[2 * k + i, -1])
    return _ContactLayout(layout.frames, layout.jacobian_projection, motion, tuple(lines), layout.positions)


@dataclass(frozen=True)
class RobotState:
    """Dynamics and contact kinematics of a robot at one state (q, v).

    Arrays over contacts follow the order of the ``contacts`` argument that produced them.

    Attributes:
        q: minimal configuration [m, rad], shape (n,).
        v: minimal velocity [m/s, rad/s], shape (n,).
        mass_matrix: M(q) [kg, kg m, kg m^2], shape (n, n), symmetric positive semi-definite.
        bias: h(q, v) = gravity + Coriolis/centrifugal generalized forces [N, N m] (+ the drives'
            damping and the joint springs' ``k (q - rest) + c v``), shape (n,).
        contact_points: world positions p_i [m], shape (k, 2).
        gaps: phi_i [m], shape (k,).
        normal_velocities: v_N,i = J_N,i v [m/s], shape (k,).
        tangential_velocities: v_T,i = J_T,i v [m/s], shape (k,).
        jacobian_normal: rows J_N,i, shape (k, n).
        jacobian_tangent: rows J_T,i, shape (k, n).
        drift_normal: dJ_N,i v [m/s^2], shape (k,).
        drift_tangent: dJ_T,i v [m/s^2], shape (k,).
    """

    q: np.ndarray
    v: np.ndarray
    mass_matrix: np.ndarray
    bias: np.ndarray
    contact_points: np.ndarray
    gaps: np.ndarray
    normal_velocities: np.ndarray
    tangential_velocities: np.ndarray
    jacobian_normal: np.ndarray
    jacobian_tangent: np.ndarray
    drift_normal: np.ndarray
    drift_tangent: np.ndarray


def _assembled_state(fields: dict[str, np.ndarray]) -> RobotState:
    """A :class:`RobotState` of ``fields`` (every field, by name), as its ``__init__`` makes it.

    The frozen dataclass's generated ``__init__`` sets each field through ``object.__setattr__``,
    about 1 us for twelve fields: a tenth of :meth:`PlanarRobot.state`. This fills the instance's
    dictionary in one call; the object is the same (frozen afterwards, equal, same repr).
    """
    state = object.__new__(RobotState)
    state.__dict__.update(fields)
    return state


_WORLD_ALIGNED = pin.LOCAL_WORLD_ALIGNED
_ONE = np.ones(1)
_ONE.setflags(write=False)

_FLOAT64 = np.dtype(np.float64)


def _reads_in_place(data: pin.Data, frames: Sequence[int]) -> bool:
    """Whether Pinocchio hands out ``data.M``, ``data.nle`` and the frames' translations as views.

    The compiled assembly makes these views once and reads the data's storage through them: each
    must not own its memory, and two reads must give the same memory. Where a Pinocchio build hands
    out copies instead, the NumPy assembly runs.
    """

    def address(array: np.ndarray) -> int:
        return int(array.__array_interface__["data"][0])

    reads = [lambda: data.M, lambda: data.nle] + [lambda f=f: data.oMf[f].translation for f in frames]
    return all(not read().flags.owndata and address(read()) == address(read()) for read in reads)


def _compiled_assembly() -> bool:
    """Whether :meth:`PlanarRobot.state` assembles in the compiled kernel.

    The kernel's backend (:func:`frcontrol.kernel.backend`) chooses when the robot is built: the
    compiled one makes a plan for ``robot_state`` (where Pinocchio's arrays read in place), NumPy's
    none. An unknown ``FRC_KERNEL`` chooses NumPy here: the analysis, which reads the variable too,
    reports it where it is used.
    """
    try:
        return backend() is COMPILED
    except KernelError:
        return False


def _check_planar_joints(urdf: str, joints: Sequence[tuple[str, str, np.ndarray]]) -> None:
    """Revolute and continuous axes along z, prismatic axes in x-y, no other movable joint.

    Raises:
        RobotModelError: a joint that does not move in the plane.
    """
    for name, kind, axis in joints:
        if kind in ("revolute", "continuous"):
            if abs(abs(axis[2]) - 1.0) > PLANE_AXIS_TOLERANCE:
                raise RobotModelError(urdf, f"joint {name!r}: a planar revolute axis is along z, got {axis}")
        elif kind == "prismatic":
            if abs(axis[2]) > PLANE_AXIS_TOLERANCE:
                raise RobotModelError(urdf, f"joint {name!r}: a planar prismatic axis lies in x-y, "
                                            f"got {axis}")
        else:
            raise RobotModelError(
                urdf,
                f"joint {name!r} of type {kind!r} is not planar: use revolute, continuous, "
                "prismatic or fixed joints and a planar base",
            )


def _coordinate_maps(model: pin.Model, base: str, joint_names: Sequence[str]
                     ) -> tuple[np.ndarray | None, np.ndarray]:
    """Minimal coordinates <-> Pinocchio (q, v).

    One velocity per coordinate; continuous joints are (cos, sin) pairs in Pinocchio's q.

    Returns:
        (q_gather: Pinocchio's q is ``[q, cos q, sin q][q_gather]``, or None when it is ``q``
        itself; v_index: the Pinocchio velocity index of each coordinate).
    """
    n = (3 if base == "planar" else 0) + len(joint_names)
    v_index = np.empty(n, dtype=int)
    q_gather = np.empty(model.nq, dtype=int)
    offset = 0
    if base == "planar":
        root_id = model.getJointId("root_joint")
        idx_q, idx_v = model.joints[root_id].idx_q, model.joints[root_id].idx_v
        v_index[:3] = idx_v + np.arange(3)
        q_gather[idx_q:idx_q + 3] = np.arange(3)
        offset = 3
    for i, name in enumerate(joint_names):
        jm = model.joints[model.getJointId(name)]
        v_index[offset + i] = jm.idx_v
        if jm.nq == 2:
            q_gather[jm.idx_q:jm.idx_q + 2] = (n + offset + i, 2 * n + offset + i)
        else:
            q_gather[jm.idx_q] = offset + i
    if np.array_equal(q_gather, np.arange(n)):
        return None, v_index
    return q_gather, v_index


def _file_content(path: Path) -> bytes:
    """The URDF's bytes (the model cache's key: a file rewritten with other content is rebuilt).

    Raises:
        RobotModelError: the file cannot be read (the URDF reader's message).
    """
    try:
        return path.read_bytes()
    except OSError as err:
        read_urdf(path)  # raises the URDF reader's one-line message for an unreadable file
        raise RobotModelError(str(path), f"cannot read URDF: {err}") from err


@dataclass(frozen=True)
class _Skeleton:
    """What a URDF, a base and locked joints determine, built once (:func:`_skeleton`).

    Attributes:
        model: the Pinocchio model (locked joints welded, no contact frame, gravity unset); never
            handed out: each :class:`PlanarRobot` works on its own copy.
        joints: the movable joints left, (name, kind, axis) in document order.
        link_names: the model's links.
        q_gather, v_index: :func:`_coordinate_maps` (read-only).
        mass_gather: M in minimal order from Pinocchio's upper triangle, by one gather of flat
            indices into M^T (read-only; C-ordered: Eigen's M is column-major, so M.T is a view):
            entry (i, j) is M^T[max, min] of the Pinocchio indices of coordinates i and j.
        identity_order: whether the minimal coordinates are in Pinocchio's velocity order.
    """

    model: pin.Model
    joints: tuple[tuple[str, str, np.ndarray], ...]
    link_names: tuple[str, ...]
    q_gather: np.ndarray | None
    v_index: np.ndarray
    mass_gather: np.ndarray
    identity_order: bool


@lru_cache(maxsize=SKELETON_CACHE_SIZE)
def _skeleton(urdf: str, content: bytes, base: str, locked: tuple[tuple[str, float], ...]) -> _Skeleton:
    """The Pinocchio model of the URDF at ``urdf`` (whose bytes are ``content``) and its layout.

    Cached by the file's path and content, the base and the locked joints with their values: a
    sweep reloads the same scene at every point, and each robot works on its own copy.

    Raises:
        RobotModelError: the URDF cannot be read, is not planar, or locks an unknown joint.
    """
    joints = [(j.name, j.kind, j.axis) for j in read_urdf(urdf).movable_joints]
    _check_planar_joints(urdf, joints)
    try:
        if base == "planar":
            root = pin.JointModelComposite(3)
            root.addJoint(pin.JointModelPX())
            root.addJoint(pin.JointModelPY())
            root.addJoint(pin.JointModelRZ())
            model = pin.buildModelFromUrdf(urdf, root)
        else:
            model = pin.buildModelFromUrdf(urdf)
    except (ValueError, RuntimeError) as err:
        raise RobotModelError(urdf, f"Pinocchio cannot build the model: {err}") from err
    if locked:
        model = _lock_joints(urdf, model, dict(locked), [name for name, _, _ in joints])
        joints = [j for j in joints if j[0] not in dict(locked)]
    model = _angle_joints(model)
    names = [name for name, _, _ in joints]
    n = (3 if base == "planar" else 0) + len(names)
    if model.nv != n:
        raise RobotModelError(urdf, f"expected {n} velocities, Pinocchio has {model.nv}")
    q_gather, v_index = _coordinate_maps(model, base, names)
    mass_gather = (np.maximum.outer(v_index, v_index) * n + np.minimum.outer(v_index, v_index)).ravel()
    for array in (q_gather, v_index, mass_gather):
        if array is not None:
            array.setflags(write=False)
    link_names = tuple(f.name for f in model.frames if f.type == pin.FrameType.BODY)
    return _Skeleton(model, tuple(joints), link_names, q_gather, v_index, mass_gather,
                     bool(np.array_equal(v_index, np.arange(n))))


_ANGLE_JOINTS = {"JointModelRUBX": pin.JointModelRX, "JointModelRUBY": pin.JointModelRY,
                 "JointModelRUBZ": pin.JointModelRZ}
"""Pinocchio's unbounded revolute joints about a frame axis, and the revolute joint of each."""


def _angle_joints(model: pin.Model) -> pin.Model:
    """``model`` with its unbounded revolute joints made revolute joints about the same axes.

    An unbounded joint (a URDF ``continuous`` one) has the pair (cos, sin) as its configuration; the
    revolute joint has the angle. All else is kept: tree, placements, inertias, frames and the
    per-velocity parameters. The kinematics and dynamics are the same (the joint's rotation is
    built from cos and sin of the angle either way); Pinocchio's q is then the minimal q, up to
    order, with no conversion per call. URDF position limits, which frcontrol does not use, are
    dropped for those joints.
    """
    unaligned = "JointModelRevoluteUnboundedUnaligned"
    kinds = [model.joints[j].shortname() for j in range(1, model.njoints)]
    if not any(kind in _ANGLE_JOINTS or kind == unaligned for kind in kinds):
        return model
    out = pin.Model()
    out.name = model.name
    data = model.createData()
    for j, kind in enumerate(kinds, start=1):
        joint = model.joints[j]
        if kind in _ANGLE_JOINTS:
            joint = _ANGLE_JOINTS[kind]()
        elif kind == unaligned:  # its axis: the angular part of its motion subspace
            local = np.reshape(pin.computeJointJacobian(model, data, pin.neutral(model), j), (6, -1))
            joint = pin.JointModelRevoluteUnaligned(local[3:, joint.idx_v].copy())
        out.addJoint(model.parents[j], joint, model.jointPlacements[j], model.names[j])
        out.inertias[j] = model.inertias[j]
    for frame in list(model.frames)[1:]:
        out.addFrame(frame, False)
    for name in ("armature", "damping", "friction", "effortLimit", "velocityLimit", "rotorInertia",
                 "rotorGearRatio"):
        setattr(out, name, getattr(model, name).copy())
    return out


def _lock_joints(urdf: str, model: pin.Model, locked: Mapping[str, float], names: Sequence[str]) -> pin.Model:
    """The reduced model with the ``locked`` joints welded at their given values.

    Raises:
        RobotModelError: an unknown joint.
    """
    unknown = [name for name in locked if name not in names]
    if unknown:
        raise RobotModelError(urdf, f"cannot lock unknown joint {unknown[0]!r}; "
                              f"the joints are: {', '.join(names)}")
    reference = pin.neutral(model)
    ids = []
    for name, value in locked.items():
        joint = model.joints[model.getJointId(name)]
        if joint.nq == 2:
            reference[joint.idx_q:joint.idx_q + 2] = [math.cos(value), math.sin(value)]
        else:
            reference[joint.idx_q] = value
        ids.append(model.getJointId(name))
    return pin.buildReducedModel(model, ids, reference)


@dataclass(frozen=True)
class PointKinematics:
    """Points fixed on links, at one state (:meth:`PlanarRobot.point_kinematics`).

    Attributes:
        positions: world positions [m], shape (p, 2).
        jacobians: world x-y Jacobians, shape (p, 2, n): ``d position / dt = J v``.
        drifts: classical accelerations at ``dv = 0`` [m/s^2], shape (p, 2).
    """

    positions: np.ndarray
    jacobians: np.ndarray
    drifts: np.ndarray


class PlanarRobot:
    """A planar robot: one Pinocchio model and data, on a planar or fixed base.

    Args:
        urdf_path: the robot's URDF. Links move in the x-y plane: revolute and continuous joints
            about z, prismatic joints along an in-plane axis.
        base: ``"planar"`` (floating x, y, theta) or ``"fixed"`` (root link bolted to the world).
        gravity: gravitational acceleration [m/s^2] along -y, >= 0.
        contacts: the contact points to evaluate; each becomes an operational frame of this
            object's own Pinocchio model.
        locked: joints held at the given angle [rad] (or position [m]): they are welded into their
            parent (Pinocchio's reduced model) and add no coordinate.
        terms: drives' inertia and damping and joint springs on the coordinates
            (:class:`~frcontrol.springs.JointTerms`; kept as ``terms``).
        surfaces_through: a minimal configuration q: each contact whose surface point is not
            finite (NaN) gets the surface line through its contact point at q (gap 0); the contact
            points at q are kept (``placed_points_in_world``, else None).

    A robot is built once with all of these and is not changed afterwards: a sweep that moves a
    contact's surface or changes its friction makes another robot on the same Pinocchio model
    (:meth:`with_contact_points`).

    Raises:
        RobotModelError: the URDF cannot be read, or is not planar.
        FrameNotFound: a contact names a link the robot does not have.
    """

    def __init__(
        self,
        urdf_path: str | Path,
        base: str = "planar",
        gravity: float = 9.81,
        contacts: Sequence[ContactPoint] = (),
        locked: Mapping[str, float] | None = None,
        terms: JointTerms | None = None,
        surfaces_through: ArrayLike | None = None,
    ) -> None:
        self.urdf_path = Path(urdf_path)
        if base not in ("planar", "fixed"):
            raise RobotModelError(str(urdf_path), f"base must be 'planar' or 'fixed', got {base!r}")
        self.base = base
        locked = dict(locked or {})
        skeleton = _skeleton(str(urdf_path), _file_content(self.urdf_path), base, tuple(locked.items()))
        model = pin.Model(skeleton.model)  # this object's own copy: frames and armature are added to it
        joints = skeleton.joints
        self.locked: dict[str, float] = locked
        model.gravity.linear[:] = [0.0, -float(gravity), 0.0]
        self.gravity = float(gravity)

        # Minimal coordinates <-> Pinocchio (q, v): one velocity per coordinate (and one q: the
        # continuous joints are revolute ones). Coordinate order: base, then URDF document order.
        joint_names = [name for name, _, _ in joints]
        self.joint_names: tuple[str, ...] = tuple(joint_names)
        self.coordinate_names: tuple[str, ...] = (
            (BASE_COORDINATES if base == "planar" else ()) + self.joint_names
        )
        n = self._n = len(self.coordinate_names)
        self._q_gather, v_index = skeleton.q_gather, skeleton.v_index
        self._identity_order = skeleton.identity_order
        self._v_index = v_index
        # Pinocchio velocity vector from a minimal one: v_pin[v_index] = v.
        self.link_names: tuple[str, ...] = skeleton.link_names

        self.contacts: tuple[ContactPoint, ...] = tuple(contacts)
        frame_ids = []
        for contact in self.contacts:
            frame_ids.append(self._add_point_frame(model, contact.name, contact.link, contact.point_in_link))
        self._contact_frames = frame_ids
        self._normals = np.array([c.normal_in_world for c in self.contacts], dtype=float).reshape(-1, 2)
        self._tangents = np.array([c.tangent_in_world for c in self.contacts], dtype=float).reshape(-1, 2)
        self._surface_points = np.array(
            [c.surface_point_in_world for c in self.contacts], dtype=float
        ).reshape(-1, 2)
        self.model = model
        self.data = model.createData()  # never replaced: the views below read its storage
        # views of the data's storage, which Pinocchio's calls overwrite in place (Eigen's M is
        # column-major: its view is strided); they do not keep the data alive, this object does
        self._frame_positions = [self.data.oMf[f].translation for f in frame_ids]
        self._mass_gather = skeleton.mass_gather  # M from CRBA's upper triangle (_Skeleton)
        self._layouts: dict = {}  # contact subsets -> _ContactLayout
        terms = self.terms = terms or JointTerms()
        armature = np.zeros(n)
        self._damping = np.zeros(n)  # [N m s/rad] drives' viscous damping, in the bias
        for i, value in terms.inertia.items():
            armature[v_index[i]] = value
        for i, value in terms.damping.items():
            self._damping[i] = value
        model.armature = armature
        self._has_damping = bool(np.any(self._damping))
        self._springs = terms.springs  # joint springs, added to h by state()
        self.placed_points_in_world: np.ndarray | None = None
        if surfaces_through is not None:
            self._place_surfaces(surfaces_through)
        # state() assembles in frcontrol._kernel.robot_state with this plan (None: in NumPy)
        self._kernel_plan = (RobotState, np.empty, model, self.data, pin.updateFramePlacement,
                             pin.getFrameJacobian, pin.getFrameClassicalAcceleration, _WORLD_ALIGNED,
                             None if self._identity_order else np.asarray(v_index, dtype=np.int64), n,
                             self.data.M, self.data.nle) if _compiled_assembly() and _reads_in_place(
                                 self.data, frame_ids) else None

    # ------------------------------------------------------------------ construction helpers
    def _add_point_frame(self, model: pin.Model, name: str, link: str, point: np.ndarray) -> int:
        if link not in self.link_names:
            raise FrameNotFound(link, self.link_names)
        body = model.frames[model.getFrameId(link, pin.FrameType.BODY)]
        placement = body.placement * pin.SE3(np.eye(3), np.array([point[0], point[1], 0.0]))
        frame = pin.Frame(
            f"contact:{name}", body.parentJoint, model.getFrameId(link, pin.FrameType.BODY),
            placement, pin.FrameType.OP_FRAME,
        )
        return int(model.addFrame(frame, False))

    def _place_surfaces(self, q: ArrayLike) -> None:
        """Give each contact whose surface point is not finite the line through its point at ``q``."""
        world = self.placed_points_in_world = self.contact_points_in_world(np.asarray(q, dtype=float))
        world.setflags(write=False)
        self.contacts = tuple(
            c if np.all(np.isfinite(c.surface_point_in_world)) else
            ContactPoint(c.name, c.link, c.point_in_link, c.normal_in_world, world[i].copy(), c.mu)
            for i, c in enumerate(self.contacts)
        )
        self._surface_points = np.array([c.surface_point_in_world for c in self.contacts],
                                        dtype=float).reshape(-1, 2)

    def with_contact_points(self, points: Sequence[ContactPoint]) -> PlanarRobot:
        """The same robot with ``points`` as its contacts, kept as given (not copied); this one unchanged.

        They are the same contacts (names, links, points, normals, in order) with their own surface
        points [m] and Coulomb coefficients [-]. The new robot shares this one's Pinocchio model
        and data (a workspace that every call overwrites: use one robot at a time) and its contact
        layouts, but where a surface point changed: those get its new gap constant
        (:func:`_resurfaced`; a surface point that is the same array as this robot's is unchanged).
        """
        robot = object.__new__(PlanarRobot)  # a shallow copy, without copy.copy's generic path
        robot.__dict__.update(self.__dict__)
        robot.contacts = tuple(points)
        if any(p.surface_point_in_world is not c.surface_point_in_world
               and p.surface_point_in_world.tolist() != c.surface_point_in_world.tolist()
               for p, c in zip(points, self.contacts, strict=True)):
            robot._surface_points = np.array([p.surface_point_in_world for p in points],
                                             dtype=float).reshape(-1, 2)
            robot._layouts = {key: _resurfaced(layout, robot._normals[robot._layout_indices(key)],
                                               robot._surface_points[robot._layout_indices(key)])
                              for key, layout in self._layouts.items()}
        return robot

    def _layout_indices(self, key: tuple[int, ...] | None) -> list[int]:
        """The contacts of a layout's key (None: all)."""
        return list(range(len(self.contacts))) if key is None else list(key)

    @property
    def coordinates_before_locking(self) -> tuple[str, ...]:
        """The coordinates of the robot with no joint locked (the order of a scene's ``[state]`` lists)."""
        if not self.locked:
            return self.coordinate_names
        return robot_outline(self.urdf_path, self.base).coordinate_names

    @property
    def springs(self) -> JointSprings:
        """The joint springs (:mod:`frcontrol.springs`), empty when there is none."""
        return self._springs

    def spring_energy(self, q: np.ndarray) -> float:
        """The joint springs' elastic energy ``sum 1/2 k (q_j - rest)^2`` [J] at ``q``."""
        return float(self._springs.elastic_energy(q)) if self._springs else 0.0

    @property
    def drive_damping(self) -> np.ndarray:
        """[N m s/rad] per minimal coordinate: the drives' viscous damping in the bias (a copy)."""
        return self._damping.copy()

    @property
    def nv(self) -> int:
        """Number of minimal coordinates n."""
        return len(self.coordinate_names)

    # ------------------------------------------------------------------ conversions
    def pinocchio_q_from_minimal(self, q: np.ndarray) -> np.ndarray:
        """Pinocchio's configuration vector for the minimal coordinates ``q`` (a new array)."""
        q_pin = self._pinocchio_q(q)
        return q_pin.copy() if q_pin is q else q_pin

    def _pinocchio_q(self, q: np.ndarray) -> np.ndarray:
        """Pinocchio's q: ``q`` itself when they coincide, else one gather from ``[q, cos q, sin q]``."""
        q = np.asarray(q, dtype=float)
        if self._q_gather is None:
            return q
        return np.concatenate((q, np.cos(q), np.sin(q))).take(self._q_gather)

    def pinocchio_v_from_minimal(self, v: np.ndarray) -> np.ndarray:
        """Pinocchio's velocity vector for the minimal velocity ``v``."""
        if self._identity_order:
            return v
        v_pin = np.empty(self.nv)
        v_pin[self._v_index] = v
        return v_pin

    def check_state(
        self, q: ArrayLike, v: ArrayLike | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Validate a state; return ``(q, v)`` as float64 arrays (v defaults to zeros).

        Raises:
            InputError: wrong length, or a NaN or infinite entry.
        """
        q_arr = np.asarray(q, dtype=float).reshape(-1)
        v_arr = np.zeros(self.nv) if v is None else np.asarray(v, dtype=float).reshape(-1)
        for label, arr in (("q", q_arr), ("v", v_arr)):
            if arr.shape != (self.nv,):
                raise InputError(
                    f"{label} has {arr.size} entries, expected {self.nv} "
                    f"({', '.join(self.coordinate_names)})"
                )
            if not np.all(np.isfinite(arr)):
                raise InputError(f"{label} has a NaN or infinite entry: {arr.tolist()}")
        return q_arr, v_arr

    # ------------------------------------------------------------------ evaluation
    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """M(q) [kg, kg m, kg m^2] in minimal coordinates (full symmetric matrix)."""
        q_pin = self.pinocchio_q_from_minimal(np.asarray(q, dtype=float))
        pin.crba(self.model, self.data, q_pin)
        return self._symmetric_minimal(self.data.M)

    def _symmetric_minimal(self, upper: np.ndarray) -> np.ndarray:
        """The full symmetric M in minimal order from Pinocchio's upper triangle."""
        return upper.T.take(self._mass_gather).reshape(self.nv, self.nv)

    def _layout(self, key: tuple[int, ...] | None) -> _ContactLayout:
        """The layout of the contacts ``key`` (None: all), made once per subset."""
        layout = self._layouts.get(key)
        if layout is None:
            indices = self._layout_indices(key)
            layout = _contact_layout([self._contact_frames[i] for i in indices], self._normals[indices],
                                     self._tangents[indices], self._surface_points[indices],
                                     [self._frame_positions[i] for i in indices])
            self._layouts[key] = layout
        return layout

    def state(
        self, q: np.ndarray, v: np.ndarray, contacts: Sequence[int] | None = None
    ) -> RobotState:
        """Everything the contact-dynamics layers need at ``(q, v)``.

        Every array of the result is new (none is shared with another call or with Pinocchio's
        data), so states may be kept across calls. One pass of Pinocchio (CRBA's upper triangle,
        nonlinear effects, joint Jacobians and the kinematics at ``(q, v, a = 0)``), then per
        contact frame its placement (first: the other two read it), its world-aligned 6 x n
        Jacobian at the point and its classical acceleration, the drift; these are projected on
        the contacts' normals and tangents in one call of the compiled kernel
        (:func:`frcontrol._kernel.robot_state`, which reads M, h and the frames' positions through
        views of the Pinocchio data's storage, made once), or in NumPy (:meth:`_state_numpy`, the
        reference) where ``FRC_KERNEL=numpy`` or the extension is not built. The joint springs'
        force (:class:`JointTerms`) is then added to the bias, the one place for both kernels.

        Args:
            q: minimal configuration, shape (n,) (not validated here: see :meth:`check_state`).
            v: minimal velocity, shape (n,) (float64 goes through as it is).
            contacts: indices into ``self.contacts`` to evaluate (default: all), in that order.
        """
        v = self.pinocchio_pass(q, v)
        layout = self._layouts.get(contacts) if contacts is None or type(contacts) is tuple else None
        if layout is None:
            layout = self._layout(None if contacts is None else tuple(contacts))
        plan = self._kernel_plan
        if plan is None:
            state = self._state_numpy(q, v, layout)
        else:
            state = compiled.robot_state(  # type: ignore[union-attr]  # a plan only where it is built
                plan, q, v, layout.frames, layout.positions, layout.lines,
                self._damping if self._has_damping else None)
        if self._springs:  # the joint springs' known force, on either kernel's new bias array
            self._springs.add_to_bias(state.bias, q, v)
        return state

    def pinocchio_pass(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Pinocchio's one pass at ``(q, v)`` (``computeAllTerms``), which :meth:`state` reads.

        Returns ``v`` as float64.

        Args:
            q: minimal configuration, shape (n,) (not validated here: see :meth:`check_state`).
            v: minimal velocity, shape (n,) (float64 goes through as it is).
        """
        if type(v) is not np.ndarray or v.dtype != _FLOAT64:  # the kernel reads float64 only
            v = np.asarray(v, dtype=float)
        # (an array q goes to Pinocchio as it is where no gather is needed: Pinocchio converts
        # other number types itself; a sequence goes through _pinocchio_q)
        pin.computeAllTerms(self.model, self.data,
                            q if self._q_gather is None and type(q) is np.ndarray else self._pinocchio_q(q),
                            v if self._identity_order else self.pinocchio_v_from_minimal(v))
        return v

    def kernel_state_plan(self, contacts: tuple[int, ...]) -> tuple[Any, ...] | None:
        """What the compiled kernel reads to assemble the state at ``contacts`` after :meth:`pinocchio_pass`.

        ``(plan, frames, positions, lines, damping)`` as ``robot_state`` takes them; None where
        :meth:`state` does more than the kernel (joint springs) or assembles in NumPy.
        """
        if self._kernel_plan is None or self._springs:
            return None
        layout = self._layout(contacts)
        return (self._kernel_plan, layout.frames, layout.positions, layout.lines,
                self._damping if self._has_damping else None)

    def _state_numpy(self, q: np.ndarray, v: np.ndarray, layout: _ContactLayout) -> RobotState:
        """:meth:`state`'s assembly in NumPy, after Pinocchio's pass: the reference of the compiled one."""
        model, data = self.model, self.data
        frames, k, n = layout.frames, len(layout.frames), self._n
        if k:
            # per frame: its placement (first: the other two read it), its world-aligned 6 x n
            # Jacobian at the point and its classical acceleration; projected on (n, t) at once
            update, jacobian = pin.updateFramePlacement, pin.getFrameJacobian
            acceleration = pin.getFrameClassicalAcceleration
            positions = [update(model, data, f).translation for f in frames]
            # (ndarray.dot: a third of the matmul operator's overhead on matrices this small)
            rows = layout.jacobian_projection.dot(np.concatenate(
                [jacobian(model, data, f, _WORLD_ALIGNED) for f in frames]))
            motion = layout.motion_projection.dot(np.concatenate(
                [acceleration(model, data, f, _WORLD_ALIGNED).vector for f in frames] + positions + [_ONE]))
        else:
            rows, motion = np.empty((0, n)), np.empty(0)
        if not self._identity_order:
            rows = rows[:, self._v_index]
        velocities = rows.dot(v)
        bias = data.nle.copy() if self._identity_order else data.nle[self._v_index]
        return _assembled_state({
            "q": q, "v": v,
            "mass_matrix": data.M.T.take(self._mass_gather).reshape(n, n),
            "bias": bias + self._damping * v if self._has_damping else bias,
            "contact_points": motion[3 * k:].reshape(k, 2), "gaps": motion[2 * k:3 * k],
            "normal_velocities": velocities[:k], "tangential_velocities": velocities[k:],
            "jacobian_normal": rows[:k], "jacobian_tangent": rows[k:],
            "drift_normal": motion[:k], "drift_tangent": motion[k:2 * k],
        })

    def contact_points_in_world(self, q: np.ndarray) -> np.ndarray:
        """World positions [m] of every contact point at ``q``, shape (k, 2)."""
        pin.framesForwardKinematics(self.model, self.data, self.pinocchio_q_from_minimal(q))
        return np.array(
            [self.data.oMf[fid].translation[:2] for fid in self._contact_frames]
        ).reshape(-1, 2)

    def link_poses(self, q: np.ndarray) -> dict[str, tuple[np.ndarray, float]]:
        """World pose of every link at ``q``: name -> (origin [m], angle [rad])."""
        pin.framesForwardKinematics(self.model, self.data, self.pinocchio_q_from_minimal(q))
        poses = {}
        for name in self.link_names:
            placement = self.data.oMf[self.model.getFrameId(name, pin.FrameType.BODY)]
            rot = placement.rotation
            poses[name] = (placement.translation[:2].copy(), math.atan2(rot[1, 0], rot[0, 0]))
        return poses

    def point_kinematics(self, q: np.ndarray, v: np.ndarray,
                         points: Sequence[tuple[str, ArrayLike]]) -> PointKinematics:
        """World positions, Jacobians and drifts of points fixed on links, at ``(q, v)``.

        A point ``p`` (link frame) of a link whose frame has world origin ``o``, rotation ``R``,
        linear Jacobian ``J_o`` and angular row ``J_w`` (z) moves with ``J = J_o + perp(R p) J_w``,
        ``perp(r) = (-r_y, r_x)``; its classical acceleration at ``dv = 0`` is
        ``a_o + alpha perp(R p) - omega^2 R p``.

        Args:
            q: configuration (minimal coordinates).
            v: velocity.
            points: ``(link name, point in the link frame [m])`` for each point.

        Raises:
            FrameNotFound: an unknown link.
        """
        model, data = self.model, self.data
        q_pin = self.pinocchio_q_from_minimal(q)
        v_pin = self.pinocchio_v_from_minimal(v)
        pin.forwardKinematics(model, data, q_pin, v_pin, np.zeros(model.nv))
        pin.computeJointJacobians(model, data, q_pin)
        lwa = pin.LOCAL_WORLD_ALIGNED
        count, n = len(points), self.nv
        positions, jacobians, drifts = np.empty((count, 2)), np.empty((count, 2, n)), np.empty((count, 2))
        for row, (link, point) in enumerate(points):
            if link not in self.link_names:
                raise FrameNotFound(link, self.link_names)
            fid = model.getFrameId(link, pin.FrameType.BODY)
            placement = pin.updateFramePlacement(model, data, fid)
            r = placement.rotation[:2, :2] @ np.asarray(point, dtype=float)[:2]
            perp = np.array([-r[1], r[0]])
            jac = pin.getFrameJacobian(model, data, fid, lwa)
            omega = float(pin.getFrameVelocity(model, data, fid, lwa).angular[2])
            alpha = float(pin.getFrameAcceleration(model, data, fid, lwa).angular[2])
            origin_acc = pin.getFrameClassicalAcceleration(model, data, fid, lwa).linear[:2]
            positions[row] = placement.translation[:2] + r
            jacobians[row] = jac[:2] + np.outer(perp, jac[5])
            drifts[row] = origin_acc + alpha * perp - omega**2 * r
        if not self._identity_order:
            jacobians = jacobians[:, :, self._v_index]
        return PointKinematics(positions, jacobians, drifts)

    @property
    def total_mass(self) -> float:
        """The robot's mass [kg]: every link's (Pinocchio's ``computeTotalMass``)."""
        return float(pin.computeTotalMass(self.model))

    def weight_scale(self) -> float:
        """The robot's weight m g [N], or 1 N when it is zero: the scale of force thresholds."""
        weight = self.total_mass * self.gravity
        return weight if weight > 0 else 1.0

    def center_of_mass(self, q: np.ndarray) -> np.ndarray:
        """World position [m] of the robot's centre of mass at ``q``, shape (2,)."""
        q_pin = self.pinocchio_q_from_minimal(q)
        return np.array(pin.centerOfMass(self.model, self.data, q_pin), dtype=float)[:2]

    def potential_energy(self, q: np.ndarray) -> float:
        """Gravitational potential energy [J] at ``q`` (zero at y = 0)."""
        return float(pin.computePotentialEnergy(self.model, self.data, self.pinocchio_q_from_minimal(q)))

    def integrate(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """``q + dq`` in minimal coordinates (all of them are additive: angles are not wrapped)."""
        return np.asarray(q, dtype=float) + np.asarray(dq, dtype=float)


__all__ = [
    "BASE_COORDINATES",
    "ContactPoint",
    "PlanarRobot",
    "PLANE_AXIS_TOLERANCE",
    "PointKinematics",
    "RobotState",
]
