"""The frc command line: output shapes and one-line errors with exit code 1."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import one_error_line, rod_scene
from frcontrol.cli.app import app
from typer.testing import CliRunner

from frcontrol.scene import load_scene

runner = CliRunner()


def test_help_and_robots():
    result = runner.invoke(app, ["--help"])
    assert result.exit_code == 0 and "show" in result.stdout
    result = runner.invoke(app, ["robots"])
    assert result.exit_code == 0
    for name in ("rhex_planar.urdf", "snake_planar.urdf", "rod.urdf", "rhex_flip", "snake_climb"):
        assert name in result.stdout


def test_show_json_contract():
    result = runner.invoke(app, ["show", "rhex_flip", "--json"])
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    # hip_front is locked in this scene: no coordinate
    assert doc["coordinates"] == ["x", "y", "theta", "hip_middle", "hip_rear"]
    mass = np.array(doc["mass_matrix"])
    assert mass.shape == (5, 5) and len(doc["bias"]) == 5
    scene = load_scene("rhex_flip")
    state = scene.robot.state(scene.q, scene.v)  # every contact, the inactive front toe too
    np.testing.assert_allclose(mass, state.mass_matrix)
    assert list(doc["contacts"]) == [c.name for c in scene.contacts]
    assert [c["active"] for c in doc["contacts"].values()] == [True, False, False, True, True]
    for i, c in enumerate(doc["contacts"].values()):
        assert set(c) >= {"gap", "v_n", "v_t", "jacobian_n", "jacobian_t"}
        np.testing.assert_allclose(c["jacobian_n"], state.jacobian_normal[i])
        np.testing.assert_allclose(c["jacobian_t"], state.jacobian_tangent[i])


def test_show_table():
    result = runner.invoke(app, ["show", "rod_on_table"])
    assert result.exit_code == 0
    assert "tip" in result.stdout and "mass matrix" in result.stdout


@pytest.mark.parametrize("overrides", [
    {"contacts": [{"name": "tip", "link": "nose", "point": [0, 0], "normal": [0, 1], "mu": 1}]},
    {"state": {"q": [0.0, 1.0]}},
    {"gravity": float("nan")},
    {"contacts": [{"name": "tip", "link": "rod", "point": [-0.5, 0.0], "normal": [0, 1], "mu": -1.0}]},
])
def test_bad_scene_is_one_line_and_exit_1(overrides, write_scene):
    path = write_scene(rod_scene(**overrides))
    result = runner.invoke(app, ["show", str(path)])
    assert result.exit_code == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0]
    assert "Traceback" not in result.output


def test_missing_file_and_malformed_toml(write_scene, tmp_path):
    result = runner.invoke(app, ["show", str(tmp_path / "nothing.toml")])
    assert result.exit_code == 1 and "no such file" in result.stderr
    result = runner.invoke(app, ["show", str(write_scene("robot = [\n"))])
    assert result.exit_code == 1 and "malformed TOML" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_analyze_json_contract():
    result = runner.invoke(app, ["analyze", "rod_on_table", "--json", "--input", "y=-2.0"])
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    assert doc["coordinates"] == ["x", "y", "theta"] and doc["contacts"] == ["tip"]
    modes = {m["mode"]: m for m in doc["modes"]}
    assert set(modes) == set("SLRF")
    for m in modes.values():
        assert set(m) >= {"mode", "feasible", "full_dimensional", "ambiguity_dim", "ambiguous_outputs",
                          "halfspaces"}
        assert m["ambiguous_outputs"] in ("none", "forces", "accelerations")
    (sol,) = doc["solutions"]
    assert sol["mode"] == "F" and len(sol["dv"]) == 3
    assert set(sol["contacts"]["tip"]) >= {"lambda_n", "lambda_t", "a_n", "a_t"}
    assert sol["ambiguity_dim"] == 0 and sol["stable"] in (True, False, None)
    assert set(doc["timings"]) >= {"total", "response", "domain"}
    # without inputs there are no solutions
    doc = json.loads(runner.invoke(app, ["analyze", "rod_on_table", "--json"]).stdout)
    assert "solutions" not in doc


def test_analyze_table_and_bad_inputs():
    result = runner.invoke(app, ["analyze", "table_on_ground", "--input", "x=5"])
    assert result.exit_code == 0 and "FF" in result.stdout
    for args, code, message in ((["--input", "phi=1"], 1, "unknown coordinate"),
                                (["--input", "x"], 2, "NAME=VALUE"),
                                (["--input", "x=abc"], 2, "not a number"),
                                (["--input", "x=1e9"], 1, "outside")):
        result = runner.invoke(app, ["analyze", "table_on_ground", *args])
        assert result.exit_code == code, args
        assert message in one_error_line(result.stderr)
