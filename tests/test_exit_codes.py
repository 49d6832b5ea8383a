"""One exit-code rule for every command (docs/commands.md, "Exit codes and errors"): 0 answered, 1 bad
input, 2 usage."""

from __future__ import annotations

import json

import pytest
from conftest import one_error_line
from frcontrol.cli.app import app
from typer.testing import CliRunner

runner = CliRunner()


@pytest.mark.parametrize("args", [
    ["analyze"],                                   # a missing argument
    ["analyze", "rod_on_table", "--bogus"],        # an unknown option
    ["flip", "--margin", "-1"],                    # an option out of its range
    ["simulate", "rod_on_table", "--model", "soft"],
    ["nonsense"],                                  # an unknown command
])
def test_usage_errors_exit_2(args):
    result = runner.invoke(app, args)
    assert result.exit_code == 2 and result.stdout == ""
    one_error_line(result.stderr)


@pytest.mark.parametrize("args, text", [
    (["analyze", "rod_on_tabel", "--json"], "did you mean 'rod_on_table'?"),
    (["analyze", "rod_on_table", "--input", "phi=1", "--json"], "unknown coordinate 'phi'"),
    (["analyze", "rod_on_table", "--input", "x=1e9", "--json"], "outside its limits"),
    (["flip", "rod_on_table", "--json"], "task.body_contacts: missing"),
    (["atlas", "rod_on_table", "--vary", "state.q.theta=0.3:2.8:3", "--what", "flip", "-w", "1"],
     "task.body_contacts: missing"),
])
def test_bad_input_exits_1_with_one_line_and_nothing_on_stdout(args, text):
    result = runner.invoke(app, args)
    assert result.exit_code == 1 and result.stdout == ""
    assert text in one_error_line(result.stderr)


@pytest.mark.parametrize("args, text", [
    (["flip", "--plot", "/nonexistent-folder/flip.png", "--json"], "'/nonexistent-folder' does not exist"),
    (["climb", "--html", "/nonexistent-folder/climb.html", "--json"], "does not exist"),
    (["statics", "rod_on_table", "--plot", "/nonexistent-folder/s.png", "--json"], "does not exist"),
    (["simulate", "rod_on_table", "--plot", "run.txt", "--json"], "must name an image format"),
    (["statics", "rod_on_table", "--plot", "s.unknown", "--json"], "must name an image format"),
    (["simulate", "rod_on_table", "--html", "/proc/x.html"], "'/proc/x.html': cannot write"),
    (["standup", "--out", "/proc/x.npz"], "'/proc/x.npz': cannot write"),
])
def test_an_output_path_that_cannot_be_written_is_a_usage_error(args, text):
    """Checked while the command line is read (a probe file created and removed): exit 2 at once."""
    result = runner.invoke(app, args)
    assert result.exit_code == 2 and result.stdout == ""
    line = one_error_line(result.stderr)
    assert text in line and any(f"'{option}'" in line for option in ("--plot", "--html", "--out"))


def test_an_output_path_that_is_a_folder_is_refused(tmp_path):
    result = runner.invoke(app, ["view", "rod_on_table", "--html", str(tmp_path)])
    assert result.exit_code == 2 and "is a directory" in one_error_line(result.stderr)
    assert list(tmp_path.iterdir()) == []


def test_the_probe_leaves_an_existing_file_as_it_was_and_no_file_behind(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    kept = tmp_path / "kept.png"
    kept.write_bytes(b"old")
    result = runner.invoke(app, ["simulate", "no_such_scene", "--plot", "kept.png", "--html", "new.html"])
    assert result.exit_code == 1 and "no_such_scene" in one_error_line(result.stderr)  # the scene: bad input
    assert kept.read_bytes() == b"old" and sorted(p.name for p in tmp_path.iterdir()) == ["kept.png"]


def test_a_negative_answer_is_an_answer_exit_0():
    """No unambiguous flip 100 N m away from every other mode: exit 0, and the JSON says why."""
    result = runner.invoke(app, ["flip", "--margin", "100", "--json"])
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    assert doc["found"] is False and doc["simulation"]["flipped"] is False
    assert "unambiguous inputs 100 away" in doc["reason"]
    assert "short of vertical" in doc["simulation"]["reason"]
    assert doc["outcome"]["achieved"] is False and doc["outcome"]["infeasible"]["margin"] == 100
