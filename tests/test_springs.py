"""Joint springs (``[model.springs.JOINT]``) against closed-form mechanics and the rigid leg.

A mass on a vertical prismatic spring under gravity: its static deflection ``m g / k`` (statics'
weak and strong stability, the rigid and compliant runs' resting state), its period
``2 pi sqrt(m / k)`` from the zero crossings of a run, its energy conserved without damping
(Radau). A leg with a toe of small mass on a stiff spring (k x 1000) against the same robot with
the leg joint locked, at a state. Bad ``[model.springs]`` tables: one line, exit 1.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import needs_kernel, toml_text, toml_value
from frcontrol.cli.app import app
from typer.testing import CliRunner

from frcontrol.engine import solutions_at
from frcontrol.errors import SceneError
from frcontrol.scene import load_scene
from frcontrol.simulation.compliant import CompliantSettings, simulate_compliant
from frcontrol.simulation.export import trajectory_arrays
from frcontrol.simulation.rigid import simulate_rigid
from frcontrol.statics import strong_stability, weak_stability

runner = CliRunner()

BOB_MASS = 2.0
"""[kg] the mass on the spring."""

BOB_STIFFNESS = 200.0
"""[N/m] its spring: period 2 pi sqrt(m / k) = 0.628 s, static deflection m g / k = 0.098 m."""

GRAVITY = 9.81

PERIOD_TOLERANCE = 2e-3
"""[-] relative error allowed on the period measured from zero crossings of a 1 ms rigid run (the
symplectic step's frequency error is (omega dt)^2 / 24, some 4e-6; the crossings are interpolated)."""

ENERGY_TOLERANCE = 1e-8
"""[-] relative drift of the total energy allowed in an undamped Radau run (rtol 1e-12)."""

STIFF_LEG_TOLERANCE = 1e-3
"""[-] relative difference allowed between the stiff leg's (k x 1000) body accelerations and contact
forces and the locked leg's, each scaled by the largest of its kind."""


def _inertial(mass: float, inertia: float) -> str:
    return (f'<inertial><origin xyz="0 0 0"/><mass value="{mass}"/><inertia ixx="{inertia}" ixy="0" '
            f'ixz="0" iyy="{inertia}" iyz="0" izz="{inertia}"/></inertial>')


def _joint(name: str, kind: str, parent: str, child: str, axis: str, origin: str = "0 0 0") -> str:
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{origin}"/><axis xyz="{axis}"/>'
            '<limit lower="-10" upper="10" effort="100" velocity="100"/></joint>')


def slider_urdf(tmp_path) -> str:
    """A fixed frame and a bob on a vertical prismatic joint ``spring`` (q = the bob's height)."""
    (tmp_path / "slider.urdf").write_text(
        '<?xml version="1.0"?><robot name="slider">'
        f'<link name="frame">{_inertial(1.0, 0.01)}</link>'
        f'<link name="bob">{_inertial(BOB_MASS, 1e-3)}'
        '<visual><geometry><box size="0.1 0.1 0.05"/></geometry></visual></link>'
        f'{_joint("spring", "prismatic", "frame", "bob", "0 1 0")}</robot>')
    return "slider.urdf"


def bob_scene(tmp_path, spring: dict, **extra) -> str:
    doc = {"name": "bob", "robot": slider_urdf(tmp_path), "base": "fixed", "gravity": GRAVITY,
           "state": {"q": [0.0]}, **extra, "model": {"springs": {"spring": spring}}}
    path = tmp_path / "bob.toml"
    path.write_text(toml_text(doc))
    return str(path)


def crossings(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The times where ``values`` changes sign, linearly interpolated."""
    i = np.nonzero(np.sign(values[:-1]) * np.sign(values[1:]) < 0)[0]
    return times[i] - values[i] * (times[i + 1] - times[i]) / (values[i + 1] - values[i])


def test_the_spring_force_is_in_h_at_the_state(tmp_path):
    scene = load_scene(bob_scene(tmp_path, {"stiffness": BOB_STIFFNESS, "damping": 3.0, "rest": 0.05}))
    state = scene.robot.state(np.array([0.2]), np.array([-0.4]))
    weight = BOB_MASS * GRAVITY
    assert state.bias[0] == pytest.approx(weight + BOB_STIFFNESS * (0.2 - 0.05) + 3.0 * -0.4, rel=1e-12)
    assert scene.robot.spring_energy(np.array([0.2])) == pytest.approx(0.5 * BOB_STIFFNESS * 0.15**2)


def test_the_static_deflection_is_m_g_over_k(tmp_path):
    """At q = -m g / k the bob rests on its spring: every rigid solution is at rest; 1 mm off, not."""
    rest = -BOB_MASS * GRAVITY / BOB_STIFFNESS
    scene = load_scene(bob_scene(tmp_path, {"stiffness": BOB_STIFFNESS}))
    (solution,) = solutions_at(scene.at(np.array([rest])), [])
    assert abs(solution.dv[0]) < 1e-12
    (off,) = solutions_at(scene.at(np.array([rest + 1e-3])), [])
    assert off.dv[0] == pytest.approx(-BOB_STIFFNESS * 1e-3 / BOB_MASS, rel=1e-9)
    result = runner.invoke(app, ["analyze", str(scene.path), "--set", f"state.q=[{rest!r}]", "--json"])
    assert result.exit_code == 0, result.output
    reported = json.loads(result.stdout)["springs"]["spring"]
    assert reported["deflection"] == rest
    assert reported["force"] == pytest.approx(BOB_MASS * GRAVITY, rel=1e-12)


def test_statics_sees_the_spring(tmp_path):
    """A body standing on the ground with a bob on a spring above it: weakly and strongly stable
    only where the spring carries the bob (the contacts act on the body, not on the joint). The
    numbers are exact in binary (m g = 20 N, k = 160 N/m, deflection 0.125 m), so that the joint's
    row balances to zero exactly: weak stability scales each row by its own terms."""
    (tmp_path / "stand.urdf").write_text(
        '<?xml version="1.0"?><robot name="stand">'
        f'<link name="body">{_inertial(3.0, 0.01)}</link><link name="bob">{_inertial(BOB_MASS, 1e-3)}</link>'
        f'{_joint("spring", "prismatic", "body", "bob", "0 1 0")}</robot>')
    contacts = [{"name": n, "link": "body", "point": [x, 0.0], "normal": [0.0, 1.0], "mu": 0.5}
                for n, x in (("left", -0.2), ("right", 0.2))]

    def stand(q_spring: float):
        doc = {"robot": "stand.urdf", "gravity": 10.0, "state": {"q": [0.0, 0.0, 0.0, q_spring]},
               "contacts": contacts, "model": {"springs": {"spring": {"stiffness": 160.0, "rest": 0.5}}}}
        (tmp_path / "stand.toml").write_text(toml_text(doc))
        return load_scene(tmp_path / "stand.toml")

    loaded = stand(0.5 - BOB_MASS * 10.0 / 160.0)
    weak = weak_stability(loaded)
    assert weak.weakly_stable and strong_stability(loaded).strongly_stable
    assert weak.lambda_n.sum() == pytest.approx((3.0 + BOB_MASS) * 10.0, rel=1e-9)
    assert not weak_stability(stand(0.25)).weakly_stable
    assert not strong_stability(stand(0.5)).strongly_stable


def test_the_rigid_run_oscillates_with_the_closed_form_period_and_rests_at_m_g_over_k(tmp_path):
    scene = load_scene(bob_scene(tmp_path, {"stiffness": BOB_STIFFNESS}))
    run = simulate_rigid(scene, duration=2.0, dt=1e-3)
    centre = -BOB_MASS * GRAVITY / BOB_STIFFNESS
    q = run.q[:, 0]
    # about m g / k, from 0 to 2 m g / k (within the step's omega dt of the amplitude)
    assert np.min(q) == pytest.approx(2 * centre, rel=1e-3) and np.max(q) <= 1e-2 * abs(centre)
    period = 2 * np.mean(np.diff(crossings(run.times, q - centre)))
    assert period == pytest.approx(2 * math.pi * math.sqrt(BOB_MASS / BOB_STIFFNESS), rel=PERIOD_TOLERANCE)
    energy = np.asarray(run.info["energy"])  # kinetic + gravitational + the spring's
    assert np.ptp(energy) < 1e-2 * BOB_MASS * GRAVITY * abs(centre)
    damped = simulate_rigid(load_scene(bob_scene(tmp_path, {"stiffness": BOB_STIFFNESS, "damping": 40.0})),
                            duration=3.0, dt=1e-3)
    assert damped.q[-1, 0] == pytest.approx(centre, rel=1e-4)  # its resting state
    document = damped.to_dict(damped_scene := load_scene(bob_scene(tmp_path, {"stiffness": BOB_STIFFNESS,
                                                                             "damping": 40.0})))
    springs = document["samples"]["springs"]["spring"]
    np.testing.assert_allclose(springs["deflection"], damped.q[:, 0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(springs["force"], -BOB_STIFFNESS * damped.q[:, 0] - 40.0 * damped.v[:, 0],
                               rtol=1e-12, atol=1e-12)
    assert springs["force"][-1] == pytest.approx(BOB_MASS * GRAVITY, rel=1e-4)  # it carries the weight
    expected = {"spring": {"stiffness": BOB_STIFFNESS, "damping": 40.0, "rest": 0.0}}
    assert document["summary"]["springs"] == expected
    arrays = trajectory_arrays(damped_scene, damped)
    np.testing.assert_array_equal(arrays["springs.spring.force"], springs["force"])


def test_the_compliant_run_conserves_energy_with_radau_and_keeps_the_period(tmp_path):
    scene = load_scene(bob_scene(tmp_path, {"stiffness": BOB_STIFFNESS}))
    run = simulate_compliant(scene, settings=CompliantSettings(integrator="radau", rtol=1e-12, atol=1e-14),
                             duration=2.0, dt=1e-3)
    total = np.asarray(run.info["energy"]) + np.asarray(run.info["elastic_energy"])
    scale = BOB_MASS * GRAVITY * 2 * BOB_MASS * GRAVITY / BOB_STIFFNESS  # the largest part: m g x the stroke
    assert np.max(np.abs(total - total[0])) <= ENERGY_TOLERANCE * scale
    np.testing.assert_allclose(run.info["spring_energy"], 0.5 * BOB_STIFFNESS * run.q[:, 0] ** 2, rtol=1e-12)
    centre = -BOB_MASS * GRAVITY / BOB_STIFFNESS
    period = 2 * np.mean(np.diff(crossings(run.times, run.q[:, 0] - centre)))
    assert period == pytest.approx(2 * math.pi * math.sqrt(BOB_MASS / BOB_STIFFNESS), rel=1e-6)


def leg_urdf(tmp_path) -> str:
    """A box body, a hip (revolute, at the body's front end) to a light thigh, and along the thigh a
    prismatic ``leg`` to a toe of small mass: q_leg is the toe's distance [m] from the hip."""
    (tmp_path / "leg.urdf").write_text(
        '<?xml version="1.0"?><robot name="leg">'
        f'<link name="body">{_inertial(2.0, 0.03)}</link><link name="thigh">{_inertial(0.05, 1e-4)}</link>'
        f'<link name="toe">{_inertial(0.02, 1e-6)}</link>'
        f'{_joint("hip", "revolute", "body", "thigh", "0 0 1", HIP_IN_BODY)}'
        f'{_joint("leg", "prismatic", "thigh", "toe", "0 -1 0")}'
        '</robot>')
    return "leg.urdf"


LEG = 0.17
"""[m] the leg's length (the locked leg's, the spring's rest length)."""

HIP_IN_BODY = "0.2 0 0"
"""[m] the hip in the body's frame: the body rests on its rear corner and the leg carries its front."""


def leg_scene(tmp_path, *, stiffness: float | None, q_leg: float = LEG):
    """The body pitched by 0.28 rad on its rear corner, the toe on the ground; the leg locked at
    ``LEG`` (stiffness None) or on a spring of rest length ``LEG`` at ``q_leg``."""
    theta, corner = 0.28, np.array([-0.2, -0.05])
    rotation = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    y = -(rotation @ corner)[1]
    hip_height = y + (rotation @ np.array([0.2, 0.0]))[1]
    hip = math.acos(hip_height / LEG) - theta  # the toe at y = 0 for a leg of LEG
    doc = {"robot": leg_urdf(tmp_path), "state": {"q": [0.0, y, theta, hip, q_leg]},
           "contacts": [{"name": "corner", "link": "body", "point": corner.tolist(), "normal": [0.0, 1.0],
                         "mu": 0.8},
                        {"name": "toe", "link": "toe", "point": [0.0, 0.0], "normal": [0.0, 1.0], "mu": 0.8}],
           "inputs": {"coordinates": ["hip"], "lower": [-5.0], "upper": [5.0]}}
    if stiffness is None:
        doc["locked_joints"] = ["leg"]
    else:
        doc["model"] = {"springs": {"leg": {"stiffness": stiffness, "rest": LEG}}}
    path = tmp_path / f"leg_{stiffness}.toml"
    path.write_text(toml_text(doc))
    return load_scene(path)


def test_a_stiff_leg_is_the_locked_leg_at_a_state(tmp_path):
    """The leg on a spring of rest length LEG and k x 1000 (SimSect's 2400 N/m per pair), deflected
    by the locked leg's load (``q_leg - LEG = F / k``, F from the spring row of the locked leg's
    solution): each of the locked leg's solutions has a spring-leg solution of the same mode with
    the same body accelerations and contact forces within STIFF_LEG_TOLERANCE, and the difference
    falls as k grows. Without the spring in h the toe's row has no load and no such solution."""
    u = [-3.0]
    rigid = {s.mode: s for s in solutions_at(leg_scene(tmp_path, stiffness=None), u)}
    assert rigid and all(np.max(s.lambda_n) > 1.0 for s in rigid.values())  # the hip pushes on the toe
    free = leg_scene(tmp_path, stiffness=0.0)  # the spring robot at the locked geometry, no spring force
    state = free.state(free.q, free.v)
    errors = []
    for k in (2.4e3, 2.4e4, 2.4e5, 2.4e6):
        worst = 0.0
        for mode, solution in rigid.items():
            forces = np.r_[solution.lambda_n, solution.lambda_t]
            contact_force = (state.jacobian_normal.T @ solution.lambda_n
                             + state.jacobian_tangent.T @ solution.lambda_t)
            load = float((contact_force - state.mass_matrix @ np.append(solution.dv, 0.0) - state.bias)[4])
            sprung_scene = leg_scene(tmp_path, stiffness=k, q_leg=LEG + load / k)  # the load holds the toe
            sprung = {s.mode: s for s in solutions_at(sprung_scene, u)}
            assert mode in sprung, (k, mode, sorted(sprung))
            other = sprung[mode]
            body = np.max(np.abs(other.dv[:3] - solution.dv[:3])) / np.max(np.abs(solution.dv[:3]))
            worst = max(worst, body, np.max(np.abs(np.r_[other.lambda_n, other.lambda_t] - forces))
                        / np.max(np.abs(forces)))
        errors.append(worst)
    assert errors[-1] <= STIFF_LEG_TOLERANCE, errors
    assert errors[-1] < errors[0], errors


@pytest.mark.parametrize(("springs", "field", "message"), [
    ({"lge": {"stiffness": 1.0}}, "model.springs.lge", "unknown joint 'lge' for a spring; did you mean 'leg"),
    ({"hip": {"stiffness": 1.0}}, "model.springs.hip", "'hip' is an input \\(actuated\\).*did you mean 'leg"),
    ({"leg": {"stiffness": -1.0}}, "model.springs.leg.stiffness", "expected >= 0, got -1.0"),
    ({"leg": {"stiffness": 1.0, "damping": -2.0}}, "model.springs.leg.damping", "expected >= 0"),
    ({"leg": {"stiffness": 1.0, "rset": 0.17}}, "model.springs.leg.rset", "did you mean 'rest'?"),
    ({"leg": {"damping": 1.0}}, "model.springs.leg.stiffness", "missing"),
])
def test_a_bad_spring_is_one_line_and_exit_1(tmp_path, springs, field, message):
    leg_scene(tmp_path, stiffness=1.0)  # writes the URDF and a good scene
    path = tmp_path / "leg_1.0.toml"
    text = path.read_text().replace('springs = {leg = {stiffness = 1.0, rest = 0.17}}',
                                    "springs = " + toml_value(springs))
    assert text != path.read_text()
    path.write_text(text)
    with pytest.raises(SceneError, match=message) as err:
        load_scene(path)
    assert err.value.field == field
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and field in lines[0] and "Traceback" not in result.output, result.output


def test_the_viewer_moves_a_prismatic_joints_link(tmp_path):
    """The page's animation of the bob follows its prismatic joint: the link's key positions are
    the joint's coordinate (the bob's origin is the joint's, on the world's y axis)."""
    from test_viz import page_commands

    from frcontrol.viz import meshcat_view

    scene = load_scene(bob_scene(tmp_path, {"stiffness": BOB_STIFFNESS}))
    run = simulate_rigid(scene, duration=0.3, dt=1e-2)
    page = meshcat_view.write_html(scene, run, tmp_path / "bob.html", fps=100).read_text(encoding="utf-8")
    (animation,) = [c for c in page_commands(page) if c["type"] == "set_animation"]
    clip = {a["path"]: a["clip"] for a in animation["animations"]}["/meshcat/frcontrol/robot/bob"]
    keys = {t["name"]: t for t in clip["tracks"]}[".position"]["keys"]
    positions = np.array([key["value"] for key in keys])
    assert np.ptp(run.q[:, 0]) > 0.05  # the bob moved
    np.testing.assert_allclose(positions[:, 1], run.q[:, 0], atol=1e-12)
    np.testing.assert_allclose(positions[:, 0], 0.0, atol=1e-12)


@needs_kernel
def test_both_kernels_add_the_springs(tmp_path, monkeypatch):
    """The compiled and the NumPy assembly give the same state with springs, which is the
    springless state plus k (q - rest) + c v on the spring's coordinate."""
    path = tmp_path / "leg.toml"
    leg_scene(tmp_path, stiffness=2400.0)
    text = (tmp_path / "leg_2400.0.toml").read_text()
    path.write_text(text.replace("rest = 0.17", "rest = 0.17, damping = 24.0"))
    states = {}
    for kernel in ("compiled", "numpy"):
        monkeypatch.setenv("FRC_KERNEL", kernel)
        robot = load_scene(path).robot
        assert (robot._kernel_plan is not None) == (kernel == "compiled")
        q, v = np.array([0.1, 0.2, 0.3, 0.4, 0.15]), np.array([0.5, -0.2, 1.0, -2.0, 0.7])
        states[kernel] = robot.state(q, v)
    monkeypatch.setenv("FRC_KERNEL", "numpy")
    free = leg_scene(tmp_path, stiffness=0.0).robot.state(q, v)
    for name, value in vars(states["numpy"]).items():
        found = getattr(states["compiled"], name)
        np.testing.assert_allclose(found, value, rtol=1e-13, atol=1e-13, err_msg=name)
    expected = free.bias.copy()
    expected[4] += 2400.0 * (0.15 - LEG) + 24.0 * 0.7
    np.testing.assert_allclose(states["compiled"].bias, expected, rtol=1e-13, atol=1e-12)
