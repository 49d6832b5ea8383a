"""The closed-loop driver: a policy on one rigid stepper, against simulate_rigid and by its contract."""

from __future__ import annotations

import numpy as np
import pytest

from frcontrol.errors import InputError
from frcontrol.scene import load_scene
from frcontrol.simulation.closed_loop import LoopOptions, run_closed_loop
from frcontrol.simulation.inputs import step_lengths
from frcontrol.simulation.rigid import RigidSettings, RigidStepper, simulate_rigid


def assert_same_run(a, b) -> None:
    """Two trajectories equal sample for sample: state, inputs, forces, events and verdict."""
    for name in ("times", "q", "v", "inputs", "contact_forces", "contact_points"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.events == b.events
    assert (a.status, a.failure, a.warnings) == (b.status, b.failure, b.warnings)
    np.testing.assert_array_equal(a.info["energy"], b.info["energy"])
    assert a.info["lcp"] == b.info["lcp"]
    assert a.info["ambiguity_checks"] == b.info["ambiguity_checks"]


@pytest.mark.parametrize(("scene_name", "inputs", "duration", "dt"), [
    ("rod_on_table", {"x": 3.0, "theta": -1.5}, 0.2, 1e-3),
    ("box_on_slope", {"x": 2.0}, 0.1037, 2e-3),     # the last step is shortened
    ("rhex_flip", {"hip_middle": -5.0, "hip_rear": -5.0}, 0.05, 1e-3),
])
def test_a_constant_policy_gives_simulate_rigids_trajectory(scene_name, inputs, duration, dt):
    scene = load_scene(scene_name)
    reference = simulate_rigid(scene, inputs, duration, dt)
    command = np.array([inputs.get(name, 0.0) for name in scene.inputs.coordinates])
    calls = []

    def constant(stepper: RigidStepper) -> np.ndarray:
        calls.append(stepper.t)
        return command

    run = run_closed_loop(RigidStepper(scene, RigidSettings()), constant, duration, dt)
    assert_same_run(run.trajectory, reference)
    assert len(reference.times) == len(list(step_lengths(duration, dt))) + 1
    assert run.decisions == len(calls) == len(reference.times) - 1
    assert not run.stopped
    assert abs(run.trajectory.times[-1] - duration) <= 1e-12


def test_the_policy_is_asked_every_n_steps_and_its_command_held():
    scene = load_scene("rod_on_table")
    seen = []

    def ramp(stepper: RigidStepper) -> np.ndarray:
        seen.append(round(stepper.t / 1e-3))
        return np.array([0.0, 0.0, 10.0 * stepper.t])

    run = run_closed_loop(RigidStepper(scene), ramp, 0.023, 1e-3,
                          options=LoopOptions(every=5, command=np.array([0.0, 0.0, -1.0])))
    assert seen == [5, 10, 15, 20]
    assert run.decisions == 4
    applied = run.trajectory.inputs[1:, 2]  # inputs[k + 1] is step k's
    expected = [-1.0] * 5 + [0.05] * 5 + [0.1] * 5 + [0.15] * 5 + [0.2] * 3
    np.testing.assert_allclose(applied, expected, rtol=0, atol=1e-12)


def test_actuation_turns_the_held_command_into_each_steps_inputs():
    scene = load_scene("rod_on_table")

    def halve_after_first_steps(command: np.ndarray, stepper: RigidStepper) -> np.ndarray:
        return command if stepper.t < 2.5e-3 else 0.5 * command

    run = run_closed_loop(RigidStepper(scene), lambda stepper: np.array([4.0, 0.0, 0.0]), 0.005, 1e-3,
                          options=LoopOptions(every=100, actuate=halve_after_first_steps))
    np.testing.assert_array_equal(run.trajectory.inputs[1:, 0], [4.0, 4.0, 4.0, 2.0, 2.0])
    assert run.decisions == 1


def test_stop_ends_the_run_after_the_step_where_it_holds():
    scene = load_scene("rod_on_table")
    run = run_closed_loop(RigidStepper(scene), lambda stepper: np.zeros(3), 1.0, 1e-3,
                          options=LoopOptions(stop=lambda stepper: stepper.t >= 0.0125))
    assert run.stopped
    assert len(run.trajectory.times) == 14
    assert run.trajectory.times[-2] < 0.0125 <= run.trajectory.times[-1]


def test_progress_is_reported_every_n_steps():
    scene = load_scene("rod_on_table")
    reports = []
    run_closed_loop(RigidStepper(scene), lambda stepper: np.zeros(3), 0.01, 1e-3,
                    options=LoopOptions(every=4),
                    progress=lambda t, total: reports.append((round(t / 1e-3), total)))
    assert reports == [(4, 0.01), (8, 0.01)]


@pytest.mark.parametrize(("command", "match"), [
    (np.array([1.0, 2.0]), "expected 3 input values"),
    (np.array([0.0, np.nan, 0.0]), "NaN"),
    (np.array([0.0, 0.0, 80.0]), "outside its limits"),
])
def test_a_bad_command_is_a_typed_error_naming_the_time(command, match):
    scene = load_scene("rod_on_table")
    with pytest.raises(InputError, match=match):
        run_closed_loop(RigidStepper(scene), lambda stepper: command, 0.01, 1e-3)
    calls = iter([np.zeros(3), command])
    with pytest.raises(InputError, match=r"t = 0\.002 s"):
        run_closed_loop(RigidStepper(scene), lambda stepper: next(calls), 0.01, 1e-3,
                        options=LoopOptions(every=2))


@pytest.mark.parametrize(("options", "match"), [
    ({"every": 0}, "every must be an integer >= 1"),
    ({"every": 1.5}, "every must be an integer >= 1"),
    ({"dt": 0.0}, "dt must be > 0"),
    ({"duration": float("nan")}, "duration must be a finite number"),
])
def test_bad_loop_options_are_typed_errors(options, match):
    scene = load_scene("rod_on_table")
    arguments = {"duration": 0.01, "dt": 1e-3, **options}
    with pytest.raises(InputError, match=match):
        run_closed_loop(RigidStepper(scene), lambda stepper: np.zeros(3), arguments.pop("duration"),
                        arguments.pop("dt"), options=LoopOptions(**arguments))
