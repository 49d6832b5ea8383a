"""The analysis's fast paths against the paths they short-cut, on random problems and shipped scenes.

- :func:`frcontrol.response.certified_responses` (one stacked QR, no SVD) against
  :func:`frcontrol.response.solve_affine`: the same rank decisions, the same ``X_u`` and ``x_0``,
  a null-space basis that is a rotation of the SVD's, hence the same motion margins;
- the consistency rows decided without their SVD against the SVD;
- :func:`frcontrol.engine.analyze` with the certified children against the SVD for every mode:
  the same modes, verdicts and counts, and the same responses and domains to round-off, w up to
  an orthogonal map (a certified mode reports its certificate's basis of the null space);
- a minimal representation that reuses its caller's Chebyshev ball against one that solves it;
- the cached row labels and the domain rows against the formulas they replace.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import needs_kernel
from test_mode_batch import SCENES, random_problem

from frcontrol import engine, geometry
from frcontrol import polytope as poly
from frcontrol import response as resp
from frcontrol.engine import analyze, domain_polytope, motion_margin
from frcontrol.modes import (
    ROWS_PER_CONTACT,
    ContactProblem,
    all_modes,
    build_child_systems,
    build_mode_system,
    extend_child_systems,
)
from frcontrol.scene import load_scene

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:  # the benchmarks beside the package; the checkout LAST (see test_peers)
    sys.path.append(str(REPO))
from benchmarks.contacts import snake_scene  # noqa: E402

RTOL = 1e-8
"""Relative agreement of two factorisations' responses (round-off of a 30 x 30 solve)."""

ROUND_OFF = 1e-12
"""Agreement of two factorisations' responses, relative to their size and per unit of the condition
number: about 4,500 machine epsilons (the largest seen on the suite's analyses: 1.1e-15)."""


def _random_stack(rng: np.random.Generator, count: int, rows: int, nx: int, m: int, deficient: bool
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    A = rng.normal(size=(count, rows, nx)) * np.exp2(rng.integers(-6, 7, size=(count, rows, 1)))
    if deficient and rows > 1:  # a row repeated (scaled): rank rows - 1
        A[:, -1] = 3.0 * A[:, 0]
    return A, rng.normal(size=(count, rows, m)), rng.normal(size=(count, rows))


def _null_projector(X_w: np.ndarray, c_scale: np.ndarray) -> np.ndarray:
    basis = X_w / c_scale[:, None]  # the orthonormal basis of null(A_hat)
    return basis @ basis.T


def test_certified_responses_are_the_svds():
    rng = np.random.default_rng(20261125)
    certified = refused = 0
    for _ in range(60):
        nx = int(rng.integers(2, 12))
        rows = int(rng.integers(1, nx + 1))
        m = int(rng.integers(0, 4))
        deficient = bool(rng.random() < 0.3)
        A, B, c = _random_stack(rng, int(rng.integers(1, 5)), rows, nx, m, deficient)
        for i, fast in enumerate(resp.certified_responses(A, B, c)):
            svd = resp.solve_affine(A[i], B[i], c[i])
            if fast is None:
                refused += 1
                continue
            certified += 1
            assert not deficient or rows == 1
            assert (fast.rank, fast.case, fast.consistent, fast.E.shape, fast.certified) == (
                svd.rank, svd.case, svd.consistent, svd.E.shape, True)
            assert fast.condition_number >= svd.condition_number * (1 - RTOL)  # an upper bound
            scale = 1.0 + np.abs(svd.X_u).max(initial=0.0) + np.abs(svd.x_0).max()
            np.testing.assert_allclose(fast.X_u, svd.X_u, rtol=0, atol=RTOL * scale)
            np.testing.assert_allclose(fast.x_0, svd.x_0, rtol=0, atol=RTOL * scale)
            _, c_scale = resp._equilibrate(A[i])
            np.testing.assert_allclose(_null_projector(fast.X_w, c_scale), _null_projector(svd.X_w, c_scale),
                                       atol=1e-10)
    assert certified > 50 and refused > 10  # both sides of the certificate were exercised


def test_rank_deficient_and_nearly_singular_systems_are_not_certified():
    rng = np.random.default_rng(7)
    A, B, c = _random_stack(rng, 3, 6, 8, 2, deficient=True)
    assert resp.certified_responses(A, B, c) == [None, None, None]
    A = rng.normal(size=(1, 5, 5))
    A[0, 4] = A[0, 3] + 1e-9 * rng.normal(size=5)  # s_min ~ 1e-9 s_max: inside the band's margin
    assert resp.certified_responses(A, rng.normal(size=(1, 5, 1)), rng.normal(size=(1, 5))) == [None]
    wide = np.zeros((2, 4, 3))  # more rows than unknowns: never certified
    assert resp.certified_responses(wide, np.zeros((2, 4, 1)), np.zeros((2, 4))) == [None, None]


def test_certified_and_svd_domains_have_the_same_motion_margins():
    """Distances in (u, w) do not see a rotation of w: the engine's LP gives the same verdict and t."""
    rng = np.random.default_rng(3)
    compared = 0
    for _ in range(25):
        problem = random_problem(rng)
        for mode in all_modes(problem.allowed_modes())[:12]:
            for prefix in (mode[:-1], mode):
                if not prefix:
                    continue
                system = build_mode_system(problem, prefix)
                fast = resp.certified_responses(system.A[None], system.B[None], system.c[None])[0]
                if fast is None:
                    continue
                svd = resp.solve_affine(system.A, system.B, system.c)
                answers = []
                for response in (fast, svd):
                    P, motion = domain_polytope(problem, system, response)
                    answers.append(motion_margin(P.A, P.b, motion, P.A_eq, P.b_eq))
                assert answers[0].verdict == answers[1].verdict
                if answers[0].margin is not None:
                    assert answers[0].margin == pytest.approx(answers[1].margin, abs=1e-7)
                compared += 1
    assert compared > 40


def _svd_consistency(monkeypatch: pytest.MonkeyPatch, A: np.ndarray, B: np.ndarray, c: np.ndarray
                     ) -> resp.AffineSolution:
    with monkeypatch.context() as patch:
        patch.setattr(resp, "_void_conditions", lambda *args: False)  # always the SVD of E_raw
        return resp.solve_affine(A, B, c)


def test_void_consistency_rows_are_decided_as_their_svd_decides(monkeypatch):
    rng = np.random.default_rng(11)
    shortcut = 0
    for _ in range(80):
        rows, nx, m = int(rng.integers(2, 8)), int(rng.integers(2, 8)), int(rng.integers(0, 3))
        A = rng.normal(size=(rows, nx))
        A[-1] = A[0] * 2.0  # a dependent row: a left null vector
        B = rng.normal(size=(rows, m))
        c = rng.normal(size=rows)
        kind = rng.integers(3)
        if kind == 0:  # B and c in the range of A: the consistency rows vanish
            B[-1], c[-1] = 2.0 * B[0], 2.0 * c[0]
        elif kind == 1:  # only c off the range: inconsistent for every input
            B[-1] = 2.0 * B[0]
        fast = resp.solve_affine(A, B, c)
        svd = _svd_consistency(monkeypatch, A, B, c)
        shortcut += kind == 0
        assert (fast.consistent, fast.E.shape, fast.rank) == (svd.consistent, svd.E.shape, svd.rank)
        np.testing.assert_array_equal(fast.X_u, svd.X_u)
        if fast.E.shape[0]:
            np.testing.assert_array_equal(fast.E, svd.E)
            np.testing.assert_array_equal(fast.e, svd.e)
    assert shortcut > 10


def _svd_only(monkeypatch: pytest.MonkeyPatch, problem):
    with monkeypatch.context() as patch:
        patch.setattr(engine, "certified_children", lambda A, B, c, rank_tolerance, kernel: [None] * len(A))
        return analyze(problem, ambiguity=False)


def _w_map(a: resp.AffineSolution, b: resp.AffineSolution, A: np.ndarray) -> np.ndarray:
    """The orthogonal map ``Q`` with ``a.X_w = b.X_w Q`` (to round-off), checked; ``A`` the mode's system.

    Both bases are orthonormal in the scaled unknowns (the scalings of :func:`solve_affine`), so
    ``Q`` is the product of the two scaled bases.
    """
    _, c_scale = resp._equilibrate(A)
    basis_a, basis_b = a.X_w / c_scale[:, None], b.X_w / c_scale[:, None]
    Q = basis_b.T @ basis_a
    tolerance = ROUND_OFF * max(1.0, b.condition_number)
    np.testing.assert_allclose(Q.T @ Q, np.eye(Q.shape[1]), rtol=0, atol=tolerance)
    np.testing.assert_allclose(basis_b @ Q, basis_a, rtol=0, atol=tolerance)
    return Q


def _assert_same_response(a: resp.AffineSolution, b: resp.AffineSolution, A: np.ndarray) -> np.ndarray:
    """``a`` is ``b`` to round-off, its w in another orthonormal basis; returns the map of w."""
    assert (a.rank, a.case, a.consistent, a.E.shape, a.X_w.shape) == (b.rank, b.case, b.consistent, b.E.shape,
                                                                       b.X_w.shape)
    scale = 1.0 + np.abs(b.X_u).max(initial=0.0) + np.abs(b.x_0).max(initial=0.0)
    tolerance = ROUND_OFF * max(1.0, b.condition_number) * scale
    np.testing.assert_allclose(a.X_u, b.X_u, rtol=0, atol=tolerance)
    np.testing.assert_allclose(a.x_0, b.x_0, rtol=0, atol=tolerance)
    if a.E.shape[0]:
        np.testing.assert_allclose(np.abs(a.E.T @ a.E), np.abs(b.E.T @ b.E), rtol=0, atol=tolerance)
    return _w_map(a, b, A)


def _unit_rows(P: poly.Polytope, Q: np.ndarray | None = None, m: int = 0) -> np.ndarray:
    """``P``'s rows ``[A | b]`` divided by their norms; with ``Q``, its w columns (after ``m``
    inputs) mapped by ``Q`` first."""
    A = P.A.copy()
    if Q is not None:
        A[:, m:] = A[:, m:] @ Q
    return np.hstack([A, P.b[:, None]]) / np.linalg.norm(A, axis=1)[:, None]


def _assert_same_set(P: poly.Polytope, R: poly.Polytope, tolerance: float, Q: np.ndarray | None = None,
                     m: int = 0) -> None:
    """Two minimal forms of one polytope: the same unit rows, one for one, in any order (``R``'s w
    mapped by ``Q``)."""
    assert P.A.shape == R.A.shape and P.A_eq.shape == R.A_eq.shape
    if not P.A.shape[0]:
        return
    ours, theirs = _unit_rows(P), _unit_rows(R, Q, m)
    distance = np.abs(ours[:, None, :] - theirs[None, :, :]).max(axis=2)
    nearest = distance.argmin(axis=1)
    assert sorted(nearest.tolist()) == list(range(len(theirs)))  # one for one
    assert distance.min(axis=1).max(initial=0.0) <= tolerance


def _assert_same_mode(a: engine.ModeAnalysis, b: engine.ModeAnalysis) -> None:
    """Two analyses of one feasible mode: the same response and domain up to an orthogonal map of w.

    D_c's rows over (u, w) are ``b``'s with their w columns mapped, to round-off, in its raw and
    its minimal form; its Chebyshev radius, whether it (and T_c) has an interior, and T_c are the same.
    """
    Q = _assert_same_response(a.response, b.response, a.system.A)
    m = a.m
    P, R = a.raw_domain, b.raw_domain
    scale = 1.0 + np.abs(R.A).max(initial=0.0) + np.abs(R.b).max(initial=0.0)
    tolerance = ROUND_OFF * max(1.0, b.response.condition_number) * scale
    np.testing.assert_allclose(P.A[:, :m], R.A[:, :m], rtol=0, atol=tolerance)
    np.testing.assert_allclose(P.A[:, m:], R.A[:, m:] @ Q, rtol=0, atol=tolerance)
    np.testing.assert_allclose(P.b, R.b, rtol=0, atol=tolerance)
    assert (a.full_dimensional, a.inputs_full_dimensional) == (b.full_dimensional, b.inputs_full_dimensional)
    assert a.chebyshev_radius == pytest.approx(b.chebyshev_radius, rel=RTOL, abs=RTOL)
    _assert_same_set(a.domain, b.domain, RTOL, Q, m)
    if a.inputs_full_dimensional:
        _assert_same_set(a.input_domain, b.input_domain, RTOL)


def _assert_same_analysis(fast, slow) -> None:
    assert fast.to_dict()["enumeration"] == slow.to_dict()["enumeration"]
    assert [(m.mode, m.feasible, m.pruned, m.response.case, m.response.rank) for m in fast.modes] == [
        (m.mode, m.feasible, m.pruned, m.response.case, m.response.rank) for m in slow.modes]
    for a, b in zip(fast.feasible_modes, slow.feasible_modes, strict=True):
        _assert_same_mode(a, b)


def test_analysis_with_certified_children_is_the_svds_on_random_problems(monkeypatch):
    rng = np.random.default_rng(20261126)
    certified = 0
    for _ in range(30):
        problem = random_problem(rng)
        fast = analyze(problem, ambiguity=False)
        certified += sum(m.response.certified for m in fast.modes)
        _assert_same_analysis(fast, _svd_only(monkeypatch, problem))
    assert certified > 10


@pytest.mark.parametrize("name", ["rhex_flip", "snake_climb", "table_on_ground", "disk_in_wedge"])
def test_analysis_with_certified_children_is_the_svds_on_shipped_scenes(monkeypatch, name):
    problem = engine.ContactProblem.from_scene(load_scene(name))
    _assert_same_analysis(analyze(problem, ambiguity=False), _svd_only(monkeypatch, problem))


def test_minimal_form_with_the_callers_ball_is_the_same():
    rng = np.random.default_rng(5)
    for _ in range(30):
        d = int(rng.integers(1, 5))
        A = rng.normal(size=(int(rng.integers(d + 1, 12)), d))
        P = poly.Polytope(A, np.abs(rng.normal(size=A.shape[0])) + 0.1 * rng.random())
        if rng.random() < 0.3:
            P = poly.Polytope(P.A, P.b - 3.0)  # often empty
        ball = poly.chebyshev_ball(P)
        given, solved = poly.minimal_representation(P, ball=ball), poly.minimal_representation(P)
        for x, y in ((given.A, solved.A), (given.b, solved.b), (given.A_eq, solved.A_eq)):
            np.testing.assert_array_equal(x, y)


def test_row_labels_and_domain_rows_are_the_formulas_they_replace():
    rng = np.random.default_rng(9)
    for _ in range(10):
        problem = random_problem(rng)
        table = problem.row_table
        for mode in all_modes(problem.allowed_modes())[:8]:
            system = build_mode_system(problem, mode)
            letters = ["SLRF".index(ch) for ch in mode]
            expected = [f"{problem.contacts[i]}: {engine_labels(letter)[j]}"
                        for i, letter in enumerate(letters) for j in range(ROWS_PER_CONTACT)
                        if table.valid[i, letter, j]]
            assert list(system.labels) == expected
            response = resp.solve_affine(system.A, system.B, system.c)
            P, motion = domain_polytope(problem, system, response)
            C, d = problem.input_bound_rows()
            p = response.ambiguity_dim
            H = np.vstack([np.hstack([system.G @ response.X_u, system.G @ response.X_w]),
                           np.hstack([C, np.zeros((C.shape[0], p))])])
            np.testing.assert_array_equal(P.A, H.reshape(P.A.shape))
            np.testing.assert_array_equal(P.b, np.concatenate([system.g - system.G @ response.x_0, d]))
            np.testing.assert_array_equal(motion[:system.G.shape[0]], system.motion)
            assert not motion[system.G.shape[0]:].any()


def engine_labels(letter: int) -> tuple[str, ...]:
    """The labels of one letter's rows, as the contact-mode table of docs/maths.md writes them."""
    return (("a_N >= 0", "", ""), ("lam_N >= 0", "a_T <= 0", ""), ("lam_N >= 0", "a_T >= 0", ""),
            ("lam_N >= 0", "lam_T <= mu lam_N", "-lam_T <= mu lam_N"))[letter]


def test_children_built_together_are_the_modes_built_alone():
    """Children built in one gather (build_child_systems) and from their parent's system
    (extend_child_systems, as the enumeration builds them): each the mode built alone, bit for bit."""
    rng = np.random.default_rng(13)
    built = 0
    for trial in range(30):
        problem = (random_problem(rng) if trial % 2 else
                   ContactProblem.from_scene(load_scene(SCENES[trial // 2 % len(SCENES)])))
        allowed = problem.allowed_modes()
        assert problem.letter_row_counts is not None  # every letter's valid rows lead
        for depth in range(problem.k):
            prefix = "".join(str(rng.choice(list(letters))) for letters in allowed[:depth])
            parent = build_mode_system(problem, prefix)
            for together in (build_child_systems(problem, prefix, allowed[depth]),
                             extend_child_systems(problem, parent, allowed[depth])):
                assert together.A.flags.c_contiguous and together.A.shape[0] == len(together)
                for i, (letter, system) in enumerate(zip(allowed[depth], together, strict=True)):
                    assert np.shares_memory(system.A, together.A[i])
                    assert np.shares_memory(system.c, together.c[i])
                    np.testing.assert_array_equal(together.A[i], system.A)
                    alone = build_mode_system(problem, prefix + letter)
                    assert (system.mode, system.labels) == (alone.mode, alone.labels)
                    assert system.G.flags.c_contiguous and system.g.flags.c_contiguous  # the kernel reads
                    for name in ("A", "B", "c", "G", "g", "motion"):
                        np.testing.assert_array_equal(getattr(system, name), getattr(alone, name))
                        assert getattr(system, name).dtype == getattr(alone, name).dtype
                    built += 1
    assert built > 200


@needs_kernel
def test_compiled_certified_children_are_numpys_certified_responses(monkeypatch):
    """The kernel's Householder QR against NumPy's stacked QR on random stacks sharing B (some
    rank-deficient, some nearly singular, widely scaled rows): the same certificates (except within
    CERTIFIED_ROUND_OFF_BAND of the threshold), bounds, X_u, x_0 and null spaces to round-off."""
    from frcontrol.kernel import CERTIFIED_ROUND_OFF_BAND

    rng = np.random.default_rng(20261126)
    limit = 1.0 / (resp.CERTIFIED_MARGIN * max(resp.RANK_TOLERANCE, resp.ILL_CONDITIONED_BAND))
    certified = refused = 0
    for trial in range(150):
        nx = int(rng.integers(2, 30))
        rows = int(rng.integers(1, nx + 1))
        count, m = int(rng.integers(1, 6)), int(rng.integers(0, 9))
        A, B, c = _random_stack(rng, count, rows, nx, m, deficient=bool(rng.random() < 0.2))
        if trial % 5 == 0 and rows > 1:  # nearly dependent rows: bounds about the threshold
            A[:, -1] = A[:, 0] + 10.0 ** rng.uniform(-12, -5) * rng.normal(size=(count, nx))
        A[:, :, rng.random(nx) < 0.2] = 0.0  # zero columns: nothing to reflect
        shared = B[0]
        monkeypatch.setenv("FRC_KERNEL", "numpy")
        reference = resp.certified_children(A, shared, c)
        monkeypatch.setenv("FRC_KERNEL", "compiled")
        fast = resp.certified_children(A, shared, c)
        for i, (a, b) in enumerate(zip(fast, reference, strict=True)):
            if (a is None) != (b is None):
                kept = a if a is not None else b
                assert abs(kept.condition_number / limit - 1.0) <= CERTIFIED_ROUND_OFF_BAND
                continue
            if a is None:
                refused += 1
                continue
            certified += 1
            assert (a.rank, a.case, a.E.shape, a.X_w.shape, a.certified) == (b.rank, b.case, b.E.shape,
                                                                              b.X_w.shape, True)
            assert a.condition_number == pytest.approx(b.condition_number, rel=1e-9)
            scale = 1.0 + np.abs(b.X_u).max(initial=0.0) + np.abs(b.x_0).max()
            tolerance = 1e-15 * b.condition_number * scale
            np.testing.assert_allclose(a.X_u, b.X_u, rtol=0, atol=tolerance)
            np.testing.assert_allclose(a.x_0, b.x_0, rtol=0, atol=tolerance)
            _, c_scale = resp._equilibrate(A[i])
            np.testing.assert_allclose(_null_projector(a.X_w, c_scale), _null_projector(b.X_w, c_scale),
                                       atol=1e-15 * b.condition_number)
    assert certified > 150 and refused > 20  # both sides of the certificate were exercised


def test_analyze_is_the_same_on_both_kernels(monkeypatch):
    """The tree's compiled fast paths (certified children and rows, the motion LP's rows) against
    NumPy on scenes: the same modes, verdicts and counts, and the same responses and domains to
    round-off, w up to an orthogonal map (the two QRs sum in other orders)."""
    for scene in (load_scene("rhex_flip"), load_scene("snake_climb"), load_scene("table_on_ground"),
                  load_scene(snake_scene(6))):
        answers = []
        for kernel_name in ("numpy", "compiled") if resp.compiled is not None else ("numpy",):
            monkeypatch.setenv("FRC_KERNEL", kernel_name)
            answers.append(analyze(scene, ambiguity=False))
        for other in answers[1:]:
            _assert_same_analysis(other, answers[0])


def test_polytope_row_norms_and_near_pairs_are_the_library_calls_they_replace():
    """Bitwise: the row norms without np.linalg.norm's wrapper, and the near pairs without np.triu,
    on random unit rows with planted duplicates and opposites (and empty and one-row inputs)."""
    rng = np.random.default_rng(41)
    seen = 0
    for _ in range(200):
        m, d = int(rng.integers(0, 12)), int(rng.integers(1, 6))
        X = rng.normal(size=(m, d)) * 10.0 ** rng.uniform(-8, 8, size=(m, 1))
        assert np.array_equal(geometry.row_norms(X), np.linalg.norm(X, axis=1))
        unit = X / np.maximum(np.linalg.norm(X, axis=1), 1e-300)[:, None]
        if m > 2:
            unit[1], unit[2] = unit[0], -unit[0] * (1.0 + 1e-12)  # a duplicate and an opposite
        for sign in (1.0, -1.0):
            threshold = 1.0 - poly.DUPLICATE_TOLERANCE
            expected = np.argwhere(np.triu(sign * (unit @ unit.T) >= threshold, 1)).reshape(-1, 2)
            found = poly._near_pairs(unit, threshold, sign)
            assert found.shape == expected.shape and np.array_equal(found, expected)
            seen += found.shape[0]
    assert seen > 100


def test_projection_with_the_raw_forms_ball_is_the_same():
    """project(minimal D, ball of raw D) against project(minimal D): random redundant polytopes
    with equalities (the shape of a mode's D_c), some empty, some flat; bitwise the same T."""
    rng = np.random.default_rng(23)
    projected = 0
    for _ in range(60):
        d = int(rng.integers(2, 6))
        A = rng.normal(size=(int(rng.integers(d + 1, 14)), d))
        b = np.abs(rng.normal(size=A.shape[0])) + 0.1 * rng.random()
        A = np.vstack([A, 2.0 * A[:2]])  # redundant copies
        b = np.concatenate([b, 2.0 * b[:2] + rng.random(2)])
        A_eq = rng.normal(size=(int(rng.integers(0, 2)), d))
        raw = poly.Polytope(A, b - (3.0 if rng.random() < 0.2 else 0.0), A_eq, np.zeros(A_eq.shape[0]))
        ball = poly.chebyshev_ball(raw)
        minimal = poly.minimal_representation(raw, ball=ball)
        keep = int(rng.integers(1, d))
        given, solved = poly.project(minimal, keep, ball=ball), poly.project(minimal, keep)
        projected += not given.empty
        for x, y in zip((given.A, given.b, given.A_eq, given.b_eq),
                        (solved.A, solved.b, solved.A_eq, solved.b_eq), strict=True):
            np.testing.assert_array_equal(x, y)
    assert projected > 30


def test_batched_svds_are_solve_affines_bit_for_bit():
    """solve_affine_stack against solve_affine one system at a time: random stacks sharing B, of
    full and deficient rank, consistent or not, some in the ill-conditioned band (None, where
    solve_affine raises)."""
    from frcontrol.errors import IllConditioned

    rng = np.random.default_rng(31)
    compared = banded = 0
    for trial in range(80):
        nx = int(rng.integers(2, 14))
        rows, count, m = int(rng.integers(1, nx + 2)), int(rng.integers(1, 5)), int(rng.integers(0, 4))
        A, B, c = _random_stack(rng, count, rows, nx, m, deficient=bool(rng.random() < 0.5))
        if trial % 6 == 0 and rows > 1:  # a singular value about 1e-9 of the largest: the band
            A[:, -1] = A[:, 0] + 1e-9 * rng.normal(size=(count, nx))
        if trial % 3 == 0 and rows > 1:  # dependent rows with their right sides: consistency rows
            c[:, -1] = 3.0 * c[:, 0]
        stacked = resp.solve_affine_stack(A, B[0], c)
        for i, fast in enumerate(stacked):
            if fast is None:
                with pytest.raises(IllConditioned, match="ill-conditioned"):
                    resp.solve_affine(A[i], B[0], c[i])
                banded += 1
                continue
            alone = resp.solve_affine(A[i], B[0], c[i])
            assert (fast.rank, fast.consistent, fast.case) == (alone.rank, alone.consistent, alone.case)
            for name in ("X_u", "X_w", "x_0", "E", "e", "singular_values"):
                np.testing.assert_array_equal(getattr(fast, name), getattr(alone, name))
            compared += 1
    assert compared > 150 and banded > 0


# ------------------------------------------------------------------ certified by the rows kept


def _dependent_stack(rng: np.random.Generator, count: int, q: int, nx: int, m: int, extra: int,
                     near: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Systems of ``q`` independent rows and ``extra`` combinations of them (consistent right sides),
    shuffled: A (count, q + extra, nx), a shared B, c, and each system's independent rows. With
    ``near``, the second independent row is the first moved by ``near`` of itself."""
    rows = q + extra
    A, c = np.empty((count, rows, nx)), np.empty((count, rows))
    kept = np.empty((count, q), dtype=np.int64)
    S_B = rng.normal(size=(q, m))
    B = np.empty((rows, m))
    order = rng.permutation(rows)  # the same for every system: B is shared
    K = rng.normal(size=(extra, q)) * (rng.random((extra, q)) < 0.6)
    B[order[:q]], B[order[q:]] = S_B, K @ S_B
    for i in range(count):
        S = rng.normal(size=(q, nx)) * np.exp2(rng.integers(-6, 7, size=(q, 1)))
        if near:
            S[1] = S[0] * (1.0 + near * rng.normal(size=nx))
        s_c = rng.normal(size=q)
        A[i, order[:q]], A[i, order[q:]] = S, K @ S
        c[i, order[:q]], c[i, order[q:]] = s_c, K @ s_c
        kept[i] = np.sort(order[:q])
    return A, B, c, kept


@pytest.mark.parametrize("kernel_name", ["numpy", pytest.param("compiled", marks=needs_kernel)])
def test_certified_by_rows_are_the_svds(monkeypatch, kernel_name):
    """Rank-deficient systems (independent rows and combinations of them): with the independent
    rows kept, a certified answer has the first scaling's SVD's rank, case, void conditions, X_u and
    x_0 (to round-off) and null space; a wrong guess (an independent row left out, or swapped for a
    dependent one) is never certified wrongly, and right sides inconsistent in B or in c, even by
    1e-7 of themselves, are refused (the SVD then finds conditions, or an inconsistency, or moves
    the solutions by more than round-off).

    The certificate is conservative: it also refuses where the dropped directions' residual
    ``||A_hat Q_2||`` exceeds a tenth of the round-off bound (dense random rows reach a few
    times it; a contact mode's structural zeros keep it below, see the analysis test below)."""
    monkeypatch.setenv("FRC_KERNEL", kernel_name)
    rng = np.random.default_rng(20261128)
    certified = refused = inconsistent = 0
    for trial in range(80):
        nx = int(rng.integers(3, 28))
        q = int(rng.integers(1, nx))
        extra, m, count = int(rng.integers(1, 5)), int(rng.integers(1, 9)), int(rng.integers(1, 5))
        A, B, c, kept = _dependent_stack(rng, count, q, nx, m, extra)
        for i, fast in enumerate(resp.certified_by_rows(A, B, c, kept)):
            svd = resp.solve_affine(A[i], B, c[i], balance=False)  # the first scaling's: the one certified
            if fast is None:
                refused += 1
                continue
            certified += 1
            assert (fast.rank, fast.case, fast.consistent, fast.E.shape, fast.certified) == (
                svd.rank, svd.case, True, svd.E.shape, True) == (q, "ambiguous", True, (0, m), True)
            scale = 1.0 + np.abs(svd.X_u).max(initial=0.0) + np.abs(svd.x_0).max()
            np.testing.assert_allclose(fast.X_u, svd.X_u, rtol=0, atol=1e-13 * svd.condition_number * scale)
            np.testing.assert_allclose(fast.x_0, svd.x_0, rtol=0, atol=1e-13 * svd.condition_number * scale)
            _, c_scale = resp._equilibrate(A[i])
            np.testing.assert_allclose(_null_projector(fast.X_w, c_scale), _null_projector(svd.X_w, c_scale),
                                       atol=1e-13 * svd.condition_number)
        if trial % 4 == 0 and q > 1:  # wrong guesses: one independent row left out, or swapped
            dropped_row = kept[:, 1:]
            assert all(r is None for r in resp.certified_by_rows(A, B, c, dropped_row))
            swapped = kept.copy()
            swapped[:, 0] = [np.setdiff1d(np.arange(q + extra), k)[0] for k in kept]
            for i, fast in enumerate(resp.certified_by_rows(A, B, c, swapped)):
                assert fast is None or fast.rank == resp.solve_affine(A[i], B, c[i], balance=False).rank
        # inconsistent right sides: a dependent row's B (a condition on u) or c moved
        dependent = np.setdiff1d(np.arange(q + extra), kept[0])[0]
        size = 10.0 ** rng.choice([-3.0, -7.0])
        bad_B, bad_c = B.copy(), c.copy()
        if trial % 2:
            bad_B[dependent] += size * (1.0 + np.abs(bad_B[dependent]))
        else:
            bad_c[:, dependent] += size * (1.0 + np.abs(bad_c[:, dependent]))
        assert all(r is None for r in resp.certified_by_rows(A, bad_B, bad_c, kept))
        for i in range(count):
            svd = resp.solve_affine(A[i], bad_B, bad_c[i], balance=False)
            inconsistent += svd.E.shape[0] > 0 or not svd.consistent
    assert certified > 60 and refused > 0 and inconsistent > 20


@pytest.mark.parametrize("kernel_name", ["numpy", pytest.param("compiled", marks=needs_kernel)])
def test_certified_by_rows_follows_the_rank_tolerance(monkeypatch, kernel_name):
    """With another rank tolerance the certificate answers for that tolerance's SVD: kept rows
    dependent at 1e-6 of themselves are refused at rank_tolerance 1e-5 (its SVD drops that value),
    and at 1e-16 (no value is round-off's: its SVD keeps them all) nothing is certified."""
    monkeypatch.setenv("FRC_KERNEL", kernel_name)
    rng = np.random.default_rng(3)
    systems = []  # systems the certificate answers at the default tolerance (dense rows: not all)
    while len(systems) < 3:
        A, B, c, kept = _dependent_stack(rng, 1, 5, 9, 2, 2)
        if resp.certified_by_rows(A, B, c, kept)[0] is not None:
            systems.append((A, B, c, kept))
    for A, B, c, kept in systems:
        assert resp.certified_by_rows(A, B, c, kept, rank_tolerance=1e-16) == [None]
    answered = 0
    for _ in range(20):  # two kept rows 1e-6 apart: sigma_q about 1e-6 of sigma_1
        A, B, c, kept = _dependent_stack(rng, 1, 5, 9, 2, 2, near=1e-6)
        assert resp.certified_by_rows(A, B, c, kept, rank_tolerance=1e-5) == [None]
        assert resp.solve_affine(A[0], B, c[0], rank_tolerance=1e-5, balance=False).rank < 5
        found = resp.certified_by_rows(A, B, c, kept)[0]
        if found is not None:
            answered += 1
            assert found.rank == resp.solve_affine(A[0], B, c[0], balance=False).rank == 5
    assert answered > 0


@needs_kernel
def test_compiled_certified_by_rows_are_numpys(monkeypatch):
    """The kernel's certified_by_rows against its NumPy twin on random guesses, right and wrong:
    the same bound, norm and scale (to round-off), the same residuals where they are not round-off
    themselves, and, certified by both, the same responses. The two decide alike except where the
    dropped directions' residual is round-off on both sides (each sums its own round-off)."""
    rng = np.random.default_rng(20261129)
    compared = 0
    for _ in range(60):
        nx = int(rng.integers(3, 28))
        q = int(rng.integers(1, nx))
        A, B, c, kept = _dependent_stack(rng, int(rng.integers(1, 5)), q, nx, int(rng.integers(0, 9)),
                                         int(rng.integers(1, 5)))
        if rng.random() < 0.3:  # some wrong guesses too
            kept = np.sort(rng.permutation(A.shape[1])[:q])[None].repeat(A.shape[0], axis=0)
        numpy_factors = resp.by_rows_factors(A, B, c, kept)
        compiled_factors = kernel_compiled_by_rows(A, B, c, kept)
        info_np, info_c = numpy_factors[3], compiled_factors[3]
        finite = np.isfinite(info_np[:, 0]) & np.isfinite(info_c[:, 0])
        assert np.array_equal(finite, np.isfinite(info_np[:, 0]))  # the same pivots rule out the same
        size = info_np[:, 4]
        np.testing.assert_allclose(info_c[:, [4]], info_np[:, [4]], rtol=1e-12)
        np.testing.assert_allclose(info_c[finite][:, [0, 5, 6]], info_np[finite][:, [0, 5, 6]], rtol=1e-9)
        round_off = 1e3 * np.finfo(float).eps * (size * info_np[:, 0] * (1.0 + info_np[:, 5]))[:, None]
        both_small = (info_c[:, 1:4] <= round_off) & (info_np[:, 1:4] <= round_off)
        close = np.isclose(info_c[:, 1:4], info_np[:, 1:4], rtol=1e-6)
        assert (both_small | close)[finite].all()
        for i in np.nonzero(finite)[0]:
            tolerance = 1e-14 * info_np[i, 0] * (1.0 + np.abs(numpy_factors[0][i]).max(initial=0.0))
            np.testing.assert_allclose(compiled_factors[0][i], numpy_factors[0][i], rtol=0, atol=tolerance)
            compared += 1
        rows = A.shape[1]
        decided = [resp.by_rows_certified(info, rows, nx, resp.RANK_TOLERANCE) for info in (info_np, info_c)]
        for i, (a, b) in enumerate(zip(*decided, strict=True)):
            if a != b:  # only at the round-off check: dropped is round-off on both sides
                bound = min(rows, nx) * resp.ROUND_OFF_RANK_DROP * size[i]
                assert max(info_np[i, 1], info_c[i, 1]) <= 100.0 * bound
    assert compared > 50


def kernel_compiled_by_rows(A: np.ndarray, B: np.ndarray, c: np.ndarray, kept: np.ndarray) -> tuple:
    from frcontrol.kernel import COMPILED
    return COMPILED.certified_by_rows(A, B, c, kept)


def test_analyze_with_rows_certified_is_the_analyze_with_their_svds(monkeypatch):
    """The tree's partial modes certified by the rows they keep (no SVD) against the same tree with
    every such certificate refused (the SVD for each): the same modes, verdicts and counts, and the
    same responses and domains of the feasible modes to round-off (w up to an orthogonal map, as a
    certified mode reports its certificate's basis), on shipped scenes, snakes on the
    ground and random problems; and the certificate did answer for most of the snakes' modes."""
    calls = {"asked": 0, "answered": 0}
    original = engine.certified_by_rows

    def counted(*args, **kwargs):
        found = original(*args, **kwargs)
        calls["asked"] += len(found)
        calls["answered"] += sum(r is not None for r in found)
        return found

    rng = np.random.default_rng(7)
    problems = [load_scene(name) for name in ("snake_climb", "solo_standup", "rhex_flip", "table_on_ground")]
    problems += [load_scene(snake_scene(k)) for k in (4, 6, 8)] + [random_problem(rng) for _ in range(25)]
    for problem in problems:
        monkeypatch.setattr(engine, "certified_by_rows", counted)
        fast = analyze(problem, ambiguity=False)
        monkeypatch.setattr(engine, "certified_by_rows", lambda A, *args, **kwargs: [None] * A.shape[0])
        slow = analyze(problem, ambiguity=False)
        assert fast.enumeration == slow.enumeration
        for a, b in zip(fast.modes, slow.modes, strict=True):
            assert (a.mode, a.pruned, a.feasible) == (b.mode, b.pruned, b.feasible)
            assert a.response.case == b.response.case
            if a.feasible:
                _assert_same_mode(a, b)
    assert calls["asked"] > 200 and calls["answered"] > 0.9 * calls["asked"]
