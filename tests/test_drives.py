"""DC-motor drives (Vukobratovic-Potkonjak §6): the scene table, closed forms, analysis in volts,
simulation samples."""

from __future__ import annotations

import copy
import json
import math
from dataclasses import replace

import numpy as np
import pytest
from frcontrol.cli.app import app
from typer.testing import CliRunner

from frcontrol.drives import (
    joint_torque,
    mechanical_time_constant,
    no_load_speed,
    stall_torque,
    torque_limits,
)
from frcontrol.engine import analyze, solutions_at
from frcontrol.errors import SceneError
from frcontrol.modes import ContactProblem
from frcontrol.scene import load_scene, scene_from_document
from frcontrol.simulation.compliant import CompliantSettings, simulate_compliant
from frcontrol.simulation.rigid import simulate_rigid
from frcontrol.simulation.samples import drive_samples, stage_samples

runner = CliRunner()

ARM_INERTIA = 0.015
"""[kg m^2] pendulum.urdf's link about its axle (0.005 + 1 kg x 0.1^2)."""

MOTOR = {"resistance": 2.0, "torque_constant": 0.05, "back_emf_constant": 0.05, "rotor_inertia": 1e-5,
         "voltage_limit": 12.0}


def motor_document(stages=None, gravity=0.0, **motor):
    """A motor on the pendulum's axle (a free inertia without gravity), fixed base, no contact."""
    drive = {**MOTOR, **motor}
    if stages is not None:
        drive["stages"] = stages
    return {"robot": "pendulum.urdf", "base": "fixed", "gravity": gravity, "state": {"q": [0.0]},
            "inputs": {"coordinates": ["axle"]}, "model": {"drives": {"axle": drive}}}


def motor_scene(stages=None, gravity=0.0, **motor):
    return scene_from_document(motor_document(stages, gravity, **motor))


GEAR = [{"ratio": 10.0, "inertia_in": 1e-6, "inertia_out": 1e-4}]


# ----------------------------------------------------------------------------------- the scene
def test_a_fixed_base_robot_without_contacts_and_a_drive_is_a_scene():
    scene = motor_scene(GEAR)
    drive = scene.drives["axle"]
    assert scene.contacts == () and scene.inputs.units == ("V",)
    assert drive.ratio == 10.0 and drive.efficiency == 1.0
    # reflected inertia N^2 J_r + N^2 I' + I'' joins the joint's diagonal of M
    reflected = 100 * 1e-5 + 100 * 1e-6 + 1e-4
    assert drive.reflected_inertia == pytest.approx(reflected, rel=1e-12)
    state = scene.state(np.zeros(1), np.array([3.0]))
    assert state.mass_matrix[0, 0] == pytest.approx(ARM_INERTIA + reflected, rel=1e-9)
    # the back-EMF term is in the bias: N^2 C_M C_E / R qdot, and S^T is N C_M / R per volt
    assert state.bias[0] == pytest.approx(100 * 0.05 * 0.05 / 2.0 * 3.0, rel=1e-12)
    assert scene.inputs.selection_transpose(1)[0, 0] == pytest.approx(10 * 0.05 / 2.0)
    # the voltage limits are the drive's
    assert scene.inputs.lower.tolist() == [-12.0] and scene.inputs.upper.tolist() == [12.0]


@pytest.mark.parametrize(("change", "field", "message"), [
    (lambda d: d["model"]["drives"].update({"axel": d["model"]["drives"].pop("axle")}),
     "model.drives.axel", "did you mean 'axle'"),
    (lambda d: d["model"]["drives"]["axle"].update(resistance=0.0), "model.drives.axle.resistance", "> 0"),
    (lambda d: d["model"]["drives"]["axle"].update(torque_constant=-1.0), "torque_constant", "> 0"),
    (lambda d: d["model"]["drives"]["axle"].update(resistence=1.0), "resistence",
     "did you mean 'resistance'"),
    (lambda d: d["model"]["drives"]["axle"].pop("voltage_limit"), "voltage_limit", "missing"),
    (lambda d: d["model"]["drives"]["axle"].update(kind="stepper"), "kind", "dc_motor"),
    (lambda d: d["model"]["drives"]["axle"].update(stages=[{"ratio": 0.0}]), "stages[0].ratio", "> 0"),
    (lambda d: d["model"]["drives"]["axle"].update(stages=[{"efficiency": 1.5}]), "efficiency", "<= 1"),
    (lambda d: d["model"]["drives"]["axle"].update(stages=[{"ratoi": 3.0}]), "ratoi", "did you mean 'ratio'"),
    (lambda d: d["inputs"].update(lower=[-20.0], upper=[12.0]), "inputs.lower[0]", "voltage_limit"),
    (lambda d: d.pop("inputs"), "model.drives.axle", "not an input"),
])
def test_bad_drive_tables_are_scene_errors_naming_the_field(change, field, message):
    document = copy.deepcopy(motor_document(GEAR))
    change(document)
    with pytest.raises(SceneError, match=message) as err:
        scene_from_document(document)
    assert field in err.value.field


def test_a_locked_joint_cannot_be_driven():
    document = motor_document()
    document["locked_joints"] = ["axle"]
    document.pop("inputs")
    with pytest.raises(SceneError, match="locked"):
        scene_from_document(document)


def test_the_cli_refuses_a_bad_drive_with_one_line(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('robot = "pendulum.urdf"\nbase = "fixed"\n[state]\nq = [0.0]\n[inputs]\n'
                    'coordinates = ["axle"]\n[model.drives.axle]\nresistance = -1.0\ntorque_constant = 0.1\n'
                    'back_emf_constant = 0.1\nrotor_inertia = 0.0\nvoltage_limit = 5.0\n')
    result = runner.invoke(app, ["analyze", str(path)])
    assert result.exit_code == 1
    assert "resistance" in result.stderr and "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


# ------------------------------------------------------------------------------- closed forms
def test_the_torque_speed_line():
    drive = motor_scene(GEAR).drives["axle"]
    n, cm, ce, r, u = 10.0, 0.05, 0.05, 2.0, 12.0
    assert stall_torque(drive) == pytest.approx(n * cm * u / r)
    assert no_load_speed(drive) == pytest.approx(u / (ce * n))
    assert joint_torque(drive, u, no_load_speed(drive)) == pytest.approx(0.0, abs=1e-12)
    lo, hi = torque_limits(drive, 5.0)
    assert hi == pytest.approx(n * cm / r * (u - ce * n * 5.0))
    assert lo == pytest.approx(-n * cm / r * (u + ce * n * 5.0))
    speeds = np.linspace(-30, 30, 7)
    line = stall_torque(drive) * (1 - speeds / no_load_speed(drive))
    assert np.allclose(joint_torque(drive, u, speeds), line)


def test_a_motor_spins_a_free_inertia_up_to_u_over_ce_n_with_the_electromechanical_time_constant():
    scene = motor_scene(GEAR)
    drive = scene.drives["axle"]
    u = 6.0
    steady = u / (drive.back_emf_constant * drive.ratio)
    tau = mechanical_time_constant(drive, ARM_INERTIA)
    # R J_total / (C_M C_E) with J_total at the rotor: (J_arm / N^2 + J_r + I' + I'' / N^2)
    j_rotor = ARM_INERTIA / 100 + 1e-5 + 1e-6 + 1e-4 / 100
    assert tau == pytest.approx(2.0 * j_rotor / (0.05 * 0.05), rel=1e-12)
    run = simulate_compliant(scene, {"axle": u}, 3 * tau, tau / 50,
                             settings=CompliantSettings(rtol=1e-9, atol=1e-12))
    exact = steady * (1 - np.exp(-run.times / tau))
    assert np.max(np.abs(run.v[:, 0] - exact)) < 1e-8 * steady
    # the rigid stepper (implicit in the motor's damping) converges to it at first order in dt
    errors = []
    for dt in (tau / 20, tau / 40):
        rigid = simulate_rigid(scene, {"axle": u}, 3 * tau, dt)
        errors.append(np.max(np.abs(rigid.v[:, 0] - steady * (1 - np.exp(-rigid.times / tau)))))
    assert errors[1] < 0.6 * errors[0] and errors[1] < 0.02 * steady
    # and samples: current (u - C_E w_m) / R, torque N C_M i, motor speed N qdot
    samples = drive_samples(scene, run)["axle"]
    assert samples["voltage"] == pytest.approx(np.full(len(run.times), u))
    assert samples["motor_speed"] == pytest.approx(drive.ratio * run.v[:, 0])
    assert samples["current"][0] == pytest.approx(u / 2.0)
    assert samples["torque"][0] == pytest.approx(10 * 0.05 * u / 2.0)
    assert samples["current"][-1] == pytest.approx((u - 0.05 * samples["motor_speed"][-1]) / 2.0)


def test_efficiency_scales_the_stall_torque_and_the_damping_not_the_steady_speed():
    stages = [{"ratio": 4.0, "efficiency": 0.9}, {"ratio": 5.0, "efficiency": 0.8}]
    scene = motor_scene(stages)
    drive = scene.drives["axle"]
    assert drive.ratio == 20.0 and drive.efficiency == pytest.approx(0.72)
    assert stall_torque(drive) == pytest.approx(0.72 * 20 * 0.05 * 12.0 / 2.0)
    run = simulate_compliant(scene, {"axle": 3.0}, 2.0, 0.01)
    assert run.v[-1, 0] == pytest.approx(3.0 / (0.05 * 20.0), rel=1e-4)


def test_a_stall_against_the_analysis_accelerates_at_stall_torque_over_the_total_inertia():
    scene = motor_scene(GEAR)
    [solution] = solutions_at(scene, {"axle": 12.0})
    total = ARM_INERTIA + scene.drives["axle"].reflected_inertia
    assert solution.dv[0] == pytest.approx(stall_torque(scene.drives["axle"]) / total, rel=1e-9)


# ------------------------------------------------------------------------ analysis in volts
def rolling_velocity(scene):
    """A velocity of the scene that keeps every active contact closed (J_N v = 0), hips moving."""
    normal = ContactProblem.from_scene(scene).jacobian_normal
    basis = np.linalg.svd(normal)[2][normal.shape[0]:]  # null space of J_N, one row per direction
    v = basis.T @ np.array([1.0, -0.7])[: basis.shape[0]]
    hips = [scene.coordinate_names.index(j) for j in ("hip_middle", "hip_rear")]
    return 2.0 * v / np.max(np.abs(v[hips]))


def test_the_analysis_in_volts_is_the_torque_analysis_through_the_affine_map():
    """solutions_at with drives at voltage u = solutions_at without drives at the torque
    tau = eta N C_M / R u - eta N^2 C_M C_E / R qdot, with M augmented by the reflected inertia."""
    plain = load_scene("rhex_flip")
    v = rolling_velocity(plain)
    sets = {f"state.v.{name}": float(x) for name, x in zip(plain.coordinate_names, v, strict=True)}
    # rhex_flip's robot (rigid massless legs) with rhex_flip_drives' drives at RHexLib's 24 V
    pair = {"kind": "dc_motor", "resistance": 0.665, "torque_constant": 0.0161,
            "back_emf_constant": 0.01806, "rotor_inertia": 1.822e-6, "voltage_limit": 24.0,
            "stages": [{"ratio": 33.0625, "efficiency": 0.7}]}
    driven = load_scene("rhex_flip", overrides={
        **sets, "model.drives.hip_middle": pair, "model.drives.hip_rear": pair,
        "inputs.lower": [-24.0, -24.0], "inputs.upper": [24.0, 24.0]})
    torque = load_scene("rhex_flip", overrides=sets)
    volt_problem = ContactProblem.from_scene(driven)
    torque_problem = ContactProblem.from_scene(torque)
    assert np.allclose(volt_problem.normal_velocities, 0.0, atol=1e-12)
    index = [driven.coordinate_names.index(j) for j in driven.inputs.coordinates]
    augmented = torque_problem.mass_matrix.copy()
    for i, joint in zip(index, driven.inputs.coordinates, strict=True):
        augmented[i, i] += driven.drives[joint].reflected_inertia
    assert np.allclose(volt_problem.mass_matrix, augmented, rtol=1e-12, atol=1e-15)
    torque_problem = replace(torque_problem, mass_matrix=augmented)
    rng = np.random.default_rng(16)
    compared = 0
    for u in rng.uniform(-24.0, 24.0, size=(6, 2)):
        tau = np.array([joint_torque(driven.drives[j], u[k], v[i])
                        for k, (i, j) in enumerate(zip(index, driven.inputs.coordinates, strict=True))])
        by_volts = {s.mode: s for s in solutions_at(volt_problem, u)}
        by_torque = {s.mode: s for s in solutions_at(torque_problem, tau)}
        assert set(by_volts) == set(by_torque)
        for mode, s in by_volts.items():
            assert np.allclose(s.dv, by_torque[mode].dv, rtol=1e-7, atol=1e-7)
            assert np.allclose(s.lambda_n, by_torque[mode].lambda_n, rtol=1e-7, atol=1e-7)
            compared += 1
    assert compared >= 3
    # the voltage box maps onto the torque-speed band: the same modes are feasible
    bands = np.array([torque_limits(driven.drives[j], v[i]) for i, j in zip(index, driven.inputs.coordinates,
                                                                             strict=True)])
    banded = replace(torque_problem, lower=bands[:, 0], upper=bands[:, 1])
    assert ([m.mode for m in analyze(volt_problem).feasible_modes]
            == [m.mode for m in analyze(banded).feasible_modes])


def test_analyze_json_names_each_inputs_unit_and_the_drives_torque_band():
    result = runner.invoke(app, ["analyze", "rhex_flip_drives", "--json", "--set", "state.v.hip_rear=10"])
    assert result.exit_code == 0, result.stderr
    payload = json.loads(result.stdout)
    assert payload["input_units"] == {"hip_middle": "V", "hip_rear": "V"}
    rear = payload["drives"]["hip_rear"]
    assert rear["torque_limits"][1] == pytest.approx(rear["stall_torque"] * (1 - 10 / rear["no_load_speed"]))
    torque = json.loads(runner.invoke(app, ["analyze", "rhex_flip", "--json"]).stdout)
    assert torque["input_units"] == {"hip_middle": "N m", "hip_rear": "N m"}


def test_the_shipped_rhex_drives_are_a_motor_pair_within_20_newton_metres_at_rhexlibs_supply():
    scene = load_scene("rhex_flip_drives")
    for drive in scene.drives.values():
        # RHexLib's motor (hardware/UofM/config.hh), two in parallel: R / 2, twice the rotor inertia
        assert drive.resistance == pytest.approx(1.33 / 2)
        assert drive.rotor_inertia == pytest.approx(2 * 9.11e-7)
        # the supply is 38 V, above RHexLib's 24 V (the pumping flip ends right side up there, not at
        # 24 V: docs/rhex-flip.md); at 24 V a pair gives at most 20 N m at stall
        assert drive.ratio == 33.0625 and drive.voltage_limit == 38.0
        lossless = 33.0625 * drive.torque_constant * 24.0 / drive.resistance  # N C_M U / R at 24 V
        assert lossless <= 20.0
        assert stall_torque(drive) == pytest.approx(drive.efficiency * lossless * 38.0 / 24.0)


# ---------------------------------------------------------------------------- simulate output
def test_simulate_json_and_out_carry_each_drives_samples(tmp_path):
    out = tmp_path / "run.npz"
    result = runner.invoke(app, ["simulate", "rhex_flip_drives", "-i", "hip_rear=-12", "-T", "0.01",
                                 "--json", "--out", str(out)])
    assert result.exit_code == 0, result.stderr
    payload = json.loads(result.stdout)
    assert payload["summary"]["input_units"]["hip_rear"] == "V"
    drives = payload["samples"]["drives"]
    assert set(drives) == {"hip_middle", "hip_rear"}
    rear = drives["hip_rear"]
    assert set(rear) >= {"voltage", "current", "motor_speed", "torque"}
    times = payload["samples"]["times"]
    assert all(len(rear[key]) == len(times) for key in rear)
    assert rear["voltage"][-1] == -12.0
    assert rear["current"][-1] == pytest.approx((-12.0 - 0.01806 * rear["motor_speed"][-1]) / 0.665)
    v_rear = [row[payload["summary"]["coordinates"].index("hip_rear")] for row in payload["samples"]["v"]]
    assert rear["motor_speed"] == pytest.approx([33.0625 * x for x in v_rear])
    arrays = np.load(out)
    assert arrays["drives.hip_rear.current"] == pytest.approx(rear["current"])
    csv_path = tmp_path / "run.csv"
    result = runner.invoke(app, ["simulate", "rhex_flip_drives", "-T", "0.004", "--out", str(csv_path)])
    assert result.exit_code == 0
    lines = csv_path.read_text().splitlines()
    header = lines[0].split(",")
    names = ("voltage", "current", "motor_speed", "torque")
    first = header.index("drives.hip_rear.voltage")
    assert header[first:first + 4] == [f"drives.hip_rear.{name}" for name in names]
    assert all(math.isfinite(float(x)) for x in lines[1].split(",")[first - 4:first + 4])


# --------------------------------------------------------------------------- elastic stages
def crossing_period(times, signal):
    """[s] The mean period of an oscillation, from its zero crossings (linear interpolation)."""
    i = np.nonzero(np.diff(np.sign(signal)))[0]
    crossings = times[i] - signal[i] * (times[i + 1] - times[i]) / (signal[i + 1] - signal[i])
    return 2.0 * float(np.mean(np.diff(crossings)))


SPRING = 2.0
"""[N m/rad] the torsion element of the two-inertia tests."""

TWO_INERTIAS = [
    # the spring after a 5:1 gear: the rotor's 1e-4 kg m^2 is 25e-4 at the spring, the arm on it
    ([{"ratio": 5.0, "stiffness": SPRING, "deflection": 0.1}], 25e-4, ARM_INERTIA),
    # the spring on the rotor, a 4:1 gear (input gear 1e-4 kg m^2) between it and the arm
    ([{"ratio": 1.0, "stiffness": SPRING, "deflection": 0.1}, {"ratio": 4.0, "inertia_in": 1e-4}],
     1e-4, (ARM_INERTIA + 16e-4) / 16),
]


@pytest.mark.parametrize(("stages", "i1", "i2"), TWO_INERTIAS)
def test_two_inertias_on_a_torsion_spring_oscillate_at_the_closed_form_frequency(stages, i1, i2):
    """sqrt(c (I1 + I2) / (I1 I2)), both inertias reflected to the spring's ends; no back-EMF."""
    scene = motor_scene(stages, back_emf_constant=0.0, rotor_inertia=1e-4)
    period = 2 * math.pi / math.sqrt(SPRING * (i1 + i2) / (i1 * i2))
    run = simulate_compliant(scene, {"axle": 0.0}, 3 * period, period / 100,
                             settings=CompliantSettings(rtol=1e-8, atol=1e-10))
    stages_out = json.loads(json.dumps(run.to_dict(scene)))["samples"]["stages"]["axle"]
    deflection = np.array(stages_out["deflection"])
    assert deflection.shape == (len(run.times), len(stages))
    assert deflection[0, 0] == pytest.approx(0.1) and np.all(deflection[:, 1:] == 0.0)
    assert crossing_period(run.times, deflection[:, 0]) == pytest.approx(period, rel=1e-7)
    assert run.info["state_size"] == 2 + 2  # (q, v) and one cluster's (theta, omega)
    # the rigid stepper's implicit Euler keeps the period to second order in the step
    # ((omega h)^2 / 3 = 8.2e-5 at 400 steps a period)
    rigid = simulate_rigid(scene, {"axle": 0.0}, 3 * period, period / 400)
    twist = np.array([r["axle"]["deflection"][0] for r in _reports(scene, rigid)])
    assert crossing_period(rigid.times, twist) == pytest.approx(period, rel=2e-4)
    # the arm's momentum about the axle and the spring's motor side balance (no external torque):
    # I1 theta_1' + I2 (rho q') is constant (here 0)
    state = rigid.info["transmissions"]["state"]
    ratio = scene.drives["axle"].stages[-1].ratio if len(stages) > 1 else 1.0
    momentum = i1 * state[:, 1] + i2 * ratio * rigid.v[:, 0]
    assert np.max(np.abs(momentum)) < 1e-9


def _reports(scene, trajectory):
    from frcontrol.simulation.transmissions import Transmissions

    model = Transmissions(scene)
    states = trajectory.info["transmissions"]["state"]
    return [model.report(q, v, z, u) for q, v, z, u in zip(trajectory.q, trajectory.v, states,
                                                            trajectory.inputs, strict=True)]


def test_an_elastic_drive_reaches_the_rigid_drives_steady_speed():
    """At steady speed the spring carries no torque: u / (C_E N) at the joint, as if rigid."""
    stages = [{"ratio": 10.0, "stiffness": 5.0, "damping": 0.05, "inertia_out": 1e-4}]
    scene = motor_scene(stages)
    run = simulate_rigid(scene, {"axle": 6.0}, 2.0, 1e-3)
    assert run.v[-1, 0] == pytest.approx(6.0 / (0.05 * 10.0), rel=1e-5)
    samples = drive_samples(scene, run)["axle"]
    assert samples["motor_speed"][-1] == pytest.approx(6.0 / 0.05, rel=1e-5)
    assert abs(samples["torque"][-1]) < 1e-5


def test_the_analysis_of_an_elastic_drive_takes_the_spring_torque_and_not_the_voltage():
    """`frc analyze` with an elastic stage: the joint sees the spring's torque at the scene's
    deflection (a known generalized force); the voltage does not reach the joint in the instant."""
    stages = [{"ratio": 10.0, "stiffness": 5.0, "deflection": 0.02, "inertia_out": 1e-4},
              {"ratio": 2.0, "efficiency": 0.9, "inertia_in": 1e-5}]
    document = motor_document(stages, gravity=9.81)
    document["state"]["q"] = [0.4]
    scene = scene_from_document(document)
    joint_side = ARM_INERTIA + 4 * 1e-5  # the rigid stage after the spring turns with the joint
    spring = 0.9 * 2.0 * 5.0 * 0.02      # eta rho c delta at the joint
    gravity = 1.0 * 9.81 * 0.1 * math.cos(0.4)
    for u in (-12.0, 0.0, 12.0):
        [solution] = solutions_at(scene, {"axle": u})
        assert solution.dv[0] == pytest.approx((spring - gravity) / joint_side, rel=1e-9)
    assert scene.inputs.selection_transpose(1)[0, 0] == 0.0


# ------------------------------------------------------------------------------ energy balance
ENERGY_STAGES = [
    [{"ratio": 10.0, "inertia_in": 1e-6, "inertia_out": 1e-4}],
    [{"ratio": 10.0, "stiffness": 5.0, "damping": 0.02, "inertia_out": 1e-4},
     {"ratio": 2.0, "inertia_in": 1e-5}],
]


def energy_balance(scene, run):
    """max |E(t) - E(0) - int (u i - i^2 R - sum d delta'^2) dt| [J], and the work's scale [J]."""
    samples = drive_samples(scene, run)["axle"]
    power = samples["voltage"] * samples["current"] - samples["current"] ** 2 * MOTOR["resistance"]
    drive = scene.drives["axle"]
    if drive.elastic:
        rates = stage_samples(scene, run)["axle"]["deflection_rate"]
        power = power - rates ** 2 @ np.array([s.damping for s in drive.stages])
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(run.times))])
    energy = run.info["energy"] + run.info.get("elastic_energy", 0.0)
    return float(np.max(np.abs(energy - energy[0] - work))), float(np.max(np.abs(work)))


@pytest.mark.parametrize("stages", ENERGY_STAGES, ids=["rigid", "elastic"])
def test_electrical_input_less_losses_is_the_mechanical_energy_change(stages):
    """A motor swinging a pendulum (C_M = C_E in SI units, efficiency 1): u i - i^2 R - d delta'^2
    = d/dt (kinetic + potential + the springs'), to the integrator's tolerance."""
    scene = motor_scene(stages, gravity=9.81)
    run = simulate_compliant(scene, {"axle": 6.0}, 0.2, 2e-4,
                             settings=CompliantSettings(rtol=1e-10, atol=1e-12))
    error, scale = energy_balance(scene, run)
    assert scale > 0.1 and error < 2e-5 * scale  # the trapezoidal rule's error on the samples
    # the rigid stepper's implicit Euler dissipates at first order in its step
    errors = [energy_balance(scene, simulate_rigid(scene, {"axle": 6.0}, 0.2, dt))[0] for dt in (2e-4, 1e-4)]
    assert errors[1] < 0.6 * errors[0] and errors[1] < 0.02 * scale


def test_an_elastic_transmission_moves_over_the_whole_step_when_the_step_is_split_at_a_landing():
    """A rigid step split at a landing moves the joints over all of it: the transmission must too.

    RHex with an elastic rear gearhead lands its body 3.5 mm below (v_y = -1 m/s), so that the
    step ending at 4 ms is split twice at the landings. Moving the transmission over the last part
    only made the stage's deflection jump there: at dt = 1 ms it read 2.3e-4 rad against 6.6e-4 rad
    at dt = 0.1 ms (error 4.3e-4); over the whole step, 5.3e-4 against 7.1e-4 (first-order error
    1.8e-4, as away from landings).
    """
    stage = [{"ratio": 33.0, "efficiency": 0.7, "stiffness": 50.0, "inertia_in": 1e-5}]
    base = load_scene("rhex_flip_drives")
    scene = load_scene("rhex_flip_drives", overrides={
        "model.drives.hip_rear.stages": stage, "state.q.y": float(base.q[1]) + 0.0035, "state.v.y": -1.0})
    deflections = {}
    for dt in (1e-3, 1e-4):
        run = simulate_rigid(scene, {"hip_middle": 3.0, "hip_rear": 6.0}, duration=0.005, dt=dt)
        assert run.info["impacts"], "the body lands within the run"
        deflection = stage_samples(scene, run)["hip_rear"]["deflection"][:, 0]
        deflections[dt] = float(np.interp(0.004, np.asarray(run.times), deflection))
    assert abs(deflections[1e-3] - deflections[1e-4]) < 2.5e-4, deflections
