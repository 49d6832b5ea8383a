"""The model layer against Pinocchio's own algorithms, finite differences and closed forms."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import needs_kernel

from frcontrol.errors import FrameNotFound, RobotModelError
from frcontrol.model import ContactPoint, PlanarRobot
from frcontrol.scene import load_scene, shipped_robots_dir, shipped_scene_names
from frcontrol.springs import JointTerms

ROBOTS = shipped_robots_dir()
EPS = 1e-6  # finite-difference step [m or rad]
FD_TOL = 1e-6  # agreement of central differences (error O(EPS^2) times curvature, plus rounding)


def point(name: str, link: str, p, n=(0.0, 1.0), s=(0.0, 0.0), mu=0.5) -> ContactPoint:
    n = np.asarray(n, float) / np.linalg.norm(n)
    return ContactPoint(name, link, np.asarray(p, float), n, np.asarray(s, float), mu)


def rhex(massive_legs: bool = False, tmp_path: Path | None = None) -> PlanarRobot:
    urdf = ROBOTS / "rhex_planar.urdf"
    if massive_legs:
        text = urdf.read_text().replace(
            '<mass value="0.0"/>\n      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>',
            '<mass value="0.1"/>\n      '
            '<inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/>',
        )
        assert text != urdf.read_text()
        urdf = tmp_path / "rhex_massive.urdf"
        urdf.write_text(text)
    contacts = [point(f"toe_{leg}", f"leg_{leg}", (0.0, -0.17), n=(0.3, 1.0))
                for leg in ("front", "middle", "rear")]
    contacts += [point("corner", "body", (0.25, 0.065), n=(-0.2, 1.0))]
    return PlanarRobot(urdf, "planar", 9.81, contacts)


def snake(base: str = "planar") -> PlanarRobot:
    contacts = [point("tail", "link0", (0.0, 0.0), n=(1.0, 0.0)),
                point("head", "link8", (0.2, 0.0), n=(0.0, 1.0))]
    return PlanarRobot(ROBOTS / "snake_planar.urdf", base, 9.81, contacts)


def random_state(robot: PlanarRobot, rng: np.random.Generator):
    return rng.uniform(-np.pi, np.pi, robot.nv), rng.normal(size=robot.nv)


def rnea_minimal(robot: PlanarRobot, q, v, a) -> np.ndarray:
    """Inverse dynamics in minimal coordinates through Pinocchio's RNEA."""
    data = robot.model.createData()
    tau = pin.rnea(robot.model, data, robot.pinocchio_q_from_minimal(q),
                   robot.pinocchio_v_from_minimal(v), robot.pinocchio_v_from_minimal(a))
    out = np.empty(robot.nv)
    out[:] = tau[robot._v_index]
    return out


@pytest.mark.parametrize("make", [lambda tp: rhex(True, tp), lambda tp: rhex(False),
                                  lambda tp: snake(), lambda tp: snake("fixed")])
def test_mass_matrix_and_bias_against_rnea(make, tmp_path):
    robot = make(tmp_path)
    rng = np.random.default_rng(1)
    for _ in range(3):
        q, v = random_state(robot, rng)
        state = robot.state(q, v)
        zero = np.zeros(robot.nv)
        np.testing.assert_allclose(state.bias, rnea_minimal(robot, q, v, zero), atol=1e-10)
        gravity_only = rnea_minimal(robot, q, zero, zero)
        for j in range(robot.nv):
            column = rnea_minimal(robot, q, zero, np.eye(robot.nv)[j]) - gravity_only
            np.testing.assert_allclose(state.mass_matrix[:, j], column, atol=1e-10)
        np.testing.assert_array_equal(state.mass_matrix, state.mass_matrix.T)


def contact_points_from_pin_q(robot: PlanarRobot, q_pin: np.ndarray) -> np.ndarray:
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q_pin)
    return np.array([data.oMf[f].translation[:2] for f in robot._contact_frames])


@pytest.mark.parametrize(
    "make", [lambda tp: rhex(True, tp), lambda tp: snake(), lambda tp: snake("fixed")]
)
def test_rows_and_drift_against_finite_differences_through_integrate(make, tmp_path):
    robot = make(tmp_path)
    rng = np.random.default_rng(2)
    q, v = random_state(robot, rng)
    state = robot.state(q, v)
    q_pin = robot.pinocchio_q_from_minimal(q)
    normals = np.array([c.normal_in_world for c in robot.contacts])
    tangents = np.array([c.tangent_in_world for c in robot.contacts])
    for j in range(robot.nv):
        dv_pin = np.zeros(robot.model.nv)
        dv_pin[robot._v_index[j]] = EPS
        plus = contact_points_from_pin_q(robot, pin.integrate(robot.model, q_pin, dv_pin))
        minus = contact_points_from_pin_q(robot, pin.integrate(robot.model, q_pin, -dv_pin))
        column = (plus - minus) / (2 * EPS)
        np.testing.assert_allclose(state.jacobian_normal[:, j], np.sum(normals * column, 1), atol=FD_TOL)
        np.testing.assert_allclose(state.jacobian_tangent[:, j], np.sum(tangents * column, 1), atol=FD_TOL)
    # drift dJ v = d/dt (J(q(t)) v) along q(t) = q + t v
    v_pin = robot.pinocchio_v_from_minimal(v)
    ahead = robot.state(q + EPS * v, v)
    behind = robot.state(q - EPS * v, v)
    pairs = (("jacobian_normal", "drift_normal", "n"), ("jacobian_tangent", "drift_tangent", "t"))
    for rows, drift, label in pairs:
        fd = (getattr(ahead, rows) - getattr(behind, rows)) @ v / (2 * EPS)
        np.testing.assert_allclose(getattr(state, drift), fd, atol=1e-5, err_msg=label)
    # the integrate path and the minimal path agree on configuration
    np.testing.assert_allclose(
        contact_points_from_pin_q(robot, pin.integrate(robot.model, q_pin, EPS * v_pin)),
        robot.contact_points_in_world(q + EPS * v), atol=1e-12,
    )


@pytest.mark.parametrize("theta", [2.007, 0.3, -1.2, np.pi / 2])
@pytest.mark.parametrize("distance", [0.5, 0.2])
def test_rod_rows_closed_form(theta, distance):
    robot = PlanarRobot(ROBOTS / "rod.urdf", "planar", 9.81,
                        [point("c", "rod", (-distance, 0.0), n=(0.0, 1.0))])
    omega = 0.7
    state = robot.state(np.array([0.1, 0.4, theta]), np.array([0.0, 0.0, omega]))
    np.testing.assert_allclose(state.jacobian_normal[0], [0.0, 1.0, -distance * np.cos(theta)], atol=1e-14)
    np.testing.assert_allclose(state.jacobian_tangent[0], [1.0, 0.0, distance * np.sin(theta)], atol=1e-14)
    # p = c + R(theta)(-l, 0): centripetal drift w^2 l (cos, sin)
    np.testing.assert_allclose(
        [state.drift_tangent[0], state.drift_normal[0]],
        omega**2 * distance * np.array([np.cos(theta), np.sin(theta)]), atol=1e-14,
    )
    np.testing.assert_allclose(state.mass_matrix, np.diag([1.0, 1.0, 1.0 / 12]), atol=1e-9)
    np.testing.assert_allclose(state.bias, [0.0, 9.81, 0.0], atol=1e-12)


def test_massless_legs_give_a_singular_mass_matrix_with_the_body_block_exact():
    robot = rhex(False)
    state = robot.state(np.array([0.0, 0.1, 0.3, 0.5, -1.0, 2.0]), np.zeros(6))
    np.testing.assert_array_equal(state.mass_matrix[3:, :], 0.0)
    np.testing.assert_array_equal(state.mass_matrix[:, 3:], 0.0)
    inertia = 7.5 * (0.5**2 + 0.13**2) / 12
    np.testing.assert_allclose(state.mass_matrix[:3, :3], np.diag([7.5, 7.5, inertia]), atol=1e-12)
    assert np.linalg.matrix_rank(state.mass_matrix) == 3
    assert np.all(np.isfinite(state.jacobian_normal))


def test_fixed_base_equals_the_joint_block_of_the_planar_base_at_the_origin():
    planar, fixed = snake("planar"), snake("fixed")
    rng = np.random.default_rng(3)
    joints = rng.uniform(-1, 1, 8)
    jv = rng.normal(size=8)
    sp = planar.state(np.r_[0.0, 0.0, 0.0, joints], np.r_[0.0, 0.0, 0.0, jv])
    sf = fixed.state(joints, jv)
    assert fixed.coordinate_names == tuple(f"j{i}" for i in range(1, 9))
    np.testing.assert_allclose(sf.mass_matrix, sp.mass_matrix[3:, 3:], atol=1e-12)
    np.testing.assert_allclose(sf.bias, sp.bias[3:], atol=1e-12)
    np.testing.assert_allclose(sf.jacobian_normal, sp.jacobian_normal[:, 3:], atol=1e-12)
    np.testing.assert_allclose(sf.drift_normal, sp.drift_normal, atol=1e-12)


@pytest.mark.parametrize("axis", ["0 0 1", "0 0 -1"])
def test_continuous_joints_are_revolute_joints_of_pinocchios_cos_sin_model(axis, tmp_path):
    """The model's continuous joints take the angle; M, h and every frame's placement equal those of
    Pinocchio's own model of the URDF (unbounded joints of (cos q, sin q)) bit for bit."""
    urdf = tmp_path / "rhex.urdf"
    text = (ROBOTS / "rhex_planar.urdf").read_text()
    assert text.count('<axis xyz="0 0 1"/>') == 3
    urdf.write_text(text.replace('<axis xyz="0 0 1"/>', f'<axis xyz="{axis}"/>'))
    robot = PlanarRobot(urdf, "planar", 9.81, [point("toe", "leg_front", (0.0, -0.17))])
    assert robot.model.nq == robot.model.nv == 6
    root = pin.JointModelComposite(3)
    for joint in (pin.JointModelPX(), pin.JointModelPY(), pin.JointModelRZ()):
        root.addJoint(joint)
    own = pin.buildModelFromUrdf(str(urdf), root)
    assert own.nq == 9 and {own.joints[j].nq for j in range(2, 5)} == {2}
    own.gravity = robot.model.gravity
    rng = np.random.default_rng(4)
    for _ in range(3):
        q, v = random_state(robot, rng)
        q_own = np.r_[q[:3], np.ravel([(np.cos(a), np.sin(a)) for a in q[3:]])]
        data, own_data = robot.model.createData(), own.createData()
        pin.computeAllTerms(robot.model, data, robot.pinocchio_q_from_minimal(q), v)
        pin.computeAllTerms(own, own_data, q_own, v)
        np.testing.assert_array_equal(data.M, own_data.M)
        np.testing.assert_array_equal(data.nle, own_data.nle)
        pin.updateFramePlacements(robot.model, data)
        pin.updateFramePlacements(own, own_data)
        for f in range(own.nframes):  # the robot's own model has the contact frame too, at the end
            np.testing.assert_array_equal(data.oMf[f].homogeneous, own_data.oMf[f].homogeneous)
    assert [f.name for f in robot.model.frames][:own.nframes] == [f.name for f in own.frames]
    assert [robot.model.inertias[j] == own.inertias[j] for j in range(own.njoints)] == [True] * own.njoints


def test_joint_order_follows_the_urdf_document(tmp_path):
    # joints listed j2 before j1: Pinocchio orders by the tree (j1 first), frcontrol by the file
    text = (ROBOTS / "snake_planar.urdf").read_text()
    start = text.index('  <joint name="j1"')
    end = text.index("</joint>", start) + len("</joint>\n")
    j1 = text[start:end]
    text = text[:start] + text[end:]
    text = text.replace("</robot>", j1 + "</robot>")
    urdf = tmp_path / "reordered.urdf"
    urdf.write_text(text)
    robot = PlanarRobot(urdf, "planar", 9.81, [point("head", "link8", (0.2, 0.0))])
    assert robot.coordinate_names == ("x", "y", "theta", "j2", "j3", "j4", "j5", "j6", "j7", "j8", "j1")
    reference = snake("planar")
    rng = np.random.default_rng(4)
    q, v = random_state(reference, rng)
    perm = [0, 1, 2, 4, 5, 6, 7, 8, 9, 10, 3]  # reordered coordinate i is reference coordinate perm[i]
    a, b = robot.state(q[perm], v[perm]), reference.state(q, v, [1])
    np.testing.assert_allclose(a.mass_matrix, b.mass_matrix[np.ix_(perm, perm)], atol=1e-12)
    np.testing.assert_allclose(a.jacobian_normal, b.jacobian_normal[:, perm], atol=1e-12)
    np.testing.assert_allclose(a.drift_normal, b.drift_normal, atol=1e-12)
    np.testing.assert_allclose(a.bias, b.bias[perm], atol=1e-12)


def test_unknown_link_and_non_planar_urdf(tmp_path):
    with pytest.raises(FrameNotFound, match="unknown link 'nose'"):
        PlanarRobot(ROBOTS / "rod.urdf", "planar", 9.81, [point("c", "nose", (0, 0))])
    text = (ROBOTS / "snake_planar.urdf").read_text().replace('<axis xyz="0 0 1"/>', '<axis xyz="1 0 0"/>', 1)
    urdf = tmp_path / "tilted.urdf"
    urdf.write_text(text)
    with pytest.raises(RobotModelError, match="revolute axis is along z"):
        PlanarRobot(urdf)
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'></robot>")
    with pytest.raises(RobotModelError, match="cannot read URDF"):
        PlanarRobot(bad)


def test_shipped_scenes_touch_at_zero_gap():
    for name in ("rod_on_table", "box_on_ground", "box_on_slope", "table_on_ground", "disk_in_wedge",
                 "rhex_flip", "snake_climb"):
        scene = load_scene(name)
        state = scene.state()
        assert scene.active_contacts, name
        np.testing.assert_allclose(state.gaps, 0.0, atol=1e-9, err_msg=name)
        assert np.linalg.eigvalsh(state.mass_matrix).min() >= -1e-12


@pytest.mark.parametrize("make", ["rhex_massive", "snake"])
def test_mass_centre_of_mass_and_potential_energy(make, tmp_path):
    """m is the URDF's masses summed; V = m g y_com; dV/dq is the bias at v = 0 (gravity alone)."""
    import xml.etree.ElementTree as ET

    robot = rhex(True, tmp_path) if make == "rhex_massive" else snake()
    masses = [float(m.get("value")) for m in ET.parse(robot.urdf_path).getroot().iter("mass")]
    assert robot.total_mass == pytest.approx(sum(masses), rel=1e-12)
    assert robot.weight_scale() == pytest.approx(sum(masses) * 9.81, rel=1e-12)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, _ = random_state(robot, rng)
        com = robot.center_of_mass(q)
        energy = robot.potential_energy(q)
        assert energy == pytest.approx(robot.total_mass * 9.81 * com[1], rel=1e-10, abs=1e-12)
        gradient = np.array([(robot.potential_energy(q + EPS * e) - robot.potential_energy(q - EPS * e))
                             / (2 * EPS) for e in np.eye(robot.nv)])
        gravity = robot.state(q, np.zeros(robot.nv)).bias
        np.testing.assert_allclose(gradient, gravity, atol=FD_TOL * max(1.0, np.abs(gravity).max()))
        # the base's horizontal move shifts the centre of mass by as much
        moved = q.copy()
        moved[0] += 0.3
        np.testing.assert_allclose(robot.center_of_mass(moved) - com, [0.3, 0.0], atol=1e-12)


@pytest.mark.parametrize("make", ["rhex_massive", "snake"])
def test_point_kinematics_against_finite_differences(make, tmp_path):
    """Positions move with J v; J's columns are d position / dq; the drift is d(J v)/dt - J dv at
    dv = 0, i.e. (J(q + eps v) - J(q - eps v)) v / (2 eps)."""
    robot = rhex(True, tmp_path) if make == "rhex_massive" else snake()
    links = robot.link_names[1:3]
    points = [(links[0], (0.07, -0.02)), (links[1], (-0.03, 0.11))]
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, v = random_state(robot, rng)
        kin = robot.point_kinematics(q, v, points)
        for j, e in enumerate(np.eye(robot.nv)):
            moved = (robot.point_kinematics(q + EPS * e, v, points).positions
                     - robot.point_kinematics(q - EPS * e, v, points).positions) / (2 * EPS)
            np.testing.assert_allclose(kin.jacobians[:, :, j], moved, atol=FD_TOL)
        ahead = robot.point_kinematics(q + EPS * v, v, points).jacobians
        behind = robot.point_kinematics(q - EPS * v, v, points).jacobians
        np.testing.assert_allclose(kin.drifts, (ahead - behind) @ v / (2 * EPS), atol=1e-5)
    with pytest.raises(FrameNotFound, match="unknown link 'no_such_link'"):
        robot.point_kinematics(q, v, [("no_such_link", (0.0, 0.0))])


ROUND_OFF = 1e-14  # [-] agreement of two evaluations of the same formulas, relative to the array's scale


def state_by_frame(robot: PlanarRobot, q, v, contacts) -> dict[str, np.ndarray]:
    """The state's arrays from Pinocchio's 3-D functions on a fresh Data, frame by frame: CRBA's
    upper triangle mirrored, nonlinear effects (plus the drives' damping and the joint springs),
    each frame's placement, world-aligned Jacobian and classical acceleration, projected on the
    contact's normal and tangent one contact at a time."""
    model, data = robot.model, robot.model.createData()
    q_pin, v_pin = robot.pinocchio_q_from_minimal(q), robot.pinocchio_v_from_minimal(v)
    order = robot._v_index
    upper = pin.crba(model, data, q_pin)
    mass = (np.triu(upper) + np.triu(upper, 1).T)[np.ix_(order, order)]
    bias = pin.nonLinearEffects(model, data, q_pin, v_pin)[order] + robot.drive_damping * v
    springs = robot.springs  # the joint springs' k (q - rest) + c v, written out
    if springs:
        j = springs.indices
        bias[j] += springs.stiffness * (q[j] - springs.rest) + springs.damping * v[j]
    pin.forwardKinematics(model, data, q_pin, v_pin, np.zeros(model.nv))
    pin.computeJointJacobians(model, data, q_pin)
    keys = ("contact_points", "gaps", "jacobian_normal", "jacobian_tangent", "drift_normal", "drift_tangent")
    out: dict[str, list] = {key: [] for key in keys}
    lwa = pin.LOCAL_WORLD_ALIGNED
    for i in contacts:
        contact, frame = robot.contacts[i], robot._contact_frames[i]
        n, t = contact.normal_in_world, contact.tangent_in_world
        p = pin.updateFramePlacement(model, data, frame).translation[:2]
        jac = pin.getFrameJacobian(model, data, frame, lwa)[:2][:, order]
        acc = pin.getFrameClassicalAcceleration(model, data, frame, lwa).linear[:2]
        for key, value in (("contact_points", p), ("gaps", n @ (p - contact.surface_point_in_world)),
                           ("jacobian_normal", n @ jac), ("jacobian_tangent", t @ jac),
                           ("drift_normal", n @ acc), ("drift_tangent", t @ acc)):
            out[key].append(value)
    k, nv = len(contacts), robot.nv
    arrays = {"mass_matrix": mass, "bias": bias, "contact_points": np.reshape(out["contact_points"], (k, 2)),
              **{key: np.reshape(out[key], (k, nv)) for key in ("jacobian_normal", "jacobian_tangent")},
              **{key: np.array(out[key]) for key in ("gaps", "drift_normal", "drift_tangent")}}
    arrays["normal_velocities"] = arrays["jacobian_normal"] @ v
    arrays["tangential_velocities"] = arrays["jacobian_tangent"] @ v
    return arrays


def assert_equal_to_round_off(found: np.ndarray, expected: np.ndarray, scale: float, label: str) -> None:
    assert found.shape == expected.shape, label
    assert np.all(np.abs(found - expected) <= ROUND_OFF * max(scale, 1e-300)), label


@pytest.mark.parametrize("name", shipped_scene_names())
def test_state_equals_the_frame_by_frame_evaluation_on_every_shipped_scene(name):
    scene = load_scene(name)
    robot = scene.robot
    rng = np.random.default_rng(sum(map(ord, name)))
    everything = tuple(range(len(robot.contacts)))
    subsets = [None, scene.active_indices, everything[::-1], list(everything[-1:]), ()]
    for contacts in subsets:
        q, v = random_state(robot, rng)
        state = robot.state(q, v, contacts)
        expected = state_by_frame(robot, q, v, everything if contacts is None else tuple(contacts))
        assert np.array_equal(state.q, q) and np.array_equal(state.v, v)
        for key, value in expected.items():
            scale = np.max(np.abs(expected["contact_points" if key == "gaps" else key]), initial=0.0)
            assert_equal_to_round_off(getattr(state, key), value, scale, f"{name} {contacts} {key}")


def test_states_are_kept_across_calls():
    """Every array of a state is its own: a later call (other q, v) leaves an earlier state as it was."""
    scene = load_scene("rhex_flip")
    robot = scene.robot
    rng = np.random.default_rng(5)
    q, v = random_state(robot, rng)
    first = robot.state(q, v, scene.active_indices)
    kept = {key: np.copy(value) for key, value in vars(first).items()}
    second = robot.state(*random_state(robot, rng), scene.active_indices)
    for key, value in vars(first).items():
        np.testing.assert_array_equal(value, kept[key], err_msg=key)
        if key not in ("q", "v"):
            assert not np.shares_memory(value, getattr(second, key)), key
    assert set(vars(first)) == {f.name for f in dataclasses.fields(first)}
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign to field 'gaps'"):
        first.gaps = np.zeros(0)  # type: ignore[misc]


def numpy_twin(monkeypatch, build):
    """``build()`` made once with the compiled assembly and once with ``FRC_KERNEL=numpy``."""
    monkeypatch.delenv("FRC_KERNEL", raising=False)  # the default: the compiled kernel, built
    compiled = build()
    assert compiled._kernel_plan is not None
    monkeypatch.setenv("FRC_KERNEL", "numpy")
    reference = build()
    monkeypatch.delenv("FRC_KERNEL")
    assert reference._kernel_plan is None
    return compiled, reference


def assert_states_equal_to_round_off(found, expected, label: str) -> None:
    assert set(vars(found)) == set(vars(expected)) == {f.name for f in dataclasses.fields(found)}
    for key, value in vars(expected).items():
        scale = np.max(np.abs(expected.contact_points if key == "gaps" else value), initial=0.0)
        assert_equal_to_round_off(getattr(found, key), value, scale, f"{label} {key}")
        assert getattr(found, key).dtype == value.dtype, f"{label} {key}"


@needs_kernel
@pytest.mark.parametrize("name", shipped_scene_names())
def test_compiled_assembly_equals_the_numpy_assembly_on_every_shipped_scene(name, monkeypatch):
    """The compiled kernel's state (frcontrol._kernel.robot_state) against the NumPy reference, on
    every contact subset shape at random states: the same Pinocchio calls, the same sums."""
    compiled, reference = numpy_twin(monkeypatch, lambda: load_scene(name).robot)
    rng = np.random.default_rng(sum(map(ord, name)) + 1)
    everything = tuple(range(len(compiled.contacts)))
    for contacts in (None, everything[::-1], everything[-1:], (), everything[:1] * 2):
        for _ in range(3):
            q, v = random_state(compiled, rng)
            assert_states_equal_to_round_off(compiled.state(q, v, contacts), reference.state(q, v, contacts),
                                             f"{name} {contacts}")


@needs_kernel
def test_compiled_assembly_reorders_coordinates_and_adds_drive_damping(tmp_path, monkeypatch):
    """A robot whose coordinates are not in Pinocchio's order (a joint listed last in its URDF) and
    drives' damping in h: both paths agree; the state's v enters as given, even strided."""
    text = (ROBOTS / "snake_planar.urdf").read_text()
    start = text.index('  <joint name="j1"')
    end = text.index("</joint>", start) + len("</joint>\n")
    urdf = tmp_path / "reordered.urdf"
    urdf.write_text(text[:start] + text[end:].replace("</robot>", text[start:end] + "</robot>"))
    contacts = [point("tail", "link0", (0.0, 0.0), n=(1.0, 0.0)),
                point("head", "link8", (0.2, 0.0), n=(0.6, 0.8))]

    def build() -> PlanarRobot:
        return PlanarRobot(urdf, "planar", 9.81, contacts,
                           terms=JointTerms({3: 0.01, 10: 0.02}, {4: 0.5, 10: 1.5}))

    compiled, reference = numpy_twin(monkeypatch, build)
    assert compiled._kernel_plan[8] is not None  # the coordinates are reordered
    rng = np.random.default_rng(11)
    for contacts in (None, (1,), ()):
        q, v = random_state(compiled, rng)
        wide = np.repeat(v, 2)  # v as a strided view
        found = compiled.state(q, wide[::2], contacts)
        assert_states_equal_to_round_off(found, reference.state(q, v, contacts), f"reordered {contacts}")
        expected_bias = rnea_minimal(compiled, q, v, np.zeros(compiled.nv)) + compiled.drive_damping * v
        np.testing.assert_allclose(found.bias, expected_bias, rtol=1e-12, atol=1e-12)


@needs_kernel
def test_compiled_assembly_refuses_malformed_arguments(monkeypatch):
    from frcontrol import _kernel
    from frcontrol.errors import KernelError

    monkeypatch.delenv("FRC_KERNEL", raising=False)
    scene = load_scene("rod_on_table")
    robot = scene.robot
    assert robot._kernel_plan is not None
    plan = robot._kernel_plan
    layout = robot._layout(None)
    good = [plan, scene.q, scene.v, layout.frames, layout.positions, layout.lines, None]
    assert _kernel.robot_state(*good).gaps.shape == (1,)
    cases = [
        ({0: plan[:-1]}, "plan must be a tuple of 12 entries"),
        ({0: (1,) + plan[1:]}, "plan must be a tuple of 12 entries"),
        ({3: list(layout.frames)}, "frames and positions tuples"),
        ({4: ()}, "frames and positions tuples of one length"),
        ({5: layout.lines[:-1]}, "lines must be a tuple of 5 floats"),
        ({5: ("a",) * 5}, r"lines\[0\] is not a number"),
        ({2: scene.v[:2]}, "v has 2 entries, expected 3"),
        ({2: scene.v.astype(np.float32)}, "buffer v"),
        ({2: [0.0, 0.0, 0.0]}, "buffer v: not a strided buffer"),
        ({0: plan[:10] + (np.zeros((3, 2)), plan[11])}, "buffer mass: axis 1 has 2 entries, expected 3"),
        ({0: plan[:11] + (np.zeros(4),)}, "buffer nle: axis 0 has 4 entries, expected 3"),
        ({4: (np.zeros(2),)}, "buffer position: axis 0 has 2 entries, expected 3"),
        ({6: np.zeros(2)}, "buffer damping"),
        ({0: plan[:8] + (np.array([0, 1, 3]),) + plan[9:]}, r"v_index\[2\] = 3 is outside 0..2"),
    ]
    for change, message in cases:
        args = [change.get(i, arg) for i, arg in enumerate(good)]
        with pytest.raises(KernelError if message else Exception, match=message):
            _kernel.robot_state(*args)
    with pytest.raises(KernelError, match="takes 7 arguments, got 6"):
        _kernel.robot_state(*good[:-1])


def test_pinocchio_hands_out_views_and_copies_are_told_apart():
    """This Pinocchio hands out views (so the compiled assembly is used where it is built); a data
    object whose arrays are copies is told apart, and would get the NumPy assembly."""
    from frcontrol.model import _reads_in_place

    robot = load_scene("rhex_flip").robot
    assert _reads_in_place(robot.data, robot._contact_frames)

    class Copies:  # Pinocchio's data as a binding that copied its arrays out would give it
        def __init__(self, data):
            self._data = data

        @property
        def M(self):
            return self._data.M.copy()

        @property
        def nle(self):
            return self._data.nle.copy()

        @property
        def oMf(self):
            return self._data.oMf

    assert not _reads_in_place(Copies(robot.data), robot._contact_frames)


@needs_kernel
def test_compiled_assembly_reads_pinocchio_storage_in_place(monkeypatch):
    """The views the compiled assembly reads (the plan's M and h, each contact's position) are of
    the Pinocchio data's own storage: after a call at another state they hold Pinocchio's new
    values, the same as its conversions of data.M, data.nle and the placement's translation."""
    monkeypatch.delenv("FRC_KERNEL", raising=False)
    scene = load_scene("rhex_flip")
    robot = scene.robot
    assert robot._kernel_plan is not None
    mass, nle = robot._kernel_plan[10:]
    layout = robot._layout(None)
    rng = np.random.default_rng(3)
    for _ in range(2):
        q, v = random_state(robot, rng)
        state = robot.state(q, v)
        np.testing.assert_array_equal(mass, robot.data.M)
        np.testing.assert_array_equal(nle, robot.data.nle)
        for frame, position, point in zip(layout.frames, layout.positions, state.contact_points, strict=True):
            placement = pin.updateFramePlacement(robot.model, robot.data, frame)
            np.testing.assert_array_equal(position, placement.translation)
            np.testing.assert_array_equal(position[:2], point)


def test_a_velocity_of_another_number_type_is_converted():
    """state() takes v as a list or an int/float32 array on either kernel, as float64."""
    scene = load_scene("rhex_flip")
    robot, v = scene.robot, np.arange(scene.robot.nv) - 2
    reference = robot.state(scene.q, v.astype(float))
    for given in (v, v.tolist(), v.astype(np.float32)):
        state = robot.state(scene.q, given)
        assert state.v.dtype == np.float64
        np.testing.assert_array_equal(state.bias, reference.bias)
        np.testing.assert_array_equal(state.normal_velocities, reference.normal_velocities)


def _state_bytes(state):
    return {f.name: np.asarray(getattr(state, f.name)).tobytes() for f in dataclasses.fields(state)}


@pytest.mark.parametrize("name", shipped_scene_names())
def test_new_surface_points_give_the_state_of_a_robot_set_before_any_state(name):
    # the layouts kept get only their gap constants again; a robot that never made a layout makes
    # them from the new surface points: the states agree to the bit
    rng = np.random.default_rng(sum(map(ord, name)))
    kept = load_scene(name)
    subsets = [None, kept.active_indices]
    before = [_state_bytes(kept.robot.state(kept.q, kept.v, subset)) for subset in subsets]
    for _ in range(2):  # as an atlas sets them: the scene's own contact points, kept as given
        robot = kept.robot
        points = [dataclasses.replace(c, surface_point_in_world=c.surface_point_in_world
                                      + rng.normal(scale=0.05, size=2)) for c in robot.contacts]
        moved = robot.with_contact_points(points)
        fresh = PlanarRobot(robot.urdf_path, robot.base, robot.gravity, points, robot.locked, robot.terms)
        for subset in subsets:
            assert _state_bytes(moved.state(kept.q, kept.v, subset)) == \
                _state_bytes(fresh.state(kept.q, kept.v, subset))
    # the robot they were set on is unchanged
    assert [_state_bytes(kept.robot.state(kept.q, kept.v, subset)) for subset in subsets] == before
