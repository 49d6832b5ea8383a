"""The one URDF reader against Pinocchio's own URDF parser, and its errors."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from frcontrol.errors import RobotModelError
from frcontrol.scene import load_scene, shipped_robots_dir
from frcontrol.urdf import read_urdf

INERTIAL = ('<inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" '
            'izz="0.01"/></inertial>')


def arm_urdf(rng: np.random.Generator) -> str:
    """Three links, two revolute joints, origins and visual poses with random xyz and rpy."""
    def origin():
        xyz = " ".join(f"{v:.6f}" for v in rng.uniform(-0.5, 0.5, 3))
        rpy = " ".join(f"{v:.6f}" for v in rng.uniform(-np.pi, np.pi, 3))
        return f'<origin xyz="{xyz}" rpy="{rpy}"/>'

    return f"""<?xml version="1.0"?>
<robot name="arm">
  <material name="steel"><color rgba="0.5 0.5 0.6 1"/></material>
  <link name="a">{INERTIAL}<visual>{origin()}<geometry><box size="0.1 0.2 0.3"/></geometry>
    <material name="steel"/></visual></link>
  <link name="b">{INERTIAL}<visual>{origin()}<geometry><cylinder radius="0.05" length="0.4"/></geometry>
    <material name="red"><color rgba="1 0 0 0.5"/></material></visual>
    <visual>{origin()}<geometry><sphere radius="0.07"/></geometry>
    </visual></link>
  <link name="c">{INERTIAL}<visual>{origin()}<geometry><mesh filename="m.obj" scale="2 2 2"/>
    </geometry></visual></link>
  <joint name="j2" type="revolute"><parent link="b"/><child link="c"/>{origin()}
    <axis xyz="0 0 2"/><limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/>{origin()}
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
</robot>
"""


@pytest.mark.parametrize("seed", range(5))
def test_joint_and_visual_poses_match_pinocchio(seed, tmp_path):
    """Joint origins are Pinocchio's joint placements; visual origins are its geometry placements
    (each link here is its joint's child, so the link frame is the joint frame)."""
    path = tmp_path / "arm.urdf"
    path.write_text(arm_urdf(np.random.default_rng(seed)))
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    document = read_urdf(path)
    assert [j.name for j in document.joints] == ["j2", "j1"]  # document order, not tree order
    assert document.links == ("a", "b", "c")
    model = pin.buildModelFromUrdf(str(path))
    for joint in document.joints:
        placement = model.jointPlacements[model.getJointId(joint.name)]
        np.testing.assert_allclose(joint.origin, placement.homogeneous, atol=1e-12)
    np.testing.assert_allclose(document.joints[0].axis, [0.0, 0.0, 1.0])  # normalised
    geometry = pin.buildGeomFromUrdf(model, str(path), pin.GeometryType.VISUAL, package_dirs=[str(tmp_path)])
    by_link: dict[str, list] = {}
    for obj in geometry.geometryObjects:
        by_link.setdefault(model.frames[obj.parentFrame].name, []).append(obj)
    for link in ("b", "c"):
        ours = document.visuals[link]
        assert len(ours) == len(by_link[link])
        for visual, obj in zip(ours, by_link[link], strict=True):
            np.testing.assert_allclose(visual.origin, obj.placement.homogeneous, atol=1e-12)
    (box,) = document.visuals["a"]
    cylinder, sphere = document.visuals["b"]
    (mesh,) = document.visuals["c"]
    assert box.size == (0.1, 0.2, 0.3) and box.rgba == (0.5, 0.5, 0.6, 1.0)  # the named material
    assert cylinder.size == (0.05, 0.4) and cylinder.rgba == (1.0, 0.0, 0.0, 0.5)
    assert sphere.size == (0.07,) and sphere.rgba is None
    assert mesh.shape == "mesh" and mesh.size == (2.0, 2.0, 2.0) and mesh.mesh_filename == "m.obj"


def test_shipped_robots_read_with_the_joints_pinocchio_builds():
    for path in sorted(shipped_robots_dir().glob("*.urdf")):
        document = read_urdf(path)
        model = pin.buildModelFromUrdf(str(path))
        movable = {name for name in model.names[1:]}
        assert {j.name for j in document.movable_joints} == movable, path.name
        assert read_urdf(path) is document  # parsed once per version of the file


@pytest.mark.parametrize(("text", "message"), [
    ("<robot><joint name='j' type='revolute'><axis xyz='0 0'/></joint></robot>", "bad axis"),
    ("<robot><joint name='j' type='revolute'><axis xyz='0 0 0'/></joint></robot>", "bad axis"),
    ("<robot><joint name='j' type='fixed'><origin xyz='0 0 nan'/></joint></robot>", "bad origin xyz"),
    ("<robot><link name='l'><visual><geometry><box size='1 1'/></geometry></visual></link></robot>",
     "bad box size"),
    ("<robot><material name='m'><color rgba='1 0 0'/></material></robot>", "bad rgba"),
    ("<model/>", "expected <robot>"),
    ("<robot>", "cannot read URDF"),
])
def test_malformed_files_raise_a_typed_error_naming_the_element(text, message, tmp_path):
    path = tmp_path / "bad.urdf"
    path.write_text(text)
    with pytest.raises(RobotModelError, match=message):
        read_urdf(path)


def test_a_changed_file_is_read_again(tmp_path):
    path = tmp_path / "r.urdf"
    path.write_text("<robot name='one'/>")
    assert read_urdf(path).name == "one"
    path.write_text("<robot name='two, longer'/>")
    assert read_urdf(path).name == "two, longer"
    with pytest.raises(RobotModelError, match="cannot read URDF"):
        read_urdf(tmp_path / "missing.urdf")


# ------------------------------------------------------------------ physical validity of links

def pendulum_urdf(mass: str, inertia: dict[str, str]) -> str:
    """A fixed base and one arm on a revolute joint about z: the arm has this mass and inertia."""
    tensor = {"ixx": "0.01", "ixy": "0", "ixz": "0", "iyy": "0.01", "iyz": "0", "izz": "0.01"} | inertia
    attributes = " ".join(f'{key}="{value}"' for key, value in tensor.items())
    return f"""<?xml version="1.0"?>
<robot name="pendulum">
  <link name="base">{INERTIAL}</link>
  <link name="arm"><inertial><origin xyz="0.5 0 0"/><mass value="{mass}"/>
    <inertia {attributes}/></inertial></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
</robot>
"""


def pendulum_scene(tmp_path, write_scene, mass: str, inertia: dict[str, str]):
    (tmp_path / "pendulum.urdf").write_text(pendulum_urdf(mass, inertia))
    return write_scene({
        "name": "pendulum", "robot": "pendulum.urdf", "base": "fixed", "state": {"q": [0.3]},
        "contacts": [{"name": "tip", "link": "arm", "point": [1.0, 0.0], "normal": [0.0, 1.0],
                      "mu": 0.5, "surface_point": [0.0, -0.0]}],
        "inputs": {"coordinates": ["hinge"], "lower": [-5.0], "upper": [5.0]},
    }, "pendulum.toml")


INVALID_LINKS = [
    ("-1", {}, "link 'arm' has mass -1 kg"),
    ("1", {"izz": "-0.01"}, "link 'arm' has an indefinite inertia"),
    ("1", {"ixx": "-0.01"}, "link 'arm' has an indefinite inertia"),  # izz > 0, but not physical
    ("1", {"ixx": "0.01", "iyy": "0.01", "ixy": "0.05"}, "link 'arm' has an indefinite inertia"),
]


@pytest.mark.parametrize(("mass", "inertia", "message"), INVALID_LINKS)
def test_a_negative_mass_or_an_indefinite_inertia_is_refused(tmp_path, mass, inertia, message):
    path = tmp_path / "pendulum.urdf"
    path.write_text(pendulum_urdf(mass, inertia))
    with pytest.raises(RobotModelError, match=message):
        read_urdf(path)


@pytest.mark.parametrize(("mass", "inertia", "message"), INVALID_LINKS[:2])
@pytest.mark.parametrize("command", [["validate"], ["analyze", "--input", "hinge=0"]])
def test_the_cli_names_the_link_in_one_line(tmp_path, write_scene, command, mass, inertia, message):
    """``frc validate`` and ``frc analyze``: exit 1, one line on stderr naming the link."""
    from frcontrol.cli.app import app
    from typer.testing import CliRunner

    scene = pendulum_scene(tmp_path, write_scene, mass, inertia)
    result = CliRunner().invoke(app, [command[0], str(scene), *command[1:]])
    assert result.exit_code == 1 and result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("frc: error: ") and message in lines[0], result.stderr


@pytest.mark.parametrize(("mass", "inertia"), [
    ("0", {key: "0" for key in ("ixx", "iyy", "izz")}),  # a massless link (RHex's legs)
    ("0.2", {key: "0" for key in ("ixx", "iyy", "izz")}),  # a point mass (the snake's links)
])
def test_a_massless_link_and_a_point_mass_are_physical(tmp_path, write_scene, mass, inertia):
    """Both load and answer; the mass matrix is positive semi-definite (here: the point mass
    gives m r^2, the massless arm 0)."""
    from frcontrol.cli.app import app
    from typer.testing import CliRunner

    scene = pendulum_scene(tmp_path, write_scene, mass, inertia)
    result = CliRunner().invoke(app, ["validate", str(scene)])
    assert result.exit_code == 0, result.stderr
    loaded = load_scene(scene)
    (m,) = loaded.robot.mass_matrix(np.array([0.3])).ravel()
    assert m == pytest.approx(float(mass) * 0.25, abs=1e-12)
