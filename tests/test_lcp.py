"""Tests of frcontrol.lcp: closed forms, the Siconos corpus, agreement and properties."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import counted, tally
from hypothesis import given, settings
from hypothesis import strategies as st

from frcontrol.errors import InputError
from frcontrol.lcp import (
    ENUMERATION_MAX_SIZE,
    FC2D_TOLERANCE,
    FrictionContact2D,
    LCPSolution,
    enumerate_lcp_solutions,
    fc2d_error,
    fc2d_to_lcp,
    lcp_residual,
    siconos_lcp_error,
    solve_fc2d,
    solve_lcp,
)
from frcontrol.siconos import read_siconos_fc2d, read_siconos_lcp

DATA = Path(__file__).parent / "data" / "siconos"
LCP_DIR = DATA / "siconos_lcp"
FC2D_DIR = DATA / "siconos_fc2d"
SICONOS_TOLERANCE = 1e-5  # Siconos accepts a solution when error / ||q|| <= 1e-5
METHODS = ("lemke", "enumerate")


def check_solution(M: np.ndarray, q: np.ndarray, result: LCPSolution) -> None:
    """Independent check of a reported solution: recompute w and test the three conditions."""
    assert result.found
    assert result.z is not None and result.w is not None
    z = result.z
    w = M @ z + q
    tol = result.tolerance
    assert np.allclose(result.w, w, rtol=0, atol=tol)
    assert np.all(z >= -tol)
    assert np.all(w >= -tol)
    assert np.all(np.abs(z * w) <= tol * max(1.0, np.max(np.abs(z)), np.max(np.abs(w))))
    assert result.residual == pytest.approx(lcp_residual(M, q, z), abs=1e-15)
    assert result.residual <= tol


def brute_force(M: np.ndarray, q: np.ndarray) -> list[np.ndarray]:
    """All solutions with a nonsingular principal block, by plain enumeration (test oracle)."""
    n = len(q)
    solutions = []
    for size in range(n + 1):
        for alpha in itertools.combinations(range(n), size):
            z = np.zeros(n)
            if size:
                block = M[np.ix_(alpha, alpha)]
                if abs(np.linalg.det(block)) < 1e-12:
                    continue
                z[list(alpha)] = np.linalg.solve(block, -q[list(alpha)])
            w = M @ z + q
            if np.all(z >= -1e-10) and np.all(w >= -1e-10):
                solutions.append(z)
    return solutions


# --------------------------------------------------------------------------------------------
# Closed forms
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("method", METHODS)
def test_1x1_active(method: str) -> None:
    result = solve_lcp([[2.0]], [-4.0], method)
    assert result.status == "solved"
    np.testing.assert_allclose(result.z, [2.0])
    np.testing.assert_allclose(result.w, [0.0], atol=1e-15)


@pytest.mark.parametrize("method", METHODS)
def test_q_nonnegative_gives_zero(method: str) -> None:
    M = np.array([[1.0, -3.0], [4.0, 1.0]])
    q = np.array([3.0, 0.0])
    result = solve_lcp(M, q, method)
    assert result.found
    np.testing.assert_array_equal(result.z, [0.0, 0.0])
    np.testing.assert_array_equal(result.w, q)
    if method == "lemke":
        assert result.pivots == 0


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize(
    ("q", "z_expected", "w_expected"),
    [
        # both active: z = M^-1 (-q) = (4/3, 7/3)
        ([-5.0, -6.0], [4.0 / 3.0, 7.0 / 3.0], [0.0, 0.0]),
        # only the first: z1 = 1/2, w2 = 1/2 + 3
        ([-1.0, 3.0], [0.5, 0.0], [0.0, 3.5]),
        # only the second: z2 = 2, w1 = 2 - 1
        ([-1.0, -4.0], [0.0, 2.0], [1.0, 0.0]),
    ],
)
def test_2x2_positive_definite(
    method: str, q: list[float], z_expected: list[float], w_expected: list[float]
) -> None:
    M = np.array([[2.0, 1.0], [1.0, 2.0]])
    result = solve_lcp(M, q, method)
    check_solution(M, np.array(q), result)
    np.testing.assert_allclose(result.z, z_expected, atol=1e-12)
    np.testing.assert_allclose(result.w, w_expected, atol=1e-12)


@pytest.mark.parametrize("q", [[-1.0, -1.0, -1.0], [-3.0, 1.0, -2.0], [1.0, -5.0, 2.0]])
def test_p_matrix_against_brute_force(q: list[float]) -> None:
    # Every principal minor of M is positive (1, 1, 1, 1, 1, 1, 9): a P-matrix, so the
    # solution is unique.
    M = np.array([[1.0, 2.0, 0.0], [0.0, 1.0, 2.0], [2.0, 0.0, 1.0]])
    q_arr = np.array(q)
    (expected,) = brute_force(M, q_arr)
    for method in METHODS:
        result = solve_lcp(M, q_arr, method)
        check_solution(M, q_arr, result)
        np.testing.assert_allclose(result.z, expected, atol=1e-10)


def naive_lemke_cycles(M: np.ndarray, q: np.ndarray, max_pivots: int = 200) -> bool:
    """Lemke with ties broken by the smallest row index (no lexicographic rule): does it cycle?"""
    n = len(q)
    tableau = np.hstack([np.eye(n), -M, -np.ones((n, 1)), q[:, None]])
    basis = list(range(n))

    def pivot(row: int, column: int) -> None:
        tableau[row] /= tableau[row, column]
        factors = tableau[:, column].copy()
        factors[row] = 0.0
        tableau[:] -= np.outer(factors, tableau[row])
        basis[row] = column

    row = int(np.argmin(q))
    leaving = basis[row]
    pivot(row, 2 * n)
    seen = set()
    for _ in range(max_pivots):
        key = tuple(sorted(basis))
        if key in seen:
            return True
        seen.add(key)
        entering = leaving + n if leaving < n else leaving - n
        column = tableau[:, entering]
        eligible = [i for i in range(n) if column[i] > 1e-9]
        if not eligible:
            return False
        ratios = [tableau[i, -1] / column[i] for i in eligible]
        ties = [i for i, r in zip(eligible, ratios, strict=True) if r <= min(ratios) + 1e-9]
        row = next((i for i in ties if basis[i] == 2 * n), ties[0])
        leaving = basis[row]
        pivot(row, entering)
        if leaving == 2 * n:
            return False
    return False


def test_lexicographic_rule_prevents_cycling() -> None:
    # Degenerate (all q_i tied): Lemke with smallest-index tie breaking returns to a basis it
    # has already visited; the lexicographic rule terminates with the solution (5, 7/3, 13/3).
    M = np.array([[1.0, 2.0, -2.0], [-2.0, 1.0, 2.0], [2.0, -2.0, -1.0]])
    q = np.array([-1.0, -1.0, -1.0])
    assert naive_lemke_cycles(M, q)
    result = solve_lcp(M, q)
    check_solution(M, q, result)
    np.testing.assert_allclose(result.z, [5.0, 7.0 / 3.0, 13.0 / 3.0], atol=1e-12)
    assert result.pivots <= 10


@pytest.mark.parametrize("seed", range(10))
def test_degenerate_p_matrix_problems(seed: int) -> None:
    # q with zeros and ties, M a P-matrix: Lemke must terminate on the unique solution.
    rng = np.random.default_rng(seed)
    n = 6
    A = rng.integers(-2, 3, size=(n, n)).astype(float)
    M = A @ A.T + np.eye(n) + (A - A.T)
    q = rng.choice([-1.0, 0.0], size=n)
    q[0] = -1.0
    result = solve_lcp(M, q)
    check_solution(M, q, result)
    (expected,) = [s.z for s in enumerate_lcp_solutions(M, q)]
    np.testing.assert_allclose(result.z, expected, atol=1e-9)


def murty(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Murty's example: Lemke visits 2^n bases."""
    M = np.eye(n) + 2.0 * np.triu(np.ones((n, n)), 1)
    q = -np.array([sum(2.0**j for j in range(i + 1, n + 1)) for i in range(n)])
    return M, q


@pytest.mark.parametrize("n", range(1, 9))
def test_murty_pivot_count_is_exponential(n: int) -> None:
    M, q = murty(n)
    result = solve_lcp(M, q)
    check_solution(M, q, result)
    assert result.pivots == 2**n
    expected = np.zeros(n)
    expected[-1] = 2.0**n
    np.testing.assert_allclose(result.z, expected)


def test_murty_file_matches_construction() -> None:
    M_file, q_file = read_siconos_lcp(LCP_DIR / "lcp_exp_murty2.dat")
    M, q = murty(6)
    np.testing.assert_array_equal(M_file, M)
    np.testing.assert_array_equal(q_file, q)


@pytest.mark.parametrize(
    ("M", "q"),
    [
        ([[-1.0]], [-1.0]),  # w = -z - 1 < 0 for every z >= 0
        ([[0.0, 0.0], [0.0, 0.0]], [-1.0, 2.0]),  # w1 = -1 whatever z
    ],
)
def test_ray_termination(M: list[list[float]], q: list[float]) -> None:
    result = solve_lcp(M, q)
    assert result.status == "ray"
    assert not result.found
    assert result.z is None and result.w is None
    assert result.residual == np.inf
    # these have no solution at all, which enumeration proves
    assert solve_lcp(M, q, "enumerate").status == "infeasible"
    assert enumerate_lcp_solutions(M, q) == []


def test_max_pivots_is_reported() -> None:
    M, q = murty(6)
    result = solve_lcp(M, q, max_pivots=10)
    assert result.status == "max_pivots"
    assert not result.found
    assert result.pivots == 10


def test_unverified_solution_is_not_found() -> None:
    # Lemke terminates on lcp_CPS_4 with a round-off residual of ~1e-14; demanding 1e-30
    # (relative) must turn that into a reported failure, never a "found" solution.
    M, q = read_siconos_lcp(LCP_DIR / "lcp_CPS_4.dat")
    loose = solve_lcp(M, q)
    assert loose.found and loose.residual > 0
    strict = solve_lcp(M, q, tolerance=1e-30)
    assert not strict.found
    assert strict.status == "inaccurate"
    assert strict.residual == loose.residual
    assert strict.residual > strict.tolerance
    # enumeration applies the same check to every support and so finds nothing at all
    assert solve_lcp(M, q, "enumerate", tolerance=1e-30).status == "infeasible"


def test_enumeration_lists_non_isolated_solutions() -> None:
    # lcp_CPS_1: the solution set is {z1 + z2 = 1}; supports {1}, {2} and the singular {1, 2}
    M, q = read_siconos_lcp(LCP_DIR / "lcp_CPS_1.dat")
    solutions = enumerate_lcp_solutions(M, q)
    zs = sorted(tuple(np.round(s.z, 12)) for s in solutions)
    assert zs == [(0.0, 1.0), (0.5, 0.5), (1.0, 0.0)]
    singular = [s for s in solutions if "singular" in s.note]
    assert len(singular) == 1
    np.testing.assert_allclose(singular[0].z, [0.5, 0.5])
    for s in solutions:
        check_solution(M, q, s)


def test_singular_support_needs_a_linear_program() -> None:
    # Solutions: z = (0, 0, t) for t >= 1, all on singular supports ({2} has block [0]); every
    # minimum-norm point is infeasible, so enumeration must find the vertex t = 1 another way.
    # Lemke ends on a ray here: a ray is "no solution found", not a proof that none exists.
    M = np.array([[-1.0, 1.0, 1.0], [1.0, -1.0, 1.0], [-1.0, 0.0, 0.0]])
    q = np.array([0.0, -1.0, 0.0])
    (solution,) = enumerate_lcp_solutions(M, q)
    check_solution(M, q, solution)
    np.testing.assert_allclose(solution.z, [0.0, 0.0, 1.0], atol=1e-9)
    assert "linear programming" in solution.note
    lemke = solve_lcp(M, q)
    assert lemke.status == "ray" and not lemke.found


def test_enumerate_method_returns_first_enumerated_solution() -> None:
    M, q = read_siconos_lcp(LCP_DIR / "lcp_CPS_2.dat")
    solutions = enumerate_lcp_solutions(M, q)
    first = solve_lcp(M, q, "enumerate")
    np.testing.assert_array_equal(first.z, solutions[0].z)
    assert first.pivots == solutions[0].pivots


def test_enumeration_deduplicates() -> None:
    # z = 0 solves it and is found on every support containing index 2 (z2 = 0 there).
    M = np.array([[1.0, 0.0], [0.0, 1.0]])
    q = np.array([1.0, 0.0])
    solutions = enumerate_lcp_solutions(M, q)
    assert len(solutions) == 1
    np.testing.assert_array_equal(solutions[0].z, [0.0, 0.0])


# --------------------------------------------------------------------------------------------
# The Siconos corpus
# --------------------------------------------------------------------------------------------

# (file, method) -> expected outcome:
#   "solved"     found, residual <= tolerance, Siconos error <= 1e-5
#   "ray"        Lemke's secondary ray, nothing reported found
#   "infeasible" enumeration proved there is no solution
#   "too_large"  enumeration refuses n > ENUMERATION_MAX_SIZE with InputError
LCP_EXPECTED = {
    ("lcp_CPS_1.dat", "lemke"): "solved",
    ("lcp_CPS_1.dat", "enumerate"): "solved",
    ("lcp_CPS_2.dat", "lemke"): "solved",
    ("lcp_CPS_2.dat", "enumerate"): "solved",
    ("lcp_CPS_3.dat", "lemke"): "ray",  # bimatrix game: Siconos marks Lemke as failing
    ("lcp_CPS_3.dat", "enumerate"): "solved",  # the game has an equilibrium
    ("lcp_CPS_4.dat", "lemke"): "solved",
    ("lcp_CPS_4.dat", "enumerate"): "solved",
    ("lcp_CPS_4bis.dat", "lemke"): "solved",
    ("lcp_CPS_4bis.dat", "enumerate"): "solved",
    ("lcp_CPS_5.dat", "lemke"): "solved",
    ("lcp_CPS_5.dat", "enumerate"): "solved",
    ("lcp_Pang_isolated_sol.dat", "lemke"): "solved",
    ("lcp_Pang_isolated_sol.dat", "enumerate"): "solved",
    ("lcp_Pang_isolated_sol_perturbed.dat", "lemke"): "ray",  # no solution exists
    ("lcp_Pang_isolated_sol_perturbed.dat", "enumerate"): "infeasible",
    ("lcp_deudeu.dat", "lemke"): "solved",
    ("lcp_deudeu.dat", "enumerate"): "solved",
    ("lcp_deudeu_block.dat", "lemke"): "solved",
    ("lcp_deudeu_block.dat", "enumerate"): "solved",
    ("lcp_enum_fails.dat", "lemke"): "solved",
    ("lcp_enum_fails.dat", "enumerate"): "solved",
    ("lcp_exp_murty.dat", "lemke"): "solved",
    ("lcp_exp_murty.dat", "enumerate"): "solved",
    ("lcp_exp_murty2.dat", "lemke"): "solved",
    ("lcp_exp_murty2.dat", "enumerate"): "solved",
    ("lcp_inf_sol_perturbed.dat", "lemke"): "solved",
    ("lcp_inf_sol_perturbed.dat", "enumerate"): "solved",
    ("lcp_mmc.dat", "lemke"): "solved",
    ("lcp_mmc.dat", "enumerate"): "too_large",  # n = 26
    ("lcp_ortiz.dat", "lemke"): "solved",
    ("lcp_ortiz.dat", "enumerate"): "solved",
    ("lcp_ortiz_block.dat", "lemke"): "solved",
    ("lcp_ortiz_block.dat", "enumerate"): "solved",
    ("lcp_tobenna.dat", "lemke"): "solved",  # 32 zeros in q: cycles without the lexico rule
    ("lcp_tobenna.dat", "enumerate"): "too_large",  # n = 40
    ("lcp_trivial.dat", "lemke"): "solved",
    ("lcp_trivial.dat", "enumerate"): "solved",
    ("lcp_trivial_block.dat", "lemke"): "solved",
    ("lcp_trivial_block.dat", "enumerate"): "solved",
}


def test_table_covers_every_file_and_method() -> None:
    files = {p.name for p in LCP_DIR.glob("*.dat")}
    assert set(LCP_EXPECTED) == set(itertools.product(files, METHODS))


@pytest.mark.parametrize(("name", "method"), sorted(LCP_EXPECTED))
def test_siconos_lcp(name: str, method: str) -> None:
    M, q = read_siconos_lcp(LCP_DIR / name)
    expected = LCP_EXPECTED[(name, method)]
    if expected == "too_large":
        assert len(q) > ENUMERATION_MAX_SIZE
        with pytest.raises(InputError, match="too large to enumerate"):
            solve_lcp(M, q, method)
        return
    result = solve_lcp(M, q, method)
    assert result.method == method
    assert result.status == expected
    if expected == "solved":
        check_solution(M, q, result)
        assert siconos_lcp_error(M, q, result.z) <= SICONOS_TOLERANCE
    else:
        assert not result.found
        assert result.z is None
        assert result.residual == np.inf


def test_siconos_murty_needs_2_to_the_n_pivots() -> None:
    M, q = read_siconos_lcp(LCP_DIR / "lcp_exp_murty2.dat")
    assert solve_lcp(M, q).pivots == 2**6


def test_pang_isolated_solution() -> None:
    M, q = read_siconos_lcp(LCP_DIR / "lcp_Pang_isolated_sol.dat")
    for method in METHODS:
        np.testing.assert_allclose(solve_lcp(M, q, method).z, [1.0, 0.0, 0.0], atol=1e-12)


@pytest.mark.parametrize("stem", ["lcp_deudeu", "lcp_ortiz", "lcp_trivial"])
def test_dense_and_block_files_agree(stem: str) -> None:
    M_dense, q_dense = read_siconos_lcp(LCP_DIR / f"{stem}.dat")
    M_block, q_block = read_siconos_lcp(LCP_DIR / f"{stem}_block.dat")
    # the block files print values with 7 significant digits
    np.testing.assert_allclose(M_block, M_dense, rtol=1e-6, atol=0)
    np.testing.assert_array_equal(q_block, q_dense)


def test_dense_file_is_column_major() -> None:
    M, q = read_siconos_lcp(LCP_DIR / "lcp_ortiz.dat")
    # the first text line of the matrix is its first column
    np.testing.assert_array_equal(M[:, 0], [3.0, -1.0, 0.0, 0.0])
    np.testing.assert_array_equal(M[0, :], [3.0, 1.0, 0.0, -1.0])
    np.testing.assert_array_equal(q, [-2.0, 1.0, -1.0, 1.0])


# --------------------------------------------------------------------------------------------
# Agreement between the solvers
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(30))
def test_lemke_matches_enumeration_on_p_matrices(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 7))
    A = rng.normal(size=(n, n))
    S = rng.normal(size=(n, n))
    M = A @ A.T + 0.1 * np.eye(n) + (S - S.T)  # positive definite, so a P-matrix
    q = rng.normal(size=n)
    solutions = enumerate_lcp_solutions(M, q)
    assert len(solutions) == 1
    lemke = solve_lcp(M, q)
    check_solution(M, q, lemke)
    np.testing.assert_allclose(lemke.z, solutions[0].z, atol=1e-9)


def test_lemke_solutions_are_enumerated_for_general_matrices() -> None:
    rng = np.random.default_rng(12345)
    found = 0
    for _ in range(60):
        n = int(rng.integers(1, 6))
        M = rng.normal(size=(n, n))
        q = rng.normal(size=n)
        solutions = enumerate_lcp_solutions(M, q)
        lemke = solve_lcp(M, q)
        if not solutions:
            assert not lemke.found
            continue
        if lemke.found:
            found += 1
            check_solution(M, q, lemke)
            assert any(np.allclose(lemke.z, s.z, atol=1e-8) for s in solutions)
    assert found >= 20  # the comparison is not vacuous


# --------------------------------------------------------------------------------------------
# Properties
# --------------------------------------------------------------------------------------------

# multiples of 1e-3 in [-10, 10]: no tiny entries, so z and w stay far from overflow
entries = st.floats(min_value=-10, max_value=10, allow_nan=False).map(lambda x: round(x, 3))


@st.composite
def lcps(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, bool]:
    """An LCP (M, q) and whether a solution was planted in it.

    Half of the draws (hypothesis's coin) plant one: a z >= 0 and a w >= 0 with complementary
    supports, and q = w - M z, so (z, w) solves it. The other half draw q freely, and about half of
    those have a solution: about three quarters in all, well above the test's floor of checked
    examples (MIN_CHECKED_FRACTION) for any seed, while the free half keeps the no-solution branch.
    """
    n = draw(st.integers(min_value=1, max_value=4))
    M = np.array(draw(st.lists(entries, min_size=n * n, max_size=n * n))).reshape(n, n)
    if not draw(st.booleans()):
        return M, np.array(draw(st.lists(entries, min_size=n, max_size=n))), False
    sizes = st.lists(st.floats(min_value=0, max_value=10).map(lambda x: round(x, 3)), min_size=n, max_size=n)
    support = np.array(draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    z = np.where(support, draw(sizes), 0.0)
    w = np.where(support, 0.0, draw(sizes))
    return M, w - M @ z, True


@counted
@settings(max_examples=300, deadline=None)
@given(lcps())
def test_every_found_solution_is_a_solution(problem: tuple[np.ndarray, np.ndarray, bool]) -> None:
    tally().example()
    M, q, planted = problem
    every = enumerate_lcp_solutions(M, q)
    results = [solve_lcp(M, q, "lemke"), solve_lcp(M, q, "enumerate"), *every]
    if not every:  # the enumeration is exhaustive: no solution there means none anywhere
        assert not planted, "the enumeration missed the planted solution"
        assert not any(r.found for r in results[:2])
    else:
        tally().check()  # a solution exists: every one found is checked below
    for result in results:
        assert result.found == (result.status == "solved")
        if result.found:
            check_solution(M, q, result)
        elif result.z is None:
            assert result.status in ("ray", "max_pivots", "infeasible")


# --------------------------------------------------------------------------------------------
# 2-D frictional contact
# --------------------------------------------------------------------------------------------


def read_expected() -> dict[str, dict[str, list[float | None]]]:
    """Parse EXPECTED.txt: ``name.dat`` then ``r = [...]`` and ``u = [...]`` (``~0`` -> None)."""
    expected: dict[str, dict[str, list[float | None]]] = {}
    current = None
    for line in (FC2D_DIR / "EXPECTED.txt").read_text().splitlines():
        header = re.match(r"^(FC2D_\S+\.dat)", line)
        if header:
            current = header.group(1)
            expected[current] = {}
            continue
        vector = re.match(r"^\s+([ru]) = \[([^\]]*)\]", line)
        if vector and current:
            values = [None if v.strip() == "~0" else float(v) for v in vector.group(2).split(",")]
            expected[current][vector.group(1)] = values
    return expected


EXPECTED_FC2D = read_expected()
# EXPECTED.txt prints 10 decimal places: agree to one unit in the last place
FC2D_ATOL = 1e-10


def test_expected_file_parsed() -> None:
    assert set(EXPECTED_FC2D) == {
        "FC2D_SliderCrankLagrangian00000.dat",
        "FC2D_SliderCrankLagrangian00001.dat",
    }
    for values in EXPECTED_FC2D.values():
        assert len(values["r"]) == 4 and len(values["u"]) == 4


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", sorted(EXPECTED_FC2D))
def test_slider_crank_matches_expected(name: str, method: str) -> None:
    problem = read_siconos_fc2d(FC2D_DIR / name)
    assert problem.number_of_contacts == 2
    result = solve_fc2d(problem, method)
    assert result.found and result.status == "solved"
    assert result.residual <= FC2D_TOLERANCE
    assert fc2d_error(problem, result.r) == pytest.approx(result.residual)
    expected = EXPECTED_FC2D[name]
    np.testing.assert_allclose(result.r, expected["r"], rtol=0, atol=FC2D_ATOL)
    scale = np.max(np.abs(problem.q))
    for computed, reference in zip(result.u, expected["u"], strict=True):
        if reference is None:
            assert abs(computed) <= 1e-9 * scale
        else:
            assert computed == pytest.approx(reference, rel=0, abs=FC2D_ATOL)
    # both contacts slide: r_t = mu r_n, opposite to u_t < 0
    np.testing.assert_allclose(result.r[1::2], problem.mu * result.r[0::2], rtol=1e-9)


# (file, method) -> expected outcome for the problems without a reference solution
FC2D_EXPECTED = {
    ("FrictionContactProblem00031.dat", "lemke"): "solved",
    ("FrictionContactProblem00031.dat", "enumerate"): "too_large",  # 4 nc = 44 unknowns
    ("FrictionContactProblem00394.dat", "lemke"): "solved",
    ("FrictionContactProblem00394.dat", "enumerate"): "too_large",  # 4 nc = 24 unknowns
}


@pytest.mark.parametrize(("name", "method"), sorted(FC2D_EXPECTED))
def test_friction_contact_problems(name: str, method: str) -> None:
    problem = read_siconos_fc2d(FC2D_DIR / name)
    if FC2D_EXPECTED[(name, method)] == "too_large":
        with pytest.raises(InputError, match="too large to enumerate"):
            solve_fc2d(problem, method)
        return
    result = solve_fc2d(problem, method)
    assert result.found and result.status == "solved"
    assert result.residual <= FC2D_TOLERANCE
    r_n, r_t = result.r[0::2], result.r[1::2]
    u_n = result.u[0::2]
    tol = 1e-9 * max(1.0, np.max(np.abs(result.r)))
    assert np.all(r_n >= -tol) and np.all(u_n >= -tol)
    assert np.all(np.abs(r_t) <= problem.mu * r_n + tol)


def test_fc2d_sparse_block_file() -> None:
    problem = read_siconos_fc2d(FC2D_DIR / "FrictionContactProblem00031.dat")
    assert problem.number_of_contacts == 11
    np.testing.assert_allclose(problem.W, problem.W.T, atol=1e-15)
    # block 7 sits at block row 6, block column 10 (column-major inside the block)
    np.testing.assert_allclose(
        problem.W[12:14, 20:22], [[-1.921399e-01, 1.180736e-01], [-1.180736e-01, 2.588994e-01]]
    )
    np.testing.assert_array_equal(problem.mu, np.full(11, 0.9))


# --------------------------------------------------------------------------------------------
# Bad input
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("M", "q", "message"),
    [
        ([[1.0, 2.0]], [1.0], "square"),
        ([[1.0, 2.0], [3.0, 4.0]], [1.0], "shape"),
        ([[1.0, np.nan], [3.0, 4.0]], [1.0, 2.0], "NaN"),
        ([[1.0, 0.0], [0.0, 1.0]], [np.inf, 2.0], "NaN or infinite"),
        ([[1.0, "a"], [0.0, 1.0]], [1.0, 1.0], "numeric"),
    ],
)
@pytest.mark.parametrize("method", METHODS)
def test_malformed_input(M: object, q: object, message: str, method: str) -> None:
    with pytest.raises(InputError, match=message):
        solve_lcp(M, q, method)
    with pytest.raises(InputError, match=message):
        enumerate_lcp_solutions(M, q)


def test_unknown_method_and_bad_options() -> None:
    with pytest.raises(InputError, match="unknown LCP method"):
        solve_lcp([[1.0]], [-1.0], "pivot")
    with pytest.raises(InputError, match="max_pivots"):
        solve_lcp([[1.0]], [-1.0], max_pivots=0)
    with pytest.raises(InputError, match="tolerance"):
        solve_lcp([[1.0]], [-1.0], tolerance=-1.0)


def test_enumeration_size_guard() -> None:
    n = ENUMERATION_MAX_SIZE + 1
    M, q = np.eye(n), -np.ones(n)
    with pytest.raises(InputError, match=f"n = {n} is too large to enumerate"):
        enumerate_lcp_solutions(M, q)
    # raising the limit explicitly is allowed; the solution has support {0}, the 2nd one tried
    q = np.ones(n)
    q[0] = -1.0
    result = solve_lcp(M, q, "enumerate", max_size=n)
    assert result.pivots == 2
    np.testing.assert_allclose(result.z, np.eye(n)[0])


GOOD_DENSE = "2\n0\n2\n2\n2\t2\n2 1\n1 2\n-5 -6\n"


@pytest.mark.parametrize(
    ("text", "line", "message"),
    [
        ("2\n0\n2\n2\n2\t2\n2 1\n1 x\n-5 -6\n", 7, "expected dense matrix"),
        ("2\n0\n2\n2\n2\t2\n2 1\n1 2\n-5\n", 8, "unexpected end of file"),
        ("2\n7\n2\n2\n", 2, "unsupported matrix storage type 7"),
        ("3\n0\n2\n2\n2\t2\n2 1\n1 2\n-5 -6\n", 1, "does not match"),
        ("2\n0\n2\n2\n2\t3\n", 5, "dense matrix column count"),
        ("two\n", 1, "problem size"),
        ("2\n0\n2\n2\n2\t2\n2 1\n1 nan\n-5 -6\n", 7, "not finite"),
        # sparse block: the block number must count 0, 1, ...
        ("2\n1\n2\n2\n1\n1\n1\n2\n2\n2\n1\n0 1\n0\n5\n2\n1\n1\n2\n-5 -6\n", 14, "block number"),
    ],
)
def test_malformed_lcp_file(tmp_path: Path, text: str, line: int, message: str) -> None:
    path = tmp_path / "bad.dat"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as info:
        read_siconos_lcp(path)
    assert str(path) in str(info.value)
    assert f"line {line}:" in str(info.value)


def test_good_minimal_file_reads(tmp_path: Path) -> None:
    path = tmp_path / "good.dat"
    path.write_text(GOOD_DENSE)
    M, q = read_siconos_lcp(path)
    np.testing.assert_array_equal(M, [[2.0, 1.0], [1.0, 2.0]])
    np.testing.assert_array_equal(q, [-5.0, -6.0])


def test_malformed_fc2d_file(tmp_path: Path) -> None:
    path = tmp_path / "bad_fc.dat"
    path.write_text("3\n1\n0\n3\n3\n3 3\n")
    with pytest.raises(InputError, match=r"line 1: expected problem dimension = 2"):
        read_siconos_fc2d(path)
    path.write_text("2\n1\n0\n2\n2\n2 2\n1 0\n0 1\n-1 0\n-0.5\n")
    with pytest.raises(InputError, match="line 10: negative friction coefficient"):
        read_siconos_fc2d(path)


def test_missing_file() -> None:
    with pytest.raises(InputError, match="cannot read"):
        read_siconos_lcp(LCP_DIR / "no_such_file.dat")


def test_friction_problem_validation() -> None:
    with pytest.raises(InputError, match="W must have shape"):
        FrictionContact2D(W=np.eye(3), q=np.zeros(2), mu=np.ones(1), number_of_contacts=1)
    with pytest.raises(InputError, match="NaN"):
        FrictionContact2D(
            W=np.eye(2), q=np.array([np.nan, 0.0]), mu=np.ones(1), number_of_contacts=1
        )
    problem = FrictionContact2D(W=np.eye(2), q=np.zeros(2), mu=np.ones(1), number_of_contacts=1)
    with pytest.raises(InputError, match="unknown LCP method"):
        solve_fc2d(problem, "nsgs")


# --------------------------------------------------------------------------------------------
# Enumeration at extreme friction
# --------------------------------------------------------------------------------------------

# An independent acceptance check, scaled by the problem's data alone (never by the candidate)
DATA_CHECK = 1e-8


def check_by_the_data(M: np.ndarray, q: np.ndarray, z: np.ndarray) -> None:
    """``z >= 0``, ``w = M z + q >= 0`` and ``min(z, w) = 0`` to ``DATA_CHECK * ||q||_inf``."""
    bound = DATA_CHECK * np.max(np.abs(q))
    w = M @ z + q
    assert np.min(z) >= -bound, f"z has an entry {np.min(z):.6g} < 0"
    assert np.min(w) >= -bound, f"w has an entry {np.min(w):.6g} < 0"
    assert np.max(np.abs(np.minimum(z, w))) <= bound


def reactions(z: np.ndarray, nc: int) -> np.ndarray:
    """``r = (r_n, r_t+ - r_t-)`` per contact from an LCP solution of :func:`fc2d_to_lcp`."""
    r = np.empty(2 * nc)
    r[0::2], r[1::2] = z[:nc], z[nc:2 * nc] - z[2 * nc:3 * nc]
    return r


@pytest.mark.parametrize("mu", [1e6, 1e7, 1e8, 1e10])
@pytest.mark.parametrize("name", sorted(EXPECTED_FC2D))
def test_slider_crank_enumeration_at_extreme_friction(name: str, mu: float) -> None:
    """Every enumerated solution is one by a check the candidate cannot loosen, and the set holds
    the reactions of the same problem at mu = 1e3 (both contacts then stick: mu no longer
    matters) and of ``solve_fc2d``. Before the check was scaled by the data, 2 of 6 solutions at
    mu = 1e7 and 1e8 had a tangential force of -11.7 on a contact without normal force."""
    base = read_siconos_fc2d(FC2D_DIR / name)
    problem = FrictionContact2D(base.W, base.q, np.full(2, mu), 2)
    M, q = fc2d_to_lcp(problem)
    solutions = enumerate_lcp_solutions(M, q)
    assert solutions
    for solution in solutions:
        assert solution.found and solution.residual <= solution.tolerance
        check_by_the_data(M, q, solution.z)
    moderate = FrictionContact2D(base.W, base.q, np.full(2, 1e3), 2)
    (r_moderate, *_) = {tuple(reactions(s.z, 2)) for s in enumerate_lcp_solutions(*fc2d_to_lcp(moderate))}
    scale = np.max(np.abs(r_moderate))
    for solution in solutions:  # one physical solution, however its friction is split
        np.testing.assert_allclose(reactions(solution.z, 2), r_moderate, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(solve_fc2d(problem).r, r_moderate, rtol=0, atol=1e-6 * scale)


@pytest.mark.parametrize("mu", [1e8, 1e10])
def test_rod_enumeration_at_extreme_friction(mu: float, tmp_path: Path) -> None:
    """The leaning rod at rest (Painleve's rod, the closed form in extreme_cases): every solution
    of its contact LCP passes the data-scaled check, and the closed form is among them."""
    from extreme_cases import rod, rod_at_rest

    from frcontrol.contact_lcp import all_contact_lcp_solutions, build_contact_lcp
    from frcontrol.modes import ContactProblem

    problem = ContactProblem.from_scene(rod(tmp_path, "rod", mu=mu))
    lcp = build_contact_lcp(problem, np.zeros(3))
    solutions = enumerate_lcp_solutions(lcp.W, lcp.b)
    assert solutions
    for solution in solutions:
        check_by_the_data(lcp.W, lcp.b, solution.z)
    mode, dv, lam_n, lam_t = rod_at_rest(mu)
    (only,) = all_contact_lcp_solutions(problem, np.zeros(3))
    assert only.mode == mode
    np.testing.assert_allclose(only.x, np.concatenate([dv, [lam_n, lam_t]]), rtol=1e-7, atol=1e-9)
