"""The pumping flip: the drive's torque-speed line in closed form, the pumping run checked from its
samples alone (every torque on the motor's line, the energy drawn, the phases), the flip through
the compliant legs verified by simulation (rigid and compliant) and by its energy audit, and the
command line."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from conftest import one_error_line
from typer.testing import CliRunner

from frcontrol.drives import joint_torque, no_load_speed, stall_torque, torque_limits
from frcontrol.engine import solutions_at
from frcontrol.errors import SceneError
from frcontrol.planning.flip import FlipSettings, flip_task, mode_allowed, plan_flip
from frcontrol.planning.flip_budget import flip_budget
from frcontrol.planning.pump import (
    REST_SPEED,
    UPRIGHT_TOLERANCE,
    pump_flip,
    pump_payload,
    pump_samples,
    simulate_pump,
    verify_compliant,
    voltage_for_torque,
    within_limits,
)
from frcontrol.scene import load_scene
from frcontrol.simulation.energy_audit import AUDIT_TERMS, AUDIT_TOLERANCE

runner = CliRunner()
PITCH = 2  # theta in RHex's coordinates
STRONG_VOLTS = 250.0
"""[V] The motors at this voltage limit (140 N m stall, 419 rad/s, ten times RHex's pair): one
stroke flips the body."""


RHEX_SUPPLY = 24.0
"""[V] RHexLib's drive supply (DRIVE_SUPPLY, hardware/UofM/config.hh): 13.4 N m stall per pair."""


def _at_supply(volts: float) -> dict:
    """``--set`` overrides putting both drives and the input limits of rhex_flip_drives at ``volts``."""
    sets = {f"model.drives.{j}.voltage_limit": volts for j in ("hip_middle", "hip_rear")}
    sets.update({"inputs.lower": [-volts] * 2, "inputs.upper": [volts] * 2})
    return sets


@pytest.fixture(scope="module")
def rhex():
    """RHex on its back with compliant legs, at RHexLib's 24 V supply (the shipped scene has 38 V)."""
    return load_scene("rhex_flip_drives", overrides=_at_supply(RHEX_SUPPLY))


@pytest.fixture(scope="module")
def rigid_legs():
    """The same body with rigid massless legs (rhex_flip): the budget's closed forms hold there."""
    return load_scene("rhex_flip")


@pytest.fixture(scope="module")
def pumped(rhex):
    """Two cycles at 24 V (13.4 N m stall per pair), with the first push's plan."""
    return pump_flip(rhex, max_time=0.6)


@pytest.fixture(scope="module")
def shipped():
    """The shipped scene (38 V) and its pumping flip, run until it rests right side up."""
    scene = load_scene("rhex_flip_drives")
    return scene, simulate_pump(scene, max_time=2.0)


@pytest.fixture(scope="module")
def strong():
    scene = load_scene("rhex_flip_drives", overrides=_at_supply(STRONG_VOLTS))
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


def test_the_hip_pairs_at_rhexlibs_supply_are_within_twenty_newton_metres(rhex):
    for drive in rhex.drives.values():
        assert 0 < stall_torque(drive) <= 20.0 and 20.0 < no_load_speed(drive) < 45.0
        # the convention without the gearhead's loss, N C_M U / R, is within 20 N m too
        assert stall_torque(drive) / drive.efficiency == pytest.approx(19.2, abs=0.05)


SHIPPED_SUPPLY = 38.0
"""[V] rhex_flip_drives' supply: above RHexLib's 24 V and the 20 N m cap (the scene says by how much)."""


def test_the_shipped_supply_and_its_stall_torque_by_both_conventions():
    for drive in load_scene("rhex_flip_drives").drives.values():
        assert drive.voltage_limit == SHIPPED_SUPPLY
        assert stall_torque(drive) == pytest.approx(21.29, abs=0.01)  # eta N C_M U / R
        assert stall_torque(drive) / drive.efficiency == pytest.approx(30.42, abs=0.01)  # N C_M U / R


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

BODY_MASS, BODY_INERTIA, TOE_MASS = 7.5, 0.1668125, 0.02
"""[kg], [kg m^2] RHex's body (rhex_planar.urdf; the legs are massless); [kg] a toe of
rhex_planar_legs.urdf."""
LEGS_BODY_MASS, LEGS_BODY_INERTIA, LEGS_CORNER = 7.0, 0.1737167, (0.265, 0.065)
"""[kg], [kg m^2], [m] RHex's body as built in rhex_planar_legs.urdf: 7 kg, a uniform 0.53 x 0.13 m
box, its front corner in the body frame."""
TOES = ("front_toe", "middle_toe", "rear_toe")
CORNER, HIP_DEPTH, LEG = (0.25, 0.065), 0.065, 0.17
"""[m] The front corner in the body frame, the hips' height above the shell lying flat (the hips on
the mid-plane, 0.065 below the back face), a leg's length (rhex_planar.urdf)."""


def _closed_form_reach(hip_to_corner: float) -> float:
    """[rad] The pitch above flat at which a hip ``hip_to_corner`` [m] behind the front corner (along
    the body) rises ``LEG`` above the ground, the body pivoting on the corner:
    ``hip_to_corner sin a + HIP_DEPTH cos a = LEG``."""
    return math.asin(LEG / math.hypot(hip_to_corner, HIP_DEPTH)) - math.atan2(HIP_DEPTH, hip_to_corner)


def test_the_flip_budget_is_the_closed_form_of_the_geometry(rigid_legs):
    rhex = rigid_legs
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


def test_the_compliant_legs_reach_as_far_as_rigid_ones_and_toes_add_to_the_barrier(rhex):
    compliant = flip_budget(rhex)
    # at rest length (0.17 m) the springs' legs reach as rigid legs would, on the 0.53 m body
    step = compliant.pitch_step
    for joint, behind in (("hip_middle", LEGS_CORNER[0]), ("hip_rear", LEGS_CORNER[0] + 0.2)):
        reach = compliant.reach_pitch[joint] - math.pi
        assert _closed_form_reach(behind) - step <= reach <= _closed_form_reach(behind)
    # the three 0.02 kg toes rise with the body: at most 0.06 kg x g x 0.5 m above the body's barrier
    g, y0 = rhex.robot.gravity, float(rhex.q[1])
    body_only = LEGS_BODY_MASS * g * (math.hypot(*LEGS_CORNER) - y0)
    extra = compliant.barrier_energy - body_only
    assert 0.0 < extra < 3 * TOE_MASS * g * 0.5
    # the belly's corners lie on the body: they are not toes
    assert set(compliant.hold_pitch) == {"front_toe", "middle_toe", "rear_toe"}


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
    # the body's mechanical energy above the start, from the samples and the URDFs' masses alone:
    # the body, and each toe as a point mass moving with the body (joints held: M_bb)
    mass, inertia = LEGS_BODY_MASS, LEGS_BODY_INERTIA
    energy = 0.5 * mass * (v[:, 0] ** 2 + v[:, 1] ** 2) + 0.5 * inertia * v[:, 2] ** 2 \
        + mass * rhex.robot.gravity * (q[:, 1] - q[0, 1])
    points = result.trajectory.contact_points
    for toe in TOES:
        r = points[:, result.trajectory.contacts.index(toe)] - q[:, :2]
        speed = v[:, :2] + v[:, 2:3] * np.column_stack([-r[:, 1], r[:, 0]])
        height = points[:, result.trajectory.contacts.index(toe), 1]
        energy += 0.5 * TOE_MASS * np.sum(speed**2, axis=1) \
            + TOE_MASS * rhex.robot.gravity * (height - height[0])
    assert pump["max_energy"] == pytest.approx(float(energy.max()), abs=1e-9)
    assert pump["max_energy"] < pump["budget"]["barrier_energy"]
    # every push after the first starts as the body falls back onto its toes, still moving (the
    # legs reach 0.46 rad up, so the body lands on them, not at rest), and no cycle reaches the barrier
    pushes = [p for p in pump["phases"] if p["kind"] == "push"]
    assert len(pushes) >= 2
    for push in pushes[1:]:
        k = int(np.searchsorted(times, push["start"]))
        kinetic = 0.5 * mass * (v[k, 0] ** 2 + v[k, 1] ** 2) + 0.5 * inertia * v[k, 2] ** 2
        assert kinetic > 1.0
    assert all(e < pump["budget"]["barrier_energy"] for e in pump["cycle_max_energy"])
    barrier = f"{pump['budget']['barrier_energy']:.2f} J brings its centre of mass over front_corner"
    assert barrier in doc["simulation"]["reason"]


# ---------------------------------------------------------------- a flip, by simulation


def test_a_strong_enough_drive_flips_and_the_samples_show_it(strong):
    scene, strong = strong
    task = flip_task(scene)
    pitch = strong.trajectory.q[:, task.pitch_index]
    crossed = int(np.argmax(pitch >= task.vertical))
    assert strong.flipped and pitch[crossed] >= task.vertical > pitch[:crossed].max()
    assert strong.trajectory.times[crossed - 1] <= strong.time_to_vertical <= strong.trajectory.times[crossed]
    assert strong.trajectory.status == "completed"
    assert strong.phases[0].kind == "push" and strong.phases[1].kind in ("recirculate", "land")


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


# ------------------------------------------- the shipped flip, through the compliant legs


def test_the_shipped_flip_passes_vertical_and_rests_right_side_up(shipped):
    scene, result = shipped
    traj, task = result.trajectory, flip_task(scene)
    pitch, times = traj.q[:, task.pitch_index], traj.times
    crossed = int(np.argmax(pitch >= task.vertical))
    assert result.flipped and crossed > 0 and result.time_to_vertical < 5.0
    assert times[crossed - 1] <= result.time_to_vertical <= times[crossed]
    # at rest right side up at the end: pitch 2 pi, the base's velocities within REST_SPEED
    assert abs(pitch[-1] - 2 * math.pi) < UPRIGHT_TOLERANCE and result.right_side_up
    assert np.all(np.abs(traj.v[-1, :3]) <= REST_SPEED) and result.phases[-1].ended_by == "at rest"
    assert result.phases[-1].kind == "land" and traj.status == "completed"
    # every sample's voltage within the supply, every torque on the motor's line within its limits
    limit = [scene.drives[name].voltage_limit for name in scene.inputs.coordinates]
    assert np.all(np.abs(traj.inputs) <= np.array(limit) + 1e-12)
    assert within_limits(pump_samples(scene, traj))


def test_the_shipped_flip_pumps_through_the_springs(shipped):
    scene, result = shipped
    # at least two pushes, each cycle's peak energy above the previous one's
    assert result.cycles >= 2
    energy = result.cycle_max_energy
    assert all(b > a for a, b in zip(energy, energy[1:], strict=False)), energy
    # the springs worked: the legs were compressed under load, and released
    springs = scene.robot.springs
    deflection = springs.deflection(result.trajectory.q)
    assert springs.joints == ("spring_middle", "spring_rear")
    assert np.all(deflection.min(axis=0) < -5e-3)  # more than 5 mm compressed at some instant
    assert np.all(np.abs(deflection[-1]) < 1e-3)    # back at rest length, the legs in the air


def test_every_samples_mode_is_one_the_plan_allowed(shipped):
    scene, result = shipped
    traj = result.trajectory
    check = result.modes_check()
    names = [c.name for c in scene.contacts]
    # recount from the samples' modes and each phase's allowed modes and free letters alone
    outside = 0
    for k in range(1, len(traj.times)):
        phase = next(p for p in result.phases if p.start <= traj.times[k - 1] + 1e-12 < p.end)
        deciding = [phase, *(p for p in result.phases if abs(p.start - traj.times[k]) <= 1e-12)]
        outside += not any(mode_allowed(traj.modes[k], base, names, p.free)
                           for p in deciding for base in p.allowed)
    assert check["outside"] == outside == 0 and check["within"] and check["samples"] == len(traj.times) - 1
    # a push allows its toes any letter and the rear corner a graze; its pivot keeps its letter
    pushes = [p for p in result.phases if p.kind == "push" and p.allowed]
    assert pushes and all(p.free == {"rear_corner": "SFLR", "middle_toe": "SFLR", "rear_toe": "SFLR"}
                          for p in pushes)
    for phase in pushes:
        inside = (traj.times > phase.start) & (traj.times <= phase.end)
        assert all(traj.modes[k][0] in "FLR" for k in np.nonzero(inside)[0])


def test_the_modes_check_is_strict_without_the_phases_free_letters(shipped):
    _, result = shipped
    # the same run judged against the decisions' modes alone: the toes' lift-offs between two
    # decisions (and the landings) fall outside
    bare = replace(result, phases=tuple(replace(p, free={}) for p in result.phases))
    check = bare.modes_check()
    assert not check["within"] and check["outside"] > 0 and check["first"]["phase"] == "push"
    # a pivot that separates in a push is outside, whatever the toes do
    push = next(p for p in result.phases if p.kind == "push" and p.allowed)
    assert push.allows(push.allowed[0], result.contacts)
    assert not push.allows("S" + push.allowed[0][1:], result.contacts)


def test_mode_allowed_compares_letter_by_letter():
    contacts = ("corner", "toe")
    assert mode_allowed("FL", "FL", contacts, None)
    assert not mode_allowed("FS", "FL", contacts, None)
    assert mode_allowed("FS", "FL", contacts, {"toe": "S"})
    assert not mode_allowed("SL", "FL", contacts, {"toe": "SFLR"})


def test_the_push_plan_accepts_the_allowed_modes_in_its_unambiguity_constraint(shipped):
    scene, _ = shipped
    toes_free = FlipSettings(free={"middle_toe": "SFLR", "rear_toe": "SFLR"})
    strict, free = plan_flip(scene), plan_flip(scene, settings=toes_free)
    assert strict.found and free.found
    # more modes allowed: the unambiguous set can only grow, so the best pitch cannot fall
    assert free.pitch_acceleration >= strict.pitch_acceleration - 1e-9
    solutions = solutions_at(free.analysis, free.input_vector(free.planned_inputs))
    modes = [s.mode for s in solutions]
    assert free.mode in modes
    assert all(mode_allowed(m, free.mode, free.contacts, {"middle_toe": "SFLR", "rear_toe": "SFLR"})
               for m in modes)


def test_the_energy_audit_closes_within_one_percent(shipped):
    scene, result = shipped
    audit, traj = result.energy_audit, result.trajectory
    terms = audit.terms
    energy = traj.info["energy"]
    assert audit.change == pytest.approx(float(energy[-1] - energy[0]), abs=1e-12)
    assert terms["drawn"] == pytest.approx(result.energy_drawn, rel=1e-12)
    # the winding's heat, from the samples' currents alone
    samples = pump_samples(scene, traj)["drives"]
    dt = np.diff(traj.times)
    heat = sum(scene.drives[j].resistance * np.asarray(d["current"])[1:] ** 2 * dt
               for j, d in samples.items())
    assert -terms["resistance"] == pytest.approx(float(np.sum(heat)), rel=1e-12)
    # losses are losses
    for name in ("resistance", "spring_damping", "slip", "landings", "time_stepping"):
        assert terms[name] <= 0.0, name
    assert terms["landings"] < -1.0 and terms["slip"] < -1.0 and terms["spring_damping"] < -0.5
    # the sum closes on the measured change within 1 % of the energy drawn ...
    assert audit.closes and abs(audit.residual) <= AUDIT_TOLERANCE * terms["drawn"]
    # ... and would not without any one of the big terms
    for name in ("resistance", "conversion", "slip", "landings"):
        assert abs(audit.residual + terms[name]) > AUDIT_TOLERANCE * audit.scale, name
    doc = result.to_dict()["energy_audit"]
    assert set(AUDIT_TERMS) <= set(doc) and doc["closes"] is True


def test_the_push_plan_sees_the_springs_state(shipped):
    scene, _ = shipped
    plan = plan_flip(scene)
    # the same state with the middle leg compressed by 1 cm: its spring pushes 32 N, and the plan changes
    q = np.array(scene.q)
    q[scene.coordinate_names.index("spring_middle")] -= 0.01
    compressed = plan_flip(scene.at(q, scene.v))
    assert plan.found and compressed.found
    assert compressed.pitch_acceleration != pytest.approx(plan.pitch_acceleration, rel=1e-3)


@pytest.mark.slow
def test_the_shipped_flip_passes_vertical_in_the_compliant_replay(shipped):
    scene, result = shipped
    check = verify_compliant(scene, result, to_end=True)
    assert check["status"] == "completed" and check["torque_within_limits"]
    assert check["flipped"] and check["time_to_vertical"] < 5.0, check
    # replayed to the rigid run's end, the compliant body lands right side up too
    assert check["duration"] == pytest.approx(float(result.trajectory.times[-1]), abs=1e-9)
    assert check["right_side_up"] and abs(check["final_pitch"] - 2 * math.pi) < UPRIGHT_TOLERANCE


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
        assert bad.exit_code == 1 and "Traceback" not in bad.output
        one_error_line(bad.stderr)  # beside any progress lines: a loaded machine may show them first
    assert math.isfinite(doc["pump"]["energy_drawn"])
    assert {"final_pitch", "right_side_up", "at_rest", "modes_check", "energy_audit"} <= set(doc["pump"])
    text = runner.invoke(app, ["flip", "rhex_flip_drives", "--max-time", "0.3"])
    assert text.exit_code == 0 and "right side up: no" in text.stdout and "energy audit" in text.stdout


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


def test_a_toe_that_reaches_the_ground_holds_the_body_only_with_the_centre_of_mass_behind_it(rigid_legs):
    rhex = rigid_legs
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
