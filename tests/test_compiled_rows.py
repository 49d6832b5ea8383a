"""The compiled kernel's contact rows (frcontrol._kernel.contact_rows, used by the mode batch)
against frcontrol.modes' dynamics_rows and contact_row_table: equal bit for bit, signs of zeros
included, on random problems (resting, sliding and separating contacts; mu below and above 1) and
on every shipped scene; strided and non-float64 arrays; malformed buffers raise KernelError."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import needs_kernel
from test_mode_batch import random_problem

from frcontrol import kernel, mode_batch
from frcontrol.errors import KernelError
from frcontrol.modes import ContactProblem
from frcontrol.scene import load_scene, shipped_scene_names

compiled = kernel.compiled
pytestmark = needs_kernel


def reference_rows(problem: ContactProblem) -> tuple[np.ndarray, ...]:
    fresh = dataclasses.replace(problem)  # its own cached properties
    table = fresh.row_table
    return (fresh.dynamics, table.equalities, table.equality_rhs, table.inequalities, table.inequality_rhs,
            table.valid, table.motion)


def assert_bitwise(found: tuple[np.ndarray, ...], expected: tuple[np.ndarray, ...], label: str) -> None:
    assert len(found) == len(expected) == 7, label
    for i, (a, b) in enumerate(zip(found, expected, strict=True)):
        assert a.shape == b.shape and a.dtype == b.dtype, (label, i)
        assert np.array_equal(a, b) and np.array_equal(np.signbit(a), np.signbit(b)), (label, i)


def test_contact_rows_equal_the_row_table_bit_for_bit_on_random_problems():
    rng = np.random.default_rng(2026)
    for trial in range(200):
        problem = random_problem(rng)
        if trial % 3 == 0:  # velocities at and just inside the tolerance, large mu
            tol = problem.velocity_tolerance
            problem = dataclasses.replace(
                problem, normal_velocities=rng.choice([0.0, tol, -tol, 2 * tol], size=problem.k),
                tangential_velocities=rng.choice([0.0, tol, -tol, -2 * tol], size=problem.k),
                mu=rng.choice([0.5, 1.0, 1e9], size=problem.k))
        assert_bitwise(mode_batch._compiled_rows(problem), reference_rows(problem), f"trial {trial}")


@pytest.mark.parametrize("name", shipped_scene_names())
def test_contact_rows_equal_the_row_table_on_every_shipped_scene(name):
    problem = ContactProblem.from_scene(load_scene(name))
    assert_bitwise(mode_batch._compiled_rows(problem), reference_rows(problem), name)


def test_contact_rows_read_strided_arrays_and_fall_back_on_other_types():
    problem = random_problem(np.random.default_rng(7))
    strided = dataclasses.replace(problem, mass_matrix=np.asfortranarray(problem.mass_matrix),
                                  jacobian_normal=np.asfortranarray(problem.jacobian_normal),
                                  drift_tangent=np.repeat(problem.drift_tangent, 2)[::2])
    assert_bitwise(mode_batch._compiled_rows(strided), reference_rows(problem), "strided")
    integers = dataclasses.replace(problem, mu=np.ones(problem.k, dtype=int))
    found = mode_batch._compiled_rows(integers)  # NumPy's table: the kernel takes float64 only
    assert "row_table" in integers.__dict__
    assert_bitwise(found, reference_rows(integers), "integer mu")


def test_contact_rows_refuse_malformed_buffers():
    problem = random_problem(np.random.default_rng(3))
    n, k = problem.n, problem.k
    nx = n + 2 * k
    good = [problem.mass_matrix, problem.jacobian_normal, problem.jacobian_tangent, problem.drift_normal,
            problem.drift_tangent, problem.mu, problem.normal_velocities, problem.tangential_velocities,
            1e-9, np.empty((n, nx)), np.empty((k, 4, 2, nx)), np.empty((k, 4, 2)), np.empty((k, 4, 3, nx)),
            np.empty((k, 4, 3)), np.empty((k, 4, 3), dtype=bool), np.empty((k, 4, 3), dtype=bool)]
    compiled.contact_rows(*good)
    cases = [
        ({0: np.zeros((n, n + 1))}, "expected a square matrix"),
        ({1: np.zeros((k, n + 1))}, f"jacobian_normal: axis 1 has {n + 1} entries, expected {n}"),
        ({2: np.zeros((k + 1, n))}, f"jacobian_tangent: axis 0 has {k + 1} entries, expected {k}"),
        ({5: np.zeros(k + 1)}, "buffer mu"),
        ({7: [0.0] * k}, "tangential_velocities: not a strided buffer"),
        ({8: "tolerance"}, "kernel argument velocity_tolerance: not a number"),
        ({9: np.empty((n, nx + 1))}, "buffer dynamics"),
        ({10: np.empty((k, 4, 2, nx))[..., ::2]}, "buffer equalities: not a C-contiguous, writable buffer"),
        ({15: np.empty((k, 4, 3))}, "buffer motion: format d, expected bool"),
    ]
    for change, message in cases:
        args = [change.get(i, arg) for i, arg in enumerate(good)]
        with pytest.raises(KernelError, match=message):
            compiled.contact_rows(*args)
    with pytest.raises(KernelError, match="takes 16 arguments, got 15"):
        compiled.contact_rows(*good[:-1])
