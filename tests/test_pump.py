"""The pumping flip: the drive's torque-speed line in closed form, the pumping run checked from its
samples alone (every torque on the motor's line, the energy drawn, the phases), the flip verified
by simulation (rigid and compliant), and the command line."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

from frcontrol.engine import solutions_at
from frcontrol.errors import InputError
from frcontrol.planning.flip import flip_task
from frcontrol.planning.pump import (
    DEFAULT_HIP_DRIVE,
    HipDrive,
    joint_torque,
    no_load_speed,
    pump_flip,
    pump_payload,
    simulate_pump,
    stall_torque,
    torque_limits,
    verify_compliant,
    voltage_for_torque,
)
from frcontrol.scene import load_scene

runner = CliRunner()
PITCH = 2  # theta in RHex's coordinates
STRONG = replace(DEFAULT_HIP_DRIVE, voltage_limit=150.0)
"""A drive 6.25 times as strong as a RHex hip pair (120 N m stall, 188 rad/s): one stroke flips."""


@pytest.fixture(scope="module")
def rhex():
    return load_scene("rhex_flip")


@pytest.fixture(scope="module")
def pumped(rhex):
    """Two cycles and a half at the default drive (19.2 N m stall per pair), with its first plan."""
    return pump_flip(rhex, max_time=0.6)


@pytest.fixture(scope="module")
def strong(rhex):
    """The strong drive alone limits the torques (the scene's 40 N m limits are lifted)."""
    free = replace(rhex, inputs=replace(rhex.inputs, lower=np.full(2, -1e3), upper=np.full(2, 1e3)))
    return simulate_pump(free, max_time=0.5, drives={n: STRONG for n in rhex.inputs.coordinates})


# ------------------------------------------------------------------------------- the drive


def test_the_line_has_the_dc_motor_closed_forms():
    d = HipDrive(resistance=2.0, torque_constant=0.05, back_emf_constant=0.04, voltage_limit=12.0, ratio=10.0,
                 efficiency=0.5)
    assert stall_torque(d) == pytest.approx(0.5 * 10 * 0.05 * 12 / 2.0)
    assert no_load_speed(d) == pytest.approx(12.0 / (0.04 * 10))
    assert joint_torque(d, 12.0, no_load_speed(d)) == pytest.approx(0.0, abs=1e-12)
    # the limits are the line at -V_max and +V_max, shifted down by the back-EMF at any speed
    lo, hi = torque_limits(d, 7.0)
    assert hi == pytest.approx(stall_torque(d) - 0.5 * 10 * 0.05 * 0.04 * 10 * 7.0 / 2.0)
    assert hi - lo == pytest.approx(2 * stall_torque(d))
    # the voltage for a torque inside the limits gives that torque back
    rng = np.random.default_rng(4)
    for speed, fraction in zip(rng.uniform(-40, 40, 20), rng.uniform(0, 1, 20), strict=True):
        lo, hi = torque_limits(d, speed)
        torque = lo + fraction * (hi - lo)
        volts = voltage_for_torque(d, torque, speed)
        assert abs(volts) <= d.voltage_limit + 1e-12
        assert joint_torque(d, volts, speed) == pytest.approx(torque, abs=1e-9)


def test_the_default_pair_is_within_twenty_newton_metres():
    assert 15.0 < stall_torque(DEFAULT_HIP_DRIVE) <= 20.0
    assert 25.0 < no_load_speed(DEFAULT_HIP_DRIVE) < 35.0


# ---------------------------------------------------------------- the run, from its samples


def test_every_sample_lies_on_the_motor_line(rhex, pumped):
    plan, result = pumped
    doc = json.loads(json.dumps(pump_payload(rhex, plan, result)))
    samples, drives = doc["simulation"]["samples"], doc["pump"]["drives"]
    v = np.array(samples["v"])
    assert len(samples["times"]) == len(samples["q"]) == len(v) == doc["simulation"]["steps"] + 1
    for name, index in zip(rhex.inputs.coordinates, rhex.inputs.indices, strict=True):
        c, s = drives[name], samples["drives"][name]
        volts, torque = np.array(s["voltage"]), np.array(s["torque"])
        speed = v[:, index]
        assert np.all(np.abs(volts) <= c["voltage_limit"] + 1e-12)
        assert np.allclose(s["motor_speed"], c["ratio"] * speed)
        current = (volts - c["back_emf_constant"] * c["ratio"] * speed) / c["resistance"]
        assert np.allclose(s["current"], current)
        line = c["efficiency"] * c["ratio"] * c["torque_constant"] * current
        assert np.allclose(torque, line, atol=1e-9)
        # the limits, recomputed from the constants alone, hold every sample's torque
        swing = c["efficiency"] * c["ratio"] * c["torque_constant"] * c["voltage_limit"] / c["resistance"]
        shift = c["efficiency"] * c["ratio"] ** 2 * c["torque_constant"] * c["back_emf_constant"] * speed \
            / c["resistance"]
        assert np.all(torque <= swing - shift + 1e-9) and np.all(torque >= -swing - shift - 1e-9)
        assert c["stall_torque"] <= 20.0
    assert doc["simulation"]["torque_within_limits"] is True
    # the stepper was given exactly these torques (the applied inputs of the rigid run)
    applied = result.trajectory.inputs[1:]
    for j, name in enumerate(rhex.inputs.coordinates):
        assert np.allclose(applied[:, j], np.array(samples["drives"][name]["torque"])[:-1], atol=1e-12)


def test_the_energy_drawn_is_the_integral_of_voltage_times_current(rhex, pumped):
    plan, result = pumped
    samples = pump_payload(rhex, plan, result)["simulation"]["samples"]
    dt = np.diff(samples["times"])
    power = sum(np.array(d["voltage"]) * np.array(d["current"]) for d in samples["drives"].values())
    assert result.energy_drawn == pytest.approx(float(np.sum(power[:-1] * dt)), rel=1e-12)
    # the supply pays at least for the mechanical energy the body gained at its highest
    energy = result.trajectory.info["energy"]
    assert result.energy_drawn > float(np.max(energy) - energy[0]) > 0


def test_the_phases_chain_push_and_recirculation_and_end_on_the_predicted_lift_off(rhex, pumped):
    _, result = pumped
    kinds = [p.kind for p in result.phases]
    assert kinds[0] == "push" and result.cycles >= 2
    assert all(a != b for a, b in zip(kinds, kinds[1:], strict=False))  # they alternate
    times = result.trajectory.times
    toes = [result.trajectory.contacts.index(n) for n in ("middle_toe", "rear_toe")]
    forces = result.trajectory.contact_forces[:, toes, 0]
    for phase in result.phases[:-1]:
        if phase.kind == "push":
            # every planned mode keeps the front corner loaded (its first letter, not S)
            assert phase.modes and all(mode[0] in "FLR" for mode in phase.modes)
            # the analysis predicted the lift-off: a few steps on, no toe carries force
            after = (times > phase.end + 0.01) & (times < phase.end + 0.03)
            assert np.all(forces[after] == 0.0), phase
        else:
            assert phase.ended_by == "the body is back on a toe"
            k = int(np.searchsorted(times, phase.end))
            assert result.trajectory.v[k, PITCH] <= 1e-3
    # the cycles' highest pitches, read from the samples
    pitch = result.trajectory.q[:, PITCH]
    assert max(result.cycle_max_pitch) == pytest.approx(float(pitch.max()))


def test_the_first_push_is_the_one_rigid_solution_at_its_torques(rhex, pumped):
    plan, _ = pumped
    assert plan.found and plan.unambiguous
    (solution,) = solutions_at(rhex, dict(plan.torques))
    assert solution.mode == plan.mode
    lo, hi = torque_limits(DEFAULT_HIP_DRIVE, 0.0)
    assert all(lo <= x <= hi for x in plan.torques.values())


def test_within_twenty_newton_metres_the_rigid_body_does_not_flip_and_says_why(pumped):
    _, result = pumped
    assert not result.flipped and result.time_to_vertical is None
    assert "short of vertical" in result.reason
    assert result.max_pitch < flip_task(load_scene("rhex_flip")).vertical


# ---------------------------------------------------------------- a flip, by simulation


def test_a_strong_enough_drive_flips_and_the_samples_show_it(rhex, strong):
    task = flip_task(rhex)
    pitch = strong.trajectory.q[:, task.pitch_index]
    assert strong.flipped and pitch[-1] >= task.vertical > pitch[:-1].max()
    assert strong.trajectory.times[-2] <= strong.time_to_vertical <= strong.trajectory.times[-1]
    assert strong.trajectory.status == "completed"
    assert strong.cycles == 1 and strong.phases[0].kind == "push"


def test_the_strong_flip_survives_the_compliant_model(rhex, strong):
    check = verify_compliant(rhex, strong)
    assert check["status"] == "completed" and check["torque_within_limits"]
    assert check["flipped"], check


def test_the_compliant_replay_follows_the_rigid_pumping(rhex):
    result = simulate_pump(rhex, max_time=0.25)
    check = verify_compliant(rhex, result)
    assert check["status"] == "completed" and check["torque_within_limits"]
    assert check["max_pitch"] == pytest.approx(result.max_pitch, abs=0.02)


def test_a_missing_drive_is_an_input_error(rhex):
    with pytest.raises(InputError, match="no drive for the input"):
        simulate_pump(rhex, max_time=0.1, drives={"hip_middle": DEFAULT_HIP_DRIVE})


# ------------------------------------------------------------------------ the command line


def test_frc_flip_pump_json_plot_and_exit_codes(tmp_path):
    from frcontrol.cli.app import app

    from frcontrol.viz.plots import text_overlaps
    from frcontrol.viz.pump_figure import pump_figure

    figure = tmp_path / "pump.png"
    result = runner.invoke(app, ["flip", "rhex_flip", "--pump", "--max-time", "0.3", "--json",
                                 "--plot", str(figure)])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    for key in ("found", "mode", "torques", "pitch_acceleration", "unambiguous", "margin", "simulation"):
        assert key in doc
    sim = doc["simulation"]
    assert {"flipped", "time_to_vertical", "body_contact_kept", "steps", "samples"} <= set(sim)
    assert {"times", "q", "v", "drives"} <= set(sim["samples"])
    assert set(sim["samples"]["drives"]["hip_rear"]) >= {"voltage", "current", "motor_speed", "torque"}
    assert {"cycles", "time_to_flip", "energy_drawn", "phases"} <= set(doc["pump"])
    assert figure.stat().st_size > 0
    scene = load_scene("rhex_flip")
    assert text_overlaps(pump_figure(scene, simulate_pump(scene, max_time=0.3))) == []
    bad = runner.invoke(app, ["flip", "rhex_flip", "--pump", "--max-time", "0.1", "--dt", "1"])
    assert bad.exit_code == 1 and "Traceback" not in bad.output
    assert math.isfinite(doc["pump"]["energy_drawn"])
