"""The climbing gait (frc climb --cycles): geometry, inputs, and the claims of one run checked by
the samples themselves (the snake's real URDF through Pinocchio, the rigid time stepper)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import frcontrol
from frcontrol.errors import InputError, SceneError
from frcontrol.planning.climb_check import BRACE_SLIP_TOLERANCE
from frcontrol.planning.disturbances import DEFAULT_HOLD, PointKinematics, load_disturbances
from frcontrol.planning.gait import plan_gait
from frcontrol.planning.gait_geometry import (
    STROKE,
    configuration_from_points,
    gait_geometry,
    knee,
    points_from_configuration,
)

CYCLES = 5
TARGET_RISE = 0.9  # [m] half the snake's length (issue target)


@pytest.fixture(scope="module")
def scene() -> frcontrol.Scene:
    return frcontrol.load_scene("snake_climb")


@pytest.fixture(scope="module")
def gait_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    """One run of ``frc climb snake_climb --cycles 5 --json --html``: its JSON and its page."""
    from frcontrol.cli.app import app

    page = tmp_path_factory.mktemp("gait") / "gait.html"
    result = CliRunner().invoke(app, ["climb", "snake_climb", "--cycles", str(CYCLES), "--json", "--html",
                                      str(page), "--quiet"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout), page


# ----------------------------------------------------------------------------- geometry
def test_knee_closes_two_links() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        a = rng.uniform(-1, 1, 2)
        b = a + rng.uniform(0.05, 0.39) * np.array([np.cos(t := rng.uniform(0, 6.3)), np.sin(t)])
        for side in (1.0, -1.0):
            k = knee(a, b, 0.2, side)
            assert np.linalg.norm(k - a) == pytest.approx(0.2, abs=1e-12)
            assert np.linalg.norm(k - b) == pytest.approx(0.2, abs=1e-12)


def test_shapes_match_the_model(scene: frcontrol.Scene) -> None:
    """The gait's chain points are the Pinocchio model's link origins (and the head)."""
    geo = gait_geometry(scene, ("tail", "tip", "top"))
    assert (geo.link_length, geo.left_wall, geo.right_wall) == pytest.approx((0.2, -0.15, 0.15))
    links = [f"link{i}" for i in range(9)]
    head = [("head", "link8", np.array([0.2, 0.0]))]
    kin = PointKinematics(scene, [(n, n, np.zeros(2)) for n in links] + head)
    for d in (STROKE[0], STROKE[1]):
        for s_lower, s_upper in ((0.0, 0.0), (0.01, 0.0), (0.0, 0.01)):
            shape = geo.nominal(0.3, d, s_lower, s_upper)
            q = geo.configuration(shape)
            assert np.allclose(kin.positions(q), geo.points(shape), atol=1e-12)
            assert np.allclose(configuration_from_points(points_from_configuration(q, 0.2)), q, atol=1e-12)
            assert np.allclose(geo.measure(q), shape, atol=1e-12)
    # the lower V of the scene is the shape's
    assert np.allclose(geo.configuration(geo.nominal(0.0, STROKE[1]))[:6], scene.q[:6], atol=1e-9)


def test_single_brace_ignores_the_upper_contacts(scene: frcontrol.Scene) -> None:
    gaps = {c.name: c.gap for c in scene.contacts}
    assert gaps["upper_right"] == pytest.approx(0.2) and gaps["upper_left"] == pytest.approx(0.1)
    assert [c.name for c in scene.active_contacts] == ["tail", "tip", "top"]


# ----------------------------------------------------------------------------- bad inputs
@pytest.mark.parametrize("cycles", [0, -1, 1.5, True])
def test_bad_cycles(scene: frcontrol.Scene, cycles: object) -> None:
    with pytest.raises(InputError, match="cycles"):
        plan_gait(scene, cycles)  # type: ignore[arg-type]


def test_scene_without_upper_brace(tmp_path: Path) -> None:
    from frcontrol.scene import resolve_scene_path

    source = resolve_scene_path("snake_climb")
    urdf = source.parent.parent / "snake_planar.urdf"
    path = tmp_path / "no_upper.toml"
    text = source.read_text()
    start = text.index("[task.gait]")
    gait = text[start:text.index("[[disturbances]]", start)]
    path.write_text(text.replace(gait, "").replace('robot = "snake_planar.urdf"', f'robot = "{urdf}"'))
    with pytest.raises(SceneError, match=r"upper brace's contacts \(\[task\] gait") as info:
        plan_gait(frcontrol.load_scene(path), 1)
    assert info.value.field == "task.gait.upper_brace"


@pytest.mark.parametrize(("change", "field", "message"), [
    (lambda t: {**t, "phases": t["phases"][1:] + t["phases"][:1]}, "task.gait.phases",
     "extend, upper_brace, pull, lower_brace in this order"),
    (lambda t: {**t, "phases": [{**t["phases"][0], "modes": {**t["phases"][0]["modes"], "tip": "S"}},
                                *t["phases"][1:]]}, "task.gait.phases[2].modes", "the pull phase holds"),
    (lambda t: {**t, "phases": [*t["phases"][:3], {**t["phases"][3], "until": {"coordinate": "y",
                                                                              "above": 0.2}}]},
     "task.gait.phases[3].until", "until = { time = T }"),
])
def test_gait_task_refuses_phases_it_cannot_run(scene: frcontrol.Scene, change: object, field: str,
                                                message: str) -> None:
    """The gait as task data: its phases' names, modes (the braces' roles) and ``until`` are checked."""
    from dataclasses import replace

    from frcontrol.planning.core.task import read_task
    from frcontrol.planning.gait_run import gait_scene
    from frcontrol.planning.gait_timing import gait_braces_of

    gait = gait_scene(scene, cycles=1)
    task = replace(gait, raw={**gait.raw, "task": change(dict(gait.raw["task"]))})  # type: ignore[operator]
    with pytest.raises(SceneError, match=message) as info:
        gait_braces_of(task, read_task(task))
    assert info.value.field == field
    # the shipped table passes, and its braces are the climb's brace and the upper one
    assert gait_braces_of(gait, read_task(gait)) == (("tail", "tip", "top"), ("upper_right", "upper_left"))


def test_cli_bad_cycles_and_plot() -> None:
    from frcontrol.cli.app import app

    result = CliRunner().invoke(app, ["climb", "snake_climb", "--cycles", "0"])
    assert result.exit_code != 0 and "Traceback" not in result.output
    result = CliRunner().invoke(app, ["climb", "snake_climb", "--cycles", "1", "--plot", "x.png"])
    assert result.exit_code == 2 and "--plot" in result.output


# ----------------------------------------------------------------------------- one run, checked
def _held_slip(payload: dict, scene: frcontrol.Scene) -> tuple[float, float]:
    """``(slip, drift)`` [m]: the largest slide of a contact while the controller held it (F).

    From the samples alone, through the model's point Jacobians: the slip sums ``|t . J(q_k)
    v_k+1| h`` over the held steps of a phase (the sliding velocity each step gave the contact),
    the drift is the contact point's largest displacement along its wall within the phase.
    """
    samples = payload["simulation"]["samples"]
    q, v, times = np.array(samples["q"]), np.array(samples["v"]), np.array(samples["times"])
    names = [c.name for c in scene.contacts]
    tangents = {c.name: c.point.tangent_in_world for c in scene.contacts}
    kin = PointKinematics(scene, [(c.name, c.point.link, c.point.point_in_link) for c in scene.contacts])
    slides: dict[tuple[int, str], float] = {}
    drift = 0.0
    first: dict[tuple[int, str], np.ndarray] = {}
    steps = zip(samples["controller_mode"], samples["mode_contacts"], strict=True)
    for k, (mode, contacts) in enumerate(steps):
        phase = samples["phase"][k]
        jac, _, positions = kin.evaluate(q[k], np.zeros(scene.robot.nv))
        for letter, name in zip(mode, contacts, strict=True):
            if letter != "F":
                continue
            i = names.index(name)
            sliding = tangents[name] @ (jac[2 * i:2 * i + 2] @ v[k + 1])
            slides[(phase, name)] = slides.get((phase, name), 0.0) + abs(sliding) * (times[k + 1] - times[k])
            anchor = first.setdefault((phase, name), positions[i])
            drift = max(drift, abs(float(tangents[name] @ (positions[i] - anchor))))
    return max(slides.values()), drift


@pytest.mark.slow
def test_gait_climbs_and_holds(gait_run: tuple[dict, Path], scene: frcontrol.Scene) -> None:
    payload, page = gait_run
    sim = payload["simulation"]
    samples = sim["samples"]
    times, q, v = (np.array(samples[k]) for k in ("times", "q", "v"))
    assert q.shape == v.shape == (times.size, scene.robot.nv)
    assert sim["status"] == "completed" and sim["phases_completed"] == 4 * CYCLES
    # the rise, from the samples alone
    rise = q[-1, 1] - q[0, 1]
    assert rise == pytest.approx(sim["rise"]) and rise >= TARGET_RISE
    # heights per cycle: the base's height at the end of each cycle's last phase
    ends = [r["end_index"] for r in payload["phase_runs"] if r["name"] == "lower_brace"]
    assert np.allclose(q[ends, 1] - q[0, 1], payload["heights"])
    assert np.all(np.diff(np.concatenate([[0.0], payload["heights"]])) > 0.5 * (STROKE[1] - STROKE[0]))
    # no brace slipped while held, recomputed from q through the model
    slip, drift = _held_slip(payload, scene)
    assert slip == pytest.approx(sim["max_slip"], rel=0.05, abs=1e-7)
    assert slip <= BRACE_SLIP_TOLERANCE and sim["brace_held"]
    assert drift <= sim["max_drift"] * 1.05 + 1e-7
    # the torques are within the limits
    torques = np.array(samples["torques"])
    limits = payload["limits"]
    assert np.all(torques >= np.array(limits["lower"]) - 1e-9)
    assert np.all(torques <= np.array(limits["upper"]) + 1e-9)
    # the samples' generalized forces are S^T u + J_d(q)^T d, d the held disturbance sample (the
    # time stepper's inputs: row k + 1 is the step from sample k, row 0 repeats the first)
    inputs = np.array(samples["inputs"])[1:]
    dist = load_disturbances(scene)
    kin = PointKinematics(scene, [(d.name, d.link, d.point_in_link) for d in dist.items])
    drawn = np.array(sim["disturbance_samples"])
    for k in range(0, len(torques), 97):
        jac, _, _ = kin.evaluate(q[k], v[k])
        held = drawn[int(times[k] / DEFAULT_HOLD + 1e-9)]
        expected = np.concatenate([np.zeros(3), torques[k]]) + jac.T @ held
        assert np.allclose(inputs[k], expected, atol=1e-9)
    assert np.all(np.abs(drawn) <= sim["scale"] * np.abs(dist.vertices()).max(axis=0) + 1e-12)
    # the sampled disturbances lie within the planned scale
    assert sim["scale"] <= payload["weakest_phase"]["max_disturbance_scale"] + 1e-12
    # every contact the controller held is closed at the sample its step reached
    from frcontrol.planning.core.loop import contact_gaps
    from frcontrol.planning.core.tolerances import SEPARATION_GAP

    names = [c.name for c in scene.contacts]
    steps = zip(samples["controller_mode"], samples["mode_contacts"], strict=True)
    for k, (mode, contacts) in enumerate(steps):
        gaps = contact_gaps(scene, q[k + 1])
        assert all(gaps[names.index(c)] <= SEPARATION_GAP for m, c in zip(mode, contacts, strict=True)
                   if m == "F"), k
    # frc plan's outcome and phases: every phase ended by its time, the run achieved
    assert payload["outcome"]["achieved"] and [p["name"] for p in payload["phases"]] == [
        "extend", "upper_brace", "pull", "lower_brace"] * CYCLES
    assert all(p["met"] for p in payload["phases"])
    assert payload["phases"][-1]["end"] == pytest.approx(times[-1])
    assert page.exists() and page.stat().st_size > 10_000


@pytest.mark.slow
def test_gait_plan_report(gait_run: tuple[dict, Path]) -> None:
    payload, _ = gait_run
    from frcontrol.cli.climb_cmd import render_gait
    from frcontrol.cli.common import console

    with console.capture() as text:  # the text answer reads the same document
        render_gait(payload)
    assert "hand-over upper_brace->pull" in text.get() and "base rise" in text.get()
    phases = payload["certificates"]
    assert [p["name"] for p in phases[:4]] == ["extend", "upper_brace", "pull", "lower_brace"]
    assert len(phases) == 4 * CYCLES and all(p["found"] and p["robust"] for p in phases)
    weakest = min(phases, key=lambda p: p["max_disturbance_scale"])
    assert payload["weakest_phase"]["max_disturbance_scale"] == weakest["max_disturbance_scale"]
    assert {p["mode"] for p in phases} == {"FFF", "FF"}
    # every hand-over: no mode in which a brace contact slides holds on the robust set
    assert len(payload["hand_overs"]) == 2 * CYCLES - 1
    for check in payload["hand_overs"]:
        assert check["unambiguous"] and not check["slip_modes"] and check["modes_checked"] == 4 ** 5 - 1


@pytest.mark.slow
def test_plan_runs_the_gait_as_climb_does(gait_run: tuple[dict, Path]) -> None:
    """``frc plan snake_climb --cycles 1``: the gait's task run by the core, the 5-cycle run's first cycle."""
    from frcontrol.cli.app import app

    result = CliRunner().invoke(app, ["plan", "snake_climb", "--cycles", "1", "--json", "--quiet"])
    assert result.exit_code == 0, result.output
    plan = json.loads(result.stdout)
    assert plan["task"]["timing"] == "gait" and plan["task"]["repeat"] == 1 and plan["outcome"]["achieved"]
    assert [p["name"] for p in plan["phases"]] == ["extend", "upper_brace", "pull", "lower_brace"]
    assert "hand-over upper_brace->pull: unambiguous" in plan["phases"][1]["why"]  # checked at its end
    five = gait_run[0]["simulation"]["samples"]
    q = np.array(plan["simulation"]["samples"]["q"])
    assert np.allclose(q, np.array(five["q"])[:len(q)], atol=1e-9)
    assert np.allclose(plan["simulation"]["samples"]["inputs"], np.array(five["inputs"])[:len(q)], atol=1e-9)
    rise = q[-1, 1] - q[0, 1]
    assert rise == pytest.approx(gait_run[0]["heights"][0]) and rise > 0.5 * (STROKE[1] - STROKE[0])
