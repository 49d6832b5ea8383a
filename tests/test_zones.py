"""Contact zones of the compliant model (Vukobratovic-Potkonjak Fig. 6) against closed forms."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import ROBOTS
from frcontrol.cli.app import app
from typer.testing import CliRunner

from frcontrol.errors import InputError, SceneError
from frcontrol.scene import load_scene
from frcontrol.simulation.compliant import CompliantSettings, simulate_compliant
from frcontrol.simulation.rigid import simulate_rigid

G = 9.81
MASS = 1.0  # disk.urdf [kg]; its bottom point (0, -0.1) is under the centre of mass: no rotation


def disk_scene(zone: dict, y0: float = 0.1, v0: float = 0.0, gravity: float = G) -> dict:
    return {
        "name": "disk on a zone",
        "robot": str(ROBOTS / "disk.urdf"),
        "gravity": gravity,
        "state": {"q": [0.0, y0, 0.0], "v": [0.0, v0, 0.0]},
        "contacts": [{"name": "bottom", "link": "disk", "point": [0.0, -0.1], "normal": [0.0, 1.0],
                      "mu": 0.5, "surface_point": [0.0, 0.0]}],
        "model": {"contact": "compliant", "contacts": {"bottom": zone}},
    }


def zone_series(traj, part: str) -> np.ndarray:
    return np.asarray(traj.info["zones"]["bottom"][part])


@pytest.mark.parametrize("stiffness", [1e4, 4e4])
def test_one_stage_zone_under_gravity_sinks_m_g_over_k_at_sqrt_k_over_m(write_scene, stiffness):
    """Released undeformed, undamped: deflection (m g / k)(1 - cos(w t)), w = sqrt(k / m)."""
    zone = {"zone": "one_stage", "mass_robot": 0.01, "stiffness_internal_robot": stiffness}
    traj = simulate_compliant(load_scene(write_scene(disk_scene(zone))), None, 0.1, 1e-3)
    static, omega = MASS * G / stiffness, math.sqrt(stiffness / MASS)
    deflection = zone_series(traj, "deformation")
    np.testing.assert_allclose(deflection, static * (1 - np.cos(omega * traj.times)), atol=1e-6 * static)
    np.testing.assert_allclose(zone_series(traj, "force"), stiffness * deflection, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(traj.q[:, 1], 0.1 - deflection, atol=1e-12)


def test_a_damped_one_stage_zone_settles_at_m_g_over_k(write_scene):
    k = 1e4
    zone = {"zone": "one_stage", "mass_robot": 0.01, "stiffness_internal_robot": k,
            "damping_internal_robot": 2 * 0.7 * math.sqrt(k * MASS)}
    traj = simulate_compliant(load_scene(write_scene(disk_scene(zone))), None, 0.3, 1e-3)
    assert zone_series(traj, "deformation")[-1] == pytest.approx(MASS * G / k, rel=1e-5)
    assert traj.contact_forces[-1, 0, 0] == pytest.approx(MASS * G, rel=1e-5)


def test_a_one_stage_mass_landing_loses_its_kinetic_energy(write_scene):
    """The mass rides its spring in free fall, so it lands at sqrt(2 g h): 1/2 m' 2 g h is lost."""
    height, m_zone = 0.01, 0.01
    zone = {"zone": "one_stage", "mass_robot": m_zone, "stiffness_internal_robot": 1e4}
    scene = load_scene(write_scene(disk_scene(zone, y0=0.1 + height)))
    traj = simulate_compliant(scene, None, 0.05, 1e-4, settings=CompliantSettings(contacts="all"))
    assert traj.info["zone_landing_energy"] == pytest.approx(m_zone * G * height, rel=0.01)
    assert [e.kind for e in traj.events][:1] == ["impact"]


def two_stage(k: float, m_zone: float = 1e-3) -> dict:
    """Internal k on both sides, external 2 k on both sides (k in series): k / 3 overall. Light
    internal dampers, sqrt(k m'), calm the masses' fast modes and barely touch the slow one."""
    b = math.sqrt(k * m_zone)
    return {"zone": "two_stage", "mass_robot": m_zone, "stiffness_internal_robot": k,
            "damping_internal_robot": b, "stiffness_external_robot": 2 * k, "mass_environment": m_zone,
            "stiffness_internal_environment": k, "damping_internal_environment": b,
            "stiffness_external_environment": 2 * k}


def test_two_stage_impact_peak_force_and_duration_are_the_linear_springs(write_scene):
    """A 1 kg body at 1 m/s on k_eff = k / 3: peak v sqrt(k_eff m), duration pi sqrt(m / k_eff)."""
    k, speed = 3e3, 1.0
    k_eff = k / 3
    duration = math.pi * math.sqrt(MASS / k_eff)
    scene = load_scene(write_scene(disk_scene(two_stage(k), y0=0.101, v0=-speed, gravity=0.0)))
    traj = simulate_compliant(scene, None, 0.001 + 1.2 * duration, duration / 50,
                              settings=CompliantSettings(contacts="all"))
    impact = next(e.to_dict() for e in traj.events if e.kind == "impact")
    assert impact["normal_velocity_before"] == pytest.approx(-speed, rel=1e-9)
    assert impact["peak_force"] == pytest.approx(speed * math.sqrt(k_eff * MASS), rel=0.02)
    assert impact["duration"] == pytest.approx(duration, rel=0.01)
    # the impulse is the momentum change; the light dampers keep ~98% of the speed
    momentum = MASS * (impact["normal_velocity_after"] + speed)
    assert impact["impulse_normal"] == pytest.approx(momentum, rel=1e-3)
    assert 0.95 < impact["normal_velocity_after"] / speed < 1.0


def test_two_stage_impacts_approach_the_momentum_law_as_the_stiffnesses_grow(write_scene):
    """k x 100: the impact lasts 10 times less, and the motion after it comes 10 times closer to the
    rigid model's impact law with the same restitution."""
    end = 0.13  # the soft impact lasts pi sqrt(m / k_eff) = 0.099 s
    outcomes = []
    for k in (3e3, 3e5):
        scene = load_scene(write_scene(disk_scene(two_stage(k), y0=0.101, v0=-1.0, gravity=0.0)))
        traj = simulate_compliant(scene, None, end, 1e-3,
                                  settings=CompliantSettings(contacts="all", max_step=2e-4))
        impact = next(e.to_dict() for e in traj.events if e.kind == "impact")
        restitution = impact["normal_velocity_after"] / -impact["normal_velocity_before"]
        rigid_scene = disk_scene({"restitution": restitution}, y0=0.101, v0=-1.0, gravity=0.0)
        rigid_scene["model"]["contact"] = "rigid"
        rigid = simulate_rigid(load_scene(write_scene(rigid_scene)), None, end, 1e-3)  # lands exactly
        outcomes.append((impact["duration"], abs(traj.q[-1, 1] - rigid.q[-1, 1]), restitution))
    (slow, far, e_soft), (fast, near, e_stiff) = outcomes
    assert slow / fast == pytest.approx(10.0, rel=0.02)
    assert far / near == pytest.approx(10.0, rel=0.1)
    assert e_soft == pytest.approx(e_stiff, abs=1e-3)  # the dampers scale as sqrt(k): same restitution


def test_zone_tables_are_checked(write_scene):
    partial = two_stage(1e4)
    del partial["mass_environment"]
    with pytest.raises(SceneError, match="mass_environment"):
        load_scene(write_scene(disk_scene(partial)))
    with pytest.raises(SceneError, match="zone"):
        load_scene(write_scene(disk_scene({"zone": "three_stage"})))
    with pytest.raises(SceneError, match="stiffness_internal_robot"):
        load_scene(write_scene(disk_scene({"zone": "one_stage", "mass_robot": 0.01,
                                           "stiffness_internal_robot": -1.0})))
    rigid_zone = load_scene(write_scene(disk_scene({"zone": "rigid"})))
    with pytest.raises(InputError, match="rigid"):
        simulate_compliant(rigid_zone, None, 0.01, 1e-3)
    scene = load_scene(write_scene(disk_scene(two_stage(1e4))))
    with pytest.raises(InputError, match="adaptive integrator"):
        simulate_compliant(scene, None, 0.01, 1e-3, settings=CompliantSettings(integrator="implicit"))


def test_the_peg_scene_carries_its_zones_to_the_json_and_the_out_file(tmp_path):
    out = tmp_path / "peg.csv"
    args = ["simulate", "peg_on_surface", "--duration", "0.02", "--input", "y=-20", "--json",
            "--out", str(out)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    zones = payload["samples"]["zones"]
    assert set(zones) == {"left_corner", "right_corner"}
    assert len(zones["left_corner"]["force"]) == len(payload["samples"]["times"])
    assert payload["summary"]["state_size"] == 2 * 3 + 2 + 2 * 4
    header = out.read_text().splitlines()[0].split(",")
    assert {"zones.left_corner.deformation", "zones.left_corner.force"} <= set(header)
    bad = CliRunner().invoke(app, ["simulate", "peg_on_surface", "--set",
                                   "model.contacts.left_corner.zone=three"])
    assert bad.exit_code == 1 and "zone" in bad.output


def test_a_one_stage_zone_lets_the_body_go(write_scene):
    """Without gravity or damping the body leaves at its approach speed, and its mass, released,
    rides along on its spring: the body is not held back (pi sqrt(m / k) in contact)."""
    k = 1e4
    zone = {"zone": "one_stage", "mass_robot": 1e-3, "stiffness_internal_robot": k}
    scene = load_scene(write_scene(disk_scene(zone, y0=0.101, v0=-1.0, gravity=0.0)))
    # the mass lands at the end of an integrator step: at most a step's travel late (max_step)
    traj = simulate_compliant(scene, None, 0.04, 1e-3,
                              settings=CompliantSettings(contacts="all", max_step=5e-5))
    impacts = [e.to_dict() for e in traj.events if e.kind == "impact"]
    assert len(impacts) == 1
    assert impacts[0]["duration"] == pytest.approx(math.pi * math.sqrt(MASS / k), rel=0.01)
    assert impacts[0]["peak_force"] == pytest.approx(math.sqrt(k * MASS), rel=0.01)
    assert traj.v[-1, 1] == pytest.approx(1.0, rel=0.01)
    # released at rest from the surface, the mass swings at +-(v / sqrt(k / m')) k on its spring
    swing = 1.0 / math.sqrt(k / 1e-3) * k
    after = traj.times > impacts[0]["time"] + impacts[0]["duration"] + 0.002
    assert np.max(np.abs(zone_series(traj, "force")[after])) < 1.5 * swing < 0.05 * math.sqrt(k * MASS)
    assert traj.info["zone_landing_energy"] == pytest.approx(0.5 * 1e-3 * 1.0**2, rel=1e-6)
