"""Trajectories export (--out FILE.npz|.csv) and carry their contact modes."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from frcontrol.cli.app import app
from typer.testing import CliRunner

from frcontrol.errors import InputError
from frcontrol.scene import load_scene
from frcontrol.simulation import sample_modes, save_trajectory, simulate_rigid

runner = CliRunner()


def sliding_box():
    """The box on its 20 deg slope with mu = 0.1 < tan 20 deg: it slides down, along -t."""
    return load_scene("box_on_slope", overrides={"contacts.lower.mu": 0.1, "contacts.upper.mu": 0.1})


def test_modes_follow_the_physics():
    scene = sliding_box()
    run = simulate_rigid(scene, None, 0.1, 0.001)
    modes = sample_modes(scene, run)
    assert len(modes) == len(run.times) and all(len(m) == 2 for m in modes)
    # t = (n_y, -n_x) points up the slope, so sliding down is L at both corners after the start
    assert set(modes[10:]) == {"LL"}
    held = load_scene("box_on_slope")  # mu = 0.5 > tan 20 deg: it holds
    assert set(sample_modes(held, simulate_rigid(held, None, 0.1, 0.001))[10:]) == {"FF"}


def test_npz_holds_the_trajectory(tmp_path):
    scene = sliding_box()
    run = simulate_rigid(scene, None, 0.05, 0.001)
    data = np.load(save_trajectory(scene, run, tmp_path / "run.npz"))
    np.testing.assert_array_equal(data["times"], run.times)
    np.testing.assert_array_equal(data["q"], run.q)
    np.testing.assert_array_equal(data["v"], run.v)
    np.testing.assert_array_equal(data["inputs"], run.inputs)
    np.testing.assert_array_equal(data["forces"], run.contact_forces)
    assert ["".join(row) for row in data["modes"]] == list(sample_modes(scene, run))
    assert list(data["contacts"]) == ["lower", "upper"] and list(data["coordinates"]) == ["x", "y", "theta"]


def test_csv_holds_the_same_numbers(tmp_path):
    scene = sliding_box()
    run = simulate_rigid(scene, None, 0.02, 0.001)
    with save_trajectory(scene, run, tmp_path / "run.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == len(run.times)
    j = 7
    assert float(rows[j]["time"]) == run.times[j] and float(rows[j]["q_theta"]) == run.q[j, 2]
    assert float(rows[j]["v_x"]) == run.v[j, 0] and float(rows[j]["u_y"]) == run.inputs[j, 1]
    assert float(rows[j]["upper_lambda_n"]) == run.contact_forces[j, 1, 0]
    assert rows[j]["lower_mode"] == sample_modes(scene, run)[j][0]
    assert all(math.isfinite(float(v)) for k, v in rows[j].items() if not k.endswith("_mode"))


def test_a_bad_suffix_is_refused(tmp_path):
    scene = load_scene("rod_on_table")
    with pytest.raises(InputError, match=r"\.npz, \.csv"):
        save_trajectory(scene, simulate_rigid(scene, None, 0.01, 0.001), tmp_path / "run.txt")
    for command in (["simulate", "rod_on_table"], ["flip"], ["climb"]):
        result = runner.invoke(app, [*command, "--out", str(tmp_path / "run.txt")])
        assert result.exit_code == 2 and "the suffix must be one of .npz, .csv" in result.stderr


def test_the_cli_exports_and_its_json_carries_the_modes(tmp_path):
    out = tmp_path / "slide.npz"
    result = runner.invoke(app, ["simulate", "box_on_slope", "--set", "contacts.lower.mu=0.1",
                                 "--set", "contacts.upper.mu=0.1", "--duration", "0.05", "--out", str(out),
                                 "--json"])
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    data = np.load(out)
    assert doc["samples"]["modes"] == ["".join(row) for row in data["modes"]]
    np.testing.assert_allclose(doc["samples"]["v"], data["v"], rtol=0, atol=0)
    for event in doc["summary"]["events"]:
        assert {"time", "contact", "kind", "from", "to"} <= set(event)
        assert event["from"] in "SLRF" and event["to"] in "SLRF"
    assert f"wrote {out}" in result.stderr


def test_every_trajectory_converts_to_json():
    """A motion no simulator produced (no energy reported) converts too; a simulator's has every
    field; the flip's closed loop runs on the rigid stepper, so it reports its energy as well."""
    scene = load_scene("rhex_flip")
    from frcontrol.planning.flip_loop import simulate_flip
    from frcontrol.viz.meshcat_view import trajectory_from_scene

    still = trajectory_from_scene(scene).to_dict(scene)
    json.dumps(still)
    assert still["summary"]["energy"] is None and len(still["samples"]["modes"]) == len(
        still["samples"]["times"])
    planned = simulate_flip(scene, max_time=0.05).trajectory.to_dict(scene)
    json.dumps(planned)
    assert planned["summary"]["energy"]["initial"] > 0 and planned["summary"]["model"] == "rigid"
    assert len(planned["samples"]["modes"]) == len(planned["samples"]["times"])
    simulated = simulate_rigid(scene, None, 0.01, 0.001).to_dict()
    assert simulated["summary"]["energy"]["initial"] > 0 and "modes" not in simulated["samples"]
