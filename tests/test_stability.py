"""Stability of rigid solutions (singular perturbation, KKD) checked against the compliant model."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from conftest import needs_kernel, rod_scene

from frcontrol import kernel
from frcontrol.engine import RigidSolution, solutions_at
from frcontrol.errors import InputError, KernelError
from frcontrol.modes import ContactProblem
from frcontrol.scene import load_scene, shipped_scene_names
from frcontrol.simulation.compliant import CompliantSettings, simulate_compliant
from frcontrol.simulation.inputs import InitialState
from frcontrol.stability import (
    _DECLINED,
    EIGENVALUE_TOLERANCE,
    _state_terms,
    boundary_layer_roots,
    classify_solutions,
    critical_damping,
    stability_of,
    stable_verdicts,
)

G = 9.81
THETA, MU, LAM = 2.0, 1.4, 10.0  # Painleve's rod: 1 m, 1 kg, I = 1/12 kg m^2


def painleve_d(theta: float, mu: float, sliding: float) -> float:
    """D = J_N M^-1 (J_N -+ mu J_T)^T for the rod's lower end; sliding = +1 (R) or -1 (L).

    J_N = [0, 1, -cos(theta)/2], J_T = [1, 0, sin(theta)/2], M = diag(1, 1, 1/12) (the URDF's
    0.08333333333 differs from 1/12 by 4e-12, hence relative tolerances of 1e-8).
    """
    return 1.0 + 3.0 * math.cos(theta) ** 2 + sliding * 3.0 * mu * math.sin(theta) * math.cos(theta)


def painleve_rod(write_scene, sliding: float, lam: float = LAM):
    """The rod sliding steadily at v_T = sliding m/s with its lower end on the table.

    The input (forces on x, y, theta) is chosen so that the sliding mode (R for +1, L for -1) has
    dv = 0 and lam_N = lam: the slow dynamics stand still (a pure translation), so the compliant
    model's deviation from the rigid solution is exactly KKD's boundary layer.
    """
    contact = {"name": "tip", "link": "rod", "point": [-0.5, 0.0], "normal": [0.0, 1.0], "mu": MU,
               "surface_point": [0.0, 0.0]}
    scene = load_scene(write_scene(rod_scene(contacts=[contact],
                                             state={"q": [0.0, 0.5 * math.sin(THETA), THETA]})))
    v = np.array([sliding, 0.0, 0.0])
    problem = ContactProblem.from_scene(scene, scene.q, v)
    jn, jt = problem.jacobian_normal[0], problem.jacobian_tangent[0]
    u = problem.bias - (jn - sliding * MU * jt) * lam
    return scene, problem, v, u


def deviation_run(scene, problem, v, u, sliding, stiffness, perturbation, duration, samples=50):
    """Start the compliant model at the rigid solution's penetration lam / k times (1 + perturbation)."""
    q0 = scene.q - np.array([0.0, (1.0 + perturbation) * LAM / stiffness, 0.0])
    return simulate_compliant(scene, u, duration, duration / samples,
                              settings=CompliantSettings(stiffness=stiffness, rtol=1e-10, atol=1e-14),
                              start=InitialState(q=q0, v=v),
                              initial_stretch=[sliding * MU * LAM / stiffness])


def penetration(scene, traj) -> np.ndarray:
    """The rod end's penetration [m] at every sample."""
    return -np.array([scene.robot.state(q, w, [0]).gaps[0] for q, w in zip(traj.q, traj.v, strict=True)])


def boundary_layer_prediction(roots, y0, t):
    """y(t) of y'' + b D y' + k D y = 0 with y(0) = y0, y'(0) = 0 (two real roots s1 < s2)."""
    s1, s2 = np.sort(np.real(roots))
    return y0 * (s2 * np.exp(s1 * t) - s1 * np.exp(s2 * t)) / (s2 - s1)


# ---------------------------------------------------------------------------------------- Painleve
def test_painleve_rod_has_two_solutions_separating_stable_sliding_unstable(write_scene):
    scene, problem, v, u = painleve_rod(write_scene, +1.0)
    solutions = {s.mode: s for s in solutions_at(problem, u)}
    assert sorted(solutions) == ["R", "S"]
    assert solutions["R"].lambda_n[0] == pytest.approx(LAM)
    np.testing.assert_allclose(solutions["R"].dv, 0.0, atol=1e-9)
    separate = stability_of(problem, solutions["S"])
    assert separate.stable is True and separate.eigenvalues.size == 0
    assert "no contact is held" in separate.reason
    sliding = stability_of(problem, solutions["R"])
    # D = 1 + 3 cos^2 + 3 mu sin cos = -0.0698 < 0 at theta = 2, mu = 1.4
    assert sliding.stable is False and "negative real part" in sliding.reason
    np.testing.assert_allclose(sliding.eigenvalues, [painleve_d(THETA, MU, +1.0)], rtol=1e-8)
    assert sliding.eigenvalues[0].real == pytest.approx(-0.0697507, abs=1e-6)
    assert sliding.rows == ("tip: N (R, column J_N - mu J_T)",)
    np.testing.assert_allclose(sliding.delassus, [[painleve_d(THETA, MU, +1.0)]])


def test_painleve_verdict_holds_for_the_classic_unforced_rod(write_scene):
    # no input: the rod spins at 6 rad/s while its end slides right; S and R again, same D
    scene, _, _, _ = painleve_rod(write_scene, +1.0)
    omega = 6.0
    v = np.array([1.0 - 0.5 * math.sin(THETA) * omega, 0.5 * math.cos(THETA) * omega, omega])
    problem = ContactProblem.from_scene(scene, scene.q, v)
    verdicts = {s.mode: stability_of(problem, s) for s in solutions_at(problem, np.zeros(3))}
    assert verdicts["S"].stable is True and verdicts["R"].stable is False
    assert verdicts["R"].eigenvalues[0].real == pytest.approx(painleve_d(THETA, MU, +1.0), rel=1e-8)


@pytest.mark.slow
def test_unstable_sliding_is_left_by_the_compliant_model_as_the_boundary_layer_predicts(write_scene):
    scene, problem, v, u = painleve_rod(write_scene, +1.0)
    rigid = next(s for s in solutions_at(problem, u) if s.mode == "R")
    verdict = stability_of(problem, rigid)
    m_normal = 1.0 / painleve_d(THETA, 0.0, 0.0)  # the critical damping's mass: 1 / (J_N M^-1 J_N^T)
    ratios = {}
    for k in (1e5, 1e6, 1e7):
        b = 2.0 * math.sqrt(k * m_normal)  # the compliant model's default damping
        roots = boundary_layer_roots(verdict.eigenvalues, k, b)
        growth = float(np.max(roots.real))  # 103, 327, 1033 1/s: grows as sqrt(k)
        assert growth > 0
        duration = (math.log(30.0) + 0.2) / growth  # until the linear prediction is about 30 %
        for perturbation in (+0.01, -0.01):
            traj = deviation_run(scene, problem, v, u, +1.0, k, perturbation, duration)
            depth = penetration(scene, traj)
            predicted = boundary_layer_prediction(roots, perturbation * LAM / k, traj.times)
            ratios[k, perturbation] = (depth[-1] - LAM / k) / predicted[-1]
    # measured: 1.11 and 1.14 at 1e5, 1.01 at 1e6, 1.001 at 1e7: KKD's boundary layer, better as k grows
    for k, tol in ((1e5, 0.2), (1e6, 0.03), (1e7, 0.005)):
        for perturbation in (+0.01, -0.01):
            assert ratios[k, perturbation] == pytest.approx(1.0, abs=tol)
    # and it leaves: pressed 1 % too hard it digs in, 1 % too lightly it lifts off (the S solution)
    growth = float(np.max(boundary_layer_roots(verdict.eigenvalues, 1e6, 2 * math.sqrt(1e6 * m_normal)).real))
    deeper = deviation_run(scene, problem, v, u, +1.0, 1e6, +0.01, 7.0 / growth)
    assert np.max(deeper.contact_forces[:, 0, 0]) > 1.5 * LAM
    lighter = deviation_run(scene, problem, v, u, +1.0, 1e6, -0.01, 7.0 / growth)
    assert lighter.contact_forces[-1, 0, 0] == 0.0 and any(e.kind == "open" for e in lighter.events)


@pytest.mark.slow
def test_stable_sliding_is_approached_by_the_compliant_model(write_scene):
    scene, problem, v, u = painleve_rod(write_scene, -1.0)
    solutions = solutions_at(problem, u)
    assert [s.mode for s in solutions] == ["L"]  # unique
    verdict = stability_of(problem, solutions[0])
    assert verdict.stable is True
    np.testing.assert_allclose(verdict.eigenvalues, [painleve_d(THETA, MU, -1.0)], rtol=1e-8)  # 3.109
    m_normal = 1.0 / painleve_d(THETA, 0.0, 0.0)
    errors = []
    for k in (1e3, 1e4, 1e5):
        roots = boundary_layer_roots(verdict.eigenvalues, k, 2.0 * math.sqrt(k * m_normal))
        assert np.all(roots.real < 0)
        duration = 3.0 / float(np.max(np.abs(roots.real)))
        for perturbation in (+0.01, -0.01):
            traj = deviation_run(scene, problem, v, u, -1.0, k, perturbation, duration)
            depth = penetration(scene, traj)
            predicted = boundary_layer_prediction(roots, perturbation * LAM / k, traj.times)
            # measured: 0.9998, 1.0000, 1.0000
            assert (depth[-1] - LAM / k) / predicted[-1] == pytest.approx(1.0, abs=1e-3)
        # the compliant force at a fixed time converges to the rigid one as k grows
        traj = deviation_run(scene, problem, v, u, -1.0, k, 0.01, 0.05, samples=10)
        errors.append(abs(traj.contact_forces[-1, 0, 0] - LAM))
        assert traj.contact_forces[-1, 0, 1] == pytest.approx(MU * traj.contact_forces[-1, 0, 0])
    assert errors[0] > errors[1] > errors[2] and errors[2] < 1e-6 * LAM


# ---------------------------------------------------------------------------------------- resting box
def test_resting_box_sticking_is_stable_with_one_internal_force_mode():
    scene = load_scene("box_on_ground")
    problem = ContactProblem.from_scene(scene)
    verdicts = {s.mode: stability_of(problem, s) for s in solutions_at(problem, np.zeros(3))}
    stick = verdicts["FF"]
    assert stick.stable is True and stick.indeterminate_modes == 1
    # rows J_N, J_T of both corners: the nonzero eigenvalues of M^-1 J^T J = [[2, 0, .5], [0, 2, 0],
    # [4.8, 0, 6]] (I = 5/48): 2 and 4 -+ sqrt(6.4)
    expected = sorted([4 - math.sqrt(6.4), 2.0, 4 + math.sqrt(6.4)])
    np.testing.assert_allclose(stick.eigenvalues.real, expected, rtol=1e-9)
    assert np.all(stick.eigenvalues.imag == 0)
    assert "statically indeterminate" in stick.reason
    # the same rest with the friction on its cone's edge, or "sliding" from rest with a_T = 0, is the
    # boundary of sticking: not analysable; so are a held contact without load and an unloaded one
    rest = next(s for s in solutions_at(problem, np.zeros(3)) if s.mode == "FF")
    edge = replace(rest, lambda_t=np.array([0.5, -0.5]) * rest.lambda_n)
    verdict = stability_of(problem, edge)
    assert verdict.stable is None and "impending slip at 'left': it sticks with |lam_T|" in verdict.reason
    verdict = stability_of(problem, replace(edge, mode="LR"))
    assert verdict.stable is None and "impending slip at 'left': L from rest (v_T = 0)" in verdict.reason
    verdict = stability_of(problem, replace(rest, lambda_n=np.array([0.0, G])))
    assert verdict.stable is None and "impending separation at 'left'" in verdict.reason
    verdict = stability_of(problem, replace(rest, mode="SF", lambda_n=np.array([0.0, G])))
    assert verdict.stable is None and "impending contact at 'left'" in verdict.reason


def test_resting_box_compliant_forces_converge_to_the_rigid_ones():
    scene = load_scene("box_on_ground")
    errors = []
    for k in (1e3, 1e4, 1e5):
        traj = simulate_compliant(scene, None, 0.2, 0.01, settings=CompliantSettings(stiffness=k))
        errors.append(float(np.max(np.abs(traj.contact_forces[-1, :, 0] - G / 2))))
        assert np.max(np.abs(traj.v[-1])) < 1e-3  # rung down
    assert errors[2] < errors[1] < errors[0] and errors[2] < 1e-6


# ---------------------------------------------------------------------------------------- massless legs
def massless_leg_problem(phi: float, v_t: float = 0.0) -> ContactProblem:
    """A 1 kg body translating in the plane (x, y) with a massless leg (angle phi, length 0.2 m).

    The toe is at (x + l sin(phi), y - l cos(phi)) on the ground: J_N = [0, 1, l sin(phi)] and
    J_T = [1, 0, l cos(phi)]; M = diag(1, 1, 0): the leg's coordinate has no inertia.
    """
    length = 0.2
    return ContactProblem(
        coordinates=("x", "y", "phi"), contacts=("toe",), inputs=("phi",),
        mass_matrix=np.diag([1.0, 1.0, 0.0]), bias=np.array([0.0, G, 0.0]),
        input_map=np.array([[0.0], [0.0], [1.0]]),
        jacobian_normal=np.array([[0.0, 1.0, length * math.sin(phi)]]),
        jacobian_tangent=np.array([[1.0, 0.0, length * math.cos(phi)]]),
        drift_normal=np.zeros(1), drift_tangent=np.zeros(1),
        normal_velocities=np.zeros(1), tangential_velocities=np.array([v_t]),
        mu=np.array([0.5]), lower=np.array([-50.0]), upper=np.array([50.0]),
    )


def test_massless_leg_sticking_has_one_finite_and_one_infinite_eigenvalue():
    phi, length = 0.6, 0.2
    problem = massless_leg_problem(phi)
    # torque -l g sin(phi) leaves the toe without friction: lam_N = m g, lam_T = 0
    stick = next(s for s in solutions_at(problem, np.array([-length * G * math.sin(phi)])) if s.mode == "F")
    assert stick.lambda_n[0] == pytest.approx(G) and stick.lambda_t[0] == pytest.approx(0.0, abs=1e-9)
    verdict = stability_of(problem, stick)
    # with a rotor inertia eps: D = I / m + v v^T / eps, v = l (sin, cos): eigenvalues 1 and 1 + l^2/eps
    assert verdict.method == "pencil" and verdict.stable is True
    np.testing.assert_allclose(verdict.eigenvalues, [1.0], rtol=1e-9)
    np.testing.assert_allclose(verdict.massless_eigenvalues, [length**2], rtol=1e-9)
    assert verdict.delassus is None


@pytest.mark.parametrize("phi, stable", [(0.3, False), (1.2, True)])
def test_massless_leg_dragged_jams_when_tan_phi_below_mu(phi, stable):
    # sliding right (R): column J_N - mu J_T, leading coefficient l^2 sin(phi) (sin(phi) - mu cos(phi))
    length, mu = 0.2, 0.5
    problem = massless_leg_problem(phi, v_t=1.0)
    torque = -1.0 if math.tan(phi) > mu else 1.0  # the sign that presses the toe down
    sliding = [s for s in solutions_at(problem, np.array([torque])) if s.mode == "R"]
    assert len(sliding) == 1 and sliding[0].lambda_n[0] > 0
    verdict = stability_of(problem, sliding[0])
    lead = length**2 * math.sin(phi) * (math.sin(phi) - mu * math.cos(phi))
    np.testing.assert_allclose(verdict.massless_eigenvalues, [lead], rtol=1e-9)
    assert verdict.eigenvalues.size == 0 and verdict.stable is stable


# ---------------------------------------------------------------------------------------- helpers
def test_boundary_layer_roots_and_critical_damping():
    roots = boundary_layer_roots([2.0], 100.0, 1.0)  # s^2 + 2 s + 200
    np.testing.assert_allclose(sorted(roots, key=lambda r: r.imag), [-1 - math.sqrt(199) * 1j,
                                                                      -1 + math.sqrt(199) * 1j])
    assert critical_damping(2.0) == 0.0 and critical_damping(-1.0) == math.inf
    # a complex d with Re d > 0 needs enough damping: check both sides of beta*
    d = 1.0 + 3.0j
    beta = critical_damping(d)
    assert 0 < beta < math.inf
    assert np.all(boundary_layer_roots([d], 1.0, math.sqrt(beta * 1.01)).real < 0)
    assert np.any(boundary_layer_roots([d], 1.0, math.sqrt(beta * 0.99)).real > 0)
    with pytest.raises(InputError, match="stiffness must be > 0"):
        boundary_layer_roots([1.0], 0.0, 1.0)


def test_stability_rejects_mismatched_input(write_scene):
    scene, problem, v, u = painleve_rod(write_scene, +1.0)
    rigid = next(s for s in solutions_at(problem, u) if s.mode == "R")
    with pytest.raises(InputError, match="give both stiffness and damping"):
        stability_of(problem, rigid, stiffness=1e5)
    box = ContactProblem.from_scene(load_scene("box_on_ground"))
    with pytest.raises(InputError, match="mode 'R' has 1 letters"):
        stability_of(box, rigid)
    verdict = stability_of(problem, rigid, stiffness=1e5, damping=100.0)
    d = painleve_d(THETA, MU, +1.0)
    np.testing.assert_allclose(sorted(verdict.boundary_layer_roots.real),
                               sorted(np.roots([1.0, 100.0 * d, 1e5 * d]).real))


# ------------------------------------------------------------------- the per-state path, to the bit
def _same_stability(a, b):
    """Every field of two verdicts equal, arrays to the bit (dtype, shape and bytes)."""
    for name in a.__dataclass_fields__:
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            assert type(x) is type(y) and x.dtype == y.dtype and x.shape == y.shape, name
            assert x.tobytes() == y.tobytes(), (name, x, y)
        else:
            assert repr(x) == repr(y), (name, x, y)


def _verdicts_both_ways(problem, solutions, **kwargs):
    fast = classify_solutions(problem, solutions, **kwargs)
    for verdict, solution in zip(fast, solutions, strict=True):
        _same_stability(verdict, stability_of(problem, solution, **kwargs))
    if not kwargs:  # the verdicts alone (no stiffness and damping: an atlas's)
        assert stable_verdicts(problem, solutions) == [v.stable for v in fast]
    return fast


@pytest.mark.parametrize("name", shipped_scene_names())
def test_classify_solutions_is_stability_of_on_every_shipped_scene(name):
    rng = np.random.default_rng(sum(map(ord, name)))
    scene = load_scene(name)
    moving = [i for i, c in enumerate(scene.coordinate_names) if c not in scene.robot.locked]
    velocities = [scene.v] + [scene.v + s * np.eye(scene.robot.nv)[int(rng.choice(moving))]
                              for s in (-0.4, 0.4)]
    lower, upper = np.maximum(scene.inputs.lower, -5.0), np.minimum(scene.inputs.upper, 5.0)
    inputs = [np.zeros(scene.inputs.count)] + [rng.uniform(lower, upper) for _ in range(4)]
    held = 0
    for v in velocities:
        problem = ContactProblem.from_scene(scene, scene.q, v)
        if any(vn < -problem.velocity_tolerance for vn in problem.normal_velocities):
            continue  # an impact: no rigid solution to classify
        for u in inputs:
            found = solutions_at(problem, u)
            held += sum(bool(s.rows) for s in _verdicts_both_ways(problem, found))
    # some solution holds a contact where one touches: the spectra were compared, not only early exits
    assert held or not scene.active_indices


def test_classify_solutions_is_stability_of_along_the_rods_pitch_and_friction(write_scene):
    # the rod sliding both ways over pitches and frictions: one held row (L, R: D is 1 x 1), two
    # (F), none (S), and the boundary layer's roots for a given stiffness and damping
    scene = load_scene("rod_on_table")
    rows_held, verdicts = set(), set()
    for theta in np.linspace(0.1, 3.0, 13):
        q = np.array([0.0, 0.5 * math.sin(theta), theta])
        for mu in (0.0, 0.3, 1.4):
            for v in ([-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]):
                problem = replace(ContactProblem.from_scene(scene, q, np.array(v)), mu=np.array([mu]))
                for u in (np.zeros(3), np.array([0.0, -20.0, 0.0]), np.array([3.0, 5.0, -1.0])):
                    found = solutions_at(problem, u)
                    checked = _verdicts_both_ways(problem, found)
                    rows_held |= {len(s.rows) for s in checked}
                    verdicts |= {s.stable for s in checked}
                    _verdicts_both_ways(problem, found, stiffness=1e4, damping=20.0)
    for sliding in (1.0, -1.0):  # Painleve's rod: sliding R is unstable here, L stable
        _, problem, _, u = painleve_rod(write_scene, sliding)
        verdicts |= {s.stable for s in _verdicts_both_ways(problem, solutions_at(problem, u))}
    assert rows_held == {0, 1, 2}
    assert {True, False} <= verdicts


def test_classify_solutions_is_stability_of_with_a_massless_leg():
    for phi, v_t in ((0.3, 0.0), (0.3, 1.0), (1.2, -1.0)):
        problem = massless_leg_problem(phi, v_t)
        _verdicts_both_ways(problem, solutions_at(problem, np.zeros(problem.m)))


def test_the_scales_of_the_tolerances_are_numpys_and_pythons_max():
    # the largest magnitude as NumPy's abs().max(initial=0), and the scale as Python's max(1, ...)
    # over them (an array with a NaN passed over), on NaN, infinities, signed zeros and empties
    import itertools

    from frcontrol.stability import _largest_magnitude, _scale_of

    rng = np.random.default_rng(0)
    arrays = [np.zeros(0), np.array([-0.0]), np.array([0.3]), np.array([-3.0, 2.0]),
              np.array([np.nan, 5.0]), np.array([5.0, np.nan]), np.array([np.inf]),
              np.array([-np.inf, 2.0]), rng.normal(size=(2, 3)) * 10]
    for values in arrays:
        assert repr(_largest_magnitude(values)) == repr(float(np.abs(values).max(initial=0.0)))
    for combo in itertools.product(arrays, repeat=3):
        assert repr(_scale_of(combo)) == repr(max(1.0, *(_largest_magnitude(a) for a in combo)))


# ------------------------------------------------------------------- the compiled verdict
def _reference_verdicts(problem, solutions, monkeypatch):
    """:func:`stable_verdicts` on the NumPy kernel: its own path decides every solution."""
    with monkeypatch.context() as patch:
        patch.setenv("FRC_KERNEL", "numpy")
        return stable_verdicts(problem, solutions)


def _random_held_case(rng: np.random.Generator):
    """A random problem with M positive definite and a random solution of a random mode.

    Forces, velocities and accelerations are drawn to land on each of the reference's branches:
    impending separation, slip and contact, sticking, sliding, separating, up to four held rows.
    """
    n, k = int(rng.integers(1, 7)), int(rng.integers(1, 4))
    L = rng.normal(size=(n, n))
    M = L @ L.T + rng.choice([0.05, 1.0]) * np.eye(n)
    jn, jt = rng.normal(size=(k, n)), rng.normal(size=(k, n))
    if k > 1 and rng.random() < 0.2:  # two contacts on one point: dependent rows
        jn[1], jt[1] = jn[0], jt[0]
    mode = "".join(rng.choice(list("SLRF"), size=k))
    mu = rng.choice([0.0, 0.3, 1.0, 2.5], size=k)
    pick = lambda *values: np.array([float(rng.choice(values)) for _ in range(k)])  # noqa: E731
    lam_n = pick(0.0, 1e-12, 2.0, 7.0) * (np.array(list(mode)) != "S")
    lam_t = np.where(np.array(list(mode)) == "F", rng.uniform(-1.2, 1.2, size=k) * mu * lam_n, 0.0)
    lam_t = np.where((np.array(list(mode)) == "F") & (rng.random(k) < 0.2), mu * lam_n, lam_t)
    problem = ContactProblem(
        coordinates=tuple(f"q{i}" for i in range(n)), contacts=tuple(f"c{i}" for i in range(k)), inputs=(),
        mass_matrix=M, bias=rng.normal(size=n) * 5.0, input_map=np.zeros((n, 0)), jacobian_normal=jn,
        jacobian_tangent=jt, drift_normal=np.zeros(k), drift_tangent=np.zeros(k),
        normal_velocities=pick(0.0, 0.0, 0.5), tangential_velocities=pick(0.0, 0.5, -0.5), mu=mu,
        lower=np.zeros(0), upper=np.zeros(0))
    a_n, a_t = pick(0.0, 1.0, -2.0), pick(0.0, 3.0, -1.0)
    solution = RigidSolution(mode, rng.normal(size=n), lam_n, lam_t, a_n, a_t, 0, "none", np.zeros(0), 0.0,
                             0.0)
    return problem, solution


@needs_kernel
def test_compiled_verdicts_are_the_reference_paths(monkeypatch):
    # the compiled held_verdict against stable_verdicts' own path (the NumPy kernel) on 3000 random
    # solutions: every verdict it gives is the reference's; it declines more than two held rows and
    # decides most of the rest
    rng = np.random.default_rng(20261128)
    decided, declined, seen = 0, 0, set()
    for _ in range(3000):
        problem, solution = _random_held_case(rng)
        reference = _reference_verdicts(problem, [solution], monkeypatch)[0]
        verdict = kernel.COMPILED.held_verdict(problem, solution, _state_terms(problem))
        assert kernel.NUMPY.held_verdict(problem, solution, _state_terms(problem)) is _DECLINED
        if verdict is _DECLINED:
            declined += 1
            continue
        assert verdict == reference, (solution.mode, verdict, reference)
        decided += 1
        seen.add(verdict)
        assert stable_verdicts(problem, [solution]) == [reference]
    assert seen == {True, False, None}
    assert decided > 4 * declined, (decided, declined)


@needs_kernel
def test_the_compiled_verdict_leaves_an_eigenvalue_on_its_tolerance_to_the_reference(monkeypatch):
    # one sliding contact whose D = (1 + c mu) / (1 - c^2) is steered to chosen values around its
    # zero tolerance eig_tol = EIGENVALUE_TOLERANCE * mu^2 (about 4e-9 here): far from it the
    # compiled call gives the reference's verdict, within its round-off band (some 1e-8 here) of
    # +-eig_tol it declines
    c = -0.5
    M = np.array([[1.0, c], [c, 1.0]])
    eig_tol = EIGENVALUE_TOLERANCE * 4.0
    expected = {1e-3: True, 1e-6: True, eig_tol * 1.001: _DECLINED, 0.0: _DECLINED, -eig_tol: _DECLINED,
                -1e-6: False, -1e-3: False}
    for d, outcome in expected.items():
        mu = ((1.0 - c * c) * d - 1.0) / c
        problem = ContactProblem(
            coordinates=("x", "y"), contacts=("tip",), inputs=(), mass_matrix=M, bias=np.zeros(2),
            input_map=np.zeros((2, 0)), jacobian_normal=np.array([[1.0, 0.0]]),
            jacobian_tangent=np.array([[0.0, 1.0]]), drift_normal=np.zeros(1), drift_tangent=np.zeros(1),
            normal_velocities=np.zeros(1), tangential_velocities=np.array([1.0]), mu=np.array([mu]),
            lower=np.zeros(0), upper=np.zeros(0))
        solution = RigidSolution("R", np.zeros(2), np.array([1.0]), np.array([-mu]), np.zeros(1), np.zeros(1),
                                 0, "none", np.zeros(0), 0.0, 0.0)
        verdict = kernel.COMPILED.held_verdict(problem, solution, _state_terms(problem))
        assert verdict is outcome, (d, verdict)
        if outcome is not _DECLINED:
            assert _reference_verdicts(problem, [solution], monkeypatch) == [outcome]
        assert stable_verdicts(problem, [solution]) == _reference_verdicts(problem, [solution], monkeypatch)


@needs_kernel
def test_the_compiled_verdict_refuses_bad_arguments(monkeypatch):
    # a buffer of the wrong shape or type raises KernelError from the extension, which the wrapper
    # turns into a decline (the reference path then reads, or refuses, the arrays); a mode that is
    # not a string of one letter per contact is declined, and the reference words its error
    problem, solution = _random_held_case(np.random.default_rng(7))
    state = _state_terms(problem)
    assert state.mass.factor is not None
    n, k = problem.n, problem.k
    extension = kernel.extension_function("held_verdict")
    numbers = (problem.velocity_tolerance, state.mass.scale, state.bias_scale, 1e-9, 1e-9, 1e-9, 1e-10,
               1e-130, 1e130, 1e-8, 1e-6)
    arrays = [state.mass.factor, problem.jacobian_normal, problem.jacobian_tangent, problem.mu,
              problem.normal_velocities, problem.tangential_velocities, solution.mode, solution.lambda_n,
              solution.lambda_t, solution.a_n, solution.a_t, solution.dv]
    assert extension(*arrays, *numbers) in (-1, 0, 1, 2)
    with pytest.raises(KernelError, match="held_verdict takes 23 arguments, got 22"):
        extension(*arrays, *numbers[:-1])
    bad = list(arrays)
    bad[7] = np.zeros(k + 1)
    with pytest.raises(KernelError, match="kernel buffer lambda_n"):
        extension(*bad, *numbers)
    bad[7] = np.zeros(k, dtype=np.int64)
    with pytest.raises(KernelError, match="kernel buffer lambda_n"):
        extension(*bad, *numbers)
    for mode in ("S" * (k + 1), 3, "X" * k):
        bad = list(arrays)
        bad[6] = mode
        assert extension(*bad, *numbers) == 2, mode
    wrong = replace(solution, lambda_n=solution.lambda_n.astype(np.int64))
    assert kernel.COMPILED.held_verdict(problem, wrong, state) is _DECLINED
    assert stable_verdicts(problem, [wrong]) == _reference_verdicts(problem, [wrong], monkeypatch)
    with pytest.raises(InputError, match="a mode is a string of the letters S, L, R, F"):
        stable_verdicts(problem, [replace(solution, mode="X" * k)])
    assert n == state.mass.factor.shape[0]


def _sliding_contacts(mu: list[float]) -> ContactProblem:
    """k unit contacts on a unit mass, each normal along a coordinate, sliding toward +t."""
    k = len(mu)
    eye = np.eye(k)
    return ContactProblem(
        coordinates=tuple(f"q{i}" for i in range(k)), contacts=tuple(f"c{i}" for i in range(k)), inputs=(),
        mass_matrix=eye, bias=np.zeros(k), input_map=np.zeros((k, 0)), jacobian_normal=eye,
        jacobian_tangent=np.roll(eye, 1, axis=0), drift_normal=np.zeros(k), drift_tangent=np.zeros(k),
        normal_velocities=np.zeros(k), tangential_velocities=np.ones(k), mu=np.array(mu), lower=np.zeros(0),
        upper=np.zeros(0))


@pytest.mark.parametrize(("mode", "k"), [("Rx", 2), ("F?", 2), ("R\u00e9", 3), ("R\x00", 2)])
def test_a_wrong_mode_is_refused_even_after_an_impending_contact(mode, k):
    # the first contact is held with lam_N = 0 (impending separation, which ends the reference's
    # walk over the contacts); the mode is still not one of this problem's: a wrong letter (a NUL
    # too, which C's string functions read as an end), or two letters (one of them two bytes long
    # in UTF-8) for three contacts
    problem = _sliding_contacts([0.3] * k)
    solution = RigidSolution(mode, np.zeros(k), np.array([0.0] + [1.0] * (k - 1)), np.zeros(k), np.ones(k),
                             np.ones(k), 0, "none", np.zeros(0), 0.0, 0.0)
    with pytest.raises(InputError, match="mode"):
        stability_of(problem, solution)
    with pytest.raises(InputError, match="mode"):
        stable_verdicts(problem, [solution])


def test_a_nan_friction_on_two_sliding_contacts_is_not_given_a_verdict(monkeypatch):
    # D's columns are NaN: the compiled call declines (a NaN fails every comparison, which would
    # read as stable), and the reference path answers as it does on the NumPy kernel
    problem = _sliding_contacts([float("nan"), 0.3])
    solution = RigidSolution("RR", np.zeros(2), np.ones(2), np.zeros(2), np.ones(2), np.ones(2), 0, "none",
                             np.zeros(0), 0.0, 0.0)
    if kernel.compiled is not None:
        assert kernel.COMPILED.held_verdict(problem, solution, _state_terms(problem)) is _DECLINED

    def outcome(run):
        try:
            return run()
        except Exception as err:  # noqa: BLE001 - whatever the reference does, both paths must do
            return type(err).__name__

    reference = outcome(lambda: _reference_verdicts(problem, [solution], monkeypatch))
    assert outcome(lambda: stable_verdicts(problem, [solution])) == reference
