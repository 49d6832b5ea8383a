"""The batch path of solutions_at against the reference path (an LP per partial mode).

Random contact problems (random mass matrices, singular ones included, Jacobians, drifts,
velocities, friction and inputs), the shipped scenes at random inputs, and the closed-form interval
rule against the engine's two LPs.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from frcontrol import polytope as poly
from frcontrol.engine import DOMAIN_TOLERANCE, ZERO_ROW_TOLERANCE, _admissible_in_w, solutions_at
from frcontrol.errors import IllConditioned, InputError
from frcontrol.mode_batch import full_modes, interval_admissible
from frcontrol.modes import ContactProblem, all_modes, build_mode_system
from frcontrol.scene import load_scene
from frcontrol.solvers import SolverSettings

SCENES = ["rod_on_table", "box_on_ground", "box_on_slope", "table_on_ground", "disk_in_wedge",
          "rhex_flip", "snake_climb"]


def random_problem(rng: np.random.Generator) -> ContactProblem:
    """A planar-sized contact problem with random data; some structure repeated to make ranks drop."""
    n = int(rng.integers(1, 6))
    k = int(rng.integers(1, 4))
    m = int(rng.integers(0, n + 1))
    L = rng.normal(size=(n, n))
    M = L @ L.T + 0.1 * np.eye(n)
    if rng.random() < 0.3:  # a massless coordinate: M singular
        j = int(rng.integers(n))
        M[j, :] = 0.0
        M[:, j] = 0.0
    jn = rng.normal(size=(k, n))
    jt = rng.normal(size=(k, n))
    dn, dt = rng.normal(size=k), rng.normal(size=k)
    if k > 1 and rng.random() < 0.4:  # two contacts on the same point: forces indeterminate
        jn[1], jt[1], dn[1], dt[1] = jn[0], jt[0], dn[0], dt[0]
    def velocity() -> float:
        return float(rng.choice([0.0, 0.0, 0.5, -0.5]))
    vt = np.array([velocity() for _ in range(k)])
    vn = np.array([abs(velocity()) if rng.random() < 0.2 else 0.0 for _ in range(k)])
    columns = rng.choice(n, size=m, replace=False) if m else np.zeros(0, dtype=int)
    input_map = np.zeros((n, m))
    input_map[columns, np.arange(m)] = 1.0
    return ContactProblem(
        coordinates=tuple(f"q{i}" for i in range(n)), contacts=tuple(f"c{i}" for i in range(k)),
        inputs=tuple(f"q{i}" for i in columns), mass_matrix=M, bias=rng.normal(size=n) * 5.0,
        input_map=input_map, jacobian_normal=jn, jacobian_tangent=jt,
        drift_normal=dn, drift_tangent=dt,
        normal_velocities=vn, tangential_velocities=vt,
        mu=rng.choice([0.0, 0.3, 1.0, 5.0], size=k), lower=np.full(m, -np.inf), upper=np.full(m, np.inf))


def assert_same_solutions(problem: ContactProblem, u: np.ndarray) -> int:
    """Both paths list the same modes, the same motion, and valid, equally central forces."""
    fast = solutions_at(problem, u, method="batch")
    reference = solutions_at(problem, u, method="reference")
    assert [s.mode for s in fast] == [s.mode for s in reference]
    for a, b in zip(fast, reference, strict=True):
        scale = 1.0 + float(np.max(np.abs(np.concatenate([b.dv, b.lambda_n, b.lambda_t]))))
        assert a.ambiguity_dim == b.ambiguity_dim and a.ambiguous_outputs == b.ambiguous_outputs
        if a.ambiguous_outputs != "accelerations":
            np.testing.assert_allclose(a.dv, b.dv, rtol=0, atol=1e-8 * scale)
        if a.ambiguity_dim == 0:
            np.testing.assert_allclose(a.lambda_n, b.lambda_n, rtol=0, atol=1e-8 * scale)
            np.testing.assert_allclose(a.lambda_t, b.lambda_t, rtol=0, atol=1e-8 * scale)
        # the batch's answer is a solution of its mode, whatever its w
        system = build_mode_system(problem, a.mode)
        x = np.concatenate([a.dv, a.lambda_n, a.lambda_t])
        assert np.abs(system.A @ x - system.B @ u - system.c).max(initial=0.0) <= 1e-8 * scale
        assert (system.G @ x - system.g).max(initial=0.0) <= 1e-6 * scale
        assert a.equality_residual <= 1e-8 * scale
    return len(fast)


def test_random_problems_agree_with_the_reference_path():
    rng = np.random.default_rng(20261125)
    solved = ambiguous = 0
    for _ in range(250):
        problem = random_problem(rng)
        u = rng.normal(size=problem.m) * 5.0
        solved += assert_same_solutions(problem, u)
        ambiguous += sum(s.ambiguity_dim > 0 for s in solutions_at(problem, u))
    assert solved > 100 and ambiguous > 5  # the comparison saw answers, ambiguous ones too


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(name=st.sampled_from(SCENES), data=st.data())
def test_shipped_scenes_agree_with_the_reference_path(name, data):
    problem = ContactProblem.from_scene(load_scene(name))
    u = np.array([data.draw(st.floats(lo, hi)) for lo, hi in zip(problem.lower, problem.upper, strict=True)])
    assume(assert_same_solutions(problem, u) > 0)  # an input with no solution compares nothing


@pytest.mark.parametrize("name", SCENES)
def test_shipped_scenes_at_zero_input(name):
    problem = ContactProblem.from_scene(load_scene(name))
    u = np.clip(np.zeros(problem.m), problem.lower, problem.upper)
    assert_same_solutions(problem, u)


def test_the_default_takes_the_batch_and_says_so_in_nothing_but_speed():
    scene = load_scene("rhex_flip")
    auto = solutions_at(scene, {})
    batch = solutions_at(scene, {}, method="batch")
    # at zero torque, four modes (the legs' toes sliding or leaving): the same from scratch
    reference = solutions_at(scene, {}, method="reference")
    assert [s.mode for s in auto] == [s.mode for s in batch] == [s.mode for s in reference]
    assert len(auto) == 4


def test_unknown_method_is_an_input_error():
    with pytest.raises(InputError, match="unknown solution method 'fast'.*auto, batch, reference"):
        solutions_at(load_scene("rod_on_table"), {}, method="fast")


def test_full_modes_are_the_reference_order():
    allowed = ("SLRF", "SR", "S", "SLRF")
    modes, letters = full_modes(allowed)
    assert list(modes) == all_modes(allowed)
    assert letters.shape == (len(modes), 4)


# ------------------------------------------------------------------ the interval rule, p = 1
def _chebyshev_radius(H: np.ndarray, h: np.ndarray, w: np.ndarray) -> float:
    a = H[:, 0]
    live = np.abs(a) > 0
    return float(np.min((h[live] + DOMAIN_TOLERANCE - a[live] * w[0]) / np.abs(a[live]), initial=np.inf))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(data=st.data())
def test_interval_rule_matches_the_two_lps(data):
    rows = data.draw(st.integers(1, 6))
    coefficient = st.one_of(st.just(0.0), st.floats(-1.0, 1.0).filter(lambda x: abs(x) > 1e-3))
    H = np.array([[data.draw(coefficient)] for _ in range(rows)])
    magnitude = st.floats(1e-3, 2.0)  # away from the tolerance, where the LPs' own tolerance decides
    h = np.array([data.draw(magnitude) * data.draw(st.sampled_from([-1.0, 1.0])) for _ in range(rows)])
    motion = np.array([data.draw(st.booleans()) for _ in range(rows)])
    cap = poly.CHEBYSHEV_RADIUS_CAP
    closed = interval_admissible(H, h, motion, DOMAIN_TOLERANCE, ZERO_ROW_TOLERANCE, cap)
    lps = _admissible_in_w(H, h, motion, SolverSettings(lp="highs"), closed_form=False)
    # two interval ends within the LPs' own tolerance of each other may go either way: skipped
    live = H[:, 0] != 0
    ends = np.sort((h + np.where(motion, 0.0, DOMAIN_TOLERANCE))[live] / H[live, 0])  # one per row
    assume(ends.size < 2 or bool(np.all(np.diff(ends) > 1e-5)))
    assert (closed is None) == (lps is None)
    if closed is not None:
        assert np.all(H[:, 0] * closed[0] <= h + np.where(motion, 0.0, DOMAIN_TOLERANCE) + 1e-12)
        # as central as the Chebyshev LP's centre (radius capped at CHEBYSHEV_RADIUS_CAP)
        assert min(_chebyshev_radius(H, h, closed), cap) >= min(_chebyshev_radius(H, h, lps), cap) - 1e-7


def _rod_on_two_contacts(write_scene, gap: float, mu: float = 0.8) -> ContactProblem:
    """The rod on its left end, listed twice, ``gap`` [m] apart along the rod."""
    from conftest import rod_scene

    contacts = [{"name": "a", "link": "rod", "point": [-0.5, 0.0], "normal": [0.0, 1.0], "mu": mu},
                {"name": "b", "link": "rod", "point": [-0.5, gap], "normal": [0.0, 1.0], "mu": mu}]
    return ContactProblem.from_scene(load_scene(write_scene(rod_scene(contacts=contacts))))


@pytest.mark.parametrize("gap", [1e-16, 1e-12])
def test_nearly_singular_modes_take_the_svd_and_agree(write_scene, gap):
    """Two contacts a hair apart (1e-16 m: one point to round-off; 1e-12 m: one point to the first
    scaling, which decides at mu <= BALANCING_FRICTION): the certificate must refuse them, the SVD
    decides, both paths agree."""
    problem = _rod_on_two_contacts(write_scene, gap)
    from frcontrol.mode_batch import CERTIFIED_MARGIN, _certified_responses, _equilibrate, _stack

    modes, letters = full_modes(problem.allowed_modes())
    st = _stack(problem, letters, np.zeros(problem.m))
    r, c = _equilibrate(st.A)
    A_hat = st.A * r[:, :, None] * c[:, None, :]
    certified = _certified_responses(problem, st, A_hat, r, c, 1e-10)[0]
    s = np.linalg.svd(A_hat, compute_uv=False)
    condition = s[:, 0] / np.where(s[:, -1] > 0, s[:, -1], 1e-300)
    # certified only where the SVD itself finds the condition far below the band
    assert np.all(condition[certified] < 1.0 / (CERTIFIED_MARGIN * 1e-8))
    assert not certified[modes.index("FF")]
    assert assert_same_solutions(problem, np.zeros(problem.m)) == 1
    (only,) = solutions_at(problem, np.zeros(problem.m))
    assert only.mode == "FF" and only.ambiguity_dim == 2  # the two contacts' forces: one point's


def test_contacts_apart_beyond_round_off_stop_both_paths_alike(write_scene):
    """1e-12 m apart at mu = 2 (above BALANCING_FRICTION, so a sliding mode's rank drop is decided
    again under a balanced scaling): LR's system is nonsingular (smallest singular value about
    1e-12 of the largest under the balanced scaling, far above round-off) and too ill-conditioned
    to decide. Both paths raise, naming the same mode and condition, instead of taking it as one
    point."""
    problem = _rod_on_two_contacts(write_scene, 1e-12, mu=2.0)
    errors = []
    for method in ("batch", "reference"):
        with pytest.raises(IllConditioned, match="ill-conditioned") as raised:
            solutions_at(problem, np.zeros(problem.m), method=method)
        errors.append(raised.value)
    assert errors[0].matrix_name == errors[1].matrix_name == "the system of mode LR (a L, b R)"
    assert errors[0].condition_number == errors[1].condition_number
    assert 1e11 < errors[0].condition_number < 1e13, errors[0]


def test_more_contacts_than_numpy_has_dimensions():
    """40 and 70 separating contacts (one mode, every contact S): the batch path lists the modes without
    numpy.meshgrid's limit of 32 arrays, and the one call (up to 64 contacts) gives its answer."""
    rng = np.random.default_rng(3)
    for k in (40, 70):
        problem = ContactProblem(
            coordinates=("x", "y", "t"), contacts=tuple(f"c{i}" for i in range(k)), inputs=("x",),
            mass_matrix=np.eye(3), bias=np.array([0.0, 9.81, 0.0]), input_map=np.eye(3)[:, :1],
            jacobian_normal=rng.normal(size=(k, 3)), jacobian_tangent=rng.normal(size=(k, 3)),
            drift_normal=np.zeros(k), drift_tangent=np.zeros(k), normal_velocities=np.ones(k),
            tangential_velocities=np.zeros(k), mu=np.full(k, 0.5), lower=np.array([-np.inf]),
            upper=np.array([np.inf]))
        batch = solutions_at(problem, np.zeros(1), method="batch")
        assert [s.mode for s in batch] == ["S" * k]
        np.testing.assert_allclose(batch[0].dv, [0.0, -9.81, 0.0], atol=1e-12)
        auto = solutions_at(problem, np.zeros(1))
        assert [s.mode for s in auto] == ["S" * k] and np.allclose(auto[0].dv, batch[0].dv, atol=1e-12)
