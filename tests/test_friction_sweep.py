"""Every shipped scene with two or more contacts, every contact's mu at 0 and each decade to 1e8.

The analysis and the solutions at an input (every input 0) either answer, or raise
:class:`~frcontrol.errors.IllConditioned` naming the mode's system, its condition number under the
balanced scaling (:func:`frcontrol.response.balanced_scaling`, about 2.4 mu for the box's LL) and
the limit. Which points raise is pinned (``ILL_CONDITIONED``, ``NOT_ROUND_OFF``). Every solution
reported is checked against the problem's own data, not the engine's flags: the rigid-body
equations, its mode's contact equalities, lam_N >= 0, the friction cone and the direction of slip.
And every mode keeps the rank it has at moderate friction: no spurious ambiguity variable.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from frcontrol.answers import analysis_and_solutions
from frcontrol.engine import DOMAIN_TOLERANCE, RigidSolution
from frcontrol.errors import IllConditioned
from frcontrol.modes import ContactProblem, build_mode_system
from frcontrol.response import ILL_CONDITIONED_BAND, RANK_TOLERANCE, ROUND_OFF_RANK_DROP, solve_affine
from frcontrol.scene import load_scene, parse_input_assignments, shipped_scene_names

FRICTIONS = (0.0, *(10.0**k for k in range(9)))

SCENES = [name for name in shipped_scene_names() if len(load_scene(name).contacts) >= 2]

ILL_CONDITIONED = {
    ("box_on_ground", 1e8): "LL",
    ("box_slide", 1e8): "LL",  # the same box and contacts as box_on_ground
    ("box_tip", 1e8): "LL",  # the same box and contacts as box_on_ground
    ("box_on_slope", 1e5): "LL", ("box_on_slope", 1e8): "LF",
    ("disk_in_wedge", 1e8): "SL",
    ("peg_on_surface", 1e7): "LL", ("peg_on_surface", 1e8): "LL",
    ("snake_climb", 1e6): "FLF", ("snake_climb", 1e7): "FLF",
    ("table_on_ground", 1e8): "LL",
}
"""(scene, mu) -> the mode whose balanced system is in the ill-conditioned band there."""

NOT_ROUND_OFF = {
    ("box_on_slope", 1e6): "LL", ("box_on_slope", 1e7): "LL", ("snake_climb", 1e8): "FLF",
}
"""(scene, mu) -> the mode whose balanced system has a singular value below ``RANK_TOLERANCE`` of
the largest that round-off does not explain (:data:`~frcontrol.response.ROUND_OFF_RANK_DROP`): a
nonsingular system whose rank cannot be read, not a rank drop. On the slope, world coordinates mix
the sliding and the normal direction, so LL's condition grows as mu^2 under every diagonal scaling
(balanced: 0.34 mu^2)."""

FAR_REPRESENTATIVE = {("rhex_flip", 1e8): "LFS"}
"""(scene, mu) -> a mode whose representative w (the Chebyshev centre of a very long interval,
about -1.6e9) cancels in x = X_u u + X_w w + x_0: its equations hold to 2e-8 of the forces only
(the engine reports an equality residual of 69 there). Checked with a tolerance that large."""

RESIDUAL_TOLERANCE = 1e-9
"""[-] The equations of a reported solution hold to this times the scale of their terms (see
:func:`check_solution`): a residual relative to the data and the solution, not to the engine's
scaling."""

SAME_RANK_FRICTION = 10.0
"""The friction at which each mode's rank is taken as the reference for every larger one."""


def check_solution(problem: ContactProblem, u: np.ndarray, sol: RigidSolution,
                   tolerance: float = RESIDUAL_TOLERANCE) -> None:
    """The solution satisfies the rigid-body problem in its mode, to :data:`RESIDUAL_TOLERANCE`.

    Scales: forces [N] by the largest sum of magnitudes of the terms of one rigid-body row; contact
    accelerations [m/s^2] by that over the largest entry of M, through the largest Jacobian entry,
    plus the largest drift.
    """
    def _holds(label: str, residual: np.ndarray, scale: float) -> None:
        assert np.all(np.abs(residual) <= tolerance * scale), (label, residual, scale)

    M, h, S = problem.mass_matrix, problem.bias, problem.input_map
    J_N, J_T, mu = problem.jacobian_normal, problem.jacobian_tangent, problem.mu
    dv, lam_n, lam_t = sol.dv, sol.lambda_n, sol.lambda_t
    for values in (dv, lam_n, lam_t):
        assert np.all(np.isfinite(values)), sol.mode
    terms = (np.abs(M) @ np.abs(dv) + np.abs(h) + np.abs(S) @ np.abs(u) + np.abs(J_N.T) @ np.abs(lam_n)
             + np.abs(J_T.T) @ np.abs(lam_t))
    force = float(terms.max())
    # M dv + h = S^T u + J_N^T lam_N + J_T^T lam_T
    _holds("dynamics", M @ dv + h - S @ u - J_N.T @ lam_n - J_T.T @ lam_t, force)
    a_n = J_N @ dv + problem.drift_normal
    a_t = J_T @ dv + problem.drift_tangent
    drift = np.abs(np.concatenate([problem.drift_normal, problem.drift_tangent]))
    jacobian = float(np.abs(np.concatenate([J_N.ravel(), J_T.ravel()])).max(initial=0.0))
    accel = force / np.abs(M).max() * jacobian + float(drift.max(initial=0.0)) + jacobian * np.abs(dv).max()
    slack = tolerance * force + DOMAIN_TOLERANCE
    for i, letter in enumerate(sol.mode):
        if letter == "S":
            _holds("S: lam = 0", np.array([lam_n[i], lam_t[i]]), force)
            assert a_n[i] >= -tolerance * accel, (sol.mode, i, a_n[i])
            continue
        _holds("a_N = 0", a_n[i:i + 1], accel)
        assert lam_n[i] >= -slack, (sol.mode, i, lam_n[i])
        if letter == "F":
            _holds("a_T = 0", a_t[i:i + 1], accel)
            cone = mu[i] * lam_n[i] + slack * max(1.0, mu[i])
            assert abs(lam_t[i]) <= cone, (sol.mode, i, lam_n[i], lam_t[i])
            continue
        sign = 1.0 if letter == "L" else -1.0  # L: lam_T = mu lam_N, a_T <= 0; R: the opposite
        _holds(f"{letter}: lam_T = {sign:+} mu lam_N", np.array([lam_t[i] - sign * mu[i] * lam_n[i]]),
               max(1.0, mu[i]) * force)
        assert sign * a_t[i] <= tolerance * accel, (sol.mode, i, a_t[i])


def scene_at(name: str, mu: float):
    contacts = [c.name for c in load_scene(name).contacts]
    return load_scene(name, overrides={f"contacts.{c}.mu": mu for c in contacts})


@pytest.mark.filterwarnings("error::RuntimeWarning")  # e.g. inf - inf in the input boxes
@pytest.mark.parametrize("name", SCENES)
def test_every_decade_of_friction_answers_right_or_names_the_ill_conditioned_system(name):
    reference_ranks: dict[str, int] = {}
    for mu in FRICTIONS:
        scene = scene_at(name, mu)
        inputs = dict.fromkeys(scene.inputs.coordinates, 0.0)
        if (name, mu) in ILL_CONDITIONED or (name, mu) in NOT_ROUND_OFF:
            in_band = (name, mu) in ILL_CONDITIONED
            mode = ILL_CONDITIONED[(name, mu)] if in_band else NOT_ROUND_OFF[(name, mu)]
            with pytest.raises(IllConditioned, match="ill-conditioned") as raised:
                analysis_and_solutions(scene, inputs)
            error = raised.value
            named = ContactProblem.from_scene(scene).named_mode(mode)  # the scene's letters, named
            assert error.matrix_name == f"the system of mode {named}", (mu, error)
            assert error.tolerance == ILL_CONDITIONED_BAND
            if in_band:
                assert 1 / ILL_CONDITIONED_BAND < error.condition_number <= 1 / RANK_TOLERANCE, error
            else:  # below the rank threshold, far above round-off
                assert 1 / RANK_TOLERANCE < error.condition_number < 1 / ROUND_OFF_RANK_DROP, error
            assert f"{error.condition_number:.3g}" in str(error) and "1e+08" in str(error)
            continue
        result, solutions = analysis_and_solutions(scene, inputs)
        assert result.feasible_modes, (name, mu)
        u = parse_input_assignments(scene, inputs)
        for solution in solutions:
            far = FAR_REPRESENTATIVE.get((name, mu)) == solution.mode
            check_solution(result.problem, u, solution, tolerance=1e-7 if far else RESIDUAL_TOLERANCE)
        ranks = {m.mode: m.response.rank for m in result.modes}
        if mu == SAME_RANK_FRICTION:
            reference_ranks = ranks
        if mu >= SAME_RANK_FRICTION:
            changed = {mode for mode, rank in ranks.items()
                       if mode in reference_ranks and rank != reference_ranks[mode]}
            assert not changed, (name, mu, changed)


@pytest.mark.parametrize("mu", [1e4, 1e5, 1e6, 1e7])
def test_a_sliding_box_is_decided_at_a_condition_growing_as_mu_not_mu_squared(mu):
    """The box's LL: 1.29 mu^2 under the max-abs equilibration (undecidable from mu = 1e4), about
    2.4 mu balanced; a rank drop there would be a spurious ambiguity variable."""
    response = solve_affine(*_system(ContactProblem.from_scene(scene_at("box_on_ground", mu)), "LL"))
    assert response.case == "unique"
    assert response.condition_number < 3 * mu, response.condition_number


def _system(problem: ContactProblem, mode: str):
    system = build_mode_system(problem, mode)
    return system.A, system.B, system.c


def _solve_exact(A: list[list[Fraction]], b: list[Fraction]) -> list[Fraction]:
    """Gaussian elimination in rationals: the exact solution of a nonsingular ``A x = b``."""
    n = len(b)
    rows = [row[:] + [b_i] for row, b_i in zip(A, b, strict=True)]
    for col in range(n):
        pivot = next(r for r in range(col, n) if rows[r][col] != 0)
        rows[col], rows[pivot] = rows[pivot], rows[col]
        for r in range(n):
            if r != col and rows[r][col] != 0:
                factor = rows[r][col] / rows[col][col]
                rows[r] = [a - factor * p for a, p in zip(rows[r], rows[col], strict=True)]
    return [rows[i][n] / rows[i][i] for i in range(n)]


@pytest.mark.parametrize("mu", [1e4, 1e5, 1e6, 1e7])
def test_the_box_sliding_left_on_both_corners_has_its_exact_normal_forces(mu):
    """Box LL at u = 0: with lam_T = mu lam_N and a_N = 0, the normal forces solve the reduced
    ``J_N M^-1 (J_N + mu J_T)^T lam_N = J_N M^-1 h - d_N``, solved here exactly in rationals from
    the problem's floats; lam_N grows as mu, lam_T as mu^2."""
    problem = ContactProblem.from_scene(scene_at("box_on_ground", mu))
    M = [[Fraction(v) for v in row] for row in problem.mass_matrix.tolist()]
    n, k = problem.n, problem.k
    J_N = [[Fraction(v) for v in row] for row in problem.jacobian_normal.tolist()]
    J_T = [[Fraction(v) for v in row] for row in problem.jacobian_tangent.tolist()]
    h = [Fraction(v) for v in problem.bias.tolist()]
    m = Fraction(mu)
    # M^-1 (J_N + mu J_T)^T column by column, and M^-1 h
    columns = [_solve_exact(M, [J_N[i][j] + m * J_T[i][j] for j in range(n)]) for i in range(k)]
    M_inv_h = _solve_exact(M, h)
    G = [[sum(J_N[r][j] * columns[c][j] for j in range(n)) for c in range(k)] for r in range(k)]
    drift = [Fraction(v) for v in problem.drift_normal.tolist()]
    rhs = [sum(J_N[r][j] * M_inv_h[j] for j in range(n)) - drift[r] for r in range(k)]
    lam_n = np.array([float(v) for v in _solve_exact(G, rhs)])
    response = solve_affine(*_system(problem, "LL"))
    assert response.case == "unique"
    x = response.x_0  # u = 0
    assert np.allclose(x[n:n + k], lam_n, rtol=1e-7, atol=0.0), (x[n:n + k], lam_n)
    assert np.allclose(x[n + k:], mu * lam_n, rtol=1e-7, atol=0.0)
    assert np.abs(lam_n).max() > 0.1 * mu  # the forces do grow with mu: the check is not vacuous


@pytest.mark.parametrize("mu", [1e6, 1e7])
def test_the_box_sliding_down_the_slope_is_not_taken_as_rank_deficient(mu):
    """Box on the slope, LL: nonsingular at every mu, with a balanced condition of about 0.34 mu^2:
    from mu = 1e6 its smallest singular value is below ``RANK_TOLERANCE`` of the largest, far above
    round-off. The rank rule would drop it (a spurious ambiguity variable): it raises instead."""
    with pytest.raises(IllConditioned, match="ill-conditioned") as raised:
        solve_affine(*_system(ContactProblem.from_scene(scene_at("box_on_slope", mu)), "LL"), name="LL")
    assert raised.value.matrix_name == "LL"
    assert 0.1 * mu**2 < raised.value.condition_number < mu**2, raised.value


def _rank_five(rng: np.random.Generator) -> np.ndarray:
    """A 6 x 6 product of 6 x 5 and 5 x 6 random factors: singular, up to the product's round-off."""
    return rng.standard_normal((6, 5)) @ rng.standard_normal((5, 6))


@pytest.mark.parametrize("seed", range(5))
def test_a_rank_drop_is_taken_only_where_round_off_explains_it(seed):
    """The same singular matrix, as computed (its smallest singular value at round-off) and moved
    off singularity by 1e-13 of its norm (below ``RANK_TOLERANCE``, far above round-off): the
    first is rank-deficient, the second raises with its condition (about 1e13)."""
    rng = np.random.default_rng(seed)
    A = _rank_five(rng)
    B, c = np.ones((6, 1)), np.zeros(6)
    singular = solve_affine(A, B, c)
    assert singular.rank == 5 and singular.ambiguity_dim == 1
    U, s, Vt = np.linalg.svd(A)
    nonsingular = A + 1e-13 * s[0] * np.outer(U[:, -1], Vt[-1])
    with pytest.raises(IllConditioned, match="ill-conditioned") as raised:
        solve_affine(nonsingular, B, c)
    assert 1e12 < raised.value.condition_number < 1e14, raised.value
    assert raised.value.tolerance == ILL_CONDITIONED_BAND


def test_input_boxes_sharing_an_infinite_side_are_not_set_apart_by_it():
    """At large friction a support LP may find an input box unbounded one way and infeasible the
    other (lower = upper = inf): that input tells nothing, and no ``inf - inf`` is formed."""
    from frcontrol.engine import _boxes_apart

    odd = (np.array([np.inf, 0.0]), np.array([np.inf, 1.0]))
    free = (np.array([-np.inf, -np.inf]), np.array([np.inf, np.inf]))
    with np.errstate(invalid="raise"):
        assert not _boxes_apart(odd, (np.array([-np.inf, 0.5]), np.array([np.inf, 2.0])))
        assert _boxes_apart(odd, (np.array([-np.inf, 2.0]), np.array([np.inf, 3.0])))  # the second input
        assert not _boxes_apart(free, free)
        assert not _boxes_apart((np.array([-np.inf, 0.0]), np.array([-np.inf, 1.0])), free)


def test_an_exact_zero_does_not_carry_a_drop_above_round_off_with_it():
    """A 6 x 6 system with a zero row and column (a singular value exactly 0, no balancing) and a
    5 x 5 block at 1e-13 of singular: the rank rule would drop both; the second is not round-off's."""
    rng = np.random.default_rng(7)
    U, _ = np.linalg.qr(rng.standard_normal((5, 5)))
    V, _ = np.linalg.qr(rng.standard_normal((5, 5)))
    A = np.zeros((6, 6))
    A[:5, :5] = U @ np.diag([1.0, 1.0, 1.0, 1.0, 1e-13]) @ V.T
    B, c = np.ones((6, 1)), np.zeros(6)
    with pytest.raises(IllConditioned, match="ill-conditioned") as raised:
        solve_affine(A, B, c)
    assert 1e12 < raised.value.condition_number < 1e14, raised.value
    A[:5, :5] = U @ np.diag([1.0, 1.0, 1.0, 1.0, 0.0]) @ V.T  # singular to round-off: both dropped
    assert solve_affine(A, B, c).rank == 4
