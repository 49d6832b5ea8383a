"""The compliant model's linearly implicit integrator ("implicit"): closed forms and invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import rod_scene
from test_simulation import BOX_INERTIA, SLOPE, SLOPE_NORMAL, UP_SLOPE, G, box_scene, slope_scene

from frcontrol.engine import solutions_at
from frcontrol.scene import load_scene
from frcontrol.simulation.compliant import (
    ACTIVE_SET_ITERATIONS,
    CompliantSettings,
    explicit_stability_limit,
    simulate_compliant,
)
from frcontrol.simulation.inputs import InitialState


def _omega(k: float, mass: float = 1.0) -> float:
    return math.sqrt(k / mass)


def test_free_fall_is_the_explicit_step_exactly(write_scene):
    # no contact closed: the step is semi-implicit Euler, sample for sample
    scene = load_scene(write_scene(box_scene([0.0, 5.0, 0.3])))
    implicit = simulate_compliant(scene, None, 0.05, 1e-3,
                                  settings=CompliantSettings(integrator="implicit"))
    explicit = simulate_compliant(scene, None, 0.05, 1e-3, settings=CompliantSettings(integrator="euler"))
    np.testing.assert_array_equal(implicit.q, explicit.q)
    np.testing.assert_array_equal(implicit.v, explicit.v)


def test_resting_box_settles_on_its_weight_at_steps_far_beyond_the_explicit_limit(write_scene):
    k = 1e8
    scene = load_scene(write_scene(box_scene([0.0, 0.25, 0.0])))
    dt = 30.0 / _omega(k)
    traj = simulate_compliant(scene, None, 8 * dt, dt,
                              settings=CompliantSettings(integrator="implicit", stiffness=k))
    assert dt > 10 * traj.info["explicit_stability_limit"]  # euler would refuse this step
    assert traj.status == "completed" and traj.warnings == ()
    lam = traj.contact_forces[-1]
    # symmetric box: each corner carries half the weight, no friction
    np.testing.assert_allclose(lam[:, 0], [G / 2, G / 2], rtol=1e-9)
    np.testing.assert_allclose(lam[:, 1], [0.0, 0.0], atol=1e-9)
    # the static sink of two springs, m g / (2 k)
    assert traj.q[-1, 1] - 0.25 == pytest.approx(-G / (2 * k), rel=1e-6)


def test_box_sticking_on_the_slope_carries_its_weight_and_does_not_creep(write_scene):
    k = 1e8
    scene = load_scene(write_scene(slope_scene(0.5)))  # tan 20 deg < 0.5: it sticks
    dt = 30.0 / _omega(k)
    traj = simulate_compliant(scene, None, 20 * dt, dt,
                              settings=CompliantSettings(integrator="implicit", stiffness=k))
    total = traj.contact_forces[-1].sum(axis=0)
    assert total[0] == pytest.approx(G * math.cos(SLOPE), rel=1e-9)
    assert total[1] == pytest.approx(G * math.sin(SLOPE), rel=1e-9)  # up the slope
    assert abs(traj.v[-1, :2] @ UP_SLOPE) < 1e-9
    assert {e.kind for e in traj.events} <= {"stick"}


def test_box_sliding_down_the_slope_has_the_coulomb_acceleration(write_scene):
    mu, k = 0.2, 1e8
    scene = load_scene(write_scene(slope_scene(mu)))
    acc = G * (math.sin(SLOPE) - mu * math.cos(SLOPE))
    dt = 1e-4
    traj = simulate_compliant(scene, None, 0.05, dt,
                              settings=CompliantSettings(integrator="implicit", stiffness=k))
    along = traj.v[:, :2] @ UP_SLOPE
    # after the first steps' transient: the rigid model's acceleration, to first order in dt
    rate = np.diff(along[40:]) / dt  # h omega = 1: the transient halves every step
    np.testing.assert_allclose(rate, -acc, rtol=1e-6)
    forces = traj.contact_forces[-1]
    np.testing.assert_allclose(forces[:, 1], mu * forces[:, 0], rtol=1e-9)  # Coulomb, opposing
    assert forces[:, 0].sum() == pytest.approx(G * math.cos(SLOPE), rel=1e-6)
    assert abs(traj.v[-1, :2] @ SLOPE_NORMAL) < 1e-9


def test_dropped_box_lands_and_rests_at_a_huge_step_without_energy_from_nowhere(write_scene):
    k = 1e7
    scene = load_scene(write_scene(box_scene([0.0, 0.3, 0.0])))  # 5 cm above the ground
    traj = simulate_compliant(scene, None, 0.4, 2e-3,
                              settings=CompliantSettings(integrator="implicit", stiffness=k, contacts="all"))
    assert traj.status == "completed"
    assert "energy" not in {w.kind for w in traj.warnings}  # the validity check's energy balance
    energy = traj.info["energy"] + traj.info["elastic_energy"]
    # in flight and at rest the step only removes energy; the landing step, whose contact closes
    # within it, adds at most the spring energy of that step's sink (measured: 0.3 % at 2 ms)
    assert np.max(np.diff(energy)) <= 5e-3 * energy[0]
    assert energy[-1] < 0.85 * energy[0]
    assert traj.contact_forces[-1, :, 0].sum() == pytest.approx(G, rel=1e-6)
    assert any(e.kind in ("impact", "close") for e in traj.events)


def test_rod_force_reaches_the_rigid_answer_to_1e_minus_3_in_three_steps(write_scene):
    scene = load_scene(write_scene(rod_scene()))
    (rigid,) = solutions_at(scene, {})
    k = 1e12
    dt = 30.0 / _omega(k, 1.0)
    traj = simulate_compliant(scene, None, 3 * dt, dt,
                              settings=CompliantSettings(integrator="implicit", stiffness=k))
    force = traj.contact_forces[-1, 0]
    reference = np.array([rigid.lambda_n[0], rigid.lambda_t[0]])
    assert np.linalg.norm(force - reference) / np.linalg.norm(reference) < 1e-3
    assert rigid.mode == "F" and traj.info["steps"] == 3


def test_iteration_bound_is_named_and_explicit_limit_reported(write_scene):
    scene = load_scene(write_scene(box_scene([0.0, 0.25, 0.0])))
    traj = simulate_compliant(scene, None, 0.01, 1e-3, settings=CompliantSettings(integrator="implicit"))
    assert ACTIVE_SET_ITERATIONS >= 2
    assert traj.info["integrator"] == "implicit"
    assert traj.info["explicit_stability_limit"] == pytest.approx(
        explicit_stability_limit_of(scene))
    assert BOX_INERTIA > 0


def explicit_stability_limit_of(scene):
    from frcontrol.simulation.compliant import ContactOverrides, _initial_state

    _, _, params = _initial_state(scene, InitialState(), None, "active", ContactOverrides(), None)
    return explicit_stability_limit(params)


@pytest.mark.slow
def test_a_box_landing_while_it_slides_follows_the_adaptive_integrator(write_scene):
    # the slip law's coupling of lam_T to J_N v+ acts only while the penetration changes: a box
    # touching down at 1 m/s while it slides at 2 m/s; the linearly implicit step at a small dt
    # must follow Radau's trajectory (a sign error there once gave a different motion at any dt)
    box = box_scene([0.0, 0.25, 0.0])
    box["state"]["v"] = [2.0, -1.0, 0.0]
    scene = load_scene(write_scene(box))
    reference = simulate_compliant(scene, None, 0.02, 1e-4,
                                   settings=CompliantSettings(integrator="radau", stiffness=1e5, rtol=1e-9,
                                                              atol=1e-12))
    implicit = simulate_compliant(scene, None, 0.02, 1e-6,
                                  settings=CompliantSettings(integrator="implicit", stiffness=1e5))
    np.testing.assert_allclose(implicit.v[-1], reference.v[-1], atol=2e-3)
    assert reference.v[-1, 0] < 1.9  # friction acted on the slide: the coupling mattered
    sliding = np.abs(implicit.contact_forces[1:, :, 1]) >= 0.999 * 0.5 * implicit.contact_forces[1:, :, 0]
    assert np.any(sliding & (implicit.contact_forces[1:, :, 0] > 0.1))  # lam_T = mu lam_N somewhere


def test_the_implicit_step_satisfies_the_law_it_was_solved_with():
    from frcontrol.simulation.compliant import _ImplicitStep

    rng = np.random.default_rng(7)
    scene = load_scene("box_on_ground")
    from frcontrol.simulation.compliant import ContactOverrides, _initial_state

    stiff = ContactOverrides(stiffness=1e5)
    _, arm, params = _initial_state(scene, InitialState(), None, "active", stiff, None)
    for _ in range(20):
        v = rng.normal(size=3)
        s = rng.normal(size=2) * 1e-4
        state = scene.robot.state(scene.q - np.array([0.0, 1e-4, 0.0]), v, params.indices)
        h = 1e-3
        step = _ImplicitStep(params, state, arm.apply(state.mass_matrix), -state.bias, v, s, h)
        status = rng.integers(1, 3, size=2)  # stick or slip
        sign = rng.choice([-1.0, 1.0], size=2)
        v_new = step.solve(status, sign)
        lam_n = step.normal_forces(v_new)
        v_t = state.jacobian_tangent @ v_new
        gain = params.tangential_stiffness * h + params.tangential_damping
        stick = -(params.tangential_stiffness * s + gain * v_t)
        lam_t = np.where(status == 1, stick, -sign * params.mu * lam_n)
        force = -state.bias + state.jacobian_normal.T @ lam_n + state.jacobian_tangent.T @ lam_t
        residual = arm.apply(state.mass_matrix) @ (v_new - v) - h * force
        assert np.max(np.abs(residual)) < 1e-9 * (1.0 + np.max(np.abs(h * force)))
