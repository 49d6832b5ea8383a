"""The RHex flip planner: unambiguity with a margin, optimality against brute force, the worst case
over within-mode ambiguity, the closed loop, and the command line."""

from __future__ import annotations

import json
import math
import socket
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import one_error_line
from typer.testing import CliRunner

from frcontrol.engine import solutions_at
from frcontrol.errors import InputError, SceneError
from frcontrol.planning.flip import (
    DEFAULT_MARGIN,
    TORQUE_ROUNDING,
    FlipPlan,
    FlipSettings,
    flip_task,
    margin_pieces,
    maximise_pitch,
    plan_flip,
    worst_case_pitch,
)
from frcontrol.planning.flip_loop import simulate_flip
from frcontrol.polytope import Polytope, chebyshev_ball
from frcontrol.scene import load_scene, resolve_scene_path
from frcontrol.solvers import qp_problem, solve_qp

runner = CliRunner()
PITCH = 2  # theta's index in RHex's coordinates (x, y, theta, hip_middle, hip_rear)
DIRECTIONS = np.array([[math.cos(a), math.sin(a)] for a in np.linspace(0, 2 * math.pi, 16, endpoint=False)])


@pytest.fixture(scope="module")
def rhex():
    """The shipped RHex scene at 10 N m per hip pair, below the 13.4 N m the scene ships (a pair of
    RHex's motors) and below the 13.29 N m at which the closed loop still flips."""
    return with_limits(load_scene("rhex_flip"), [-10.0, -10.0], [10.0, 10.0])


@pytest.fixture(scope="module")
def plan(rhex):
    return plan_flip(rhex)


def rhex_text(*, inputs: bool = True) -> str:
    """The shipped RHex scene's TOML, its robot by absolute path (to be written elsewhere)."""
    path = resolve_scene_path("rhex_flip")
    text = path.read_text().replace('robot = "rhex_planar.urdf"',
                                    f'robot = "{path.parent.parent / "rhex_planar.urdf"}"')
    text = text.replace("[-13.4, -13.4]", "[-10.0, -10.0]").replace("[13.4, 13.4]", "[10.0, 10.0]")
    return text if inputs else text[: text.index("[inputs]")]


def with_limits(scene, lower, upper):
    """The scene with other torque limits (a new Inputs; the scene file is untouched)."""
    return replace(scene, inputs=replace(scene.inputs, lower=np.array(lower, float),
                                         upper=np.array(upper, float)))


def app():
    """The real ``frc`` group (``frc flip`` in it): its one-line usage errors and error lines."""
    from frcontrol.cli.app import app as frc_app

    return frc_app


def unique_mode(analysis, u):
    """(mode, pitch) of the single rigid solution at u, or None if there are none or several."""
    solutions = solutions_at(analysis, u)
    if len(solutions) != 1:
        return None
    return solutions[0].mode, float(solutions[0].dv[PITCH])


def distance_to(T, p):
    """Euclidean distance from p to the polytope T (a QP with HiGHS: independent of the planner)."""
    A_eq = T.A_eq if T.A_eq.shape[0] else None
    b_eq = T.b_eq if T.A_eq.shape[0] else None
    result = solve_qp(qp_problem(np.eye(2), -p, T.A, T.b, A_eq, b_eq), solver="highs")
    assert result.found, result.status
    return float(np.linalg.norm(result.x - p))


def admissible(analysis, u, radius, candidates):
    """The rigid model predicts one mode, a candidate, everywhere within ``radius`` of u (inside the
    limits: a limit is not a mode boundary, nothing lies beyond it).

    Exact for the other modes (every other feasible mode's T_j is at least ``radius`` away, by a
    QP); by sampling for the inputs with no rigid solution at all (the disk at 16 directions and 4
    radii): None if not admissible, else (mode, pitch) at u.
    """
    centre = unique_mode(analysis, u)
    if centre is None or centre[0] not in candidates:
        return None
    for mode in analysis.feasible_modes:
        if mode.mode != centre[0] and distance_to(mode.input_domain, u) < radius:
            return None
    lower, upper = analysis.problem.lower, analysis.problem.upper
    for fraction in (0.25, 0.5, 0.75, 1.0):
        for d in DIRECTIONS:
            p = u + fraction * radius * d
            if np.any(p < lower) or np.any(p > upper):
                continue
            if unique_mode(analysis, p) is None:
                return None
    return centre


# ------------------------------------------------------------------------------------ the plan


def test_task_of_the_rhex_scene(rhex):
    task = flip_task(rhex)  # as phases: the first phase's contacts on its pivot's link, its maximised pitch
    assert task.body_contacts == ("front_corner", "rear_corner") and task.pitch == "theta"
    assert task.pitch_index == PITCH and task.vertical == pytest.approx(1.5 * math.pi)


def test_plan_is_unambiguous_at_the_printed_torques(rhex, plan):
    assert plan.found and plan.unambiguous and plan.reason is None
    assert plan.margin == DEFAULT_MARGIN and not plan.worst_case
    assert set(plan.torques) == {"hip_middle", "hip_rear"}
    u = np.array([plan.torques["hip_middle"], plan.torques["hip_rear"]])
    # rounded as printed: the value typed back is the value checked
    for x in u:
        assert float(f"{x:.4f}") == x and abs(x / TORQUE_ROUNDING - round(x / TORQUE_ROUNDING)) < 1e-9
    # an independent enumeration (not the plan's analysis) finds exactly one solution, the plan's
    (solution,) = solutions_at(rhex, {"hip_middle": u[0], "hip_rear": u[1]})
    assert solution.mode == plan.mode
    assert abs(solution.dv[PITCH] - plan.pitch_acceleration) <= 1e-9 * (1 + abs(plan.pitch_acceleration))
    assert plan.pitch_acceleration > 0
    # the body contact that touches (the front corner, the first letter) is loaded, not S
    assert plan.contacts[0] == "front_corner" and plan.mode[0] in "FLR"
    assert solution.lambda_n[0] > 0
    # the whole margin ball (inside the limits) predicts the same single mode
    assert admissible(plan.analysis, u, 0.999 * plan.margin, {plan.mode}) is not None


def test_frc_analyze_at_the_plan_gives_that_one_solution(plan):
    from frcontrol.cli.app import app as frc

    args = ["analyze", "rhex_flip", "--json"]
    for name, value in plan.torques.items():
        args += ["--input", f"{name}={value:.4f}"]
    result = runner.invoke(frc, args)
    assert result.exit_code == 0, result.stderr
    (solution,) = json.loads(result.stdout)["solutions"]
    assert solution["mode"] == plan.mode
    assert solution["dv"][PITCH] == pytest.approx(plan.pitch_acceleration, rel=1e-9)


def test_branch_and_bound_gives_the_exhaustive_plan(rhex, plan):
    full = plan_flip(rhex, settings=FlipSettings(exhaustive=True))
    assert (full.mode, dict(full.torques), full.pitch_acceleration) == (
        plan.mode, dict(plan.torques), plan.pitch_acceleration)
    # exhaustive: every candidate whose shrunk T_c is not empty (bound > -inf) is explored
    assert set(full.explored) == {c for c in full.candidates if full.bounds[c] > -math.inf}
    assert len(plan.explored) < len(full.explored)
    # every candidate's bound (the LP over its shrunk T_c) bounds its pieces
    for piece in full.pieces:
        assert piece.pitch_acceleration <= full.bounds[piece.mode] + 1e-9


def test_every_piece_keeps_the_margin(rhex):
    """Vertices and centres of every piece: one solution, in the piece's mode, on the whole ball."""
    full = plan_flip(rhex, settings=FlipSettings(exhaustive=True))
    analysis = full.analysis
    assert len(full.pieces) >= 3
    for piece in full.pieces:
        region = piece.region
        ball = chebyshev_ball(region)
        points = [ball.center] + list(_vertices_2d(region))
        for p in points:
            assert admissible(analysis, p, 0.999 * full.margin, {piece.mode}) is not None, (piece.mode, p)


def _vertices_2d(P):
    A, b = P.A, P.b
    out = []
    for i in range(len(A)):
        for j in range(i + 1, len(A)):
            M = A[[i, j]]
            if abs(np.linalg.det(M)) < 1e-12:
                continue
            v = np.linalg.solve(M, b[[i, j]])
            if np.all(A @ v <= b + 1e-9):
                out.append(v)
    return out


def test_lower_dimensional_modes_are_kept_at_a_distance(rhex):
    """The toe-S modes of the massless legs hold on hip torque = 0 (a line): no piece comes nearer."""
    full = plan_flip(rhex, settings=FlipSettings(exhaustive=True))
    flat = full.analysis.lower_dimensional_modes()
    assert flat and all(m.response.E.shape[0] >= 1 for m in flat)
    hulls = {tuple(np.round(np.abs(m.response.E[0]), 9)) for m in flat}
    assert hulls == {(1.0, 0.0), (0.0, 1.0)}  # hip_middle = 0 or hip_rear = 0
    for piece in full.pieces:
        for v in _vertices_2d(piece.region):
            assert min(abs(v[0]), abs(v[1])) >= full.margin - 1e-9 or _beyond_segments(v, flat, full)
    # the pieces next to hip_middle = 0 (RRL, RRF, LRR) stop exactly at the margin
    assert any(abs(abs(p.optimum[0]) - full.margin) < 1e-9 for p in full.pieces)


def _beyond_segments(v, flat, plan):
    """v is at least the margin away from every flat T_j it is near (beyond its segment's ends)."""
    for m in flat:
        T = m.input_domain
        if np.all(np.abs(T.A_eq @ v - T.b_eq) < plan.margin - 1e-9):
            if not np.any(T.A @ v - T.b >= plan.margin * np.linalg.norm(T.A, axis=1) - 1e-9):
                return False
    return True


def test_no_admissible_grid_point_beats_the_plan(rhex, plan):
    """Brute force over the input box: the pitch of every input whose unique solution keeps the
    body loaded, on a ball of radius 2 margin, is at most the plan's. (Radius 2 margin: the
    planner grows the other modes' sets row by row, which near a corner of angle phi between the
    rows' normals reaches m / cos(phi / 2) <= 2 m for phi <= 120 degrees.)"""
    analysis = plan.analysis
    candidates = set(plan.candidates)
    grid = np.linspace(-10.0, 10.0, 41)
    best, count = -np.inf, 0
    for a in grid:
        for b in grid:
            u = np.array([a, b])
            found = unique_mode(analysis, u)
            if found is None or found[0] not in candidates:
                continue
            count += 1
            if found[1] > plan.pitch_acceleration + 1e-6:
                assert admissible(analysis, u, 2 * plan.margin, candidates) is None, (u, found)
            best = max(best, found[1])
    assert count > 100
    # the plan is the best unique input of the grid (it sits on the box's corner)
    assert best == pytest.approx(plan.pitch_acceleration, rel=1e-9)


def test_margin_moves_the_plan_off_a_mode_boundary(rhex):
    """At +-13.4 N m, hip_rear >= -11.83 N m leaves a sliver of RLL (0.02 N m wide) at the corner
    where the pitch is largest. Without a margin the plan takes the corner; with 0.05 N m, RLL has
    no room and the plan is RFL, held 0.05 N m off the RLL boundary (the LP optimum would sit on
    it)."""
    scene = with_limits(rhex, [-13.4, -11.83], [13.4, 13.4])
    bare = plan_flip(scene, margin=0.0)
    assert bare.found and bare.mode == "RLL"
    assert dict(bare.torques) == {"hip_middle": -13.4, "hip_rear": -11.83}
    kept = plan_flip(scene, margin=0.05)
    assert kept.found and kept.mode == "RFL" and kept.unambiguous
    assert kept.pitch_acceleration < bare.pitch_acceleration
    u = np.array(list(kept.torques.values()))
    rll = kept.analysis.mode("RLL").input_domain
    # distance from the RLL boundary line (its non-limit row): the margin, to the rounding
    a, b = next((row, rhs) for row, rhs in zip(rll.A, rll.b, strict=True) if abs(row[1]) > 0.5)
    assert (a @ u - b) / np.linalg.norm(a) == pytest.approx(0.05, abs=TORQUE_ROUNDING)
    # brute force along the lines next to the limit where the optimum lies
    analysis = kept.analysis
    candidates = set(kept.candidates)
    for u1 in (-13.4, -13.39, -13.35):
        for u2 in np.linspace(-11.83, -11.48, 141):
            p = np.array([u1, u2])
            found = unique_mode(analysis, p)
            if found and found[0] in candidates and found[1] > kept.pitch_acceleration + 1e-6:
                assert admissible(analysis, p, 2 * 0.05, candidates) is None, p
    assert admissible(analysis, u, 0.999 * 0.05, {"RFL"}) is not None


def test_pieces_of_a_mode_are_disjoint_and_inside_its_domain(rhex, plan):
    pieces = margin_pieces(plan.analysis, "FFF", 0.05)
    T = plan.analysis.mode("FFF").input_domain
    rng = np.random.default_rng(0)
    for piece in pieces:
        for v in _vertices_2d(piece):
            assert np.all(T.A @ v <= T.b + 1e-9)
    samples = rng.uniform(-10, 10, size=(4000, 2))
    inside = np.array([[np.all(p.A @ s <= p.b - 1e-9) for p in pieces] for s in samples])
    assert inside.any() and np.all(inside.sum(axis=1) <= 1)  # interiors do not overlap


# ------------------------------------------------------------------------------- worst case


def fake_mode(X_u, X_w, x_0, A, b, name="F"):
    """What maximise_pitch reads of a mode: its response and its domain over (u, w)."""
    response = SimpleNamespace(X_u=np.array(X_u, float), X_w=np.array(X_w, float),
                               x_0=np.array(x_0, float))
    return SimpleNamespace(mode=name, response=response, domain=Polytope(A, b), m=np.array(X_u).shape[1])


def test_worst_case_when_the_pitch_depends_on_w():
    """pitch = 0.1 u1 - 0.05 u2 + w with |u1 + u2| <= w <= 3 on the box |u| <= 1: the worst case,
    0.1 u1 - 0.05 u2 + |u1 + u2|, is convex; its maximum over the box is at the vertex (1, 1):
    2.05. Treating w as a decision (the best case) would promise 3.05 at (1, 1)."""
    A = [[1, 1, -1], [-1, -1, -1], [0, 0, 1], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]]
    b = [0, 0, 3, 1, 1, 1, 1]
    mode = fake_mode([[0.1, -0.05]], [[1.0]], [0.0], A, b)
    box = Polytope.from_box([-1, -1], [1, 1])
    piece = maximise_pitch(mode, box, 0)
    assert piece.worst_case
    assert piece.pitch_acceleration == pytest.approx(2.05, abs=1e-9)
    np.testing.assert_allclose(piece.optimum, [1.0, 1.0], atol=1e-9)
    # brute force: the worst case on a grid never beats the vertex
    grid = np.linspace(-1, 1, 21)
    values = [worst_case_pitch(mode, 0, np.array([x, y])) for x in grid for y in grid]
    assert max(values) == pytest.approx(2.05, abs=1e-9)
    assert worst_case_pitch(mode, 0, np.array([0.0, 0.0])) == pytest.approx(0.0, abs=1e-12)
    assert worst_case_pitch(mode, 0, np.array([0.5, -0.5])) == pytest.approx(0.075, abs=1e-9)


def test_pitch_without_w_is_one_lp():
    A = [[1, 0], [-1, 0], [0, 1], [0, -1]]
    mode = fake_mode([[2.0, -1.0]], np.zeros((1, 0)), [0.5], A, [1, 1, 1, 1])
    piece = maximise_pitch(mode, Polytope.from_box([-1, -1], [1, 1]), 0)
    assert not piece.worst_case and piece.pitch_acceleration == pytest.approx(3.5)
    np.testing.assert_allclose(piece.optimum, [1.0, -1.0], atol=1e-9)


# ------------------------------------------------------------------------------ no flip, errors


def test_tight_limits_are_no_flip_not_an_error(rhex):
    result = plan_flip(with_limits(rhex, [-0.01, -0.01], [0.01, 0.01]))
    assert isinstance(result, FlipPlan) and not result.found and not result.unambiguous
    assert "0.05 N m" in result.reason
    flip = simulate_flip(with_limits(rhex, [-0.01, -0.01], [0.01, 0.01]), plan=result)
    assert not flip.flipped and flip.trajectory is None and flip.reason == result.reason


def test_toes_that_cannot_push_give_no_flip(rhex):
    """With hip_middle >= 0 the toes can at best hold the body still: FFF is the only candidate,
    and no input holds it unambiguously (another mode shares every input of its domain there)."""
    result = plan_flip(with_limits(rhex, [0.0, -10.0], [10.0, 10.0]))
    assert not result.found and result.mode is None and result.candidates == ("FFF",)
    assert "no candidate mode (FFF) has an unambiguous input" in result.reason


def test_bad_input_raises(rhex, write_scene):
    with pytest.raises(InputError, match="has no inputs"):
        plan_flip(load_scene(write_scene(rhex_text(inputs=False))))
    with pytest.raises(InputError, match="without interior"):
        plan_flip(with_limits(rhex, [-1.0, 2.0], [1.0, 2.0]))
    with pytest.raises(InputError, match="margin"):
        plan_flip(rhex, margin=-1.0)
    no_pitch = rhex_text().replace("maximize = { coordinate", "minimize = { coordinate")
    with pytest.raises(SceneError, match=r"task.phases\[0\].maximize"):
        plan_flip(load_scene(write_scene(no_pitch)))
    no_body = rhex_text().replace('modes = { front_corner = "FLR",', 'modes = { front_corner = "SFLR",')
    with pytest.raises(SceneError, match=r"task.phases\[0\].modes"):
        plan_flip(load_scene(write_scene(no_body)))
    text = rhex_text()
    task = text[text.index("[task]"): text.index("[inputs]")]
    dedicated = text.replace(task, '[task]\nbody_contacts = ["front_corner"]\npitch = "phi"\n\n')
    with pytest.raises(SceneError, match="task.pitch"):
        plan_flip(load_scene(write_scene(dedicated)))
    with pytest.raises(InputError, match="replan_every"):
        simulate_flip(rhex, replan_every=0)


# ------------------------------------------------------------------------------- closed loop


def test_closed_loop_flips_a_robot_strong_enough(rhex):
    """With the shipped 13.4 N m per hip pair the re-planned pushes pitch the body past vertical
    while the front corner (the pivot) stays on the ground; 10 N m cannot (see the next test)."""
    scene = with_limits(rhex, [-13.4, -13.4], [13.4, 13.4])
    result = simulate_flip(scene, max_time=1.2)
    assert result.plan.found and result.flipped and result.body_contact_kept
    assert result.separation is None and result.reason is None
    traj = result.trajectory
    pitch = traj.coordinate("theta")
    assert pitch[-1] >= 1.5 * math.pi > pitch[-2]  # the trajectory ends at the first sample past vertical
    assert traj.times[-2] <= result.time_to_vertical <= traj.times[-1]
    assert result.steps == len(traj.times) - 1 and result.replans >= 10
    assert len(result.modes) == len(traj.times)
    assert all(len(m) == len(rhex.contacts) for m in result.modes)
    # the front corner touches at every sample up to vertical
    front = np.array([p[0][1] for p in traj.contact_points])
    assert np.all(front <= 1e-4)
    # the first step applies the first plan
    np.testing.assert_allclose(traj.inputs[1], [result.plan.torques["hip_middle"],
                                                result.plan.torques["hip_rear"]])


def test_closed_loop_at_realistic_torques_does_not_flip(rhex, plan):
    """10 N m per pair lifts the body from 3.19 to 3.97 rad, 0.74 rad short of vertical, and it falls
    back: a clear 'not flipped' with the reason."""
    result = simulate_flip(rhex, max_time=0.4, plan=plan)
    assert not result.flipped and result.time_to_vertical is None
    assert "short of vertical" in result.reason
    assert result.trajectory.coordinate("theta").max() < 1.5 * math.pi - 0.6


# --------------------------------------------------------------------------------------- CLI


def test_cli_json_contract():
    plan = plan_flip(load_scene("rhex_flip"))  # the shipped scene, the command's default
    result = runner.invoke(app(), ["flip", "--json", "--max-time", "0.05"])
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    assert doc["mode"] == plan.mode and doc["torques"] == dict(plan.torques)
    assert doc["pitch_acceleration"] == pytest.approx(plan.pitch_acceleration)
    assert doc["unambiguous"] is True and doc["margin"] == DEFAULT_MARGIN
    sim = doc["simulation"]
    assert set(sim) >= {"flipped", "time_to_vertical", "body_contact_kept", "steps"}
    assert sim["flipped"] is False and sim["time_to_vertical"] is None and sim["steps"] == 50
    assert isinstance(sim["body_contact_kept"], bool)


@pytest.mark.parametrize("name", ["rhex_flip", "rhex_flip_drives"])
def test_frc_flip_is_frc_plan_with_the_flips_keys(name):
    """frc flip runs the scene's task on frc plan's path: its outcome and phases are frc plan's."""
    from frcontrol.answers import without_run_dependent

    args = [name, "--max-time", "0.3", "--json"]
    flipped = runner.invoke(app(), ["flip", *args])
    planned = runner.invoke(app(), ["plan", *args])
    assert flipped.exit_code == 0 and planned.exit_code == 0, flipped.stderr + planned.stderr
    flip, plan = json.loads(flipped.stdout), json.loads(planned.stdout)
    for key in ("outcome", "phases"):
        assert without_run_dependent(flip[key]) == without_run_dependent(plan[key])
    first = plan["phases"][0]["plans"][0]
    assert flip["mode"] == first["mode"] and flip["torques"] == first["inputs"]
    assert flip["simulation"]["steps"] == len(plan["simulation"]["samples"]["times"]) - 1
    assert plan["phases"][0]["name"] == ("flip" if name == "rhex_flip" else "push")
    if name == "rhex_flip":  # the short names' rule (with_legacy_keys): frc plan's document and more
        assert set(plan) <= set(flip) and flip["task"] == plan["task"]
        assert flip["simulation"]["samples"] == plan["simulation"]["samples"]


def test_cli_no_flip_exits_0_with_the_reason(rhex, write_scene):
    text = rhex_text().replace("lower = [-10.0, -10.0]", "lower = [-0.01, -0.01]")
    path = write_scene(text.replace("upper = [10.0, 10.0]", "upper = [0.01, 0.01]"))
    result = runner.invoke(app(), ["flip", str(path), "--json"])
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    assert doc["found"] is False and doc["mode"] is None and doc["torques"] is None
    # the task runs as frc plan runs it, the torques held: the outcome names the phase without a plan
    assert doc["simulation"]["flipped"] is False and "short of vertical" in doc["simulation"]["reason"]
    assert doc["outcome"]["achieved"] is False and doc["outcome"]["infeasible"]["reason"] == doc["reason"]
    assert doc["outcome"]["infeasible"]["phase"] == "flip" and doc["phases"][0]["plans"][0]["found"] is False
    human = runner.invoke(app(), ["flip", str(path)])
    assert human.exit_code == 0 and "no flip plan" in human.stdout


def test_cli_bad_input_is_one_line_and_exit_1(write_scene):
    result = runner.invoke(app(), ["flip", str(write_scene(rhex_text(inputs=False)))])
    assert result.exit_code == 1
    assert "no inputs" in one_error_line(result.stderr)  # the planner's refusal, after any progress
    result = runner.invoke(app(), ["flip", "--port", "7001"])
    assert result.exit_code == 2 and "add --view" in result.stderr


def test_cli_refuses_a_taken_port_before_planning():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = runner.invoke(app(), ["flip", "--view", "--port", str(port)])
    assert result.exit_code == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and f"port {port}" in lines[0]


def test_cli_writes_the_html_and_the_plot(tmp_path):
    html, png = tmp_path / "flip.html", tmp_path / "flip.png"
    result = runner.invoke(app(), ["flip", "--max-time", "0.05", "--html", str(html), "--plot", str(png)])
    assert result.exit_code == 0, result.stderr
    assert f"wrote {html}" in result.stdout and f"wrote {png}" in result.stdout
    page = html.read_text()
    assert page.startswith("<!DOCTYPE html>") or "<html" in page[:500].lower()
    assert "meshcat" in page.lower() and len(page) > 100_000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the mode over every scene contact, in scene order, with the names (rear_corner, front_toe apart)
    assert ("mode RSSLL (front_corner R, rear_corner S, front_toe S, middle_toe L, rear_toe L)"
            in " ".join(result.stdout.split())) and "hip torques" in result.stdout


def test_build_flip_is_the_formulation_and_needs_no_solver(monkeypatch):
    """build_flip assembles the task, the contact problem and the forced inputs with no LP: with
    every LP back-end removed it still works, and the planner on its result plans as before."""
    import frcontrol.solvers as door
    from frcontrol.errors import SolverNotFound
    from frcontrol.planning.flip import build_flip, plan_flip

    scene = load_scene("rhex_flip")
    with monkeypatch.context() as patch:
        patch.setattr(door, "_LP_SOLVERS", {})
        built = build_flip(scene)
        with pytest.raises(SolverNotFound, match="is not available"):
            plan_flip(scene)  # the planner does need one: the removal is real
    assert built.task.pitch == "theta" and set(built.body_contacts) <= set(built.task.body_contacts)
    assert built.problem.inputs == tuple(i for k, i in enumerate(built.full.inputs) if k not in built.forced)
    assert built.full.inputs == scene.inputs.coordinates
    plan = plan_flip(scene)
    assert plan.found and plan.planned_inputs == built.problem.inputs
    assert plan.body_contacts == built.body_contacts
