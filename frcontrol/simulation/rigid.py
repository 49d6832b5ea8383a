r"""Rigid-body simulation: velocity-level time stepping with inelastic impacts (METHOD §7).

The scheme (Stewart and Trinkle 1996; Anitescu and Potra 1997), one step of length ``h`` from
``(q, v)`` at time ``t`` with input ``u``::

    M (v+ - v) = h (S^T u - h(q, v)) + J_N^T p_N + J_T^T p_T          (impulses p [N s])
    q+ = q + h v+                                                     (minimal coordinates add)

For every contact i of the scene that is *near* (gap ``phi_i <= d_act + 2 h max(0, -v_N,i)``,
:data:`ACTIVATION_DISTANCE`), with ``p_T,i = p_T,i^+ - p_T,i^-`` and a slip-speed multiplier
``sigma_i``, the 2-D Coulomb law at the velocity level, exactly (no polygonal cone)::

    0 <= p_N       _|_  J_N v+ + phi~ / h            >= 0      (non-penetration at the step's end)
    0 <= p_T^+     _|_  sigma + J_T v+               >= 0
    0 <= p_T^-     _|_  sigma - J_T v+               >= 0
    0 <= sigma     _|_  mu p_N - p_T^+ - p_T^-       >= 0      (cone; slip opposes J_T v+)

with ``phi~ = phi`` for an open gap (the contact may close exactly at the step's end) and
``phi~ = beta phi`` for a penetration (gap stabilisation: a fraction ``beta`` =
``stabilization`` of the penetration is removed per step; Stewart and Trinkle's ``phi / h`` term
is ``beta = 1``). Substituting ``v+ = v_free + M^-1 J^T p`` with ``v_free = v + h M^-1 (S^T u -
h)`` (Cholesky solves, never an inverse) gives an LCP in ``z = (p_N, p_T^+, p_T^-, sigma)``::

    [ W_NN   W_NT  -W_NT  0 ]       [ J_N v_free + phi~/h ]
    [ W_TN   W_TT  -W_TT  I ] z  +  [ J_T v_free          ]   = w >= 0,  z >= 0,  z^T w = 0
    [-W_TN  -W_TT   W_TT  I ]       [-J_T v_free          ]
    [ mu    -I     -I     0 ]       [ 0                   ]

``W = J M^-1 J^T`` (the Delassus matrix), solved by Lemke's method (:func:`frcontrol.lcp.solve_lcp`).
*Why an LCP and not a QP*: Anitescu's convex (QP/CCP) relaxation replaces the normal
complementarity by ``J_N v+ >= -mu |J_T v+|``, so sliding bodies drift off their surface by
``mu |v_T| h`` per step; the box on a slope then would not slide on the slope. The LCP keeps
Coulomb's law exact in the plane, and Lemke's method solves it (Anitescu and Potra showed that
this LCP always has a solution that Lemke's method finds, for positive-definite ``M``; should it
ever end on a ray here, the step is retried with a tiny regularisation of ``W``, then by
enumeration when small, else the simulation stops with ``status = "failed"`` and the
trajectory up to there).

Impacts are *inelastic* (restitution 0): a closing contact's normal velocity after the step is
``-phi~/h >= ...`` i.e. ~0, with the complementarity above; the kinetic energy of the approach is
lost. Energy: for constant ``M`` and a linear potential (one rigid body under gravity) a step
changes the mechanical energy by ``-1/2 |v+ - v|_M^2 + p_T . J_T v+ - sum_i p_N,i phi~_i / h``:
never positive except for the stabilisation term of penetrations, which is reported
(``info["stabilization_work"]``).

Massless links get a joint armature (see :mod:`frcontrol.simulation.armature`). DC-motor drives
(:mod:`frcontrol.drives`): their electrical damping ``D`` is taken at the step's end, ``M`` becoming
``M + h D``; elastic transmissions step with the robot (:mod:`frcontrol.simulation.drives`).

Events (``Trajectory.events``): ``close`` / ``impact`` (a contact starts carrying force, with
approach speed above ``impact_velocity`` for an impact), ``open``, ``stick``, ``slip``, and
``ambiguous``: after an event (and at the start), at the first state where every touching
contact has ``|v_N| <= AMBIGUITY_VELOCITY_TOLERANCE``, :func:`frcontrol.engine.solutions_at`
lists every rigid-body solution at that state and input (``info["ambiguity_checks"]``); when they
hold two or more distinct motions, the event says which modes and which one the step took
(``detail="modes FF, SS; the step took FF"``; modes with the same accelerations, differing only in
indeterminate forces, are joined by ``=``). The check uses the stepper's model: M with the
armature, touching contacts' ``v_N`` set to 0 and ``|v_T| <= slip_velocity_tolerance`` set to 0.
The step's mode is read from its impulses: S without load, else F if ``|v_T+|`` is within the slip
tolerance, else R or L by the sign of ``v_T+``.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg

from ..errors import FrcontrolError, InputError
from ..lcp import ENUMERATION_MAX_SIZE, solve_lcp
from ..modes import ContactProblem, contact_mode_letter
from ..scene import Scene
from .armature import DEFAULT_ARMATURE, Armature, mass_factor, massless_armature
from .drives import ImplicitTransmissions, TransmissionRun
from .inputs import InputSchedule, check_simulation_times, input_schedule, step_lengths
from .model_table import model_options
from .trajectory import ContactEvent, SimulationFailure, Trajectory
from .validity import HINT as VALIDITY_HINT
from .validity import assess

ACTIVATION_DISTANCE = 1e-3
"""[m] A contact takes part in a step when its gap is at most this (plus twice its approach
distance ``2 h max(0, -v_N)`` in the step): far contacts add no LCP rows."""

DEFAULT_STABILIZATION = 1.0
"""[-] Fraction beta of a penetration removed per step (Stewart and Trinkle's phi/h term: 1)."""

IMPACT_VELOCITY = 0.05
"""[m/s] A contact that closes with approach speed above this is an ``impact`` event, else a
``close`` (a resting contact that chatters open for a step re-closes at about g h)."""

SLIP_VELOCITY_TOLERANCE = 1e-6
"""[m/s] A loaded contact with |v_T| at most this after the step sticks; above, it slips."""

CONTACT_FORCE_TOLERANCE = 1e-9
"""[-] A contact carries force when its impulse / h exceeds this times the force scale
(the robot's weight, or 1 N without gravity)."""

AMBIGUITY_VELOCITY_TOLERANCE = 1e-4
"""[m/s] The rigid solutions are listed only where every touching contact has |v_N| at most
this (then v_N is taken as 0): the acceleration-level model applies there."""

AMBIGUITY_ACCELERATION_TOLERANCE = 1e-6
"""[-] Two rigid solutions are one motion when their accelerations differ by at most this times
``1 + max|dv|``; the ``ambiguous`` event needs two distinct motions (modes that differ only in
statically indeterminate forces, like a resting box's FF and LR, are written ``FF=LR``)."""

MAX_AMBIGUITY_CHECKS = 20
"""Calls of :func:`~frcontrol.engine.solutions_at` per simulation, at most (each enumerates the
modes; on RHex it takes about half a second)."""

LCP_REGULARIZATION = 1e-10
"""[-] When Lemke's method fails, the step is retried with ``W + eps I`` (W scaled to unit
diagonal): this eps."""


@dataclass(frozen=True)
class _StepResult:
    v_next: np.ndarray
    impulse_n: np.ndarray  # per candidate
    impulse_t: np.ndarray
    lcp_size: int
    residual: float
    regularized: bool


class _StepFailure(FrcontrolError):
    """The step's LCP had no solution by any method (a result of the simulation, not raised out)."""


def _solve_step(
    factor: tuple[np.ndarray, bool],
    v_free: np.ndarray,
    jn: np.ndarray,
    jt: np.ndarray,
    gaps: np.ndarray,
    mu: np.ndarray,
    dt: float,
    stabilization: float,
    method: str,
) -> _StepResult:
    """Solve one step's LCP for the candidate contacts (rows jn, jt)."""
    c = jn.shape[0]
    jac = np.vstack([jn, jt])
    X = scipy.linalg.cho_solve(factor, jac.T, check_finite=False)  # M^-1 J^T, (n, 2c)
    W = jac @ X
    scale = float(np.max(np.diag(W)))
    m_ref = 1.0 / scale if scale > 0 else 1.0  # impulses in units of m_ref [kg] x [m/s]
    Ws = W * m_ref
    shifted = np.where(gaps >= 0.0, gaps, stabilization * gaps)
    b_n = jn @ v_free + shifted / dt
    b_t = jt @ v_free
    if np.all(b_n >= 0.0):  # every candidate separates or just touches: z = 0, sigma = |b_t|
        return _StepResult(v_free.copy(), np.zeros(c), np.zeros(c), 0, 0.0, False)
    n_idx, p_idx, m_idx, s_idx = (np.arange(c) + j * c for j in range(4))
    base = np.zeros((4 * c, 4 * c))
    base[np.ix_(n_idx, n_idx)] = Ws[:c, :c]
    base[np.ix_(n_idx, p_idx)] = Ws[:c, c:]
    base[np.ix_(n_idx, m_idx)] = -Ws[:c, c:]
    base[np.ix_(p_idx, n_idx)] = Ws[c:, :c]
    base[np.ix_(p_idx, p_idx)] = Ws[c:, c:]
    base[np.ix_(p_idx, m_idx)] = -Ws[c:, c:]
    base[np.ix_(m_idx, n_idx)] = -Ws[c:, :c]
    base[np.ix_(m_idx, p_idx)] = -Ws[c:, c:]
    base[np.ix_(m_idx, m_idx)] = Ws[c:, c:]
    base[p_idx, s_idx] = 1.0
    base[m_idx, s_idx] = 1.0
    base[s_idx, n_idx] = mu
    base[s_idx, p_idx] = -1.0
    base[s_idx, m_idx] = -1.0
    diagonal = np.concatenate([n_idx, p_idx, m_idx])

    def lcp_matrix(eps: float) -> np.ndarray:
        if eps == 0.0:
            return base
        out = base.copy()
        out[diagonal, diagonal] += eps
        return out

    q_lcp = np.concatenate([b_n, b_t, -b_t, np.zeros(c)])
    attempts = [(method, 0.0)]
    if method == "lemke":
        attempts.append(("lemke", LCP_REGULARIZATION))
    if 4 * c <= ENUMERATION_MAX_SIZE and method != "enumerate":
        attempts.append(("enumerate", 0.0))
    statuses = []
    for how, eps in attempts:
        result = solve_lcp(lcp_matrix(eps), q_lcp, method=how)
        if result.found and result.z is not None:
            z = result.z
            p_n = m_ref * z[:c]
            p_t = m_ref * (z[c:2 * c] - z[2 * c:3 * c])
            v_next = v_free + X @ np.concatenate([p_n, p_t])
            return _StepResult(v_next, p_n, p_t, 4 * c, float(result.residual), eps > 0 or how != method)
        statuses.append(f"{how}{' (regularised)' if eps else ''}: {result.status}")
    raise _StepFailure(f"the step's LCP ({4 * c} unknowns) has no solution: {'; '.join(statuses)}")


def _sliding_phrase(sliding: str | None, v_t: float) -> str:
    if sliding == "slip":
        return f"slides toward {'+t' if v_t > 0 else '-t'}"
    return "sticks" if sliding == "stick" else "no load"


def _taken_mode(p_n: np.ndarray, v_t: np.ndarray, force_tol: float, dt: float, slip_tol: float) -> str:
    """The step's mode: one letter per contact from its impulse over the step and its slip."""
    return "".join(contact_mode_letter(p_n[i] / dt, v_t[i], force_tol, slip_tol) for i in range(len(p_n)))


def simulate_rigid(
    scene: Scene,
    inputs: Mapping[str, float] | Sequence[float] | np.ndarray | InputSchedule | None = None,
    duration: float = 1.0,
    dt: float = 1e-3,
    *,
    q0: Sequence[float] | np.ndarray | None = None,
    v0: Sequence[float] | np.ndarray | None = None,
    activation_distance: float = ACTIVATION_DISTANCE,
    stabilization: float = DEFAULT_STABILIZATION,
    impact_velocity: float = IMPACT_VELOCITY,
    slip_velocity_tolerance: float = SLIP_VELOCITY_TOLERANCE,
    armature: float | None = None,
    lcp_method: str = "lemke",
    max_ambiguity_checks: int = MAX_AMBIGUITY_CHECKS,
) -> Trajectory:
    """Simulate the scene with rigid contacts by velocity-level time stepping.

    Args:
        scene: the scene; every one of its contacts may open and close (inactive ones too).
        inputs: a constant input vector, ``{name: value}`` (others 0), or ``(t, q, v) -> u``
            called once per step (zero-order hold); None: zero inputs.
        duration: [s] simulated time, > 0.
        dt: [s] step, > 0 and <= duration (the last step is shortened to end at ``duration``).
        q0: initial configuration (default: the scene's).
        v0: initial velocity (default: the scene's).
        activation_distance: [m] see :data:`ACTIVATION_DISTANCE`.
        stabilization: beta in [0, 1], the fraction of a penetration removed per step.
        impact_velocity: [m/s] see :data:`IMPACT_VELOCITY`.
        slip_velocity_tolerance: [m/s] see :data:`SLIP_VELOCITY_TOLERANCE`.
        armature: rotor inertia for massless coordinates (default: the scene's ``[model]``
            armature, else :data:`~frcontrol.simulation.armature.DEFAULT_ARMATURE`).
        lcp_method: ``"lemke"`` or ``"enumerate"``.
        max_ambiguity_checks: at most this many :func:`~frcontrol.engine.solutions_at` calls
            (0: none).

    Returns:
        The trajectory (``model = "rigid"``; its ``status``, ``"completed"``, ``"failed"`` or
        ``"diverged"`` (see :mod:`~frcontrol.simulation.validity`), and ``failure``: time, reason
        and, when it diverged, a hint; or None): one sample per step; ``info`` holds ``dt``, ``steps``,
        ``energy`` [J] (kinetic with the armature + gravitational) and its parts,
        ``max_penetration`` [m] per sample, ``stabilization_work`` [J] (cumulative), ``lcp``
        statistics, ``armature``, ``ambiguity_checks`` and the tolerances. ``warnings`` on the
        trajectory say where the run left its model's validity.

    Raises:
        InputError: a bad duration, step, state, input (length, NaN, outside limits),
            stabilization outside [0, 1], negative distances or tolerances, unknown LCP method.
        SceneError: a bad ``[model]`` table.
        IllConditioned: M is singular even with the armature.
    """
    duration, dt = check_simulation_times(duration, dt)
    settings = RigidSettings(activation_distance, stabilization, impact_velocity, slip_velocity_tolerance,
                             lcp_method, max_ambiguity_checks)
    schedule, _ = input_schedule(scene, inputs)
    stepper = RigidStepper(scene, settings, q0=q0, v0=v0, armature=armature)
    for _, h in step_lengths(duration, dt):
        if not stepper.step(schedule(stepper.t, stepper.q, stepper.v), h):
            break
    return stepper.trajectory(dt)


@dataclass(frozen=True)
class RigidSettings:
    """The rigid stepper's settings (see :func:`simulate_rigid` for each), validated.

    Raises:
        InputError: stabilization outside [0, 1], a negative or non-finite distance or tolerance,
            an unknown LCP method or a negative number of ambiguity checks.
    """

    activation_distance: float = ACTIVATION_DISTANCE
    stabilization: float = DEFAULT_STABILIZATION
    impact_velocity: float = IMPACT_VELOCITY
    slip_velocity_tolerance: float = SLIP_VELOCITY_TOLERANCE
    lcp_method: str = "lemke"
    max_ambiguity_checks: int = MAX_AMBIGUITY_CHECKS

    def __post_init__(self) -> None:
        if not 0.0 <= self.stabilization <= 1.0:
            raise InputError(f"stabilization must be in [0, 1] (fraction of a penetration removed per step), "
                             f"got {self.stabilization}")
        for label in ("activation_distance", "impact_velocity", "slip_velocity_tolerance"):
            value = getattr(self, label)
            if not np.isfinite(value) or value < 0:
                raise InputError(f"{label} must be a finite number >= 0, got {value}")
        if self.lcp_method not in ("lemke", "enumerate"):
            raise InputError(f"unknown LCP method {self.lcp_method!r}; use 'lemke' or 'enumerate'")


class RigidStepper:
    """The rigid model's time stepper: one velocity-level step at a time, with its records.

    :func:`simulate_rigid` runs it over a schedule; a closed loop (the flip's re-planning) calls
    :meth:`step` with the inputs it chooses, reads :attr:`q`, :attr:`v`, :attr:`t` and
    :attr:`last_forces`, and ends with :meth:`trajectory`. Each step: the free velocity, the LCP
    of the candidate contacts (:func:`_solve_step`), the contact events and, while the model may
    be ambiguous there, the check against every rigid solution.
    """

    def __init__(self, scene: Scene, settings: RigidSettings | None = None, *,
                 q0: Sequence[float] | np.ndarray | None = None,
                 v0: Sequence[float] | np.ndarray | None = None,
                 armature: float | None = None) -> None:
        self.scene = scene
        self.settings = settings or RigidSettings()
        robot = scene.robot
        self.q, self.v = robot.check_state(scene.q if q0 is None else q0, scene.v if v0 is None else v0)
        self.t = 0.0
        self.names = tuple(c.name for c in scene.contacts)
        self._all = list(range(len(self.names)))
        self._mu = np.array([c.mu for c in scene.contacts], dtype=float)
        self._input_map = scene.inputs.selection_transpose(robot.nv)
        damping = robot.drive_damping
        self._damping = damping if np.any(damping) else None
        run = TransmissionRun(scene, self.q, self.v)  # elastic drives' own state, if any
        self.transmissions = run if run.model else None
        self._coupled: ImplicitTransmissions | None = None  # the current step's, with transmissions
        self.state = robot.state(self.q, self.v, self._all)
        options = model_options(scene)
        self.armature = massless_armature(scene, self.state.mass_matrix,
                                          options.armature if armature is None else armature)
        self.force_tolerance = CONTACT_FORCE_TOLERANCE * robot.weight_scale()
        self.status = "completed"
        self.failure: SimulationFailure | None = None
        k = len(self.names)
        self.last_forces = np.zeros((k, 2))
        self._times, self._qs, self._vs = [0.0], [self.q.copy()], [self.v.copy()]
        self._us: list[np.ndarray] = []
        self._forces = [np.zeros((k, 2))]
        self._points = [self.state.contact_points.copy()]
        self._kinetic: list[float] = []
        self._potential: list[float] = []
        self._penetration = [max(0.0, -float(np.min(self.state.gaps, initial=np.inf)))]
        self._stab_work = [0.0]
        self.events: list[ContactEvent] = []
        self.checks: list[dict] = []
        self.lcp_stats = {"solves": 0, "max_unknowns": 0, "regularised_or_fallback": 0, "max_residual": 0.0}
        slip = self.settings.slip_velocity_tolerance
        self._closed = np.abs(self.state.gaps) <= scene.gap_tolerance
        self._sliding: list[str | None] = [
            ("slip" if abs(self.state.tangential_velocities[i]) > slip else "stick")
            if self._closed[i] else None
            for i in range(k)]
        self._check_pending = True
        self._start_wall = time.perf_counter()

    def step(self, u: np.ndarray, h: float) -> bool:
        """Advance by ``h`` [s] with the inputs ``u`` held.

        Returns:
            False when the run cannot go on (the LCP failed, or the velocity left the numbers):
            :attr:`status` and :attr:`failure` say why, and no sample was added.
        """
        mass = self.armature.apply(self.state.mass_matrix)
        self._kinetic.append(0.5 * float(self.v @ mass @ self.v))
        self._potential.append(self.scene.robot.potential_energy(self.q))
        try:
            v_next, p_n, p_t, candidates = self._impulses(mass, u, h)
        except _StepFailure as err:
            self.status, self.failure = "failed", SimulationFailure(self.t, str(err))
            return False
        if not np.all(np.isfinite(v_next)):
            self.status = "diverged"
            self.failure = SimulationFailure(self.t, "the velocity became NaN or infinite", VALIDITY_HINT)
            self._stab_work.pop()
            return False
        self._contact_bookkeeping(u, h, v_next, p_n, candidates)
        self._advance(u, h, v_next, p_n, p_t)
        return True

    def _impulses(self, mass: np.ndarray, u: np.ndarray, h: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(v_next, normal and tangential impulses per contact, the candidates' mask) of a step."""
        st, cfg = self.state, self.settings
        force = self._input_map @ u - st.bias
        if self._damping is not None:  # drives' damping, implicit: (M + h D)(v+ - v) = h (f - D v) + J^T p
            mass = mass + np.diag(h * self._damping)
        if self.transmissions is not None:  # elastic drives: the springs' torques, see .drives
            self._coupled = self.transmissions.implicit(self.q, self.v, u, h)
            force, mass = force + self._coupled.force, self._coupled.mass(mass)
        factor = mass_factor(mass, self.armature)
        accel = scipy.linalg.cho_solve(factor, force, check_finite=False)
        v_free = self.v + h * accel
        gaps, vn = st.gaps, st.normal_velocities
        cand = np.nonzero(gaps <= cfg.activation_distance + 2.0 * h * np.maximum(0.0, -vn))[0]
        k = len(self.names)
        p_n, p_t = np.zeros(k), np.zeros(k)
        in_cand = np.zeros(k, dtype=bool)
        in_cand[cand] = True
        if not cand.size:
            self._stab_work.append(self._stab_work[-1])
            return v_free, p_n, p_t, in_cand
        res = _solve_step(factor, v_free, st.jacobian_normal[cand], st.jacobian_tangent[cand], gaps[cand],
                          self._mu[cand], h, cfg.stabilization, cfg.lcp_method)
        p_n[cand], p_t[cand] = res.impulse_n, res.impulse_t
        stats = self.lcp_stats
        stats["solves"] += 1
        stats["max_unknowns"] = max(stats["max_unknowns"], res.lcp_size)
        stats["regularised_or_fallback"] += int(res.regularized)
        stats["max_residual"] = max(stats["max_residual"], res.residual)
        shifted = np.where(gaps[cand] >= 0, gaps[cand], cfg.stabilization * gaps[cand])
        work = float(np.sum(res.impulse_n * np.maximum(0.0, -shifted))) / h
        self._stab_work.append(self._stab_work[-1] + work)
        return res.v_next, p_n, p_t, in_cand

    def _contact_bookkeeping(self, u: np.ndarray, h: float, v_next: np.ndarray, p_n: np.ndarray,
                             candidates: np.ndarray) -> None:
        """Which contacts close, open, stick or slip in this step (events), and the ambiguity check."""
        st, cfg = self.state, self.settings
        vn, vn_next, vt_next = st.normal_velocities, st.jacobian_normal @ v_next, st.jacobian_tangent @ v_next
        loaded = p_n / h > self.force_tolerance
        closed_next = loaded | (candidates & (st.gaps + h * vn_next <= self.scene.gap_tolerance))
        self._maybe_check_ambiguity(u, h, p_n, vn, vt_next)
        t_next = self.t + h
        had_event = False
        for i, name in enumerate(self.names):
            new_sliding: str | None = None
            if closed_next[i] and loaded[i]:
                new_sliding = "slip" if abs(vt_next[i]) > cfg.slip_velocity_tolerance else "stick"
            if closed_next[i] and not self._closed[i]:
                had_event = True
                how = _sliding_phrase(new_sliding, vt_next[i])
                if vn[i] < -cfg.impact_velocity:
                    detail = f"v_N = {vn[i]:.4g} m/s, impulse {p_n[i]:.4g} N s; {how}"
                    self.events.append(ContactEvent(t_next, name, "impact", detail))
                else:
                    self.events.append(ContactEvent(t_next, name, "close", how))
            elif self._closed[i] and not closed_next[i]:
                had_event = True
                self.events.append(ContactEvent(t_next, name, "open", f"v_N = {vn_next[i]:.4g} m/s"))
            elif closed_next[i] and new_sliding is not None and self._sliding[i] is not None \
                    and new_sliding != self._sliding[i]:
                had_event = True
                detail = f"v_T = {vt_next[i]:.4g} m/s" if new_sliding == "slip" else ""
                self.events.append(ContactEvent(t_next, name, new_sliding, detail))
            if closed_next[i]:
                self._sliding[i] = new_sliding if new_sliding is not None else self._sliding[i]
            else:
                self._sliding[i] = None
        if had_event:
            self._check_pending = True
        self._closed = closed_next

    def _maybe_check_ambiguity(self, u: np.ndarray, h: float, p_n: np.ndarray, vn: np.ndarray,
                               vt_next: np.ndarray) -> None:
        """Is the rigid model ambiguous at this state? Compare with what the step took."""
        cfg = self.settings
        if not self._check_pending or len(self.checks) >= cfg.max_ambiguity_checks:
            return
        touching = [i for i in range(len(self.names)) if self._closed[i]]
        if not touching:
            self._check_pending = False
            return
        if not np.all(np.abs(vn[touching]) <= AMBIGUITY_VELOCITY_TOLERANCE):
            return
        self._check_pending = False
        taken = _taken_mode(p_n[touching], vt_next[touching], self.force_tolerance, h,
                            cfg.slip_velocity_tolerance)
        drive_torque = (None if self.transmissions is None
                        else self.transmissions.model.joint_force(self.q, self.v, self.transmissions.z))
        entry = _ambiguity_check(self.scene, self.q, self.v, u, touching, self.armature,
                                 cfg.slip_velocity_tolerance, taken, self.t, drive_torque)
        self.checks.append(entry)
        if entry["distinct_motions"] > 1:
            self.events.append(ContactEvent(self.t, ",".join(entry["contacts"]), "ambiguous",
                                            f"modes {entry['summary']}; the step took {taken}"))

    def _advance(self, u: np.ndarray, h: float, v_next: np.ndarray, p_n: np.ndarray, p_t: np.ndarray) -> None:
        """Move the state to the end of the step and record the sample."""
        robot = self.scene.robot
        self.q = robot.integrate(self.q, h * v_next)
        self.v = v_next
        if self.transmissions is not None and self._coupled is not None:
            self.transmissions.advance(self._coupled, v_next, u)
        self.t = self.t + h
        self.state = robot.state(self.q, self.v, self._all)
        self.last_forces = np.column_stack([p_n / h, p_t / h])
        self._times.append(self.t)
        self._qs.append(self.q.copy())
        self._vs.append(self.v.copy())
        self._us.append(np.asarray(u, dtype=float).copy())
        self._forces.append(self.last_forces)
        self._points.append(self.state.contact_points.copy())
        self._penetration.append(max(0.0, -float(np.min(self.state.gaps, initial=np.inf))))

    def trajectory(self, dt: float) -> Trajectory:
        """The run so far, checked against the model's validity (:func:`.validity.assess`).

        Args:
            dt: [s] the nominal step, reported (the last step may have been shorter).
        """
        cfg, scene = self.settings, self.scene
        mass = self.armature.apply(self.state.mass_matrix)
        kinetic = np.array(self._kinetic + [0.5 * float(self.v @ mass @ self.v)])
        potential = np.array(self._potential + [scene.robot.potential_energy(self.q)])
        us = self._us
        inputs_arr = np.vstack([us[0]] + us) if us else np.zeros((1, scene.inputs.count))
        energy = kinetic + potential
        extra_work = np.array(self._stab_work)
        if self.transmissions is not None:
            energy = energy + self.transmissions.energy(np.array(self._qs))
            extra_work = extra_work + self.transmissions.work()
        info = {
            "scheme": "velocity-level time stepping (Stewart-Trinkle), exact 2-D Coulomb law, LCP by "
                      f"{cfg.lcp_method}, inelastic impacts",
            "dt": dt,
            "steps": len(self._times) - 1,
            "duration": float(self._times[-1]),
            "energy": energy,
            "kinetic_energy": kinetic,
            "potential_energy": potential,
            "max_penetration": np.array(self._penetration),
            "stabilization_work": np.array(self._stab_work),
            "lcp": dict(self.lcp_stats),
            "armature": self.armature.report(),
            "ambiguity_checks": list(self.checks),
            "ambiguity_checks_limit": cfg.max_ambiguity_checks,
            "tolerances": {
                "activation_distance": cfg.activation_distance,
                "stabilization": cfg.stabilization,
                "impact_velocity": cfg.impact_velocity,
                "slip_velocity": cfg.slip_velocity_tolerance,
                "contact_force": self.force_tolerance,
                "ambiguity_velocity": AMBIGUITY_VELOCITY_TOLERANCE,
                "gap": scene.gap_tolerance,
            },
            "wall_time": time.perf_counter() - self._start_wall,
        }
        if self.transmissions is not None:
            info["transmissions"] = self.transmissions.info()
        trajectory = Trajectory(
            scene_name=scene.name, coordinates=scene.coordinate_names, contacts=self.names,
            times=np.array(self._times), q=np.array(self._qs), v=np.array(self._vs), inputs=inputs_arr,
            input_names=scene.inputs.coordinates, contact_forces=np.array(self._forces),
            contact_points=np.array(self._points), events=tuple(self.events), info=info, model="rigid",
            status=self.status, failure=self.failure,
        )
        return assess(scene, trajectory, energy=energy, penetration=info["max_penetration"], stiffness=None,
                      dt=dt, extra_work=extra_work)


def _ambiguity_check(scene: Scene, q: np.ndarray, v: np.ndarray, u: np.ndarray, touching: list[int],
                     arm: Armature, slip_tol: float, taken: str, t: float,
                     drive_torque: np.ndarray | None = None) -> dict:
    """Every rigid solution at this state (touching contacts, v_N taken as 0), and the step's mode."""
    from ..engine import solutions_at  # the engine is heavy; import on first use

    at_state = ContactProblem.from_scene(scene, q, v, contacts=touching, velocity_tolerance=slip_tol,
                                         drive_torque=drive_torque)
    vt = at_state.tangential_velocities.copy()
    vt[np.abs(vt) <= slip_tol] = 0.0
    problem = replace(at_state, mass_matrix=arm.apply(at_state.mass_matrix),
                      normal_velocities=np.zeros(len(touching)), tangential_velocities=vt)
    entry: dict = {"time": t, "contacts": list(problem.contacts), "taken": taken}
    try:
        solutions = solutions_at(problem, u)
    except FrcontrolError as err:  # reported, never fatal: the check is a diagnosis
        entry.update({"modes": [], "distinct_motions": 0, "summary": "", "error": str(err)})
        return entry
    # Modes with the same accelerations are one motion (they differ in indeterminate forces only).
    groups: list[tuple[np.ndarray, list[str]]] = []
    for sol in solutions:
        scale = AMBIGUITY_ACCELERATION_TOLERANCE * (1.0 + float(np.max(np.abs(sol.dv), initial=0.0)))
        for dv, modes in groups:
            if np.max(np.abs(dv - sol.dv), initial=0.0) <= scale:
                modes.append(sol.mode)
                break
        else:
            groups.append((sol.dv, [sol.mode]))
    entry["modes"] = [s.mode for s in solutions]
    entry["distinct_motions"] = len(groups)
    entry["summary"] = ", ".join("=".join(modes) for _, modes in groups)
    entry["taken_among_them"] = taken in entry["modes"]
    return entry


__all__ = [
    "RigidSettings",
    "RigidStepper",
    "ACTIVATION_DISTANCE",
    "AMBIGUITY_ACCELERATION_TOLERANCE",
    "AMBIGUITY_VELOCITY_TOLERANCE",
    "CONTACT_FORCE_TOLERANCE",
    "DEFAULT_ARMATURE",
    "DEFAULT_STABILIZATION",
    "IMPACT_VELOCITY",
    "MAX_AMBIGUITY_CHECKS",
    "SLIP_VELOCITY_TOLERANCE",
    "simulate_rigid",
]
