"""Strict scenes: the published JSON Schema, every shipped scene valid, broken scenes named exactly.

Each broken scene below is a shipped scene with one mistake a user makes (a typo, a wrong type, a
value out of range, a name that refers to nothing). Loading it must raise a SceneError naming the
exact field and, for a typo, the nearest valid key; ``frc validate`` and every command must exit 1
with one line on stderr.
"""

from __future__ import annotations

import copy
import json
import re
import subprocess
import sys
import tomllib

import jsonschema
import pytest
from conftest import ROBOTS, one_error_line, toml_text
from frcontrol.cli.app import app
from typer.testing import CliRunner

from frcontrol.errors import SceneError
from frcontrol.scene import load_scene, scene_problems, shipped_scene_names
from frcontrol.scene_schema import SCENE_SCHEMA, _schema_errors, schema_problems

SHIPPED = shipped_scene_names()
runner = CliRunner()


def shipped(name: str) -> dict:
    return tomllib.loads((ROBOTS / "scenes" / f"{name}.toml").read_text())


def test_the_published_schema_is_a_valid_json_schema_and_ships_verbatim():
    jsonschema.Draft202012Validator.check_schema(SCENE_SCHEMA)
    assert json.loads((ROBOTS / "scene.schema.json").read_text()) == SCENE_SCHEMA
    result = runner.invoke(app, ["schema"])
    assert result.exit_code == 0 and json.loads(result.stdout) == SCENE_SCHEMA


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_scene_is_valid(name):
    doc = shipped(name)
    jsonschema.Draft202012Validator(SCENE_SCHEMA).validate(doc)
    assert schema_problems(doc) == []
    assert scene_problems(name) == []


def edit(name: str | dict, path: str, value=None, *, rename: str | None = None,
         delete: bool = False) -> dict:
    """A shipped scene (or a document) with one change at a dotted path (``contacts[0].mu``)."""
    doc = shipped(name) if isinstance(name, str) else name
    keys = [int(k) if k.isdigit() else k for k in re.findall(r"[^.\[\]]+", path)]
    parent = doc
    for key in keys[:-1]:
        parent = parent.setdefault(key, {}) if isinstance(key, str) else parent[key]
    last = keys[-1]
    if rename is not None:
        parent[rename] = parent.pop(last)
    elif delete:
        del parent[last]
    else:
        parent[last] = value
    return doc


def flip_keys(**task) -> dict:
    """rhex_flip with the flip's dedicated [task] keys (its own task is given as phases)."""
    keys = {"body_contacts": ["front_corner", "rear_corner"], "pitch": "theta", **task}
    return edit("rhex_flip", "task", keys)


# name -> (scene document, the field named, text the reason must hold, jsonschema also rejects it)
BROKEN = {
    "typo in [inputs]": (edit("rod_on_table", "inputs.upper", rename="uper"), "inputs.uper",
                         "did you mean 'upper'?", True),
    "typo in [[contacts]] mu": (edit("rod_on_table", "contacts[0].mu", rename="muu"), "contacts[0].muu",
                                "in [[contacts]] 'tip'; did you mean 'mu'?", True),
    "typo in [[contacts]] surface_point": (
        edit("box_on_ground", "contacts[1].surface_point", rename="surface_piont"),
        "contacts[1].surface_piont", "in [[contacts]] 'right'; did you mean 'surface_point'?", True),
    "typo in [state]": (edit("rod_on_table", "state.v", rename="vel"), "state.vel",
                        "did you mean 'v'?", True),
    "typo in [task]": (edit(flip_keys(), "task.pitch", rename="pitchh"), "task.pitchh",
                       "did you mean 'pitch'?", True),
    "typo in [[task.phases]]": (edit("rhex_flip", "task.phases[0].margin", rename="margn"),
                                "task.phases[0].margn", "did you mean 'margin'?", True),
    "typo in [model]": (edit("rod_on_table", "model.stifness", 1e5), "model.stifness",
                        "did you mean 'stiffness'?", True),
    "typo in [model.contacts.NAME]": (edit("rod_on_table", "model.contacts.tip.dampnig", 3.0),
                                      "model.contacts.tip.dampnig", "did you mean 'damping'?", True),
    "typo in [[disturbances]]": (edit("snake_climb", "disturbances[1].vertices", rename="vertice"),
                                 "disturbances[1].vertice", "did you mean 'vertices'?", True),
    "typo at the top level": (edit("rod_on_table", "gravity", rename="gravty"), "gravty",
                              "did you mean 'gravity'?", True),
    "string for a number": (edit("rod_on_table", "contacts[0].mu", "0.5"), "contacts[0].mu",
                            "expected a number", True),
    "negative mu": (edit("rod_on_table", "contacts[0].mu", -0.5), "contacts[0].mu", ">= 0", True),
    "zero stiffness": (edit("rod_on_table", "model.stiffness", 0.0), "model.stiffness", "> 0", True),
    "negative armature": (edit("rhex_flip", "model.armature", -1e-4), "model.armature", ">= 0", True),
    "unknown contact model": (edit("rod_on_table", "model.contact", "soft"), "model.contact",
                              "'rigid' or 'compliant'", True),
    "nan in state": (edit("rod_on_table", "state.q[1]", float("nan")), "state.q[1]", "finite", False),
    "short point": (edit("rod_on_table", "contacts[0].point", [0.5]), "contacts[0].point",
                    "at least 2", True),
    "task is not a table": (edit("rhex_flip", "task", "flip"), "task", "expected a table", True),
    "override of an unknown contact": (edit("rod_on_table", "model.contacts.tipp.stiffness", 1e5),
                                       "model.contacts.tipp", "did you mean 'tip'?", False),
    "unknown body contact": (edit(flip_keys(), "task.body_contacts[0]", "front_croner"),
                             "task.body_contacts[0]", "did you mean 'front_corner'?", False),
    "unknown pitch coordinate": (edit(flip_keys(), "task.pitch", "thetaa"), "task.pitch",
                                 "did you mean 'theta'?", False),
    "unknown contact in a phase": (edit("rhex_flip", "task.phases[0].modes", {"front_croner": "FLR"}),
                                   "task.phases[0].modes.front_croner", "did you mean 'front_corner'?",
                                   False),
    "unknown coordinate in a phase": (edit("rhex_flip", "task.phases[0].maximize.coordinate", "thetaa"),
                                      "task.phases[0].maximize.coordinate", "did you mean 'theta'?", False),
    "unknown head link": (edit("snake_climb", "task.phases[0].require[0].link", "link9"),
                          "task.phases[0].require[0].link", "unknown link 'link9'", False),
    "unknown disturbance link": (edit("snake_climb", "disturbances[0].link", "lnk8"), "disturbances[0].link",
                                 "did you mean 'link8'?", False),
    "empty disturbance box": (edit("snake_climb", "disturbances[0].lower", [4.0, -3.0]),
                              "disturbances[0].lower[0]", "exceeds upper", False),
    "both box and polygon": (edit("snake_climb", "disturbances[0].vertices", [[0.0, 0.0]]),
                             "disturbances[0].vertices", "not both", False),
    "missing q": (edit("rod_on_table", "state.q", delete=True), "state.q", "missing", True),
}


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_a_broken_scene_names_the_exact_field(case, write_scene):
    doc, field, reason, schema_rejects = BROKEN[case]
    path = write_scene(toml_text(doc) if not isinstance(doc, str) else doc)
    with pytest.raises(SceneError, match=re.escape(reason)) as info:
        load_scene(path)
    assert info.value.field == field, info.value
    assert reason in info.value.reason, info.value
    assert str(path) in str(info.value)
    problems = scene_problems(path)
    assert problems and problems[0].field == field
    if schema_rejects:  # the published schema, read by a third-party validator, agrees
        assert not jsonschema.Draft202012Validator(SCENE_SCHEMA).is_valid(tomllib.loads(path.read_text()))


def test_every_problem_is_listed_not_only_the_first(write_scene):
    doc = edit("rod_on_table", "inputs.upper", rename="uper")
    doc["contacts"][0]["muu"] = doc["contacts"][0].pop("mu")
    fields = [p.field for p in scene_problems(write_scene(toml_text(doc)))]
    assert fields == ["contacts[0].muu", "contacts[0].mu", "inputs.uper"]


def test_frc_validate_exit_codes_and_lines(write_scene):
    good = runner.invoke(app, ["validate", "rod_on_table", "snake_climb"])
    assert good.exit_code == 0, good.stderr
    broken = write_scene(toml_text(BROKEN["typo in [inputs]"][0]))
    result = runner.invoke(app, ["validate", "rod_on_table", str(broken), "--json"])
    assert result.exit_code == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "inputs.uper" in lines[0] and "did you mean 'upper'?" in lines[0]
    doc = json.loads(result.stdout)
    assert doc["valid"] is False and [f["valid"] for f in doc["files"]] == [True, False]
    assert doc["files"][1]["problems"][0]["field"] == "inputs.uper"


def test_missing_scene_lists_the_shipped_ones_with_the_nearest(tmp_path):
    with pytest.raises(SceneError, match="did you mean 'rod_on_table'") as info:
        load_scene("rod_on_tabel")
    assert "did you mean 'rod_on_table'?" in info.value.reason
    assert all(name in info.value.reason for name in SHIPPED)
    with pytest.raises(SceneError, match="it is a directory, not a scene file") as info:
        load_scene(tmp_path)
    assert info.value.reason == "cannot read: it is a directory, not a scene file"
    (tmp_path / "latin1.toml").write_bytes(b'name = "caf\xe9"\n')
    with pytest.raises(SceneError, match="not UTF-8"):
        load_scene(tmp_path / "latin1.toml")


@pytest.mark.parametrize("args, field", [
    (["flip", "rod_on_table"], "task.body_contacts"),
    (["flip", "snake_climb"], "task.phases[0].maximize"),  # a task as phases that is not a flip
    (["climb", "rhex_flip"], "task.phases[0].require"),  # frc climb is frc plan on the scene's task
])
def test_planners_refuse_a_scene_without_their_task(args, field, monkeypatch):
    """One error line; the refusal comes from the planner's work, whose progress display a loaded
    machine may reach first (it is made due at once here, so its lines are always met)."""
    from frcontrol.cli import progress as progress_module

    monkeypatch.setattr(progress_module, "SHOW_AFTER", 0.0)
    monkeypatch.setattr(progress_module, "HEARTBEAT", 0.01)
    result = runner.invoke(app, args + ["--json"])
    assert result.exit_code == 1 and result.stdout == ""
    assert f": {field}: " in one_error_line(result.stderr)


def test_a_typo_on_the_command_line_is_one_line_and_exit_1(write_scene, tmp_path):
    """As a user meets it: the installed `frc`, a real process, a scene with a typo."""
    path = write_scene(toml_text(BROKEN["typo in [[contacts]] mu"][0]))
    out = subprocess.run([sys.executable, "-m", "frcontrol.cli", "analyze", str(path), "--json"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert out.returncode == 1 and out.stdout == ""
    assert out.stderr.count("\n") == 1 and "Traceback" not in out.stderr
    assert "contacts[0].muu" in out.stderr and "did you mean 'mu'?" in out.stderr


# ---------------------------------------------------------------------------------- overrides
def test_overrides_set_values_and_are_checked_like_the_file(write_scene):
    from frcontrol.scene_schema import parse_override

    sets = dict(parse_override(a) for a in ["contacts.tip.mu=0.5", "gravity=3.7", "state.q=[0,0.45,2.0]",
                                            "model.stiffness=1e6", "model.contact=compliant"])
    scene = load_scene("rod_on_table", overrides=sets)
    assert scene.contacts[0].mu == 0.5 and scene.robot.gravity == 3.7
    assert scene.q.tolist() == [0.0, 0.45, 2.0]
    assert scene.raw["model"] == {"stiffness": 1e6, "contact": "compliant"}
    # the same scene written with those values: the same model at the same state
    doc = shipped("rod_on_table")
    doc["contacts"][0]["mu"], doc["gravity"], doc["state"]["q"] = 0.5, 3.7, [0.0, 0.45, 2.0]
    doc["robot"] = str(ROBOTS / doc["robot"])
    written = load_scene(write_scene(toml_text(doc)))
    assert written.state().bias.tolist() == scene.state().bias.tolist()
    assert written.contacts[0].point.surface_point_in_world.tolist() == \
        scene.contacts[0].point.surface_point_in_world.tolist()
    assert load_scene("rod_on_table").contacts[0].mu == 1.4  # the file is untouched


@pytest.mark.parametrize("assignment, field, reason", [
    ("contacts.tipp.mu=1", "contacts.tipp.mu", "did you mean 'tip'?"),
    ("contacts.tip.muu=1", "contacts.tip.muu", "did you mean 'mu'?"),
    ("gravty=1", "gravty", "did you mean 'gravity'?"),
    ("state.q[5]=1", "state.q[5]", "out of range"),
    ("contacts.tip.mu=-1", "contacts.tip.mu", ">= 0"),  # named as it was set
    ("contacts[0].mu=-1", "contacts[0].mu", ">= 0"),
    ("model.contacts.tipp.stiffness=3", "model.contacts.tipp", "did you mean 'tip'?"),
    ("gravity.x=1", "gravity.x", "not a table"),
    ("state.q=abc", "state.q", "expected a list"),
])
def test_a_bad_override_names_its_path(assignment, field, reason):
    from frcontrol.scene_schema import parse_override

    with pytest.raises(SceneError, match=re.escape(reason)) as info:
        load_scene("rod_on_table", overrides=dict([parse_override(assignment)]))
    assert info.value.field == field and reason in info.value.reason


def test_override_grammar():
    from frcontrol.scene_schema import parse_override

    assert parse_override("a.b=[1, 2.5]") == ("a.b", [1, 2.5])
    assert parse_override(" model.contact = compliant ") == ("model.contact", "compliant")
    assert parse_override('name="x=y"') == ("name", "x=y")
    with pytest.raises(ValueError, match="expected PATH=VALUE"):
        parse_override("gravity")


@pytest.mark.parametrize("command", [["show"], ["analyze"], ["statics"], ["view", "--html", "x.html"]])
def test_every_scene_command_takes_set_and_refuses_a_bad_path(command):
    args = [command[0], "rod_on_table", *command[1:], "--set", "contacts.tip.muu=0.5"]
    result = runner.invoke(app, args)
    assert result.exit_code == 1 and result.stdout == ""
    assert "contacts.tip.muu" in result.stderr and "did you mean 'mu'?" in result.stderr


def test_set_changes_the_answer_as_editing_the_file_would(write_scene):
    """At mu = 0.1 the rod's tip slides (R) under a push where at mu = 1.4 it holds (F)."""
    def modes(extra):
        result = runner.invoke(app, ["analyze", "rod_on_table", "--input", "x=1", "--json", *extra])
        assert result.exit_code == 0, result.stderr
        return [s["mode"] for s in json.loads(result.stdout)["solutions"]]

    doc = shipped("rod_on_table")
    doc["contacts"][0]["mu"] = 0.1
    doc["robot"] = str(ROBOTS / doc["robot"])
    edited = write_scene(toml_text(doc))
    edited_modes = runner.invoke(app, ["analyze", str(edited), "--input", "x=1", "--json"])
    assert modes(["--set", "contacts.tip.mu=0.1"]) == [
        s["mode"] for s in json.loads(edited_modes.stdout)["solutions"]]
    assert modes(["--set", "contacts.tip.mu=0.1"]) != modes([])


def test_version_and_short_help():
    from importlib.metadata import version

    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and result.stdout.strip() == f"frcontrol {version('frcontrol')}"
    assert runner.invoke(app, ["-h"]).stdout == runner.invoke(app, ["--help"]).stdout
    assert runner.invoke(app, ["analyze", "-h"]).exit_code == 0


def _leaf_paths(node, path=()):
    """Every path to a value of ``node`` that is not a table or a list, and to every table."""
    if isinstance(node, dict):
        yield path
        for key, value in node.items():
            yield from _leaf_paths(value, (*path, key))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from _leaf_paths(value, (*path, i))
    else:
        yield path


def _changed(doc: dict, path: tuple, value) -> dict:
    out = copy.deepcopy(doc)
    parent = out
    for key in path[:-1]:
        parent = parent[key]
    parent[path[-1]] = value
    return out


WRONG_VALUES = ("text", "", -1.0, 0, 2, True, 1e400, [], [0.0], {}, {"typo": 1.0})
"""Values put in place of each field of a shipped scene: wrong types, lengths, ranges, an unknown key."""


@pytest.mark.parametrize("name", ["rod_on_table", "rhex_flip_drives", "snake_climb", "box_slide"])
def test_the_check_and_jsonschema_agree_on_every_field(name):
    # the check compiled from the published schema accepts exactly what jsonschema accepts, but
    # for non-finite numbers (JSON Schema cannot say "finite": the check refuses them)
    validator = jsonschema.Draft202012Validator(SCENE_SCHEMA)
    doc = shipped(name)
    checked = 0
    for path in _leaf_paths(doc):
        for value in WRONG_VALUES:
            if not path:
                continue
            changed = _changed(doc, path, value)
            ours = _schema_errors(changed)
            if value == 1e400:  # refused; where jsonschema takes it as a number, as not finite
                assert ours and ("finite" in ours[0].reason or not validator.is_valid(changed)), (path, ours)
            else:
                assert (not ours) == validator.is_valid(changed), (path, value, ours)
            checked += 1
    assert checked > 100
