"""Benchmark: the trade between speed and accuracy, rigid mode analysis against compliant contact.

Run from the repository root::

    python -m benchmarks.trade            # the full sweep (about 45 minutes here)
    python -m benchmarks.trade --quick    # fewer knobs (a few minutes)
    python -m benchmarks.trade --replot   # redraw the figures from the JSON
    python -m benchmarks.trade --zones    # contact zones and the impact law (benchmarks/trade_zones.py)

Writes ``benchmarks/results/trade.json``, one figure per scene ``benchmarks/results/trade_<scene>.png``
(error against wall time, log-log, the Pareto front marked) and prints a short table. The drives'
part (what a DC-motor drive and an elastic gearhead cost per step, and how far the gearhead's
stiffness moves the answer) is ``python -m benchmarks.trade_drives``.

The question each point answers
-------------------------------
*What are the contact forces at this state and input?* Five scenes, each at its file's state
(``v = 0``) and one fixed input ``u`` (:data:`SCENARIOS`):

================  ======  ================================================================
scene             mode    input u (why)
================  ======  ================================================================
rod_on_table      F       0 (the rod pivots about its sticking tip: a moving answer)
box_on_slope      FF      0 (tan 20 deg < mu: it sticks; tangential forces indeterminate)
table_on_ground   FF      0 (statically indeterminate internal squeeze)
rhex_flip         RFL     hip torques (-3.08, -3.65) N m: the body pitches up at 2.6 rad/s^2
                          with its front corner sliding (the flip's opening phase)
snake_climb       FFF     joint torques (-0.43, 2.12, -0.96, -0.09, 0.01, 0.26, 0, 0) N m: the
                          brace holds while the upper part falls
================  ======  ================================================================

The two inputs that are not zero are the Chebyshev centres of the named mode's domain D_c
(:func:`frcontrol.engine.analyze`) under +-10 N m input limits, rounded to 0.01 N m; at each input the
rigid model has one solution (checked at run time) and it is stable
(:func:`frcontrol.stability.stability_of`), so the compliant model converges to it as the stiffness
grows (Kraus, Kumar and Dupont).

**Reference** (the converged answer): the rigid solution at ``u``,
``f_ref = (lam_N, lam_T)`` over the active contacts, from :func:`frcontrol.engine.solutions_at`
with HiGHS. Where the mode is statically indeterminate (box on the slope, table) the forces are
defined only up to the internal forces ``N w`` (``N``: the force rows of the mode's null-space
basis ``X_w``), and every error below is taken *modulo* them.

**Force error** of an answer ``f``::

    e_F = min_w |f - f_ref - N w|_2 / |f_ref|_2                       (relative, [-])

Rigid answers (the knobs: LP back-end DAQP / HiGHS / ProxQP; and with or without a prior
:func:`~frcontrol.engine.analyze` of the whole scene): ``f`` from ``solutions_at``. Valid when
every solution found has the reference's accelerations (one motion) and one of them is in the
reference's mode.

Compliant answers: :func:`frcontrol.simulation.compliant.simulate_compliant` started at the
scene's state with relaxed springs (no penetration, no stretch: a user who does not know the forces
cannot preload them), run for a *settling window* ``t_r = N_r / omega_min`` and read at its end:
``f`` = the Kelvin–Voigt forces at ``t_r``. ``omega_min = sqrt(k d_min)`` is the slowest
boundary-layer frequency, ``d_min`` the smallest eigenvalue of KKD's ``D`` (the stability
verdict's eigenvalues). Knobs: the contact stiffness ``k`` (1e2 .. 1e10 N/m, normal and tangential;
damping critical for each contact's effective mass, the module's default, so it scales as
``sqrt(k)``), the integrator (implicit ``radau``, ``bdf``; switching ``lsoda``; explicit ``rk45``,
``dop853`` and fixed-step semi-implicit ``euler``), its accuracy (adaptive: ``rtol`` with
``atol = rtol * delta_ref``, ``delta_ref = max lam_N,ref / k`` the reference penetration, floored
at :data:`ATOL_FLOOR`; ``euler``: the step as a fraction of the module's reported explicit stability
limit) and the window ``N_r`` (a short window leaves the transient, a long one lets the state move
on: the answer is for a later state). Valid when the simulation completes (``status`` completed,
finite forces); a run that raises (see the notes) or fails is recorded, never timed.

**Trajectory error** (the time step and the integrator, at a fixed stiffness): a compliant
simulation over :data:`TRAJECTORY_DURATION` from the scene's state, samples every
:data:`TRAJECTORY_SAMPLE`; error = the largest distance [m] between a link origin and the same
origin in a fine reference of the *same* model (``radau``, ``rtol`` :data:`REFERENCE_RTOL`; if it
fails, ``lsoda``, then ``dop853``), over every sample and link. This isolates the discretisation
error; the model error (finite k) is the force error above.

**Projection** (Fourier–Motzkin is the only method of :func:`frcontrol.polytope.project`): its
knob is the pruning tolerance (redundancy slack, default 1e-9). For every feasible mode with
ambiguity variables, T_c is projected at each tolerance; error = the largest difference of the
support function over :data:`PROJECTION_DIRECTIONS` seeded unit directions, relative to T_c's width
in that direction, against the projection at :data:`PROJECTION_REFERENCE_TOLERANCE`; time = the
sum over the modes. Scenes whose modes have no ambiguity variable need no projection (T_c = D_c).

LP tolerances are not a knob of the engine: :func:`~frcontrol.engine.analyze` and
``solutions_at`` take the back-end but no LP options (the tolerances are the modules' named
constants, e.g. ``DOMAIN_TOLERANCE``, ``FEASIBILITY_TOLERANCE``); the back-end is swept instead.

**Timing.** Wall time of the whole call in this process (``time.perf_counter``), scene loaded once
outside. Every configuration is run once; the configurations on a Pareto front and the cheapest
one reaching :data:`TARGET_FORCE_ERROR` are re-run and get the median of ``--runs`` runs (the
``runs`` field says how many). Rigid answers: median of :data:`RIGID_RUNS`.

**The 100x target.** Per scene: the median time of the cheapest valid compliant configuration with
``e_F <= 1e-3``, divided by the median time of ``solutions_at`` (DAQP) answering the same state,
in the same process.

**Pruning inactive contacts** (snake): the snake scene with every joint, the tail and the head
listed against both walls (20 contacts, 17 of them not touching). With pruning (the default) the
engine models the 3 touching ones; without, ``load_scene(..., gap_tolerance=1 m)`` makes all 20
active (a different model: it treats the open ones as touching). Also the compliant model with
``contacts="active"`` (3 contacts in the state) against ``contacts="all"`` (20).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import statistics
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from frcontrol import polytope as poly
from frcontrol.engine import analyze, solutions_at
from frcontrol.errors import FrcontrolError
from frcontrol.modes import ContactProblem, build_mode_system
from frcontrol.response import solve_affine
from frcontrol.scene import Scene, load_scene, shipped_robots_dir
from frcontrol.simulation.compliant import CompliantSettings, simulate_compliant
from frcontrol.solvers import available_solvers
from frcontrol.stability import stability_of

RESULTS = Path(__file__).resolve().parent / "results"

TARGET_FORCE_ERROR = 1e-3
"""[-] The relative force error the 100x target names."""

ATOL_FLOOR = 1e-15
"""[m, m/s] Smallest absolute tolerance handed to an adaptive integrator."""

MAX_STEPS = 3_000
"""Integrator steps per compliant force readout at most (beyond: ``failed``, not timed)."""

MAX_TRAJECTORY_STEPS = 30_000
"""Integrator steps per trajectory run (and per fine reference) at most."""

MAX_EULER_STEPS = 20_000
"""A fixed-step configuration predicted to need more steps is skipped (recorded as such)."""

PROBE_DURATION = 1e-9
"""[s] Length of the probe run that reads the explicit stability limit."""

RIGID_RUNS = 20
"""Repetitions of each rigid answer (median)."""

TRAJECTORY_DURATION = 0.1
"""[s] Length of the trajectory-error simulations."""

TRAJECTORY_SAMPLE = 0.005
"""[s] Sample interval of the trajectory comparison."""

REFERENCE_RTOL = 1e-9
"""[-] rtol of the fine reference trajectory."""

PROJECTION_TOLERANCES = (1e-12, 1e-9, 1e-6, 1e-3)
"""[units of u] Fourier–Motzkin pruning tolerances swept (1e-9 is the default)."""

PROJECTION_REFERENCE_TOLERANCE = 1e-12
"""[units of u] The projection every other is compared with."""

PROJECTION_DIRECTIONS = 64
"""Seeded unit directions of the support-function comparison."""

ERROR_FLOOR = 1e-16
"""[-] Errors below this are drawn at this value on the log axes."""

SEED = 20250501
"""Seed of every random choice (projection directions)."""


@dataclass(frozen=True)
class Scenario:
    """A scene and the input of the question (see the module docstring)."""

    name: str
    mode: str
    inputs: tuple[float, ...] | None = None


SCENARIOS = (
    Scenario("rod_on_table", "F"),
    Scenario("box_on_slope", "FF"),
    Scenario("table_on_ground", "FF"),
    Scenario("rhex_flip", "RFL", (-3.08, -3.65)),
    Scenario("snake_climb", "FFF", (-0.43, 2.12, -0.96, -0.09, 0.01, 0.26, 0.0, 0.0)),
)


@dataclass(frozen=True)
class Sweep:
    """The knobs of one run of the benchmark."""

    stiffness: tuple[float, ...]
    integrators: tuple[str, ...]
    rtols: tuple[float, ...]
    euler_fractions: tuple[float, ...]
    windows: tuple[float, ...]
    trajectory_stiffness: tuple[float, ...]
    runs: int


FULL = Sweep(
    stiffness=tuple(10.0 ** e for e in range(2, 11)),
    integrators=("radau", "bdf", "lsoda", "rk45", "dop853", "euler"),
    rtols=(1e-3, 1e-5, 1e-8),
    euler_fractions=(0.3, 0.1),
    windows=(12.0, 40.0, 120.0),
    trajectory_stiffness=(1e5, 1e7),
    runs=5,
)
QUICK = Sweep(
    stiffness=(1e3, 1e5, 1e7, 1e9),
    integrators=("radau", "lsoda", "rk45", "euler"),
    rtols=(1e-3, 1e-6),
    euler_fractions=(0.3,),
    windows=(12.0, 40.0),
    trajectory_stiffness=(1e5,),
    runs=3,
)


# ------------------------------------------------------------------------------------ reference
@dataclass(frozen=True)
class Reference:
    """The converged answer of a scenario and what the errors need."""

    scenario: Scenario
    scene: Scene
    u: np.ndarray
    mode: str
    dv: np.ndarray
    forces: np.ndarray          # (lam_N, lam_T) over the active contacts
    internal: np.ndarray        # (2k, p) force rows of X_w: the internal forces
    slowest_eigenvalue: float   # d_min [1/kg]
    stable: bool | None

    @property
    def active(self) -> list[int]:
        """Indices of the active contacts in the scene's contact list."""
        return list(self.scene.active_indices)


def force_error(ref: Reference, forces: np.ndarray) -> float:
    """``min_w |f - f_ref - N w| / |f_ref|`` (module docstring)."""
    d = np.asarray(forces, dtype=float) - ref.forces
    if ref.internal.shape[1]:
        w, *_ = np.linalg.lstsq(ref.internal, d, rcond=None)
        d = d - ref.internal @ w
    return float(np.linalg.norm(d) / np.linalg.norm(ref.forces))


def build_reference(scenario: Scenario, scene: Scene) -> Reference:
    """The rigid solution at the scenario's input, checked unique and in the named mode."""
    u = np.zeros(scene.inputs.count) if scenario.inputs is None else np.array(scenario.inputs, float)
    solutions = solutions_at(scene, u, solver="highs")
    motions = {tuple(np.round(s.dv, 9)) for s in solutions}
    chosen = [s for s in solutions if s.mode == scenario.mode]
    if len(motions) != 1 or not chosen:
        raise RuntimeError(f"{scenario.name}: expected one motion in mode {scenario.mode}, got "
                           f"{[s.mode for s in solutions]}")
    solution = chosen[0]
    problem = ContactProblem.from_scene(scene)
    system = build_mode_system(problem, solution.mode)
    response = solve_affine(system.A, system.B, system.c)
    verdict = stability_of(problem, solution)
    finite = verdict.eigenvalues.real[np.isfinite(verdict.eigenvalues.real)]
    if finite.size:
        d_min = float(np.min(finite))
    else:  # no held row: the per-contact effective masses
        d_min = float(np.min(np.einsum("kn,kn->k", problem.jacobian_normal,
                                       np.linalg.lstsq(problem.mass_matrix, problem.jacobian_normal.T,
                                                       rcond=None)[0].T)))
    return Reference(
        scenario=scenario, scene=scene, u=u, mode=solution.mode, dv=solution.dv,
        forces=np.concatenate([solution.lambda_n, solution.lambda_t]),
        internal=response.X_w[problem.n:], slowest_eigenvalue=d_min, stable=verdict.stable,
    )


# ------------------------------------------------------------------------------------ timing
def median_time(call: Callable[[], Any], runs: int) -> tuple[float, list[float], Any]:
    """Median wall time [s] of ``runs`` calls, the times, and the last result."""
    times, result = [], None
    for _ in range(max(1, runs)):
        start = time.perf_counter()
        result = call()
        times.append(time.perf_counter() - start)
    return statistics.median(times), times, result


# ------------------------------------------------------------------------------------ rigid answers
def rigid_points(ref: Reference, runs: int = RIGID_RUNS) -> list[dict]:
    """The rigid answers: each LP back-end, with and without a prior analysis of the scene."""
    points = []
    for solver in available_solvers():
        def at_state(solver: str = solver) -> list:
            return solutions_at(ref.scene, ref.u, solver=solver)

        def with_analysis(solver: str = solver) -> list:
            return solutions_at(analyze(ref.scene, solver=solver, ambiguity=False), ref.u, solver=solver)

        for label, call in (("solutions_at", at_state), ("analyze+solutions_at", with_analysis)):
            try:
                seconds, times, solutions = median_time(call, runs if label == "solutions_at" else
                                                        max(3, runs // 4))
            except FrcontrolError as err:
                points.append({"kind": "rigid", "call": label, "solver": solver, "valid": False,
                               "reason": f"{type(err).__name__}: {err}"})
                continue
            chosen = [s for s in solutions if s.mode == ref.mode]
            one_motion = all(np.allclose(s.dv, ref.dv, rtol=1e-6, atol=1e-6) for s in solutions)
            valid = bool(chosen) and one_motion
            point = {"kind": "rigid", "call": label, "solver": solver, "valid": valid,
                     "modes": [s.mode for s in solutions], "runs": len(times)}
            if valid:
                s = chosen[0]
                point.update(time=seconds, error=force_error(ref, np.concatenate([s.lambda_n, s.lambda_t])))
            else:
                point["reason"] = "not the reference's single motion"
            points.append(point)
    return points


# ------------------------------------------------------------------------------------ compliant
def euler_limit(ref: Reference, stiffness: float) -> float:
    """The explicit stability limit [s] that simulate_compliant reports at this stiffness.

    Read from a one-step probe run (``info["explicit_stability_limit"]``), so that the fractions of
    the ``euler`` sweep follow the library's own limit.
    """
    probe = simulate_compliant(ref.scene, ref.u, PROBE_DURATION, PROBE_DURATION,
                               settings=CompliantSettings(stiffness=stiffness))
    return float(probe.info["explicit_stability_limit"])


def compliant_run(ref: Reference, config: dict, duration: float, dt: float,
                  contacts: str = "active", max_steps: int = MAX_STEPS) -> Any:
    """One compliant simulation of a configuration (stiffness, integrator, rtol or step)."""
    k = config["stiffness"]
    delta = float(np.max(np.abs(ref.forces[: len(ref.active)]))) / k
    rtol = config.get("rtol", 1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # SciPy's num_jac overflow warnings
        settings = CompliantSettings(integrator=config["integrator"], stiffness=k, rtol=rtol,
                                     atol=max(rtol * delta, ATOL_FLOOR), max_step=duration,
                                     max_steps=max_steps, contacts=contacts)
        return simulate_compliant(ref.scene, ref.u, duration, dt, settings=settings)


def readout_forces(ref: Reference, trajectory: Any) -> np.ndarray:
    """(lam_N, lam_T) of the active contacts at the last sample."""
    last = trajectory.contact_forces[-1][ref.active]
    return np.concatenate([last[:, 0], last[:, 1]])


def force_configs(ref: Reference, sweep: Sweep) -> list[dict]:
    """Every compliant configuration of the force sweep."""
    configs = []
    for k in sweep.stiffness:
        for window in sweep.windows:
            for integrator in sweep.integrators:
                if integrator == "euler":
                    limit = euler_limit(ref, k)
                    for fraction in sweep.euler_fractions:
                        configs.append({"stiffness": k, "window": window, "integrator": integrator,
                                        "euler_fraction": fraction, "step": fraction * limit})
                else:
                    for rtol in sweep.rtols:
                        configs.append({"stiffness": k, "window": window, "integrator": integrator,
                                        "rtol": rtol})
    return configs


def force_point(ref: Reference, config: dict, runs: int = 1) -> dict:
    """Run one force configuration: error, validity and time."""
    k = config["stiffness"]
    t_r = config["window"] / math.sqrt(k * ref.slowest_eigenvalue)
    point = {"kind": "compliant", **config, "readout_time": t_r}
    if config["integrator"] == "euler":
        steps = t_r / config["step"]
        if steps > MAX_EULER_STEPS:
            return {**point, "valid": False, "reason": f"skipped: {steps:.0f} fixed steps predicted"}
        dt = t_r / math.ceil(steps)
    else:
        dt = t_r
    try:
        seconds, times, trajectory = median_time(lambda: compliant_run(ref, config, t_r, dt), runs)
    except (FrcontrolError, ValueError, np.linalg.LinAlgError) as err:
        return {**point, "valid": False, "reason": f"raised {type(err).__name__}: {str(err)[:160]}"}
    status = trajectory.status
    forces = readout_forces(ref, trajectory)
    if status != "completed" or not np.all(np.isfinite(forces)):
        reason = trajectory.failure.reason if trajectory.failure else "non-finite forces"
        return {**point, "valid": False, "reason": f"{status}: {reason}"}
    return {**point, "valid": True, "time": seconds, "runs": len(times),
            "error": force_error(ref, forces), "steps": trajectory.info["steps"],
            "rhs_evaluations": trajectory.info["rhs_evaluations"]}


# ------------------------------------------------------------------------------------ trajectories
def link_origins(scene: Scene, q_samples: np.ndarray) -> np.ndarray:
    """World positions [m] of every link origin, shape (T, links, 2)."""
    out = []
    for q in q_samples:
        poses = scene.robot.link_poses(q)
        out.append([poses[name][0] for name in sorted(poses)])
    return np.array(out)


def trajectory_reference(ref: Reference, stiffness: float) -> tuple[np.ndarray | None, str]:
    """Link origins of the fine reference at the sample times, and the integrator used."""
    for integrator, rtol in (("radau", REFERENCE_RTOL), ("lsoda", REFERENCE_RTOL), ("dop853", 1e-10)):
        config = {"stiffness": stiffness, "integrator": integrator, "rtol": rtol}
        try:
            trajectory = compliant_run(ref, config, TRAJECTORY_DURATION, TRAJECTORY_SAMPLE,
                                       max_steps=MAX_TRAJECTORY_STEPS)
        except (FrcontrolError, ValueError, np.linalg.LinAlgError):
            continue
        if trajectory.completed:
            return link_origins(ref.scene, trajectory.q), f"{integrator} rtol {rtol:g}"
    return None, "none: every reference integrator failed"


def trajectory_point(ref: Reference, config: dict, reference: np.ndarray, runs: int = 1) -> dict:
    """Run one trajectory configuration against the reference."""
    point = {"kind": "trajectory", **config}
    samples = round(TRAJECTORY_DURATION / TRAJECTORY_SAMPLE)
    if config["integrator"] == "euler":
        per_sample = math.ceil(TRAJECTORY_SAMPLE / config["step"])
        if per_sample * samples > MAX_EULER_STEPS:
            return {**point, "valid": False, "reason": f"skipped: {per_sample * samples} fixed steps"}
        dt = TRAJECTORY_SAMPLE / per_sample
    else:
        per_sample, dt = 1, TRAJECTORY_SAMPLE
    try:
        seconds, times, trajectory = median_time(
            lambda: compliant_run(ref, config, TRAJECTORY_DURATION, dt, max_steps=MAX_TRAJECTORY_STEPS),
            runs)
    except (FrcontrolError, ValueError, np.linalg.LinAlgError) as err:
        return {**point, "valid": False, "reason": f"raised {type(err).__name__}: {str(err)[:160]}"}
    if not trajectory.completed:
        return {**point, "valid": False, "reason": f"{trajectory.status}: {trajectory.failure.reason}"}
    origins = link_origins(ref.scene, trajectory.q[::per_sample])
    if origins.shape != reference.shape or not np.all(np.isfinite(origins)):
        return {**point, "valid": False, "reason": "samples do not match the reference's"}
    error = float(np.max(np.linalg.norm(origins - reference, axis=2)))
    return {**point, "valid": True, "time": seconds, "runs": len(times), "error": error,
            "steps": trajectory.info["steps"]}


# ------------------------------------------------------------------------------------ projection
def projection_points(ref: Reference) -> dict:
    """Fourier–Motzkin pruning tolerance: time against support-function error."""
    analysis = analyze(ref.scene, ambiguity=False)
    modes = [m for m in analysis.feasible_modes if m.ambiguity_dim > 0]
    if not modes:
        return {"applicable": False,
                "reason": "no feasible mode has ambiguity variables: T_c = D_c, nothing to project"}
    m = analysis.problem.m
    rng = np.random.default_rng(SEED)
    directions = rng.standard_normal((PROJECTION_DIRECTIONS, m))
    directions /= np.linalg.norm(directions, axis=1)[:, None]

    def supports(P: poly.Polytope) -> np.ndarray:
        if P.empty:
            return np.full(len(directions), -np.inf)
        return np.array([poly.support(P, d) for d in directions])

    def project_all(tolerance: float) -> list[poly.Polytope]:
        return [poly.project(mode.domain, range(m), tolerance=tolerance) for mode in modes]

    exact = project_all(PROJECTION_REFERENCE_TOLERANCE)
    reference = [supports(P) for P in exact]
    opposite = [-supports(poly.Polytope(-P.A, P.b, -P.A_eq, P.b_eq)) if not P.empty else r
                for P, r in zip(exact, reference, strict=True)]
    widths = [np.maximum(r - o, 1e-300) for r, o in zip(reference, opposite, strict=True)]
    points = []
    for tolerance in PROJECTION_TOLERANCES:
        seconds, times, projected = median_time(lambda tol=tolerance: project_all(tol), 3)
        errors = []
        for P, r, w in zip(projected, reference, widths, strict=True):
            s = supports(P)
            both = np.isfinite(s) & np.isfinite(r)
            if np.any(np.isfinite(s) != np.isfinite(r)):
                errors.append(1.0)
            elif np.any(both):
                errors.append(float(np.max(np.abs(s[both] - r[both]) / w[both])))
        points.append({"tolerance": tolerance, "time": seconds, "runs": len(times),
                       "error": max(errors, default=0.0),
                       "rows": int(sum(P.A.shape[0] for P in projected))})
    return {"applicable": True, "modes": [mode.mode for mode in modes], "points": points}


# ------------------------------------------------------------------------------------ pruning
def snake_with_listed_contacts(folder: Path) -> Path:
    """The snake scene with the tail, every joint and the head listed against both walls."""
    text = (shipped_robots_dir() / "scenes" / "snake_climb.toml").read_text()
    text = text.replace('robot = "snake_planar.urdf"',
                        f'robot = "{shipped_robots_dir() / "snake_planar.urdf"}"')
    touching = {("link0", "left"), ("link2", "right"), ("link4", "left")}  # tail, tip, top
    points = [(f"j{i}" if i else "tail", f"link{i}", [0.0, 0.0]) for i in range(9)]
    points.append(("head", "link8", [0.2, 0.0]))
    extra = ""
    for name, link, point in points:
        for wall, normal, surface in (("left", [1.0, 0.0], [-0.15, 0.0]),
                                      ("right", [-1.0, 0.0], [0.15, 0.0])):
            if (link, wall) in touching and point == [0.0, 0.0]:
                continue
            extra += (f'\n[[contacts]]\nname = "{name}_{wall}"\nlink = "{link}"\npoint = {point}\n'
                      f"normal = {normal}\nmu = 0.6\nsurface_point = {surface}\n")
    path = folder / "snake_listed_contacts.toml"
    path.write_text(text.replace("[inputs]", extra + "\n[inputs]"))
    return path


def pruning(folder: Path, runs: int) -> dict:
    """Time saved by modelling only the touching contacts of the snake."""
    scenario = SCENARIOS[-1]
    path = snake_with_listed_contacts(folder)
    pruned = load_scene(path)
    unpruned = load_scene(path, gap_tolerance=1.0)
    u = np.array(scenario.inputs)
    out: dict[str, Any] = {"listed_contacts": len(pruned.contacts),
                           "active_with_pruning": len(pruned.active_contacts),
                           "active_without_pruning": len(unpruned.active_contacts)}
    t_p, times_p, sol_p = median_time(lambda: solutions_at(pruned, u), max(runs, 5))
    t_u, times_u, sol_u = median_time(lambda: solutions_at(unpruned, u), max(3, runs // 2))
    out["rigid_solutions_at"] = {
        "pruned_s": t_p, "unpruned_s": t_u, "saving_factor": t_u / t_p,
        "pruned_modes": [s.mode for s in sol_p], "unpruned_modes": [s.mode for s in sol_u],
        "runs": [len(times_p), len(times_u)],
        "note": "without pruning the open contacts are modelled as touching: the answer differs "
                "(they are held) and is not the physical one"}
    t_a, times_a, _ = median_time(lambda: analyze(pruned, ambiguity=False), 3)
    out["rigid_analyze_pruned_s"] = t_a
    ref = build_reference(scenario, pruned)
    k = 1e5
    t_r = 40.0 / math.sqrt(k * ref.slowest_eigenvalue)
    config = {"stiffness": k, "integrator": "radau", "rtol": 1e-5}
    t_act, times_act, traj_act = median_time(lambda: compliant_run(ref, config, t_r, t_r, "active"), runs)
    t_all, times_all, traj_all = median_time(lambda: compliant_run(ref, config, t_r, t_r, "all"), runs)
    out["compliant_radau_k1e5"] = {
        "active_s": t_act, "all_s": t_all, "saving_factor": t_all / t_act,
        "state_size": [traj_act.info["state_size"], traj_all.info["state_size"]],
        "force_difference": float(np.max(np.abs(traj_act.contact_forces[-1] - traj_all.contact_forces[-1]))),
        "runs": [len(times_act), len(times_all)], "readout_time": t_r}
    return out


# ------------------------------------------------------------------------------------ analysis
def pareto(points: list[dict]) -> list[int]:
    """Indices of the valid points that no other valid point beats in both time and error."""
    valid = [(p["time"], max(p["error"], ERROR_FLOOR), i) for i, p in enumerate(points) if p.get("valid")]
    valid.sort()
    front, best = [], math.inf
    for _, error, i in valid:
        if error < best:
            front.append(i)
            best = error
    return front


def retime(points: list[dict], indices: list[int], rerun: Callable[[dict], dict]) -> None:
    """Replace the points at ``indices`` by their re-run (median of several runs)."""
    for i in indices:
        again = rerun(points[i])
        if again.get("valid"):
            points[i] = again


def label(point: dict) -> str:
    """A short description of a compliant configuration."""
    if point["integrator"] == "euler":
        accuracy = f"h={point['euler_fraction']:g}x limit"
    else:
        accuracy = f"rtol {point['rtol']:g}"
    window = f", window {point['window']:g}/w" if "window" in point else ""
    return f"k={point['stiffness']:.0e} {point['integrator']} {accuracy}{window}"


def plot_scene(name: str, rigid: list[dict], forces: list[dict], trajectories: list[dict],
               path: Path) -> None:
    """Force error and trajectory error against wall time, Pareto fronts marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colors = {"radau": "tab:blue", "bdf": "tab:cyan", "lsoda": "tab:purple", "rk45": "tab:orange",
              "dop853": "tab:red", "euler": "tab:brown"}
    fig, axes = plt.subplots(1, 2, figsize=(15, 5.5))
    for ax, points, title, ylabel in (
        (axes[0], forces, "force at the state: compliant readout vs rigid", "relative force error [-]"),
        (axes[1], trajectories, f"trajectory ({TRAJECTORY_DURATION:g} s) vs fine reference",
         "max link-origin error [m]"),
    ):
        for integrator, color in colors.items():
            chosen = [p for p in points if p.get("valid") and p["integrator"] == integrator]
            if chosen:
                sizes = [12 + 6 * math.log10(p["stiffness"]) for p in chosen]
                ax.scatter([p["time"] for p in chosen], [max(p["error"], ERROR_FLOOR) for p in chosen],
                           s=sizes, color=color, alpha=0.45, label=integrator, edgecolors="none")
        front = [points[i] for i in pareto(points)]
        if front:  # (compliant configurations only: the rigid answers, drawn as stars, beat them all)
            ax.step([p["time"] for p in front], [max(p["error"], ERROR_FLOOR) for p in front],
                    where="post", color="k", lw=1.2, label="Pareto front")
            ax.scatter([p["time"] for p in front], [max(p["error"], ERROR_FLOOR) for p in front],
                       s=40, facecolors="none", edgecolors="k")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time per answer [s]")
        ax.set_ylabel(ylabel)
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.2)
    ok = [p for p in rigid if p.get("valid")]
    for p in ok:
        axes[0].scatter(p["time"], max(p["error"], ERROR_FLOOR), marker="*", s=120,
                        color="k" if p["call"] == "solutions_at" else "0.5", zorder=3)
    if ok:
        axes[0].scatter([], [], marker="*", color="k", label="rigid solutions_at")
        axes[0].scatter([], [], marker="*", color="0.5", label="rigid analyze + solutions_at")
        fastest = min(p["time"] for p in ok if p["call"] == "solutions_at")
        axes[0].axvline(100 * fastest, color="g", ls=":", lw=1.0, label="100 x rigid solutions_at")
    axes[0].axhline(TARGET_FORCE_ERROR, color="r", ls="--", lw=0.8, label="target 1e-3")
    for ax in axes:
        ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
    fig.suptitle(f"{name}: error against time (marker size grows with the stiffness 1e2..1e10 N/m; "
                 f"errors below {ERROR_FLOOR:g}, e.g. the rigid answers' 0, drawn at {ERROR_FLOOR:g})",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ------------------------------------------------------------------------------------ driver
def bench_scene(scenario: Scenario, sweep: Sweep, progress: Callable[[str], None]) -> dict:
    """Every measurement of one scene."""
    scene = load_scene(scenario.name)
    ref = build_reference(scenario, scene)
    progress(f"{scenario.name}: mode {ref.mode}, d_min {ref.slowest_eigenvalue:.4g} 1/kg")
    rigid = rigid_points(ref)
    configs = force_configs(ref, sweep)
    forces = []
    for j, config in enumerate(configs):
        forces.append(force_point(ref, config))
        if j % 50 == 49:
            progress(f"  force sweep {j + 1}/{len(configs)}")
    reached = [i for i, p in enumerate(forces) if p.get("valid") and p["error"] <= TARGET_FORCE_ERROR]
    cheapest = min(reached, key=lambda i: forces[i]["time"]) if reached else None
    to_retime = set(pareto(forces)) | ({cheapest} if cheapest is not None else set())
    retime(forces, sorted(to_retime), lambda p: force_point(ref, {
        key: p[key] for key in ("stiffness", "window", "integrator", "rtol", "euler_fraction", "step")
        if key in p}, sweep.runs))
    reached = [i for i, p in enumerate(forces) if p.get("valid") and p["error"] <= TARGET_FORCE_ERROR]
    cheapest = min(reached, key=lambda i: forces[i]["time"]) if reached else None

    trajectories, references = [], {}
    for k in sweep.trajectory_stiffness:
        origins, how = trajectory_reference(ref, k)
        references[f"{k:g}"] = how
        if origins is None:
            continue
        limit = euler_limit(ref, k)
        for integrator in sweep.integrators:
            if integrator == "euler":
                levels = [{"euler_fraction": f, "step": f * limit} for f in sweep.euler_fractions]
            else:
                levels = [{"rtol": r} for r in sweep.rtols]
            for level in levels:
                config = {"stiffness": k, "integrator": integrator, **level}
                trajectories.append(trajectory_point(ref, config, origins))
        front = [i for i in pareto(trajectories) if trajectories[i]["stiffness"] == k]
        retime(trajectories, front, lambda p, origins=origins: trajectory_point(ref, {
            key: p[key] for key in ("stiffness", "integrator", "rtol", "euler_fraction", "step")
            if key in p}, origins, sweep.runs))
    progress(f"  trajectories done ({len(trajectories)} runs)")
    projection = projection_points(ref)

    rigid_state = [p for p in rigid if p.get("valid") and p["call"] == "solutions_at"]
    fastest_rigid = min(rigid_state, key=lambda p: p["time"]) if rigid_state else None
    daqp = next((p for p in rigid_state if p["solver"] == "daqp"), fastest_rigid)
    target: dict[str, Any] = {"rigid_solutions_at_daqp_s": daqp["time"] if daqp else None}
    if cheapest is not None and daqp is not None:
        target.update(compliant_s=forces[cheapest]["time"], compliant_config=label(forces[cheapest]),
                      compliant_error=forces[cheapest]["error"],
                      ratio=forces[cheapest]["time"] / daqp["time"])
    else:
        best = min((p for p in forces if p.get("valid")), key=lambda p: p["error"], default=None)
        target.update(compliant_s=None, ratio=None,
                      note="no valid compliant configuration reached the target error",
                      best_error=best["error"] if best else None,
                      best_config=label(best) if best else None,
                      best_time=best["time"] if best else None)
    return {
        "scene": scenario.name, "mode": ref.mode, "input": ref.u.tolist(),
        "reference_forces": ref.forces.tolist(), "internal_force_modes": int(ref.internal.shape[1]),
        "slowest_boundary_layer_eigenvalue": ref.slowest_eigenvalue, "stable": ref.stable,
        "rigid": rigid, "force_sweep": forces, "force_pareto": pareto(forces),
        "trajectory_sweep": trajectories, "trajectory_pareto": pareto(trajectories),
        "trajectory_references": references, "projection": projection, "target": target,
        "invalid_force_runs": sum(1 for p in forces if not p.get("valid")),
        "invalid_reasons": sorted({p["reason"].split(":")[0] for p in forces if not p.get("valid")}),
    }


def print_table(results: list[dict], pruning_result: dict) -> None:
    """The short table."""
    print()
    print(f"{'scene':16s} {'rigid [ms]':>10s} {'compliant@1e-3 [ms]':>20s} {'ratio':>8s}  "
          f"cheapest configuration reaching 1e-3")
    for r in results:
        t = r["target"]
        rigid_ms = 1e3 * t["rigid_solutions_at_daqp_s"]
        if t.get("ratio"):
            print(f"{r['scene']:16s} {rigid_ms:10.2f} {1e3 * t['compliant_s']:20.1f} {t['ratio']:8.0f}  "
                  f"{t['compliant_config']} (e_F {t['compliant_error']:.1e})")
        else:
            print(f"{r['scene']:16s} {rigid_ms:10.2f} {'not reached':>20s} {'-':>8s}  best "
                  f"{t.get('best_error', float('nan')):.1e} by {t.get('best_config')}")
    print()
    for r in results:
        front = [r["force_sweep"][i] for i in r["force_pareto"]]
        desc = "; ".join(f"{1e3 * p['time']:.0f} ms -> {p['error']:.0e} ({label(p)})" for p in front)
        print(f"{r['scene']} force Pareto front: {desc}")
    p = pruning_result
    print()
    print(f"snake pruning: {p['listed_contacts']} listed, {p['active_with_pruning']} touching. "
          f"solutions_at {1e3 * p['rigid_solutions_at']['pruned_s']:.1f} ms pruned vs "
          f"{1e3 * p['rigid_solutions_at']['unpruned_s']:.0f} ms all active "
          f"(x{p['rigid_solutions_at']['saving_factor']:.0f}); compliant "
          f"{1e3 * p['compliant_radau_k1e5']['active_s']:.0f} ms active vs "
          f"{1e3 * p['compliant_radau_k1e5']['all_s']:.0f} ms all "
          f"(x{p['compliant_radau_k1e5']['saving_factor']:.2f})")


def main() -> None:
    """Run the benchmark and write the results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer knobs and runs")
    parser.add_argument("--runs", type=int, default=None, help="runs per re-timed point (median)")
    parser.add_argument("--scenes", nargs="*", default=None, help="a subset of the scenes")
    parser.add_argument("--replot", action="store_true", help="redraw the figures from trade.json only")
    parser.add_argument("--zones", action="store_true", help="contact zones and the impact law only")
    args = parser.parse_args()
    if args.zones:
        from benchmarks import trade_zones

        trade_zones.print_table(trade_zones.run(args.quick))
        return
    if args.replot:
        for result in json.loads((RESULTS / "trade.json").read_text())["scenes"]:
            plot_scene(result["scene"], result["rigid"], result["force_sweep"], result["trajectory_sweep"],
                       RESULTS / f"trade_{result['scene']}.png")
        return
    sweep = QUICK if args.quick else FULL
    if args.runs is not None:
        sweep = Sweep(**{**sweep.__dict__, "runs": args.runs})
    RESULTS.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()

    def progress(message: str) -> None:
        print(f"[{time.perf_counter() - started:7.1f} s] {message}", flush=True)

    results: list[dict] = []
    pruning_result: dict = {}

    def payload() -> dict:
        return {
            "benchmark": "speed against accuracy: rigid mode analysis vs compliant contact",
            "command": "python -m benchmarks.trade" + (" --quick" if args.quick else ""),
            "sweep": {key: list(value) if isinstance(value, tuple) else value
                      for key, value in sweep.__dict__.items()},
            "target_force_error": TARGET_FORCE_ERROR,
            "trajectory": {"duration": TRAJECTORY_DURATION, "sample": TRAJECTORY_SAMPLE,
                           "reference_rtol": REFERENCE_RTOL},
            "projection": {"tolerances": list(PROJECTION_TOLERANCES),
                           "reference": PROJECTION_REFERENCE_TOLERANCE,
                           "directions": PROJECTION_DIRECTIONS, "seed": SEED},
            "python": platform.python_version(),
            "machine": platform.machine(),
            "processor": platform.processor() or platform.machine(),
            "wall_time_s": time.perf_counter() - started,
            "scenes": results,
            "pruning": pruning_result,
        }

    for scenario in SCENARIOS:
        if args.scenes and scenario.name not in args.scenes:
            continue
        result = bench_scene(scenario, sweep, progress)
        results.append(result)
        plot_scene(scenario.name, result["rigid"], result["force_sweep"], result["trajectory_sweep"],
                   RESULTS / f"trade_{scenario.name}.png")
        (RESULTS / "trade.json").write_text(json.dumps(payload(), indent=1, default=_jsonable) + "\n")
    with tempfile.TemporaryDirectory() as tmp:
        pruning_result.update(pruning(Path(tmp), sweep.runs))
    (RESULTS / "trade.json").write_text(json.dumps(payload(), indent=1, default=_jsonable) + "\n")
    print_table(results, pruning_result)


def _jsonable(value: Any) -> Any:
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.bool_):
        return bool(value)
    raise TypeError(f"not JSON: {type(value)}")


if __name__ == "__main__":
    main()
