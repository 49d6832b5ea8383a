"""Every option of every command refuses a bad value the same way: exit 2, one line naming it.

The command tree is walked (commands added later are covered without a change here): each option
that takes a value is given bad values derived from its type (a non-number, NaN, a number past its
range, an unknown choice); options that take free text (paths, grammars, addresses) need an entry
in FREE_TEXT, and the test fails for one that has none.
"""

from __future__ import annotations

import enum
import os
import signal
import subprocess
import sys
import types
import typing

import pytest
import typer
from frcontrol.cli.app import app
from frcontrol.cli.options import NumberRange
from typer.testing import CliRunner

runner = CliRunner()
COMMANDS = typer.main.get_command(app).commands

FREE_TEXT = {
    "--input": ["x", "x=abc", "x=nan", "x=1 --input x=2"],
    "--set": ["nonsense", "=1"],
    "--vary": ["p=0:1:0", "p=0:1", "p=a:1:2"],
    "--plot": ["/proc/frc-probe.png", "figure.txt", "/nonexistent-folder/x.png"],
    "--html": ["/proc/frc-probe.html", "/nonexistent-folder/x.html"],
    "--out": ["/proc/frc-probe.npz", "run.txt"],
    "--figure": ["no-such-array"],
    "--scheduler": ["not an address", "tcp://:8786"],
    "--host": ["not a host!"],
    "--token-file": ["/nonexistent-folder/token.txt"],
    "--integrator": ["foo"],
}
"""Bad values of the options whose type says nothing about what they accept."""

PARSER_WORDS = ("Input should", "unable to parse", "Value error")
"""The value parser's own wording, which a usage error replaces with the option's range or choices."""

BASE = {
    "analyze": ["rod_on_table"], "show": ["rod_on_table"], "statics": ["rod_on_table"],
    "view": ["rod_on_table"], "simulate": ["rod_on_table", "-T", "0.01"], "validate": ["rod_on_table"],
    "flip": ["-T", "0"], "climb": ["-T", "0"], "standup": ["-T", "0"],
    "atlas": ["rod_on_table", "--vary", "state.q.theta=0.3:2.8:2", "-w", "1"],
    "serve": ["--openapi"],  # a bad value that slipped through would print the schema, not serve
}
"""Arguments that make each command quick if a bad value were let through (unknown commands: none)."""


def _annotation(param) -> type:
    """The option's value type, without Optional and list."""
    annotation = param.type_descriptor.annotation
    for _ in range(3):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        if typing.get_origin(annotation) in (typing.Union, types.UnionType, list) and args:
            annotation = args[0]
    return annotation


def bad_values(param) -> list[str]:
    """Bad values for one option, from its type and its range; free text from FREE_TEXT."""
    annotation = _annotation(param)
    name = param.opts[0]
    if name in FREE_TEXT:
        return FREE_TEXT[name]
    if isinstance(annotation, type) and issubclass(annotation, enum.Enum):
        return ["no-such-choice"]
    if annotation in (int, float):
        callback = param.type_descriptor.parameter_info.callback
        limits = getattr(callback, "__self__", None)
        assert isinstance(limits, NumberRange), f"{name}: a number option needs a range (options.in_range)"
        values = ["abc", "nan", "inf"] if annotation is float else ["abc", "1.5"]
        for bound, step in ((limits.low, -1), (limits.above, 0), (limits.high, 1)):
            if bound is not None:
                values.append(str(type(bound)(bound + step) if annotation is int else bound + step))
        return values
    raise AssertionError(f"{name}: a new option of type {annotation!r} needs bad values in FREE_TEXT")


def cases():
    out = []
    for command_name, command in sorted(COMMANDS.items()):
        for param in command.params:
            if not param.opts[0].startswith("-") or param.is_flag:
                continue
            for value in bad_values(param):
                out.append(pytest.param(command_name, param.opts[0], value, id=f"{command_name} "
                                        f"{param.opts[0]} {value}"))
    return out


@pytest.mark.parametrize("command, option, value", cases())
def test_every_option_refuses_a_bad_value_with_exit_2_and_one_line(command, option, value, tmp_path,
                                                                   monkeypatch):
    monkeypatch.chdir(tmp_path)
    args = [command, *BASE.get(command, []), option, *value.split(" --input ")[:1]]
    if " --input " in value:  # a name given twice
        args += ["--input", value.split(" --input ")[1]]
    result = runner.invoke(app, args)
    assert result.exit_code == 2, (args, result.exit_code, result.stdout[-300:], result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("frc: error: "), result.stderr
    assert f"'{option}'" in lines[0] and "Traceback" not in result.stderr
    assert lines[0].count("'-") == 1, lines[0]  # the option named once, by its long name
    assert not any(words in lines[0] for words in PARSER_WORDS), lines[0]
    assert result.stdout == "" and list(tmp_path.iterdir()) == []


def test_the_walk_covers_every_command_and_the_free_text_table_has_no_stale_entry():
    """Every command is walked, and every FREE_TEXT entry names an option some command has."""
    options = {p.opts[0] for c in COMMANDS.values() for p in c.params}
    assert set(FREE_TEXT) <= options, set(FREE_TEXT) - options
    walked = {case.values[0] for case in cases()}
    assert walked == {name for name, c in COMMANDS.items()
                      if any(p.opts[0].startswith("-") and not p.is_flag for p in c.params)}


@pytest.mark.parametrize("args", [
    ["simulate", "rod_on_table", "--dt", "0"],
    ["flip", "--max-time", "-1"],
    ["atlas", "rod_on_table", "--vary", "p=0:1:0"],
])
def test_a_real_process_exits_2_with_one_line(args, tmp_path):
    run = subprocess.run([sys.executable, "-m", "frcontrol", *args], capture_output=True, text=True,
                         cwd=tmp_path, timeout=120)
    assert run.returncode == 2 and run.stdout == ""
    [line] = run.stderr.strip().splitlines()
    assert line.startswith("frc: error: Invalid value for '" + args[-2])


def _ctrl_c_ready(process: subprocess.Popen, ready: str) -> list[str]:
    """stderr lines until one contains ``ready`` (the command says it is working)."""
    seen = []
    assert process.stderr is not None
    for line in process.stderr:
        seen.append(line)
        if ready in line:
            return seen
    raise AssertionError(f"the command ended before saying {ready!r}: {''.join(seen)}")


@pytest.mark.parametrize("args, ready", [
    (["view", "rod_on_table", "--watch", "--html", "rod.html"], "watching"),
])
def test_ctrl_c_exits_130_with_one_line(args, ready, tmp_path):
    """SIGINT once the command says it works: exit 130 and `frc: error: interrupted by SIGINT`."""
    env = {**os.environ, "COLUMNS": "200"}
    process = subprocess.Popen([sys.executable, "-m", "frcontrol", *args], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, cwd=tmp_path, env=env,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        _ctrl_c_ready(process, ready)
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    if "--watch" in args:  # a watcher's Ctrl-C is its ordinary end
        assert process.returncode == 0, err
        return
    assert process.returncode == 130, err
    assert err.strip().splitlines()[-1] == "frc: error: interrupted by SIGINT" and "Traceback" not in err
    assert out == ""
