"""Scene loading: the format, defaults, activity of contacts and every bad input."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import ROBOTS, rod_scene

import frcontrol
from frcontrol.errors import CoordinateNotFound, InputError, SceneError
from frcontrol.model import _skeleton
from frcontrol.scene import (
    _parsed_toml,
    load_scene,
    parse_input_assignments,
    resolve_scene_path,
    shipped_robots_dir,
    shipped_scene_names,
)


def test_readme_scene_loads_with_defaults(write_scene):
    scene_dict = rod_scene()
    del scene_dict["gravity"]
    del scene_dict["state"]["v"]
    scene = load_scene(write_scene(scene_dict))
    assert scene.coordinate_names == ("x", "y", "theta")
    assert scene.robot.gravity == 9.81
    np.testing.assert_array_equal(scene.v, 0.0)
    (tip,) = scene.contacts
    assert tip.active and tip.gap == 0.0 and tip.mu == 1.4
    assert scene.inputs.coordinates == ("x", "y", "theta")


def test_robot_relative_to_the_scene_then_shipped(write_scene, tmp_path):
    (tmp_path / "my_rod.urdf").write_text((ROBOTS / "rod.urdf").read_text())
    assert load_scene(write_scene(rod_scene(robot="my_rod.urdf"))).robot.urdf_path.name == "my_rod.urdf"
    assert load_scene(write_scene(rod_scene(robot="rod.urdf"))).robot.urdf_path == ROBOTS / "rod.urdf"


def test_normal_is_normalised_and_surface_point_sets_the_gap(write_scene):
    contact = {"name": "tip", "link": "rod", "point": [-0.5, 0.0], "normal": [0.0, 3.0], "mu": 0.5,
               "surface_point": [0.0, -0.25]}
    scene = load_scene(write_scene(rod_scene(contacts=[contact])))
    (tip,) = scene.contacts
    np.testing.assert_allclose(tip.point.normal_in_world, [0.0, 1.0])
    tip_y = 0.453 - 0.5 * np.sin(2.007)
    assert tip.gap == pytest.approx(tip_y + 0.25)
    assert not tip.active and scene.active_contacts == ()
    assert scene.state().jacobian_normal.shape == (0, 3)


def test_gap_tolerance_decides_activity(write_scene):
    contact = {"name": "tip", "link": "rod", "point": [-0.5, 0.0], "normal": [0.0, 1.0], "mu": 0.5,
               "surface_point": [0.0, 0.453 - 0.5 * np.sin(2.007) - 5e-7]}
    assert load_scene(write_scene(rod_scene(contacts=[contact]))).contacts[0].active
    assert not load_scene(write_scene(rod_scene(contacts=[contact])), gap_tolerance=1e-7).contacts[0].active


def bad(**overrides):
    return rod_scene(**overrides)


def contact(**overrides):
    c = {"name": "tip", "link": "rod", "point": [-0.5, 0.0], "normal": [0.0, 1.0], "mu": 1.4}
    c.update(overrides)
    return [c]


BAD_SCENES = {
    "unknown link": (bad(contacts=contact(link="nose")), "contacts[0].link", "unknown link 'nose'"),
    "unknown input coordinate": (
        bad(inputs={"coordinates": ["x", "phi"]}), "inputs.coordinates[1]", "unknown coordinate 'phi'"),
    "short q": (bad(state={"q": [0.0, 0.453]}), "state.q", "expected 3 numbers"),
    "long v": (bad(state={"q": [0.0, 0.453, 2.007], "v": [0.0] * 4}), "state.v", "expected 3 numbers"),
    "short limits": (bad(inputs={"coordinates": ["x", "y"], "lower": [0.0]}), "inputs.lower", "expected 2"),
    "nan in q": (bad(state={"q": [0.0, float("nan"), 2.007]}), "state.q[1]", "finite"),
    "inf mu": (bad(contacts=contact(mu=float("inf"))), "contacts[0].mu", "finite"),
    "negative mu": (bad(contacts=contact(mu=-0.1)), "contacts[0].mu", ">= 0"),
    "zero normal": (bad(contacts=contact(normal=[0.0, 0.0])), "contacts[0].normal", "non-zero"),
    "lower above upper": (
        bad(inputs={"coordinates": ["x"], "lower": [1.0], "upper": [-1.0]}), "inputs.lower[0]", "exceeds"),
    "penetration": (bad(contacts=contact(surface_point=[0.0, 0.1])), "contacts[0]", "penetrates"),
    "missing robot": ({"name": "x", "state": {"q": [0.0]}}, "robot", "missing"),
    "unknown robot": (bad(robot="nothere.urdf"), "robot", "no URDF"),
    "bad base": (bad(base="floating"), "base", "'planar' or 'fixed'"),
    "negative gravity": (bad(gravity=-9.81), "gravity", ">= 0"),
    "unknown field": (bad(colour="red"), "colour", "unknown field"),
    "duplicate contact": (bad(contacts=contact() + contact()), "contacts[1].name", "duplicate"),
    "string number": (bad(gravity="9.81"), "gravity", "expected a number"),
}


@pytest.mark.parametrize("case", sorted(BAD_SCENES))
def test_bad_scene_names_file_and_field(case, write_scene):
    scene_dict, field, reason = BAD_SCENES[case]
    path = write_scene(scene_dict)
    with pytest.raises(SceneError, match=re.escape(reason)) as info:
        load_scene(path)
    assert info.value.field == field
    assert reason in info.value.reason
    assert str(path) in str(info.value)


def test_missing_unreadable_and_malformed_files(write_scene, tmp_path):
    with pytest.raises(SceneError, match="no such file"):
        load_scene(tmp_path / "missing.toml")
    (tmp_path / "dir.toml").mkdir()
    with pytest.raises(SceneError, match="cannot read"):
        load_scene(tmp_path / "dir.toml")
    with pytest.raises(SceneError, match="malformed TOML"):
        load_scene(write_scene('name = "x"\nrobot = \n'))
    (tmp_path / "broken.urdf").write_text("<robot name='b'><link name='a'>")
    with pytest.raises(SceneError, match="cannot read URDF") as info:
        load_scene(write_scene(bad(robot="broken.urdf")))
    assert info.value.field == "robot"


def test_input_assignments(write_scene):
    scene = load_scene(write_scene(rod_scene()))
    np.testing.assert_array_equal(parse_input_assignments(scene, {"theta": 2.0}), [0.0, 0.0, 2.0])
    with pytest.raises(CoordinateNotFound, match="'phi'"):
        parse_input_assignments(scene, {"phi": 1.0})
    with pytest.raises(InputError, match="outside its limits"):
        parse_input_assignments(scene, {"x": 51.0})
    with pytest.raises(InputError, match="finite"):
        parse_input_assignments(scene, {"x": float("nan")})


def test_fixed_base_scene(write_scene):
    scene = load_scene(write_scene({
        "robot": "snake_planar.urdf", "base": "fixed",
        "state": {"q": [0.1] * 8},
        "contacts": [{"name": "head", "link": "link8", "point": [0.2, 0.0], "normal": [0.0, 1.0], "mu": 0.5}],
        "inputs": {"coordinates": ["j1", "j8"]},
    }))
    assert scene.coordinate_names[0] == "j1" and len(scene.q) == 8
    assert np.all(np.isinf(scene.inputs.upper))
    np.testing.assert_array_equal(scene.inputs.selection_transpose(8)[[0, 7], [0, 1]], 1.0)


def rhex_scene(**overrides):
    scene = {
        "robot": "rhex_planar.urdf",
        "state": {"q": [0.0, 0.3, 0.0, 0.1, 0.2, 0.3]},
        "locked_joints": ["hip_front"],
        "contacts": [{"name": "toe", "link": "leg_rear", "point": [0.0, -0.17], "normal": [0.0, 1.0],
                      "mu": 0.5}],
        "inputs": {"coordinates": ["hip_rear"]},
    }
    scene.update(overrides)
    return scene


def test_locked_joints_add_no_coordinate_and_keep_the_kinematics(write_scene):
    locked = load_scene(write_scene(rhex_scene()))
    free = load_scene(write_scene(rhex_scene(locked_joints=[])))
    assert locked.coordinate_names == ("x", "y", "theta", "hip_middle", "hip_rear")
    np.testing.assert_array_equal(locked.q, [0.0, 0.3, 0.0, 0.2, 0.3])
    a, b = locked.state(), free.state()
    np.testing.assert_allclose(a.contact_points, b.contact_points, atol=1e-14)
    keep = [0, 1, 2, 4, 5]
    np.testing.assert_allclose(a.jacobian_normal, b.jacobian_normal[:, keep], atol=1e-14)


@pytest.mark.parametrize("overrides, field, reason", [
    ({"locked_joints": ["hip_side"]}, "locked_joints[0]", "unknown joint"),
    ({"locked_joints": "hip_front"}, "locked_joints", "expected a list"),
    ({"inputs": {"coordinates": ["hip_front"]}}, "inputs.coordinates[0]", "locked"),
    ({"state": {"q": [0.0, 0.3, 0.0, 0.1, 0.2, 0.3], "v": [0.0, 0.0, 0.0, 1.0, 0.0, 0.0]}}, "state.v",
     "zero velocity"),
])
def test_bad_locked_joints(write_scene, overrides, field, reason):
    with pytest.raises(SceneError, match=re.escape(reason)) as info:
        load_scene(write_scene(rhex_scene(**overrides)))
    assert info.value.field == field and reason in info.value.reason


def test_scene_at_another_state_recomputes_activity():
    scene = load_scene("rhex_flip")
    assert [c.active for c in scene.contacts] == [True, False, False, True, True]
    lifted = scene.at(scene.q + np.array([0.0, 0.01, 0.0, 0.0, 0.0]))
    assert [c.active for c in lifted.contacts] == [False] * 5
    np.testing.assert_allclose([c.gap for c in lifted.contacts],
                               [c.gap + 0.01 for c in scene.contacts], atol=1e-12)
    with pytest.raises(InputError, match="entries"):
        scene.at(np.zeros(3))


def test_model_task_and_disturbances_are_typed_when_the_scene_is_loaded(write_scene):
    """[model], [task] and [[disturbances]] are records on the scene, checked at load: a planner or
    a simulator reads them, never the raw TOML."""
    import tomllib

    from frcontrol.errors import SceneError
    from frcontrol.scene_tables import DisturbanceTable, ModelOptions, TaskTable

    raw = tomllib.loads((shipped_robots_dir() / "scenes" / "snake_climb.toml").read_text())
    raw["robot"] = str(shipped_robots_dir() / raw["robot"])
    raw["task"] = {"head_link": "link8", "head_point": [0.2, 0.0]}  # the climb's dedicated keys
    climb = load_scene(write_scene(raw))
    assert isinstance(climb.task, TaskTable) and climb.task.head_link == "link8"
    assert climb.task.head_point is not None and climb.task.head_point.shape == (2,)
    assert all(isinstance(d, DisturbanceTable) and d.corners.shape[1] == 2 for d in climb.disturbances)
    assert [d.name for d in climb.disturbances] == [t["name"] for t in climb.raw["disturbances"]]
    flip = load_scene("rhex_flip")  # its task is given as phases: no dedicated keys
    assert flip.task == TaskTable() and flip.model.armature_given and flip.model.armature == 2e-3
    assert flip.disturbances == () and isinstance(flip.model, ModelOptions)
    text = resolve_scene_path("rhex_flip").read_text()
    urdf = shipped_robots_dir() / "rhex_planar.urdf"
    text = text.replace('robot = "rhex_planar.urdf"', f'robot = "{urdf}"')
    dedicated = text.replace(text[text.index("[task]"): text.index("[inputs]")],
                             '[task]\nbody_contacts = ["front_corner", "rear_corner"]\npitch = "theta"\n\n')
    keys = load_scene(write_scene(dedicated))
    assert keys.task.body_contacts == ("front_corner", "rear_corner") and keys.task.pitch == "theta"
    plain = load_scene("rod_on_table")
    assert plain.task == TaskTable() and plain.model.contact == "rigid" and not plain.model.armature_given
    with pytest.raises(SceneError, match=re.escape("disturbances[0].lower[0]")) as bad_box:
        load_scene(write_scene(rod_scene(disturbances=[
            {"name": "push", "link": "rod", "point": [0.0, 0.0], "lower": [1.0, 0.0], "upper": [0.0, 1.0]}])))
    assert bad_box.value.field == "disturbances[0].lower[0]"
    with pytest.raises(SceneError, match=re.escape("model.stiffness")) as bad_model:
        load_scene(write_scene(rod_scene(model={"stiffness": -1.0})))
    assert bad_model.value.field == "model.stiffness"


def _scene_arrays(scene) -> dict[str, np.ndarray]:
    """A loaded scene's numbers: state, contacts, inputs, and its state's arrays at a seeded (q, v)."""
    robot = scene.robot
    rng = np.random.default_rng(11)
    state = scene.state(rng.uniform(-1.0, 1.0, robot.nv), rng.normal(size=robot.nv))
    arrays = {f"state.{key}": np.asarray(value) for key, value in vars(state).items()}
    arrays.update(q=scene.q, v=scene.v, gaps=np.array([c.gap for c in scene.contacts]),
                  active=np.array([c.active for c in scene.contacts]),
                  surfaces=np.array([c.point.surface_point_in_world for c in scene.contacts]).reshape(-1, 2),
                  lower=scene.inputs.lower, upper=scene.inputs.upper, armature=np.array(robot.model.armature),
                  damping=robot.drive_damping, mass=np.array(robot.total_mass))
    return arrays


@pytest.mark.parametrize("name", shipped_scene_names())
def test_a_scene_loads_the_same_from_the_caches(name):
    """The second load (parsed TOML and Pinocchio model reused) equals the first, from cold caches,
    bit for bit; and the two loads share no mutable part."""
    _skeleton.cache_clear()
    _parsed_toml.cache_clear()
    cold = load_scene(name)
    warm = load_scene(name)
    assert _skeleton.cache_info().hits >= 1 and _parsed_toml.cache_info().hits == 1
    assert cold.coordinate_names == warm.coordinate_names and cold.robot.link_names == warm.robot.link_names
    assert cold.raw == warm.raw and cold.raw is not warm.raw
    first, second = _scene_arrays(cold), _scene_arrays(warm)
    for key, value in first.items():
        np.testing.assert_array_equal(value, second[key], err_msg=f"{name}: {key}")
    assert cold.robot.model is not warm.robot.model and cold.robot.data is not warm.robot.data


def test_a_loaded_scene_changed_in_place_leaves_the_next_load_alone():
    scene = load_scene("rhex_flip")
    scene.raw["contacts"][0]["mu"] = 123.0  # the raw document is the caller's
    armature = scene.robot.model.armature.copy()
    armature[3] = 0.5
    scene.robot.model.armature = armature  # of its own Pinocchio model
    again = load_scene("rhex_flip")
    assert again.raw["contacts"][0]["mu"] != 123.0
    np.testing.assert_array_equal(again.robot.model.armature, 0.0)
    np.testing.assert_array_equal(again.robot.drive_damping, 0.0)
    assert again.state().mass_matrix[3, 3] == scene.state().mass_matrix[3, 3] - 0.5


def test_files_rewritten_with_other_content_are_read_again(write_scene, tmp_path):
    """The caches key on the files' content: an edit of the same size, at once, is seen."""
    urdf = tmp_path / "my_rod.urdf"
    urdf.write_text((ROBOTS / "rod.urdf").read_text())
    path = write_scene(rod_scene(robot="my_rod.urdf"))
    before = load_scene(path)
    urdf.write_text(urdf.read_text().replace('<mass value="1.0"/>', '<mass value="2.0"/>'))
    text = path.read_text()
    assert "mu = 1.4" in text
    path.write_text(text.replace("mu = 1.4", "mu = 0.7"))
    after = load_scene(path)
    assert (before.robot.total_mass, after.robot.total_mass) == (1.0, 2.0)
    assert (before.contacts[0].mu, after.contacts[0].mu) == (1.4, 0.7)
    assert after.state().mass_matrix[0, 0] == pytest.approx(2.0 * before.state().mass_matrix[0, 0], rel=1e-15)


PACKAGE_DIR = str(Path(frcontrol.__file__).parent)


def _modules_entered(call) -> list[tuple[str, str]]:
    """(module file, function) each time ``call()`` enters code written in a frcontrol module's file.

    Entering: a call from a frame of another module's file (or from outside frcontrol). Returns
    to a caller are not entries; code generated at run time (a dataclass's ``__init__``, whose
    file is ``<string>``) belongs to no module.
    """
    events: list[tuple[str, str, str]] = []

    def profile(frame, event, _arg):
        filename = frame.f_code.co_filename
        if event in ("call", "return") and filename.startswith(PACKAGE_DIR):
            events.append((event, filename[len(PACKAGE_DIR) + 1:], frame.f_code.co_name))

    sys.setprofile(profile)
    try:
        call()
    finally:
        sys.setprofile(None)
    stack: list[str] = []
    entered = []
    for event, module, function in events:
        if event == "call":
            if not stack or stack[-1] != module:
                entered.append((module, function))
            stack.append(module)
        elif stack:
            stack.pop()
    return entered


@pytest.mark.parametrize("name", shipped_scene_names())
def test_loading_a_scene_enters_each_module_once(name):
    # schema -> names from the URDF -> records -> the robot built once -> the scene: each module
    # is entered once and left for good (a load after the first: the URDF's parse and the
    # Pinocchio model are cached per process, as for every load of a sweep or of frc serve)
    load_scene(name)
    entered = _modules_entered(lambda: load_scene(name))
    modules = [module for module, _ in entered]
    assert modules[0] == "scene.py" and len(modules) == len(set(modules)), entered
    assert {"scene_schema.py", "urdf.py", "model.py", "scene_tables.py"} <= set(modules)
    assert [f for m, f in entered if m == "model.py"] == ["__init__"]  # PlanarRobot, once


def test_every_input_vector_is_checked_with_the_one_slack():
    # by name, as a vector, in the engine and in statics: INPUT_LIMIT_SLACK past a limit is taken
    # as given, twice that is refused, with the same message everywhere
    from frcontrol.engine import solutions_at
    from frcontrol.scene import INPUT_LIMIT_SLACK
    from frcontrol.statics import static_body_from_scene

    scene = load_scene("box_on_ground")
    upper = float(scene.inputs.upper[0])
    calls = [lambda x: parse_input_assignments(scene, {"x": x}),  # by name
             lambda x: solutions_at(scene, {"x": x}),  # the engine
             lambda x: static_body_from_scene(scene, [x, 0.0, 0.0])]  # statics, a vector
    for call in calls:
        call(upper + 0.5 * INPUT_LIMIT_SLACK)
        with pytest.raises(InputError, match=r"input 'x' = 20 is outside its limits \[-20, 20\]"):
            call(upper + 2 * INPUT_LIMIT_SLACK)
