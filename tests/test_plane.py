"""A plane of a 3-D robot (example-robot-data's Solo) as a planar robot, against Pinocchio's 3-D model.

The oracle is Pinocchio on the original 3-D URDF with a free-flyer root: at the same configuration,
the planar robot's mass matrix must equal the 3-D one restricted to the planar motions,
``J^T M_3 J`` (J maps the planar velocities to the free-flyer's and the joints'), and its gravity
terms ``J^T g_3``. The planar robot is built from the file frcontrol writes, so any error in a
frame, an axis sign, a centre of mass or an inertia shows up here.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pinocchio as pin
import pytest

from frcontrol.errors import RobotModelError, SceneError
from frcontrol.model import PlanarRobot
from frcontrol.plane import (
    PLANES,
    example_robot_data_robots,
    example_robot_data_urdf,
    planar_urdf,
    plane_rotation,
    rpy_from_matrix,
)
from frcontrol.scene import load_scene
from frcontrol.scene_schema import SCENE_SCHEMA
from frcontrol.urdf import read_urdf

SOLO = example_robot_data_urdf("example-robot-data:solo")
SOLO12 = example_robot_data_urdf("example-robot-data:solo12")
HAA = ("FL_HAA", "FR_HAA", "HL_HAA", "HR_HAA")


def three_d(urdf, plane: str, robot: PlanarRobot, q: np.ndarray, locked=None):
    """(3-D model, data, its q, J: planar velocities -> 3-D velocities) at the planar ``q``."""
    model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
    P = plane_rotation(plane)
    rotation = P.T @ pin.utils.rotate("z", q[2]) @ P
    q3 = pin.neutral(model)
    q3[:3] = P.T @ np.array([q[0], q[1], 0.0])
    q3[3:7] = pin.Quaternion(rotation).coeffs()
    J = np.zeros((model.nv, robot.nv))
    J[0:3, 0], J[0:3, 1] = rotation.T @ P[0], rotation.T @ P[1]  # the free flyer's v is local
    J[3:6, 2] = P[2]
    for name, value in (locked or {}).items():
        q3[model.joints[model.getJointId(name)].idx_q] = value
    for i, name in enumerate(robot.joint_names):
        joint = model.joints[model.getJointId(name)]
        q3[joint.idx_q] = q[3 + i]
        J[joint.idx_v, 3 + i] = 1.0
    model.gravity.linear[:] = -robot.gravity * P[1]  # the planar -y is "down"
    return model, model.createData(), q3, J


@pytest.mark.parametrize("seed", range(3))
def test_solo_in_its_sagittal_plane_has_the_3d_mass_matrix_and_gravity(seed):
    robot = PlanarRobot(planar_urdf(SOLO, "xz"))
    assert robot.joint_names == ("FL_HFE", "FL_KFE", "FR_HFE", "FR_KFE", "HL_HFE", "HL_KFE", "HR_HFE",
                                 "HR_KFE")
    q = np.random.default_rng(seed).uniform(-3.0, 3.0, robot.nv)
    model, data, q3, J = three_d(SOLO, "xz", robot, q)
    M3 = pin.crba(model, data, q3)
    M3 = np.triu(M3) + np.triu(M3, 1).T
    M = robot.mass_matrix(q)
    assert np.allclose(M, J.T @ M3 @ J, rtol=0, atol=1e-12 * np.abs(M).max())
    gravity = robot.state(q, np.zeros(robot.nv)).bias
    assert np.allclose(gravity, J.T @ pin.computeGeneralizedGravity(model, data, q3), rtol=0, atol=1e-12)
    assert robot.total_mass == pytest.approx(pin.computeTotalMass(model), rel=1e-14)
    # every link's origin: the planar pose is the 3-D one in the plane's axes
    pin.framesForwardKinematics(model, data, q3)
    P = plane_rotation("xz")
    for link, (origin, _) in robot.link_poses(q).items():
        placed = P @ data.oMf[model.getFrameId(link, pin.FrameType.BODY)].translation
        assert np.allclose(origin, placed[:2], atol=1e-12), link


def test_the_mass_matrix_check_can_fail():
    """The same comparison on a wrong map (the plane's normal flipped: joint angles of the wrong
    sign) disagrees: the test above is not vacuous."""
    robot = PlanarRobot(planar_urdf(SOLO, "xz"))
    q = np.random.default_rng(7).uniform(-3.0, 3.0, robot.nv)
    model, data, q3, J = three_d(SOLO, "xz", robot, q)
    for i, name in enumerate(robot.joint_names):
        q3[model.joints[model.getJointId(name)].idx_q] = -q[3 + i]
    M3 = pin.crba(model, data, q3)
    M3 = np.triu(M3) + np.triu(M3, 1).T
    assert not np.allclose(robot.mass_matrix(q), J.T @ M3 @ J, rtol=0, atol=1e-6)


def test_solo12_with_its_ab_ad_joints_locked_matches_its_3d_model():
    locked = dict.fromkeys(HAA, 0.0)
    robot = PlanarRobot(planar_urdf(SOLO12, "xz", locked))
    assert len(robot.joint_names) == 8 and not set(HAA) & set(robot.joint_names)
    q = np.random.default_rng(3).uniform(-3.0, 3.0, robot.nv)
    model, data, q3, J = three_d(SOLO12, "xz", robot, q, locked)
    M3 = pin.crba(model, data, q3)
    M3 = np.triu(M3) + np.triu(M3, 1).T
    assert np.allclose(robot.mass_matrix(q), J.T @ M3 @ J, rtol=0, atol=1e-12)


@pytest.mark.parametrize(("urdf", "plane", "locked", "joint"), [
    (SOLO12, "xz", {}, "FL_HAA"),  # an ab/ad joint turns about x
    (SOLO12, "xz", {"FL_HAA": 0.3, "FR_HAA": 0.0, "HL_HAA": 0.0, "HR_HAA": 0.0}, "FL_HFE"),  # tilted leg
    (SOLO, "yz", {}, "FL_HFE"),  # the frontal plane: Solo's joints turn about y, in that plane
])
def test_a_joint_off_the_planes_normal_is_named(urdf, plane, locked, joint):
    with pytest.raises(RobotModelError, match=f"joint '{joint}' does not turn about the normal"):
        planar_urdf(urdf, plane, locked)


def test_the_planes_and_their_rotations():
    assert list(PLANES) == SCENE_SCHEMA["properties"]["plane"]["enum"]
    for plane in PLANES:
        P = plane_rotation(plane)
        assert np.allclose(P @ P.T, np.eye(3)) and np.linalg.det(P) == pytest.approx(1.0)
    assert np.allclose(plane_rotation("xz")[2], [0.0, -1.0, 0.0])  # theta is minus the pitch
    with pytest.raises(RobotModelError, match="unknown plane 'xw'"):
        plane_rotation("xw")


def test_rpy_round_trips_through_the_urdf_reader(tmp_path):
    rng = np.random.default_rng(0)
    for angles in [*rng.uniform(-3, 3, (20, 3)), (0.3, math.pi / 2, -0.2), (0.1, -math.pi / 2, 0.4)]:
        rotation = pin.utils.rpyToMatrix(*angles)
        path = tmp_path / "r.urdf"
        rpy = " ".join(repr(x) for x in rpy_from_matrix(rotation))
        path.write_text(f'<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="fixed">'
                        f'<parent link="a"/><child link="b"/><origin rpy="{rpy}"/></joint></robot>')
        assert np.allclose(read_urdf(path).joints[0].origin[:3, :3], rotation, atol=1e-12)
        path.unlink()


def test_the_written_urdf_keeps_meshes_and_welds_locked_joints():
    document = read_urdf(planar_urdf(SOLO12, "xz", dict.fromkeys(HAA, 0.0)))
    kinds = {j.name: j.kind for j in document.joints}
    assert all(kinds[name] == "fixed" for name in HAA)
    meshes = [v for shapes in document.visuals.values() for v in shapes if v.shape == "mesh"]
    assert meshes and all(v.mesh_filename.startswith("file://") for v in meshes)
    for joint in document.movable_joints:
        assert np.allclose(np.abs(joint.axis), [0.0, 0.0, 1.0])


def test_example_robot_data_names():
    robots = example_robot_data_robots()
    assert robots["solo"] == robots["solo/solo"] and robots["solo12"].name == "solo12.urdf"
    with pytest.raises(RobotModelError, match="did you mean example-robot-data:solo"):
        example_robot_data_urdf("example-robot-data:sol")
    with pytest.raises(RobotModelError, match="no robot '../../etc/passwd'"):
        example_robot_data_urdf("example-robot-data:../../etc/passwd")


def scene_text(extra: str, robot: str = "example-robot-data:solo12") -> str:
    return (f'robot = "{robot}"\n{extra}\n[state]\nq = [0.0, 0.3, 0.0{", 0.0" * 8}]\n')


@pytest.mark.parametrize(("extra", "field", "reason"), [
    ("", "plane", "a 3-D robot; give the plane"),
    ('plane = "xz"', "plane", "joint 'FL_HAA' does not turn about the normal of plane 'xz'"),
    ('plane = "xz"\nplane_locked = {FL_HAX = 0.0}', "plane_locked", "did you mean 'FL_HAA'"),
    ('plane_locked = {FL_HAA = 0.0}', "plane_locked", "give the plane too"),
    ('plane = "xy"\nplane_locked = {FL_HAA = 0.0}', "plane", "joint 'FL_HFE'"),
    ('plane = "xq"', "plane", "expected one of 'xz'"),
])
def test_a_scene_names_what_is_wrong_with_its_plane(tmp_path, extra, field, reason):
    path = tmp_path / "s.toml"
    path.write_text(scene_text(extra))
    with pytest.raises(SceneError, match=re.escape(reason)) as info:
        load_scene(path)
    assert info.value.field == field and reason in info.value.reason, info.value


def test_a_scene_loads_solo12_in_its_sagittal_plane(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(scene_text('plane = "xz"\nplane_locked = {FL_HAA = 0.0, FR_HAA = 0.0, HL_HAA = 0.0, '
                               'HR_HAA = 0.0}'))
    scene = load_scene(path)
    assert scene.coordinate_names[:3] == ("x", "y", "theta") and len(scene.coordinate_names) == 11


def test_a_scene_document_names_an_example_robot_data_robot():
    """The service's door (a document, no paths) accepts the package's robots by name."""
    from frcontrol.scene import read_scene_document, resolve_scene_path, scene_from_document

    document = read_scene_document(resolve_scene_path("solo_standup"))
    scene = scene_from_document(document)
    assert scene.robot.total_mass == pytest.approx(2.17784899, rel=1e-8)
    with pytest.raises(SceneError, match="example-robot-data has no robot"):
        scene_from_document({**document, "robot": "example-robot-data:../solo"})


@pytest.mark.parametrize(("joints", "reason"), [
    ('<joint name="free" type="floating"><parent link="a"/><child link="b"/></joint>', "is floating"),
    ("", "expected one root link, found 2: a, b"),
])
def test_a_urdf_that_is_not_one_tree_without_a_base_is_refused(tmp_path, joints, reason):
    path = tmp_path / "r.urdf"
    path.write_text(f'<robot name="r"><link name="a"/><link name="b"/>{joints}</robot>')
    with pytest.raises(RobotModelError, match=reason):
        planar_urdf(path, "xz")


def test_a_removed_cache_file_is_written_again(tmp_path):
    source = tmp_path / "private_solo.urdf"  # its own cache file: others may be reading Solo's
    source.write_text(SOLO.read_text())
    path = planar_urdf(source, "xz")
    path.unlink()
    again = planar_urdf(source, "xz")
    assert again == path and again.is_file()
    again.unlink()
