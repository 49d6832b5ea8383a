"""Outputs that explain themselves: one mode-letter convention, legends, analyze's columns, progress.

- Every mode a text table, figure legend or page shows has one letter per contact of the scene,
  in scene order, with the contacts' names beside it (:func:`frcontrol.modes.scene_mode`).
- Every kind of mark a figure draws has a legend entry (checked on the Figure object).
- ``frc analyze`` names its columns in words, ``--help`` defines them, no word is cut at 80 columns.
- Long commands report progress on stderr (a fraction and the time left) as plain lines when
  stderr is a pipe, nothing under ``--quiet``, and stdout stays one JSON document.
"""

from __future__ import annotations

import io
import json
import os
import re
import subprocess

import numpy as np
import pytest
from frcontrol.cli.app import app
from test_json_output import frc_executable
from typer.testing import CliRunner

from frcontrol.errors import InputError
from frcontrol.modes import check_mode, mode_heading, mode_key, mode_label, scene_mode
from frcontrol.scene import load_scene

runner = CliRunner()

RHEX_CONTACTS = ("front_corner", "rear_corner", "front_toe", "middle_toe", "rear_toe")
"""rhex_flip's contacts in scene order; rear_corner and front_toe do not touch at its state."""


# ------------------------------------------------------------------ the mode-letter convention

def test_a_mode_of_the_touching_contacts_becomes_one_of_every_scene_contact():
    assert scene_mode("RLL", ("front_corner", "middle_toe", "rear_toe"), RHEX_CONTACTS) == "RSSLL"
    assert scene_mode("", (), ("a", "b")) == "SS"
    assert mode_label("RSL", ("toe", "hip", "heel")) == "RSL (toe R, hip S, heel L)"
    assert mode_heading(("toe", "heel")) == "mode (toe heel)"
    assert "(toe, heel)" in mode_key(("toe", "heel")) and "S separate" in mode_key(("toe", "heel"))
    with pytest.raises(InputError, match="2 letters for 3 contacts"):
        scene_mode("RL", ("a", "b", "c"), ("a", "b", "c"))
    with pytest.raises(InputError, match="'z' is not among"):
        scene_mode("R", ("z",), ("a", "b"))


def test_a_problems_scene_mode_is_the_functions():
    """ContactProblem.scene_mode (the contacts' places read once) against scene_mode, on every mode
    of rhex_flip's three touching contacts (two apart) and of table_on_ground, and its errors."""
    import itertools

    from frcontrol.modes import ContactProblem

    for name in ("rhex_flip", "table_on_ground"):
        problem = ContactProblem.from_scene(load_scene(name))
        for letters in itertools.product("SLRF", repeat=problem.k):
            mode = "".join(letters)
            assert problem.scene_mode(mode) == scene_mode(mode, problem.contacts, problem.scene_contacts)
        with pytest.raises(InputError, match="letters for"):
            problem.scene_mode("F" * (problem.k + 1))
    assert ContactProblem.from_scene(load_scene("rhex_flip")).scene_mode("RLL") == "RSSLL"


def test_errors_name_a_mode_by_the_scenes_letters_and_its_contacts():
    from frcontrol import analyze

    # progress names the modes by the scene's letters: five (three touch: front_corner, middle_toe, rear_toe)
    seen: list[str] = []
    result = analyze(load_scene("rhex_flip"), progress=seen.append)
    assert len(seen) == len(result.modes) and {len(mode) for mode in seen} == {5}
    named = "FSSLR (front_corner F, rear_corner S, front_toe S, middle_toe L, rear_toe R)"
    assert result.mode("FLR").named == named
    assert result.problem.named_mode("FL") == "FL (front_corner F, middle_toe L)"  # a partial mode, as grown
    with pytest.raises(InputError, match=r"'FSSLR' has one letter per scene contact .*touching contact "
                                         r"\(front_corner, middle_toe, rear_toe\): 'FLR'"):
        result.mode("FSSLR")
    with pytest.raises(InputError,
                       match=r"'QQQ' was not evaluated .* feasible: 'LSS' = LSSSS \(front_corner L, "):
        result.mode("QQQ")
    infeasible = next(m for m in result.modes if not m.feasible)
    with pytest.raises(InputError, match=re.escape(f"mode {infeasible.named} is infeasible")):
        _ = infeasible.feasible_domain
    assert infeasible.named.startswith(result.problem.scene_mode(infeasible.mode) + " (front_corner ")
    with pytest.raises(InputError, match="one per touching contact, 3 .*'FSSLR' has one per scene contact"):
        check_mode(result.problem, "FSSLR")


def _text_and_json(args: list[str]) -> tuple[str, dict]:
    text = runner.invoke(app, args, env={"COLUMNS": "200"})
    doc = runner.invoke(app, [*args, "--json"])
    assert text.exit_code == 0 and doc.exit_code == 0, text.stderr + doc.stderr
    return text.stdout, json.loads(doc.stdout)


def _modes_in(document: object) -> list[dict]:
    """Every record of a JSON document with a ``"mode"``."""
    if isinstance(document, dict):
        own = [document] if isinstance(document.get("mode"), str) else []
        return own + [r for value in document.values() for r in _modes_in(value)]
    if isinstance(document, list):
        return [r for value in document for r in _modes_in(value)]
    return []


@pytest.mark.slow
@pytest.mark.parametrize("args", [
    ["analyze", "rhex_flip"],
    ["analyze", "rhex_flip", "--input", "hip_middle=-5", "--input", "hip_rear=-5"],
    ["flip", "rhex_flip", "--max-time", "0"],
    ["standup", "solo_standup", "--max-time", "0"],
    ["climb", "snake_climb", "--duration", "0"],
    ["statics", "snake_climb"],
], ids=lambda a: " ".join(a))
def test_every_text_output_shows_modes_over_every_scene_contact_with_names(args):
    text, doc = _text_and_json(args)
    names = [c.name for c in load_scene(args[1]).contacts]
    assert doc["scene_contacts"] == names
    records = _modes_in(doc)
    assert records, "the command's document has a mode to show"
    flat = " ".join(text.split())
    for record in records:
        assert len(record["scene_mode"]) == len(names)
        if "contacts" in record or record is doc:
            touching = record.get("contacts", doc.get("contacts"))
            assert record["scene_mode"] == scene_mode(record["mode"], list(touching), names)
    shown = [r["scene_mode"] for r in records if re.search(rf"\b{r['scene_mode']}\b", flat)]
    assert shown, "the text shows the modes over every contact"
    # every mode printed stands beside the contacts' names: "RSSLL (front_corner R, ...)" or a
    # heading or key naming them in order
    assert mode_label(shown[0], names) in flat or " ".join(names) in flat or ", ".join(names) in flat
    touching = doc.get("contacts")
    if isinstance(touching, list) and len(touching) < len(names) and doc.get("mode"):
        assert not re.search(rf"\b{doc['mode']}\b", flat), "a mode over the touching contacts only"


# ----------------------------------------------------------------------------------- legends

def _mark_kinds(figure) -> set[tuple]:
    """Each kind of mark drawn (colour, marker or fill, hatch), ignoring texts and grid lines."""
    from matplotlib.colors import to_hex
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.text import Annotation

    kinds = set()
    for ax in figure.axes:
        for line in ax.lines:
            if not (isinstance(line, Line2D) and len(line.get_xdata())):
                continue
            if to_hex(line.get_color()) == "#999999":  # the zero line of a force axis
                continue
            marker = line.get_marker() if line.get_marker() not in ("None", "", None) else None
            kinds.add(("line", to_hex(line.get_color()), marker))
        for patch in ax.patches:
            if not (isinstance(patch, Patch) and patch.get_visible()):
                continue
            face = patch.get_facecolor()
            if not patch.get_fill() or face[3] == 0.0:  # an outline: explained by a line or an edge
                kinds.add(("outline", to_hex(patch.get_edgecolor()), patch.get_hatch()))
            else:
                kinds.add(("patch", to_hex(face), patch.get_hatch()))
        for child in ax.get_children():
            if isinstance(child, Annotation) and child.arrow_patch is not None:
                kinds.add(("arrow", to_hex(child.arrow_patch.get_edgecolor()), None))
    return kinds


def _legend_kinds(figure) -> set[tuple]:
    from matplotlib.colors import to_hex
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    legends = [ax.get_legend() for ax in figure.axes if ax.get_legend() is not None] + list(figure.legends)
    kinds = set()
    for legend in legends:
        for handle in legend.legend_handles:
            if isinstance(handle, Line2D):
                colour = to_hex(handle.get_color())
                marker = handle.get_marker() if handle.get_marker() not in ("None", "", None) else None
                kinds |= {("line", colour, marker), ("arrow", colour, None)} if marker == ">" else \
                    {("line", colour, marker)}
            elif isinstance(handle, Patch):
                kinds.add(("patch", to_hex(handle.get_facecolor()), handle.get_hatch()))
                kinds.add(("patch", to_hex(handle.get_edgecolor()), handle.get_hatch()))
    return kinds


def _unexplained(figure) -> set[tuple]:
    """The kinds of marks with no legend entry of their colour (and marker or hatch)."""
    legend = _legend_kinds(figure)
    colours = {(kind, colour) for kind, colour, _ in legend}
    missing = set()
    for kind, colour, detail in _mark_kinds(figure):
        if kind == "line" and detail is None:  # a plain line: a legend line of its colour
            explained = ("line", colour) in colours
        elif kind == "outline":  # an outlined region: a legend line or patch edge of its colour
            explained = ("line", colour) in colours or ("patch", colour, detail) in legend
        else:
            explained = (kind, colour, detail) in legend
        if not explained:
            missing.add((kind, colour, detail))
    return missing


@pytest.fixture(scope="module")
def statics_report():
    from frcontrol.statics import analyze_statics

    scene = load_scene("table_on_ground")
    return scene, analyze_statics(scene)


def test_the_statics_figure_explains_its_cones_arrows_and_points(statics_report):
    from frcontrol.viz import figures

    scene, report = statics_report
    figure = figures.plot_statics(scene, report)
    assert _unexplained(figure) == set()
    labels = [t.get_text() for t in figure.axes[0].get_legend().get_texts()]
    assert any("friction cone" in label for label in labels)
    assert any("contact force" in label for label in labels)
    # the check can fail: a cone drawn in a colour the legend does not have
    from matplotlib.patches import Polygon

    figure.axes[0].add_patch(Polygon(np.array([[0, 0], [1, 0], [0, 1]]), facecolor="#123456"))
    assert _unexplained(figure) == {("patch", "#123456", None)}


@pytest.mark.slow
def test_the_flip_figure_has_its_star_in_the_legend_and_modes_over_every_contact():
    from frcontrol.planning.flip import plan_flip
    from frcontrol.planning.flip_loop import simulate_flip
    from frcontrol.viz import figures

    scene = load_scene("rhex_flip")
    plan = plan_flip(scene)
    result = simulate_flip(scene, plan=plan, max_time=0.05)
    figure = figures.flip_figure(result)
    assert _unexplained(figure) == set()
    legend = figure.axes[0].get_legend()
    labels = [t.get_text() for t in legend.get_texts()]
    assert "the plan's torques" in labels
    assert legend.get_title().get_text().startswith(mode_heading(RHEX_CONTACTS))
    planned = scene_mode(plan.mode, plan.contacts, RHEX_CONTACTS)
    assert planned in labels and planned in figure.axes[0].get_title()


def test_the_html_page_names_the_contacts_beside_the_mode_letters():
    from frcontrol.simulation.export import sample_modes
    from frcontrol.simulation.rigid import simulate_rigid
    from frcontrol.viz.meshcat_view import scene_html

    scene = load_scene("rhex_flip")
    trajectory = simulate_rigid(scene, {"hip_middle": -5.0, "hip_rear": -5.0}, 0.02)
    modes = sample_modes(scene, trajectory)
    page, _ = scene_html(scene, trajectory, modes=modes)
    assert mode_heading(RHEX_CONTACTS) in page  # the caption names the letters' contacts
    data = json.loads(re.search(r"const data = (\{.*?\});\n", page).group(1))
    assert len(data["modes"]) == len(data["times"])  # one per drawn sample
    assert set(data["modes"]) <= {mode_label(mode, RHEX_CONTACTS) for mode in modes}
    assert all(len(mode) == len(RHEX_CONTACTS) for mode in modes)


@pytest.mark.slow
def test_the_pump_figure_names_the_contacts_of_its_modes_and_explains_its_shading():
    from frcontrol.planning.pump import simulate_pump
    from frcontrol.viz.pump_figure import pump_figure

    scene = load_scene("rhex_flip_drives")
    contacts = tuple(c.name for c in scene.contacts)  # the legs robot: its belly corners too
    result = simulate_pump(scene, max_time=0.3)
    figure = pump_figure(scene, result)
    portrait = figure.axes[0].get_legend()
    assert portrait.get_title().get_text() == mode_heading(contacts)
    entries = {t.get_text() for t in portrait.get_texts()}
    assert set(result.trajectory.modes) <= entries | {"a push starts"}
    assert all(len(mode) == len(contacts) for phase in result.phases for mode in phase.modes)
    labels = {t.get_text() for axes in figure.axes if axes.get_legend() is not None
              for t in axes.get_legend().get_texts()}
    assert {f"a {phase.kind} phase" for phase in result.phases} <= labels  # the shading, in a legend


# ------------------------------------------------------------------------------ frc analyze

def test_analyze_names_its_columns_in_words_and_help_defines_them():
    from frcontrol.cli.analyze_cmd import MODE_COLUMNS, RESPONSE_WORDS

    done = runner.invoke(app, ["analyze", "rod_on_table"], env={"COLUMNS": "80"})
    assert done.exit_code == 0
    for column in ("response", "free directions", "ambiguous outputs", "interior", "faces", "overlaps with"):
        assert column in MODE_COLUMNS
    flat = " ".join(done.stdout.split())
    assert "free directions" in flat and "(tip)" in flat and "half-spaces" not in flat
    assert set(RESPONSE_WORDS) == {"unique", "ambiguous", "constrained", "ambiguous_constrained"}
    helped = " ".join(runner.invoke(app, ["analyze", "--help"], env={"COLUMNS": "200"}).stdout.split())
    for name, meaning in MODE_COLUMNS.items():
        assert f"{name}: {' '.join(meaning.split()[:4])}" in helped


@pytest.mark.parametrize("scene", ["rhex_flip", "solo_standup", "snake_climb", "peg_on_surface"])
def test_analyze_cuts_no_word_at_80_columns(scene):
    narrow = runner.invoke(app, ["analyze", scene, "--input", "hip_middle=1"] if scene == "rhex_flip"
                           else ["analyze", scene], env={"COLUMNS": "80"})
    wide = runner.invoke(app, ["analyze", scene, "--input", "hip_middle=1"] if scene == "rhex_flip"
                         else ["analyze", scene], env={"COLUMNS": "2000"})
    assert narrow.exit_code == 0 and wide.exit_code == 0
    whole = {token.rstrip(":;,") for token in wide.stdout.split()}
    lines = [line for line in narrow.stdout.splitlines() if not line.startswith("time:")]
    assert max(len(line) for line in lines) <= 80
    cut = [token for line in lines for token in line.split()
           if token.rstrip(":;,") not in whole and set(token) != {"-"}]
    assert cut == []


def test_a_rich_table_would_cut_words_where_ours_does_not():
    """The negative control: the same rows in a Rich table at 80 columns cut a word."""
    from frcontrol.cli.text_table import table_lines
    from rich.console import Console
    from rich.table import Table

    columns = ("mode (front_corner rear_corner front_toe middle_toe rear_toe)", "response",
               "free directions", "ambiguous outputs", "interior", "faces", "overlaps with")
    row = ("RSSLL", "ambiguous, inputs constrained", "2", "accelerations", "no", "2", "RSSFL, RSSRL")
    words = {word.rstrip(":;,") for word in " ".join([*columns, *row]).split()}
    table = Table()
    for column in columns:
        table.add_column(column, overflow="fold")
    table.add_row(*row)
    out = io.StringIO()
    Console(file=out, width=80).print(table)
    rich_tokens = [t.rstrip(":;,") for t in re.split(r"[\s\u2500-\u257f]+", out.getvalue()) if t]
    assert [t for t in rich_tokens if t and t not in words]  # Rich cut some word
    ours = table_lines("modes", columns, [row], 80)
    assert all(len(line) <= 80 for line in ours)
    assert [t for line in ours[1:] for t in line.split()
            if t.rstrip(":;,") not in words and set(t) != {"-"}] == []


# ----------------------------------------------------------------------------------- progress

def test_plain_progress_lines_are_paced_and_say_fraction_and_time_left(monkeypatch):
    from frcontrol.cli import progress as progress_module

    clock = [100.0]
    monkeypatch.setattr(progress_module.time, "monotonic", lambda: clock[0])
    stream = io.StringIO()
    shown = progress_module.Progress("simulating", "s", stream=stream)
    for step in range(1, 101):  # 0.1 s of work per 0.01 s simulated: 10 s for 1 s
        clock[0] += 0.1
        shown(step / 100, 1.0)
    lines = stream.getvalue().splitlines()
    assert re.fullmatch(r"frc: simulating: 0\.2\d* / 1 s \(2\d%\), about 8 s left", lines[0])
    assert len(lines) == 1 + int((10.0 - 2.0) / progress_module.PLAIN_INTERVAL)
    quiet = io.StringIO()
    silent = progress_module.Progress("simulating", "s", quiet=True, stream=quiet)
    clock[0] += 10.0
    silent(0.5, 1.0)
    assert quiet.getvalue() == ""


def test_work_without_reports_shows_its_time_so_far(monkeypatch):
    """A planner before its simulation reports nothing: the display wakes up by itself."""
    import time

    from frcontrol.cli import progress as progress_module

    monkeypatch.setattr(progress_module, "SHOW_AFTER", 0.0)
    monkeypatch.setattr(progress_module, "HEARTBEAT", 0.01)
    stream = io.StringIO()
    with progress_module.Progress("planning the flip", "s", stream=stream):
        deadline = time.monotonic() + 60.0  # a condition, not a timing: the first heartbeat's line
        while "so far" not in stream.getvalue():
            assert time.monotonic() < deadline, "no heartbeat line"
            time.sleep(0.01)
    assert re.match(r"frc: planning the flip: \d+ s so far\n", stream.getvalue())
    quiet = io.StringIO()
    with progress_module.Progress("planning the flip", "s", quiet=True, stream=quiet) as shown:
        assert shown.beat is None  # no thread at all under --quiet


def _run_long(*extra: str, tmp_path) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"}
    return subprocess.run([*frc_executable(), "simulate", "box_on_slope", "--model", "compliant",
                           "--stiffness", "1e6", "--json", *extra], capture_output=True, text=True,
                          cwd=tmp_path, env=env, timeout=600)


@pytest.mark.slow
def test_a_long_simulation_shows_progress_on_a_piped_stderr_and_keeps_its_json(tmp_path):
    done = _run_long("--every", "10", tmp_path=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    doc = json.loads(done.stdout)
    lines = done.stderr.splitlines()
    progress = [line for line in lines if line.startswith("frc: simulating on the compliant model:")]
    wall = doc["summary"]["wall_time"]
    assert wall > 2.0 and progress, (wall, lines)  # the run is long enough to be reported
    assert all(re.search(r"\d+(\.\d+)? / 1 s \(\d+%\), (about \d+ (s|min) left|time left unknown)", line)
               for line in progress)
    assert "\x1b" not in done.stderr and "\r" not in done.stderr  # plain lines, no terminal codes
    assert doc["summary"]["sample_every"] == 10 and len(doc["samples"]["times"]) == 101
    quiet = _run_long("--quiet", tmp_path=tmp_path)
    assert quiet.returncode == 0 and json.loads(quiet.stdout)["summary"]["wall_time"] > 2.0
    assert not [line for line in quiet.stderr.splitlines() if line.startswith("frc: simulating")]


def test_every_keeps_every_nth_sample_and_the_last():
    full = runner.invoke(app, ["simulate", "rod_on_table", "-T", "0.1", "--json"])
    tenth = runner.invoke(app, ["simulate", "rod_on_table", "-T", "0.1", "--json", "--every", "7"])
    assert full.exit_code == 0 and tenth.exit_code == 0
    a, b = json.loads(full.stdout), json.loads(tenth.stdout)
    count = len(a["samples"]["times"])
    kept = list(range(0, count, 7)) + ([count - 1] if (count - 1) % 7 else [])
    assert b["summary"]["samples_kept"] == len(kept) == len(b["samples"]["times"])
    np.testing.assert_array_equal(np.array(b["samples"]["q"]), np.array(a["samples"]["q"])[kept])
    assert b["samples"]["modes"] == [a["samples"]["modes"][i] for i in kept]
    assert b["summary"]["final_q"] == a["summary"]["final_q"]
    assert b["summary"]["events"] == a["summary"]["events"]
    bad = runner.invoke(app, ["simulate", "rod_on_table", "--every", "0"])
    assert bad.exit_code == 2 and "--every" in bad.stderr
