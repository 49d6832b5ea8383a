"""The former projection rule's cheaper redundancy stage (``project(..., method="fourier_motzkin")``,
which prunes after every step; frcontrol/polytope.py): the same polytopes, fewer LPs.

Rows two other rows imply are removed without their LP (``_implied_by_pairs``, proposed by the
rows' Fourier-Motzkin ancestry), and the Gram products run in blocks (``_gram``). Both are held to
the plain path: every certificate is a true implication (checked by an LP of another solver), and
projections with and without the certificates are bitwise equal, on random polytopes and on every
feasible mode of the snake lying on the ground with 6 contacts (the ``benchmarks.contacts`` scene).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import on

from frcontrol import polytope as poly
from frcontrol.engine import analyze
from frcontrol.scene import load_scene
from frcontrol.solvers import solve_lp

sys.path.append(str(Path(__file__).resolve().parents[1]))
from benchmarks.contacts import snake_scene  # noqa: E402  (the benchmark's scene set)


def random_polytope(rng: np.random.Generator, d: int, m: int) -> poly.Polytope:
    """A bounded polytope: m random unit rows around the origin, plus a box."""
    A = rng.normal(size=(m, d))
    A /= np.linalg.norm(A, axis=1)[:, None]
    b = rng.uniform(0.5, 2.0, m)
    box = np.vstack([np.eye(d), -np.eye(d)])
    return poly.Polytope(np.vstack([A, box]), np.concatenate([b, np.full(2 * d, 3.0)]))


def same(P: poly.Polytope, Q: poly.Polytope) -> bool:
    return (np.array_equal(P.A, Q.A) and np.array_equal(P.b, Q.b) and np.array_equal(P.A_eq, Q.A_eq)
            and np.array_equal(P.b_eq, Q.b_eq))


@pytest.fixture
def certificates(monkeypatch):
    """Every certificate ``_implied_by_pairs`` gives during the test, with its rows."""
    found: list[tuple[np.ndarray, np.ndarray, dict]] = []
    original = poly._implied_by_pairs

    def recording(unit, offsets, ancestors, tolerance):
        implied = original(unit, offsets, ancestors, tolerance)
        found.append((unit, offsets, implied))
        return implied

    monkeypatch.setattr(poly, "_implied_by_pairs", recording)
    return found


def without_certificates(monkeypatch) -> None:
    monkeypatch.setattr(poly, "_implied_by_pairs", lambda *arguments: {})


def test_every_certificate_is_an_implication(certificates):
    """Row i certified by rows j, k: max g_i z over {g_j z <= h_j, g_k z <= h_k} (HiGHS) <= h_i + tol."""
    rng = np.random.default_rng(29)
    for _ in range(12):
        poly.project(random_polytope(rng, 6, 14), 3, method="fourier_motzkin")
    checked = 0
    for unit, offsets, implied in certificates:
        for i, pairs in implied.items():
            j, k = pairs[0]
            bound = solve_lp(-unit[i], unit[[j, k]], offsets[[j, k]], door=on("highs"))
            assert bound.status in ("optimal", "unbounded")
            if bound.status == "optimal":  # two rows bound a direction only when it is their cone's
                assert -bound.objective <= offsets[i] + poly.REDUNDANCY_TOLERANCE + 1e-9
                checked += 1
    assert checked >= 20, checked


def test_random_projections_are_the_same_with_and_without_the_certificates(monkeypatch, certificates):
    rng = np.random.default_rng(7)
    polytopes = [random_polytope(rng, int(rng.integers(5, 8)), int(rng.integers(8, 18))) for _ in range(10)]
    fast = [poly.project(P, 3, method="fourier_motzkin") for P in polytopes]
    used = sum(len(implied) for _, _, implied in certificates)
    without_certificates(monkeypatch)
    plain = [poly.project(P, 3, method="fourier_motzkin") for P in polytopes]
    assert all(same(P, Q) for P, Q in zip(fast, plain, strict=True))
    assert used >= 20  # rows were removed without their LP


@pytest.mark.slow
def test_the_snake_on_the_ground_projects_the_same_without_the_certificates(monkeypatch, certificates):
    scene = load_scene(snake_scene(6))

    def projections():  # type: ignore[no-untyped-def]
        return [(m.mode, poly.project(m.domain, range(m.m), method="fourier_motzkin", minimal=True))
                for m in analyze(scene, ambiguity=False).feasible_modes]

    fast = projections()
    used = sum(len(implied) for _, _, implied in certificates)
    without_certificates(monkeypatch)
    plain = projections()
    assert [mode for mode, _ in fast] == [mode for mode, _ in plain] and len(fast) > 40
    assert all(same(P, Q) for (_, P), (_, Q) in zip(fast, plain, strict=True))
    assert used >= 50


@pytest.mark.parametrize("rows, columns", [(5, 3), (300, 11), (1000, 2)])
def test_the_blocked_gram_product_is_the_product(rows, columns):
    X = np.random.default_rng(rows).normal(size=(rows, columns))
    gram = poly._gram(X)
    assert gram.shape == (rows, rows)
    np.testing.assert_allclose(gram, X @ X.T, rtol=0, atol=1e-12 * columns)


@pytest.mark.parametrize("third_offset, off_plane, implied", [
    (1.5, 0.0, True),  # (g1 + g2) / sqrt(2) <= 2 / sqrt(2) = 1.414 holds wherever rows 1 and 2 hold
    (1.3, 0.0, False),  # tighter than their sum: the row cuts
    (1.5, 1e-6, False),  # not in the plane of rows 1 and 2
])
def test_a_row_is_certified_only_when_two_rows_imply_it(third_offset, off_plane, implied):
    g1, g2 = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    g3 = g1 + g2 + np.array([0.0, 0.0, off_plane])
    scale = np.linalg.norm(g3)
    unit = np.array([g1, g2, g3 / scale])
    offsets = np.array([1.0, 1.0, third_offset])
    ancestors = np.array([[1, 1, 0], [0, 1, 1], [1, 1, 1]], dtype=bool)  # row 3 combines rows 1 and 2's
    found = poly._implied_by_pairs(unit, offsets, ancestors, poly.REDUNDANCY_TOLERANCE)
    assert (found == {2: [(0, 1)]}) == implied, found
