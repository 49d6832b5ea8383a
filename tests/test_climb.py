"""The snake climb planner: robustness checked independently, the scale, the contract, bad input."""

from __future__ import annotations

import copy
import itertools
import json
import math
import re
import tomllib
from dataclasses import replace

import numpy as np
import pytest
import typer
from conftest import ROBOTS
from frcontrol.cli.app import app as frc_app
from frcontrol.cli.climb_cmd import climb_command
from typer.testing import CliRunner

from frcontrol.engine import solutions_at
from frcontrol.errors import InputError, SceneError
from frcontrol.model import ContactPoint, PlanarRobot
from frcontrol.modes import ContactProblem
from frcontrol.planning.climb import plan_climb
from frcontrol.planning.climb_check import BRACE_SLIP_TOLERANCE, ClimbCheckSettings, simulate_climb
from frcontrol.planning.climb_problem import build_climb, check_scale
from frcontrol.planning.disturbances import load_disturbances
from frcontrol.planning.exclusions import mode_exclusions
from frcontrol.scene import load_scene

runner = CliRunner()
SNAKE = ROBOTS / "scenes" / "snake_climb.toml"


def climb_app() -> typer.Typer:
    """``frc climb`` in an app of its own (the main app registers it separately)."""
    app = typer.Typer()

    @app.callback()
    def _root() -> None:
        """frc."""

    app.command("climb")(climb_command)
    return app


def snake_dict() -> dict:
    raw = tomllib.loads(SNAKE.read_text())
    raw["robot"] = str(ROBOTS / "snake_planar.urdf")
    return raw


@pytest.fixture(scope="module")
def scene():
    return load_scene("snake_climb")


@pytest.fixture(scope="module")
def plan(scene):
    return plan_climb(scene)


def independent_problem(scene, bound: float = 1e4) -> tuple[ContactProblem, np.ndarray]:
    """The lifted problem built here, not by the planner: point Jacobians from a robot of our own.

    Returns the problem (inputs: torques, then fx, fy per disturbance, limits +-bound) and the head's
    vertical Jacobian row J_y.
    """
    raw = snake_dict()
    points = [(d["link"], d["point"]) for d in raw["disturbances"]] + [("link8", [0.2, 0.0])]
    contacts = [ContactPoint(f"p{i}{axis}", link, np.array(point, float), np.array(normal), np.zeros(2), 0.0)
                for i, (link, point) in enumerate(points)
                for axis, normal in (("x", (1.0, 0.0)), ("y", (0.0, 1.0)))]
    robot = PlanarRobot(ROBOTS / "snake_planar.urdf", "planar", 9.81, contacts)
    jac = robot.state(scene.q, scene.v).jacobian_normal
    base = ContactProblem.from_scene(scene)
    k = 2 * len(raw["disturbances"])
    problem = replace(base, inputs=base.inputs + tuple(f"d{i}" for i in range(k)),
                      input_map=np.hstack([base.input_map, jac[:k].T]),
                      lower=np.concatenate([base.lower, np.full(k, -bound)]),
                      upper=np.concatenate([base.upper, np.full(k, bound)]))
    return problem, jac[k + 1]


def polytope_points(raw: dict, scale: float, count: int, rng: np.random.Generator) -> np.ndarray:
    """The vertices of scale * P (product of the tables' boxes / polygons) and random interior points."""
    polygons = []
    for d in raw["disturbances"]:
        if "vertices" in d:
            polygons.append(np.array(d["vertices"], float))
        else:
            lo, hi = d["lower"], d["upper"]
            polygons.append(np.array([[x, y] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])], float))
    vertices = np.array([np.concatenate(combo) for combo in itertools.product(*polygons)])
    interior = [np.concatenate([rng.dirichlet(np.ones(len(p))) @ p for p in polygons]) for _ in range(count)]
    return scale * np.vstack([vertices, np.array(interior)])


# ----------------------------------------------------------------------------------- the plan
def test_plan_on_the_snake(plan):
    assert plan.found and plan.robust, plan.reason
    assert plan.mode == "FFF" and plan.nominal_feasible and plan.scale == 1.0
    assert list(plan.torques) == [f"j{i}" for i in range(1, 9)]
    assert all(-20.0 <= x <= 20.0 for x in plan.torques.values())
    assert all(round(x, 3) == x for x in plan.torques.values())
    assert plan.robustness_radius >= plan.margin
    assert plan.worst_head_acceleration >= plan.min_head_acceleration
    assert plan.head_acceleration >= plan.worst_head_acceleration
    assert abs(plan.head_sideways_acceleration) < 0.05  # zero before rounding
    assert len(plan.exclusions) == 63 and not any(e.held for e in plan.exclusions)
    assert plan.pieces >= 1 and plan.max_disturbance_scale > 1.0


def test_robust_for_every_vertex_and_interior_point_checked_independently(scene, plan):
    """solutions_at on a lifted problem built here: one solution, FFF, the head rising."""
    problem, head_y = independent_problem(scene)
    rng = np.random.default_rng(7)
    points = polytope_points(snake_dict(), 1.0, 12, rng)
    assert len(points) == 4 * 3 + 12
    u = np.array(list(plan.torques.values()))
    for d in points:
        solutions = solutions_at(problem, np.concatenate([u, d]))
        assert [s.mode for s in solutions] == ["FFF"], d
        (s,) = solutions
        assert head_y @ s.dv >= plan.min_head_acceleration  # v = 0: no drift
        assert np.all(s.lambda_n > 0) and np.all(np.abs(s.lambda_t) < 0.6 * s.lambda_n)
        assert s.equality_residual < 1e-8


def test_the_robust_set_is_exact_not_only_at_vertices(scene, plan):
    """At torques that hold FFF at every vertex of a segment of disturbances, another mode may hold in
    between only if the exclusion LP says so: the LP agrees with solutions_at on a fine sampling."""
    problem, _ = independent_problem(scene)
    cp = plan.problem
    u = np.zeros(8)  # a limp snake: the brace does not hold; some other mode does
    points = np.zeros((1, 4))
    held = {e.mode for e in mode_exclusions(cp.problem, cp.mode, u, points, systems=cp.systems)
            if e.held}
    found = {s.mode for s in solutions_at(problem, np.concatenate([u, np.zeros(4)]))}
    assert held == found - {"FFF"} and held
    # over a whole polytope: the modes the LP says hold somewhere are found at some sample
    rng = np.random.default_rng(3)
    torques = rng.uniform(-3, 3, 8)
    segment = np.array([[0.0, 0.0, -30.0, 0.0], [0.0, 0.0, 30.0, 10.0]])
    held = {e.mode for e in mode_exclusions(cp.problem, cp.mode, torques, segment, systems=cp.systems)
            if e.held}
    sampled: set[str] = set()
    for lam in np.linspace(0.0, 1.0, 61):
        d = (1 - lam) * segment[0] + lam * segment[1]
        sampled |= {s.mode for s in solutions_at(problem, np.concatenate([torques, d]))}
    assert sampled - {"FFF"} <= held
    assert held, "the test needs a case where some mode holds"


def test_largest_scale_within_the_bisection_tolerance(scene, plan):
    s = plan.max_disturbance_scale
    tol = plan.tolerances["scale_tolerance"] * max(plan.scale_bound, 1.0)
    lo, hi = plan.scale_bracket
    assert lo == s and hi - lo <= tol and s <= plan.scale_bound
    cp = plan.problem
    below = check_scale(cp, s - tol)
    assert below.robust and below.radius >= cp.margin
    for solver in ("highs", "daqp"):
        above = check_scale(cp, s + tol, solver=solver)
        assert not above.lp_feasible and above.torques is None
    # the largest scale's torques, checked independently at the vertices of s P
    problem, head_y = independent_problem(scene)
    u = np.array(list(plan.max_scale_torques.values()))
    for d in polytope_points(snake_dict(), s, 4, np.random.default_rng(1)):
        solutions = solutions_at(problem, np.concatenate([u, d]))
        assert [x.mode for x in solutions] == ["FFF"]
        assert head_y @ solutions[0].dv >= plan.min_head_acceleration


def test_frc_analyze_at_the_rounded_torques_gives_exactly_fff(plan):
    args = ["analyze", "snake_climb", "--json"]
    for name, value in plan.torques.items():
        args += ["--input", f"{name}={value}"]
    result = runner.invoke(frc_app, args)
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    assert [s["mode"] for s in doc["solutions"]] == ["FFF"]


def test_simulation_holds_the_brace(scene, plan):
    short = simulate_climb(scene, plan)
    assert short.status == "completed" and short.brace_held
    assert short.upper_rise > 0.0 and short.max_upper_rise >= short.upper_rise
    for seed in (1, 2):
        result = simulate_climb(scene, plan, ClimbCheckSettings(duration=0.3, seed=seed))
        assert result.brace_held and result.max_slip <= BRACE_SLIP_TOLERANCE
        assert not [e for e in result.brace_events if e.kind in ("open", "slip")]
        assert len(result.disturbance_samples) == 6 and np.any(result.disturbance_samples != 0)


def test_simulation_detects_a_brace_that_slips(scene, plan):
    """The check can fail: limp torques let the brace go."""
    limp = replace(plan, torques=dict.fromkeys(plan.torques, 0.0))
    result = simulate_climb(scene, limp, ClimbCheckSettings(duration=0.1, scale=0.0))
    assert not result.brace_held and result.max_slip > BRACE_SLIP_TOLERANCE


# ----------------------------------------------------------------------------------- the CLI
def test_json_contract(scene, plan):
    """frc climb is frc plan on the climb's task: its keys, plus the climb's, judged by the engine."""
    from frcontrol.engine import analyze
    from frcontrol.planning.disturbances import augmented_problem

    result = runner.invoke(climb_app(), ["climb", "--json"])
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    contract = {"mode", "torques", "max_disturbance_scale", "robust", "simulation", "outcome", "phases"}
    assert contract <= set(doc)
    assert doc["mode"] == "FFF" and doc["robust"] is True and doc["outcome"]["achieved"] is True
    assert doc["torques"] == doc["phases"][0]["plans"][0]["inputs"]  # the run's first plan
    assert doc["max_disturbance_scale"] >= plan.max_disturbance_scale  # the dedicated planner's 9.78
    dist = load_disturbances(scene)
    points = dist.robust_points()
    analysis = analyze(augmented_problem(scene, dist, points.min(axis=0) - 1.0, points.max(axis=0) + 1.0))
    u = np.array([doc["torques"][n] for n in scene.inputs.coordinates])
    for v in points:  # robust: exactly FFF at every disturbance vertex, at the printed torques
        assert [s.mode for s in solutions_at(analysis, np.concatenate([u, v]))] == ["FFF"]
    sim = doc["simulation"]
    assert {"brace_held", "max_slip", "upper_rise", "samples"} <= set(sim)
    assert sim["brace_held"] is True and isinstance(sim["max_slip"], float) and sim["upper_rise"] > 0
    assert sim["duration"] == pytest.approx(0.1) and sim["max_slip"] <= BRACE_SLIP_TOLERANCE
    forces = np.array(sim["samples"]["forces"])[1:, :3, 0]
    assert np.all(forces > 0)  # the samples: every brace contact loaded at every step


def test_table_and_files(tmp_path):
    pytest.importorskip("matplotlib")
    plot = tmp_path / "climb.png"
    html = tmp_path / "climb.html"
    result = runner.invoke(climb_app(), ["climb", "snake_climb", "--plot", str(plot), "--html", str(html),
                                         "--duration", "0.02"])
    assert result.exit_code == 0, result.stderr
    assert "FFF" in result.stdout and "largest disturbance scale" in result.stdout
    assert plot.stat().st_size > 1000 and html.stat().st_size > 1000


# ----------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("table, field", [
    ({"lower": [1.0, 0.0], "upper": [0.0, 1.0]}, "disturbances[0].lower[0]"),
    ({"vertices": []}, "disturbances[0].vertices"),
    ({"lower": [-math.inf, 0.0], "upper": [1.0, 1.0]}, "disturbances[0].lower[0]"),
    ({"lower": [0.0, 0.0], "upper": [1.0, math.nan]}, "disturbances[0].upper[1]"),
    ({"vertices": [[0.0, 1.0], [math.inf, 0.0]]}, "disturbances[0].vertices[1][0]"),
    ({"link": "tail", "lower": [0.0, 0.0], "upper": [1.0, 1.0]}, "disturbances[0].link"),
    ({"lower": [0.0, 0.0], "upper": [1.0, 1.0], "vertices": [[0.0, 0.0]]}, "disturbances[0].vertices"),
    ({}, "disturbances[0]"),
    ({"lower": [0.0, 0.0]}, "disturbances[0].upper"),
    ({"lower": [0.0, 0.0], "upper": [1.0, 1.0], "force": 3}, "disturbances[0].force"),
    ({"lower": [0.0, 0.0], "upper": [1.0, 1.0], "point": [0.1]}, "disturbances[0].point"),
])
def test_bad_disturbance_tables(table, field, write_scene):
    raw = snake_dict()
    entry = {"name": "push", "link": "link8", "point": [0.2, 0.0]}
    entry.update(table)
    if "point" in table:
        entry["point"] = table["point"]
    raw["disturbances"] = [entry]
    # strict scenes: the table is checked when the scene is loaded, before any planner reads it
    with pytest.raises(SceneError, match=r"disturbances") as info:
        load_scene(write_scene(raw))
    assert info.value.field == field


def test_missing_and_duplicate_disturbances(write_scene):
    raw = snake_dict()
    del raw["disturbances"]
    with pytest.raises(SceneError, match="missing"):
        plan_climb(load_scene(write_scene(raw)))
    raw = snake_dict()
    raw["disturbances"][1]["name"] = "head_push"
    with pytest.raises(SceneError, match="duplicate") as info:
        load_disturbances(load_scene(write_scene(raw)))
    assert info.value.field == "disturbances[1].name"


def test_bad_task_tables(write_scene):
    for task, field in (({"brace_contacts": ["tail", "tip"]}, "task.brace_contacts"),
                        ({"brace_contacts": ["tail", "tip", "nose"]}, "task.brace_contacts[2]"),
                        ({"head_link": "skull"}, "task.head_link"),
                        ({"min_head_acceleration": "fast"}, "task.min_head_acceleration")):
        raw = snake_dict()
        raw["task"] = task
        with pytest.raises(SceneError, match=re.escape(field)) as info:
            plan_climb(load_scene(write_scene(raw)))
        assert info.value.field == field


def test_bad_disturbance_is_one_line_and_exit_1(write_scene):
    raw = snake_dict()
    raw["disturbances"][0]["upper"] = [-5.0, 3.0]
    result = runner.invoke(climb_app(), ["climb", str(write_scene(raw))])
    assert result.exit_code == 1
    assert "disturbances[0].lower[0]" in result.stderr and "empty" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_torque_limits_that_leave_nothing_feasible(write_scene):
    raw = snake_dict()
    raw["inputs"]["lower"] = [-0.5] * 8
    raw["inputs"]["upper"] = [0.5] * 8
    path = write_scene(raw)
    plan = plan_climb(load_scene(path))
    assert not plan.found and not plan.robust and not plan.torques
    assert "torque limits" in plan.reason
    result = runner.invoke(climb_app(), ["climb", str(path)])  # no plan is an answer: exit 0
    assert result.exit_code == 0 and "no climb plan" in result.stdout
    result = runner.invoke(climb_app(), ["climb", str(path), "--json"])
    doc = json.loads(result.stdout)
    assert result.exit_code == 0 and not doc["found"] and doc["outcome"]["infeasible"]["phase"] == "brace"


def test_a_brace_with_an_indeterminate_squeeze_is_refused(write_scene):
    """With j1 locked the brace has five coordinates for six rows: FFF has an ambiguity variable."""
    raw = snake_dict()
    raw["locked_joints"] = ["j1"]
    raw["inputs"] = {"coordinates": [f"j{i}" for i in range(2, 9)], "lower": [-20.0] * 7,
                     "upper": [20.0] * 7}
    plan = plan_climb(load_scene(write_scene(raw)))
    assert not plan.found and "ambiguity variable" in plan.reason


def test_nominal_scale_infeasible_plans_at_the_largest(write_scene):
    raw = snake_dict()
    raw["disturbances"][1]["vertices"] = [[20 * x for x in v] for v in raw["disturbances"][1]["vertices"]]
    plan = plan_climb(load_scene(write_scene(raw)))
    assert plan.found and plan.robust and not plan.nominal_feasible
    assert plan.scale == plan.max_disturbance_scale < 1.0


def test_polygons_are_convex_hulls(write_scene):
    raw = snake_dict()
    raw["disturbances"] = [
        {"name": "square", "link": "link8", "point": [0.2, 0.0],
         "vertices": [[1.0, 1.0], [-1.0, 1.0], [0.0, 0.0], [-1.0, -1.0], [1.0, -1.0], [1.0, 1.0],
                      [0.5, 1.0]]},
        {"name": "segment", "link": "link5", "point": [0.1, 0.0],
         "vertices": [[0.0, 0.0], [2.0, 2.0], [1.0, 1.0]]},
        {"name": "constant", "link": "link2", "point": [0.0, 0.0], "vertices": [[0.0, -3.0]]},
    ]
    dist = load_disturbances(load_scene(write_scene(raw)))
    square, segment, constant = dist.items
    assert {tuple(v) for v in square.vertices} == {(1, 1), (-1, 1), (-1, -1), (1, -1)}
    assert {tuple(v) for v in segment.vertices} == {(0, 0), (2, 2)}
    assert constant.vertices.tolist() == [[0.0, -3.0]]
    assert dist.names == ("square.fx", "square.fy", "segment.fx", "segment.fy", "constant.fx", "constant.fy")
    assert dist.vertices(2.0).shape == (8, 6)
    assert not dist.contains_zero()  # the constant push: the zero disturbance is added to V_s
    points = dist.robust_points(1.0)
    assert points.shape == (9, 6) and not np.any(points[0])


def test_bad_arguments(scene):
    with pytest.raises(InputError, match="margin"):
        build_climb(scene, margin=-1.0)
    with pytest.raises(InputError, match="scale"):
        plan_climb(scene, scale=math.nan)
    limp = plan_climb(copy.copy(scene), margin=1e3)
    assert not limp.found
    with pytest.raises(InputError, match="not found"):
        simulate_climb(scene, limp)
