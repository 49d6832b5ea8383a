r"""Drives in a simulation: the elastic transmissions' state and dynamics (their samples: :mod:`.samples`).

Rigid stages
------------
A drive with rigid stages adds no state: its reflected inertia is in ``M``, its electrical damping
in the bias and its voltage gain in ``S^T`` (:mod:`frcontrol.drives`), so both simulators run it
unchanged.

Elastic stages (Vukobratović and Potkonjak 1999, eqs. 41-44)
------------------------------------------------------------
A drive with e elastic stages has e + 1 rigid clusters (:func:`frcontrol.drives.clusters`); the
first e have a coordinate each, ``theta_c`` [rad] (the output gear of the elastic stage that
ends the cluster, i.e. the spring's motor-side end), the last turns with the joint ``q``. With
``rho_c`` and ``eta_c`` the product of the ratios and of the efficiencies of cluster c's stages
and ``J_c`` its inertia reflected to ``theta_c``, spring k (the torsion element of the k-th
elastic stage) twists by ``delta_k = theta_k - rho_{k+1} x_{k+1}`` (``x_e = q``) and carries
``S_k = c_k delta_k + d_k d(delta_k)/dt``; then::

    J_0 theta_0'' = eta_0 rho_0 (C_M / R) (u - C_E rho_0 theta_0') - S_0          (motor cluster)
    J_c theta_c'' = eta_c rho_c S_{c-1} - S_c                                     (0 < c < e)
    tau_joint     = eta_e rho_e S_{e-1}                                           (joint cluster)

and the joint cluster's inertia joins ``M``. In matrix form, per drive, with ``X`` the cluster
coordinates: ``delta = A X + a q``, the clusters' generalized forces ``-B^T S`` (B is A with
the ``-rho`` entries scaled by the driving efficiency) and the joint's ``-b^T S``.

The rigid stepper and the compliant model's ``implicit`` integrator take one implicit Euler step
of the clusters and the joint together, linear in the transmission: the springs' torques at the
step's end are ``S+ = S0 + G Omega+ + g v+`` (``S0 = C (A X + a q)``, ``G = (h C + D) A``,
``g = (h C + D) a``), the clusters' equation
``(J + h B^T G + h m e_0 e_0^T) Omega+ = J Omega + h (-B^T S0 + g_u u e_0) - h B^T g v+``
gives ``Omega+ = P + Q v+``, and the joint's torque at the step's end is
``tau+ = -b^T (S0 + G P) - kappa v+`` with ``kappa = b^T (G Q + g)``: the robot's step solves
with ``M + h kappa`` on the joint's diagonal (:class:`ImplicitTransmissions`). Action and
reaction are taken at the same instant, so the step is unconditionally stable in the spring and
keeps the momentum of a free pair of inertias. The adaptive integrators integrate ``(X, Omega)``
as part of the ODE state, the compliant ``euler`` by semi-implicit Euler (explicit: stable only
for steps below ``2 / omega`` of the transmission's fastest mode). The transmission's state is
``(X, Omega)`` of every elastic drive, appended to the simulator's state; it starts with the
springs at rest (twist 0, or each stage's ``deflection``) and the clusters turning with the joint.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..drives import Drive, clusters
from ..scene import Scene


@dataclass(frozen=True)
class _Elastic:
    """One drive with elastic stages, in the matrix form of the module docstring."""

    drive: Drive
    joint: int              # the joint's index in the minimal coordinates
    input_index: int        # its voltage's index in the inputs
    inertia: np.ndarray     # J_c [kg m^2], (e,)
    A: np.ndarray           # twist rows: delta = A X + a q, (e, e)
    a: np.ndarray           # (e,)
    B: np.ndarray           # driving rows: cluster forces -B^T S, (e, e)
    b: np.ndarray           # joint force -b^T S, (e,)
    stiffness: np.ndarray   # c_k [N m/rad], (e,)
    damping: np.ndarray     # d_k [N m s/rad], (e,)
    motor_gain: float       # eta_0 rho_0 C_M / R [N m/V] on theta_0
    motor_damping: float    # eta_0 rho_0^2 C_M C_E / R [N m s/rad] on theta_0'
    rotor_ratio: float      # rho_0: rotor speed / theta_0'
    ratios: np.ndarray      # rho_c of every cluster, (e + 1,)

    @property
    def size(self) -> int:
        return len(self.inertia)

    def twist(self, q: float, x: np.ndarray) -> np.ndarray:
        """[rad] The twist delta of each spring."""
        return self.A @ x + self.a * q

    def spring_torques(self, q: float, v: float, x: np.ndarray, w: np.ndarray) -> np.ndarray:
        """S [N m] of each spring."""
        return self.stiffness * self.twist(q, x) + self.damping * (self.A @ w + self.a * v)

    def joint_torque(self, q: float, v: float, x: np.ndarray, w: np.ndarray) -> float:
        """[N m] at the joint: eta_e rho_e S_{e-1}."""
        return float(-self.b @ self.spring_torques(q, v, x, w))

    def motor_torque(self, u: float, w: np.ndarray) -> float:
        """[N m] on theta_0: eta_0 rho_0 C_M i (the motor's torque reflected to the coordinate)."""
        return self.motor_gain * u - self.motor_damping * float(w[0])

    def accelerations(self, q: float, v: float, x: np.ndarray, w: np.ndarray, u: float) -> np.ndarray:
        """[rad/s^2] The angular acceleration of every cluster."""
        force = -self.B.T @ self.spring_torques(q, v, x, w)
        force[0] += self.motor_torque(u, w)
        return force / self.inertia

    def coupling(self, q: float, v: float, x: np.ndarray, w: np.ndarray, u: float, h: float
                 ) -> tuple[np.ndarray, np.ndarray, float, float]:
        """One implicit Euler step of the clusters and the joint together, reduced to the joint.

        With ``S+ = S0 + G Omega+ + g v+`` (``S0 = C (A X + a q)``, ``G = (h C + D) A``,
        ``g = (h C + D) a``), the clusters' equation gives ``Omega+ = P + Q v+`` and the joint
        torque at the step's end ``tau+ = tau_P - kappa v+``.

        Returns:
            ``(P, Q, tau_P, kappa)``.
        """
        gain = h * self.stiffness + self.damping
        s0 = self.stiffness * self.twist(q, x)
        G, g = gain[:, None] * self.A, gain * self.a
        lhs = np.diag(self.inertia) + h * self.B.T @ G
        lhs[0, 0] += h * self.motor_damping
        rhs = self.inertia * w - h * self.B.T @ s0
        rhs[0] += h * self.motor_gain * u
        P = np.linalg.solve(lhs, rhs)
        Q = np.linalg.solve(lhs, -h * self.B.T @ g)
        return P, Q, float(-self.b @ (s0 + G @ P)), float(self.b @ (G @ Q + g))

    def initial(self, q: float, v: float) -> tuple[np.ndarray, np.ndarray]:
        """Clusters turning with the joint, each spring at its stage's ``deflection``."""
        e = self.size
        x, w = np.zeros(e), np.zeros(e)
        angle, speed = q, v
        for k in reversed(range(e)):
            stage = self.drive.stages[self.drive.elastic_stages[k]]
            angle, speed = self.ratios[k + 1] * angle + stage.deflection, self.ratios[k + 1] * speed
            x[k], w[k] = angle, speed
        return x, w


def _elastic(scene: Scene, drive: Drive) -> _Elastic:
    """The matrices of one elastic drive (module docstring)."""
    parts = clusters(drive)
    e = len(parts) - 1
    rho = np.array([c.input_ratio for c in parts])
    eta = np.array([c.input_efficiency for c in parts])
    A, B = np.eye(e), np.eye(e)
    a, b = np.zeros(e), np.zeros(e)
    for k in range(e - 1):
        A[k, k + 1], B[k, k + 1] = -rho[k + 1], -eta[k + 1] * rho[k + 1]
    a[e - 1], b[e - 1] = -rho[e], -eta[e] * rho[e]
    springs = [drive.stages[i] for i in drive.elastic_stages]
    return _Elastic(
        drive=drive, joint=scene.coordinate_names.index(drive.joint),
        input_index=scene.inputs.coordinates.index(drive.joint),
        inertia=np.array([c.inertia for c in parts[:-1]]), A=A, a=a, B=B, b=b,
        stiffness=np.array([float(s.stiffness or 0.0) for s in springs]),
        damping=np.array([s.damping for s in springs]),
        motor_gain=float(eta[0] * rho[0] * drive.motor_gain),
        motor_damping=float(eta[0] * rho[0] ** 2 * drive.motor_damping),
        rotor_ratio=float(rho[0]), ratios=rho,
    )


class Transmissions:
    """The elastic transmissions of a scene: their state ``z = (X, Omega)`` and dynamics.

    ``z`` holds every elastic drive's cluster angles [rad], then their speeds [rad/s] (in the
    order of ``scene.drives``); :attr:`size` is ``2 E`` for E elastic stages in all.
    """

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.parts = tuple(_elastic(scene, d) for d in scene.drives.values() if d.elastic)
        sizes = [p.size for p in self.parts]
        self.offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
        self.count = int(self.offsets[-1])

    @property
    def size(self) -> int:
        """Entries of ``z``: 2 per elastic stage."""
        return 2 * self.count

    def __bool__(self) -> bool:
        return self.count > 0

    def _views(self, z: np.ndarray, i: int) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self.offsets[i], self.offsets[i + 1]
        return z[lo:hi], z[self.count + lo:self.count + hi]

    def initial(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``z`` at the start: clusters turning with their joints, springs at their deflection."""
        z = np.zeros(self.size)
        for i, p in enumerate(self.parts):
            x, w = self._views(z, i)
            x[:], w[:] = p.initial(float(q[p.joint]), float(v[p.joint]))
        return z

    def joint_force(self, q: np.ndarray, v: np.ndarray, z: np.ndarray) -> np.ndarray:
        """[N m] per coordinate: the springs' torques on the joints (n,)."""
        out = np.zeros(len(q))
        for i, p in enumerate(self.parts):
            x, w = self._views(z, i)
            out[p.joint] += p.joint_torque(float(q[p.joint]), float(v[p.joint]), x, w)
        return out

    def derivative(self, q: np.ndarray, v: np.ndarray, z: np.ndarray, u: np.ndarray) -> np.ndarray:
        """dz/dt = (Omega, Omega')."""
        out = np.empty(self.size)
        out[:self.count] = z[self.count:]
        for i, p in enumerate(self.parts):
            x, w = self._views(z, i)
            lo, hi = self.offsets[i], self.offsets[i + 1]
            out[self.count + lo:self.count + hi] = p.accelerations(
                float(q[p.joint]), float(v[p.joint]), x, w, float(u[p.input_index]))
        return out

    def implicit(self, q: np.ndarray, v: np.ndarray, z: np.ndarray, u: np.ndarray, h: float
                 ) -> ImplicitTransmissions:
        """The transmissions' part of one implicit Euler step from ``(q, v, z)`` with input ``u``."""
        n = len(q)
        force, stiffening = np.zeros(n), np.zeros(n)
        gains = []
        for i, p in enumerate(self.parts):
            x, w = self._views(z, i)
            P, Q, tau, kappa = p.coupling(float(q[p.joint]), float(v[p.joint]), x, w,
                                          float(u[p.input_index]), h)
            force[p.joint] += tau - kappa * float(v[p.joint])
            stiffening[p.joint] += h * kappa
            gains.append((P, Q))
        return ImplicitTransmissions(self, z, h, force, stiffening, tuple(gains))

    def energy(self, q: np.ndarray, z: np.ndarray) -> float:
        """[J] kinetic energy of the clusters plus the springs' elastic energy."""
        total = 0.0
        for i, p in enumerate(self.parts):
            x, w = self._views(z, i)
            delta = p.twist(float(q[p.joint]), x)
            total += 0.5 * float(p.inertia @ w**2) + 0.5 * float(p.stiffness @ delta**2)
        return total

    def motor_power(self, z: np.ndarray, u: np.ndarray) -> float:
        """[W] the motors' mechanical power into the elastic transmissions."""
        total = 0.0
        for i, p in enumerate(self.parts):
            _, w = self._views(z, i)
            total += p.motor_torque(float(u[p.input_index]), w) * float(w[0])
        return total

    def report(self, q: np.ndarray, v: np.ndarray, z: np.ndarray, u: np.ndarray
               ) -> dict[str, dict[str, Any]]:
        """Per elastic drive: motor speed [rad/s], joint torque [N m], stage deflections [rad], rates.

        The deflections and their rates [rad/s] have one entry per stage of the drive (0 for a
        rigid stage).
        """
        out = {}
        for i, p in enumerate(self.parts):
            x, w = self._views(z, i)
            qj, vj = float(q[p.joint]), float(v[p.joint])
            deflection, rate = np.zeros(len(p.drive.stages)), np.zeros(len(p.drive.stages))
            deflection[list(p.drive.elastic_stages)] = p.twist(qj, x)
            rate[list(p.drive.elastic_stages)] = p.twist(vj, w)
            out[p.drive.joint] = {"motor_speed": p.rotor_ratio * float(w[0]),
                                  "torque": p.joint_torque(qj, vj, x, w),
                                  "deflection": deflection, "deflection_rate": rate}
        return out

@dataclass(frozen=True)
class ImplicitTransmissions:
    """The transmissions' part of one implicit Euler step (module docstring).

    The robot's step solves ``(M + diag(mass_diagonal)) (v+ - v) = h (f + force) + J^T p``; then
    :meth:`state` gives the transmissions' state at the step's end from ``v+``.

    Attributes:
        force: [N m] per coordinate, ``tau_P - kappa v``: the springs' torques at the step's end
            with the joints' new speed moved to the left.
        mass_diagonal: [kg m^2] per coordinate, ``h kappa``.
    """

    model: Transmissions
    z: np.ndarray
    h: float
    force: np.ndarray
    mass_diagonal: np.ndarray
    gains: tuple[tuple[np.ndarray, np.ndarray], ...]

    def mass(self, mass: np.ndarray) -> np.ndarray:
        """``M + diag(h kappa)``."""
        return mass + np.diag(self.mass_diagonal)

    def state(self, v_new: np.ndarray) -> np.ndarray:
        """``z`` at the step's end: ``Omega+ = P + Q v+``, ``X+ = X + h Omega+``."""
        model, out = self.model, np.empty_like(self.z)
        for i, (p, (P, Q)) in enumerate(zip(model.parts, self.gains, strict=True)):
            x, _ = model._views(self.z, i)
            xo, wo = model._views(out, i)
            wo[:] = P + Q * float(v_new[p.joint])
            xo[:] = x + self.h * wo
        return out


class TransmissionRun:
    """A fixed-step simulator's record of the elastic transmissions along a run.

    The stepper takes :meth:`implicit`'s force and mass into its step, then calls :meth:`advance`
    with the joints' new velocity (:meth:`move` first for each part of a step split at a landing,
    so that the transmissions move over the whole step, as the joints do); :meth:`energy` and
    :meth:`work` give the
    series the validity check needs, :meth:`info` what ``Trajectory.info["transmissions"]`` holds.
    """

    def __init__(self, scene: Scene, q0: np.ndarray, v0: np.ndarray) -> None:
        self.model = Transmissions(scene)
        self.z = self.model.initial(q0, v0)
        self.samples = [self.z.copy()]
        self._work = [0.0]
        self._part_work = 0.0  # [J] the motors' work over the parts of the current step moved so far

    def implicit(self, q: np.ndarray, v: np.ndarray, u: np.ndarray, h: float) -> ImplicitTransmissions:
        """The transmissions' part of a step of ``h`` [s] from the run's current state."""
        return self.model.implicit(q, v, self.z, u, h)

    def move(self, step: ImplicitTransmissions, v_new: np.ndarray, u: np.ndarray) -> None:
        """Move the transmissions over a part of a step (no sample); :meth:`advance` books its work."""
        self.z = step.state(v_new)
        self._part_work += step.h * self.model.motor_power(self.z, u)

    def undo_parts(self, z: np.ndarray) -> None:
        """Go back to ``z``, the state at the start of a step that failed, forgetting its parts."""
        self.z, self._part_work = z, 0.0

    def advance(self, step: ImplicitTransmissions, v_new: np.ndarray, u: np.ndarray) -> None:
        """Move the transmissions to the step's end and record the sample."""
        self.z = step.state(v_new)
        self.samples.append(self.z.copy())
        work = self._part_work + step.h * self.model.motor_power(self.z, u)
        self._work.append(self._work[-1] + work)
        self._part_work = 0.0

    def energy(self, qs: np.ndarray) -> np.ndarray:
        """[J] per sample: the clusters' kinetic and the springs' elastic energy."""
        return np.array([self.model.energy(q, z) for q, z in zip(qs, self.samples, strict=False)])

    def work(self) -> np.ndarray:
        """[J] per sample: the motors' cumulative mechanical work into the transmissions."""
        return np.array(self._work)

    def info(self) -> dict[str, Any]:
        """``{"state": (T, 2E) samples of z, "size": 2E}``."""
        return {"state": np.array(self.samples), "size": self.model.size}


__all__ = ["ImplicitTransmissions", "TransmissionRun", "Transmissions"]
