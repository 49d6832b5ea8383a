"""T_c from D_c's minimal form (``project(..., minimal=True)``) is the set the former path gives.

``ModeAnalysis.input_domain`` projects ``ModeAnalysis.domain`` (D_c, already minimal) without
pruning it again. The former path pruned it first (``project(domain, ball=raw_ball)``): the same
set must come out, in the same minimal form (a full-dimensional polytope has one minimal
representation up to the order and scale of its rows), on every shipped scene and on the snake
lying on the ground with 6 contacts (benchmarks/contacts.py's scene set).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from frcontrol import polytope as poly
from frcontrol.engine import analyze
from frcontrol.scene import load_scene, shipped_scene_names

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:  # the benchmarks beside the package; the checkout LAST (see test_peers)
    sys.path.append(str(REPO))
from benchmarks.contacts import snake_scene  # noqa: E402

ROW_TOLERANCE = 1e-7
"""Two unit rows are the same facet when their normals and offsets agree to this [units of u]."""


def unit_rows(P: poly.Polytope) -> tuple[np.ndarray, np.ndarray]:
    norms = np.linalg.norm(P.A, axis=1)
    return P.A / norms[:, None], P.b / norms


def assert_same_minimal_form(new: poly.Polytope, old: poly.Polytope, label: str) -> None:
    """The same rows, matched one to one (normals and offsets to ROW_TOLERANCE), and equalities."""
    assert new.A.shape == old.A.shape and new.A_eq.shape == old.A_eq.shape, (
        f"{label}: {new} against {old}")
    E, E0 = np.column_stack([new.A_eq, new.b_eq]), np.column_stack([old.A_eq, old.b_eq])
    assert np.linalg.matrix_rank(np.vstack([E, E0]), tol=ROW_TOLERANCE) == np.linalg.matrix_rank(
        E, tol=ROW_TOLERANCE), f"{label}: other equalities"
    if new.A.shape[0] == 0:
        return
    (A, b), (A0, b0) = unit_rows(new), unit_rows(old)
    match = np.argmax(A @ A0.T, axis=1)
    assert sorted(match.tolist()) == list(range(A0.shape[0])), f"{label}: rows do not match one to one"
    assert np.allclose(A, A0[match], atol=ROW_TOLERANCE), label
    assert np.allclose(b, b0[match], atol=ROW_TOLERANCE * (1.0 + np.abs(b0[match]))), label


def former_input_domain(mode) -> poly.Polytope:  # type: ignore[no-untyped-def]
    """T_c as the engine computed it before: D_c pruned again, then projected."""
    return poly.project(mode.domain, range(mode.m), method="fourier_motzkin", solver=mode.solver,
                        ball=mode.raw_ball)


def checked_modes(scene) -> int:  # type: ignore[no-untyped-def]
    result = analyze(scene, ambiguity=False)
    modes = [m for m in result.feasible_modes if m.ambiguity_dim]
    for mode in modes:
        assert_same_minimal_form(mode.feasible_input_domain, former_input_domain(mode), mode.mode)
    return len(modes)


@pytest.mark.parametrize("name", shipped_scene_names())
def test_input_domains_equal_the_former_path_on_shipped_scenes(name: str) -> None:
    checked_modes(load_scene(name))


def test_input_domains_equal_the_former_path_on_the_snake_with_6_contacts() -> None:
    assert checked_modes(load_scene(snake_scene(6))) == 57


def test_minimal_skips_only_the_first_pruning() -> None:
    """From a minimal P, ``minimal=True`` gives P's projection; a non-minimal P's is still pruned."""
    box = poly.Polytope.from_box([-1.0, -2.0, -3.0], [1.0, 2.0, 3.0])
    redundant = poly.Polytope(np.vstack([box.A, [[1.0, 1.0, 1.0]]]), np.append(box.b, 100.0))
    minimal = poly.minimal_representation(redundant)
    projected = poly.project(minimal, [0, 1], minimal=True)
    assert_same_minimal_form(projected, poly.Polytope.from_box([-1.0, -2.0], [1.0, 2.0]), "box")
    assert poly.project(redundant, [0, 1]).A.shape == (4, 2)


def forced(scene):  # type: ignore[no-untyped-def]
    """The analysis with its overlaps and every feasible mode's minimal D_c and T_c."""
    result = analyze(scene)
    for mode in result.feasible_modes:
        _ = mode.domain, mode.input_domain
    return result


def assert_same_analysis(new, old) -> None:  # type: ignore[no-untyped-def]
    """The same modes, verdicts, balls, minimal D_c and T_c (rows one to one) and overlaps."""
    assert [m.mode for m in new.modes] == [m.mode for m in old.modes]
    for a, b in zip(new.modes, old.modes, strict=True):
        assert (a.feasible, a.pruned, a.full_dimensional, a.inputs_full_dimensional) == (
            b.feasible, b.pruned, b.full_dimensional, b.inputs_full_dimensional), a.mode
        assert a.chebyshev_radius == pytest.approx(b.chebyshev_radius, abs=ROW_TOLERANCE), a.mode
        if a.feasible:
            assert_same_minimal_form(a.domain, b.domain, f"D_c of {a.mode}")
            assert_same_minimal_form(a.input_domain, b.input_domain, f"T_c of {a.mode}")
    assert [o.modes for o in new.overlaps] == [o.modes for o in old.overlaps]
    for a, b in zip(new.overlaps, old.overlaps, strict=True):
        assert a.chebyshev_radius == pytest.approx(b.chebyshev_radius, abs=ROW_TOLERANCE), a.modes


@pytest.mark.parametrize("name", shipped_scene_names())
def test_the_lean_lp_path_gives_the_general_doors_analysis_on_shipped_scenes(name: str) -> None:
    """The forced analysis (overlaps, every D_c and T_c) with the polytope module's and the engine's
    LPs on the door's lean path (InequalityLPs) equals the one through the general door."""
    from benchmarks.lp_door import general_door

    scene = load_scene(name)
    new = forced(scene)
    with general_door():
        old = forced(scene)
    assert_same_analysis(new, old)


def test_the_lean_lp_path_gives_the_general_doors_analysis_on_the_snake_with_6_contacts() -> None:
    from benchmarks.lp_door import general_door

    scene = load_scene(snake_scene(6))
    new = analyze(scene, ambiguity=False)
    for mode in new.feasible_modes:
        _ = mode.domain, mode.input_domain
    with general_door():
        old = analyze(scene, ambiguity=False)
        for mode in old.feasible_modes:
            _ = mode.domain, mode.input_domain
    assert new.enumeration == old.enumeration and new.enumeration.feasible == 62
    assert_same_analysis(new, old)
