"""Degenerate sizes are ordinary cases: an LCP of size 0, a scene with no active contact, a robot
with no inputs. Each returns its trivial answer, checked against the closed form."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import ROBOTS, toml_text
from frcontrol.cli.app import app
from typer.testing import CliRunner

from frcontrol.contact_lcp import all_contact_lcp_solutions, solve_contact_lcp
from frcontrol.engine import analyze, solutions_at
from frcontrol.lcp import enumerate_lcp_solutions, solve_lcp
from frcontrol.modes import ContactProblem
from frcontrol.scene import load_scene
from frcontrol.simulation import simulate_compliant, simulate_rigid
from frcontrol.statics import analyze_statics

G = 9.81
ROD_MASS = 1.0
ROD_INERTIA = 0.08333333333  # [kg m^2] izz of robots/rod.urdf (m l^2 / 12 to 11 digits)


@pytest.mark.parametrize("method", ["lemke", "enumerate"])
def test_an_lcp_of_size_0_has_its_one_empty_solution(method):
    result = solve_lcp(np.zeros((0, 0)), np.zeros(0), method)
    assert result.found and result.z.shape == (0,) and result.w.shape == (0,) and result.residual == 0.0
    (only,) = enumerate_lcp_solutions(np.zeros((0, 0)), np.zeros(0))
    assert only.found and only.z.shape == (0,)


def lifted_rod(**sets):
    """The shipped rod with its table 0.1 m below the tip: no active contact."""
    return load_scene("rod_on_table", overrides={"contacts.tip.surface_point": [0.0, -0.1], **sets})


def free_rod(write_scene, inputs=True):
    doc = {"robot": str(ROBOTS / "rod.urdf"), "state": {"q": [0.0, 1.0, 0.3], "v": [0.5, 0.0, 0.0]}}
    if inputs:
        doc["inputs"] = {"coordinates": ["x", "y", "theta"]}
    return load_scene(write_scene(toml_text(doc)))


def test_no_active_contact_is_free_flight(write_scene):
    """One mode, the empty one, with dv = M^-1 (u - h): (u_x / m, u_y / m - g, u_theta / I)."""
    u = np.array([2.0, 3.0, 0.5])
    want = np.array([u[0] / ROD_MASS, u[1] / ROD_MASS - G, u[2] / ROD_INERTIA])
    for scene in (lifted_rod(), free_rod(write_scene)):
        assert scene.active_contacts == ()
        result = analyze(scene)
        assert [m.mode for m in result.feasible_modes] == [""] and result.overlaps == ()
        for source in (result, scene):
            (solution,) = solutions_at(source, u)
            assert solution.mode == ""
            np.testing.assert_allclose(solution.dv, want, rtol=1e-12, atol=1e-12)
            assert solution.lambda_n.shape == (0,) and solution.lambda_t.shape == (0,)
        problem = ContactProblem.from_scene(scene)
        lcp = solve_contact_lcp(problem, u)
        np.testing.assert_allclose(lcp.x, want, rtol=1e-12, atol=1e-12)
        assert [s.mode for s in all_contact_lcp_solutions(problem, u)] == [""]


def test_statics_of_a_free_body(write_scene):
    """No contact: no closure, no support; at rest only when nothing loads it (gravity 0)."""
    report = analyze_statics(lifted_rod())
    assert not report.form_closure.closed and not report.force_closure.closed
    assert not report.equilibrium.exists and not report.support.feasible
    assert not report.weakly_stable and not report.strongly_stable
    weightless = analyze_statics(lifted_rod(gravity=0.0))
    assert weightless.equilibrium.exists and weightless.weakly_stable and weightless.strongly_stable


@pytest.mark.parametrize("simulate", [simulate_rigid, simulate_compliant])
def test_simulating_free_flight_is_the_parabola(simulate, write_scene):
    scene = free_rod(write_scene)
    trajectory = simulate(scene, None, 0.2, 0.001)
    t = trajectory.times
    x = trajectory.coordinate("x")
    y = trajectory.coordinate("y")
    np.testing.assert_allclose(x, 0.5 * t, atol=1e-9)
    # the rigid stepper is semi-implicit Euler: its y error is g dt t / 2 at most
    np.testing.assert_allclose(y, 1.0 - 0.5 * G * t**2, atol=0.5 * G * 0.001 * 0.2 + 1e-9)
    assert trajectory.contact_forces.size == 0 or not np.any(trajectory.contact_forces)


def test_a_robot_with_no_inputs(write_scene):
    """The rod at rest on the table with no [inputs]: F alone, the closed form of the shipped case."""
    doc = json.loads(json.dumps(load_scene("rod_on_table").raw))
    del doc["inputs"]
    doc["robot"] = str(ROBOTS / "rod.urdf")
    scene = load_scene(write_scene(toml_text(doc)))
    assert scene.inputs.count == 0
    result = analyze(scene)
    assert [m.mode for m in result.feasible_modes] == ["F"]
    assert len(result.unambiguous_set("F")) == 1  # all of R^0: the one point
    (solution,) = solutions_at(result, {})
    with_inputs = solutions_at(load_scene("rod_on_table"), np.zeros(3))
    assert [s.mode for s in with_inputs] == ["F"]
    np.testing.assert_allclose(solution.dv, with_inputs[0].dv, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(solution.lambda_n, with_inputs[0].lambda_n, rtol=1e-12)
    report = analyze_statics(scene)
    assert report.inputs.shape == (0,)
    assert report.equilibrium.exists == analyze_statics(load_scene("rod_on_table")).equilibrium.exists


@pytest.mark.parametrize("command", ["analyze", "statics", "show"])
def test_the_cli_answers_degenerate_scenes(command, write_scene):
    runner = CliRunner()
    free = write_scene('robot = "rod.urdf"\n[state]\nq = [0.0, 1.0, 0.3]\n')
    for args in ([command, str(free), "--json"],
                 [command, "rod_on_table", "--set", "contacts.tip.surface_point=[0.0,-0.1]", "--json"]):
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.stderr
        json.loads(result.stdout)
