"""The fast paths of the simulations against their references.

The rigid step's compiled parts (Lemke's pivots, the check of its answer, the Coulomb LCP matrix:
:mod:`frcontrol._kernel`) against their NumPy references (:func:`frcontrol.lcp._lemke_pivots`,
the NumPy branch of ``_verified``, ``_coulomb_matrix``), piece by piece on random problems and
through whole runs: a rigid simulation with the compiled pieces and one with the NumPy pieces
(the per-step path as it was, switched in by the modules' ``backend``) give the same samples,
bit for bit (q, v, inputs, forces, points, modes, events). The compliant contact law against its
NumPy reference, and the compliant run with a held input (one solver while the input keeps its
value) against the run restarted at every sample (the scheme it replaced, forced by an input
that changes by one unit in the last place at every sample).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import needs_kernel

from frcontrol import kernel, lcp
from frcontrol.planning import flip_loop as flip
from frcontrol.scene import load_scene
from frcontrol.simulation import (
    CompliantSettings,
    RigidSettings,
    compliant,
    impact,
    simulate_compliant,
    simulate_rigid,
)

RIGID_RUNS = (("rhex_flip", 0.15), ("box_on_slope", 0.2), ("rod_drop", 0.4), ("snake_climb", 0.1))
"""Scenes and durations [s] of the rigid runs compared (rod_drop lands: impacts)."""

COMPLIANT_AGREEMENT = 1e-5
"""[-] The compliant run with a held input and the one restarted at every sample agree to this,
relative to the largest |q|, |v| (both integrate to rtol 1e-6; measured 2e-7 on the box)."""


def numpy_simulation_pieces(monkeypatch) -> None:
    """The rigid step's LCP pieces in NumPy (the per-step path before the compiled ones)."""
    for module in (lcp, impact, compliant):
        monkeypatch.setattr(module, "backend", lambda: kernel.NUMPY)


def assert_same_trajectory(a, b) -> None:
    for field in ("times", "q", "v", "inputs", "contact_forces", "contact_points"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    assert a.modes == b.modes
    assert [(e.time, e.contact, e.kind, e.detail) for e in a.events] == \
        [(e.time, e.contact, e.kind, e.detail) for e in b.events]
    assert a.status == b.status


def random_lcp(rng: np.random.Generator, trial: int) -> tuple[np.ndarray, np.ndarray]:
    """Positive-definite, general and indefinite-shifted LCPs; rounded ones have ties."""
    n = int(rng.integers(1, 13))
    A = rng.normal(size=(n, n))
    M = (A @ A.T, A, A @ A.T - 0.5 * np.eye(n))[trial % 3]
    q = rng.normal(size=n)
    if trial % 4 == 0:
        M, q = np.round(M), np.round(q)
    return M, q


@needs_kernel
def test_compiled_lemke_pivots_like_the_numpy_reference():
    rng = np.random.default_rng(29)
    statuses = set()
    for trial in range(400):
        M, q = random_lcp(rng, trial)
        limit = 50 * q.size + 100
        status, pivots, tab = lcp._lemke_pivots(M, q, limit)
        status_c, pivots_c, basis = lcp._lemke_pivots_compiled(M, q, limit)
        statuses.add(status)
        assert (status_c, pivots_c) == (status, pivots)
        np.testing.assert_array_equal(basis.basis, tab.basis)
        np.testing.assert_array_equal(basis.matrix, tab.A[:, tab.basis])
        np.testing.assert_array_equal(basis.rhs, tab.table[:, tab.rhs])
    assert statuses == {"solved", "ray"}  # both endings were exercised


@needs_kernel
def test_compiled_lcp_check_agrees_with_numpy(monkeypatch):
    rng = np.random.default_rng(7)
    for trial in range(200):
        M, q = random_lcp(rng, trial)
        fast = lcp.solve_lcp(M, q)
        with monkeypatch.context() as patch:
            numpy_simulation_pieces(patch)
            slow = lcp.solve_lcp(M, q)
        assert (fast.found, fast.status, fast.pivots) == (slow.found, slow.status, slow.pivots)
        if slow.z is None:
            assert fast.z is None
            continue
        np.testing.assert_array_equal(fast.z, slow.z)
        scale = 1.0 + float(np.max(np.abs(M))) * float(np.max(np.abs(slow.z))) + float(np.max(np.abs(q)))
        np.testing.assert_allclose(fast.w, slow.w, rtol=0, atol=1e-13 * scale)
        assert fast.residual == pytest.approx(slow.residual, rel=1e-9, abs=1e-13 * scale)
        assert fast.tolerance == pytest.approx(slow.tolerance, rel=1e-12)


@needs_kernel
def test_compiled_coulomb_matrix_and_contact_law_equal_numpy():
    rng = np.random.default_rng(3)
    for c in (1, 2, 5, 9):
        A = rng.normal(size=(2 * c, 2 * c))
        W, mu, m_ref = A @ A.T, rng.uniform(0, 1.5, c), float(rng.uniform(0.1, 10))
        np.testing.assert_array_equal(impact.coulomb_matrix(W, m_ref, mu),
                                      impact._coulomb_matrix(W * m_ref, mu))
    scene = load_scene("box_on_slope")
    state = scene.robot.state(np.array(scene.q), np.zeros(3))
    contacts = compliant.compliant_contacts(scene, state.mass_matrix, state.jacobian_normal,
                                            state.jacobian_tangent, contacts="all")
    c = contacts.count
    seen = set()
    for _ in range(300):  # open, stick and slip, with zero and signed trial forces
        gaps, vn, vt = rng.normal(scale=1e-4, size=c), rng.normal(size=c), rng.normal(size=c) * 1e-2
        stretch = rng.choice([0.0, 1e-5, -1e-5], size=c) * rng.uniform(0, 3, c)
        fast = compliant.contact_forces(contacts, gaps, vn, vt, stretch)
        slow = kernel.NUMPY.contact_forces(contacts, gaps, vn, vt, stretch, None)
        for a, b in zip(fast, slow, strict=True):
            np.testing.assert_array_equal(a, b)
        seen.update(slow[3].tolist())
    assert seen == {0, 1, 2}


@needs_kernel
@pytest.mark.parametrize(("name", "duration"), RIGID_RUNS)
@pytest.mark.parametrize("impact_law", [True, False])
def test_rigid_samples_equal_the_numpy_step(name, duration, impact_law, monkeypatch):
    scene = load_scene(name)
    fast = simulate_rigid(scene, None, duration, 1e-3, settings=RigidSettings(impact_law=impact_law))
    with monkeypatch.context() as patch:
        numpy_simulation_pieces(patch)
        slow = simulate_rigid(scene, None, duration, 1e-3, settings=RigidSettings(impact_law=impact_law))
    assert fast.info["lcp"]["solves"] > 0
    assert_same_trajectory(fast, slow)
    if name == "rod_drop" and impact_law:
        assert fast.info["impacts"]  # the landing took the impact law


@needs_kernel
def test_flip_closed_loop_samples_equal_the_numpy_step(monkeypatch):
    scene = load_scene("rhex_flip")
    fast = flip.simulate_flip(scene, max_time=0.12)
    with monkeypatch.context() as patch:
        numpy_simulation_pieces(patch)
        slow = flip.simulate_flip(scene, max_time=0.12)
    assert_same_trajectory(fast.trajectory, slow.trajectory)
    assert fast.plans == slow.plans


def test_legs_in_the_air_read_from_the_stepper_points_as_from_q():
    scene = load_scene("rhex_flip")
    rng = np.random.default_rng(11)
    for _ in range(50):
        q = np.array(scene.q) + rng.normal(scale=0.3, size=len(scene.q))
        points = scene.robot.state(q, np.zeros_like(q)).contact_points
        each = [c.point.normal_in_world @ (p - c.point.surface_point_in_world)  # the per-contact reference
                for c, p in zip(scene.contacts, scene.robot.contact_points_in_world(q), strict=True)]
        np.testing.assert_array_equal(flip._gaps(scene, q, points), np.array(each))
        np.testing.assert_array_equal(flip._gaps(scene, q), np.array(each))


def _held_inputs(scene, flicker: bool):
    """A push of 8 N along x for 40 ms, then none; ``flicker``: each sample's value moved by one ulp
    in turn (never equal to the last: the integrator starts anew at every sample, as before)."""
    def push(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        u = np.zeros(scene.inputs.count)
        u[0] = 8.0 if t < 0.04 - 1e-9 else 0.0
        if flicker and int(round(t / 1e-3)) % 2:
            u[0] = np.nextafter(u[0], np.inf)
        return u

    return push


def test_compliant_held_input_runs_one_solver_while_it_holds(write_scene):
    scene = load_scene("box_on_slope")
    merged = simulate_compliant(scene, _held_inputs(scene, False), 0.1, 1e-3,
                                settings=CompliantSettings(stiffness=1e5))
    restarted = simulate_compliant(scene, _held_inputs(scene, True), 0.1, 1e-3,
                                   settings=CompliantSettings(stiffness=1e5))
    assert merged.status == restarted.status == "completed"
    scale = max(float(np.max(np.abs(restarted.q))), float(np.max(np.abs(restarted.v))))
    np.testing.assert_allclose(merged.q, restarted.q, rtol=0, atol=COMPLIANT_AGREEMENT * scale)
    np.testing.assert_allclose(merged.v, restarted.v, rtol=0, atol=COMPLIANT_AGREEMENT * scale)
    np.testing.assert_array_equal(merged.inputs[:, 0] > 4.0, restarted.inputs[:, 0] > 4.0)
    assert merged.info["rhs_evaluations"] < 0.7 * restarted.info["rhs_evaluations"]


def test_compliant_callable_constant_input_equals_the_constant_run():
    scene = load_scene("box_on_slope")
    u = np.zeros(scene.inputs.count)
    u[0] = 3.0
    constant = simulate_compliant(scene, u, 0.05, 1e-3, settings=CompliantSettings(stiffness=1e5))
    held = simulate_compliant(scene, lambda t, q, v: u, 0.05, 1e-3,
                              settings=CompliantSettings(stiffness=1e5))
    np.testing.assert_array_equal(held.q, constant.q)
    np.testing.assert_array_equal(held.v, constant.v)
    np.testing.assert_array_equal(held.contact_forces, constant.contact_forces)
