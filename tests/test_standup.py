"""Solo stands up from its back (frc standup), checked on the simulated samples, not the planner's word.

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
    plan_standup,
    simulate_standup,
    standup_task,
)
from frcontrol.scene import load_scene

runner = CliRunner()


@pytest.fixture(scope="module")
def solo():
    return load_scene("solo_standup")


@pytest.fixture(scope="module")
def stood(solo):
    return simulate_standup(solo, duration=1.0)


def test_solo_stands_up_in_the_rigid_simulation(solo, stood):
    trajectory = stood.trajectory
    assert trajectory.status == "completed" and stood.held == ()
    task = standup_task(solo)
    y, theta = trajectory.coordinate("y"), trajectory.coordinate("theta")
    assert abs(y[-1] - task.stand_height) <= STAND_TOLERANCE and abs(theta[-1] - np.pi) < 0.01
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
    plan = stood.plan
    assert plan.found and plan.mode == "SSFF" and plan.contacts == ("front_end", "rear_end", "front_foot",
                                                                   "hind_foot")
    analysis = analyze(ContactProblem.from_scene(solo))
    u = plan.input_vector(solo.inputs.coordinates)
    solutions = solutions_at(analysis, u)
    assert [s.mode for s in solutions] == ["SSFF"]
    y = solo.coordinate_names.index("y")
    assert solutions[0].dv[y] == pytest.approx(plan.accelerations["y"], rel=1e-9)
    assert 0.0 < plan.accelerations["y"] <= plan.targets["y"]
    # without the torques the robot lies still with all four contacts loaded: the plan is not trivial
    assert [s.mode for s in solutions_at(analysis, np.zeros(4))] != ["SSFF"]


def test_too_weak_motors_cannot_lift_it():
    weak = load_scene("solo_standup", overrides={"inputs.lower": [-0.3] * 4, "inputs.upper": [0.3] * 4})
    plan = plan_standup(weak)
    assert not plan.found and "infeasible within the torque limits" in plan.reason


def test_the_json_carries_the_samples_and_the_verdict(solo, stood):
    document = stood.to_dict(solo)
    simulation = document["simulation"]
    assert simulation["stood"] and simulation["feet_held"] and document["task"]["stand_height"] == 0.2
    samples = simulation["samples"]
    q = np.array(samples["q"])
    assert q.shape == (len(samples["times"]), 11 - 4) and abs(q[-1, 1] - 0.2) <= STAND_TOLERANCE
    assert np.max(np.abs(samples["inputs"])) <= 2.5 and set(samples["modes"][-1][2:]) == {"F"}
    json.dumps(document)


@pytest.mark.parametrize(("overrides", "field"), [
    ({"task.stand_height": 0.01}, "task.stand_height"),
    ({"task.feet": ["front_toe"]}, "task.feet[0]"),
])
def test_a_bad_task_names_its_field(overrides, field):
    with pytest.raises(SceneError, match=re.escape(field)) as info:
        standup_task(load_scene("solo_standup", overrides=overrides))
    assert info.value.field == field


def test_the_command_refuses_a_scene_without_the_task():
    result = runner.invoke(app, ["standup", "rhex_flip"])
    assert result.exit_code == 1 and "task.feet: missing" in result.stderr
