"""Extreme cases of the engine, the LCP solvers, the statics and the compliant model.

Shared by ``tests/test_extremes.py`` (each case is a test) and ``benchmarks/extremes.py`` (which
regenerates ``benchmarks/extremes.md``, the table of cases, expected outcomes and what happened).

Every :class:`Case` states its expected outcome in words and runs with a scratch folder. It
returns an :class:`Outcome`: ``"pass"`` (the right answer to the stated tolerance) or ``"typed
error"`` (a :class:`~frcontrol.errors.FrcontrolError` that the case accepts, whose message names
the cause, and for :class:`~frcontrol.errors.IllConditioned` the condition number met). Anything
else, a wrong answer, a NaN or infinite value, a wrong mode or an untyped exception, is a failure:
:class:`CaseFailure` or the exception itself. A case whose failure is a known library bug carries
``known_failure``, the diagnosis (the test marks it ``xfail(strict=True)``: the fix flips it).

The groups: friction (mu from 0 to 1e8), stiffness (up to 1e12 N/m), mass ratios (RHex's legs from
1e-9 of the body's mass to exactly 0), configurations near singularity (a rod 1e-9 rad from
vertical, duplicated, nearly parallel and 1e-12 m apart contacts), many contacts (a snake lying
straight on 8 points) and scale (a rod of 1 mm and of 1 km).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from conftest import toml_text

from frcontrol.contact_lcp import all_contact_lcp_solutions, solve_contact_lcp
from frcontrol.engine import analyze, solutions_at
from frcontrol.errors import FrcontrolError, IllConditioned, InputError
from frcontrol.modes import ContactProblem
from frcontrol.scene import Scene, load_scene, shipped_robots_dir
from frcontrol.simulation.compliant import CompliantSettings, simulate_compliant
from frcontrol.stability import stability_of
from frcontrol.statics import analyze_statics

G = 9.81
"""[m/s^2] Gravity of every scene here."""

ROBOTS = shipped_robots_dir()

CLOSED_FORM_RTOL = 1e-9
"""[-] Relative tolerance against closed forms (the URDFs state inertias to 10 digits)."""

LCP_RTOL = 1e-8
"""[-] Relative tolerance of an LCP answer against the closed form (Lemke's pivots and the
Cholesky solve of M lose a few digits more than the mode solve)."""

MASS_RATIO_RTOL = 1e-6
"""[-] How close a robot with legs of a tiny mass ratio r <= 1e-9 must answer to the massless one
(its inertial forces differ by O(r), far below this)."""

PARALLEL_PAIR_LCP_ATOL = np.finfo(float).eps * 9.81 / math.sin(1e-9)
"""[m/s^2] The enumerated LCP's dv against rest for two contacts at one point whose normals are
1e-9 rad apart: condition about 1 / 1e-9 times round-off times g (about 2.2e-6); the engine's
own answer for that pair is held to 1e-9 (its balanced system is well conditioned)."""

COMPLIANT_RTOL = 1e-3
"""[-] Relative tolerance of a compliant answer against the rigid limit (finite stiffness)."""

SETTLED_VELOCITY = 1e-3
"""[m/s] A compliant body at rest has settled when its speed is below this."""

SLOPE = math.radians(20.0)
"""[rad] The box_on_slope scene's incline."""

ROD_THETA = 2.007
"""[rad] The leaning rod's angle (rod_on_table)."""

FRICTION_VALUES = (0.0, 1e-12, 1e-6, 1.0, 1e3, 1e8)
"""The friction coefficients swept."""

BEYOND_FRICTION_VALUES = (1e10,)
"""Friction coefficients past the list (the engine answered a spurious R there before the sliding
rows were scaled by mu; the LCP enumeration did before its residual bound was taken row by row)."""


# ------------------------------------------------------------------------------------ outcomes
class CaseFailure(AssertionError):
    """A case got a wrong answer (the message says what was expected and what came)."""


@dataclass(frozen=True)
class Outcome:
    """What a case returned: ``kind`` is ``"pass"`` or ``"typed error"``; ``detail`` in words."""

    kind: str
    detail: str


@dataclass(frozen=True)
class Case:
    """One extreme case.

    Attributes:
        id: a short unique name (the test id).
        group: friction, stiffness, mass ratio, singular, many contacts or scale.
        what: the situation and the parts exercised.
        expected: the right outcome, with its tolerance.
        run: ``run(folder) -> Outcome``; raises :class:`CaseFailure` on a wrong answer.
        known_failure: the diagnosis of a known library bug this case exposes (None if none).
    """

    id: str
    group: str
    what: str
    expected: str
    run: Callable[[Path], Outcome]
    known_failure: str | None = None


TYPED_ERROR_CASES = {
    "slope-statics-mu1e+08": "IllConditioned:",
    "box-euler-k1e12-refused": "InputError:",
    "rhex-radau-tight": "status failed:",
    "rhex-lcp-ratio0": "IllConditioned:",
    "rhex-lcp-ratio1e-12": "IllConditioned:",
    "rhex-lcp-ratio1e-09": "IllConditioned:",
    "rod-massless-statics": "InputError:",
    "box-nearly-parallel": "IllConditioned:",
    "snake-8-lcp": "InputError:",
}
"""The cases whose right outcome is a typed error, with how its detail starts; every other case
must pass. A case that starts passing, or fails with another error, is a change to look at."""


def check(condition: bool, message: str) -> None:
    """Raise :class:`CaseFailure` with ``message`` unless ``condition``."""
    if not condition:
        raise CaseFailure(message)


def finite(label: str, *arrays: object) -> None:
    """Every entry of every array is finite (no NaN, no infinity)."""
    for a in arrays:
        arr = np.asarray(a, dtype=float)
        check(bool(np.all(np.isfinite(arr))), f"{label}: a NaN or infinite value: {arr.tolist()}")


def close(label: str, got: object, want: object, rtol: float, atol: float = 0.0) -> None:
    """``|got - want| <= atol + rtol |want|`` entry by entry, and finite."""
    g = np.asarray(got, dtype=float)
    w = np.asarray(want, dtype=float)
    finite(label, g)
    check(g.shape == w.shape, f"{label}: shape {g.shape}, expected {w.shape}")
    bad = np.abs(g - w) > atol + rtol * np.abs(w)
    check(not np.any(bad), f"{label}: got {g.tolist()}, expected {w.tolist()} (rtol {rtol:g}, atol {atol:g})")


def typed(err: FrcontrolError, *, condition_number: bool = False) -> Outcome:
    """Accept a typed error: a non-empty message, and for IllConditioned a finite condition number
    above ``1 / tolerance`` named in the message."""
    message = str(err)
    check(bool(message.strip()), f"{type(err).__name__} without a message")
    if condition_number:
        check(isinstance(err, IllConditioned),
              f"expected IllConditioned, got {type(err).__name__}: {message}")
    if isinstance(err, IllConditioned):
        check(math.isfinite(err.condition_number) and err.condition_number * err.tolerance > 1.0,
              f"IllConditioned with condition number {err.condition_number} and tolerance {err.tolerance}")
        check("condition number" in message, f"the message does not name the condition number: {message}")
    return Outcome("typed error", f"{type(err).__name__}: {message}")


def passed(detail: str) -> Outcome:
    """A right answer."""
    return Outcome("pass", detail)


# ------------------------------------------------------------------------------------ scenes
def write_scene(folder: Path, name: str, scene: dict) -> Scene:
    """Write a scene dictionary to ``folder/name.toml`` and load it."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text(toml_text(scene))
    return load_scene(path)


def rod_urdf(folder: Path, length: float = 1.0, mass: float = 1.0) -> Path:
    """A uniform rod along x: length [m], mass [kg], I = m L^2 / 12 about its centre."""
    inertia = mass * length**2 / 12.0
    path = folder / f"rod_{length:g}_{mass:g}.urdf"
    folder.mkdir(parents=True, exist_ok=True)
    path.write_text(
        f'<?xml version="1.0"?>\n<robot name="rod"><link name="rod"><inertial>'
        f'<origin xyz="0 0 0" rpy="0 0 0"/><mass value="{mass!r}"/>'
        f'<inertia ixx="{1e-6 * inertia!r}" ixy="0" ixz="0" iyy="{inertia!r}" iyz="0" izz="{inertia!r}"/>'
        f"</inertial></link></robot>\n")
    return path


def rod(folder: Path, name: str, *, theta: float = ROD_THETA, mu: float = 1.4, length: float = 1.0,
        mass: float = 1.0) -> Scene:
    """A uniform rod at rest with its lower end (-L/2, 0) on the ground y = 0 at angle theta."""
    urdf = rod_urdf(folder, length, mass)
    return write_scene(folder, name, {
        "name": name, "robot": str(urdf), "base": "planar", "gravity": G,
        "state": {"q": [0.0, 0.5 * length * math.sin(theta), theta], "v": [0.0, 0.0, 0.0]},
        "contacts": [{"name": "tip", "link": "rod", "point": [-0.5 * length, 0.0], "normal": [0.0, 1.0],
                      "mu": mu, "surface_point": [0.0, 0.0]}],
        "inputs": {"coordinates": ["x", "y", "theta"], "lower": [-50.0, -50.0, -50.0 * length],
                   "upper": [50.0, 50.0, 50.0 * length]},
    })


def rod_at_rest(mu: float, theta: float = ROD_THETA) -> tuple[str, np.ndarray, float, float]:
    """The closed form of the unit rod (1 m, 1 kg, I = 1/12) released at rest on its lower end.

    With c = cos(theta), s = sin(theta): J_N = [0, 1, -c/2], J_T = [1, 0, s/2] and
    J M^-1 J^T = [[1 + 3c^2, -3cs], [-3cs, 1 + 3s^2]] (determinant 4), J M^-1 (-h) = [-g, 0].

    - F (sticks) iff mu >= 3|cs| / (1 + 3s^2): lam_N = g (1 + 3s^2)/4, lam_T = 3 c s g / 4;
    - else R (the tip slides toward +x, for c < 0): lam_N = g / (1 + 3c^2 + 3 mu c s),
      lam_T = -mu lam_N.

    dv = (lam_T, lam_N - g, 6 (-c lam_N + s lam_T)). Returns (mode, dv, lam_N, lam_T).
    """
    c, s = math.cos(theta), math.sin(theta)
    if mu >= 3.0 * abs(c * s) / (1.0 + 3.0 * s * s):
        mode, lam_n, lam_t = "F", G * (1.0 + 3.0 * s * s) / 4.0, 3.0 * c * s * G / 4.0
    else:
        mode = "R"
        lam_n = G / (1.0 + 3.0 * c * c + 3.0 * mu * c * s)
        lam_t = -mu * lam_n
    return mode, np.array([lam_t, lam_n - G, 6.0 * (-c * lam_n + s * lam_t)]), lam_n, lam_t


def slope_box(folder: Path, name: str, mu: float) -> Scene:
    """The shipped box_on_slope scene with both contacts' mu replaced."""
    text = (ROBOTS / "scenes" / "box_on_slope.toml").read_text()
    text = text.replace('robot = "box.urdf"', f'robot = "{ROBOTS / "box.urdf"}"')
    text = text.replace("mu = 0.5", f"mu = {float(mu)!r}")
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text(text)
    return load_scene(path)


def box(folder: Path, name: str, contacts: Sequence[dict]) -> Scene:
    """The 1 m x 0.5 m, 1 kg box resting flat on the ground (centre 0.25 m up) with these contacts."""
    return write_scene(folder, name, {
        "name": name, "robot": str(ROBOTS / "box.urdf"), "base": "planar",
        "state": {"q": [0.0, 0.25, 0.0]}, "contacts": list(contacts),
        "inputs": {"coordinates": ["x", "y", "theta"], "lower": [-20.0, -20.0, -5.0],
                   "upper": [20.0, 20.0, 5.0]},
    })


def corner(name: str, point: Sequence[float], normal: Sequence[float] = (0.0, 1.0), mu: float = 0.5) -> dict:
    """A contact of the box against a line through the origin."""
    return {"name": name, "link": "box", "point": list(point), "normal": list(normal), "mu": mu,
            "surface_point": [0.0, 0.0]}


RHEX_STATIC_INPUT = np.array([-1.0, -3.84])
"""[N m] Hip torques at which RHex (rhex_flip) rests in mode FFF (a Chebyshev centre, rounded)."""

RHEX_MOVING_INPUT = np.array([-8.08, -6.34])
"""[N m] Hip torques at which RHex pitches up in mode RFL (a Chebyshev centre, rounded)."""


def rhex(folder: Path, ratio: float) -> Scene:
    """The rhex_flip scene with legs of ``ratio`` times the body's 7.5 kg (0: the shipped model).

    A leg of mass m is a uniform 0.17 m bar: I = m 0.17^2 / 12 [kg m^2] about its origin's axis.
    """
    folder.mkdir(parents=True, exist_ok=True)
    mass = 7.5 * ratio
    inertia = mass * 0.17**2 / 12.0
    urdf = (ROBOTS / "rhex_planar.urdf").read_text()
    urdf = urdf.replace('<mass value="0.0"/>', f'<mass value="{mass!r}"/>').replace(
        '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>',
        f'<inertia ixx="{inertia!r}" ixy="0" ixz="0" iyy="{inertia!r}" iyz="0" izz="{inertia!r}"/>')
    urdf_path = folder / f"rhex_{ratio:g}.urdf"
    urdf_path.write_text(urdf)
    text = (ROBOTS / "scenes" / "rhex_flip.toml").read_text()
    text = text.replace('robot = "rhex_planar.urdf"', f'robot = "{urdf_path}"')
    path = folder / f"rhex_{ratio:g}.toml"
    path.write_text(text)
    return load_scene(path)


def snake_lying(folder: Path) -> Scene:
    """The snake lying straight along the ground (q = 0), touching at its 8 link origins."""
    return write_scene(folder, "snake_lying", {
        "name": "snake lying straight", "robot": str(ROBOTS / "snake_planar.urdf"), "base": "planar",
        "state": {"q": [0.0] * 11},
        "contacts": [{"name": f"c{i}", "link": f"link{i}", "point": [0.0, 0.0], "normal": [0.0, 1.0],
                      "mu": 0.6, "surface_point": [0.0, 0.0]} for i in range(8)],
        "inputs": {"coordinates": [f"j{i}" for i in range(1, 9)], "lower": [-20.0] * 8, "upper": [20.0] * 8},
    })


def one_solution(scene: Scene | ContactProblem, u: np.ndarray, mode: str):
    """``solutions_at`` must give exactly one solution, in ``mode``; return it."""
    solutions = solutions_at(scene, u)
    check([s.mode for s in solutions] == [mode],
          f"expected the single solution {mode}, got {[s.mode for s in solutions]}")
    s = solutions[0]
    finite("solution", s.dv, s.lambda_n, s.lambda_t, s.a_n, s.a_t)
    return s


def lcp_x(problem: ContactProblem, u: np.ndarray, method: str = "lemke"):
    """Lemke's (or the first enumerated) solution, read back; a failure to find one is a failure."""
    result = solve_contact_lcp(problem, u, method=method)
    check(hasattr(result, "x"), f"the LCP found no solution: status {getattr(result, 'status', '?')}")
    finite("LCP solution", result.x)
    return result


# ------------------------------------------------------------------------------------ friction
def _rod_engine(mu: float) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        scene = rod(folder, "rod", mu=mu)
        mode, dv, lam_n, lam_t = rod_at_rest(mu)
        s = one_solution(scene, np.zeros(3), mode)
        close("dv", s.dv, dv, CLOSED_FORM_RTOL, 1e-9)
        close("lambda", [s.lambda_n[0], s.lambda_t[0]], [lam_n, lam_t], CLOSED_FORM_RTOL, 1e-9)
        analysis = analyze(scene)
        check(mode in [m.mode for m in analysis.feasible_modes], f"analyze: mode {mode} not feasible")
        again = solutions_at(analysis, np.zeros(3))
        check([x.mode for x in again] == [mode], f"solutions_at(analysis): {[x.mode for x in again]}")
        return passed(f"{mode}: lam_N = {s.lambda_n[0]:.10g} N, lam_T = {s.lambda_t[0]:.4g} N")
    return run


def _rod_lcp(mu: float) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        scene = rod(folder, "rod", mu=mu)
        problem = ContactProblem.from_scene(scene)
        mode, dv, lam_n, lam_t = rod_at_rest(mu)
        want = np.concatenate([dv, [lam_n, lam_t]])
        lemke = lcp_x(problem, np.zeros(3))
        check(lemke.mode == mode, f"Lemke: mode {lemke.mode}, expected {mode}")
        close("Lemke x", lemke.x, want, LCP_RTOL, 1e-9)
        every = all_contact_lcp_solutions(problem, np.zeros(3))
        check(len(every) == 1, f"enumeration: {len(every)} solutions, expected the one of the closed form")
        for sol in every:
            check(sol.mode == mode, f"enumeration lists a solution in mode {sol.mode} (expected only "
                  f"{mode}): x = {sol.x.tolist()}")
            close("enumerated x", sol.x, want, LCP_RTOL, 1e-9)
        return passed(f"Lemke and {len(every)} enumerated solution(s): {mode}, x to {LCP_RTOL:g}")
    return run


def _slope_statics(mu: float) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        scene = slope_box(folder, "slope", mu)
        try:
            report = analyze_statics(scene)
        except IllConditioned as err:
            return typed(err, condition_number=True)
        eq = report.equilibrium
        holds = mu >= math.tan(SLOPE)
        check(eq.exists == holds, f"equilibrium {eq.exists}, expected {holds} (mu vs tan 20 deg)")
        check(report.weakly_stable == holds, f"weakly stable {report.weakly_stable}, expected {holds}")
        check(not report.form_closure.closed and not report.force_closure.closed,
              "closure on 2 coplanar corners")
        if holds:
            close("sum of lam_N", eq.lambda_n.sum(), G * math.cos(SLOPE), CLOSED_FORM_RTOL)
            close("sum of lam_T", eq.lambda_t.sum(), G * math.sin(SLOPE), CLOSED_FORM_RTOL)
            check(report.strongly_stable is True, "a sticking box at rest is strongly stable")
            return passed("equilibrium: sum lam_N = m g cos a, sum lam_T = m g sin a; "
                          f"dimension {eq.dimension}")
        finite("residual", eq.residual)
        check(eq.residual > 0, "no equilibrium but zero residual")
        return passed(f"no equilibrium (residual wrench {eq.residual:.4g} N)")
    return run


def _slope_compliant(mu: float) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        scene = slope_box(folder, "slope", mu)
        duration = 0.2
        traj = simulate_compliant(scene, None, duration, 0.01)
        check(traj.completed, f"status {traj.status}: {traj.failure}")
        finite("trajectory", traj.q, traj.v, traj.contact_forces)
        up = np.array([math.cos(SLOPE), math.sin(SLOPE)])
        along = float(traj.v[-1, :2] @ up)
        total = traj.contact_forces[-1].sum(axis=0)
        close("sum of lam_N", total[0], G * math.cos(SLOPE), COMPLIANT_RTOL)
        if mu < math.tan(SLOPE):
            accel = -G * (math.sin(SLOPE) - mu * math.cos(SLOPE))
            close("acceleration along the slope", along / duration, accel, COMPLIANT_RTOL)
            return passed(f"slides at {along / duration:.6g} m/s^2 (g (sin a - mu cos a) = {accel:.6g})")
        check(abs(along) < SETTLED_VELOCITY, f"sticks: speed along the slope {along:.3g} m/s")
        close("sum of lam_T", total[1], G * math.sin(SLOPE), COMPLIANT_RTOL)
        return passed(f"sticks: speed {abs(along):.2g} m/s, forces m g (cos a, sin a)")
    return run




def friction_cases() -> list[Case]:
    """mu in {0, 1e-12, 1e-6, 1, 1e3, 1e8}: the engine, the LCP solvers, statics, compliant; and
    mu = 1e10 (engine and LCP), past the list."""
    cases = []
    mu_star = 3.0 * abs(math.cos(ROD_THETA) * math.sin(ROD_THETA)) / (1.0 + 3.0 * math.sin(ROD_THETA) ** 2)
    for mu in FRICTION_VALUES:
        mode = rod_at_rest(mu)[0]
        tag = f"mu{mu:g}"
        cases.append(Case(
            f"rod-engine-{tag}", "friction",
            f"leaning rod (theta = 2.007) released at rest, mu = {mu:g}: solutions_at, analyze",
            f"one solution, {mode} (mu {'>=' if mode == 'F' else '<'} {mu_star:.4f}), dv and forces = the "
            f"closed form to {CLOSED_FORM_RTOL:g}", _rod_engine(mu)))
        cases.append(Case(
            f"rod-lcp-{tag}", "friction",
            f"the same rod, mu = {mu:g}: contact LCP by Lemke and by enumeration",
            f"every LCP solution is the closed form ({mode}) to {LCP_RTOL:g}", _rod_lcp(mu)))
        holds = mu >= math.tan(SLOPE)
        cases.append(Case(
            f"slope-statics-{tag}", "friction",
            f"box on the 20 deg slope, mu = {mu:g}: analyze_statics",
            ("equilibrium with sum lam = m g (cos a, sin a), strongly stable" if holds else
             "no equilibrium, positive residual") + "; or IllConditioned naming the condition number "
            "(mu = 1e8 makes the sliding modes' systems singular as mu -> infinity)", _slope_statics(mu)))
        cases.append(Case(
            f"slope-compliant-{tag}", "friction",
            f"box on the 20 deg slope, mu = {mu:g}: compliant model (radau, k = 1e5), 0.2 s",
            ("sticks: speed < 1e-3 m/s, forces m g (cos a, sin a) to 1e-3" if holds else
             "slides at g (sin a - mu cos a) to 1e-3"), _slope_compliant(mu)))
    for mu in BEYOND_FRICTION_VALUES:
        cases.append(Case(
            f"rod-engine-mu{mu:g}", "friction",
            f"beyond the list: the leaning rod at rest, mu = {mu:g}: solutions_at, analyze",
            "one solution, F, the closed form", _rod_engine(mu)))
        cases.append(Case(
            f"rod-lcp-mu{mu:g}", "friction",
            f"beyond the list: the same rod, mu = {mu:g}: contact LCP by Lemke and by enumeration",
            "every LCP solution is the closed form (F)", _rod_lcp(mu)))
    return cases


# ------------------------------------------------------------------------------------ stiffness
def _resting_box_compliant(stiffness: float, integrator: str) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        scene = load_scene("box_on_ground")
        traj = simulate_compliant(scene, None, 0.05, 0.01,
                                  settings=CompliantSettings(stiffness=stiffness, integrator=integrator))
        status = traj.status
        finite("trajectory", traj.q, traj.v, traj.contact_forces)
        if status != "completed":
            reason = traj.failure.reason if traj.failure else ""
            check(bool(reason), "failed without a reason")
            return Outcome("typed error", f"status failed: {reason}")
        close("lam_N", traj.contact_forces[-1, :, 0], [G / 2, G / 2], COMPLIANT_RTOL)
        check(float(np.max(np.abs(traj.v[-1]))) < SETTLED_VELOCITY, f"not at rest: v = {traj.v[-1].tolist()}")
        return passed(f"lam_N = {traj.contact_forces[-1, 0, 0]:.7g} N each, {traj.info['steps']} steps")
    return run


def _euler_refused(folder: Path) -> Outcome:
    scene = load_scene("box_on_ground")
    try:
        simulate_compliant(scene, None, 0.01, 1e-4,
                           settings=CompliantSettings(stiffness=1e12, integrator="euler"))
    except InputError as err:
        check("stability limit" in str(err), f"the message does not name the stability limit: {err}")
        return typed(err)
    raise CaseFailure("euler with dt = 1e-4 s at k = 1e12 N/m ran (its limit is ~1e-6 s)")


def _euler_near_limit(folder: Path) -> Outcome:
    scene = load_scene("box_on_ground")
    probe = simulate_compliant(scene, None, 1e-3, 1e-3, settings=CompliantSettings(stiffness=1e6))
    limit = probe.info["explicit_stability_limit"]
    try:
        traj = simulate_compliant(scene, None, 0.2, 0.9 * limit,
                                  settings=CompliantSettings(stiffness=1e6, integrator="euler"))
    except InputError as err:
        return typed(err)
    finite("trajectory", traj.q, traj.v, traj.contact_forces)
    close("lam_N after 0.2 s", traj.contact_forces[-1, :, 0], [G / 2, G / 2], COMPLIANT_RTOL)
    return passed("settled")


def _radau_tight(folder: Path) -> Outcome:
    scene = load_scene("rhex_flip")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        traj = simulate_compliant(scene, RHEX_MOVING_INPUT, 0.0034, 0.0034,
                                  settings=CompliantSettings(stiffness=1e8, rtol=1e-7, atol=3e-14))
    finite("trajectory", traj.q, traj.v)
    if not traj.completed:
        return Outcome("typed error", f"status {traj.status}: {traj.failure.reason}")
    return passed(f"completed in {traj.info['steps']} steps")


def _boundary_layer_1e12(folder: Path) -> Outcome:
    scene = load_scene("box_on_ground")
    problem = ContactProblem.from_scene(scene)
    stick = next(s for s in solutions_at(problem, np.zeros(3)) if s.mode == "FF")
    k = 1e12
    verdict = stability_of(problem, stick, stiffness=k, damping=2.0 * math.sqrt(k * 0.25))
    check(verdict.stable is True, f"verdict {verdict.stable}: {verdict.reason}")
    finite("roots", verdict.boundary_layer_roots.real, verdict.boundary_layer_roots.imag)
    check(bool(np.all(verdict.boundary_layer_roots.real < 0)), "a root in the right half-plane")
    return passed(f"stable; fastest root {np.min(verdict.boundary_layer_roots.real):.3g} 1/s")


def stiffness_cases() -> list[Case]:
    """The compliant model from 1e8 to 1e12 N/m, the explicit limit, the boundary layer."""
    cases = []
    for k, integrator in ((1e8, "radau"), (1e10, "radau"), (1e12, "radau"), (1e12, "bdf")):
        cases.append(Case(
            f"box-rest-{integrator}-k{k:.0e}", "stiffness",
            f"box resting on the ground, compliant {integrator}, k = {k:.0e} N/m (penetration "
            f"{G / 2 / k:.1e} m), 0.05 s",
            "lam_N = m g / 2 each to 1e-3 and at rest, or status failed with a reason; no NaN",
            _resting_box_compliant(k, integrator)))
    cases.append(Case(
        "box-euler-k1e12-refused", "stiffness",
        "explicit euler with dt = 1e-4 s at k = 1e12 N/m (limit ~1e-6 s)",
        "InputError naming the stability limit", _euler_refused))
    cases.append(Case(
        "box-euler-near-limit", "stiffness",
        "explicit euler at 0.9 x the reported stability limit (k = 1e6 N/m), resting box, 0.2 s",
        "settles at lam_N = m g / 2 (to 1e-3), or InputError: dt above the true limit",
        _euler_near_limit))
    cases.append(Case(
        "rhex-radau-tight", "stiffness",
        "RHex pitching up (RFL input), compliant radau at k = 1e8 N/m, rtol 1e-7, atol 3e-14",
        "completes, or status failed with a reason; never an untyped exception",
        _radau_tight))
    cases.append(Case(
        "box-boundary-layer-k1e12", "stiffness",
        "stability of the resting box's FF at k = 1e12 N/m, critical damping",
        "stable, finite roots with negative real parts", _boundary_layer_1e12))
    return cases


# ------------------------------------------------------------------------------------ mass ratio
def _rhex_engine(ratio: float) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        massless = rhex(folder / "zero", 0.0)
        light = rhex(folder / "light", ratio)
        try:
            details = []
            for u, mode, rtol in ((RHEX_STATIC_INPUT, "FFF", MASS_RATIO_RTOL),
                                  (RHEX_MOVING_INPUT, "RFL", MASS_RATIO_RTOL)):
                want = one_solution(massless, u, mode)
                got = one_solution(light, u, mode)
                close(f"{mode} dv", got.dv, want.dv, rtol, 1e-9)
                if want.ambiguous_outputs == "none":
                    close(f"{mode} lam_N", got.lambda_n, want.lambda_n, rtol, 1e-9)
                else:  # statically indeterminate: the total force is determined
                    close(f"{mode} total lam_N", got.lambda_n.sum(), want.lambda_n.sum(), rtol)
                details.append(mode)
            analysis = analyze(light, ambiguity=False)
            for mode in ("FFF", "RFL"):
                check(mode in [m.mode for m in analysis.feasible_modes], f"analyze: {mode} not feasible")
        except IllConditioned as err:
            return typed(err, condition_number=True)
        return passed(f"{' and '.join(details)} as the massless legs' to {MASS_RATIO_RTOL:g}")
    return run


def _rhex_lcp(ratio: float) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        scene = rhex(folder, ratio)
        problem = ContactProblem.from_scene(scene)
        try:
            result = lcp_x(problem, RHEX_MOVING_INPUT)
        except IllConditioned as err:
            return typed(err, condition_number=True)
        want = one_solution(problem, RHEX_MOVING_INPUT, "RFL")
        check(result.mode == "RFL", f"Lemke's solution is labelled {result.mode}, the engine's is RFL "
              f"(dv {result.x[:problem.n].tolist()} vs {want.dv.tolist()})")
        close("Lemke dv", result.x[:problem.n], want.dv, LCP_RTOL, 1e-9)
        return passed("Lemke: RFL, dv as the engine's")
    return run


def _rhex_compliant(ratio: float) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        scene = rhex(folder, ratio)
        # RHex's compliant model has a slow, overdamped mode (about 0.06 of its slowest boundary-layer
        # frequency at the default stiffness): 0.5 s to settle to 1e-3
        traj = simulate_compliant(scene, RHEX_STATIC_INPUT, 0.5, 0.25)
        finite("trajectory", traj.q, traj.v, traj.contact_forces)
        check(traj.completed, f"status {traj.status}: {traj.failure}")
        total = traj.contact_forces[-1, :, 0].sum()
        close("total normal force", total, 7.5 * (1.0 + 3.0 * ratio) * G, COMPLIANT_RTOL)
        check(float(np.max(np.abs(traj.v[-1, :3]))) < SETTLED_VELOCITY,
              f"body not at rest: {traj.v[-1].tolist()}")
        return passed(f"rests on total lam_N = {total:.6g} N; armature on "
                      f"{traj.info['armature']['coordinates']}")
    return run


def _rhex_statics(ratio: float) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        scene = rhex(folder, ratio)
        try:
            report = analyze_statics(scene, RHEX_STATIC_INPUT)
        except IllConditioned as err:
            return typed(err, condition_number=True)
        eq = report.equilibrium
        check(eq.exists, "the locked robot on three points below its centre of mass is in equilibrium")
        close("sum lam_N", eq.lambda_n.sum(), 7.5 * (1.0 + 3.0 * ratio) * G, CLOSED_FORM_RTOL)
        check(report.weakly_stable, "the FFF input holds the robot at rest: weakly stable")
        return passed(f"equilibrium, weakly stable; strongly stable: {report.strongly_stable}")
    return run


def _massless_rod(folder: Path) -> Outcome:
    scene = rod(folder, "massless_rod", mass=0.0)
    try:
        report = analyze_statics(scene)
    except InputError as err:
        check("mass" in str(err), f"the message does not name the missing mass: {err}")
        return typed(err)
    raise CaseFailure(f"statics of a massless robot answered: equilibrium {report.equilibrium.exists}")


def mass_ratio_cases() -> list[Case]:
    """RHex's legs at 0, 1e-12 and 1e-9 of the body's mass; a massless robot."""
    cases = []
    for ratio in (1e-12, 1e-9):
        cases.append(Case(
            f"rhex-engine-ratio{ratio:g}", "mass ratio",
            f"RHex with legs of {ratio:g} x the body's mass: solutions_at at the FFF and RFL inputs, analyze",
            f"the massless legs' answers to {MASS_RATIO_RTOL:g}, or IllConditioned naming the condition "
            "number",
            _rhex_engine(ratio)))
    for ratio in (0.0, 1e-12, 1e-9):
        cases.append(Case(
            f"rhex-lcp-ratio{ratio:g}", "mass ratio",
            f"RHex with legs of {ratio:g} x the body's mass: contact LCP (Lemke) at the RFL input",
            "the engine's RFL solution, or IllConditioned naming the condition number (M not positive "
            "definite)",
            _rhex_lcp(ratio)))
    for ratio in (0.0, 1e-9):
        cases.append(Case(
            f"rhex-compliant-ratio{ratio:g}", "mass ratio",
            f"RHex with legs of {ratio:g} x the body's mass, compliant radau at the FFF input, 0.5 s",
            "rests; total lam_N = total weight to 1e-3 (armature on the near-massless legs)",
            _rhex_compliant(ratio)))
        cases.append(Case(
            f"rhex-statics-ratio{ratio:g}", "mass ratio",
            f"RHex with legs of {ratio:g} x the body's mass: analyze_statics at the FFF input",
            "equilibrium with sum lam_N = weight, weakly stable; or IllConditioned",
            _rhex_statics(ratio)))
    cases.append(Case(
        "rod-massless-statics", "mass ratio", "a rod of mass exactly 0: analyze_statics",
        "InputError: the robot has no mass", _massless_rod))
    return cases


# ------------------------------------------------------------------------------------ singular
def _vertical_rod(offset: float) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        theta = math.pi / 2 + offset
        scene = rod(folder, "vertical", theta=theta, mu=0.5)
        mode, dv, lam_n, lam_t = rod_at_rest(0.5, theta)
        s = one_solution(scene, np.zeros(3), "F")
        close("lam_N", s.lambda_n, [G], CLOSED_FORM_RTOL)
        close("lam_T", s.lambda_t, [lam_t], 0.0, 1e-12)
        close("dv", s.dv, dv, 0.0, 1e-9)
        lemke = lcp_x(ContactProblem.from_scene(scene), np.zeros(3))
        close("Lemke x", lemke.x, np.concatenate([dv, [lam_n, lam_t]]), LCP_RTOL, 1e-9)
        report = analyze_statics(scene)
        check(report.equilibrium.exists, "a vertical rod on its tip balances (within the tolerance)")
        close("statics lam_N", report.equilibrium.lambda_n, [G], CLOSED_FORM_RTOL)
        traj = simulate_compliant(scene, None, 0.05, 0.01)
        finite("trajectory", traj.q, traj.v, traj.contact_forces)
        close("compliant lam_N", traj.contact_forces[-1, 0, 0], G, COMPLIANT_RTOL)
        return passed(f"F, lam_N = m g, lam_T = {s.lambda_t[0]:.3g} N (3 cs g / 4 = {lam_t:.3g}); "
                      "LCP, statics, compliant agree")
    return run


def _box_pair(kind: str) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        second = {
            "duplicate": corner("left_b", (-0.5, -0.25)),
            "apart": corner("left_b", (-0.5 + 1e-12, -0.25)),
            "parallel": corner("left_b", (-0.5, -0.25), (math.sin(1e-9), math.cos(1e-9))),
        }[kind]
        scene = box(folder, kind, [corner("left_a", (-0.5, -0.25)), second, corner("right", (0.5, -0.25))])
        problem = ContactProblem.from_scene(scene)
        try:
            details = []
            for u in (np.zeros(3), np.array([4.0, 0.0, 0.0])):
                solutions = solutions_at(problem, u)
                check(bool(solutions), f"no solution at u = {u.tolist()}")
                # the single corner's answer: the box at rest, lam_N = m g / 2 -+ u_x h / 1 m
                # (the push at the centre, 0.25 m above the ground, tips the load to the right)
                left = G / 2 - u[0] * 0.25
                for s in solutions:
                    finite("solution", s.dv, s.lambda_n, s.lambda_t)
                    close("dv", s.dv, np.zeros(3), 0.0, 1e-9)
                    close("left pair lam_N", s.lambda_n[0] + s.lambda_n[1], left, 1e-7, 1e-9)
                    close("right lam_N", s.lambda_n[2], G - left, 1e-7, 1e-9)
                details.append(f"{len(solutions)} solution(s) {sorted({s.mode for s in solutions})}")
            report = analyze_statics(scene)
        except IllConditioned as err:
            return typed(err, condition_number=True)
        check(report.equilibrium.exists and report.equilibrium.statically_indeterminate,
              "resting on duplicated points: equilibrium, statically indeterminate")
        lemke = lcp_x(problem, np.zeros(3))
        close("Lemke dv", lemke.x[:3], np.zeros(3), 0.0, 1e-9)
        every = all_contact_lcp_solutions(problem, np.zeros(3))
        for sol in every:
            atol = PARALLEL_PAIR_LCP_ATOL if kind == "parallel" else 1e-9
            close("enumerated dv", sol.x[:3], np.zeros(3), 0.0, atol)
            close("enumerated left pair", sol.x[3] + sol.x[4], G / 2, 1e-7, 1e-9)
        traj = simulate_compliant(scene, None, 0.1, 0.05)
        finite("trajectory", traj.q, traj.v, traj.contact_forces)
        forces = traj.contact_forces[-1, :, 0]
        close("compliant left pair", forces[0] + forces[1], G / 2, COMPLIANT_RTOL)
        return passed("; ".join(details) + f"; LCP: {len(every)} enumerated, all at rest; statics and "
                      "compliant share the load")
    return run


def singular_cases() -> list[Case]:
    """Near-singular configurations."""
    return [
        Case("rod-vertical", "singular", "rod standing exactly vertical on its tip (theta = pi/2)",
             "F with lam_N = m g, lam_T = 0 (engine, LCP, statics, compliant to 1e-3)", _vertical_rod(0.0)),
        Case("rod-vertical-1e-9", "singular", "rod 1e-9 rad from vertical on its tip",
             "F with lam_N = m g, lam_T = 3 c s g / 4 ~ 7e-9 N (engine, LCP, statics, compliant)",
             _vertical_rod(1e-9)),
        Case("box-duplicate-contact", "singular", "resting box with its left corner listed twice",
             "at rest; the pair carries what the corner alone would (engine, LCP, statics, compliant)",
             _box_pair("duplicate")),
        Case("box-contacts-1e-12-apart", "singular", "resting box with two left contacts 1e-12 m apart",
             "as the duplicate (at mu <= BALANCING_FRICTION the first scaling decides: one point)",
             _box_pair("apart")),
        Case("box-nearly-parallel", "singular",
             "resting box with two left contacts at one point, normals 1e-9 rad apart",
             "as the duplicate, or IllConditioned naming the condition number", _box_pair("parallel")),
    ]


# ------------------------------------------------------------------------------------ many contacts
def _snake_engine(folder: Path) -> Outcome:
    scene = snake_lying(folder)
    u = np.zeros(8)
    s = one_solution(scene, u, "F" * 8)
    # every point mass on a contact rests on it (0.2 kg each); the two beyond the last contact
    # (j8 at 1.6 m, the head at 1.8 m) fall freely: j7 turns at -g / 0.2, j8 keeps link8 level
    dv = np.zeros(11)
    dv[9], dv[10] = -G / 0.2, G / 0.2
    close("dv", s.dv, dv, CLOSED_FORM_RTOL, 1e-9)
    close("lam_N", s.lambda_n, np.full(8, 0.2 * G), CLOSED_FORM_RTOL, 1e-9)
    close("sum lam_T", s.lambda_t.sum(), 0.0, 0.0, 1e-9)
    analysis = analyze(scene, ambiguity=False)
    check("F" * 8 in [m.mode for m in analysis.feasible_modes], "analyze: FFFFFFFF not feasible")
    check([x.mode for x in solutions_at(analysis, u)] == ["F" * 8], "solutions_at(analysis) differs")
    return passed(f"FFFFFFFF, lam_N = 0.2 g each; analyze: {analysis.enumeration.feasible} feasible of "
                  f"{analysis.enumeration.total} modes ({analysis.enumeration.evaluated} evaluated)")


def _snake_lcp(folder: Path) -> Outcome:
    scene = snake_lying(folder)
    problem = ContactProblem.from_scene(scene)
    lemke = lcp_x(problem, np.zeros(8))
    dv = np.zeros(11)
    dv[9], dv[10] = -G / 0.2, G / 0.2
    close("Lemke dv", lemke.x[:11], dv, LCP_RTOL, 1e-9)
    close("Lemke lam_N", lemke.x[11:19], np.full(8, 0.2 * G), LCP_RTOL, 1e-9)
    check(lemke.mode == "F" * 8, f"Lemke mode {lemke.mode}")
    try:
        all_contact_lcp_solutions(problem, np.zeros(8))
    except InputError as err:
        check("too large" in str(err), f"the refusal does not say the problem is too large: {err}")
        return typed(err)
    return passed("Lemke FFFFFFFF; enumeration ran")


def _snake_statics(folder: Path) -> Outcome:
    scene = snake_lying(folder)
    report = analyze_statics(scene, strong=False)
    eq = report.equilibrium
    check(eq.exists, "the locked snake (centre of mass at 0.9 m, supports 0 .. 1.4 m) balances")
    close("sum lam_N", eq.lambda_n.sum(), 2.0 * G, CLOSED_FORM_RTOL)
    check(eq.statically_indeterminate, "8 collinear supports of one locked body are indeterminate")
    check(not report.weakly_stable, "with zero torques the last two links fall: not weakly stable")
    return passed(f"locked body in equilibrium (dimension {eq.dimension}); not weakly stable at u = 0")


def _snake_compliant(folder: Path) -> Outcome:
    scene = snake_lying(folder)
    traj = simulate_compliant(scene, None, 0.01, 0.01)
    finite("trajectory", traj.q, traj.v, traj.contact_forces)
    check(traj.completed, f"status {traj.status}")
    close("lam_N of the first 7 contacts", traj.contact_forces[-1, :7, 0], np.full(7, 0.2 * G), 0.05)
    return passed(f"8 springs carry ~0.2 g each after 0.01 s ({traj.info['steps']} steps)")


def many_contact_cases() -> list[Case]:
    """The snake lying straight on 8 points."""
    return [
        Case("snake-8-engine", "many contacts",
             "snake lying straight on 8 contacts, zero torques: solutions_at and analyze (4^8 modes)",
             "one solution FFFFFFFF: lam_N = 0.2 g at each contact, the last two masses in free fall",
             _snake_engine),
        Case("snake-8-lcp", "many contacts", "the same: contact LCP (Lemke, size 32), and enumeration",
             "Lemke gives the same solution; enumeration (2^32 supports) refused with InputError",
             _snake_lcp),
        Case("snake-8-statics", "many contacts", "the same: analyze_statics (no strong stability)",
             "locked-body equilibrium with sum lam_N = m g, indeterminate; not weakly stable",
             _snake_statics),
        Case("snake-8-compliant", "many contacts", "the same: compliant radau, 0.01 s",
             "completes; the first 7 springs carry 0.2 g each to 5 % (still settling)", _snake_compliant),
    ]


# ------------------------------------------------------------------------------------ scale
SCALE_INPUT_SEED = 3
"""Seed of the random inputs of the scale cases."""


def _scaled_rod(length: float) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        unit = rod(folder / "unit", "rod_1m", length=1.0)
        scaled = rod(folder / "scaled", f"rod_{length:g}m", length=length)
        rng = np.random.default_rng(SCALE_INPUT_SEED)
        stretch = np.array([1.0, 1.0, length])  # torques scale with L, angular accelerations with 1/L
        modes_seen = set()
        for _ in range(6):
            u = rng.uniform(-20.0, 20.0, 3)
            want = {s.mode: s for s in solutions_at(unit, u)}
            got = {s.mode: s for s in solutions_at(scaled, u * stretch)}
            check(set(got) == set(want),
                  f"u = {u.tolist()}: modes {sorted(got)} vs the 1 m rod's {sorted(want)}")
            for mode, s in got.items():
                close(f"{mode} dv (angular x L)", s.dv * stretch, want[mode].dv, 1e-9, 1e-9)
                close(f"{mode} forces", [s.lambda_n[0], s.lambda_t[0]],
                      [want[mode].lambda_n[0], want[mode].lambda_t[0]], 1e-9, 1e-9)
            modes_seen |= set(got)
        a_unit, a_scaled = analyze(unit), analyze(scaled)
        check([m.mode for m in a_scaled.feasible_modes] == [m.mode for m in a_unit.feasible_modes],
              "analyze: other feasible modes")
        check(sorted(o.modes for o in a_scaled.overlaps) == sorted(o.modes for o in a_unit.overlaps),
              "analyze: other overlaps")
        u0 = rng.uniform(-20.0, 20.0, 3)
        lemke_unit = lcp_x(ContactProblem.from_scene(unit), u0)
        lemke_scaled = lcp_x(ContactProblem.from_scene(scaled), u0 * stretch)
        close("Lemke x", lemke_scaled.x * np.array([1, 1, length, 1, 1]), lemke_unit.x, 1e-8, 1e-9)
        s_unit = analyze_statics(unit, lateral_acceleration=1.0)
        s_scaled = analyze_statics(scaled, lateral_acceleration=1.0)
        close("support interval / L", [s_scaled.support.x_min / length, s_scaled.support.x_max / length],
              [s_unit.support.x_min, s_unit.support.x_max], 1e-9, 1e-12)
        check(s_scaled.equilibrium.exists == s_unit.equilibrium.exists, "statics: another verdict")
        return passed(f"modes {sorted(modes_seen)} and forces as the 1 m rod's, accelerations x 1/L, "
                      "support interval x L; analyze, LCP and statics agree")
    return run


def _scaled_rod_compliant(length: float) -> Callable[[Path], Outcome]:
    def run(folder: Path) -> Outcome:
        scaled = rod(folder, f"rod_{length:g}m", length=length, theta=math.pi / 2)
        # lengths x L at fixed mass and g: times scale as sqrt(L); k = 1e5 / L keeps the penetration
        # at the same fraction of the length, and atol (1e-9 m by default) scales with L
        duration = 0.1 * math.sqrt(length)
        traj = simulate_compliant(scaled, None, duration, duration / 2,
                                  settings=CompliantSettings(stiffness=1e5 / length, atol=1e-9 * length))
        finite("trajectory", traj.q, traj.v, traj.contact_forces)
        check(traj.completed, f"status {traj.status}: {traj.failure}")
        close("lam_N", traj.contact_forces[-1, 0, 0], G, COMPLIANT_RTOL)
        return passed(f"standing rod: lam_N = {traj.contact_forces[-1, 0, 0]:.6g} N (k = 1e5 / L)")
    return run


def scale_cases() -> list[Case]:
    """A rod of 1 mm and of 1 km against the 1 m rod (mass 1 kg, same angle)."""
    cases = []
    for length, unit in ((1e-3, "1 mm"), (1e3, "1 km")):
        cases.append(Case(
            f"rod-{unit.replace(' ', '')}", "scale",
            f"leaning rod of {unit} (URDF and scene scaled; torques x L): solutions_at at 6 seeded inputs, "
            "analyze, Lemke, analyze_statics",
            "the 1 m rod's modes and forces, linear accelerations equal, angular ones x 1/L, support "
            "interval x L (rel 1e-9)", _scaled_rod(length)))
        cases.append(Case(
            f"rod-{unit.replace(' ', '')}-compliant", "scale",
            f"vertical rod of {unit} standing on its tip, compliant radau with k = 1e5 / L N/m, atol "
            "1e-9 L m, 0.1 sqrt(L) s",
            "lam_N = m g to 1e-3", _scaled_rod_compliant(length)))
    return cases


CASES: tuple[Case, ...] = tuple(
    friction_cases() + stiffness_cases() + mass_ratio_cases() + singular_cases() + many_contact_cases()
    + scale_cases()
)
"""Every extreme case, in table order."""
