r"""Compliant-contact simulation: Kelvin–Voigt contacts with a Coulomb slider (docs/maths.md, *Simulation*).

The model
---------
Each modelled contact i (by default the scene's *active* contacts; ``contacts="all"`` models every
contact) is a Kelvin–Voigt element, as in Kraus, Kumar and Dupont (eq. 4-5, 8). With the gap
``phi_i(q)``, the penetration ``delta_i = -phi_i`` and ``d delta_i / dt = -v_N,i = -J_N,i v``:

Normal (no pulling force)::

    lam_N,i = max(0, k_N,i delta_i + b_N,i d delta_i/dt)    if delta_i > 0,   else 0

Tangential: a spring-damper ``(k_T,i, b_T,i)`` *in series with a Coulomb slider*. Its stretch
``s_i`` [m] (the displacement of the contact point from the slider's anchor along t_i) is a state
variable. With ``v_T,i = J_T,i v``, the limit ``L_i = mu_i lam_N,i`` and the force the element would
transmit if the anchor held, ``F_i = k_T,i s_i + b_T,i v_T,i``::

    stick  (|F_i| <= L_i):  lam_T,i = -F_i,              ds_i/dt = v_T,i
    slip   (|F_i| >  L_i):  lam_T,i = -L_i sign(F_i),    ds_i/dt = (L_i sign(F_i) - k_T,i s_i) / b_T,i

In slip the anchor slides so that the spring-damper carries exactly the Coulomb force. Both
``lam_T`` and ``ds/dt`` are continuous across the switch (at ``|F| = L`` the two branches agree), so
the right-hand side is Lipschitz in the tangential state; an open contact (``L = 0``) relaxes its
stretch to 0 at the rate ``k_T / b_T`` (the "reset"). ``b_T > 0`` is required (with ``b_T = 0`` the
slider's rate is undefined: an index-2 problem).

Impacts are not inelastic here: a Kelvin–Voigt contact lets go while still compressed (its force
reaches 0 with ``k delta = -b d delta/dt``), so even critical damping returns some speed (a box
dropped flat at 1.98 m/s leaves at 0.37 m/s with zeta = 1), unlike the rigid model's restitution 0.

Contact zones: a contact whose ``[model.contacts.NAME] zone`` is ``"one_stage"`` or
``"two_stage"`` takes its normal force from the lumped masses, springs and dampers of
:mod:`.zones` (their coordinates join the state ``y = (q, v, s, z)``; the adaptive integrators
only), with the same tangential slider, limited by the zone's normal force while its interface is
closed. An impact (a contact closing faster than ``impact_velocity``) is an ``impact`` event whose
values, filled at the end of its transition phase (:class:`.zones.ImpactPhases`), give its
``peak_force`` [N], ``duration`` [s], ``impulse_normal`` [N s] and normal velocities.

Dynamics (M with the armature of massless coordinates, see :mod:`.armature`)::

    M(q) dv/dt = S^T u - h(q, v) + J_N^T lam_N + J_T^T lam_T,     dq/dt = v

Forward dynamics is unique: the state is ``y = (q, v, s)`` (``2 n + c`` entries for c modelled
contacts), followed by the elastic transmissions' ``z`` when the scene's drives have elastic
stages (:mod:`frcontrol.simulation.transmissions`; a drive's rigid stages are in ``M``, ``h`` and
``S^T``). Stiffness ``k_N`` [N/m] and damping ``b_N`` [N s/m] come from the arguments, else the
scene's ``[model]`` table (:mod:`.model_table`), else its default stiffness and critical damping
``b = 2 zeta sqrt(k m_eff)`` for each contact's effective mass at the initial state
(:class:`ContactOverrides`); ``k_T`` defaults to ``k_N`` and ``b_T`` to critical damping for the tangential
effective mass.

Integration
-----------
``integrator`` picks a SciPy ODE solver with error control and step-size adaptation
(``"radau"``, ``"bdf"``: implicit, for stiff contacts; ``"lsoda"``: switching; ``"rk45"``,
``"dop853"``: explicit) or ``"euler"``: fixed-step semi-implicit (symplectic) Euler with step
``dt`` (``v += dt a(q, v, s); q += dt v; s += dt ds/dt``), explicit and so stable only for
``dt < min_i 2 (sqrt(1 + zeta_i^2) - zeta_i) / omega_i`` (``omega_i = sqrt(k_i / m_eff,i)`` and
``zeta_i`` the damping ratio of contact direction i at the initial state: the explicit damper
shrinks the undamped limit ``2 / omega``; reported as ``info["explicit_stability_limit"]``; a
larger ``dt`` is refused), or ``"implicit"``: fixed-step *linearly implicit* Euler with step ``dt``,
the contact forces taken at the end of the step (below). Samples are taken every
``dt`` from the solvers' dense output; a callable input is held constant over each sample
interval (zero-order hold): it is asked for its value at every sample, at the sampled state, and an
adaptive solver runs on across the samples where that value does not change (a new solver starts
at a sample where it does). The adaptive solvers' step is at most ``max_step`` (default ``dt``)
so that no contact onset is stepped over. A solver that fails (step size underflow, a NaN) or
exceeds ``max_steps`` ends the simulation: ``status = "failed"`` with the time and the
reason, and the trajectory up to there is returned.

The linearly implicit step (``"implicit"``), as peer simulators step stiff contacts: the robot's
``M`` and ``h`` are taken at the start of the step, the contact forces at its end. With
``delta+ = delta - h J_N v+`` and, for a sticking contact, ``s+ = s + h J_T v+``, the law above is
affine in ``v+`` on each contact's status (open, stick, slip with the trial force's sign)::

    lam_N = k_N delta - (k_N h + b_N) J_N v+                   (closed: > 0 and delta+ > 0)
    lam_T = -(k_T s + (k_T h + b_T) J_T v+)                    (stick: |lam_T| <= mu lam_N)
    lam_T = -sign(F) mu lam_N                                  (slip)

so ``M (v+ - v) = h (S^T u - h(q, v) + J_N^T lam_N + J_T^T lam_T)`` is one linear solve. The
statuses start from the explicit law at the step's start and are updated from the solution until
they repeat (at most :data:`ACTIVE_SET_ITERATIONS`). Then ``q+ = q + h v+`` and the stretch
follows its status (stick: ``s + h J_T v+``; slip and open, implicitly:
``s+ = (s + h sign(F) mu lam_N / b_T) / (1 + h k_T / b_T)``). The contact's spring-damper is thus
integrated by implicit Euler, unconditionally stable and strongly damping its oscillation at any
step: ``dt`` may exceed the explicit limit many times, to reach a steady force in a few steps, at
first-order accuracy in ``dt`` for the slow motion.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.integrate
import scipy.linalg

from ..errors import InputError, LimitExceeded
from ..kernel import backend, compiled, twin
from ..model import RobotState
from ..scene import Scene
from .armature import Armature, mass_factor, massless_armature, solve_mass
from .choices import INTEGRATORS
from .inputs import (
    STEP_COUNT_TOLERANCE,
    InitialState,
    InputSchedule,
    check_simulation_times,
    input_schedule,
)
from .model_table import ContactParameters, model_options
from .rigid import IMPACT_VELOCITY
from .trajectory import ContactEvent, EventKind, SimulationFailure, Trajectory, TrajectoryStatus
from .transmissions import Transmissions
from .validity import HINT as VALIDITY_HINT
from .validity import assess
from .zones import ContactZones, ImpactPhases, ZoneForces, contact_zones

_SCIPY_SOLVERS = {"radau": "Radau", "bdf": "BDF", "lsoda": "LSODA", "rk45": "RK45", "dop853": "DOP853"}

DEFAULT_RTOL = 1e-6
"""[-] Relative error tolerance of the adaptive integrators."""

DEFAULT_ATOL = 1e-9
"""[m, m/s] Absolute error tolerance of the adaptive integrators (penetrations are ~ m g / k)."""

MAX_STEPS = 500_000
"""Integrator steps per simulation at most (then ``status = "failed"``)."""

ACTIVE_SET_ITERATIONS = 8
"""The linearly implicit step re-solves with updated contact statuses (open, stick, slip) at most
this many times; statuses that still change then (a contact at a status boundary) keep the last
solve, which satisfies the law of the statuses it was solved with."""

DIVERGENCE_VELOCITY = 1e8
"""[m/s or rad/s] A velocity above this (or a NaN) is taken as a blow-up and ends the simulation as
failed. Deliberately far above anything physical: a massless leg with a small armature legitimately
spins at thousands of rad/s under a few N m."""

IMMOBILE_ROW_TOLERANCE = 1e-12
"""[-] A contact direction whose inverse effective mass ``J M^-1 J^T`` times the heaviest diagonal
entry of M is at most this cannot move the robot: its effective mass is taken as that entry."""


@dataclass(frozen=True)
class CompliantContacts:
    """The modelled contacts and their resolved parameters (arrays over the c modelled contacts).

    Attributes:
        names: contact names; indices: their indices in ``scene.contacts``.
        mu: friction coefficients [-].
        stiffness: k_N [N/m]; damping: b_N [N s/m].
        tangential_stiffness: k_T [N/m]; tangential_damping: b_T [N s/m].
        effective_mass_normal: m_N = 1 / (J_N M^-1 J_N^T) [kg] at the initial state.
        effective_mass_tangent: m_T = 1 / (J_T M^-1 J_T^T) [kg] at the initial state.
        damping_ratio: zeta [-] used for the damping that was not given.
    """

    names: tuple[str, ...]
    indices: tuple[int, ...]
    mu: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    tangential_stiffness: np.ndarray
    tangential_damping: np.ndarray
    effective_mass_normal: np.ndarray
    effective_mass_tangent: np.ndarray
    damping_ratio: np.ndarray

    @property
    def count(self) -> int:
        """Number of modelled contacts c."""
        return len(self.names)

    def report(self) -> dict:
        """The ``info["contacts"]`` entry: parameters per contact."""
        return {
            name: {"stiffness": self.stiffness[i], "damping": self.damping[i],
                   "tangential_stiffness": self.tangential_stiffness[i],
                   "tangential_damping": self.tangential_damping[i],
                   "effective_mass_normal": self.effective_mass_normal[i],
                   "effective_mass_tangent": self.effective_mass_tangent[i], "mu": self.mu[i]}
            for i, name in enumerate(self.names)
        }


def contact_forces(
    contacts: CompliantContacts,
    gaps: np.ndarray,
    normal_velocities: np.ndarray,
    tangential_velocities: np.ndarray,
    stretch: np.ndarray,
    zones: tuple[Sequence[int], ZoneForces] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The Kelvin–Voigt forces and the stretch rates (module docstring's equations).

    Args:
        contacts: the modelled contacts.
        gaps: phi [m].
        normal_velocities: v_N [m/s].
        tangential_velocities: v_T [m/s].
        stretch: s [m], the tangential springs' stretches.
        zones: the contact zones' slots among the modelled contacts and their forces
            (:mod:`.zones`): there the normal force is the zone's ``F_r`` and the friction limit
            ``mu max(0, F_r)`` while the zone's interface is closed.

    Returns:
        ``(lam_N, lam_T, ds/dt, status)`` with status per contact 0 = open (no normal force),
        1 = stick, 2 = slip.

    By the kernel's ``contact_forces`` (:func:`frcontrol.kernel.backend`): without zones, the compiled
    kernel's ``compliant_law`` gives the same numbers in one call; its NumPy twin is
    :func:`_contact_forces_numpy`.
    """
    return backend().contact_forces(
        contacts, gaps, normal_velocities, tangential_velocities, stretch, zones)


def _contact_forces_compiled(contacts: CompliantContacts, gaps: np.ndarray, normal_velocities: np.ndarray,
                             tangential_velocities: np.ndarray, stretch: np.ndarray,
                             zones: tuple[Sequence[int], ZoneForces] | None
                             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`contact_forces` by the compiled kernel's ``compliant_law`` (with zones: NumPy's)."""
    if zones is not None:
        return _contact_forces_numpy(contacts, gaps, normal_velocities, tangential_velocities, stretch, zones)
    c = contacts.count
    lam_n, lam_t, rate, status = np.empty(c), np.empty(c), np.empty(c), np.empty(c, dtype=np.int64)
    kernel: Any = compiled
    kernel.compliant_law(*(np.ascontiguousarray(a, dtype=float) for a in (
        gaps, normal_velocities, tangential_velocities, stretch, contacts.mu, contacts.stiffness,
        contacts.damping, contacts.tangential_stiffness, contacts.tangential_damping)),
        lam_n, lam_t, rate, status)
    return lam_n, lam_t, rate, status


def _contact_forces_numpy(contacts: CompliantContacts, gaps: np.ndarray, normal_velocities: np.ndarray,
                          tangential_velocities: np.ndarray, stretch: np.ndarray,
                          zones: tuple[Sequence[int], ZoneForces] | None
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`contact_forces` in NumPy (the reference twin)."""
    delta = -gaps
    lam_n = np.where(delta > 0.0,
                     np.maximum(0.0, contacts.stiffness * delta - contacts.damping * normal_velocities), 0.0)
    limit = contacts.mu * lam_n
    closed = lam_n > 0.0
    if zones is not None:
        slots, zone = list(zones[0]), zones[1]
        lam_n[slots] = zone.robot_force
        closed[slots] = zone.closed
        limit[slots] = contacts.mu[slots] * np.maximum(zone.robot_force, 0.0) * zone.closed
    trial = contacts.tangential_stiffness * stretch + contacts.tangential_damping * tangential_velocities
    stick = np.abs(trial) <= limit
    sign = np.sign(trial)
    lam_t = np.where(stick, -trial, -limit * sign)
    rate = np.where(stick, tangential_velocities,
                    (limit * sign - contacts.tangential_stiffness * stretch) / contacts.tangential_damping)
    status = np.where(closed, np.where(stick, 1, 2), 0)
    return lam_n, lam_t, rate, status


twin("contact_forces", numpy=_contact_forces_numpy, compiled=_contact_forces_compiled)


def _positive(value: float | None, label: str, *, allow_zero: bool = False) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{label} must be a finite number, got {value!r}")
    if value < 0 or (value == 0 and not allow_zero):
        raise InputError(f"{label} must be {'>= 0' if allow_zero else '> 0'}, got {value}")
    return float(value)


@dataclass(frozen=True)
class ContactOverrides:
    """Contact parameters given for every modelled contact, over the scene's ``[model]`` (None: not given).

    Attributes:
        stiffness: k_N [N/m], > 0.
        damping: b_N [N s/m], >= 0.
        damping_ratio: zeta [-] for the damping not given, > 0.
        tangential_stiffness: k_T [N/m], > 0.
        tangential_damping: b_T [N s/m], > 0.

    Raises:
        InputError: a value out of its range, or not a finite number.
    """

    stiffness: float | None = None
    damping: float | None = None
    damping_ratio: float | None = None
    tangential_stiffness: float | None = None
    tangential_damping: float | None = None

    def __post_init__(self) -> None:
        if self.tangential_damping is not None and self.tangential_damping == 0:
            raise InputError("the tangential damping must be > 0 [N s/m]: the spring-damper in series with "
                             "the Coulomb slider needs it (it sets how fast the slider's anchor follows)")
        checked = {
            "stiffness": _positive(self.stiffness, "the contact stiffness [N/m]"),
            "damping": _positive(self.damping, "the contact damping [N s/m]", allow_zero=True),
            "damping_ratio": _positive(self.damping_ratio, "the damping ratio"),
            "tangential_stiffness": _positive(self.tangential_stiffness, "the tangential stiffness [N/m]"),
            "tangential_damping": _positive(self.tangential_damping, "the tangential damping [N s/m]"),
        }
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    def resolve(self, base: ContactParameters, mass_normal: float, mass_tangent: float
                ) -> tuple[float, float, float, float, float]:
        """``(k_N, b_N, k_T, b_T, zeta)`` of one contact.

        These values, else ``base`` (the contact's ``[model]``), else ``k_T = k_N`` and critical
        damping ``2 zeta sqrt(k m)`` for the effective masses [kg].
        """
        k_n = self.stiffness if self.stiffness is not None else base.stiffness
        k_t = self.tangential_stiffness if self.tangential_stiffness is not None else (
            base.tangential_stiffness if base.tangential_stiffness is not None else k_n)
        zeta = self.damping_ratio if self.damping_ratio is not None else base.damping_ratio
        b_n = self.damping if self.damping is not None else (
            base.damping if base.damping is not None else 2.0 * zeta * math.sqrt(k_n * mass_normal))
        b_t = self.tangential_damping if self.tangential_damping is not None else (
            base.tangential_damping if base.tangential_damping is not None
            else 2.0 * zeta * math.sqrt(k_t * mass_tangent))
        return k_n, b_n, k_t, b_t, zeta


def _effective_masses(factor: tuple[np.ndarray, bool], mass_matrix: np.ndarray, rows: Sequence[np.ndarray]
                      ) -> list[float]:
    """[kg] ``1 / (J M^-1 J^T)`` of each Jacobian row (Cholesky solves).

    A row that cannot move the robot (``J M^-1 J^T`` at most :data:`IMMOBILE_ROW_TOLERANCE` over
    the heaviest coordinate's mass) gets the heaviest coordinate's mass.
    """
    heaviest = float(np.max(np.diag(mass_matrix)))
    masses = []
    for row in rows:
        w = float(row @ scipy.linalg.cho_solve(factor, row))  # 1 / effective mass [1/kg]
        masses.append(1.0 / w if w * heaviest > IMMOBILE_ROW_TOLERANCE else heaviest)
    return masses


def compliant_contacts(
    scene: Scene,
    mass_matrix: np.ndarray,
    jacobian_normal: np.ndarray,
    jacobian_tangent: np.ndarray,
    *,
    contacts: str = "active",
    overrides: ContactOverrides | None = None,
) -> CompliantContacts:
    """Resolve the modelled contacts' parameters (``overrides`` > scene ``[model]`` > defaults).

    Args:
        scene: the scene.
        mass_matrix: the (regularised, positive-definite) M at the initial state.
        jacobian_normal: J_N of ALL the scene's contacts at the initial state, (k, n).
        jacobian_tangent: J_T of all the scene's contacts, (k, n).
        contacts: ``"active"`` (the scene's active contacts) or ``"all"``.
        overrides: parameters for every contact (default: none given).

    Raises:
        InputError: an unknown ``contacts`` choice.
        SceneError: a bad ``[model]`` table.
    """
    if contacts not in ("active", "all"):
        raise InputError(f"contacts must be 'active' or 'all', got {contacts!r}")
    overrides = overrides if overrides is not None else ContactOverrides()
    options = model_options(scene)
    indices = scene.active_indices if contacts == "active" else tuple(range(len(scene.contacts)))
    factor = scipy.linalg.cho_factor(mass_matrix)
    rows = []
    for i in indices:
        m_n, m_t = _effective_masses(factor, mass_matrix, (jacobian_normal[i], jacobian_tangent[i]))
        k_n, b_n, k_t, b_t, zeta = overrides.resolve(options.parameters(scene.contacts[i].name), m_n, m_t)
        rows.append((k_n, b_n, k_t, b_t, m_n, m_t, zeta))
    arr = np.array(rows, dtype=float).reshape(-1, 7)
    return CompliantContacts(
        names=tuple(scene.contacts[i].name for i in indices),
        indices=tuple(indices),
        mu=np.array([scene.contacts[i].mu for i in indices], dtype=float),
        stiffness=arr[:, 0], damping=arr[:, 1], tangential_stiffness=arr[:, 2],
        tangential_damping=arr[:, 3], effective_mass_normal=arr[:, 4],
        effective_mass_tangent=arr[:, 5], damping_ratio=arr[:, 6],
    )


@dataclass(frozen=True)
class _Dynamics:
    """The right-hand side ``dy/dt = f(y; u)`` of the compliant model at one held input."""

    scene: Scene
    contacts: CompliantContacts
    armature: Armature
    input_map: np.ndarray
    zones: ContactZones | None = None
    transmissions: Transmissions | None = None  # elastic drives: their state ends y

    @property
    def stretch_end(self) -> int:
        """Where the contacts' stretch ends in ``y = (q, v, s, z_zones, z_drives)``."""
        return 2 * self.scene.robot.nv + self.contacts.count

    @property
    def zones_end(self) -> int:
        """Where the contact zones' state ends (and the elastic drives' starts) in ``y``."""
        return self.stretch_end + (0 if self.zones is None else self.zones.size)

    def _law(self, y: np.ndarray) -> tuple[RobotState, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                           ZoneForces | None]:
        """``(state, lam_N, lam_T, ds/dt, status, zone forces)`` at ``y``."""
        n, end = self.scene.robot.nv, self.stretch_end
        state = self.scene.robot.state(y[:n], y[n:2 * n], self.contacts.indices)
        zone = None if self.zones is None else self.zones.forces(
            y[end:self.zones_end], state.gaps, state.normal_velocities)
        lam_n, lam_t, rate, status = contact_forces(
            self.contacts, state.gaps, state.normal_velocities, state.tangential_velocities,
            y[2 * n:end], None if zone is None or self.zones is None else (self.zones.slots, zone))
        return state, lam_n, lam_t, rate, status, zone

    def evaluate(self, y: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, tuple]:
        n, end = self.scene.robot.nv, self.zones_end
        q, v = y[:n], y[n:2 * n]
        state, lam_n, lam_t, rate, status, zone = self._law(y)
        force = self.input_map @ u - state.bias + state.jacobian_normal.T @ lam_n \
            + state.jacobian_tangent.T @ lam_t
        parts = [v, np.empty(n), rate]
        if self.transmissions is not None:
            force = force + self.transmissions.joint_force(q, v, y[end:])
            parts.append(self.transmissions.derivative(q, v, y[end:], u))
        factor = mass_factor(self.armature.apply(state.mass_matrix), self.armature)
        parts[1] = solve_mass(factor, force)
        if zone is not None:
            parts.insert(3, zone.rates)
        return np.concatenate(parts), (state, lam_n, lam_t, status)

    def forces(self, y: np.ndarray) -> tuple[RobotState, np.ndarray, np.ndarray, np.ndarray]:
        """The state's kinematics and the contact law at ``y``: ``(state, lam_N, lam_T, status)``.

        What :meth:`evaluate` computes besides the accelerations (no mass matrix solve).
        """
        state, lam_n, lam_t, _, status, _ = self._law(y)
        return state, lam_n, lam_t, status

    def zone_forces(self, y: np.ndarray) -> ZoneForces | None:
        """The contact zones' forces at ``y`` (None without zones)."""
        return self._law(y)[5]

    def switch(self, y: np.ndarray) -> tuple[np.ndarray, float] | None:
        """``y`` with the one-stage zone masses landed or released (:meth:`.zones.ContactZones.switch`).

        Returns ``(y, energy)``, the kinetic energy [J] the landings took, or None when nothing
        changed.
        """
        if self.zones is None:
            return None
        n, start, end = self.scene.robot.nv, self.stretch_end, self.zones_end
        state = self.scene.robot.state(y[:n], y[n:2 * n], self.contacts.indices)
        landed = self.zones.switch(y[start:end], state.gaps, state.normal_velocities)
        if landed is None:
            return None
        return np.concatenate([y[:start], landed[0], y[end:]]), landed[1]

    def explicit_step(self, y: np.ndarray, u: np.ndarray, h: float) -> tuple[np.ndarray, RobotState]:
        """One semi-implicit (symplectic) Euler step: ``v += h a; q += h v; s += h ds/dt``."""
        n = self.scene.robot.nv
        ydot, (state, _, _, _) = self.evaluate(y, u)
        y_new = y.copy()
        y_new[n:2 * n] = y[n:2 * n] + h * ydot[n:2 * n]
        y_new[:n] = y[:n] + h * y_new[n:2 * n]
        y_new[2 * n:] = y[2 * n:] + h * ydot[2 * n:]
        if self.transmissions is not None:  # the clusters' angles move with their new speeds
            end, count = self.zones_end, self.transmissions.count
            y_new[end:end + count] = y[end:end + count] + h * y_new[end + count:]
        return y_new, state

    def implicit_step(self, y: np.ndarray, u: np.ndarray, h: float) -> tuple[np.ndarray, RobotState]:
        """One linearly implicit Euler step (module docstring): contact forces at the step's end."""
        n, end = self.scene.robot.nv, self.stretch_end
        q, v, s = y[:n], y[n:2 * n], y[2 * n:end]
        state = self.scene.robot.state(q, v, self.contacts.indices)
        _, _, _, status = contact_forces(self.contacts, state.gaps, state.normal_velocities,
                                         state.tangential_velocities, s)
        sign = np.sign(self.contacts.tangential_stiffness * s
                       + self.contacts.tangential_damping * state.tangential_velocities)
        mass, force = self.armature.apply(state.mass_matrix), self.input_map @ u - state.bias
        coupled = None
        if self.transmissions is not None:  # elastic drives: see frcontrol.simulation.transmissions
            coupled = self.transmissions.implicit(q, v, y[end:], u, h)
            mass, force = coupled.mass(mass), force + coupled.force
        system = _ImplicitStep(self.contacts, state, mass, force, v, s, h)
        v_new = system.solve(status, sign)
        for _ in range(ACTIVE_SET_ITERATIONS):
            new_status, new_sign = system.statuses(v_new)
            sliding = status == 2
            if np.array_equal(new_status, status) and np.array_equal(new_sign[sliding], sign[sliding]):
                break
            status, sign = new_status, new_sign
            v_new = system.solve(status, sign)
        parts = [q + h * v_new, v_new, system.stretch(v_new, status, sign)]
        if coupled is not None:
            parts.append(coupled.state(v_new))
        return np.concatenate(parts), state


@dataclass(frozen=True)
class _ImplicitStep:
    """The linear system of one linearly implicit step: ``(M + h K) v+ = M v + h (f + r)``.

    ``K`` and ``r`` depend on the contacts' statuses (0 open, 1 stick, 2 slip) and slip signs.
    """

    contacts: CompliantContacts
    state: RobotState
    mass: np.ndarray
    free_force: np.ndarray  # S^T u - h(q, v)
    v: np.ndarray
    s: np.ndarray
    h: float

    def solve(self, status: np.ndarray, sign: np.ndarray) -> np.ndarray:
        """``v+`` for these statuses."""
        c, st, h = self.contacts, self.state, self.h
        closed, stick, slip = status > 0, status == 1, status == 2
        delta = -st.gaps
        normal_gain = np.where(closed, c.stiffness * h + c.damping, 0.0)  # lam_N = k delta - gain J_N v+
        normal_force = np.where(closed, c.stiffness * delta, 0.0)
        tangent_gain = np.where(stick, c.tangential_stiffness * h + c.tangential_damping, 0.0)
        friction = np.where(slip, sign * c.mu, 0.0)  # slip: lam_T = -sign mu lam_N
        jn, jt = st.jacobian_normal, st.jacobian_tangent
        # J^T lam(v+) = J_N^T (k delta - g_N J_N v+) - J_T^T (k_T s + g_T J_T v+)   (stick)
        #             - J_T^T sign mu (k delta - g_N J_N v+)                        (slip)
        # the v+ terms, moved to the left: K = J_N^T g_N J_N + J_T^T g_T J_T - J_T^T sign mu g_N J_N
        stiffness = ((jn.T * normal_gain) @ jn + (jt.T * tangent_gain) @ jt
                     - (jt.T * (friction * normal_gain)) @ jn)
        rhs = self.mass @ self.v + h * (self.free_force + jn.T @ normal_force
                                        - jt.T @ np.where(stick, c.tangential_stiffness * self.s, 0.0)
                                        - jt.T @ (friction * normal_force))
        return np.linalg.solve(self.mass + h * stiffness, rhs)

    def normal_forces(self, v_new: np.ndarray) -> np.ndarray:
        """``lam_N`` at the step's end if every contact were closed (the law before its max)."""
        c, st = self.contacts, self.state
        return c.stiffness * -st.gaps - (c.stiffness * self.h + c.damping) * (st.jacobian_normal @ v_new)

    def statuses(self, v_new: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The contact law's statuses and trial-force signs at the step's end, for ``v+``."""
        c, st, h = self.contacts, self.state, self.h
        lam_n = self.normal_forces(v_new)
        closed = (lam_n > 0.0) & (-st.gaps - h * (st.jacobian_normal @ v_new) > 0.0)
        v_t = st.jacobian_tangent @ v_new
        trial = c.tangential_stiffness * (self.s + h * v_t) + c.tangential_damping * v_t
        stick = np.abs(trial) <= c.mu * np.maximum(lam_n, 0.0)
        return np.where(closed, np.where(stick, 1, 2), 0), np.sign(trial)

    def stretch(self, v_new: np.ndarray, status: np.ndarray, sign: np.ndarray) -> np.ndarray:
        """``s+``: stick ``s + h v_T+``; slip and open relax implicitly towards the slider's force."""
        c, h = self.contacts, self.h
        limit = np.where(status == 2, c.mu * np.maximum(self.normal_forces(v_new), 0.0), 0.0)
        relaxed = (self.s + h * sign * limit / c.tangential_damping) / (1.0 + h * c.tangential_stiffness
                                                                        / c.tangential_damping)
        return np.where(status == 1, self.s + h * (self.state.jacobian_tangent @ v_new), relaxed)


@dataclass(frozen=True)
class CompliantSettings:
    """The compliant model's options (checked by :func:`simulate_compliant`).

    Attributes:
        integrator: one of :data:`INTEGRATORS`.
        stiffness: k_N [N/m] of every modelled contact (default: the scene's ``[model]``).
        damping: b_N [N s/m] (default: the scene's, else critical for the effective mass).
        damping_ratio: zeta [-] for damping that is not given.
        tangential_stiffness: k_T [N/m] (default: k_N).
        tangential_damping: b_T [N s/m], > 0 (default: critical).
        contacts: ``"active"`` (the scene's active contacts only: inactive ones add no state and
            no force) or ``"all"``.
        rtol: relative tolerance of the adaptive integrators.
        atol: absolute tolerance of the adaptive integrators.
        max_step: [s] largest step of the adaptive integrators (default ``dt``).
        max_steps: integrator steps at most.
        armature: rotor inertia for massless coordinates (default: the scene's ``[model]``).
        impact_velocity: [m/s] a contact closing faster than this is an ``impact`` event.
    """

    integrator: str = "radau"
    stiffness: float | None = None
    damping: float | None = None
    damping_ratio: float | None = None
    tangential_stiffness: float | None = None
    tangential_damping: float | None = None
    contacts: str = "active"
    rtol: float = DEFAULT_RTOL
    atol: float = DEFAULT_ATOL
    max_step: float | None = None
    max_steps: int = MAX_STEPS
    armature: float | None = None
    impact_velocity: float = IMPACT_VELOCITY

    def contact_overrides(self) -> ContactOverrides:
        """The contact parameters given here, for every modelled contact."""
        return ContactOverrides(self.stiffness, self.damping, self.damping_ratio, self.tangential_stiffness,
                                self.tangential_damping)


def simulate_compliant(
    scene: Scene,
    inputs: Mapping[str, float] | Sequence[float] | np.ndarray | InputSchedule | None = None,
    duration: float = 1.0,
    dt: float = 1e-3,
    *,
    settings: CompliantSettings | None = None,
    start: InitialState | None = None,
    initial_stretch: Sequence[float] | np.ndarray | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> Trajectory:
    """Simulate the scene with compliant (Kelvin–Voigt + Coulomb slider) contacts.

    Args:
        scene: the scene.
        inputs: a constant input vector, ``{name: value}`` (others 0), or ``(t, q, v) -> u``
            held constant over each sample interval; None: zero inputs.
        duration: [s] simulated time, > 0.
        dt: [s] sample interval (and control period, and the ``euler`` step), in (0, duration].
        settings: the integrator and its tolerances, the contact parameters, the modelled contacts,
            the armature and the impact speed (:class:`CompliantSettings`; default: its defaults).
        start: the initial configuration and velocity (default: the scene's).
        initial_stretch: s at t = 0 [m], one per modelled contact (default 0).
        progress: called with (simulated time [s], duration [s]) after every integrator step.

    Returns:
        The trajectory (``model = "compliant"``, ``status``, ``failure``), sampled every ``dt``;
        ``info``: the settings, the steps (:meth:`_CompliantRun.report`), ``energy`` [J] (kinetic +
        gravitational), ``elastic_energy`` [J] (the contacts', transmissions' and joint springs';
        theirs alone: ``spring_energy``), ``max_penetration`` [m] per sample, the contacts' parameters.

    Raises:
        InputError: a bad duration or ``dt`` (<= 0, > duration, or above the explicit stability
            limit with ``euler``), stiffness (<= 0), damping (< 0), tangential damping (<= 0),
            tolerance, unknown integrator, bad state, input or stretch.
        LimitExceeded: over the caps of :func:`~.inputs.check_simulation_times`, or ``max_steps``.
        SceneError: a bad ``[model]`` table.
        IllConditioned: M is singular even with the armature.
    """
    duration, dt = check_simulation_times(duration, dt, scene=scene)
    options = CompliantSettings() if settings is None else settings
    start = InitialState() if start is None else start
    integrator, max_step, max_steps = options.integrator, options.max_step, options.max_steps
    _check_integrator_options(integrator, options.rtol, options.atol, max_step, max_steps, duration, dt)
    overrides = options.contact_overrides()
    schedule, constant = input_schedule(scene, inputs)
    y0, arm, params = _initial_state(scene, start, options.armature, options.contacts, overrides,
                                     initial_stretch)
    y0, zones = _with_zones(scene, params, y0, integrator)
    stability_limit = _checked_stability_limit(integrator, dt, params)
    dynamics, y0 = _dynamics(scene, params, arm, y0, zones)
    run = _CompliantRun(scene, dynamics, params, duration, dt, max_steps, options.impact_velocity, y0,
                        progress)
    chosen: dict[str, Any] = {"integrator": integrator, "rtol": options.rtol, "atol": options.atol,
                              "max_step": dt if max_step is None else max_step}
    run.integrate(schedule, None if constant else dt, stability_limit=stability_limit, **chosen)
    info = run.report(explicit_stability_limit=stability_limit, contacts_modelled=options.contacts, **chosen)
    return _trajectory(scene, dynamics, params, arm, run.sample_times[:len(run.samples_y)], run.samples_y,
                       run.samples_u, run.events, run.status, run.failure, info)


def _with_zones(scene: Scene, params: CompliantContacts, y0: np.ndarray, integrator: str
                ) -> tuple[np.ndarray, ContactZones | None]:
    """The initial state with the contact zones' (undeformed) appended, and the zones.

    Raises:
        InputError: a zone with a fixed-step integrator (``euler``, ``implicit``: their steps do
            not carry the zones' masses), or a modelled contact with a ``rigid`` zone.
    """
    zones = contact_zones(scene, params.names)
    if zones is None:
        return y0, None
    if integrator in ("euler", "implicit"):
        raise InputError(f"contact zones ({', '.join(zones.names)}) need an adaptive integrator "
                         f"('radau', 'bdf', 'lsoda', 'rk45', 'dop853'), not {integrator!r}")
    n = scene.robot.nv
    state = scene.robot.state(y0[:n], y0[n:2 * n], params.indices)
    return np.concatenate([y0, zones.initial_state(state.gaps, state.normal_velocities)]), zones


def _dynamics(scene: Scene, params: CompliantContacts, arm: Armature, y0: np.ndarray,
              zones: ContactZones | None = None) -> tuple[_Dynamics, np.ndarray]:
    """The right-hand side, and ``y0`` (zones' state included) with the elastic drives' appended (if any)."""
    transmissions = Transmissions(scene)
    dynamics = _Dynamics(scene, params, arm, scene.inputs.selection_transpose(scene.robot.nv),
                         zones, transmissions if transmissions else None)
    if not transmissions:
        return dynamics, y0
    n = scene.robot.nv
    return dynamics, np.concatenate([y0, transmissions.initial(y0[:n], y0[n:2 * n])])


def _checked_stability_limit(integrator: str, dt: float, params: CompliantContacts) -> float:
    """The explicit step's stability limit [s] (:func:`explicit_stability_limit`), checked for ``euler``.

    Raises:
        InputError: with ``euler``, the step ``dt`` [s] is not below the limit.
    """
    stability_limit = explicit_stability_limit(params)
    if integrator == "euler" and dt >= stability_limit:
        raise InputError(f"the explicit 'euler' step dt = {dt:.3g} s is not below its stability limit "
                         f"2 (sqrt(1 + zeta^2) - zeta) / omega = {stability_limit:.3g} s (omega = "
                         "sqrt(k / m_eff), zeta the damping ratio, of the most restrictive contact): use "
                         "a smaller dt or an implicit integrator ('radau', 'bdf')")
    return stability_limit


def _initial_state(scene: Scene, start: InitialState, armature: float | None, contacts: str,
                   overrides: ContactOverrides, initial_stretch: Sequence[float] | np.ndarray | None
                   ) -> tuple[np.ndarray, Armature, CompliantContacts]:
    """``(y0 = (q, v, s), armature, contact parameters)`` at the start of a run.

    Raises:
        InputError: a bad state or stretch. IllConditioned: M is singular even with the armature.
    """
    robot = scene.robot
    q, v = robot.check_state(scene.q if start.q is None else start.q, scene.v if start.v is None else start.v)
    state0 = robot.state(q, v, list(range(len(scene.contacts))))
    default_armature = model_options(scene).armature if armature is None else armature
    arm = massless_armature(scene, state0.mass_matrix, default_armature)
    mass0 = arm.apply(state0.mass_matrix)
    mass_factor(mass0, arm)  # raises IllConditioned early
    params = compliant_contacts(scene, mass0, state0.jacobian_normal, state0.jacobian_tangent,
                                contacts=contacts, overrides=overrides)
    return np.concatenate([q, v, _initial_stretch(initial_stretch, params)]), arm, params


def _check_integrator_options(integrator: str, rtol: float, atol: float, max_step: float | None,
                              max_steps: int, duration: float, dt: float) -> None:
    """Raises InputError for an unknown integrator or a bad tolerance, step or step count.

    And :class:`~frcontrol.errors.LimitExceeded` for a run over ``max_steps`` (:func:`_check_step_budget`).
    """
    if integrator not in INTEGRATORS:
        raise InputError(f"unknown integrator {integrator!r}; choose one of: {', '.join(INTEGRATORS)}")
    for label, value in (("rtol", rtol), ("atol", atol)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise InputError(f"{label} must be a positive number, got {value!r}")
    if max_step is not None and not (math.isfinite(max_step) and max_step > 0):
        raise InputError(f"max_step must be a positive number [s], got {max_step!r}")
    if not (isinstance(max_steps, int) and max_steps > 0):
        raise InputError(f"max_steps must be a positive integer, got {max_steps!r}")
    _check_step_budget(integrator, duration, dt if max_step is None else max_step, max_steps)


def _check_step_budget(integrator: str, duration: float, step: float, max_steps: int) -> None:
    """Refuse a run that needs more than ``max_steps`` integrator steps before it starts.

    A fixed-step integrator takes ``duration / dt`` steps, an adaptive one at least
    ``duration / max_step`` (``step``: the fixed step or ``max_step`` [s]).

    Raises:
        LimitExceeded: ``field`` ``"duration"``, the least step count and ``max_steps``.
    """
    least = math.ceil(duration / step - STEP_COUNT_TOLERANCE)
    if least > max_steps:
        kind = "steps of dt" if integrator in ("euler", "implicit") else "steps of at most max_step"
        raise LimitExceeded("duration", least, max_steps, (
            f"the compliant model's {integrator!r} integrator needs at least {least:.4g} {kind} = {step:g} s "
            f"for duration = {duration:g} s; a run takes at most max_steps = {max_steps} (MAX_STEPS): "
            "shorten the duration or lengthen the step"))


def _initial_stretch(initial_stretch: Sequence[float] | np.ndarray | None, params: CompliantContacts
                     ) -> np.ndarray:
    """The springs' stretch at t = 0, one per modelled contact (default 0)."""
    c = params.count
    if initial_stretch is None:
        return np.zeros(c)
    s0 = np.asarray(initial_stretch, dtype=float).reshape(-1)
    if s0.shape != (c,) or not np.all(np.isfinite(s0)):
        raise InputError(f"initial_stretch needs {c} finite values (contacts {', '.join(params.names)}), "
                         f"got {s0.tolist()}")
    return s0


def explicit_stability_limit(params: CompliantContacts) -> float:
    """[s] The largest stable semi-implicit Euler step over the modelled contacts (inf without any).

    On ``x'' + 2 zeta w x' + w^2 x = 0`` with the damper explicit the step is stable for
    ``h w < 2 (sqrt(1 + zeta^2) - zeta)`` (``2 / w`` without damping).
    """
    stiffness_all = np.concatenate([params.stiffness, params.tangential_stiffness])
    mass_all = np.concatenate([params.effective_mass_normal, params.effective_mass_tangent])
    damping_all = np.concatenate([params.damping, params.tangential_damping])
    omega = np.sqrt(stiffness_all / mass_all)
    zeta = damping_all / (2.0 * np.sqrt(stiffness_all * mass_all))
    limits = 2.0 * (np.sqrt(1.0 + zeta**2) - zeta) / omega
    return float(np.min(limits)) if limits.size else math.inf


class _CompliantRun:
    """One compliant run's integration: segments of constant input, samples, events and failures."""

    def __init__(self, scene: Scene, dynamics: _Dynamics, params: CompliantContacts, duration: float,
                 dt: float, max_steps: int, impact_velocity: float, y0: np.ndarray,
                 progress: Callable[[float, float], None] | None = None) -> None:
        self.scene, self.dynamics, self.params = scene, dynamics, params
        self.n = scene.robot.nv
        self.duration, self.max_steps, self.impact_velocity = duration, max_steps, impact_velocity
        self._dt = dt
        self.sample_count = max(1, int(np.ceil(duration / dt - 1e-9)))
        self.sample_times = np.minimum(np.arange(self.sample_count + 1) * dt, duration)
        self.next_sample = 1
        self.samples_y = [y0.copy()]
        self.samples_u: list[np.ndarray] = []
        self.events: list[ContactEvent] = []
        self.status: TrajectoryStatus = "completed"
        self.failure: dict[str, Any] | None = None
        self.steps_taken: list[float] = []
        self.rhs_evaluations = 0
        st0, _, _, status0 = dynamics.forces(y0)
        self.contact_status = _event_status(status0, st0.gaps, scene.gap_tolerance)
        self.last_vn = st0.normal_velocities.copy()
        self.impact_phases = ImpactPhases()
        self.landing_energy = 0.0
        self.progress = progress  # called with (time, duration) after each step
        self.start_wall = time.perf_counter()

    def integrate(self, schedule: InputSchedule, hold: float | None, *, integrator: str,
                  stability_limit: float, rtol: float, atol: float, max_step: float) -> None:
        """Run to the end (or a failure).

        ``hold``: None for a constant input (one segment), else the sample interval over which a
        scheduled input is held. The fixed-step integrators run one segment per sample interval;
        the adaptive ones run one solver for as long as the held input keeps its value
        (:meth:`scipy_segment`), and start anew where it changes.
        """
        n = self.n
        y, t_seg = self.samples_y[0].copy(), 0.0
        u = schedule(0.0, y[:n], y[n:2 * n])
        while self.next_sample <= self.sample_count and self.status == "completed":
            if integrator in ("euler", "implicit"):
                u = u if hold is None else schedule(t_seg, y[:n], y[n:2 * n])
                t_end = float(self.sample_times[self.next_sample]) if hold is not None else self.duration
                y, t_seg = self.fixed_step_segment(y, t_seg, t_end, u, stability_limit,
                                                   implicit=integrator == "implicit")
            else:
                y, t_seg, u = self.scipy_segment(integrator, y, t_seg, u, None if hold is None else schedule,
                                                 rtol=rtol, atol=atol, max_step=max_step)

    def report(self, **settings: Any) -> dict[str, Any]:
        """The trajectory's ``info``.

        The run's settings, its steps (``steps``, ``min_step``, ``max_step_taken``, ``mean_step``
        [s]), ``rhs_evaluations``, the contacts' parameters, ``armature`` and ``state_size``.
        """
        steps_taken = self.steps_taken
        return {
            "integrator": settings["integrator"], "dt": self._dt, "rtol": settings["rtol"],
            "atol": settings["atol"], "max_step": settings["max_step"],
            "steps": len(steps_taken),
            "min_step": float(min(steps_taken)) if steps_taken else 0.0,
            "max_step_taken": float(max(steps_taken)) if steps_taken else 0.0,
            "mean_step": float(np.mean(steps_taken)) if steps_taken else 0.0,
            "rhs_evaluations": self.rhs_evaluations,
            "explicit_stability_limit": settings["explicit_stability_limit"],
            "contacts": self.params.report(), "contacts_modelled": settings["contacts_modelled"],
            "state_size": len(self.samples_y[0]),
            "zones_parameters": {} if self.dynamics.zones is None else self.dynamics.zones.report(),
            "zone_landing_energy": self.landing_energy,
            "armature": self.dynamics.armature.report(),
            "impact_velocity": self.impact_velocity, "wall_time": time.perf_counter() - self.start_wall,
        }

    def fail(self, status: TrajectoryStatus, t: float, reason: str, hint: bool = False) -> None:
        """End the run: ``failed`` or ``diverged`` at ``t`` (with the validity hint when diverged)."""
        self.status = status
        self.failure = {"time": t, "reason": reason}
        if hint:
            self.failure["hint"] = VALIDITY_HINT

    def record_events(self, t: float, y_now: np.ndarray, vn_before: np.ndarray) -> np.ndarray:
        """Compare each contact's status with the previous step's; return v_N now."""
        st, lam_n, _, raw = self.dynamics.forces(y_now)
        stat = _event_status(raw, st.gaps, self.scene.gap_tolerance)
        if self.dynamics.zones is not None:  # a zone touches through its interface, not the point's gap
            slots = list(self.dynamics.zones.slots)
            stat[slots] = raw[slots]
        self.impact_phases.update(t, lam_n, st.normal_velocities, stat > 0)
        for j in np.nonzero(stat != self.contact_status)[0]:
            name, before, now = self.params.names[j], self.contact_status[j], stat[j]
            values: dict[str, Any] = {}
            kind: EventKind
            if before == 0:
                kind = "impact" if vn_before[j] < -self.impact_velocity else "close"
                how = {1: "sticks", 2: "slides", 3: "no load"}[int(now)]
                detail = f"v_N = {vn_before[j]:.4g} m/s; {how}"
                if kind == "impact":
                    values = self.impact_phases.start(int(j), t, vn_before[j], lam_n[j])
            elif now == 0:
                kind, detail = "open", f"v_N = {st.normal_velocities[j]:.4g} m/s"
            elif now == 3 or before == 3:
                continue  # loading or unloading while touching: no event
            else:
                kind = "stick" if now == 1 else "slip"
                detail = f"v_T = {st.tangential_velocities[j]:.4g} m/s" if kind == "slip" else ""
            self.events.append(ContactEvent(t, name, kind, detail, values))
        self.contact_status = stat.copy()
        return st.normal_velocities.copy()

    def _due(self, t: float) -> bool:
        return self.next_sample <= self.sample_count and \
            self.sample_times[self.next_sample] <= t + 1e-12 * self.duration

    def fixed_step_segment(self, y: np.ndarray, t_seg: float, t_end: float, u: np.ndarray,
                           stability_limit: float, implicit: bool) -> tuple[np.ndarray, float]:
        """Steps of at most dt from ``t_seg`` to ``t_end``: semi-implicit or linearly implicit Euler."""
        n = self.n
        while t_seg < t_end - 1e-12 * self.duration:
            h = min(self._dt, t_end - t_seg)
            if implicit:
                y_new, st_now = self.dynamics.implicit_step(y, u, h)
            else:
                y_new, st_now = self.dynamics.explicit_step(y, u, h)
            self.rhs_evaluations += 1
            self.steps_taken.append(h)
            y, t_seg = y_new, t_seg + h
            if not np.all(np.isfinite(y)) or np.max(np.abs(y[n:2 * n])) > DIVERGENCE_VELOCITY:
                limit = "" if implicit else (f"; the explicit step's stability limit was "
                                             f"{stability_limit:.3g} s at the start")
                self.fail("diverged", t_seg, f"the state became NaN or a velocity exceeded "
                          f"{DIVERGENCE_VELOCITY:g}{limit}", hint=True)
                break
            self.record_events(t_seg, y, st_now.normal_velocities)
            if self.progress is not None:
                self.progress(t_seg, self.duration)
            while self._due(t_seg):
                self.samples_y.append(y.copy())
                self.samples_u.append(u.copy())
                self.next_sample += 1
            if len(self.steps_taken) >= self.max_steps:
                self.fail("failed", t_seg, f"more than {self.max_steps} steps")
                break
        return y, t_seg

    def scipy_segment(self, integrator: str, y: np.ndarray, t_seg: float, u: np.ndarray,
                      schedule: InputSchedule | None, *, rtol: float, atol: float, max_step: float
                      ) -> tuple[np.ndarray, float, np.ndarray]:
        """SciPy's adaptive integrator from ``t_seg`` on at the input ``u``, sampled by its dense output.

        With a held input (``schedule``), the input's next value is asked at each sample, at the
        sampled state; the segment ends there when it differs from ``u`` (the step that went past
        the sample is cut back to it). Returns ``(y, t, u)`` at the segment's end, ``u`` the input
        from there on.
        """
        def fun(t: float, yy: np.ndarray) -> np.ndarray:
            self.rhs_evaluations += 1
            return self.dynamics.evaluate(yy, u)[0]

        solver_cls = getattr(scipy.integrate, _SCIPY_SOLVERS[integrator])
        solver = solver_cls(fun, t_seg, y, self.duration, rtol=rtol, atol=atol, max_step=max_step)
        while solver.status == "running":
            y_now = self._solver_step(solver, integrator)
            if y_now is None:
                break
            t_now = float(solver.t)
            if self.progress is not None:
                self.progress(t_now, self.duration)
            if self._due(t_now):
                dense = solver.dense_output()
                while self._due(t_now):
                    ts = float(self.sample_times[self.next_sample])
                    y_s = y_now.copy() if ts >= t_now else dense(ts)
                    self.samples_y.append(y_s)
                    self.samples_u.append(u.copy())
                    self.next_sample += 1
                    u_next = u if schedule is None or self.next_sample > self.sample_count \
                        else schedule(ts, y_s[:self.n], y_s[self.n:2 * self.n])
                    if not np.array_equal(u_next, u):  # the input changes here: start anew from ts
                        self.steps_taken[-1] = ts - float(solver.t_old)
                        self.last_vn = self.record_events(ts, y_s, self.last_vn)
                        return y_s.copy(), ts, u_next
            self.last_vn = self.record_events(t_now, y_now, self.last_vn)
            if len(self.steps_taken) >= self.max_steps:
                self.fail("failed", t_now, f"more than {self.max_steps} steps")
                break
            landed = self.dynamics.switch(solver.y)
            if landed is not None and solver.status == "running":  # a one-stage mass landed or left
                self.landing_energy += landed[1]
                solver = solver_cls(fun, t_now, landed[0], self.duration, rtol=rtol, atol=atol,
                                    max_step=max_step)
        return solver.y.copy(), float(solver.t), u

    def _solver_step(self, solver: Any, integrator: str) -> np.ndarray | None:
        """One step of a SciPy solver, its length recorded; its state, or None when the run ends here."""
        n = self.n
        try:
            message = solver.step()
        except (ValueError, np.linalg.LinAlgError, FloatingPointError) as err:
            # SciPy's Radau/BDF difference their Jacobian with a factor that grows without bound
            # on a column that never changes (e.g. the horizontal position): it can overflow
            # into inf and the LU factorisation raises. Report it as a failure, keep the samples.
            # diverged only if the state itself left the numbers; a finite state whose
            # Jacobian differencing overflowed is the integrator's failure, not the model's
            diverged = not np.all(np.isfinite(solver.y))
            self.fail("diverged" if diverged else "failed", float(solver.t), f"{integrator}: {err}",
                      hint=diverged)
            return None
        if solver.status == "failed":
            self.fail("failed", float(solver.t), f"{integrator}: {message}")
            return None
        t_now = float(solver.t)
        self.steps_taken.append(t_now - float(solver.t_old))
        y_now = solver.y
        if not np.all(np.isfinite(y_now)) or np.max(np.abs(y_now[n:2 * n])) > DIVERGENCE_VELOCITY:
            self.fail("diverged", t_now, "the state became NaN or a velocity exceeded "
                      f"{DIVERGENCE_VELOCITY:g}", hint=True)
            return None
        return y_now


def _event_status(status: np.ndarray, gaps: np.ndarray, gap_tolerance: float) -> np.ndarray:
    """Per contact: 0 open, 1 stick, 2 slip, 3 touching (|gap| <= tolerance) without load."""
    return np.where((status == 0) & (np.abs(gaps) <= gap_tolerance), 3, status)


def _zone_sample(dynamics: _Dynamics, y: np.ndarray, gaps: np.ndarray, samples: dict[str, list]) -> None:
    """Append one sample's zone deformations [m], forces [N] and energy [J] (nothing without zones).

    The energy is the zones' springs', their masses' kinetic energy and the robot-side masses'
    potential ``-m'_r g_n y_r``.
    """
    zones, forces = dynamics.zones, dynamics.zone_forces(y)
    if zones is None or forces is None:
        return
    z = y[dynamics.stretch_end:dynamics.zones_end]
    heights = z[np.array(zones.offsets, dtype=int)]
    samples["deformation"].append(forces.deformation)
    samples["force"].append(forces.robot_force)
    samples["energy"].append(zones.elastic_energy(z, gaps) + zones.kinetic_energy(z)
                             - float(np.sum(zones.mass_robot * zones.gravity_normal * heights)))


def _zone_info(dynamics: _Dynamics, samples: dict[str, list]) -> dict[str, Any]:
    """The zones' samples for ``info``.

    ``info["zones"]``: per zone, ``deformation`` [m] and ``force`` [N] per sample;
    ``info["zone_energy"]``: [J] per sample (0 without zones).
    """
    zones = dynamics.zones
    if zones is None:
        return {"zones": {}, "zone_energy": 0.0}
    deformation, force = np.array(samples["deformation"]), np.array(samples["force"])
    return {"zones": {name: {"deformation": deformation[:, j], "force": force[:, j]}
                      for j, name in enumerate(zones.names)},
            "zone_energy": np.array(samples["energy"])}


def _trajectory(scene: Scene, dynamics: _Dynamics, params: CompliantContacts, arm: Armature,
                times: np.ndarray, samples_y: list[np.ndarray], samples_u: list[np.ndarray],
                events: list[ContactEvent], status: TrajectoryStatus, failure: dict | None,
                info: dict) -> Trajectory:
    robot = scene.robot
    n = robot.nv
    k_all = len(scene.contacts)
    ys = np.array(samples_y)
    inputs = np.vstack([samples_u[0]] + samples_u) if samples_u else np.zeros((1, scene.inputs.count))
    forces = np.zeros((len(ys), k_all, 2))
    points = np.zeros((len(ys), k_all, 2))
    kinetic, potential, elastic, penetration = [], [], [], []
    kelvin_voigt = np.ones(params.count, dtype=bool)
    if dynamics.zones is not None:
        kelvin_voigt[list(dynamics.zones.slots)] = False
    zone_samples: dict[str, list] = {"deformation": [], "force": [], "energy": []}
    for j, y in enumerate(ys):
        st, lam_n, lam_t, _ = dynamics.forces(y)
        idx = list(params.indices)
        forces[j, idx, 0] = lam_n
        forces[j, idx, 1] = lam_t
        full = robot.state(y[:n], y[n:2 * n], list(range(k_all)))
        points[j] = full.contact_points
        mass = arm.apply(full.mass_matrix)
        kinetic.append(0.5 * float(y[n:2 * n] @ mass @ y[n:2 * n]))
        potential.append(scene.robot.potential_energy(y[:n]))
        delta = np.where(kelvin_voigt, np.maximum(0.0, -st.gaps), 0.0)
        s = y[2 * n:dynamics.stretch_end]
        elastic.append(float(0.5 * np.sum(params.stiffness * delta**2)
                             + 0.5 * np.sum(params.tangential_stiffness * s**2)))
        penetration.append(max(0.0, -float(np.min(full.gaps, initial=np.inf))))
        _zone_sample(dynamics, y, st.gaps, zone_samples)
    info.update(_zone_info(dynamics, zone_samples))
    springs = np.asarray(robot.springs.elastic_energy(ys[:, :n]), dtype=float)
    info.update({
        "energy": np.array(kinetic) + np.array(potential),
        "kinetic_energy": np.array(kinetic),
        "potential_energy": np.array(potential),
        "elastic_energy": np.array(elastic) + springs,
        "spring_energy": springs,
        "max_penetration": np.array(penetration),
        "stretch": ys[:, 2 * n:dynamics.stretch_end],
        "modelled_contacts": list(params.names),
    })
    extra_work = None
    if dynamics.transmissions is not None:  # the clusters' and springs' energy; the motors' work
        z = ys[:, dynamics.zones_end:]
        info["elastic_energy"] = info["elastic_energy"] + np.array(
            [dynamics.transmissions.energy(y[:n], zj) for y, zj in zip(ys, z, strict=True)])
        info["transmissions"] = {"state": z, "size": dynamics.transmissions.size}
        power = np.array([dynamics.transmissions.motor_power(zj, uj)
                          for zj, uj in zip(z, inputs, strict=True)])
        extra_work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(times))])
    trajectory = Trajectory(
        scene_name=scene.name,
        coordinates=scene.coordinate_names,
        contacts=tuple(c.name for c in scene.contacts),
        times=np.asarray(times, dtype=float),
        q=ys[:, :n],
        v=ys[:, n:2 * n],
        inputs=inputs,
        input_names=scene.inputs.coordinates,
        contact_forces=forces,
        contact_points=points,
        events=tuple(events),
        info=info,
        model="compliant",
        status=status,
        failure=None if failure is None else SimulationFailure(**failure),
    )
    softest = float(np.min(params.stiffness)) if params.count else None
    if dynamics.zones is not None:  # the zones' own softest spring, in series
        softest = float(np.min(1.0 / (1.0 / dynamics.zones.stiffness_internal_robot + np.where(
            dynamics.zones.stiffness_external > 0, 1.0 / np.maximum(dynamics.zones.stiffness_external, 1e-300)
            + 1.0 / np.maximum(dynamics.zones.stiffness_internal_environment, 1e-300), 0.0))))
    return assess(scene, trajectory, energy=info["energy"] + info["elastic_energy"] + info["zone_energy"],
                  penetration=info["max_penetration"], stiffness=softest, dt=float(info["dt"]),
                  extra_work=extra_work)


__all__ = [
    "DEFAULT_ATOL",
    "DEFAULT_RTOL",
    "INTEGRATORS",
    "IMMOBILE_ROW_TOLERANCE",
    "CompliantContacts",
    "CompliantSettings",
    "ContactOverrides",
    "compliant_contacts",
    "contact_forces",
    "simulate_compliant",
]
