"""The planar multi-rigid-body model on Pinocchio, and contact kinematics at a state.

One :class:`PlanarRobot` owns a Pinocchio model and its data, built from a URDF whose links move in
the world's x-y plane (y up, revolute axes along z) on either a floating planar base or a fixed
base. Its coordinates are *minimal*: ``q = [x, y, theta, joints...]`` for a planar base (theta
counter-clockwise), ``q = [joints...]`` for a fixed one, and ``v = dq/dt``. The equations of motion
(METHOD §1) are::

    M(q) dv + h(q, v) = S^T u + J_N^T lam_N + J_T^T lam_T

Contact ``i`` is a point ``p_i`` fixed in a link, against a fixed line with unit normal ``n_i``
(pointing at the robot) and tangent ``t_i = (n_y, -n_x)``. Its gap is ``phi_i = n_i . (p_i - s_i)``
with ``s_i`` a point of the line; its rows are ``J_N,i = n_i^T J_p,i`` and ``J_T,i = t_i^T J_p,i``
and its contact accelerations ``a_N = J_N dv + dJ_N v``, ``a_T = J_T dv + dJ_T v``, where the drift
``dJ v`` is the classical acceleration of the point at ``dv = 0``.

The planar base is three one-degree-of-freedom joints (prismatic x, prismatic y, revolute z) in a
Pinocchio composite joint, so that Pinocchio's velocity equals ``dq/dt`` in the world (a
``JointModelPlanar`` would express it in the body frame). URDF ``continuous`` joints are stored by
Pinocchio as ``(cos, sin)`` pairs; the minimal joint angle is mapped onto them here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from .errors import FrameNotFound, InputError, RobotModelError
from .urdf import read_urdf

BASE_COORDINATES = ("x", "y", "theta")
"""Names of the planar base's coordinates: position [m] of the root link's frame and its angle
[rad], counter-clockwise from the world x axis."""

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
    """A subset of the contacts, laid out once: frame ids, (n, t) rows (2, k, 2), surface points."""

    frames: tuple[int, ...]
    basis: np.ndarray
    surface_points: np.ndarray


@dataclass(frozen=True)
class RobotState:
    """Dynamics and contact kinematics of a robot at one state (q, v).

    Arrays over contacts follow the order of the ``contacts`` argument that produced them.

    Attributes:
        q: minimal configuration [m, rad], shape (n,).
        v: minimal velocity [m/s, rad/s], shape (n,).
        mass_matrix: M(q) [kg, kg m, kg m^2], shape (n, n), symmetric positive semi-definite.
        bias: h(q, v) = gravity + Coriolis/centrifugal generalized forces [N, N m], shape (n,).
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
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Minimal coordinates <-> Pinocchio (q, v).

    One velocity per coordinate; continuous joints are (cos, sin) pairs in Pinocchio's q.

    Returns:
        (linear q sources, their Pinocchio q indices, continuous q sources, their first Pinocchio
        q index, v_index: the Pinocchio velocity index of each coordinate).
    """
    n = (3 if base == "planar" else 0) + len(joint_names)
    v_index = np.empty(n, dtype=int)
    linear_q_src, linear_q_dst, unbounded_src, unbounded_dst = [], [], [], []
    offset = 0
    if base == "planar":
        root_id = model.getJointId("root_joint")
        idx_q, idx_v = model.joints[root_id].idx_q, model.joints[root_id].idx_v
        v_index[:3] = idx_v + np.arange(3)
        linear_q_src += [0, 1, 2]
        linear_q_dst += [idx_q, idx_q + 1, idx_q + 2]
        offset = 3
    for i, name in enumerate(joint_names):
        jm = model.joints[model.getJointId(name)]
        v_index[offset + i] = jm.idx_v
        if jm.nq == 2:
            unbounded_src.append(offset + i)
            unbounded_dst.append(jm.idx_q)
        else:
            linear_q_src.append(offset + i)
            linear_q_dst.append(jm.idx_q)
    as_int = [np.array(x, dtype=int) for x in (linear_q_src, linear_q_dst, unbounded_src, unbounded_dst)]
    return as_int[0], as_int[1], as_int[2], as_int[3], v_index


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
    ) -> None:
        self.urdf_path = Path(urdf_path)
        if base not in ("planar", "fixed"):
            raise RobotModelError(str(urdf_path), f"base must be 'planar' or 'fixed', got {base!r}")
        self.base = base
        joints = [(j.name, j.kind, j.axis) for j in read_urdf(self.urdf_path).movable_joints]
        _check_planar_joints(str(urdf_path), joints)
        try:
            if base == "planar":
                root = pin.JointModelComposite(3)
                root.addJoint(pin.JointModelPX())
                root.addJoint(pin.JointModelPY())
                root.addJoint(pin.JointModelRZ())
                model = pin.buildModelFromUrdf(str(self.urdf_path), root)
            else:
                model = pin.buildModelFromUrdf(str(self.urdf_path))
        except (ValueError, RuntimeError) as err:
            raise RobotModelError(str(urdf_path), f"Pinocchio cannot build the model: {err}") from err
        locked = dict(locked or {})
        if locked:
            model = self._lock_joints(model, locked, [name for name, _, _ in joints])
            joints = [j for j in joints if j[0] not in locked]
        self.locked: dict[str, float] = locked
        model.gravity.linear[:] = [0.0, -float(gravity), 0.0]
        self.gravity = float(gravity)

        # Minimal coordinates <-> Pinocchio (q, v): one velocity per coordinate; continuous joints
        # are (cos, sin) pairs in Pinocchio's q. Coordinate order: base, then URDF document order.
        joint_names = [name for name, _, _ in joints]
        self.joint_names: tuple[str, ...] = tuple(joint_names)
        self.coordinate_names: tuple[str, ...] = (
            (BASE_COORDINATES if base == "planar" else ()) + self.joint_names
        )
        n = len(self.coordinate_names)
        if model.nv != n:
            raise RobotModelError(str(urdf_path), f"expected {n} velocities, Pinocchio has {model.nv}")
        maps = _coordinate_maps(model, base, joint_names)
        self._q_linear_src, self._q_linear_dst, self._q_unbounded_src, self._q_unbounded_dst, v_index = maps
        self._identity_order = bool(np.array_equal(v_index, np.arange(n)))
        self._v_index = v_index
        # Pinocchio velocity vector from a minimal one: v_pin[v_index] = v.
        self.link_names: tuple[str, ...] = tuple(
            f.name for f in model.frames if f.type == pin.FrameType.BODY
        )

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
        self.data = model.createData()
        # M in minimal order from Pinocchio's upper triangle (CRBA fills only that): one gather of
        # flat indices, entry (i, j) from (min, max) of the Pinocchio indices of coordinates i, j
        pi, pj = np.meshgrid(v_index, v_index, indexing="ij")
        self._mass_gather = (np.minimum(pi, pj) * n + np.maximum(pi, pj)).ravel()
        self._layouts: dict = {}  # contact subsets -> _ContactLayout
        self._damping = np.zeros(n)  # [N m s/rad] drives' viscous damping (set_drive_terms)
        self._has_damping = False

    # ------------------------------------------------------------------ construction helpers
    def _lock_joints(self, model: pin.Model, locked: Mapping[str, float], names: Sequence[str]) -> pin.Model:
        """The reduced model with the ``locked`` joints welded at their given values."""
        unknown = [name for name in locked if name not in names]
        if unknown:
            raise RobotModelError(str(self.urdf_path), f"cannot lock unknown joint {unknown[0]!r}; "
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

    def set_surface_points(self, surface_points: Sequence[np.ndarray]) -> None:
        """Set the surface point [m] of every contact line (the scene loader's gap-0 default)."""
        self._surface_points = np.array(surface_points, dtype=float).reshape(-1, 2)
        self._layouts = {}
        self.contacts = tuple(
            ContactPoint(c.name, c.link, c.point_in_link, c.normal_in_world, s.copy(), c.mu)
            for c, s in zip(self.contacts, self._surface_points, strict=True)
        )

    def set_drive_terms(self, inertia: Mapping[int, float], damping: Mapping[int, float]) -> None:
        """Add drives' reflected inertia and viscous damping to minimal coordinates.

        ``inertia`` [kg m^2] goes into the coordinate's diagonal of M (Pinocchio's ``armature`` of
        this object's own model, which CRBA adds); ``damping`` b [N m s/rad] adds ``b v`` to the
        bias h(q, v) (a DC motor's electrical damping, :mod:`frcontrol.drives`). Both by index
        into the minimal coordinates; the values replace earlier ones.
        """
        armature = np.zeros(self.nv)
        self._damping = np.zeros(self.nv)
        for i, value in inertia.items():
            armature[self._v_index[i]] = value
        for i, value in damping.items():
            self._damping[i] = value
        self.model.armature = armature
        self._has_damping = bool(np.any(self._damping))

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
        """Pinocchio's configuration vector for the minimal coordinates ``q``."""
        q_pin = np.empty(self.model.nq)
        q_pin[self._q_linear_dst] = q[self._q_linear_src]
        if self._q_unbounded_src.size:
            angles = q[self._q_unbounded_src]
            q_pin[self._q_unbounded_dst] = np.cos(angles)
            q_pin[self._q_unbounded_dst + 1] = np.sin(angles)
        return q_pin

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
        return upper.ravel()[self._mass_gather].reshape(self.nv, self.nv)

    def _layout(self, contacts: Sequence[int] | None) -> _ContactLayout:
        key = None if contacts is None else tuple(contacts)
        layout = self._layouts.get(key)
        if layout is None:
            indices = tuple(range(len(self.contacts))) if key is None else key
            idx = np.array(indices, dtype=int)
            # rows n^T and t^T of each contact's frame, stacked as (2, k, 2)
            basis = np.stack([self._normals[idx], self._tangents[idx]])
            layout = _ContactLayout(tuple(self._contact_frames[i] for i in indices), basis,
                                    self._surface_points[idx])
            self._layouts[key] = layout
        return layout

    def state(
        self, q: np.ndarray, v: np.ndarray, contacts: Sequence[int] | None = None
    ) -> RobotState:
        """Everything the contact-dynamics layers need at ``(q, v)``.

        Args:
            q: minimal configuration, shape (n,) (not validated here: see :meth:`check_state`).
            v: minimal velocity, shape (n,).
            contacts: indices into ``self.contacts`` to evaluate (default: all), in that order.
        """
        model, data = self.model, self.data
        # One pass: CRBA (upper triangle), nonlinear effects, joint Jacobians and the kinematics
        # at (q, v, a = 0), from which the frames' classical accelerations are the drifts.
        pin.computeAllTerms(model, data, self.pinocchio_q_from_minimal(q), self.pinocchio_v_from_minimal(v))
        layout = self._layout(contacts)
        k, n = len(layout.frames), self.nv
        points = np.empty((k, 2))
        jac = np.empty((2, k, n))  # world x and y rows of every contact point's Jacobian
        drift = np.empty((k, 2))
        lwa = pin.LOCAL_WORLD_ALIGNED
        for row, fid in enumerate(layout.frames):
            points[row] = pin.updateFramePlacement(model, data, fid).translation[:2]
            jac[:, row] = pin.getFrameJacobian(model, data, fid, lwa)[:2]
            drift[row] = pin.getFrameClassicalAcceleration(model, data, fid, lwa).linear[:2]
        if not self._identity_order:
            jac = jac[:, :, self._v_index]
        # project on the contact frames: rows n^T J and t^T J (as (2, k, n)), drifts n^T a and t^T a
        basis = layout.basis
        rows = basis[:, :, 0, None] * jac[0] + basis[:, :, 1, None] * jac[1]
        drifts = (basis * drift).sum(axis=2)
        velocities = rows @ v
        return RobotState(
            q=q,
            v=v,
            mass_matrix=data.M.ravel()[self._mass_gather].reshape(n, n),
            bias=(data.nle[self._v_index] + self._damping * v) if self._has_damping
            else data.nle[self._v_index],
            contact_points=points,
            gaps=(basis[0] * (points - layout.surface_points)).sum(axis=1),
            normal_velocities=velocities[0],
            tangential_velocities=velocities[1],
            jacobian_normal=rows[0],
            jacobian_tangent=rows[1],
            drift_normal=drifts[0],
            drift_tangent=drifts[1],
        )

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
