"""Contact modes and the linear system each one imposes (METHOD §2).

Every active contact is in one of four modes, always spelled S, L, R, F:

| mode | equalities | inequalities |
| --- | --- | --- |
| S separate | lam_N = 0, lam_T = 0 | a_N >= 0 (only if v_N = 0) |
| F fixed | a_N = 0, a_T = 0 | lam_N >= 0, -mu lam_N <= lam_T <= mu lam_N |
| R slide right (+t) | a_N = 0, lam_T = -mu lam_N | lam_N >= 0, a_T >= 0 (only if v_T = 0) |
| L slide left (-t) | a_N = 0, lam_T = +mu lam_N | lam_N >= 0, a_T <= 0 (only if v_T = 0) |

Velocity pruning: v_N > 0 leaves S only; v_T > 0 leaves {S, R}; v_T < 0 leaves {S, L}; v_N < 0
is an impact, reported as :class:`~frcontrol.errors.ImpactState`.

With the unknowns ``x = (dv, lam_N, lam_T)`` (n + 2k entries) a mode of the whole system
(one letter per contact, e.g. ``"SFF"``) is the linear system::

    A x = B u + c          (dynamics: n rows; mode equalities: 2 rows per contact)
    G x <= g               (mode inequalities)

built here by :func:`build_mode_system` without solving anything. A partial assignment (fewer
letters than contacts) leaves the remaining contacts' forces free and their accelerations
unconstrained: a relaxation of every mode that completes it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .errors import ImpactState, InputError
from .scene import Scene

MODE_LETTERS = "SLRF"
"""The four contact modes, in their canonical order."""

VELOCITY_TOLERANCE = 1e-9
"""[m/s] A contact velocity (normal or tangential) with magnitude <= this counts as zero."""


@dataclass(frozen=True)
class ContactProblem:
    """The rigid-body contact problem of a scene's active contacts at one state.

    ``M dv + h = S^T u + J_N^T lam_N + J_T^T lam_T`` with contact accelerations
    ``a_N = J_N dv + drift_N`` and ``a_T = J_T dv + drift_T``.

    Attributes:
        coordinates: names of the n minimal coordinates.
        contacts: names of the k active contacts, in scene order.
        inputs: names of the m inputs.
        mass_matrix: M (n, n) [kg, kg m, kg m^2].
        bias: h (n,) [N, N m].
        input_map: S^T (n, m).
        jacobian_normal: J_N (k, n); jacobian_tangent: J_T (k, n).
        drift_normal: dJ_N v (k,) [m/s^2]; drift_tangent: dJ_T v (k,) [m/s^2].
        normal_velocities: v_N (k,) [m/s]; tangential_velocities: v_T (k,) [m/s].
        mu: friction coefficients (k,).
        lower: input lower limits (m,) (-inf where none); upper: upper limits (m,).
        velocity_tolerance: [m/s] what counts as a zero contact velocity.
    """

    coordinates: tuple[str, ...]
    contacts: tuple[str, ...]
    inputs: tuple[str, ...]
    mass_matrix: np.ndarray
    bias: np.ndarray
    input_map: np.ndarray
    jacobian_normal: np.ndarray
    jacobian_tangent: np.ndarray
    drift_normal: np.ndarray
    drift_tangent: np.ndarray
    normal_velocities: np.ndarray
    tangential_velocities: np.ndarray
    mu: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    velocity_tolerance: float = VELOCITY_TOLERANCE

    @property
    def n(self) -> int:
        """Number of coordinates."""
        return len(self.coordinates)

    @property
    def k(self) -> int:
        """Number of active contacts."""
        return len(self.contacts)

    @property
    def m(self) -> int:
        """Number of inputs."""
        return len(self.inputs)

    @classmethod
    def from_scene(
        cls,
        scene: Scene,
        q: np.ndarray | None = None,
        v: np.ndarray | None = None,
        *,
        contacts: Sequence[int] | None = None,
        velocity_tolerance: float = VELOCITY_TOLERANCE,
    ) -> ContactProblem:
        """The problem at the scene's state (or at ``q``, ``v``).

        Args:
            scene: the scene.
            q: configuration (default: the scene's).
            v: velocity (default: the scene's).
            contacts: indices into ``scene.contacts`` of the contacts that take part (default: the
                scene's active contacts), e.g. those a simulator finds touching.
            velocity_tolerance: [m/s] |v| at most this is zero (see :data:`VELOCITY_TOLERANCE`).
        """
        indices = list(scene.active_indices if contacts is None else contacts)
        state = scene.robot.state(scene.q if q is None else q, scene.v if v is None else v, indices)
        active = [scene.contacts[i] for i in indices]
        return cls(
            coordinates=scene.coordinate_names,
            contacts=tuple(c.name for c in active),
            inputs=scene.inputs.coordinates,
            mass_matrix=state.mass_matrix,
            bias=state.bias,
            input_map=scene.inputs.selection_transpose(scene.robot.nv),
            jacobian_normal=state.jacobian_normal,
            jacobian_tangent=state.jacobian_tangent,
            drift_normal=state.drift_normal,
            drift_tangent=state.drift_tangent,
            normal_velocities=state.normal_velocities,
            tangential_velocities=state.tangential_velocities,
            mu=np.array([c.mu for c in active], dtype=float),
            lower=scene.inputs.lower,
            upper=scene.inputs.upper,
            velocity_tolerance=velocity_tolerance,
        )

    def allowed_modes(self) -> tuple[str, ...]:
        """Per contact, the modes its velocity allows (velocity pruning), in S, L, R, F order.

        Raises:
            ImpactState: a contact moves into its surface (v_N < -tolerance).
        """
        tol = self.velocity_tolerance
        allowed = []
        for name, vn, vt in zip(self.contacts, self.normal_velocities, self.tangential_velocities,
                                strict=True):
            if vn < -tol:
                raise ImpactState(name, vn)
            if vn > tol:
                allowed.append("S")
            elif vt > tol:
                allowed.append("SR")
            elif vt < -tol:
                allowed.append("SL")
            else:
                allowed.append(MODE_LETTERS)
        return tuple(allowed)

    def input_bound_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """The finite input limits as rows ``C u <= d``."""
        m = self.m
        eye = np.eye(m)
        up = np.isfinite(self.upper)
        lo = np.isfinite(self.lower)
        if not m:  # a robot with no inputs: no rows over an empty u
            return np.zeros((0, 0)), np.zeros(0)
        rows = np.vstack([eye[up], -eye[lo]])
        rhs = np.concatenate([self.upper[up], -self.lower[lo]])
        return rows.reshape(-1, m), rhs


@dataclass(frozen=True)
class ModeSystem:
    """The linear system of one (possibly partial) contact mode: ``A x = B u + c``, ``G x <= g``.

    ``x = (dv, lam_N, lam_T)``. Rows of ``G`` carry a label each (``"tip: lam_N >= 0"``) so that
    reports can say which physical condition bounds a domain, and a flag ``motion``: True for the
    rows that state the mode's motion (``a_N >= 0`` of S, ``a_T >= 0`` / ``<= 0`` of R / L), which
    a non-degenerate solution of the mode satisfies strictly.
    """

    mode: str
    A: np.ndarray
    B: np.ndarray
    c: np.ndarray
    G: np.ndarray
    g: np.ndarray
    labels: tuple[str, ...]
    motion: np.ndarray


def check_mode(problem: ContactProblem, mode: str, *, partial: bool = False) -> str:
    """Validate a mode string (one letter S, L, R, F per active contact); return it.

    Raises:
        InputError: a wrong letter or length.
    """
    if not isinstance(mode, str) or any(ch not in MODE_LETTERS for ch in mode):
        raise InputError(f"a mode is a string of the letters S, L, R, F; got {mode!r}")
    if len(mode) > problem.k or (not partial and len(mode) != problem.k):
        raise InputError(f"mode {mode!r} has {len(mode)} letters; the scene has {problem.k} active "
                         f"contacts ({', '.join(problem.contacts)})")
    return mode


def build_mode_system(problem: ContactProblem, mode: str) -> ModeSystem:
    """Assemble the equalities and inequalities of ``mode`` (a prefix of letters is allowed).

    Contacts beyond ``len(mode)`` are unassigned: no rows for them.
    """
    check_mode(problem, mode, partial=True)
    n, k = problem.n, problem.k
    nx = n + 2 * k
    jn, jt = problem.jacobian_normal, problem.jacobian_tangent
    eq_rows = [np.hstack([problem.mass_matrix, -jn.T, -jt.T])]
    eq_rhs = [-problem.bias]
    eq_input = [problem.input_map]
    ineq_rows: list[np.ndarray] = []
    ineq_rhs: list[float] = []
    labels: list[str] = []
    motion: list[bool] = []
    for i, letter in enumerate(mode):
        rows = _contact_rows(problem, i, letter)
        eq_rows.append(np.vstack(rows.pair))
        eq_rhs.append(np.array(rows.pair_rhs))
        eq_input.append(np.zeros((2, problem.m)))
        ineq_rows += rows.inequalities
        ineq_rhs += rows.inequality_rhs
        labels += rows.labels
        motion += rows.motion
    G = np.vstack(ineq_rows) if ineq_rows else np.zeros((0, nx))
    return ModeSystem(
        mode=mode,
        A=np.vstack(eq_rows),
        B=np.vstack(eq_input),
        c=np.concatenate(eq_rhs),
        G=G,
        g=np.array(ineq_rhs, dtype=float),
        labels=tuple(labels),
        motion=np.array(motion, dtype=bool),
    )


@dataclass
class _ContactRows:
    pair: list[np.ndarray]  # two equalities (the contact's mode law)
    pair_rhs: list[float]
    inequalities: list[np.ndarray]
    inequality_rhs: list[float]
    labels: list[str]
    motion: list[bool]  # whether each inequality bounds a motion (an acceleration) or a force


def _contact_rows(problem: ContactProblem, i: int, letter: str) -> _ContactRows:
    """The rows contact ``i`` adds in mode ``letter`` over x = (dv, lam_N, lam_T)."""
    n, k, tol = problem.n, problem.k, problem.velocity_tolerance
    nx = n + 2 * k
    jn, jt, dn, dt = (problem.jacobian_normal[i], problem.jacobian_tangent[i], problem.drift_normal[i],
                      problem.drift_tangent[i])
    name, mu = problem.contacts[i], problem.mu[i]
    i_n, i_t = n + i, n + k + i

    def unit(index: int) -> np.ndarray:
        row = np.zeros(nx)
        row[index] = 1.0
        return row

    def accel_row(jac_row: np.ndarray) -> np.ndarray:
        row = np.zeros(nx)
        row[:n] = jac_row
        return row

    out = _ContactRows([], [], [], [], [], [])
    if letter == "S":
        out.pair, out.pair_rhs = [unit(i_n), unit(i_t)], [0.0, 0.0]
        if abs(problem.normal_velocities[i]) <= tol:
            out.inequalities.append(-accel_row(jn))  # a_N >= 0
            out.inequality_rhs.append(dn)
            out.labels.append(f"{name}: a_N >= 0")
            out.motion.append(True)
        return out
    normal = accel_row(jn)  # a_N = 0
    if letter == "F":
        out.pair, out.pair_rhs = [normal, accel_row(jt)], [-dn, -dt]
    else:
        sign = 1.0 if letter == "R" else -1.0  # R: lam_T = -mu lam_N; L: lam_T = +mu lam_N
        friction = unit(i_t)
        friction[i_n] = sign * mu
        out.pair, out.pair_rhs = [normal, friction], [-dn, 0.0]
    # lam_N >= 0; for a sliding contact measured as the friction force it implies,
    # -max(1, mu) lam_N <= 0 (the same half-space): with mu ~ 1e9 the plain row, after the
    # response is substituted, has coefficients of order 1/mu and would read as a constant
    out.inequalities.append(-(1.0 if letter == "F" else max(1.0, mu)) * unit(i_n))
    out.inequality_rhs.append(0.0)
    out.labels.append(f"{name}: lam_N >= 0")
    out.motion.append(False)
    if letter == "F":
        cone_hi = unit(i_t)
        cone_hi[i_n] = -mu
        cone_lo = -unit(i_t)
        cone_lo[i_n] = -mu
        out.inequalities += [cone_hi, cone_lo]
        out.inequality_rhs += [0.0, 0.0]
        out.labels += [f"{name}: lam_T <= mu lam_N", f"{name}: -lam_T <= mu lam_N"]
        out.motion += [False, False]
    elif abs(problem.tangential_velocities[i]) <= tol:
        sign = 1.0 if letter == "R" else -1.0  # R: a_T >= 0; L: a_T <= 0
        out.inequalities.append(-sign * accel_row(jt))
        out.inequality_rhs.append(sign * dt)
        out.labels.append(f"{name}: a_T {'>=' if letter == 'R' else '<='} 0")
        out.motion.append(True)
    return out


def mode_outputs(problem: ContactProblem, x: np.ndarray) -> dict[str, np.ndarray]:
    """Split ``x = (dv, lam_N, lam_T)`` and add the contact accelerations a_N, a_T."""
    n, k = problem.n, problem.k
    dv = x[:n]
    return {
        "dv": dv,
        "lambda_n": x[n:n + k],
        "lambda_t": x[n + k:n + 2 * k],
        "a_n": problem.jacobian_normal @ dv + problem.drift_normal,
        "a_t": problem.jacobian_tangent @ dv + problem.drift_tangent,
    }


def all_modes(allowed: Sequence[str]) -> list[str]:
    """Every mode string from per-contact allowed letters (the naive, exhaustive list)."""
    modes = [""]
    for letters in allowed:
        modes = [m + ch for m in modes for ch in letters]
    return modes


def contact_mode_letter(normal_force: float, tangential_velocity: float, force_tolerance: float,
                        slip_tolerance: float, tangential_acceleration: float = 0.0,
                        acceleration_tolerance: float = float("inf")) -> str:
    """The mode a contact is in: S, L, R or F. The one rule every part of frcontrol uses.

    S when the normal force [N] is at most ``force_tolerance`` [N]; else R (along +t) or L when
    ``|v_T|`` exceeds ``slip_tolerance`` [m/s]; else, at the acceleration level, R or L when
    ``|a_T|`` exceeds ``acceleration_tolerance`` [m/s^2] (a sticking contact that starts to slip;
    infinite by default: a sampled motion has no acceleration); else F.
    """
    if normal_force <= force_tolerance:
        return "S"
    if tangential_velocity > slip_tolerance:
        return "R"
    if tangential_velocity < -slip_tolerance:
        return "L"
    if tangential_acceleration > acceleration_tolerance:
        return "R"
    if tangential_acceleration < -acceleration_tolerance:
        return "L"
    return "F"


__all__ = [
    "all_modes",
    "contact_mode_letter",
    "build_mode_system",
    "check_mode",
    "ContactProblem",
    "MODE_LETTERS",
    "mode_outputs",
    "ModeSystem",
    "VELOCITY_TOLERANCE",
]
