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

Massless links get a joint armature (see :mod:`frcontrol.simulation.options`).

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
from .options import (
    DEFAULT_ARMATURE,
    Armature,
    InputSchedule,
    check_simulation_times,
    input_schedule,
    mass_factor,
    massless_armature,
    model_options,
    potential_energy,
)
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
            armature, else :data:`~frcontrol.simulation.options.DEFAULT_ARMATURE`).
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
    if not 0.0 <= stabilization <= 1.0:
        raise InputError(f"stabilization must be in [0, 1] (fraction of a penetration removed per step), "
                         f"got {stabilization}")
    for label, value in (("activation_distance", activation_distance), ("impact_velocity", impact_velocity),
                         ("slip_velocity_tolerance", slip_velocity_tolerance)):
        if not np.isfinite(value) or value < 0:
            raise InputError(f"{label} must be a finite number >= 0, got {value}")
    if lcp_method not in ("lemke", "enumerate"):
        raise InputError(f"unknown LCP method {lcp_method!r}; use 'lemke' or 'enumerate'")
    options = model_options(scene)
    robot = scene.robot
    q, v = robot.check_state(scene.q if q0 is None else q0, scene.v if v0 is None else v0)
    schedule, _ = input_schedule(scene, inputs)
    n = robot.nv
    names = tuple(c.name for c in scene.contacts)
    k_all = len(names)
    all_idx = list(range(k_all))
    mu_all = np.array([c.mu for c in scene.contacts], dtype=float)
    input_map = scene.inputs.selection_transpose(n)
    state = robot.state(q, v, all_idx)
    arm = massless_armature(scene, state.mass_matrix,
                            options.armature if armature is None else armature)
    force_scale = robot.weight_scale()
    force_tol = CONTACT_FORCE_TOLERANCE * force_scale

    steps = max(1, int(np.ceil(duration / dt - 1e-9)))
    times = [0.0]
    qs, vs = [q.copy()], [v.copy()]
    us: list[np.ndarray] = []
    forces = [np.zeros((k_all, 2))]
    points = [state.contact_points.copy()]
    kinetic, potential = [], []
    penetration = [max(0.0, -float(np.min(state.gaps, initial=np.inf)))]
    stab_work = [0.0]
    events: list[ContactEvent] = []
    checks: list[dict] = []
    lcp_stats = {"solves": 0, "max_unknowns": 0, "regularised_or_fallback": 0, "max_residual": 0.0}
    status = "completed"
    failure: SimulationFailure | None = None

    touching = np.abs(state.gaps) <= scene.gap_tolerance
    closed = touching.copy()
    sliding: list[str | None] = [
        ("slip" if abs(state.tangential_velocities[i]) > slip_velocity_tolerance else "stick")
        if closed[i] else None for i in range(k_all)
    ]
    check_pending = True
    start_wall = time.perf_counter()
    t = 0.0
    for step in range(steps):
        h = min(dt, duration - t) if step == steps - 1 else dt
        mass = arm.apply(state.mass_matrix)
        kinetic.append(0.5 * float(v @ mass @ v))
        potential.append(potential_energy(scene, q))
        u = schedule(t, q, v)
        factor = mass_factor(mass, arm)
        v_free = v + h * scipy.linalg.cho_solve(factor, input_map @ u - state.bias, check_finite=False)
        gaps, vn = state.gaps, state.normal_velocities
        cand = np.nonzero(gaps <= activation_distance + 2.0 * h * np.maximum(0.0, -vn))[0]
        p_n_all = np.zeros(k_all)
        p_t_all = np.zeros(k_all)
        if cand.size:
            try:
                res = _solve_step(factor, v_free, state.jacobian_normal[cand], state.jacobian_tangent[cand],
                                  gaps[cand], mu_all[cand], h, stabilization, lcp_method)
            except _StepFailure as err:
                status, failure = "failed", SimulationFailure(t, str(err))
                break
            v_next = res.v_next
            p_n_all[cand] = res.impulse_n
            p_t_all[cand] = res.impulse_t
            lcp_stats["solves"] += 1
            lcp_stats["max_unknowns"] = max(lcp_stats["max_unknowns"], res.lcp_size)
            lcp_stats["regularised_or_fallback"] += int(res.regularized)
            lcp_stats["max_residual"] = max(lcp_stats["max_residual"], res.residual)
            shifted = np.where(gaps[cand] >= 0, gaps[cand], stabilization * gaps[cand])
            stab_work.append(stab_work[-1] + float(np.sum(res.impulse_n * np.maximum(0.0, -shifted))) / h)
        else:
            v_next = v_free
            stab_work.append(stab_work[-1])
        if not np.all(np.isfinite(v_next)):
            status = "diverged"
            failure = SimulationFailure(t, "the velocity became NaN or infinite", VALIDITY_HINT)
            stab_work.pop()
            break

        vn_next = state.jacobian_normal @ v_next
        vt_next = state.jacobian_tangent @ v_next
        loaded = p_n_all / h > force_tol
        in_cand = np.zeros(k_all, dtype=bool)
        in_cand[cand] = True
        closed_next = loaded | (in_cand & (gaps + h * vn_next <= scene.gap_tolerance))

        # Is the rigid model ambiguous at this state? Compare with what the step took.
        if check_pending and len(checks) < max_ambiguity_checks:
            touching_idx = [i for i in range(k_all) if closed[i]]
            if touching_idx and np.all(np.abs(vn[touching_idx]) <= AMBIGUITY_VELOCITY_TOLERANCE):
                check_pending = False
                taken = _taken_mode(p_n_all[touching_idx], vt_next[touching_idx], force_tol, h,
                                    slip_velocity_tolerance)
                checks.append(_ambiguity_check(scene, q, v, u, touching_idx, arm, slip_velocity_tolerance,
                                               taken, t))
                entry = checks[-1]
                if entry["distinct_motions"] > 1:
                    events.append(ContactEvent(t, ",".join(entry["contacts"]), "ambiguous",
                                               f"modes {entry['summary']}; the step took {taken}"))
            elif not touching_idx:
                check_pending = False

        t_next = t + h
        had_event = False
        for i in range(k_all):
            new_sliding: str | None = None
            if closed_next[i] and loaded[i]:
                new_sliding = "slip" if abs(vt_next[i]) > slip_velocity_tolerance else "stick"
            if closed_next[i] and not closed[i]:
                had_event = True
                how = _sliding_phrase(new_sliding, vt_next[i])
                if vn[i] < -impact_velocity:
                    events.append(ContactEvent(t_next, names[i], "impact",
                                               f"v_N = {vn[i]:.4g} m/s, impulse {p_n_all[i]:.4g} N s; {how}"))
                else:
                    events.append(ContactEvent(t_next, names[i], "close", how))
            elif closed[i] and not closed_next[i]:
                had_event = True
                events.append(ContactEvent(t_next, names[i], "open", f"v_N = {vn_next[i]:.4g} m/s"))
            elif closed_next[i] and new_sliding is not None and sliding[i] is not None \
                    and new_sliding != sliding[i]:
                had_event = True
                detail = f"v_T = {vt_next[i]:.4g} m/s" if new_sliding == "slip" else ""
                events.append(ContactEvent(t_next, names[i], new_sliding, detail))
            if closed_next[i]:
                sliding[i] = new_sliding if new_sliding is not None else sliding[i]
            else:
                sliding[i] = None
        if had_event:
            check_pending = True
        closed = closed_next

        q = robot.integrate(q, h * v_next)
        v = v_next
        t = t_next
        state = robot.state(q, v, all_idx)
        times.append(t)
        qs.append(q.copy())
        vs.append(v.copy())
        us.append(u.copy())
        f = np.zeros((k_all, 2))
        f[:, 0] = p_n_all / h
        f[:, 1] = p_t_all / h
        forces.append(f)
        points.append(state.contact_points.copy())
        penetration.append(max(0.0, -float(np.min(state.gaps, initial=np.inf))))

    mass = arm.apply(state.mass_matrix)
    kinetic.append(0.5 * float(v @ mass @ v))
    potential.append(potential_energy(scene, q))
    if us:
        inputs_arr = np.vstack([us[0]] + us)
    else:
        inputs_arr = np.zeros((1, scene.inputs.count))
    energy = np.array(kinetic) + np.array(potential)
    info = {
        "scheme": "velocity-level time stepping (Stewart-Trinkle), exact 2-D Coulomb law, LCP by "
                  f"{lcp_method}, inelastic impacts",
        "dt": dt,
        "steps": len(times) - 1,
        "duration": float(times[-1]),
        "energy": energy,
        "kinetic_energy": np.array(kinetic),
        "potential_energy": np.array(potential),
        "max_penetration": np.array(penetration),
        "stabilization_work": np.array(stab_work),
        "lcp": lcp_stats,
        "armature": arm.report(),
        "ambiguity_checks": checks,
        "ambiguity_checks_limit": max_ambiguity_checks,
        "tolerances": {
            "activation_distance": activation_distance,
            "stabilization": stabilization,
            "impact_velocity": impact_velocity,
            "slip_velocity": slip_velocity_tolerance,
            "contact_force": force_tol,
            "ambiguity_velocity": AMBIGUITY_VELOCITY_TOLERANCE,
            "gap": scene.gap_tolerance,
        },
        "wall_time": time.perf_counter() - start_wall,
    }
    trajectory = Trajectory(
        scene_name=scene.name,
        coordinates=scene.coordinate_names,
        contacts=names,
        times=np.array(times),
        q=np.array(qs),
        v=np.array(vs),
        inputs=inputs_arr,
        input_names=scene.inputs.coordinates,
        contact_forces=np.array(forces),
        contact_points=np.array(points),
        events=tuple(events),
        info=info,
        model="rigid",
        status=status,
        failure=failure,
    )
    return assess(scene, trajectory, energy=energy, penetration=info["max_penetration"], stiffness=None,
                  dt=dt, extra_work=info["stabilization_work"])


def _ambiguity_check(scene: Scene, q: np.ndarray, v: np.ndarray, u: np.ndarray, touching: list[int],
                     arm: Armature, slip_tol: float, taken: str, t: float) -> dict:
    """Every rigid solution at this state (touching contacts, v_N taken as 0), and the step's mode."""
    from ..engine import solutions_at  # the engine is heavy; import on first use

    at_state = ContactProblem.from_scene(scene, q, v, contacts=touching, velocity_tolerance=slip_tol)
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
