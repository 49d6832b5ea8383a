"""Solo stands up from its back (frc standup, a short name for frc plan), checked on the samples.

The run is judged here again from its samples alone: the base's height and pitch at the end, the
feet's positions recomputed with the robot's own kinematics at every sample, the body's ends off
the ground, the applied torques within the motors' limits; and the first plan's torques give
exactly one rigid solution, in the planned mode, in a fresh analysis.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from frcontrol.cli.app import app
from typer.testing import CliRunner

from frcontrol.engine import analyze, solutions_at
from frcontrol.errors import SceneError
from frcontrol.modes import ContactProblem
from frcontrol.planning.standup import (
    SLIP_DISTANCE,
    STAND_TOLERANCE,
    simulate_standup,
    stand_up_as_phases,
    standup_task,
)
from frcontrol.scene import load_scene, shipped_robots_dir

FORMER_HEIGHT = 0.199011
"""[m] The base's height at the end of the stand-up's former dedicated planner's run (1.2 s, dt 2 ms):
the task reaches it within 1 mm."""

runner = CliRunner()


@pytest.fixture(scope="module")
def solo():
    return load_scene("solo_standup")


@pytest.fixture(scope="module")
def stood(solo):
    return simulate_standup(solo)


def test_solo_stands_up_in_the_rigid_simulation(solo, stood):
    trajectory = stood.trajectory
    assert trajectory.status == "completed"
    task = standup_task(solo)
    y, theta = trajectory.coordinate("y"), trajectory.coordinate("theta")
    assert abs(y[-1] - task.stand_height) <= STAND_TOLERANCE and abs(theta[-1] - np.pi) < 0.01
    assert abs(y[-1] - FORMER_HEIGHT) <= 1e-3
    assert y[0] == pytest.approx(0.028) and stood.stood and stood.reason is None
    # the feet, recomputed from q: on the ground at every sample, never moved along it
    names = [c.name for c in solo.contacts]
    feet = [names.index(name) for name in task.feet]
    ends = [names.index(name) for name in ("front_end", "rear_end")]
    points = np.array([solo.robot.contact_points_in_world(q) for q in trajectory.q])
    assert np.all(np.abs(points[:, feet, 1] - 0.016) <= 1e-4)
    assert np.max(np.abs(points[:, feet, 0] - points[0, feet, 0])) <= SLIP_DISTANCE and stood.feet_held
    assert np.all(points[-1, ends, 1] > 0.15)  # the body's ends are well off the ground
    # the torques stayed within Solo's 2.5 N m, and they did the lifting (the limit was reached)
    inputs = trajectory.inputs
    assert np.all(inputs >= solo.inputs.lower) and np.all(inputs <= solo.inputs.upper)
    assert np.max(np.abs(inputs)) == pytest.approx(2.5)


def test_the_first_plan_is_unambiguous_in_a_fresh_analysis(solo, stood):
    document = stood.to_dict(solo)
    assert document["mode"] == "SSFF" and document["contacts"] == ["front_end", "rear_end", "front_foot",
                                                                  "hind_foot"]
    analysis = analyze(ContactProblem.from_scene(solo))
    u = np.array([document["torques"][n] for n in solo.inputs.coordinates])
    assert np.allclose(u, stood.trajectory.inputs[1])  # the torques applied over the first step
    solutions = solutions_at(analysis, u)
    assert [s.mode for s in solutions] == ["SSFF"]
    y = solo.coordinate_names.index("y")
    assert solutions[0].dv[y] == pytest.approx(document["accelerations"]["y"], rel=1e-9)
    assert 0.0 < document["accelerations"]["y"] <= document["targets"]["y"]
    # without the torques the robot lies still with all four contacts loaded: the plan is not trivial
    assert [s.mode for s in solutions_at(analysis, np.zeros(4))] != ["SSFF"]


def test_too_weak_motors_cannot_lift_it():
    weak = ["--set", "inputs.lower=[-0.3,-0.3,-0.3,-0.3]", "--set", "inputs.upper=[0.3,0.3,0.3,0.3]"]
    result = runner.invoke(app, ["standup", "--json", "-T", "0", *weak])
    assert result.exit_code == 0, result.stderr
    document = json.loads(result.stdout)
    assert document["found"] is False and document["torques"] is None
    assert document["outcome"]["infeasible"]["phase"] == "stand"
    assert "no feasible mode has only the allowed letters" in document["reason"]


def test_the_json_is_frc_plans_with_the_stand_ups_keys(solo, stood):
    document = stood.to_dict(solo)
    simulation = document["simulation"]
    assert simulation["stood"] and simulation["feet_held"] and document["task"]["stand_height"] == 0.2
    assert document["task"]["feet"] == ["front_foot", "hind_foot"] and document["task"]["max_time"] == 1.2
    samples = simulation["samples"]
    q = np.array(samples["q"])
    assert q.shape == (len(samples["times"]), 11 - 4) and abs(q[-1, 1] - 0.2) <= STAND_TOLERANCE
    assert np.max(np.abs(samples["inputs"])) <= 2.5 and set(samples["modes"][-1][2:]) == {"F"}
    planned = stood.run.to_dict(solo)  # frc plan's document of the same run
    assert document["phases"] == planned["phases"] and document["outcome"] == planned["outcome"]
    assert {k: v for k, v in document["simulation"].items() if k in planned["simulation"]} == \
        planned["simulation"]
    json.dumps(document)


def test_frc_standup_is_frc_plan_on_the_same_scene():
    standup = runner.invoke(app, ["standup", "--json", "-T", "0.02", "--dt", "0.002", "--margin", "0.1"])
    plan = runner.invoke(app, ["plan", "solo_standup", "--json", "-T", "0.02", "--dt", "0.002", "--margin",
                               "0.1"])
    assert standup.exit_code == 0 and plan.exit_code == 0, standup.stderr + plan.stderr
    short, full = json.loads(standup.stdout), json.loads(plan.stdout)
    for key in ("phases", "outcome"):
        assert short[key] == full[key]
    assert short["simulation"]["samples"] == full["simulation"]["samples"]
    assert short["margin"] == 0.1 and short["phases"][0]["plans"][0]["margin"] == 0.1


def _former_scene(tmp_path, overrides=None):
    """``solo_standup`` with its task in the former keys (``feet``, ``stand_height``)."""
    text = (shipped_robots_dir() / "scenes" / "solo_standup.toml").read_text()
    start, end = text.index("[task]"), text.index("[inputs]")
    path = tmp_path / "solo_former.toml"
    path.write_text(text[:start] + '[task]\nfeet = ["front_foot", "hind_foot"]\nstand_height = 0.2\n\n'
                    + text[end:])
    return load_scene(path, overrides=overrides)


def test_the_former_keys_run_as_the_phase_they_meant(tmp_path, solo):
    former = stand_up_as_phases(_former_scene(tmp_path))
    assert former.raw["task"] == dict(solo.raw["task"]) | {"phases": former.raw["task"]["phases"]}
    [phase] = former.raw["task"]["phases"]
    [shipped] = solo.raw["task"]["phases"]
    assert phase["modes"] == shipped["modes"] and phase["track"] == shipped["track"]
    assert phase["until"] == shipped["until"] and phase["margin"] == shipped["margin"]


@pytest.mark.parametrize(("overrides", "field"), [
    ({"task.stand_height": 0.01}, "task.stand_height"),
    ({"task.feet": ["front_toe"]}, "task.feet[0]"),
])
def test_a_bad_former_task_names_its_field(tmp_path, overrides, field):
    with pytest.raises(SceneError, match=re.escape(field)) as info:
        stand_up_as_phases(_former_scene(tmp_path, overrides))
    assert info.value.field == field


@pytest.mark.parametrize(("args", "message"), [
    (["standup", "rod_on_table"], "task.phases: missing"),
    (["standup", "rhex_flip"], "task.phases[0].track.coordinates.y: missing"),
    (["standup", "box_slide"], "task.phases[0].track.coordinates.y: missing"),
    (["standup", "--set", "task.phases[0].track.coordinates.y=0.01"], "expected a height above"),
])
def test_the_command_refuses_a_scene_that_is_no_stand_up(args, message):
    result = runner.invoke(app, args)
    assert result.exit_code == 1 and result.stdout == "" and message in result.stderr, result.stderr
