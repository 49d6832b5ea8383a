r"""Rigid-body simulation: velocity-level time stepping with an impact law (docs/maths.md, *Simulation*).

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

``W = J M^-1 J^T`` (the Delassus matrix), solved by Lemke's method (:func:`frcontrol.lcp.solve_lcp`,
through :func:`.impact.solve_impulse_lcp`).
*Why an LCP and not a QP*: Anitescu's convex (QP/CCP) relaxation replaces the normal
complementarity by ``J_N v+ >= -mu |J_T v+|``, so sliding bodies drift off their surface by
``mu |v_T| h`` per step; the box on a slope then would not slide on the slope. The LCP keeps
Coulomb's law exact in the plane, and Lemke's method solves it (Anitescu and Potra showed that
this LCP always has a solution that Lemke's method finds, for positive-definite ``M``; should it
ever end on a ray here, the step is retried with a tiny regularisation of ``W``, then by
enumeration when small, else the simulation stops with ``status = "failed"`` and the
trajectory up to there).

Impacts go through the impact law (:mod:`.impact`): a step that would land a contact approaching
faster than ``impact_velocity`` (open at the step's start, taking an impulse in it) is split at the
instant ``gap / -v_N`` the contact closes (at most :data:`MAX_LANDINGS_PER_STEP` times); there,
and at a step's start where a touching contact (gap <= :data:`IMPACT_GAP_TOLERANCE`) approaches
that fast, every touching contact takes the instantaneous impulses of :func:`.impact.impact_law`:
the momentum balance, Coulomb's law on the impulses and Newton's restitution ``e`` of
``[model.contacts.NAME] restitution`` (default 0, inelastic), an LCP solved by Lemke's method. The
kinetic energy never grows through it. Each impact is an ``impact`` event with its numbers
(``impulse_normal``, ``impulse_tangent`` [N s], ``normal_velocity_before``/``_after`` [m/s],
``restitution``, ``kinetic_energy_before``/``_after`` [J]), listed in ``info["impacts"]``, and the
impulses of each step in ``info["impact_impulses"]`` (T, k, 2). Between impacts the steps are
inelastic at the velocity level as above. Energy: for constant ``M`` and a linear potential (one
rigid body under gravity) a step changes the mechanical energy by ``-1/2 |v+ - v|_M^2 + p_T . J_T
v+ - sum_i p_N,i phi~_i / h``: never positive except for the stabilisation term of penetrations,
which is reported (``info["stabilization_work"]``).

Massless links get a joint armature (see :mod:`frcontrol.simulation.armature`). DC-motor drives
(:mod:`frcontrol.drives`): their electrical damping ``D`` is taken at the step's end, ``M`` becoming
``M + h D``; elastic transmissions step with the robot (:mod:`frcontrol.simulation.transmissions`).

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
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from ..engine import solutions_at
from ..errors import FrcontrolError, InputError
from ..modes import ContactProblem, contact_mode_letter
from ..scene import Scene
from .armature import DEFAULT_ARMATURE, Armature, mass_factor, massless_armature, solve_mass
from .impact import ImpulseLCPFailure, impact_law, solve_impulse_lcp
from .inputs import InitialState, InputSchedule, check_simulation_times, input_schedule, step_lengths
from .model_table import model_options
from .samples import CONTACT_FORCE_TOLERANCE, SLIP_VELOCITY_TOLERANCE
from .trajectory import ContactEvent, SimulationFailure, Trajectory, TrajectoryStatus
from .transmissions import ImplicitTransmissions, TransmissionRun
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

IMPACT_GAP_TOLERANCE = 1e-5
"""[m] A contact within this of its surface is touching for the impact law: it takes the law when
it approaches faster than ``impact_velocity``, and bounds the impulses of the others touching."""

Sliding = Literal["stick", "slip"]
"""A loaded, touching contact's tangential state after a step (its ``stick``/``slip`` events)."""

MAX_LANDINGS_PER_STEP = 4
"""A step is split at most this many times at the instants contacts land (then the rest of the
step lands the next contact by its LCP, as a step without impact law)."""


def _sliding_phrase(sliding: Sliding | None, v_t: float) -> str:
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
    settings: RigidSettings | None = None,
    start: InitialState | None = None,
    armature: float | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> Trajectory:
    """Simulate the scene with rigid contacts by velocity-level time stepping.

    Args:
        scene: the scene; every one of its contacts may open and close (inactive ones too).
        inputs: a constant input vector, ``{name: value}`` (others 0), or ``(t, q, v) -> u``
            called once per step (zero-order hold); None: zero inputs.
        duration: [s] simulated time, > 0.
        dt: [s] step, > 0 and <= duration (the last step is shortened to end at ``duration``).
        settings: the stepper's distances, tolerances, LCP method, ambiguity checks and impact law
            (:class:`RigidSettings`; default: its defaults).
        start: the initial configuration and velocity (default: the scene's).
        armature: rotor inertia for massless coordinates (default: the scene's ``[model]``
            armature, else :data:`~frcontrol.simulation.armature.DEFAULT_ARMATURE`).
        progress: called with (simulated time [s], duration [s]) after every step.

    Returns:
        The trajectory (``model = "rigid"``; its ``status``, ``"completed"``, ``"failed"`` or
        ``"diverged"`` (see :mod:`~frcontrol.simulation.validity`), and ``failure``: time, reason
        and, when it diverged, a hint; or None): one sample per step; ``info`` holds ``dt``, ``steps``,
        ``energy`` [J] (kinetic with the armature + gravitational + the joint springs') and its parts,
        ``max_penetration`` [m] per sample, ``stabilization_work`` [J] (cumulative), ``lcp``
        statistics, ``armature``, ``ambiguity_checks`` and the tolerances. ``warnings`` on the
        trajectory say where the run left its model's validity.

    Raises:
        InputError: a bad duration, step, state, input (length, NaN, outside limits),
            stabilization outside [0, 1], negative distances or tolerances, unknown LCP method.
        LimitExceeded: more samples or sampled memory than the caps of
            :func:`~.inputs.check_simulation_times`.
        SceneError: a bad ``[model]`` table.
        IllConditioned: M is singular even with the armature.
    """
    duration, dt = check_simulation_times(duration, dt, scene=scene)
    start = InitialState() if start is None else start
    schedule, _ = input_schedule(scene, inputs)
    stepper = RigidStepper(scene, RigidSettings() if settings is None else settings, q0=start.q, v0=start.v,
                           armature=armature)
    for _, h in step_lengths(duration, dt):
        if not stepper.step(schedule(stepper.t, stepper.q, stepper.v), h):
            break
        if progress is not None:
            progress(stepper.t, duration)
    return stepper.trajectory(dt)


@dataclass(frozen=True)
class RigidSettings:
    """The rigid stepper's settings, validated.

    Attributes:
        activation_distance: [m] see :data:`ACTIVATION_DISTANCE`.
        stabilization: beta in [0, 1], the fraction of a penetration removed per step.
        impact_velocity: [m/s] see :data:`IMPACT_VELOCITY`.
        slip_velocity_tolerance: [m/s] see :data:`SLIP_VELOCITY_TOLERANCE`.
        lcp_method: ``"lemke"`` or ``"enumerate"``.
        max_ambiguity_checks: at most this many :func:`~frcontrol.engine.solutions_at` calls
            (0: none).
        impact_law: apply the impact law at landings (module docstring). False steps without it:
            the step that lands a contact and the next one absorb its impact through their LCPs
            (inelastic, no restitution, no split; the scheme the flip planner's closed loop was
            verified with).

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
    impact_law: bool = True

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
        self._all = tuple(range(len(self.names)))
        self._mu = np.array([c.mu for c in scene.contacts], dtype=float)
        self._restitution = np.array([scene.model.parameters(c.name).restitution for c in scene.contacts],
                                     dtype=float)
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
        self.status: TrajectoryStatus = "completed"
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
        self.impacts: list[dict] = []
        self._step_impacts = np.zeros((k, 2))
        self._impact_impulses = [np.zeros((k, 2))]
        self.checks: list[dict] = []
        self.lcp_stats = {"solves": 0, "max_unknowns": 0, "regularised_or_fallback": 0, "max_residual": 0.0}
        slip = self.settings.slip_velocity_tolerance
        self._closed = np.abs(self.state.gaps) <= scene.gap_tolerance
        self._sliding: list[Sliding | None] = [
            ("slip" if abs(self.state.tangential_velocities[i]) > slip else "stick")
            if self._closed[i] else None
            for i in range(k)]
        self._check_pending = True
        self._mass_of: object = None  # the state whose M with the armature is self._mass
        self._mass = self.state.mass_matrix
        self._damping_of, self._damping_matrix = -1.0, np.zeros((robot.nv, robot.nv))  # see _step_damping
        self._start_wall = time.perf_counter()

    def step(self, u: np.ndarray, h: float) -> bool:
        """Advance by ``h`` [s] with the inputs ``u`` held.

        Returns:
            False when the run cannot go on (the LCP failed, or the velocity left the numbers):
            :attr:`status` and :attr:`failure` say why, and no sample was added.
        """
        mass = self._applied_mass()
        self._kinetic.append(0.5 * float(self.v @ mass @ self.v))
        self._potential.append(self.scene.robot.potential_energy(self.q))
        start = (self.q, self.v, self.state, len(self.events), len(self.impacts), self._closed.copy(),
                 None if self.transmissions is None else self.transmissions.z.copy())
        self._step_impacts = np.zeros((len(self.names), 2))
        try:
            v_next, p_n, p_t, candidates, rest = self._landed_step(u, h)
        except ImpulseLCPFailure as err:
            self._restore(start)
            self.status, self.failure = "failed", SimulationFailure(self.t, str(err))
            return False
        if not np.isfinite(v_next).all():
            self._restore(start)
            self.status = "diverged"
            self.failure = SimulationFailure(self.t, "the velocity became NaN or infinite", VALIDITY_HINT)
            return False
        self._contact_bookkeeping(u, h, v_next, p_n, candidates)
        self._advance(u, h, v_next, p_n, p_t, rest)
        return True

    def _restore(self, start: tuple) -> None:
        """Undo a step that failed: the state, events and impacts of its start; no sample."""
        self.q, self.v, self.state, n_events, n_impacts, self._closed, z = start
        if self.transmissions is not None and z is not None:
            self.transmissions.undo_parts(z)
        del self.events[n_events:], self.impacts[n_impacts:]
        self._kinetic.pop()
        self._potential.pop()

    def _landed_step(self, u: np.ndarray, h: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
        """One step, split at the instants contacts land, each landing followed by the impact law.

        Returns ``(v+, p_N, p_T, candidates, rest)``: the impulses [N s] summed over the step
        (impacts included), and the length [s] of its last part, which :meth:`_advance` moves.
        """
        k = len(self.names)
        p_n, p_t, cand = np.zeros(k), np.zeros(k), np.zeros(k, dtype=bool)
        rest, work, elapsed = h, 0.0, 0.0
        splits = MAX_LANDINGS_PER_STEP if self.settings.impact_law else 0
        for landing in range(splits + 1):
            if splits:
                self._impact_if_closing(self.t + h)
            mass = self._applied_mass()
            v_next, pn, pt, cand_part, w = self._impulses(mass, u, rest)
            split = self._landing_time(rest, pn, u) if landing < splits else None
            if split is not None:
                v_next, pn, pt, cand_part, w = self._impulses(mass, u, split)
            p_n, p_t, cand, work = p_n + pn, p_t + pt, cand | cand_part, work + w
            if split is None:
                break
            self._move(split, v_next)
            if self.transmissions is not None and self._coupled is not None:  # they move with the joints
                self.transmissions.move(self._coupled, v_next, u)
            rest, elapsed = rest - split, elapsed + split
        self._stab_work.append(self._stab_work[-1] + work)
        return v_next, p_n + self._step_impacts[:, 0], p_t + self._step_impacts[:, 1], cand, rest

    def _step_damping(self, h: float, damping: np.ndarray) -> np.ndarray:
        """``diag(h D)``, the drives' damping over a step of ``h`` [s] (made once per step length)."""
        if self._damping_of != h:
            self._damping_of, self._damping_matrix = h, np.diag(h * damping)
        return self._damping_matrix

    def _applied_mass(self) -> np.ndarray:
        """M with the armature at the current state (made once per state: do not modify it)."""
        if self._mass_of is not self.state:
            self._mass_of, self._mass = self.state, self.armature.apply(self.state.mass_matrix)
        return self._mass

    def _landing_time(self, h: float, p_n: np.ndarray, u: np.ndarray) -> float | None:
        """[s] When the first contact that this step lands at speed closes (None: none does in ``h``).

        A contact lands when it is open at the step's start (gap above :data:`IMPACT_GAP_TOLERANCE`),
        approaches faster than ``impact_velocity`` and takes an impulse. In free flight its gap
        after a step of length ``s`` is ``phi + s v_N + s^2 a_N`` (``a_N = J_N M^-1 (S^T u - h)``,
        as the step predicts it): the step is split at the root, where the contact closes with no
        impulse, so that the impact law sees its whole approach speed.
        """
        st = self.state
        landing = (p_n > 0.0) & (st.gaps > IMPACT_GAP_TOLERANCE) \
            & (st.normal_velocities < -self.settings.impact_velocity)
        if not landing.any():
            return None
        mass = self._applied_mass()
        accel = solve_mass(mass_factor(mass, self.armature), self._input_map @ u - st.bias)
        gap, vn = st.gaps[landing], st.normal_velocities[landing]
        a_n = st.jacobian_normal[landing] @ accel
        disc = vn**2 - 4.0 * a_n * gap
        reach = disc >= 0.0
        if not np.any(reach):
            return None
        roots = 2.0 * gap[reach] / (-vn[reach] + np.sqrt(disc[reach]))  # the smaller root, stably
        first = float(np.min(roots))
        return first if first < h else None

    def _move(self, length: float, v_next: np.ndarray) -> None:
        """Move q by ``length`` [s] at ``v_next`` within a step (no sample, no time)."""
        robot = self.scene.robot
        self.q = robot.integrate(self.q, length * v_next)
        self.v = v_next
        self.state = robot.state(self.q, self.v, self._all)

    def _impact_if_closing(self, t_event: float) -> None:
        """Apply the impact law when a touching contact approaches faster than ``impact_velocity``.

        Every touching contact (gap at most :data:`IMPACT_GAP_TOLERANCE`) takes part; each that
        approached gets an ``impact`` event (time ``t_event``, the step's end) with its impulses
        and normal velocities, and counts as closed from then on.
        """
        st, cfg = self.state, self.settings
        touching = np.flatnonzero(st.gaps <= IMPACT_GAP_TOLERANCE)
        closing = st.normal_velocities[touching] < -cfg.impact_velocity
        if not closing.any():
            return
        mass = self._applied_mass()
        law = impact_law(mass, mass_factor(mass, self.armature), self.v, st.jacobian_normal[touching],
                         st.jacobian_tangent[touching], self._mu[touching], self._restitution[touching],
                         cfg.lcp_method)
        self._step_impacts[touching, 0] += law.impulse_normal
        self._step_impacts[touching, 1] += law.impulse_tangent
        for j in np.nonzero(closing)[0]:
            i = int(touching[j])
            record = {
                "impulse_normal": float(law.impulse_normal[j]),
                "impulse_tangent": float(law.impulse_tangent[j]),
                "normal_velocity_before": float(law.normal_velocity_before[j]),
                "normal_velocity_after": float(law.normal_velocity_after[j]),
                "tangential_velocity_after": float(law.tangential_velocity_after[j]),
                "restitution": float(law.restitution[j]),
                "kinetic_energy_before": law.kinetic_energy_before,
                "kinetic_energy_after": law.kinetic_energy_after,
            }
            detail = (f"v_N = {record['normal_velocity_before']:.4g} -> {record['normal_velocity_after']:.4g}"
                      f" m/s, impulse ({record['impulse_normal']:.4g}, {record['impulse_tangent']:.4g}) N s"
                      f", e = {record['restitution']:.3g}")
            self.events.append(ContactEvent(t_event, self.names[i], "impact", detail, record))
            self.impacts.append({"time": t_event, "contact": self.names[i], **record})
            self._closed[i] = True
            self._sliding[i] = "slip" if abs(law.tangential_velocity_after[j]) \
                > cfg.slip_velocity_tolerance else "stick"
        self.v = law.velocity
        self.state = self.scene.robot.state(self.q, self.v, self._all)

    def _impulses(self, mass: np.ndarray, u: np.ndarray, h: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
        """A step of length ``h`` from the current state, by its LCP.

        Returns ``(v_next, p_N, p_T, candidates, work)``: impulses per contact, the candidates' mask
        and the stabilization work [J].
        """
        st, cfg = self.state, self.settings
        force = self._input_map @ u - st.bias
        if self._damping is not None:  # drives' damping, implicit: (M + h D)(v+ - v) = h (f - D v) + J^T p
            mass = mass + self._step_damping(h, self._damping)
        if self.transmissions is not None:  # elastic drives: the springs' torques, see .drives
            self._coupled = self.transmissions.implicit(self.q, self.v, u, h)
            force, mass = force + self._coupled.force, self._coupled.mass(mass)
        factor = mass_factor(mass, self.armature)
        accel = solve_mass(factor, force)
        v_free = self.v + h * accel
        gaps, vn = st.gaps, st.normal_velocities
        cand = np.flatnonzero(gaps <= cfg.activation_distance + 2.0 * h * np.maximum(0.0, -vn))
        k = len(self.names)
        p_n, p_t = np.zeros(k), np.zeros(k)
        in_cand = np.zeros(k, dtype=bool)
        in_cand[cand] = True
        if not cand.size:
            return v_free, p_n, p_t, in_cand, 0.0
        shifted = np.where(gaps[cand] >= 0, gaps[cand], cfg.stabilization * gaps[cand])
        res = solve_impulse_lcp(factor, v_free, st.jacobian_normal[cand], st.jacobian_tangent[cand],
                                shifted / h, self._mu[cand], cfg.lcp_method)
        p_n[cand], p_t[cand] = res.impulse_normal, res.impulse_tangent
        stats = self.lcp_stats
        stats["solves"] += 1
        stats["max_unknowns"] = max(stats["max_unknowns"], res.lcp_size)
        stats["regularised_or_fallback"] += int(res.regularized)
        stats["max_residual"] = max(stats["max_residual"], res.residual)
        work = float(np.sum(res.impulse_normal * np.maximum(0.0, -shifted))) / h
        return res.velocity, p_n, p_t, in_cand, work

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
        # Python numbers in the loop (numpy scalars cost more per test); the same values
        closed, loaded_l, vt = closed_next.tolist(), loaded.tolist(), vt_next.tolist()
        vn_l, vn_n = vn.tolist(), vn_next.tolist()
        was_closed = self._closed.tolist()
        for i, name in enumerate(self.names):
            new_sliding: Sliding | None = None
            if closed[i] and loaded_l[i]:
                new_sliding = "slip" if abs(vt[i]) > cfg.slip_velocity_tolerance else "stick"
            if closed[i] and not was_closed[i]:
                had_event = True
                how = _sliding_phrase(new_sliding, vt[i])
                if vn_l[i] < -cfg.impact_velocity:
                    detail = f"v_N = {vn_l[i]:.4g} m/s, impulse {float(p_n[i]):.4g} N s; {how}"
                    self.events.append(ContactEvent(t_next, name, "impact", detail))
                else:
                    self.events.append(ContactEvent(t_next, name, "close", how))
            elif was_closed[i] and not closed[i]:
                had_event = True
                self.events.append(ContactEvent(t_next, name, "open", f"v_N = {vn_n[i]:.4g} m/s"))
            elif closed[i] and new_sliding is not None and self._sliding[i] is not None \
                    and new_sliding != self._sliding[i]:
                had_event = True
                detail = f"v_T = {vt[i]:.4g} m/s" if new_sliding == "slip" else ""
                self.events.append(ContactEvent(t_next, name, new_sliding, detail))
            if closed[i]:
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
            detail = f"modes {entry['summary']}; the step took {entry['scene_taken']}"
            self.events.append(ContactEvent(self.t, ",".join(entry["contacts"]), "ambiguous", detail))

    def _advance(self, u: np.ndarray, h: float, v_next: np.ndarray, p_n: np.ndarray, p_t: np.ndarray,
                 rest: float | None = None) -> None:
        """Move the state to the end of the step (its last ``rest`` [s], default all) and record it."""
        robot = self.scene.robot
        self.q = robot.integrate(self.q, (h if rest is None else rest) * v_next)
        self.v = v_next
        if self.transmissions is not None and self._coupled is not None:
            self.transmissions.advance(self._coupled, v_next, u)
        self.t = self.t + h
        self.state = robot.state(self.q, self.v, self._all)
        forces = np.empty((len(p_n), 2))
        forces[:, 0], forces[:, 1] = p_n, p_t
        forces /= h
        self.last_forces = forces
        self._times.append(self.t)
        self._qs.append(self.q.copy())
        self._vs.append(self.v.copy())
        self._us.append(np.asarray(u, dtype=float).copy())
        self._forces.append(self.last_forces)
        self._impact_impulses.append(self._step_impacts.copy())
        self._points.append(self.state.contact_points.copy())
        self._penetration.append(max(0.0, -float(self.state.gaps.min())) if len(self.names) else 0.0)

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
        springs = np.asarray(scene.robot.springs.elastic_energy(np.array(self._qs)), dtype=float)
        energy = kinetic + potential + springs
        extra_work = np.array(self._stab_work)
        if self.transmissions is not None:
            energy = energy + self.transmissions.energy(np.array(self._qs))
            extra_work = extra_work + self.transmissions.work()
        info = {
            "scheme": "velocity-level time stepping (Stewart-Trinkle), exact 2-D Coulomb law, LCP by "
                      f"{cfg.lcp_method}, impact law (Coulomb, Newton restitution) at landings",
            "dt": dt,
            "steps": len(self._times) - 1,
            "duration": float(self._times[-1]),
            "energy": energy,
            "kinetic_energy": kinetic,
            "potential_energy": potential,
            "spring_energy": springs,
            "max_penetration": np.array(self._penetration),
            "stabilization_work": np.array(self._stab_work),
            "impacts": list(self.impacts),
            "impact_impulses": np.array(self._impact_impulses),
            "restitution": dict(zip(self.names, self._restitution.tolist(), strict=True)),
            "lcp": dict(self.lcp_stats),
            "armature": self.armature.report(),
            "ambiguity_checks": list(self.checks),
            "ambiguity_checks_limit": cfg.max_ambiguity_checks,
            "tolerances": {
                "activation_distance": cfg.activation_distance,
                "stabilization": cfg.stabilization,
                "impact_velocity": cfg.impact_velocity,
                "impact_gap": IMPACT_GAP_TOLERANCE,
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
    at_state = ContactProblem.from_scene(scene, q, v, contacts=touching, velocity_tolerance=slip_tol,
                                         drive_torque=drive_torque)
    vt = at_state.tangential_velocities.copy()
    vt[np.abs(vt) <= slip_tol] = 0.0
    problem = replace(at_state, mass_matrix=arm.apply(at_state.mass_matrix),
                      normal_velocities=np.zeros(len(touching)), tangential_velocities=vt)
    entry: dict = {"time": t, "contacts": list(problem.contacts), "taken": taken,
                   "scene_taken": problem.scene_mode(taken)}
    try:
        solutions = solutions_at(problem, u)
    except FrcontrolError as err:  # reported, never fatal: the check is a diagnosis
        entry.update({"modes": [], "scene_modes": [], "distinct_motions": 0, "summary": "",
                      "error": str(err)})
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
    entry["scene_modes"] = [problem.scene_mode(s.mode) for s in solutions]
    entry["distinct_motions"] = len(groups)
    entry["summary"] = ", ".join("=".join(problem.scene_mode(mode) for mode in modes) for _, modes in groups)
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
