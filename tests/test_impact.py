"""The rigid model's impact law against the momentum balance's closed forms, and its energy."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.linalg
from conftest import ROBOTS
from frcontrol.cli.app import app
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from frcontrol.errors import InputError, SceneError
from frcontrol.scene import load_scene
from frcontrol.simulation.impact import ENERGY_TOLERANCE, impact_law
from frcontrol.simulation.inputs import InitialState
from frcontrol.simulation.rigid import simulate_rigid

G = 9.81
ROD_MASS, ROD_INERTIA = 1.0, 1.0 / 12.0  # rod.urdf: 1 kg, 1 m, m l^2 / 12
DT = 1e-3


def drop_scene(angle: float, height: float, restitution: float, mu: float) -> dict:
    """The rod released at rest, turned by ``angle``, its lower end ``height`` above the line y = 0."""
    ends = (("left_end", [-0.5, 0.0]), ("right_end", [0.5, 0.0]))
    return {
        "name": "rod drop",
        "robot": str(ROBOTS / "rod.urdf"),
        "state": {"q": [0.0, height + 0.5 * abs(math.sin(angle)), angle]},
        "contacts": [{"name": name, "link": "rod", "point": point, "normal": [0.0, 1.0], "mu": mu,
                      "surface_point": [0.0, 0.0]} for name, point in ends],
        "model": {"contact": "rigid", "contacts": {name: {"restitution": restitution} for name, _ in ends}},
    }


def impacts_of(traj) -> list[dict]:
    return [e.to_dict() for e in traj.events if e.kind == "impact"]


@pytest.mark.parametrize("e", [0.0, 0.3, 0.8])
def test_a_rod_dropped_flat_rebounds_at_e_times_its_speed(write_scene, e):
    height = 0.2
    traj = simulate_rigid(load_scene(write_scene(drop_scene(0.0, height, e, 0.5))), None, 0.25, DT)
    first = impacts_of(traj)[:2]
    assert {i["contact"] for i in first} == {"left_end", "right_end"}
    assert first[0]["time"] == first[1]["time"]
    speed = math.sqrt(2 * G * height)
    for impact in first:  # symplectic Euler reaches the table within one step's g dt of the fall's speed
        assert impact["normal_velocity_before"] == pytest.approx(-speed, abs=G * DT)
        after = impact["normal_velocity_after"]
        assert after == pytest.approx(-e * impact["normal_velocity_before"], abs=1e-12)
        assert impact["impulse_normal"] == pytest.approx(
            0.5 * ROD_MASS * (1 + e) * -impact["normal_velocity_before"], rel=1e-9)
        assert impact["impulse_tangent"] == pytest.approx(0.0, abs=1e-12)
    k = int(np.searchsorted(traj.times, first[0]["time"] - 1e-12))
    # the rest of the step is free flight (or rest on the table for e = 0)
    assert traj.v[k, 1] == pytest.approx(-e * first[0]["normal_velocity_before"], abs=G * DT)
    if e == 0.0:
        np.testing.assert_allclose(traj.q[k:, 1], 0.0, atol=1e-12)
        np.testing.assert_allclose(traj.v[k:], 0.0, atol=1e-12)
    else:
        assert traj.q[k + 5, 1] > 0.0  # in the air again


def rod_end_matrix(angle: float) -> tuple[np.ndarray, np.ndarray]:
    """The lower end's lever r (from the centre, world) and K: impulse (P_T, P_N) -> its velocity jump."""
    r = np.array([-0.5 * math.cos(angle), -0.5 * math.sin(angle)])
    # v_end = v + omega x r = (v_x - omega r_y, v_y + omega r_x); omega jumps by (r_x P_N - r_y P_T) / I
    K = np.array([[1 / ROD_MASS + r[1] ** 2 / ROD_INERTIA, -r[0] * r[1] / ROD_INERTIA],
                  [-r[0] * r[1] / ROD_INERTIA, 1 / ROD_MASS + r[0] ** 2 / ROD_INERTIA]])
    return r, K


@pytest.mark.parametrize(("mu", "e"), [(0.0, 0.0), (0.0, 0.6), (5.0, 0.0), (5.0, 0.6)])
def test_a_rod_dropped_at_an_angle_takes_the_momentum_balance_impulse(write_scene, mu, e):
    """Impulse at one end: frictionless, P_N = (1 + e) v / (1/m + r_x^2 / I); sticking, the end's
    tangential velocity stops and K (P_T, P_N) = (0, (1 + e) v)."""
    angle = 0.4
    scene = load_scene(write_scene(drop_scene(angle, 0.1, e, mu)))
    traj = simulate_rigid(scene, None, 0.16, DT)
    impact = impacts_of(traj)[0]
    assert impact["contact"] == "left_end"
    v = -impact["normal_velocity_before"]
    r, K = rod_end_matrix(angle)
    if mu == 0.0:
        p_t, p_n = 0.0, (1 + e) * v / (1 / ROD_MASS + r[0] ** 2 / ROD_INERTIA)
    else:
        p_t, p_n = np.linalg.solve(K, [0.0, (1 + e) * v])
        assert abs(p_t) < mu * p_n  # it sticks indeed
    assert impact["impulse_normal"] == pytest.approx(p_n, rel=1e-9)
    assert impact["impulse_tangent"] == pytest.approx(p_t, rel=1e-9, abs=1e-12)
    assert impact["normal_velocity_after"] == pytest.approx(e * v, abs=1e-12)
    # the law's velocities on the real Pinocchio model of the rod, at the instant of the impact
    state = scene.robot.state(np.array([0.0, 0.5 * math.sin(angle), angle]), np.array([0.0, -v, 0.0]), [0])
    law = impact_law(state.mass_matrix, scipy.linalg.cho_factor(state.mass_matrix), state.v,
                     state.jacobian_normal, state.jacobian_tangent, [mu], [e])
    expected = np.array([p_t / ROD_MASS, -v + p_n / ROD_MASS, (r[0] * p_n - r[1] * p_t) / ROD_INERTIA])
    np.testing.assert_allclose(law.velocity, expected, atol=1e-12)
    assert law.kinetic_energy_after <= law.kinetic_energy_before


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 8), c=st.integers(1, 4))
def test_no_impact_gains_energy(seed, n, c):
    """Random positive-definite M, contact rows (2 c <= n of them: full row rank, a positive-definite
    Delassus matrix), velocities, friction and restitution."""
    c = min(c, n // 2)
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    M = A @ A.T + 0.05 * np.eye(n)
    jn, jt = rng.normal(size=(c, n)), rng.normal(size=(c, n))
    v = rng.normal(size=n) * 3.0
    mu, e = rng.uniform(0.0, 2.0, c), rng.uniform(0.0, 1.0, c)
    law = impact_law(M, scipy.linalg.cho_factor(M), v, jn, jt, mu, e)
    before = 0.5 * v @ M @ v
    after = 0.5 * law.velocity @ M @ law.velocity
    assert after == pytest.approx(law.kinetic_energy_after, rel=1e-12, abs=1e-12)
    assert after <= before + ENERGY_TOLERANCE * (before + 1.0)
    # the law: impulses in the cone, no contact left approaching, restitution where pushed
    assert np.all(law.impulse_normal >= -1e-9)
    assert np.all(np.abs(law.impulse_tangent) <= mu * law.impulse_normal + 1e-9)
    target = law.restitution * np.maximum(0.0, -law.normal_velocity_before)
    assert np.all(law.normal_velocity_after >= target - 1e-8)
    pushed = law.impulse_normal > 1e-9
    np.testing.assert_allclose(law.normal_velocity_after[pushed], target[pushed], atol=1e-7)
    np.testing.assert_allclose(law.velocity - v, np.linalg.solve(M, jn.T @ law.impulse_normal
                                                                 + jt.T @ law.impulse_tangent), atol=1e-9)


def test_the_shipped_rod_drop_never_gains_energy():
    traj = simulate_rigid(load_scene("rod_drop"), None, 0.8, DT)
    impacts = impacts_of(traj)
    assert traj.completed and len(impacts) >= 4
    assert {i["contact"] for i in impacts} == {"left_end", "right_end"}
    assert all(i["kinetic_energy_after"] <= i["kinetic_energy_before"] for i in impacts)
    assert all(i["restitution"] == 0.5 for i in impacts)  # no impact needed its restitution lowered
    assert float(np.max(np.diff(traj.info["energy"]))) <= 1e-9
    # the first impact: the left end strikes at about sqrt(2 g h), h = 0.2022 m
    assert impacts[0]["contact"] == "left_end"
    assert impacts[0]["normal_velocity_before"] == pytest.approx(-math.sqrt(2 * G * 0.20224), abs=G * DT)


def test_bad_restitution_is_refused(write_scene):
    text = drop_scene(0.0, 0.1, 1.5, 0.5)
    with pytest.raises(SceneError, match="restitution"):
        load_scene(write_scene(text))
    M = np.eye(3)
    with pytest.raises(InputError, match="restitution"):
        impact_law(M, scipy.linalg.cho_factor(M), np.zeros(3), np.ones((1, 3)), np.ones((1, 3)), [0.5],
                   [-0.1])


def test_impacts_reach_the_json_and_the_out_file(tmp_path):
    out = tmp_path / "drop.csv"
    args = ["simulate", "rod_drop", "--duration", "0.25", "--json", "--out", str(out)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)["summary"]
    impact = next(e for e in summary["events"] if e["kind"] == "impact")
    assert summary["impacts"][0]["impulse_normal"] == impact["impulse_normal"] > 0
    assert impact["normal_velocity_after"] == pytest.approx(-0.5 * impact["normal_velocity_before"])
    header = out.read_text().splitlines()[0].split(",")
    column = header.index("impacts.left_end.impulse_normal")
    rows = [line.split(",") for line in out.read_text().splitlines()[1:]]
    assert sum(float(r[column]) for r in rows) == pytest.approx(impact["impulse_normal"], rel=1e-12)


@pytest.mark.parametrize("name", ["box_on_ground", "table_on_ground", "peg_on_surface", "rhex_flip"])
def test_no_impact_of_a_shipped_scene_gains_energy(name):
    """Shipped scenes raised 2 cm and dropped, restitution 0.7 on every contact, rigid model:
    several contacts strike at once, with friction (RHex: corners and massless legs' toes)."""
    scene = load_scene(name, overrides={"model.contact": "rigid", "model.restitution": 0.7})
    q0 = scene.q.copy()
    q0[1] += 0.02
    traj = simulate_rigid(scene, None, 0.15, DT, start=InitialState(q=q0))
    impacts = traj.info["impacts"]
    assert traj.completed and len(impacts) >= 2
    for impact in impacts:
        assert impact["kinetic_energy_after"] <= impact["kinetic_energy_before"] * (1 + 1e-12) + 1e-12
