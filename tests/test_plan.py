"""frc plan and frcontrol.planning.core: tasks as data, judged from their samples alone.

Each new task (a scene file, no code of its own) is judged from its run's samples: the allowed
modes held at every sample (a fixed contact loaded and moving along its surface by at most the
stand-up's SLIP_DISTANCE; a sliding contact loaded and moving its way), the objective's sign,
``until`` met, the inputs within their limits. The planner's own flags are not read.
"""

from __future__ import annotations

import ast
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import counted, tally
from frcontrol.cli.app import app
from test_architecture import circles
from typer.testing import CliRunner

from frcontrol.engine import solutions_at
from frcontrol.errors import SceneError
from frcontrol.planning.core import plan_task, read_task
from frcontrol.planning.core.decision import decide
from frcontrol.planning.core.loop import contact_gaps
from frcontrol.planning.core.task import LETTERS, Objective, Phase, Until
from frcontrol.planning.standup import SLIP_DISTANCE
from frcontrol.scene import load_scene, shipped_robots_dir
from frcontrol.simulation.rigid import CONTACT_FORCE_TOLERANCE

SCENES = shipped_robots_dir() / "scenes"
runner = CliRunner()


def scene(name: str):
    return load_scene(SCENES / f"{name}.toml")


def loaded(trajectory, scene_, name: str) -> np.ndarray:
    """Per sample after the first (sample 0 carries no step's forces), whether the contact is loaded."""
    i = [c.name for c in scene_.contacts].index(name)
    return trajectory.contact_forces[1:, i, 0] > CONTACT_FORCE_TOLERANCE * scene_.robot.weight_scale()


def travel(trajectory, scene_, name: str) -> np.ndarray:
    """The contact point's displacement along its surface's tangent (+x for an upward normal), per sample."""
    i = [c.name for c in scene_.contacts].index(name)
    n = scene_.contacts[i].point.normal_in_world
    tangent = np.array([n[1], -n[0]])
    return (trajectory.contact_points[:, i] - trajectory.contact_points[0, i]) @ tangent


def within_limits(trajectory, scene_) -> bool:
    return bool(
        np.all(trajectory.inputs >= scene_.inputs.lower - 1e-12)
        and np.all(trajectory.inputs <= scene_.inputs.upper + 1e-12)
    )


def test_rod_pivots_about_its_tip_without_slip():
    rod = scene("rod_pivot")
    result = plan_task(rod)
    traj = result.trajectory
    assert np.all(loaded(traj, rod, "tip"))
    assert np.max(np.abs(travel(traj, rod, "tip"))) <= SLIP_DISTANCE
    theta = traj.q[:, 2]
    assert theta[-1] >= 2.08 > theta[-2]  # until met, at the last sample
    assert np.all(np.diff(traj.v[:, 2]) > 0)  # the maximised angular acceleration is positive
    assert within_limits(traj, rod)


def test_box_slides_right_on_both_corners_without_tipping():
    box = scene("box_slide")
    traj = plan_task(box).trajectory
    for corner in ("left", "right"):
        assert np.all(loaded(traj, box, corner))  # no corner lifts: no tipping
        assert np.all(np.diff(travel(traj, box, corner)) > 0)  # both slide right at every step
    assert abs(traj.q[-1, 2]) < 1e-6  # level
    assert traj.q[-1, 0] >= 0.05 > traj.q[-2, 0]
    assert np.all(np.diff(traj.v[:, 0]) > 0)  # the maximised x acceleration is positive
    assert within_limits(traj, box)


def test_box_tips_about_its_left_corner_though_sliding_would_turn_it_faster():
    box = scene("box_tip")
    traj = plan_task(box).trajectory
    assert np.all(loaded(traj, box, "left"))
    assert np.max(np.abs(travel(traj, box, "left"))) <= SLIP_DISTANCE  # F, not L: the best without the modes
    assert np.all(traj.contact_forces[1:, 1, 0] == 0) and np.all(contact_gaps(box, traj.q[-1])[1] > 0)
    assert np.all(np.diff(traj.v[:, 2]) > 0)
    assert traj.q[-1, 2] >= 0.02 > traj.q[-2, 2]
    assert within_limits(traj, box)


@pytest.mark.slow
def test_solo_shifts_forward_with_both_feet_fixed():
    solo = scene("solo_shift")
    result = plan_task(solo)
    traj = result.trajectory
    for foot in ("front_foot", "hind_foot"):
        assert np.all(loaded(traj, solo, foot))
        assert np.max(np.abs(travel(traj, solo, foot))) <= SLIP_DISTANCE
    gaps = np.array([contact_gaps(solo, q) for q in traj.q[1:]])
    assert np.all(gaps[:, :2] > 0)  # the body's ends (mode S) are off the ground
    assert traj.q[-1, 0] >= 0.03 > traj.q[-2, 0]
    assert within_limits(traj, solo)
    assert result.to_dict(solo)["phases"][0]["why"] == "until x above 0.03"


def crossing_time(trajectory, index: int, level: float) -> float:
    """[s] When the coordinate first reaches ``level``, linear between the two samples around it."""
    values = trajectory.q[:, index]
    end = int(np.argmax(values >= level))
    assert values[end] >= level and end > 0
    t_a, t_b, p_a, p_b = trajectory.times[end - 1], trajectory.times[end], values[end - 1], values[end]
    return float(t_a + (level - p_a) / (p_b - p_a) * (t_b - t_a))


@pytest.mark.slow
def test_the_flip_as_a_task_reaches_vertical_as_fast_as_frc_flip():
    from frcontrol.planning.flip import SEPARATION_GAP
    from frcontrol.planning.flip_loop import simulate_flip

    rhex = scene("rhex_flip")  # one scene: frc plan and frc flip run its task
    traj = plan_task(rhex).trajectory
    vertical = 1.5 * np.pi
    front = [c.name for c in rhex.contacts].index("front_corner")
    gaps = np.array([contact_gaps(rhex, q)[front] for q in traj.q])
    assert np.all(gaps <= SEPARATION_GAP)  # the pivot corner never leaves the ground
    assert within_limits(traj, rhex)
    names = [c.name for c in rhex.contacts]
    for hip, toe in (("hip_middle", "middle_toe"), ("hip_rear", "rear_toe")):  # massless legs
        toe_gaps = np.array([contact_gaps(rhex, q)[names.index(toe)] for q in traj.q])
        in_the_air = toe_gaps[:-1] > SEPARATION_GAP  # inputs[i + 1] is held over the step from sample i
        held = traj.inputs[1:, rhex.inputs.coordinates.index(hip)]
        assert np.any(in_the_air) and np.all(held[in_the_air] == 0)
    dedicated = simulate_flip(scene("rhex_flip"))
    assert dedicated.time_to_vertical is not None
    assert crossing_time(traj, 2, vertical) <= 1.1 * dedicated.time_to_vertical


PUMP_VERTICAL_TIME = 1.016
"""[s] When the pumping flip passed vertical on its dedicated loop, before the pump became a task
(``frc flip rhex_flip_drives``, docs/rhex-flip.md): the task must get there within 10 %."""


def outside_the_phases_modes(result, scene_) -> int:
    """How many samples have a mode that the letters of the phase that chose their step do not allow.

    Sample k ends the step from sample k - 1, whose inputs the phase running at t_k-1 chose; the
    letters are the task's (its ``modes``), not the planner's records.
    """
    traj, names = result.trajectory, tuple(c.name for c in scene_.contacts)
    phases = {p.name: p for p in result.task.phases}
    records = result.run.records
    outside = 0
    for k in range(1, len(traj.times)):
        t = traj.times[k - 1]
        record = next((r for r in records if r.start <= t + 1e-12 < r.end), records[-1])
        outside += not phases[record.name].allows(names, traj.modes[k])
    return outside


@pytest.mark.slow
def test_the_pump_as_a_task_passes_vertical_and_rests_right_side_up():
    """frc plan rhex_flip_drives, judged from the samples: the figures of the dedicated loop."""
    from frcontrol.planning.pump import pump_samples
    from frcontrol.planning.pump import within_limits as torques_within_limits

    rhex = scene("rhex_flip_drives")
    result = plan_task(rhex, max_time=2.0)
    traj = result.trajectory
    assert abs(crossing_time(traj, 2, 1.5 * np.pi) - PUMP_VERTICAL_TIME) <= 0.1 * PUMP_VERTICAL_TIME
    assert abs(traj.q[-1, 2] - 2 * np.pi) < 0.3  # right side up
    assert np.all(np.abs(traj.v[-1, :3]) <= 0.02)  # the body at rest (x, y, pitch)
    assert outside_the_phases_modes(result, rhex) == 0
    assert within_limits(traj, rhex) and torques_within_limits(pump_samples(rhex, traj))
    pushes = [r for r in result.run.records if r.name == "push"]
    assert len(pushes) >= 2 and result.run.records[-1].name == "land"  # pumped: more than one stroke
    strict = replace(result.task.phases[0], modes={**result.task.phases[0].modes, "front_corner": "F"})
    stricter = replace(result, task=replace(result.task, phases=(strict, *result.task.phases[1:])))
    assert outside_the_phases_modes(stricter, rhex) > 0  # the check can fail: the pivot slides (R)


@pytest.mark.slow
def test_the_climb_as_a_task_finds_frc_climbs_disturbance_scale():
    """The largest scale is checked by the engine on the climb's own lifted problem, at every vertex."""
    from frcontrol.engine import analyze
    from frcontrol.planning.climb import plan_climb
    from frcontrol.planning.disturbances import augmented_problem, load_disturbances

    snake = scene("snake_climb")
    result = plan_task(snake)
    found = result.to_dict(snake)["phases"][0]["largest_scale"]
    assert found["scale"] >= plan_climb(scene("snake_climb")).max_disturbance_scale
    dist = load_disturbances(snake)
    points = dist.robust_points(found["scale"])
    lifted = augmented_problem(snake, dist, points.min(axis=0) - 1.0, points.max(axis=0) + 1.0)
    analysis = analyze(lifted)
    u = np.array([found["inputs"][n] for n in snake.inputs.coordinates])
    head = snake.robot.point_kinematics(snake.q, snake.v, [("link8", np.array([0.2, 0.0]))])
    for v in points:
        (solution,) = solutions_at(analysis, np.concatenate([u, v]))
        assert solution.mode == "FFF"
        assert head.jacobians[0][1] @ solution.dv[: snake.robot.nv] + head.drifts[0][1] >= 1.0
    traj = result.trajectory
    assert traj.times[-1] == pytest.approx(0.1)  # the brace holds over the climb's whole horizon
    for contact in ("tail", "tip", "top"):
        assert np.all(loaded(traj, snake, contact))
        assert np.max(np.abs(travel(traj, snake, contact))) <= 1e-4
    assert within_limits(traj, snake)
    rest = np.zeros(snake.robot.nv)
    heights = [snake.robot.point_kinematics(q, rest, [("link8", np.array([0.2, 0.0]))]).positions[0][1]
               for q in traj.q]
    assert np.all(np.diff(heights) > 0)  # the head rises at every step (require: >= 1 m/s^2 up)


def test_track_is_least_squares_to_the_pd_target():
    """The pivoting rod's accelerations are alpha g (one direction): the plan's alpha is least squares'.

    Targets that no pivot reaches exactly (x, y and theta asked to move apart from the pivot's
    direction g): the weighted least-squares alpha is ``sum w_i^2 g_i a_i / sum w_i^2 g_i^2``; the
    L1 distance would be smallest at alpha = 1 (theta's own target) instead.
    """
    from frcontrol.engine import analyze

    rod = scene("rod_pivot")
    targets = {"x": rod.q[0] + 0.5, "y": rod.q[1], "theta": rod.q[2] + 1.0}
    weights = {"x": 1.0, "y": 2.0, "theta": 1.0}
    objective = Objective("track", targets=targets, stiffness=1.0, damping=0.0, weights=weights)
    decision = decide(rod, Phase("p", {"tip": "F"}, 0.05, False, objective, Until("time", time=1.0)))
    u = np.array([decision.inputs[n] for n in rod.inputs.coordinates])
    (solution,) = solutions_at(analyze(rod), u)
    assert solution.mode == "F"
    dv = solution.dv[:3]
    g = dv / dv[2]
    a = np.array([0.5, 0.0, 1.0])  # stiffness (target - q), the rod at rest
    w2 = np.array([1.0, 4.0, 1.0])
    assert dv[2] == pytest.approx(np.sum(w2 * g * a) / np.sum(w2 * g * g), abs=1e-3)
    assert not dv[2] == pytest.approx(1.0, abs=0.05)  # not the L1 optimum
    assert decision.objective == pytest.approx(float(np.sum(w2 * (dv - a) ** 2)), rel=1e-9)


def test_frc_plan_json_has_the_documented_keys():
    result = runner.invoke(app, ["plan", "box_slide", "--json", "--replan-every", "5"])
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    assert {"task", "phases", "outcome", "simulation"} <= set(doc)
    assert doc["task"]["phases"][0]["name"] == "slide"
    phase = doc["phases"][0]
    assert {"name", "start", "end", "why", "plans"} <= set(phase)
    assert {"mode", "inputs", "objective", "margin"} <= set(phase["plans"][0])
    assert {"times", "q", "v", "inputs", "forces", "modes"} <= set(doc["simulation"]["samples"])
    assert doc["outcome"] == {"achieved": True, "reason": None}


def test_an_infeasible_phase_says_which_mode_and_the_closest_margin():
    result = runner.invoke(app, ["plan", "box_slide", "--json", "--margin", "100", "-T", "0.01"])
    assert result.exit_code == 0, result.stderr
    outcome = json.loads(result.stdout)["outcome"]
    assert outcome["achieved"] is False and outcome["infeasible"]["phase"] == "slide"
    assert outcome["infeasible"]["closest_mode"] == "RR"
    assert 0 < outcome["infeasible"]["closest_margin"] < 100


TASK_SCENES = ("rod_pivot", "box_slide", "box_tip", "solo_shift", "solo_standup")
"""The shipped tasks as phases this module owns (the flip's and the climb's are compared above)."""


def _infeasible(name: str, how: str) -> tuple[object, dict]:
    """The scene, made infeasible ``how``, and its first decision's outcome (``frc plan -T 0``)."""
    base = scene(name)
    if how == "margin":
        loaded, options = base, ["--margin", "1000"]
    else:  # every input limited to +-1e-3: no allowed mode is feasible (the rod's pivot needs none)
        count = base.inputs.count
        loaded = load_scene(SCENES / f"{name}.toml", overrides={"inputs.lower": [-1e-3] * count,
                                                                "inputs.upper": [1e-3] * count})
        options = [f"--set=inputs.lower={[-1e-3] * count}", f"--set=inputs.upper={[1e-3] * count}"]
    result = runner.invoke(app, ["plan", name, "--json", "-T", "0", *options])
    assert result.exit_code == 0, result.stderr
    return loaded, json.loads(result.stdout)["outcome"]


@pytest.mark.parametrize(
    ("name", "how"),
    [(n, "margin") for n in TASK_SCENES] + [(n, "limits") for n in TASK_SCENES if n != "rod_pivot"],
)
def test_an_infeasible_task_says_which_phase_which_mode_and_the_closest_margin(name, how):
    from frcontrol.engine import analyze
    from frcontrol.planning.flip import margin_pieces

    loaded, outcome = _infeasible(name, how)
    task = read_task(loaded)
    phase = task.phases[0]
    infeasible = outcome["infeasible"]
    assert outcome["achieved"] is False and infeasible["phase"] == phase.name
    contacts = [c.name for c in loaded.contacts]  # every contact touches at the shipped states
    modes = [m["mode"] for m in infeasible["modes"]]
    assert modes and all(phase.allows(tuple(contacts), m) for m in modes) and all(
        m["why"] for m in infeasible["modes"])
    analysis = analyze(loaded)
    feasible = {m.mode for m in analysis.feasible_modes}
    if how == "limits":  # no allowed mode is feasible: the engine agrees, and no margin helps
        assert not feasible & set(modes) and infeasible["closest_margin"] is None
        return
    closest, mode = infeasible["closest_margin"], infeasible["closest_mode"]
    assert 0 < closest < 1000 and mode in modes
    assert margin_pieces(analysis, mode, closest)  # the engine finds unambiguous inputs at it ...
    assert not margin_pieces(analysis, mode, closest * 1.01)  # ... and none 1 % further in


def test_an_objective_floor_out_of_reach_is_the_reason():
    result = runner.invoke(
        app, ["plan", "box_slide", "--json", "-T", "0.002", "--set", "task.phases[0].maximize.at_least=1000"]
    )
    assert result.exit_code == 0, result.stderr
    outcome = json.loads(result.stdout)["outcome"]
    assert outcome["achieved"] is False
    assert outcome["infeasible"]["reason"] == "no allowed mode's unambiguous inputs reach at_least = 1000"


@pytest.mark.parametrize(
    ("assignment", "message"),
    [
        ("task.phases[0].modes.lefft=F", "did you mean 'left'"),
        ("task.phases[0].modes.left=FX", "^[SLRF]+$"),
        ("task.phases[0].maximize.coordinate=xx", "unknown coordinate 'xx'"),
        ("task.phases[0].until.coordinat=x", "did you mean 'coordinate'"),
        ("task.phases[0].minimize={coordinate='x'}", "exactly one of maximize, minimize, track"),
        ("task.phases[0].robust=true", "needs [[disturbances]]"),
        ("task.body_contacts=['left']", "not both"),
        ("task.phases[0].maximize={link='box', point=[0, 0]}", "direction"),
        ("task.phases[0].largest_scale={upper=2.0}", "add robust = true"),
        ("task.phases[0].largest_scale={upper=-2.0}", "largest_scale.upper"),
        ("task.phases[0].maximize.at_least='x'", "at_least"),
    ],
)
def test_bad_tasks_are_one_line_errors(assignment, message):
    result = runner.invoke(app, ["plan", "box_slide", "--set", assignment])
    assert result.exit_code == 1 and result.stdout == ""
    line = result.stderr.strip()
    assert line.startswith("frc: error: ") and "\n" not in line and message in line, line


def test_a_dedicated_planners_scene_is_refused_by_read_task(write_scene):
    text = (shipped_robots_dir() / "scenes" / "rhex_flip.toml").read_text()
    urdf = shipped_robots_dir() / "rhex_planar.urdf"
    text = text.replace('robot = "rhex_planar.urdf"', f'robot = "{urdf}"')
    task = text[text.index("[task]") : text.index("[inputs]")]
    dedicated = text.replace(task, '[task]\nbody_contacts = ["front_corner"]\n\n')
    with pytest.raises(SceneError, match="frc flip"):
        read_task(load_scene(write_scene(dedicated)))


DISTURBANCE = """
[[disturbances]]
name = "push"
link = "{link}"
point = [0.0, 0.0]
lower = [-0.5, -0.5]
upper = [0.5, 0.5]
"""
"""A small force [N] on the body's frame origin, for the robust phases."""


def _with_disturbance(name: str, tmp_path: Path):
    """The scene with :data:`DISTURBANCE` on its first contact's link."""
    base = scene(name)
    path = tmp_path / f"{name}.toml"
    text = (SCENES / f"{name}.toml").read_text()
    path.write_text(text + DISTURBANCE.format(link=base.contacts[0].point.link))
    return load_scene(path)


def _random_phase(
    rng: np.random.Generator, contacts: list[str], coordinates: list[str], robust: bool
) -> Phase:
    modes = {
        name: "".join(sorted(set(rng.choice(list(LETTERS), size=rng.integers(1, 4))), key=LETTERS.index))
        for name in contacts
        if rng.random() < 0.5
    }
    if rng.random() < 0.3:
        targets = {
            name: float(rng.normal(scale=0.1)) for name in rng.choice(coordinates, size=2, replace=False)
        }
        objective = Objective(
            "track", targets=targets, stiffness=float(rng.uniform(0, 50)), damping=float(rng.uniform(0, 10))
        )
    else:
        objective = Objective(
            str(rng.choice(["maximize", "minimize"])), coordinate=str(rng.choice(coordinates))
        )
    margin = float(rng.choice([0.0, 0.01, 0.1, 0.5]))
    return Phase("random", modes, margin, robust, objective, Until("time", time=1.0))


def _solutions(scene_, decision, robust: bool) -> list[list[str]]:
    """The engine's rigid solutions' modes at the decision's inputs: per disturbance vertex when robust."""
    from frcontrol.engine import analyze
    from frcontrol.modes import ContactProblem
    from frcontrol.planning.core.decision import lifted_problem
    from frcontrol.planning.disturbances import load_disturbances

    u = np.array([decision.inputs[n] for n in scene_.inputs.coordinates])
    if not robust:
        return [[s.mode for s in solutions_at(analyze(scene_), u)]]
    lifted, _ = lifted_problem(scene_, ContactProblem.from_scene(scene_), 0.0)
    analysis = analyze(lifted)
    points = load_disturbances(scene_).robust_points()
    return [[s.mode for s in solutions_at(analysis, np.concatenate([u, v]))] for v in points]


@pytest.mark.slow
@counted
def test_every_plan_said_unambiguous_has_exactly_one_solution_in_an_allowed_mode(tmp_path):
    """Random phases (allowed letters, margins up to 0.5, objectives; robust with a disturbance polytope)."""
    rng = np.random.default_rng(26)
    modes_seen, robust_checked = set(), 0
    for name in ("box_on_ground", "rod_on_table", "rod_pivot"):
        plain, disturbed = scene(name), _with_disturbance(name, tmp_path)
        contacts = [c.name for c in plain.contacts]
        for i in range(16):
            robust = i % 2 == 1
            base = disturbed if robust else plain
            phase = _random_phase(rng, contacts, list(base.coordinate_names), robust)
            decision = decide(base, phase)
            tally().example()
            if not decision.found:
                continue
            tally().check()
            for solved in _solutions(base, decision, robust):
                assert solved == [decision.mode], (name, phase, decision, solved)
                assert phase.allows(decision.contacts, solved[0]), (name, phase, decision)
            modes_seen.add(decision.mode)
            robust_checked += robust
    assert robust_checked >= 4 and len(modes_seen) >= 3  # both kinds of phase, several modes, are checked


def _imports(path: Path) -> list[tuple[str, list[str]]]:
    """(module imported, names imported) of every import in a file, resolved within frcontrol.planning."""
    tree = ast.parse(path.read_text())
    parts = list(path.relative_to(PLANNING.parent.parent).with_suffix("").parts)
    package = parts[:-1] if parts[-1] != "__init__" else parts[:-1]
    if parts[-1] == "__init__":
        package = parts[:-1]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            out.append((module, [a.name for a in node.names]))
        elif isinstance(node, ast.Import):
            out += [(a.name, []) for a in node.names]
    return out


PLANNING = Path(__import__("frcontrol.planning", fromlist=["x"]).__file__).parent


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PLANNING.parent.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)




def test_no_planner_imports_another_planners_private_names():
    found = set()
    for path in sorted(PLANNING.rglob("*.py")):
        here = _module_name(path)
        for module, names in _imports(path):
            if module.startswith("frcontrol.planning") and module != here:
                found |= {(here, module, n) for n in names if n.startswith("_")}
    assert not found, f"a planner imports another planning module's private names: {sorted(found)}"
    assert not [f for f in found if ".core" in f[0] or ".core" in f[1]]
    assert any(m.startswith("frcontrol.planning.core") for m in map(_module_name, PLANNING.rglob("*.py")))


def _graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for path in sorted(PLANNING.rglob("*.py")):
        here = _module_name(path)
        graph[here] = set()
        for module, names in _imports(path):
            for target in [module] + [f"{module}.{n}" for n in names]:
                if target.startswith("frcontrol.planning") and target != here:
                    graph[here].add(target)
    return {k: {t for t in v if t in graph and not k.startswith(t + ".")} for k, v in graph.items()}


def test_no_import_cycle_within_planning():
    cycles = circles(_graph())  # Tarjan's algorithm, as tests/test_architecture.py's
    assert not cycles, cycles
    assert circles({"a": {"b"}, "b": {"a"}, "c": {"a"}}) == [["a", "b"]]  # the check can fail


def test_require_caps_an_acceleration_judged_by_the_engine_and_the_samples(write_scene):
    """The rod pivots with its angular acceleration maximised but required at most half the free best.

    The engine's solution at the planned inputs, and the run's own velocity samples, show the cap
    held (within the rounding's effect), the pivot kept (tip F, loaded, no slip).
    """
    import tomllib

    from frcontrol.engine import analyze
    from frcontrol.planning.core.task import Requirement

    rod = scene("rod_pivot")
    free = decide(rod, read_task(rod).phases[0])
    cap = 0.5 * float(free.objective)
    theta = Objective("require", coordinate="theta")
    capped = decide(rod, replace(read_task(rod).phases[0], requires=(Requirement(theta, at_most=cap),)))
    u = np.array([capped.inputs[n] for n in rod.inputs.coordinates])
    (solution,) = solutions_at(analyze(rod), u)
    assert solution.mode == "F" and 0.9 * cap <= solution.dv[2] <= cap  # maximised up to the cap
    raw = tomllib.loads((shipped_robots_dir() / "scenes" / "rod_pivot.toml").read_text())
    raw["robot"] = str(shipped_robots_dir() / raw["robot"])
    raw["task"]["max_time"] = 0.1
    raw["task"]["phases"][0]["require"] = [{"coordinate": "theta", "at_most": cap}]
    run = load_scene(write_scene(raw))
    traj = plan_task(run, replan_every=1).trajectory  # a plan at every step: the cap at every step
    alpha = np.diff(traj.v[:, 2]) / np.diff(traj.times)
    assert np.all(alpha > 0.5 * cap) and np.max(alpha) <= cap * (1 + 1e-3)
    assert np.all(loaded(traj, run, "tip")) and np.max(np.abs(travel(traj, run, "tip"))) <= SLIP_DISTANCE


def test_a_requirement_needs_a_bound(write_scene):
    import tomllib

    raw = tomllib.loads((shipped_robots_dir() / "scenes" / "rod_pivot.toml").read_text())
    raw["robot"] = str(shipped_robots_dir() / raw["robot"])
    raw["task"]["phases"][0]["require"] = [{"coordinate": "theta"}]
    with pytest.raises(SceneError, match="at_least = X or at_most = X") as info:
        load_scene(write_scene(raw))
    assert info.value.field == "task.phases[0].require[0]"
