"""The pumping flip: the drive's torque-speed line in closed form, the pumping run checked from its
samples alone (every torque on the motor's line, the energy drawn, the phases), the flip verified
by simulation (rigid and compliant), and the command line."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from test_json_output import is_progress
from typer.testing import CliRunner

from frcontrol.drives import joint_torque, no_load_speed, stall_torque, torque_limits
from frcontrol.engine import solutions_at
from frcontrol.errors import SceneError
from frcontrol.planning.flip import flip_task
from frcontrol.planning.flip_budget import flip_budget
from frcontrol.planning.pump import (
    pump_flip,
    pump_payload,
    simulate_pump,
    verify_compliant,
    voltage_for_torque,
)
from frcontrol.scene import load_scene

runner = CliRunner()
PITCH = 2  # theta in RHex's coordinates
STRONG_VOLTS = 250.0
"""[V] The motors at this voltage limit (140 N m stall, 419 rad/s, ten times RHex's pair): one
stroke flips the body."""


@pytest.fixture(scope="module")
def rhex():
    return load_scene("rhex_flip_drives")


@pytest.fixture(scope="module")
def pumped(rhex):
    """Two cycles at the scene's drives (13.4 N m stall per pair), with the first push's plan."""
    return pump_flip(rhex, max_time=0.6)


@pytest.fixture(scope="module")
def strong():
    sets = {f"model.drives.{j}.voltage_limit": STRONG_VOLTS for j in ("hip_middle", "hip_rear")}
    sets.update({"inputs.lower": [-STRONG_VOLTS] * 2, "inputs.upper": [STRONG_VOLTS] * 2})
    scene = load_scene("rhex_flip_drives", overrides=sets)
    return scene, simulate_pump(scene, max_time=0.5)


# ------------------------------------------------------------------------------- the drive


def test_the_voltage_for_a_torque_inverts_the_motor_line(rhex):
    rng = np.random.default_rng(4)
    for drive in rhex.drives.values():
        for speed, fraction in zip(rng.uniform(-40, 40, 20), rng.uniform(0, 1, 20), strict=True):
            lo, hi = torque_limits(drive, speed)
            torque = lo + fraction * (hi - lo)
            volts = voltage_for_torque(drive, torque, speed)
            assert abs(volts) <= drive.voltage_limit + 1e-12
            assert joint_torque(drive, volts, speed) == pytest.approx(torque, abs=1e-9)
        # beyond the limits, the voltage saturates
        assert voltage_for_torque(drive, 2 * stall_torque(drive), 0.0) == drive.voltage_limit


def test_the_scene_hip_pairs_are_within_twenty_newton_metres(rhex):
    for drive in rhex.drives.values():
        assert 0 < stall_torque(drive) <= 20.0 and 20.0 < no_load_speed(drive) < 45.0


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
    # the stepper was given exactly these voltages (the inputs of the rigid run)
    for j, name in enumerate(rhex.inputs.coordinates):
        assert np.array_equal(result.trajectory.inputs[:, j], samples["drives"][name]["voltage"])
    assert doc["input_units"] == {"hip_middle": "V", "hip_rear": "V"}


def test_the_energy_drawn_is_the_integral_of_voltage_times_current(rhex, pumped):
    plan, result = pumped
    samples = pump_payload(rhex, plan, result)["simulation"]["samples"]
    dt = np.diff(samples["times"])
    power = sum(np.array(d["voltage"]) * np.array(d["current"]) for d in samples["drives"].values())
    assert result.energy_drawn == pytest.approx(float(np.sum(power[1:] * dt)), rel=1e-12)
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
            # the legs' voltages never left the body two possible motions
            assert phase.predicted and phase.unambiguous
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
    assert all(abs(x) <= rhex.drives[name].voltage_limit for name, x in plan.torques.items())


def test_within_twenty_newton_metres_the_rigid_body_does_not_flip_and_says_why(pumped):
    _, result = pumped
    assert not result.flipped and result.time_to_vertical is None
    assert "short of vertical" in result.reason
    assert result.max_pitch < flip_task(load_scene("rhex_flip_drives")).vertical


# ------------------------------------------------------- the energy budget, and why no flip

BODY_MASS, BODY_INERTIA = 7.5, 0.1668125
"""[kg], [kg m^2] RHex's body (rhex_planar.urdf; the legs are massless)."""
CORNER, HIP_DEPTH, LEG = (0.25, 0.065), 0.065, 0.17
"""[m] The front corner in the body frame, the hips' height above the shell lying flat (the hips on
the mid-plane, 0.065 below the back face), a leg's length (rhex_planar.urdf)."""


def _closed_form_reach(hip_to_corner: float) -> float:
    """[rad] The pitch above flat at which a hip ``hip_to_corner`` [m] behind the front corner (along
    the body) rises ``LEG`` above the ground, the body pivoting on the corner:
    ``hip_to_corner sin a + HIP_DEPTH cos a = LEG``."""
    return math.asin(LEG / math.hypot(hip_to_corner, HIP_DEPTH)) - math.atan2(HIP_DEPTH, hip_to_corner)


def test_the_flip_budget_is_the_closed_form_of_the_geometry(rhex):
    budget = flip_budget(rhex)
    g, y0, step = rhex.robot.gravity, float(rhex.q[1]), budget.pitch_step
    weight = BODY_MASS * g
    assert budget.pivot == "front_corner"
    # the barrier: the centre of mass right above the front corner
    assert budget.barrier_energy == pytest.approx(weight * (math.hypot(*CORNER) - y0), abs=1e-4)
    assert budget.tip_pitch == pytest.approx(math.pi + math.atan2(*CORNER), abs=step)
    assert budget.vertical_energy == pytest.approx(weight * (CORNER[0] - y0), abs=1e-9)
    # the legs reach the ground only a few degrees up (0.2 m between hips, 0.05 m corner to front hip)
    for joint, behind in (("hip_middle", 0.25), ("hip_rear", 0.45)):
        reach = budget.reach_pitch[joint] - math.pi
        assert _closed_form_reach(behind) - step <= reach <= _closed_form_reach(behind)
    top = max(budget.reach_pitch.values()) - math.pi
    height = CORNER[0] * math.sin(top) + CORNER[1] * math.cos(top)
    assert budget.reach_energy == pytest.approx(weight * (height - y0), abs=1e-9)
    assert budget.kinetic_energy_needed == pytest.approx(budget.barrier_energy - budget.reach_energy)
    assert budget.kinetic_energy_needed > 6.0  # 6.5 J of the 13.3 J: the legs reach half-way up


def test_a_budget_over_body_contacts_on_different_surfaces_is_a_scene_error():
    scene = load_scene("rhex_flip_drives", overrides={"contacts.rear_corner.normal": [0.1, 1.0]})
    with pytest.raises(SceneError, match="one flat surface") as error:
        flip_budget(scene)
    assert error.value.field == "task.body_contacts"


def test_a_toe_carries_force_only_below_its_reach_pitch(rhex, pumped):
    _, result = pumped
    budget, traj = result.budget, result.trajectory
    pitch = traj.q[:, PITCH]
    for toe, joint in (("middle_toe", "hip_middle"), ("rear_toe", "hip_rear")):
        loaded = traj.contact_forces[:, traj.contacts.index(toe), 0] > 0
        assert np.any(loaded)
        assert np.all(pitch[loaded] <= budget.reach_pitch[joint] + budget.pitch_step)


def test_the_rigid_pumping_stays_below_the_barrier_and_the_samples_show_it(rhex, pumped):
    plan, result = pumped
    doc = json.loads(json.dumps(pump_payload(rhex, plan, result)))
    samples, pump = doc["simulation"]["samples"], doc["pump"]
    q, v, times = np.array(samples["q"]), np.array(samples["v"]), np.array(samples["times"])
    # the body's mechanical energy above the start, from the samples and the URDF's mass alone
    energy = 0.5 * BODY_MASS * (v[:, 0] ** 2 + v[:, 1] ** 2) + 0.5 * BODY_INERTIA * v[:, 2] ** 2 \
        + BODY_MASS * rhex.robot.gravity * (q[:, 1] - q[0, 1])
    assert pump["max_energy"] == pytest.approx(float(energy.max()), abs=1e-9)
    assert pump["max_energy"] < pump["budget"]["barrier_energy"]
    # every push after the first starts as the body falls back onto its toes, still moving (the
    # legs reach 0.46 rad up, so the body lands on them, not at rest), and no cycle reaches the barrier
    pushes = [p for p in pump["phases"] if p["kind"] == "push"]
    assert len(pushes) >= 2
    for push in pushes[1:]:
        k = int(np.searchsorted(times, push["start"]))
        kinetic = 0.5 * BODY_MASS * (v[k, 0] ** 2 + v[k, 1] ** 2) + 0.5 * BODY_INERTIA * v[k, 2] ** 2
        assert kinetic > 1.0
    assert all(e < pump["budget"]["barrier_energy"] for e in pump["cycle_max_energy"])
    assert "13.31 J brings its centre of mass over front_corner" in doc["simulation"]["reason"]


# ---------------------------------------------------------------- a flip, by simulation


def test_a_strong_enough_drive_flips_and_the_samples_show_it(strong):
    scene, strong = strong
    task = flip_task(scene)
    pitch = strong.trajectory.q[:, task.pitch_index]
    assert strong.flipped and pitch[-1] >= task.vertical > pitch[:-1].max()
    assert strong.trajectory.times[-2] <= strong.time_to_vertical <= strong.trajectory.times[-1]
    assert strong.trajectory.status == "completed"
    assert strong.cycles == 1 and strong.phases[0].kind == "push"


def test_the_strong_flip_survives_the_compliant_model(strong):
    scene, strong = strong
    check = verify_compliant(scene, strong)
    assert check["status"] == "completed" and check["torque_within_limits"]
    assert check["flipped"], check


def test_the_compliant_replay_follows_the_rigid_pumping(rhex):
    result = simulate_pump(rhex, max_time=0.25)
    check = verify_compliant(rhex, result)
    assert check["status"] == "completed" and check["torque_within_limits"]
    assert check["max_pitch"] == pytest.approx(result.max_pitch, abs=0.02)


def test_a_scene_without_drives_is_a_scene_error():
    with pytest.raises(SceneError, match="needs a DC-motor drive on every input"):
        simulate_pump(load_scene("rhex_flip"), max_time=0.1)


def test_an_elastic_stage_is_a_scene_error_not_a_run_without_pushes():
    stage = {"ratio": 33.0, "efficiency": 0.7, "stiffness": 20.0, "damping": 0.05}
    scene = load_scene("rhex_flip_drives", overrides={"model.drives.hip_rear.stages": [stage]})
    with pytest.raises(SceneError, match="needs rigid stages") as error:
        pump_flip(scene, max_time=0.1)
    assert error.value.field == "model.drives.hip_rear.stages[0]"


# ------------------------------------------------------------------------ the command line


def test_frc_flip_pump_json_plot_and_exit_codes(tmp_path):
    from frcontrol.cli.app import app

    from frcontrol.viz.plots import text_overlaps
    from frcontrol.viz.pump_figure import pump_figure

    figure = tmp_path / "pump.png"
    result = runner.invoke(app, ["flip", "rhex_flip_drives", "--max-time", "0.3", "--json",
                                 "--plot", str(figure)])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    for key in ("found", "mode", "torques", "pitch_acceleration", "unambiguous", "margin", "simulation"):
        assert key in doc
    sim = doc["simulation"]
    assert {"flipped", "time_to_vertical", "body_contact_kept", "steps", "samples"} <= set(sim)
    assert {"times", "q", "v", "drives"} <= set(sim["samples"])
    assert set(sim["samples"]["drives"]["hip_rear"]) >= {"voltage", "current", "motor_speed", "torque"}
    assert {"cycles", "time_to_flip", "energy_drawn", "phases", "budget", "max_energy"} <= set(doc["pump"])
    assert figure.stat().st_size > 0
    scene = load_scene("rhex_flip_drives")
    assert text_overlaps(pump_figure(scene, simulate_pump(scene, max_time=0.3))) == []
    for args in (["rhex_flip_drives", "--max-time", "0.1", "--dt", "1"], ["rhex_flip", "--pump"]):
        bad = runner.invoke(app, ["flip", *args])
        errors = [line for line in bad.stderr.splitlines() if not is_progress(line)]  # a loaded machine
        assert bad.exit_code == 1 and "Traceback" not in bad.output and len(errors) == 1
    assert math.isfinite(doc["pump"]["energy_drawn"])


def _closed_form_hold(hip_to_corner: float, low: float, high: float) -> float:
    """[rad] The pitch above flat, in [low, high], at which a toe whose hip is ``hip_to_corner`` [m]
    behind the front corner reaches the ground exactly as far behind the corner as the centre of
    mass, the body pivoting on the corner (bisection on ``x_hip + sqrt(LEG^2 - h^2) - x_com``)."""
    def excess(a: float) -> float:
        along = CORNER[0] * math.cos(a) - CORNER[1] * math.sin(a)
        hip = hip_to_corner * math.cos(a) - HIP_DEPTH * math.sin(a)
        height = hip_to_corner * math.sin(a) + HIP_DEPTH * math.cos(a)
        return hip + math.sqrt(max(LEG**2 - height**2, 0.0)) - along

    sign = math.copysign(1.0, excess(low))
    for _ in range(60):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if excess(middle) * sign > 0 else (low, middle)
    return 0.5 * (low + high)


def test_a_toe_that_reaches_the_ground_holds_the_body_only_with_the_centre_of_mass_behind_it(rhex):
    budget = flip_budget(rhex)
    step, start = budget.pitch_step, budget.start_pitch - math.pi
    holds = {toe: [(a - math.pi, b - math.pi) for a, b in spans] for toe, spans in budget.hold_pitch.items()}
    # the front toe (hip 0.05 m behind the corner): from 0.680 rad up to vertical, 11.0 J above flat
    (first, last), = holds["front_toe"]
    front = _closed_form_hold(0.05, 0.5, 1.3)
    assert front <= first <= front + step
    assert last == pytest.approx(0.5 * math.pi)
    height = CORNER[0] * math.sin(front) + CORNER[1] * math.cos(front)
    assert BODY_MASS * rhex.robot.gravity * (height - CORNER[1]) == pytest.approx(11.05, abs=0.05)
    # the middle and rear toes: from the start until just before their hips leave their reach
    for toe, behind in (("middle_toe", 0.25), ("rear_toe", 0.45)):
        (first, last), = holds[toe]
        end = min(_closed_form_hold(behind, start, _closed_form_reach(behind)), _closed_form_reach(behind))
        assert first == pytest.approx(start)
        assert end - step <= last <= end
