"""Shared fixtures: scene files written on the fly from small dictionaries."""

from __future__ import annotations

import functools
import math
import os
import re
from pathlib import Path

import pytest

from frcontrol.kernel import compiled
from frcontrol.scene import shipped_robots_dir
from frcontrol.solvers import NO_FALLBACK, DoorOptions, Fallback, settings_from

ROBOTS = shipped_robots_dir()

needs_kernel = pytest.mark.skipif(
    compiled is None and os.environ.get("CI") != "true",
    reason="frcontrol._kernel is not built here, or is stale (pip install . builds it); the NumPy kernel "
           "runs, and every other test checks it")
"""For tests of the compiled kernel: they skip outside CI where it is not built; in CI they run (and
fail without it, as tests/test_kernel.py::test_the_extension_is_built_in_ci does)."""


def on(solver: str, fallback: Fallback = NO_FALLBACK, **options: object) -> DoorOptions:
    """The LP door's options for back-end ``solver`` with its ``options`` and ``fallback``."""
    return DoorOptions(settings_from(solver).with_options(solver, **options), fallback=fallback)


MIN_CHECKED_FRACTION = 0.5
"""A property test whose assertion sits under an ``if`` must have run it on at least this fraction
of its examples (hypothesis's rejected examples, by ``assume``, do not count): otherwise the filter,
not the property, decided the outcome."""


class PropertyTally:
    """How many examples a filtering property test saw, and on how many its assertion ran."""

    def __init__(self) -> None:
        self.examples = 0
        self.checked = 0

    def example(self) -> None:
        self.examples += 1

    def check(self) -> None:
        self.checked += 1


_TALLIES: list[PropertyTally] = []


def counted(test):
    """Wrap a hypothesis test (above ``@settings``/``@given``): it calls ``tally().example()`` once
    per example and ``tally().check()`` where its filtered assertion ran; the test fails when the
    assertion ran on fewer than MIN_CHECKED_FRACTION of the examples."""

    @functools.wraps(test)
    def run(*args, **kwargs):
        _TALLIES.append(PropertyTally())
        try:
            test(*args, **kwargs)
        finally:
            seen = _TALLIES.pop()
        assert seen.examples > 0, f"{test.__name__}: no example ran"
        assert seen.checked >= MIN_CHECKED_FRACTION * seen.examples, (
            f"{test.__name__}: the filtered assertion ran on {seen.checked} of {seen.examples} examples "
            f"(at least {MIN_CHECKED_FRACTION:.0%} required)")

    return run


def tally() -> PropertyTally:
    """The tally of the counted property test running now."""
    return _TALLIES[-1]


PROGRESS_LINE = re.compile(r"frc: (?!error: |warning: ).*: "
                           r"(.*(left|time left unknown|total unknown)|\d+ s so far)$")
"""A plain progress line (cli.progress): on a loaded machine a refusal may come after one: a
command's work shows its progress once it has run ``SHOW_AFTER`` seconds, loading included."""


def is_progress(line: str) -> bool:
    """Whether a stderr line is a progress line, not an error or a warning."""
    return PROGRESS_LINE.match(line) is not None


def error_lines(stderr: str) -> list[str]:
    """A command's stderr without its progress lines: what it said about the outcome."""
    return [line for line in stderr.strip().splitlines() if not is_progress(line)]


def one_error_line(stderr: str) -> str:
    """The one error line a refused command wrote: its last line, the only one but progress lines
    (a loaded machine may reach the progress display before the refusal), no traceback."""
    lines = error_lines(stderr)
    assert len(lines) == 1 and lines[0].startswith("frc: error: "), stderr
    assert stderr.strip().splitlines()[-1] == lines[0] and "Traceback" not in stderr, stderr
    return lines[0]


def toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace('"', '\\"') + '"'
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(float(value))
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):  # a nested table, written inline
        return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"
    return str(value)


def toml_text(scene: dict) -> str:
    """A minimal TOML writer for scene dictionaries (tables and arrays of tables)."""
    lines = [f"{k} = {toml_value(v)}" for k, v in scene.items() if not isinstance(v, (dict, list))
             or (isinstance(v, list) and (not v or not isinstance(v[0], dict)))]
    for key, value in scene.items():
        if isinstance(value, dict):
            lines.append(f"[{key}]")
            lines += [f"{k} = {toml_value(v)}" for k, v in value.items()]
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            for table in value:
                lines.append(f"[[{key}]]")
                lines += [f"{k} = {toml_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


def rod_scene(**overrides) -> dict:
    """The rod-on-a-table scene of docs/scenes.md as a dictionary (robot by absolute path)."""
    scene = {
        "name": "rod on a table",
        "robot": str(ROBOTS / "rod.urdf"),
        "base": "planar",
        "gravity": 9.81,
        "state": {"q": [0.0, 0.453, 2.007], "v": [0.0, 0.0, 0.0]},
        "contacts": [
            {"name": "tip", "link": "rod", "point": [-0.5, 0.0], "normal": [0.0, 1.0], "mu": 1.4}
        ],
        "inputs": {"coordinates": ["x", "y", "theta"], "lower": [-50.0, -50.0, -50.0],
                   "upper": [50.0, 50.0, 50.0]},
    }
    scene.update(overrides)
    return scene


@pytest.fixture
def write_scene(tmp_path: Path):
    """Write a scene dictionary (or raw text) to a file and return its path."""
    counter = iter(range(10_000))

    def write(scene: dict | str, name: str | None = None) -> Path:
        path = tmp_path / (name or f"scene{next(counter)}.toml")
        path.write_text(scene if isinstance(scene, str) else toml_text(scene))
        return path

    return write


# ----------------------------------------------------------- the browser tests, counted for CI

_BROWSER_TESTS = {"collected": 0}


def pytest_collection_modifyitems(config, items):
    """Mark every test that drives the real Chromium (it uses the ``chromium`` fixture)."""
    for item in items:
        if "chromium" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.browser)
            _BROWSER_TESTS["collected"] += 1


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """One line CI's log can be read for: how many browser tests ran, passed, failed or skipped."""
    import os

    if not _BROWSER_TESTS["collected"] and os.environ.get("CI") != "true":
        return
    outcomes = {"passed": 0, "failed": 0, "skipped": 0}
    for kind in ("passed", "failed", "error", "skipped"):
        for report in terminalreporter.stats.get(kind, []):
            if "browser" not in getattr(report, "keywords", {}):
                continue
            if kind == "passed" and report.when != "call":
                continue
            outcomes["failed" if kind == "error" else kind] += 1
    ran = outcomes["passed"] + outcomes["failed"]
    terminalreporter.write_line(
        f"browser tests (real Chromium): {ran} ran, {outcomes['passed']} passed, "
        f"{outcomes['failed']} failed, {outcomes['skipped']} skipped")
