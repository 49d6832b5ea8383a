"""Simulation on both contact models against closed forms (free fall, slope, impact, pendulum)."""

from __future__ import annotations

import math
import re

import numpy as np
import pinocchio as pin
import pytest
from conftest import ROBOTS, rod_scene
from scipy.integrate import solve_ivp

from frcontrol.errors import CoordinateNotFound, IllConditioned, InputError, LimitExceeded, SceneError
from frcontrol.modes import ContactProblem
from frcontrol.scene import load_scene
from frcontrol.simulation.compliant import CompliantSettings, contact_forces, simulate_compliant
from frcontrol.simulation.inputs import InitialState
from frcontrol.simulation.model_table import model_options
from frcontrol.simulation.rigid import RigidSettings, simulate_rigid

G = 9.81
SLOPE = math.radians(20.0)
UP_SLOPE = np.array([math.cos(SLOPE), math.sin(SLOPE)])
SLOPE_NORMAL = np.array([-math.sin(SLOPE), math.cos(SLOPE)])
BOX_INERTIA = 0.1041666667  # box.urdf: 1 kg, 1 m x 0.5 m


def rotation(angle: float) -> np.ndarray:
    return np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])


def box_scene(q, mu=0.5, normal=(0.0, 1.0), **extra) -> dict:
    """The 1 kg box with contacts at its two lower corners against a line through the origin."""
    scene = {
        "name": "box",
        "robot": str(ROBOTS / "box.urdf"),
        "state": {"q": list(q)},
        "contacts": [
            {"name": name, "link": "box", "point": point, "normal": list(normal), "mu": mu,
             "surface_point": [0.0, 0.0]}
            for name, point in (("left", [-0.5, -0.25]), ("right", [0.5, -0.25]))
        ],
        "inputs": {"coordinates": ["x", "y", "theta"], "lower": [-20.0, -20.0, -5.0],
                   "upper": [20.0, 20.0, 5.0]},
    }
    scene.update(extra)
    return scene


def slope_scene(mu: float) -> dict:
    """The box resting flat on a 20 degree slope (normal (-sin a, cos a)) through the origin."""
    centre = 0.25 * SLOPE_NORMAL
    return box_scene([centre[0], centre[1], SLOPE], mu=mu, normal=SLOPE_NORMAL.tolist())


def tipped_box_scene(angle: float = -0.3, mu: float = 0.8) -> dict:
    """The box on its right corner at the origin, turned by ``angle``: the left corner is in the air."""
    centre = -rotation(angle) @ np.array([0.5, -0.25])
    return box_scene([centre[0], centre[1], angle], mu=mu)


# ---------------------------------------------------------------------------------------- free fall
def test_rigid_free_fall_is_semi_implicit_euler_exactly(write_scene):
    scene = load_scene(write_scene(box_scene([0.0, 5.0, 0.0])))
    dt, steps = 1e-3, 100
    traj = simulate_rigid(scene, None, steps * dt, dt)
    # v_N = -g N dt and y_N = y_0 - g dt^2 N (N + 1) / 2: the scheme's closed form
    assert traj.v[-1, 1] == pytest.approx(-G * steps * dt, abs=1e-12)
    assert traj.q[-1, 1] == pytest.approx(5.0 - G * dt**2 * steps * (steps + 1) / 2, abs=1e-12)
    assert traj.q.shape == (steps + 1, 3) and traj.events == ()
    # each step loses exactly m g^2 dt^2 / 2 of energy (the scheme's dissipation in free fall)
    np.testing.assert_allclose(np.diff(traj.info["energy"]), -0.5 * G**2 * dt**2, atol=1e-12)
    assert traj.status == "completed" and traj.info["lcp"]["solves"] == 0


@pytest.mark.parametrize("integrator, tol", [("radau", 1e-9), ("rk45", 1e-9), ("dop853", 1e-9),
                                             ("bdf", 1e-5)])
def test_compliant_free_fall_exact_to_the_integrators_order(write_scene, integrator, tol):
    # quadratic in t: exact for the order >= 3 methods (up to round-off), BDF starts at order 1
    scene = load_scene(write_scene(box_scene([0.0, 5.0, 0.0])))
    traj = simulate_compliant(scene, None, 0.3, 0.01, settings=CompliantSettings(integrator=integrator))
    np.testing.assert_allclose(traj.q[:, 1], 5.0 - 0.5 * G * traj.times**2, atol=tol)
    np.testing.assert_allclose(traj.v[:, 1], -G * traj.times, atol=tol * 10)
    assert traj.info["state_size"] == 6  # inactive contacts add no state
    assert traj.info["modelled_contacts"] == []


def test_compliant_euler_free_fall_matches_its_closed_form(write_scene):
    scene = load_scene(write_scene(box_scene([0.0, 5.0, 0.0])))
    dt, steps = 1e-3, 50
    traj = simulate_compliant(scene, None, steps * dt, dt, settings=CompliantSettings(integrator="euler"))
    assert traj.q[-1, 1] == pytest.approx(5.0 - G * dt**2 * steps * (steps + 1) / 2, abs=1e-12)
    assert traj.info["steps"] == steps


# ---------------------------------------------------------------------------------------- the slope
def test_rigid_box_slides_down_the_slope_with_g_sin_minus_mu_cos(write_scene):
    mu = 0.2
    scene = load_scene(write_scene(slope_scene(mu)))
    acc = G * (math.sin(SLOPE) - mu * math.cos(SLOPE))  # down the slope, 1.5115 m/s^2
    dt, steps = 1e-3, 300
    traj = simulate_rigid(scene, None, steps * dt, dt)
    along = traj.v[:, :2] @ UP_SLOPE
    np.testing.assert_allclose(along, -acc * traj.times, atol=1e-12)
    moved = (traj.q[-1, :2] - traj.q[0, :2]) @ UP_SLOPE
    assert moved == pytest.approx(-acc * dt**2 * steps * (steps + 1) / 2, abs=1e-12)
    assert np.max(traj.info["max_penetration"]) < 1e-12  # no drift into the slope
    assert np.max(np.abs(traj.v[:, :2] @ SLOPE_NORMAL)) < 1e-12
    # Coulomb: lam_T = mu lam_N, opposing the slip (up the slope: +t is up for this normal)
    forces = traj.contact_forces[1:]
    np.testing.assert_allclose(forces[:, :, 1], mu * forces[:, :, 0], rtol=1e-9)
    assert forces[:, :, 0].sum(axis=1) == pytest.approx(G * math.cos(SLOPE))
    kinds = {(e.contact, e.kind) for e in traj.events}
    assert kinds == {("left", "slip"), ("right", "slip")}


def test_rigid_box_sticks_on_the_slope_when_tan_a_below_mu(write_scene):
    scene = load_scene(write_scene(slope_scene(0.5)))  # tan 20 deg = 0.364 < 0.5
    traj = simulate_rigid(scene, None, 0.5, 1e-3)
    assert np.max(np.abs(traj.q - traj.q[0])) < 1e-12
    total = traj.contact_forces[-1].sum(axis=0)
    assert total[1] / total[0] == pytest.approx(math.tan(SLOPE))
    assert traj.events == ()


def test_compliant_box_on_the_slope_converges_to_the_rigid_one(write_scene):
    mu = 0.2
    scene = load_scene(write_scene(slope_scene(mu)))
    acc = G * (math.sin(SLOPE) - mu * math.cos(SLOPE))
    T = 0.3
    errors = []
    for k in (1e3, 1e4, 1e5):
        traj = simulate_compliant(scene, None, T, 1e-3, settings=CompliantSettings(stiffness=k))
        assert traj.status == "completed"
        assert (traj.v[-1, :2] @ UP_SLOPE) / T == pytest.approx(-acc, rel=1e-4)
        shift = traj.q[-1, :2] - traj.q[0, :2]
        # the normal sink is the static penetration m g cos a / (2 k) of the two springs
        assert shift @ SLOPE_NORMAL == pytest.approx(-G * math.cos(SLOPE) / (2 * k), rel=1e-3)
        errors.append(abs(shift @ UP_SLOPE + 0.5 * acc * T**2))
    # measured: 9.2e-4, 9.2e-5, 9.2e-6 m: the compliant path tends to the rigid one as 1/k
    assert errors[1] < errors[0] / 5 and errors[2] < errors[1] / 5 and errors[2] < 2e-5


def test_compliant_box_sticks_on_the_slope_with_creep_of_order_one_over_k(write_scene):
    scene = load_scene(write_scene(slope_scene(0.5)))
    creep = []
    for k in (1e3, 1e4):
        traj = simulate_compliant(scene, None, 0.2, 1e-3, settings=CompliantSettings(stiffness=k))
        creep.append(np.max(np.abs((traj.q[:, :2] - traj.q[0, :2]) @ UP_SLOPE)))
        assert abs(traj.v[-1, :2] @ UP_SLOPE) < 1e-4  # settled (the springs ring down)
        assert {e.kind for e in traj.events} <= {"stick"}
    # tangential springs carry m g sin a: 2.1e-3 m at 1e3 N/m, ten times less at 1e4
    assert creep[0] < 5 * G * math.sin(SLOPE) / 1e3 and creep[1] == pytest.approx(creep[0] / 10, rel=0.05)


# ---------------------------------------------------------------------------------------- impacts
def test_dropped_box_stops_without_bounce_and_loses_its_kinetic_energy(write_scene):
    height = 0.2
    scene = load_scene(write_scene(box_scene([0.0, 0.25 + height, 0.0])))
    dt = 1e-3
    traj = simulate_rigid(scene, None, 0.5, dt)
    impacts = [e for e in traj.events if e.kind == "impact"]
    assert {e.contact for e in impacts} == {"left", "right"}
    # the step ending at the event lands exactly (v+ = -gap / dt), the next one stops the box
    k = int(np.argmin(np.abs(traj.times - impacts[0].time)))
    v_before = traj.v[k - 1, 1]
    assert v_before == pytest.approx(-math.sqrt(2 * G * height), abs=2 * G * dt)
    # restitution 0: at rest on the ground right after, and never up again
    np.testing.assert_allclose(traj.q[k:, 1], 0.25, atol=1e-12)
    np.testing.assert_allclose(traj.v[k + 1:], 0.0, atol=1e-12)
    energy = traj.info["energy"]
    gap_before = traj.q[k - 1, 1] - 0.25
    # the impact loses the kinetic energy and the last bit of height: exactly
    assert energy[k - 1] - energy[k + 1] == pytest.approx(0.5 * v_before**2 + G * gap_before, abs=1e-12)
    assert energy[0] - energy[-1] == pytest.approx(G * height, abs=1e-12)


def test_tipped_box_falls_back_as_a_pendulum_then_rests(write_scene):
    angle = -0.3
    scene = load_scene(write_scene(tipped_box_scene(angle)))
    assert [c.active for c in scene.contacts] == [False, True]  # the left corner starts open
    dt = 1e-3
    traj = simulate_rigid(scene, None, 0.5, dt)
    # closed form before the impact: a pendulum about the sticking right corner
    inertia = BOX_INERTIA + 0.5**2 + 0.25**2
    arm = np.array([-0.5, 0.25])

    def pendulum(t, y):
        return [y[1], -G * (rotation(y[0]) @ arm)[0] / inertia]

    def flat(t, y):
        return y[0]

    flat.terminal, flat.direction = True, 1
    ref = solve_ivp(pendulum, (0.0, 2.0), [angle, 0.0], events=flat, rtol=1e-12, atol=1e-12)
    t_impact, omega = ref.t_events[0][0], ref.y_events[0][0][1]  # 0.2459 s, 2.536 rad/s
    impacts = [e for e in traj.events if e.kind == "impact"]
    assert len(impacts) == 1 and impacts[0].contact == "left"
    assert impacts[0].time == pytest.approx(t_impact, abs=2 * dt)
    assert not [e for e in traj.events if e.time < impacts[0].time]  # it sticks until then
    before = int(np.searchsorted(traj.times, impacts[0].time)) - 1
    assert traj.v[before, 2] == pytest.approx(omega, rel=0.02)
    # after: flat, at rest (both corners stop: no bounce), resting on both corners
    np.testing.assert_allclose(traj.q[-1], [traj.q[-1, 0], 0.25, 0.0], atol=1e-9)
    np.testing.assert_allclose(traj.v[before + 3:], 0.0, atol=1e-9)
    assert np.all(traj.contact_forces[-1, :, 0] == pytest.approx(G / 2))
    # energy never increases (beyond the reported stabilisation work) and the fall's energy is gone
    energy, work = traj.info["energy"], traj.info["stabilization_work"]
    assert np.all(np.diff(energy) <= np.diff(work) + 1e-12)
    assert energy[-1] == pytest.approx(G * 0.25, abs=1e-9)


def test_compliant_tipped_box_hits_at_the_pendulum_time_when_all_contacts_are_modelled(write_scene):
    scene = load_scene(write_scene(tipped_box_scene()))
    only_active = simulate_compliant(scene, None, 0.3, 1e-3, settings=CompliantSettings(stiffness=1e5))
    assert only_active.info["modelled_contacts"] == ["right"] and only_active.q[-1, 2] > 0.05  # falls through
    traj = simulate_compliant(scene, None, 0.3, 1e-3,
                              settings=CompliantSettings(stiffness=1e5, contacts="all"))
    assert traj.info["state_size"] == 8
    impact = next(e for e in traj.events if e.kind == "impact")
    assert impact.contact == "left" and impact.time == pytest.approx(0.24591, abs=2e-4)


def test_rigid_stepper_energy_never_increases_without_input(write_scene):
    cases = [
        load_scene("rod_on_table"),                         # a rod falling over its sticking tip
        load_scene(write_scene(slope_scene(0.2))),          # sliding
        load_scene(write_scene(tipped_box_scene(-0.5))),    # a tumble with an impact
    ]
    for scene in cases:
        for stabilization in (1.0, 0.0):
            traj = simulate_rigid(scene, None, 0.4, 1e-3,
                                  settings=RigidSettings(stabilization=stabilization, max_ambiguity_checks=0))
            d_energy, d_work = np.diff(traj.info["energy"]), np.diff(traj.info["stabilization_work"])
            assert np.all(d_energy <= d_work + 1e-12), scene.name
            if stabilization == 0.0:
                assert np.all(d_work == 0.0) and np.all(d_energy <= 1e-12)


# ---------------------------------------------------------------------------------------- resting
def test_rod_lying_on_the_table_does_not_drift(write_scene):
    contacts = [{"name": name, "link": "rod", "point": [x, 0.0], "normal": [0.0, 1.0], "mu": 0.5,
                 "surface_point": [0.0, 0.0]} for name, x in (("left", -0.5), ("right", 0.5))]
    scene = load_scene(write_scene(rod_scene(state={"q": [0.0, 0.0, 0.0]}, contacts=contacts)))
    traj = simulate_rigid(scene, None, 2.0, 1e-3, settings=RigidSettings(max_ambiguity_checks=0))
    assert traj.info["steps"] == 2000
    assert np.max(np.abs(traj.q - traj.q[0])) < 1e-12
    assert np.max(traj.info["max_penetration"]) < 1e-12
    np.testing.assert_allclose(traj.contact_forces[1:, :, 0], G / 2, rtol=1e-9)
    compliant = simulate_compliant(scene, None, 0.5, 1e-2, settings=CompliantSettings(stiffness=1e5))
    # settles at the static penetration m g / (2 k), without sideways drift
    assert compliant.q[-1, 1] == pytest.approx(-G / 2e5, rel=1e-4)
    assert abs(compliant.q[-1, 0]) < 1e-12 and abs(compliant.q[-1, 2]) < 1e-12


# ---------------------------------------------------------------------------------------- rigid vs compliant
def test_falling_rod_compliant_converges_to_the_rigid_pendulum():
    scene = load_scene("rod_on_table")
    theta0 = scene.q[2]
    tip = scene.state().contact_points[0]

    def pendulum(t, y):  # about the sticking tip: I_tip = 1/12 + 1/4 = 1/3
        return [y[1], -1.5 * G * math.cos(y[0])]

    T = 0.25
    theta, omega = solve_ivp(pendulum, (0.0, T), [theta0, 0.0], rtol=1e-12, atol=1e-12).y[:, -1]
    exact = np.array([tip[0] + 0.5 * math.cos(theta), tip[1] + 0.5 * math.sin(theta), theta])
    rigid = simulate_rigid(scene, None, T, 1e-3, settings=RigidSettings(max_ambiguity_checks=0))
    assert rigid.events == ()  # the tip sticks throughout
    assert np.max(np.abs(rigid.q[-1] - exact)) < 2e-3  # first order in dt
    errors = []
    for k in (1e3, 1e4, 1e5):
        traj = simulate_compliant(scene, None, T, 1e-3, settings=CompliantSettings(stiffness=k))
        errors.append(float(np.max(np.abs(traj.q[-1] - exact))))
    # measured: 6.9e-3, 6.1e-4, 5.2e-5
    assert errors[1] < errors[0] / 5 and errors[2] < errors[1] / 5 and errors[2] < 1e-4


# ---------------------------------------------------------------------------------------- inputs
def test_callable_input_is_held_per_step_push_then_coast(write_scene):
    scene = load_scene(write_scene(box_scene([0.0, 0.25, 0.0])))

    def push(t, q, v):
        return [10.0, 0.0, 0.0] if t < 0.1 - 1e-9 else [0.0, 0.0, 0.0]

    traj = simulate_rigid(scene, push, 0.3, 1e-3)
    speed = (10.0 - 0.5 * G) * 0.1  # mu = 0.5: 0.5095 m/s after the push
    k = int(round(0.1 / 1e-3))
    assert traj.v[k, 0] == pytest.approx(speed, abs=1e-12)
    stop = 0.1 + speed / (0.5 * G)  # Coulomb deceleration mu g
    moving = traj.times[np.abs(traj.v[:, 0]) > 1e-9]
    assert moving[-1] == pytest.approx(stop, abs=1e-3)
    assert traj.inputs.shape == (301, 3) and traj.inputs[k, 0] == 10.0 and traj.inputs[-1, 0] == 0.0
    assert {e.kind for e in traj.events} == {"slip", "stick"}
    # the compliant model holds the callable's value over each sample interval too
    compliant = simulate_compliant(scene, push, 0.3, 1e-3, settings=CompliantSettings(stiffness=1e5))
    assert compliant.v[k, 0] == pytest.approx(speed, rel=1e-4)
    sticks = [e.time for e in compliant.events if e.kind == "stick"]
    assert sticks and sticks[0] == pytest.approx(stop, abs=1e-4)
    by_name = simulate_rigid(scene, {"x": 10.0}, 0.01, 1e-3)
    by_vector = simulate_rigid(scene, [10.0, 0.0, 0.0], 0.01, 1e-3)
    np.testing.assert_array_equal(by_name.q, by_vector.q)


def test_ambiguous_instant_is_reported_with_the_mode_the_step_took(write_scene):
    # Painleve's rod sliding steadily (mu = 1.4, theta = 2): both S and R are rigid solutions
    scene = load_scene(write_scene(rod_scene(contacts=[{"name": "tip", "link": "rod", "point": [-0.5, 0.0],
                                                        "normal": [0.0, 1.0], "mu": 1.4,
                                                        "surface_point": [0.0, 0.0]}],
                                             state={"q": [0.0, 0.5 * math.sin(2.0), 2.0]})))
    v = np.array([1.0, 0.0, 0.0])
    problem = ContactProblem.from_scene(scene, scene.q, v)
    u = problem.bias - (problem.jacobian_normal[0] - 1.4 * problem.jacobian_tangent[0]) * 10.0
    traj = simulate_rigid(scene, u, 0.005, 1e-3, start=InitialState(v=v))
    event = traj.events[0]
    assert (event.time, event.contact, event.kind) == (0.0, "tip", "ambiguous")
    assert event.detail == "modes S, R; the step took S"
    check = traj.info["ambiguity_checks"][0]
    assert check["modes"] == ["S", "R"] and check["distinct_motions"] == 2


def test_resting_box_is_not_called_ambiguous(write_scene):
    scene = load_scene(write_scene(box_scene([0.0, 0.25, 0.0])))
    traj = simulate_rigid(scene, None, 0.01, 1e-3)
    check = traj.info["ambiguity_checks"][0]
    # one motion (rest) with indeterminate forces: the engine reports it once, as FF
    assert list(check["modes"]) == ["FF"] and check["distinct_motions"] == 1
    assert "FF" in check["summary"].split("=") and traj.events == ()


# ---------------------------------------------------------------------------------------- massless links
def test_massless_legs_get_the_reported_armature_like_pinocchio():
    scene = load_scene("rhex_flip")
    push = {"hip_middle": -3.0, "hip_rear": -3.0}
    traj = simulate_rigid(scene, push, 0.005, 1e-3, settings=RigidSettings(max_ambiguity_checks=0))
    M = scene.state().mass_matrix
    legs = [name for name in scene.coordinate_names if name.startswith("hip")]
    assert np.all(np.diag(M)[-len(legs):] == 0.0)  # the legs are massless
    assert traj.info["armature"]["coordinates"] == legs
    armature = scene.model.armature  # the scene's [model] armature (2e-3 kg m^2), the flip's
    assert scene.model.armature_given and traj.info["armature"]["value"] == armature
    # the regularisation is Pinocchio's own joint armature: CRBA adds it to M's diagonal
    model = pin.Model(scene.robot.model)
    model.armature[3:] = armature
    data = model.createData()
    pin.crba(model, data, scene.robot.pinocchio_q_from_minimal(scene.q))
    np.testing.assert_allclose(np.diag(data.M), np.diag(M) + np.array([0.0] * 3 + [armature] * len(legs)),
                               atol=1e-15)
    with pytest.raises(IllConditioned, match="armature"):
        simulate_rigid(scene, None, 0.01, 1e-3, armature=0.0)
    compliant = simulate_compliant(scene, push, 0.005, 1e-3, settings=CompliantSettings(armature=1e-3))
    assert compliant.info["armature"]["value"] == 1e-3 and compliant.status == "completed"


# ---------------------------------------------------------------------------------------- [model] table
MODEL_TABLE = """
[model]
contact = "compliant"
stiffness = 2e4
damping_ratio = 0.5

[model.contacts.right]
stiffness = 5e4
damping = 40.0
"""


def test_model_table_sets_the_compliant_parameters(write_scene):
    from conftest import toml_text

    path = write_scene(toml_text(box_scene([0.0, 0.25, 0.0])) + MODEL_TABLE)
    scene = load_scene(path)
    options = model_options(scene)
    assert options.contact == "compliant" and options.parameters("left").stiffness == 2e4
    assert options.parameters("right").stiffness == 5e4 and options.parameters("right").damping == 40.0
    assert options.parameters("right").damping_ratio == 0.5  # inherited from the table's defaults
    traj = simulate_compliant(scene, None, 0.01, 1e-3)
    left, right = traj.info["contacts"]["left"], traj.info["contacts"]["right"]
    assert right["stiffness"] == 5e4 and right["damping"] == 40.0
    # damping ratio 0.5 of critical for the corner's effective mass 1 / (J_N M^-1 J_N^T)
    m_eff = 1.0 / (1.0 + 0.25 / BOX_INERTIA)
    assert left["damping"] == pytest.approx(2 * 0.5 * math.sqrt(2e4 * m_eff))
    assert left["effective_mass_normal"] == pytest.approx(m_eff)
    # the arguments override the table
    softer = simulate_compliant(scene, None, 0.01, 1e-3, settings=CompliantSettings(stiffness=1e3))
    assert softer.info["contacts"]["right"]["stiffness"] == 1e3


@pytest.mark.parametrize("table, field", [
    ("[model]\ncontact = \"soft\"\n", "model.contact"),
    ("[model]\nstiffness = -1.0\n", "model.stiffness"),
    ("[model]\ndamping = -2.0\n", "model.damping"),
    ("[model]\ntangential_damping = 0.0\n", "model.tangential_damping"),
    ("[model]\narmature = -1.0\n", "model.armature"),
    ("[model]\nstiffnes = 1.0\n", "model.stiffnes"),
    ("[model.contacts.nope]\nstiffness = 1.0\n", "model.contacts.nope"),
    ("[model.contacts.left]\nmu = 1.0\n", "model.contacts.left.mu"),
    ("[model.contacts.left]\nstiffness = \"hard\"\n", "model.contacts.left.stiffness"),
])
def test_bad_model_table_names_the_field(write_scene, table, field):
    from conftest import toml_text

    # strict scenes: [model] is checked when the scene is loaded, before a simulator reads it
    with pytest.raises(SceneError, match=re.escape(field)) as info:
        load_scene(write_scene(toml_text(box_scene([0.0, 0.25, 0.0])) + table))
    assert info.value.field == field


# ---------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("kwargs, match", [
    ({"duration": 0.0}, "duration must be > 0"),
    ({"duration": float("nan")}, "duration must be a finite number"),
    ({"dt": 0.0}, "dt must be > 0"),
    ({"dt": -1e-3}, "dt must be > 0"),
    ({"dt": 2.0}, "exceeds the duration"),
    ({"inputs": [1.0, 2.0]}, "expected 3 input values"),
    ({"inputs": [100.0, 0.0, 0.0]}, "outside its limits"),
    ({"inputs": [float("nan"), 0.0, 0.0]}, "NaN"),
    ({"inputs": lambda t, q, v: [0.0, 0.0, 50.0] if t > 0.005 else [0.0, 0.0, 0.0]}, "at t = 0.006"),
    ({"start": InitialState(q=[0.0, 1.0])}, "q has 2 entries"),
])
def test_bad_simulation_input_raises_input_error(write_scene, kwargs, match):
    scene = load_scene(write_scene(box_scene([0.0, 0.25, 0.0])))
    args = {"inputs": None, "duration": 0.01, "dt": 1e-3} | kwargs
    for simulate in (simulate_rigid, simulate_compliant):
        with pytest.raises(InputError, match=match):
            simulate(scene, **args)


@pytest.mark.parametrize("kwargs, match", [
    ({"settings": CompliantSettings(stiffness=0.0)}, "stiffness"),
    ({"settings": CompliantSettings(stiffness=-1e4)}, "stiffness"),
    ({"settings": CompliantSettings(damping=-1.0)}, "damping"),
    ({"settings": CompliantSettings(tangential_damping=0.0)}, "tangential damping must be > 0"),
    ({"settings": CompliantSettings(damping_ratio=0.0)}, "damping ratio"),
    ({"settings": CompliantSettings(integrator="leapfrog")},
     "unknown integrator 'leapfrog'; choose one of: radau"),
    ({"settings": CompliantSettings(contacts="some")}, "'active' or 'all'"),
    ({"settings": CompliantSettings(rtol=0.0)}, "rtol"),
    ({"initial_stretch": [0.0]}, "initial_stretch needs 2"),
])
def test_bad_compliant_parameters(write_scene, kwargs, match):
    scene = load_scene(write_scene(box_scene([0.0, 0.25, 0.0])))
    with pytest.raises(InputError, match=match):
        simulate_compliant(scene, None, 0.01, 1e-3, **kwargs)


def test_bad_rigid_parameters_and_unknown_input_name(write_scene):
    scene = load_scene(write_scene(box_scene([0.0, 0.25, 0.0])))
    with pytest.raises(InputError, match="stabilization must be in"):
        simulate_rigid(scene, None, 0.01, 1e-3, settings=RigidSettings(stabilization=1.5))
    with pytest.raises(InputError, match="unknown LCP method"):
        simulate_rigid(scene, None, 0.01, 1e-3, settings=RigidSettings(lcp_method="pgs"))
    with pytest.raises(CoordinateNotFound, match="unknown coordinate 'hip'"):
        simulate_rigid(scene, {"hip": 1.0}, 0.01, 1e-3)


def test_integrator_failure_keeps_the_trajectory_and_reports_time_and_reason(write_scene):
    scene = load_scene(write_scene(box_scene([0.0, 0.45, 0.0])))
    # 50 steps at the least
    traj = simulate_compliant(scene, None, 0.5, 1e-3, settings=CompliantSettings(max_steps=50, max_step=0.01))
    assert traj.status == "failed"
    with pytest.raises(LimitExceeded, match=r"needs at least 500 steps .* at most max_steps = 50") as info:
        # refused before it starts
        simulate_compliant(scene, None, 0.5, 1e-3, settings=CompliantSettings(max_steps=50))
    assert (info.value.field, info.value.value, info.value.limit) == ("duration", 500, 50)
    assert traj.status == "failed"
    failure = traj.failure
    assert "more than 50 steps" in failure.reason and 0.0 < failure.time < 0.5
    assert traj.times[-1] <= failure.time and len(traj.times) == len(traj.q) > 1
    # an explicit step above the stability limit is refused (it would gain energy): with the
    # critical damper explicit, 2 (sqrt(2) - 1) / omega = 0.414 x the undamped 2 / omega = 1.08 ms
    resting = load_scene(write_scene(box_scene([0.0, 0.25, 0.0])))
    limit = r"stability limit 2 \(sqrt\(1 \+ zeta\^2\) - zeta\) / omega = 0.000449"
    with pytest.raises(InputError, match=limit):
        simulate_compliant(resting, None, 0.5, 2e-3,
                           settings=CompliantSettings(integrator="euler", stiffness=1e6))


def test_contact_forces_law():
    """The Kelvin-Voigt + slider law on hand-made numbers (module docstring's equations)."""
    from frcontrol.simulation.compliant import CompliantContacts

    one = np.ones(3)
    contacts = CompliantContacts(("a", "b", "c"), (0, 1, 2), 0.5 * one, 1e4 * one, 10 * one, 2e4 * one,
                                 20 * one, one, one, one)
    gaps = np.array([-1e-3, -1e-3, 1e-3])
    v_n = np.array([0.0, 0.0, -1.0])
    v_t = np.array([0.0, 1.0, 0.0])
    stretch = np.array([1e-4, 0.0, 5e-4])
    lam_n, lam_t, rate, status = contact_forces(contacts, gaps, v_n, v_t, stretch)
    np.testing.assert_allclose(lam_n, [10.0, 10.0, 0.0])  # k delta; the open contact pulls nothing
    # a: sticks (|F| = 2 <= 5): lam_T = -F, ds/dt = v_T; b: slips (F = 20 > 5)
    np.testing.assert_allclose(lam_t, [-2.0, -5.0, 0.0])
    np.testing.assert_allclose(rate, [0.0, (5.0 - 0.0) / 20.0, -2e4 * 5e-4 / 20.0])
    np.testing.assert_array_equal(status, [1, 2, 0])
    # continuity at the switch: |F| = L gives the same force and rate on both branches
    at_limit = np.array([5.0 / 2e4, 0.0, 0.0])
    _, lt, rt, _ = contact_forces(contacts, gaps, np.zeros(3), np.zeros(3), at_limit)
    assert lt[0] == pytest.approx(-5.0) and rt[0] == pytest.approx(0.0, abs=1e-15)


# ---------------------------------------------------------------------------------------- command line
def cli_app():
    """The real ``frc`` group: its one-line usage errors (exit 2) and error lines (exit 1)."""
    from frcontrol.cli.app import app

    return app


def test_cli_simulate_json_summary_and_samples():
    import json

    from typer.testing import CliRunner

    result = CliRunner().invoke(cli_app(), ["simulate", "rod_on_table", "--duration", "0.05", "--json"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    summary, samples = payload["summary"], payload["samples"]
    assert summary["model"] == "rigid" and summary["status"] == "completed" and summary["steps"] == 50
    assert len(samples["times"]) == 51 and len(samples["q"][0]) == 3 and len(samples["energy"]) == 51
    assert summary["final_q"] == samples["q"][-1]
    assert summary["energy"]["largest_increase"] <= summary["stabilization_work"] + 1e-12
    assert summary["events"] == [] and summary["max_penetration"] < 1e-4


def test_cli_simulate_compliant_table_and_errors(tmp_path):
    from typer.testing import CliRunner

    runner = CliRunner()
    result = runner.invoke(cli_app(), ["simulate", "box_on_ground", "--model", "compliant", "-k", "1e4",
                                       "--duration", "0.05", "--dt", "0.01", "-i", "x=1"])
    assert result.exit_code == 0, result.output
    assert "compliant model" in result.stdout and "final state" in result.stdout
    bad = runner.invoke(cli_app(), ["simulate", "box_on_ground", "--dt", "0"])
    assert bad.exit_code == 2 and "'--dt': expected a finite number > 0" in bad.stderr
    bad = runner.invoke(cli_app(), ["simulate", "box_on_ground", "-k", "1e4"])
    assert bad.exit_code == 2 and "--stiffness and --damping belong" in bad.stderr
    bad = runner.invoke(cli_app(), ["simulate", "box_on_ground", "--model", "compliant", "--integrator", "x"])
    assert bad.exit_code == 2 and "'--integrator': expected one of" in bad.stderr
    failed = runner.invoke(cli_app(), ["simulate", "box_on_ground", "-i", "x=99"])
    assert failed.exit_code == 1 and "outside its limits" in failed.stderr


def test_cli_simulate_writes_the_html_replay(tmp_path):
    from typer.testing import CliRunner

    page = tmp_path / "replay.html"
    result = CliRunner().invoke(cli_app(), ["simulate", "box_on_ground", "--duration", "0.02",
                                            "--html", str(page)])
    assert result.exit_code == 0, result.output
    assert page.stat().st_size > 1000 and "<html" in page.read_text()[:2000].lower()


def test_the_front_door_refuses_settings_of_the_other_model():
    from frcontrol.simulation import simulate

    rigid = load_scene("rod_on_table")
    compliant = load_scene("rod_on_table", overrides={"model.contact": "compliant"})
    with pytest.raises(InputError, match="is rigid: its settings are RigidSettings, got CompliantSettings"):
        simulate(rigid, None, 0.01, 1e-3, settings=CompliantSettings())
    with pytest.raises(InputError, match="is compliant: its settings are CompliantSettings, got Rigid"):
        simulate(compliant, None, 0.01, 1e-3, settings=RigidSettings())
    run = simulate(compliant, None, 0.01, 1e-3, settings=CompliantSettings(integrator="implicit"),
                   start=InitialState(v=[0.0, 0.0, 0.0]))
    assert run.model == "compliant" and run.info["integrator"] == "implicit"
