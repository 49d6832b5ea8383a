"""SolverSettings: one frozen object carries the back-ends, their options and the residual tolerance
from the public functions down to the door; `solver=` names are converted at the boundary."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import frcontrol.solvers as solvers
from frcontrol.engine import analyze
from frcontrol.errors import InputError
from frcontrol.kernel import backend
from frcontrol.lcp import enumerate_lcp_solutions
from frcontrol.planning.core.decision import decide
from frcontrol.planning.core.task import read_task
from frcontrol.planning.core.tolerances import TORQUE_ROUNDING
from frcontrol.polytope import Polytope, minimal_representation
from frcontrol.scene import load_scene
from frcontrol.solvers import (
    DEFAULT_SETTINGS,
    FEASIBILITY_TOLERANCE,
    DoorOptions,
    InequalityLPs,
    SolverSettings,
    settings_from,
    solve_lp,
)
from frcontrol.statics import DAQP_PRIMAL_TOLERANCE, form_closure, static_body


def test_a_name_becomes_settings_at_the_boundary():
    assert settings_from() is DEFAULT_SETTINGS
    assert settings_from("highs") == SolverSettings(lp="highs")
    chosen = SolverSettings(lp="highs")
    assert settings_from("highs", chosen) is chosen
    with pytest.raises(InputError, match="contradicts settings.lp"):
        settings_from("daqp", chosen)
    with pytest.raises(InputError, match="must be a back-end name"):
        settings_from(3)  # type: ignore[arg-type]


def test_settings_are_frozen_and_their_options_read_only():
    settings = SolverSettings().with_options("daqp", primal_tol=1e-9)
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign"):
        settings.lp = "highs"  # type: ignore[misc]
    with pytest.raises(TypeError, match="does not support item assignment"):
        settings.options["daqp"]["primal_tol"] = 1.0  # type: ignore[index]
    assert settings.options_for("daqp") == {"primal_tol": 1e-9} and settings.options_for("highs") == {}
    with pytest.raises(InputError, match="feasibility_tolerance must be in"):
        SolverSettings(feasibility_tolerance=0.0)


def test_the_residual_tolerance_and_the_options_reach_the_back_end():
    """The tolerance scales every result's residual_tolerance, on the general and the lean path;
    a back-end's options reach it (DAQP rejects an option it does not know)."""
    A, b, c = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4), np.array([-1.0, -1.0])
    tight = SolverSettings(feasibility_tolerance=1e-9)

    def general(settings: SolverSettings) -> solvers.LPResult:
        return solve_lp(c, A, b, door=DoorOptions(settings))

    def lean(settings: SolverSettings) -> solvers.LPResult:
        return InequalityLPs(settings=settings).solve(c, A, b)

    for solve in (general, lean):
        default, strict = solve(DEFAULT_SETTINGS), solve(tight)
        assert default.found and strict.found
        scale = default.residual_tolerance / FEASIBILITY_TOLERANCE
        assert strict.residual_tolerance == pytest.approx(1e-9 * scale, rel=1e-12)
    with pytest.raises(InputError, match="unknown DAQP option"):
        solve_lp(c, A, b, door=DoorOptions(SolverSettings().with_options("daqp", no_such_option=1.0)))


def test_the_door_takes_its_keywords_as_one_checked_record():
    """``door=`` is a DoorOptions whose fields have their types; the QP door takes a built QP."""
    A, b, c = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4), np.array([-1.0, -1.0])
    with pytest.raises(InputError, match="door must be a DoorOptions"):
        solve_lp(c, A, b, door=SolverSettings())  # type: ignore[arg-type]
    with pytest.raises(InputError, match="DoorOptions.settings must be a SolverSettings"):
        DoorOptions("highs")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="DoorOptions.fallback must be a Fallback"):
        DoorOptions(fallback="retry")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="DoorOptions.check must be a residual check"):
        DoorOptions(check=None)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="solve_qp takes the problem that qp_problem"):
        solvers.solve_qp(solvers.lp_problem(c, A, b))  # type: ignore[arg-type]
    with pytest.raises(dataclasses.FrozenInstanceError, match="fallback"):
        solvers.DEFAULT_DOOR.fallback = solvers.RETRY_ERRORS  # type: ignore[misc]
    highs = DoorOptions(SolverSettings(lp="highs"), check=backend().lp_check)
    assert solve_lp(c, A, b, door=highs).solver == "highs"
    assert solvers.solve_lp_prepared(c, A, b, door=highs).solver == "highs"


def test_analyze_and_polytopes_answer_alike_with_a_name_or_settings():
    scene = load_scene("rod_on_table")
    by_name = analyze(scene, solver="highs")
    by_settings = analyze(scene, settings=SolverSettings(lp="highs"))
    assert by_name.solver == by_settings.solver == "highs"
    documents = [analysis.to_dict() for analysis in (by_name, by_settings)]
    for document in documents:
        document.pop("timings")
    assert documents[0] == documents[1]
    P = Polytope(np.vstack([np.eye(2), -np.eye(2), [[1.0, 1.0]]]), [1.0, 1.0, 1.0, 1.0, 5.0])
    reduced = minimal_representation(P, settings=SolverSettings(lp="highs"))
    assert reduced.A.shape == (4, 2)
    assert np.array_equal(reduced.A, minimal_representation(P, solver="highs").A)


def _spy(monkeypatch, name):
    """Record the options of every LP that back-end ``name`` solves."""
    seen: list[dict] = []
    adapter = solvers._LP_SOLVERS[name]

    def spying(problem, **options):
        seen.append(options)
        return adapter(problem, **options)

    monkeypatch.setitem(solvers._LP_SOLVERS, name, spying)
    monkeypatch.delitem(solvers._LEAN_LP_SOLVERS, name, raising=False)
    return seen


def test_statics_gives_daqp_its_primal_tolerance_through_the_settings(monkeypatch):
    seen = _spy(monkeypatch, "daqp")
    body = static_body([[-1.0, 0.0], [1.0, 0.0]], [[0.0, 1.0], [0.0, 1.0]], 0.5, 1.0, [0.0, 0.5])
    closure = form_closure(body)
    assert not closure.closed and seen
    assert all(options.get("primal_tol") == DAQP_PRIMAL_TOLERANCE for options in seen)


def test_the_lcp_support_lp_goes_through_the_door(monkeypatch):
    """The enumeration's LP (a singular block whose minimum-norm point fails) is the door's: HiGHS,
    with the door's residual check, not scipy's linprog around it."""
    seen = _spy(monkeypatch, "highs")
    M = np.array([[-1.0, 1.0, 1.0], [1.0, -1.0, 1.0], [-1.0, 0.0, 0.0]])
    q = np.array([0.0, -1.0, 0.0])
    (solution,) = enumerate_lcp_solutions(M, q)
    assert "linear programming" in solution.note and len(seen) >= 1
    np.testing.assert_allclose(solution.z, [0.0, 0.0, 1.0], atol=1e-9)


def test_a_plan_runs_every_lp_on_its_settings_and_checks_it_with_the_kernel(monkeypatch):
    """The planners take the settings object: a decision's LPs (the engine's and the planner's own:
    interior tests, piece optima) go to its back-end, and each answer is checked by the kernel's
    ``lp_check`` (handed to the door), none by the door's default."""
    scene = load_scene("rhex_flip")
    phase = read_task(scene).sequence()[0]
    reference = decide(scene, phase)
    on_highs = SolverSettings(lp="highs", qp="highs")
    highs, daqp = _spy(monkeypatch, "highs"), _spy(monkeypatch, "daqp")
    checks: list[int] = []
    kernel_check = backend().lp_check

    def counted(*args):
        checks.append(1)
        return kernel_check(*args)

    monkeypatch.setattr(backend(), "lp_check", counted)
    decision = decide(scene, phase, settings=on_highs)
    assert decision.found and reference.found and decision.mode == reference.mode
    assert decision.inputs == pytest.approx(reference.inputs, abs=2 * TORQUE_ROUNDING)
    assert len(highs) > 10 and not daqp
    assert len(checks) >= len(highs), f"{len(highs) - len(checks)} LPs not checked by the kernel"
