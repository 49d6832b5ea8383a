"""The CLI's conventions hold for every command: --json, --quiet, -h; --set where a scene is read."""

from __future__ import annotations

import pytest
import typer
from frcontrol.cli.app import app
from typer.testing import CliRunner

runner = CliRunner()
COMMANDS = typer.main.get_command(app).commands
READS_A_SCENE = {"show", "analyze", "statics", "simulate", "flip", "climb", "standup", "plan", "view",
                 "atlas"}


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_has_the_shared_options(name):
    options = {opt for param in COMMANDS[name].params for opt in param.opts}
    assert {"--json", "--quiet", "-q"} <= options, options
    assert ("--set" in options) == (name in READS_A_SCENE)
    result = runner.invoke(app, [name, "-h"])
    assert result.exit_code == 0 and "--quiet" in result.stdout


def test_every_command_is_registered():
    assert set(COMMANDS) == READS_A_SCENE | {"robots", "schema", "validate", "serve"}


def test_quiet_keeps_the_answer_and_drops_the_notes(tmp_path):
    page = tmp_path / "rod.html"
    loud = runner.invoke(app, ["view", "rod_on_table", "--html", str(page)])
    assert loud.exit_code == 0 and loud.stdout.strip() == f"wrote {page}"
    quiet = runner.invoke(app, ["view", "rod_on_table", "--html", str(page), "-q"])
    assert quiet.exit_code == 0 and quiet.stdout == "" and page.stat().st_size > 100_000
    answer = runner.invoke(app, ["analyze", "rod_on_table", "--input", "x=1", "-q"])
    assert answer.exit_code == 0 and "mode" in answer.stdout
    assert runner.invoke(app, ["validate", "rod_on_table", "-q"]).stdout == ""


TRAJECTORY_OUTPUTS = {"--plot", "--html", "--out"}
OUTPUTS = {"simulate": TRAJECTORY_OUTPUTS, "flip": TRAJECTORY_OUTPUTS, "climb": TRAJECTORY_OUTPUTS,
           "statics": {"--plot", "--html"}, "view": {"--plot", "--html"}}
"""Commands that produce a trajectory (all three outputs) or a figure and a page."""


@pytest.mark.parametrize("name", sorted(OUTPUTS))
def test_output_options_are_on_every_producing_command_and_worded_once(name):
    """--plot, --html and --out come from cli/options.py: the same metavar and shared wording."""
    params = {opt: param for param in COMMANDS[name].params for opt in param.opts}
    assert OUTPUTS[name] <= set(params), set(params)
    shared = {"--plot": "Write a figure:", "--html": "Write a self-contained HTML page (meshcat, works "
              "offline)", "--out": "Export the trajectory: FILE.npz"}
    for option in OUTPUTS[name]:
        assert params[option].metavar == "FILE"
        assert params[option].help.startswith(shared[option]), (name, option, params[option].help)
    if "--view" in params:
        assert "until Ctrl-C or SIGTERM" in params["--view"].help and "--port" in params


def test_a_short_option_means_the_same_everywhere():
    """-T is the simulated time, -i an input, -q quiet, -h help: wherever they exist."""
    meaning = {"-T": "imulated time", "-i": "NAME=VALUE", "-q": "Print only the answer"}
    seen = {}
    for name, command in COMMANDS.items():
        for param in command.params:
            for short in set(param.opts + param.secondary_opts) & set(meaning):
                assert meaning[short] in (param.help or ""), (name, short, param.help)
                seen.setdefault(short, set()).add(name)
    assert {"simulate", "flip", "climb", "standup"} <= seen["-T"]
    assert {"analyze", "statics", "simulate"} <= seen["-i"]


@pytest.mark.parametrize("args", [
    ["analyze", "rhex_flip", "--input", "hip_middle=-5"],
    ["show", "snake_climb"],
    ["statics", "rhex_flip"],
    ["simulate", "rhex_flip", "--duration", "0.02"],
    ["flip", "--max-time", "0.02"],
])
def test_tables_wrap_rather_than_truncate_at_80_columns(args, tmp_path):
    import os
    import subprocess
    import sys

    env = {**os.environ, "COLUMNS": "80"}
    out = subprocess.run([sys.executable, "-m", "frcontrol", *args], capture_output=True, text=True,
                         cwd=tmp_path, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "…" not in out.stdout
    assert max(len(line) for line in out.stdout.splitlines()) <= 80


def help_examples():
    """Every example command in every command's --help (served viewers left out: they wait)."""
    out = []
    for name in sorted(COMMANDS):
        text = runner.invoke(app, [name, "--help"]).stdout
        block = text.split("Examples:" if "Examples:" in text else "Example:")
        assert len(block) == 2, f"frc {name} --help has no example"
        for line in block[1].splitlines():
            line = line.strip()
            if not line.startswith("frc "):
                if line == "" or line.startswith("frc"):
                    continue
                break
            if "--view" not in line:
                out.append(line)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("example", help_examples())
def test_every_help_example_runs(example, tmp_path, monkeypatch):
    import shlex

    monkeypatch.chdir(tmp_path)
    result = runner.invoke(app, shlex.split(example)[1:])
    assert result.exit_code == 0, (example, result.stderr[-500:])


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_help_names_arguments_and_repeated_options_in_words(name):
    """The usage line names arguments in capitals (SCENE, FILE), and --input shows its grammar
    (NAME=VALUE), not a Python type such as <list[str]>."""
    result = runner.invoke(app, [name, "-h"])
    assert result.exit_code == 0
    usage = result.stdout.splitlines()[0]
    assert "scene" not in usage and "files" not in usage, usage
    if "--input" in result.stdout:
        assert "--input NAME=VALUE" in result.stdout


EVERY_COMMAND_OPTIONS = {"--help", "--set", "--quiet"}
"""Options of (nearly) every command, documented once below the command table of docs/commands.md."""


def command_table_rows() -> dict[str, str]:
    """The synopsis table of docs/commands.md: the command's name -> its row's first cell."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "commands.md").read_text(encoding="utf-8")
    table = text.split("## Synopsis", 1)[1].split("\n\n", 3)[2]
    rows = {}
    for line in table.splitlines():
        cells = line.replace("\\|", "/").split("|")  # an escaped bar is part of a cell
        synopsis = cells[1].strip().strip("`") if line.startswith("| `frc ") else ""
        if synopsis and synopsis != "frc --help":
            rows[synopsis.split()[1]] = synopsis
    return rows


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_the_command_table_lists_every_option_of_every_command(name):
    """Each command's row in the synopsis names exactly the long options its --help has (less
    --help, --set and --quiet, which the text below the table documents for every command)."""
    import re

    rows = command_table_rows()
    assert name in rows, f"the command table of docs/commands.md has no row for frc {name}"
    documented = set(re.findall(r"--[a-z][a-z-]*", rows[name]))
    options = {opt for param in COMMANDS[name].params for opt in param.opts
               if opt.startswith("--") and not param.hidden}  # a hidden former name is not documented
    assert documented == options - EVERY_COMMAND_OPTIONS, (documented, options)


def test_help_texts_keep_their_brackets():
    """Units and table names in brackets are text, not markup: [s], [N/m] and [model] show."""
    shown = " ".join(runner.invoke(app, ["simulate", "-h"], terminal_width=200).stdout.split())
    for text in ("Simulated time [s]", "[N/m]", "the scene's [model]"):
        assert text in shown, text
