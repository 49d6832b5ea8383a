"""The mode-domain engine against closed-form mechanics, the LCP and its own invariants."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROBOTS, counted, on, rod_scene, tally
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from frcontrol import polytope as poly
from frcontrol.contact_lcp import all_contact_lcp_solutions, solve_contact_lcp
from frcontrol.engine import DOMAIN_TOLERANCE, analyze, solutions_at
from frcontrol.errors import CoordinateNotFound, IllConditioned, ImpactState, InputError
from frcontrol.modes import ContactProblem, build_mode_system
from frcontrol.response import ambiguous_outputs, solve_affine
from frcontrol.scene import load_scene
from frcontrol.solvers import solve_lp

G = 9.81
CLOSED_FORM_TOL = 1e-8


# ----------------------------------------------------------------------------- the rod
def rod_problem(write_scene, theta=2.007, mu=1.4, omega=0.0, slide=0.0, arm=0.5):
    """The rod touching y = 0 at its end l behind the centre, spinning at omega, tip sliding at slide."""
    c, s = np.cos(theta), np.sin(theta)
    q = [0.0, arm * s, theta]
    # tip velocity (x' + l s w, y' - l c w) = (slide, 0)
    v = [slide - arm * s * omega, arm * c * omega, omega]
    contact = {"name": "tip", "link": "rod", "point": [-arm, 0.0], "normal": [0.0, 1.0], "mu": mu,
               "surface_point": [0.0, 0.0]}
    scene = load_scene(write_scene(rod_scene(state={"q": q, "v": v}, contacts=[contact])))
    return scene


def rod_closed_form(mode, u, theta, mu, omega, l=0.5, m=1.0, inertia=1.0 / 12):  # noqa: E741
    """(dv, lam_N, lam_T) of a rod with one contact, by hand (see the derivation in comments).

    Tip p = c - l (cos, sin); its acceleration is
    a_T = x'' + l sin th'' + l cos w^2,  a_N = y'' - l cos th'' + l sin w^2.
    Contact force (lam_T, lam_N) at the tip has moment -l cos lam_N + l sin lam_T about the centre.
    """
    fx, fy, tau = u
    c, s = np.cos(theta), np.sin(theta)
    if mode == "S":
        dv = np.array([fx / m, fy / m - G, tau / inertia])
        return dv, 0.0, 0.0
    if mode == "F":
        # pivot about the tip: (I + m l^2) th'' = tau + moment of (F + gravity) about the tip
        th = (tau + l * c * (fy - m * G) - l * s * fx) / (inertia + m * l * l)
        xdd = -l * s * th - l * c * omega**2
        ydd = l * c * th - l * s * omega**2
        return np.array([xdd, ydd, th]), m * ydd + m * G - fy, m * xdd - fx
    sign = 1.0 if mode == "R" else -1.0  # R: lam_T = -mu lam_N
    k = l * (c + sign * mu * s)
    # a_N = 0: y'' = l c th'' - l s w^2;  lam_N = m y'' + m g - fy;  I th'' = tau - k lam_N
    th = (tau - k * (m * (-l * s * omega**2) + m * G - fy)) / (inertia + k * m * l * c)
    ydd = l * c * th - l * s * omega**2
    lam_n = m * ydd + m * G - fy
    lam_t = -sign * mu * lam_n
    return np.array([(fx + lam_t) / m, ydd, th]), lam_n, lam_t


def rod_mode_feasible(mode, dv, lam_n, lam_t, theta, mu, omega, l=0.5, sliding=False):  # noqa: E741
    c, s = np.cos(theta), np.sin(theta)
    a_t = dv[0] + l * s * dv[2] + l * c * omega**2
    a_n = dv[1] - l * c * dv[2] + l * s * omega**2
    tol = 1e-9
    if mode == "S":
        return a_n >= -tol
    if lam_n < -tol:
        return False
    if mode == "F":
        return abs(lam_t) <= mu * lam_n + tol
    if sliding:
        return True
    return a_t >= -tol if mode == "R" else a_t <= tol


@pytest.mark.parametrize("theta", [2.007, np.pi - 2.007, 0.6])
@pytest.mark.parametrize("omega", [0.0, 1.3])
@pytest.mark.parametrize("mu", [0.3, 1.4])
def test_rod_single_contact_closed_forms(write_scene, theta, omega, mu):
    scene = rod_problem(write_scene, theta=theta, mu=mu, omega=omega)
    rng = np.random.default_rng(7)
    for _ in range(12):
        u = rng.uniform(-20, 20, 3)
        got = {s.mode: s for s in solutions_at(scene, u)}
        expected = set()
        for mode in "SLRF":
            dv, lam_n, lam_t = rod_closed_form(mode, u, theta, mu, omega)
            if rod_mode_feasible(mode, dv, lam_n, lam_t, theta, mu, omega):
                expected.add(mode)
                if mode in got:
                    np.testing.assert_allclose(got[mode].dv, dv, atol=CLOSED_FORM_TOL)
                    np.testing.assert_allclose(got[mode].lambda_n, [lam_n], atol=CLOSED_FORM_TOL)
                    np.testing.assert_allclose(got[mode].lambda_t, [lam_t], atol=CLOSED_FORM_TOL)
        assert set(got) == expected, (u, set(got), expected)


def test_rod_sticks_under_gravity_alone(write_scene):
    scene = rod_problem(write_scene)
    (only,) = solutions_at(scene, {})
    assert only.mode == "F"
    dv, lam_n, lam_t = rod_closed_form("F", np.zeros(3), 2.007, 1.4, 0.0)
    np.testing.assert_allclose(only.dv, dv, atol=1e-10)
    # pivoting about the tip: lam_N = m g (1 - 3 l^2 cos^2(theta)) for l = 0.5, I = m/12
    # (rel 1e-9: the URDF states I to 10 digits)
    assert only.lambda_n[0] == pytest.approx(G * (1 - 0.75 * np.cos(2.007) ** 2), rel=1e-9)


def test_rod_leaves_the_table_when_pulled_up(write_scene):
    scene = rod_problem(write_scene)
    (only,) = solutions_at(scene, {"y": 30.0})
    assert only.mode == "S"
    np.testing.assert_allclose(only.dv, [0.0, 30.0 - G, 0.0], atol=1e-12)


@pytest.mark.parametrize("slide", [0.8, -0.8])
def test_rod_sliding_painleve(write_scene, slide):
    """Sliding (v_T != 0): only S and the sliding direction's mode are allowed. Painleve's rod
    (mu = 1.4, theta = 2.007, sliding toward +x) has a negative effective inertia: at rest input it
    admits two solutions or none; the closed form says which."""
    theta = 2.007 if slide > 0 else np.pi - 2.007
    scene = rod_problem(write_scene, theta=theta, slide=slide)
    problem = ContactProblem.from_scene(scene)
    assert problem.allowed_modes() == (("SR",) if slide > 0 else ("SL",))
    letter = "R" if slide > 0 else "L"
    rng = np.random.default_rng(8)
    counts = set()
    for _ in range(20):
        u = rng.uniform(-20, 20, 3)
        got = {s.mode for s in solutions_at(scene, u)}
        expected = set()
        for mode in ("S", letter):
            dv, lam_n, lam_t = rod_closed_form(mode, u, theta, 1.4, 0.0)
            if rod_mode_feasible(mode, dv, lam_n, lam_t, theta, 1.4, 0.0, sliding=True):
                expected.add(mode)
        assert got == expected
        counts.add(len(got))
    assert {0, 2} <= counts  # Painleve: inconsistency and ambiguity both occur


def test_rod_analysis_domains(write_scene):
    scene = rod_problem(write_scene, mu=0.3)
    result = analyze(scene)
    assert {m.mode for m in result.feasible_modes} == set("SLRF")
    for m in result.feasible_modes:
        assert m.ambiguity_dim == 0 and m.ambiguous_outputs == "none" and m.full_dimensional
    # one contact, no Painleve at mu = 0.3: the T_c tile the input space, no two interiors overlap
    assert result.overlaps == ()


# ----------------------------------------------------------------------------- two contacts
def test_box_on_ground_sticks_slides_and_tips():
    """Under a push F at the centre of mass (h = 0.25 m above the corners, w = 1 m apart), FF holds
    with normal forces m g / 2 -+ F h / w and a free internal squeeze; the boundary modes LR, RL,
    FL, RF... (zero sliding acceleration, forces on the cone edges) are solutions too, with the same
    (zero) accelerations."""
    scene = load_scene("box_on_ground")
    for push in (0.0, 4.0):
        sols = {s.mode: s for s in solutions_at(scene, {"x": push})}
        assert "FF" in sols and sols["FF"].ambiguous_outputs == "forces"
        for mode, sol in sols.items():
            np.testing.assert_allclose(sol.dv, 0.0, atol=1e-10)
            np.testing.assert_allclose(sol.lambda_n, [G / 2 - 0.25 * push, G / 2 + 0.25 * push], atol=1e-10)
            assert sol.lambda_t.sum() == pytest.approx(-push, abs=1e-9)
            for i, letter in enumerate(mode):
                if letter in "LR":
                    assert sol.a_t[i] == pytest.approx(0.0, abs=1e-10)
    # a push above mu m g = 4.905 N: slides right with (F - mu m g) / m (no tipping moment:
    # the force acts at the centre of mass)
    (slide,) = solutions_at(scene, {"x": 8.0})
    assert slide.mode == "RR"
    np.testing.assert_allclose(slide.dv, [8.0 - 0.5 * G, 0.0, 0.0], atol=1e-9)
    friction = 0.5 * G  # mu m g, acting 0.25 m below the centre of mass
    np.testing.assert_allclose(slide.lambda_n, [G / 2 - 0.25 * friction, G / 2 + 0.25 * friction], atol=1e-9)
    # a counter-clockwise torque above m g w / 2 = 4.905 N m lifts the right corner: the box
    # pivots about the left one; below it, it stays put
    tipping = {s.mode for s in solutions_at(scene, {"theta": 5.0})}
    assert "FS" in tipping and all(m[0] != "S" and m[1] == "S" for m in tipping)
    staying = solutions_at(scene, {"theta": 4.8})
    assert all(m.mode[1] != "S" for m in staying)
    for sol in staying:
        np.testing.assert_allclose(sol.dv, 0.0, atol=1e-10)


def test_table_forces_ambiguous_accelerations_not():
    scene = load_scene("table_on_ground")
    result = analyze(scene)
    ff = result.mode("FF")
    assert ff.feasible and ff.full_dimensional
    assert ff.ambiguity_dim == 1 and ff.ambiguous_outputs == "forces"
    assert ff.response.case == "ambiguous"
    rest = {s.mode: s for s in solutions_at(scene, {"x": 10.0})}["FF"]
    np.testing.assert_allclose(rest.dv, 0.0, atol=1e-12)
    # the push acts at the slab's frame, 0.525 m above the feet, which are 0.9 m apart
    shift = 10.0 * 0.525 / 0.9
    np.testing.assert_allclose(rest.lambda_n, [5 * G / 2 - shift, 5 * G / 2 + shift], atol=1e-9)
    assert rest.lambda_t.sum() == pytest.approx(-10.0, abs=1e-9)


def _wedge(write_scene, mu):
    text = (ROBOTS / "scenes" / "disk_in_wedge.toml").read_text()
    text = text.replace("mu = 0.3", f"mu = {mu}").replace('robot = "disk.urdf"',
                                                         f'robot = "{ROBOTS / "disk.urdf"}"')
    return load_scene(write_scene(text))


@pytest.mark.parametrize("mu, jams", [(0.3, False), (0.9, False), (1.1, True), (2.0, True)])
def test_disk_in_wedge_jams_iff_the_squeeze_lies_in_both_cones(write_scene, mu, jams):
    """Walls at 45 degrees: the internal squeeze (along the line joining the contacts, 45 degrees off
    each normal) lies inside both friction cones iff mu > tan 45 = 1. Then a wedged disk (FF) may
    resist any pull, so FF's input domain overlaps the free flight's (SS): the ball-in-a-wedge
    ambiguity. Below that, the two never share interior."""
    result = analyze(_wedge(write_scene, mu))
    pairs = {frozenset(o.modes) for o in result.overlaps}
    assert (frozenset({"FF", "SS"}) in pairs) == jams
    assert result.mode("FF").ambiguous_outputs == "forces"
    if jams:
        sols = {s.mode for s in solutions_at(result.problem, [0.0, 25.0, 0.0])}
        assert {"FF", "SS"} <= sols


def test_between_mode_ambiguity_removed_from_unambiguous_sets(write_scene):
    result = analyze(_wedge(write_scene, 2.0))
    ss = result.mode("SS")
    rng = np.random.default_rng(3)
    for _ in range(200):
        u = rng.uniform(-30, 30, 3)
        u[2] = rng.uniform(-1, 1)
        modes = {s.mode for s in solutions_at(result.problem, u)}
        in_unambiguous = any(poly.contains(piece, u) for piece in result.unambiguous_set("SS"))
        if in_unambiguous and poly.contains(ss.input_domain, u):
            assert modes == {"SS"}, (u, modes)


# ----------------------------------------------------------------------------- rank cases
def test_four_rank_cases_of_the_affine_solve():
    B = np.array([[1.0], [0.0]])
    c = np.array([0.0, 2.0])
    unique = solve_affine(np.eye(2), B, c)
    assert unique.case == "unique"
    np.testing.assert_allclose(unique.X_u @ [3.0] + unique.x_0, [3.0, 2.0])
    # 2 equations, 3 unknowns, independent rows: w only
    amb = solve_affine(np.array([[1.0, 0, 0], [0, 1.0, 0]]), B, c)
    assert amb.case == "ambiguous" and amb.ambiguity_dim == 1
    np.testing.assert_allclose(np.abs(amb.X_w[:, 0]) / np.abs(amb.X_w).max(), [0, 0, 1], atol=1e-12)
    # 3 equations, 2 unknowns, full column rank: the third row demands u = e
    A3 = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    con = solve_affine(A3, np.array([[1.0], [0.0], [0.0]]), np.array([0.0, 2.0, 5.0]))
    assert con.case == "constrained" and con.consistent
    # x1 = u, x2 = 2, x1 + x2 = 5 -> u = 3
    assert con.E.shape == (1, 1)
    assert float(con.e[0] / con.E[0, 0]) == pytest.approx(3.0)
    # neither: rank 1 of a 2x2
    both = solve_affine(np.array([[1.0, 1.0], [2.0, 2.0]]), np.array([[1.0], [0.0]]), np.zeros(2))
    assert both.case == "ambiguous_constrained"
    assert float(both.e[0] / both.E[0, 0]) == pytest.approx(0.0, abs=1e-12)
    # inconsistent for every input: freedom pruning
    none = solve_affine(np.array([[1.0, 1.0], [2.0, 2.0]]), np.zeros((2, 1)), np.array([1.0, 0.0]))
    assert not none.consistent


def test_rhex_massless_legs_hit_the_rank_cases():
    """Contacts: front corner, middle toe, rear toe; inputs: hip_middle, hip_rear."""
    problem = ContactProblem.from_scene(load_scene("rhex_flip"))
    assert problem.contacts == ("front_corner", "middle_toe", "rear_toe")
    cases = {}
    for mode in ("FFF", "LLR", "FSF", "FSS"):
        system = build_mode_system(problem, mode)
        cases[mode] = solve_affine(system.A, system.B, system.c)
    assert cases["FFF"].case == "ambiguous"  # the pivot and two toes: an internal squeeze
    assert cases["LLR"].case == "unique"
    # a massless leg in the air: its torque must vanish (E u = e) and its acceleration is free
    toe_up = cases["FSF"]
    assert toe_up.case == "ambiguous_constrained"
    np.testing.assert_allclose(np.abs(toe_up.E), [[1.0, 0.0]], atol=1e-9)
    np.testing.assert_allclose(toe_up.e, 0.0, atol=1e-9)
    assert ambiguous_outputs(toe_up, problem.n) == "accelerations"
    assert cases["FSS"].case == "ambiguous_constrained" and cases["FSS"].E.shape[0] == 2


def test_rhex_analysis_is_complete_and_consistent():
    scene = load_scene("rhex_flip")
    assert [c.name for c in scene.contacts if not c.active] == ["rear_corner", "front_toe"]
    fast = analyze(scene)
    naive = analyze(scene, prune_partial=False, ambiguity=False)
    assert {m.mode for m in fast.feasible_modes} == {m.mode for m in naive.feasible_modes}
    e = fast.enumeration
    assert e.total == 4**3 and e.after_velocity == 4**3
    assert e.evaluated <= naive.enumeration.evaluated == 4**3
    assert e.feasible + e.pruned_freedom + e.pruned_infeasible == e.after_velocity
    pivot_kept = [m for m in fast.feasible_modes if m.mode[0] != "S" and m.inputs_full_dimensional]
    assert pivot_kept, "some mode keeps the front corner on the ground"
    # with the hips on the body's mid-plane no two modes' input domains overlap in the box (with
    # them on the belly face, the massless legs made some overlap): at most one solution anywhere
    assert not fast.overlaps
    # the fast path through the analysis gives the same solutions as the enumeration from scratch
    rng = np.random.default_rng(5)
    for _ in range(20):
        u = rng.uniform(-10, 10, 2)
        a = {s.mode: s.dv for s in solutions_at(fast, u)}
        b = {s.mode: s.dv for s in solutions_at(scene, u)}
        assert a.keys() == b.keys() and len(a) <= 1


def test_partial_pruning_drops_subtrees_and_loses_no_mode(write_scene):
    """The straight snake lying on the ground, touching at 4 points: lifting any subset of points
    is possible, but two touching neighbours cannot slide apart: subtrees are dropped early."""
    contacts = [{"name": f"c{i}", "link": f"link{i}", "point": [0.0, 0.0], "normal": [0.0, 1.0],
                 "mu": 0.5, "surface_point": [0.0, 0.0]} for i in range(4)]
    scene = load_scene(write_scene({
        "robot": str(ROBOTS / "snake_planar.urdf"), "state": {"q": [0.0] * 11}, "contacts": contacts,
        "inputs": {"coordinates": [f"j{i}" for i in range(1, 9)], "lower": [-5.0] * 8, "upper": [5.0] * 8},
    }))
    fast = analyze(scene, ambiguity=False)
    naive = analyze(scene, prune_partial=False, ambiguity=False)
    assert fast.enumeration.evaluated < naive.enumeration.evaluated == 4**4
    assert fast.enumeration.partial_checks > 0
    assert {m.mode for m in fast.feasible_modes} == {m.mode for m in naive.feasible_modes}
    e = fast.enumeration
    assert e.feasible + e.pruned_freedom + e.pruned_infeasible == e.after_velocity


# ----------------------------------------------------------------------------- LCP agreement
@pytest.mark.slow
@pytest.mark.parametrize("name", ["rod_on_table", "box_on_ground", "box_on_slope", "table_on_ground",
                                  "disk_in_wedge", "snake_climb"])
def test_modes_lemke_and_enumeration_agree(name):
    scene = load_scene(name)
    problem = ContactProblem.from_scene(scene)
    rng = np.random.default_rng(11)
    lo = np.where(np.isfinite(problem.lower), problem.lower, -20)
    hi = np.where(np.isfinite(problem.upper), problem.upper, 20)
    samples = 2 if problem.k >= 3 else 8  # 3 sticking contacts: 2^12 supports to enumerate
    for _ in range(samples):
        u = rng.uniform(lo, hi)
        mode_solutions = solutions_at(problem, u)
        modes = {s.mode for s in mode_solutions}
        lcp_all = all_contact_lcp_solutions(problem, u)
        # every LCP solution satisfies the equalities and inequalities of a mode the engine found
        for sol in lcp_all:
            assert _satisfies_some_mode(problem, sol.x, u, modes), (name, u, sol.mode, modes)
        # every mode the engine found with a unique response is among the LCP's solutions
        for s in mode_solutions:
            if s.ambiguity_dim == 0:
                matches = [np.allclose(s.dv, lsol.x[:problem.n], atol=1e-7) for lsol in lcp_all]
                assert any(matches), (name, s.mode)
        lemke = solve_contact_lcp(problem, u)
        if modes:
            assert hasattr(lemke, "x"), (name, u, getattr(lemke, "status", None))
            assert _satisfies_some_mode(problem, lemke.x, u, modes)
        else:
            assert not lcp_all


def _satisfies_some_mode(problem, x, u, modes, tol=1e-6):
    for mode in modes:
        system = build_mode_system(problem, mode)
        eq = np.abs(system.A @ x - system.B @ u - system.c).max()
        ineq = (system.G @ x - system.g).max(initial=0.0)
        if eq <= tol * (1 + np.abs(x).max()) and ineq <= tol * (1 + np.abs(x).max()):
            return True
    return False


def test_lcp_refuses_a_singular_mass_matrix():
    problem = ContactProblem.from_scene(load_scene("rhex_flip"))
    with pytest.raises(IllConditioned, match="positive definite"):
        solve_contact_lcp(problem, np.zeros(problem.m))


# ----------------------------------------------------------------------------- properties
SCENES = ["rod_on_table", "box_on_ground", "table_on_ground", "disk_in_wedge", "rhex_flip"]
_analyses = {}


def analysis(name):
    if name not in _analyses:
        _analyses[name] = analyze(load_scene(name))
    return _analyses[name]


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(name=st.sampled_from(SCENES), data=st.data())
def test_every_solution_satisfies_its_mode(name, data):
    problem = analysis(name).problem
    u = np.array([data.draw(st.floats(lo, hi)) for lo, hi in zip(problem.lower, problem.upper, strict=True)])
    solutions = solutions_at(problem, u)
    assume(solutions)  # an input with no rigid solution checks nothing here: draw another
    for sol in solutions:
        system = build_mode_system(problem, sol.mode)
        x = np.concatenate([sol.dv, sol.lambda_n, sol.lambda_t])
        scale = 1.0 + np.abs(x).max()
        assert np.abs(system.A @ x - system.B @ u - system.c).max() <= 1e-8 * scale
        assert (system.G @ x - system.g).max(initial=0.0) <= 1e-6 * scale
        assert sol.equality_residual <= 1e-8 * scale


@counted
@settings(max_examples=40, deadline=None)
@given(name=st.sampled_from(SCENES), data=st.data())
def test_projection_membership_matches_an_lp_on_the_domain(name, data):
    result = analysis(name)
    feasible = [m for m in result.feasible_modes if m.ambiguity_dim > 0]
    assume(feasible)  # a scene without ambiguity variables has nothing to project
    tally().example()
    mode = data.draw(st.sampled_from(feasible))
    problem = result.problem
    u = np.array([data.draw(st.floats(lo, hi)) for lo, hi in zip(problem.lower, problem.upper, strict=True)])
    in_projection = poly.contains(mode.input_domain, u, tolerance=1e-7)
    # is there a w with (u, w) in D_c?  An LP over w (HiGHS, the reference).
    D = mode.domain
    m = problem.m
    H_w, h_w = D.A[:, m:], D.b - D.A[:, :m] @ u
    eq_ok = D.A_eq.shape[0] == 0 or np.abs(D.A_eq[:, :m] @ u - D.b_eq).max() <= 1e-7
    lp = solve_lp(np.zeros(H_w.shape[1]), H_w, h_w + 1e-9, door=on("highs"))
    has_w = bool(eq_ok and lp.found)
    # points within 1e-6 of the boundary may go either way
    margin = _distance_to_boundary(mode.input_domain, u)
    if margin > 1e-6:
        tally().check()
        assert in_projection == has_w, (mode.mode, u)


def _distance_to_boundary(P, u):
    norms = np.linalg.norm(P.A, axis=1)
    norms[norms == 0] = 1
    return float(np.min(np.abs(P.b - P.A @ u) / norms, initial=np.inf))


# ----------------------------------------------------------------------------- bad input
def test_bad_inputs_are_typed_errors(write_scene):
    scene = load_scene("rod_on_table")
    with pytest.raises(CoordinateNotFound, match="unknown coordinate 'phi'"):
        solutions_at(scene, {"phi": 1.0})
    with pytest.raises(InputError, match="outside"):
        solutions_at(scene, {"x": 100.0})
    with pytest.raises(InputError, match="entries"):
        solutions_at(scene, [1.0, 2.0])
    moving_in = load_scene(write_scene(rod_scene(state={"q": [0.0, 0.453, 2.007], "v": [0.0, -1.0, 0.0]})))
    with pytest.raises(ImpactState, match="impact"):
        analyze(moving_in)
    with pytest.raises(ImpactState, match="this is an impact"):
        solutions_at(moving_in, {})
    assert DOMAIN_TOLERANCE > 0


@pytest.mark.parametrize(("args", "letter"), [
    ((0.0, 5.0, 1e-9, 1e-6), "S"),               # no load: separate, whatever it slides
    ((1.0, 2e-6, 1e-9, 1e-6), "R"),              # slides along +t
    ((1.0, -2e-6, 1e-9, 1e-6), "L"),
    ((1.0, 5e-7, 1e-9, 1e-6), "F"),              # within the slip tolerance: sticks
    ((1.0, 0.0, 1e-9, 1e-6, 0.5, 1e-9), "R"),    # sticking but accelerating along +t: starts to slip
    ((1.0, 0.0, 1e-9, 1e-6, -0.5, 1e-9), "L"),
    ((1.0, 0.0, 1e-9, 1e-6, 0.5), "F"),          # a sampled motion has no acceleration level
    ((1.0, -1.0, 1e-9, 1e-6, 0.5, 1e-9), "L"),   # velocity decides before acceleration
])
def test_one_contact_mode_rule(args, letter):
    from frcontrol.modes import contact_mode_letter

    assert contact_mode_letter(*args) == letter


def test_lcp_cancelling_friction_split_is_one_solution(write_scene):
    """A sticking contact's split lam_T+ - lam_T- with both parts positive is the same solution.

    It is an LCP solution too (then beta = a_T = 0), and at a huge mu its x differs from the
    canonical one by round-off of the cancelled part only: listed once, under F.
    """
    contact = {"name": "tip", "link": "rod", "point": [-0.5, 0.0], "normal": [0.0, 1.0], "mu": 1e8}
    scene = load_scene(write_scene(rod_scene(contacts=[contact])))
    problem = ContactProblem.from_scene(scene)
    u = np.zeros(problem.m)
    from frcontrol.contact_lcp import build_contact_lcp
    lcp = build_contact_lcp(problem, u)
    canonical = solve_contact_lcp(problem, u)
    z = canonical.lcp.z.copy()
    ns = len(lcp.sticking)
    nn = ns + len(lcp.sliding)
    shift = 1e8  # the same friction, split as (lam_T+ + shift) - (lam_T- + shift)
    z[nn:nn + ns] += shift
    z[nn + ns:nn + 2 * ns] += shift
    assert lcp.cancelled(z) == pytest.approx(shift + min(canonical.lcp.z[nn], canonical.lcp.z[nn + ns]))
    assert lcp.cancelled(canonical.lcp.z) == 0.0
    np.testing.assert_allclose(lcp.unknowns_from(z), canonical.x, rtol=0, atol=1e-6)
    every = all_contact_lcp_solutions(problem, u)
    assert [s.mode for s in every] == ["F"]


def test_an_analysis_is_immutable_and_its_query_table_built_once():
    """Queries read the point-location table built on the first one; they change no field."""
    import copy
    import dataclasses

    from frcontrol.query import QueryTable

    analysis = analyze(load_scene(ROBOTS / "scenes" / "box_on_slope.toml"))
    assert "query" not in vars(analysis) and analysis.timings["query_table"] == 0.0  # not built yet
    table = analysis.query
    assert isinstance(table, QueryTable) and analysis.timings["query_table"] > 0.0
    before = copy.copy(vars(analysis))
    box = analysis.mode(analysis.feasible_modes[0].mode)
    first = solutions_at(analysis, np.zeros(analysis.problem.m))
    pieces = analysis.unambiguous_set(box.mode)
    again = analysis.unambiguous_set(box.mode)  # computed anew, alike
    assert first and len(again) == len(pieces)
    assert all(np.array_equal(a.A, b.A) for a, b in zip(again, pieces, strict=True))
    assert vars(analysis) == before and analysis.query is table  # nothing was filled in
    twin = dataclasses.replace(analysis)  # its own table, built again on its first query
    assert "query" not in vars(twin) and "query" not in {f.name for f in dataclasses.fields(analysis)}
    assert [s.mode for s in solutions_at(twin, np.zeros(analysis.problem.m))] == [s.mode for s in first]
    assert twin.query is not table and twin.query.modes == table.modes
    assert not any(f.name.startswith("_") for f in dataclasses.fields(analysis))
    assert not any(f.name.startswith("_") for f in dataclasses.fields(box))


def test_the_overlap_stage_is_announced():
    """``analyze(stage=...)`` names the stage after the modes' as it starts (progress displays show it)."""
    calls: list[str] = []
    result = analyze(load_scene("snake_climb"), stage=calls.append)
    full = sum(m.inputs_full_dimensional for m in result.feasible_modes)
    assert calls == [f"finding the overlaps of {full} modes"] and full > 2
    calls.clear()
    analyze(load_scene("snake_climb"), ambiguity=False, stage=calls.append)
    assert calls == []


@pytest.mark.parametrize("name", ["rod_on_table", "rod_pivot", "snake_climb", "solo_standup"])
def test_the_box_filter_keeps_every_overlap(monkeypatch, name):
    """The bounding boxes drop pairs only where the lifted LP finds no overlap: each scene with the
    filter forced on and off gives the same overlaps (the rods have 3 each)."""
    import frcontrol.engine as engine

    analysis = analyze(load_scene(name), ambiguity=False)
    monkeypatch.setattr(engine, "BOX_FILTER_MODES_PER_INPUT", -1)  # on for any count
    filtered = engine._overlaps(analysis.feasible_modes, analysis.settings)
    monkeypatch.setattr(engine, "BOX_FILTER_MODES_PER_INPUT", 10**9)  # off
    every_pair = engine._overlaps(analysis.feasible_modes, analysis.settings)
    assert [o.modes for o in filtered] == [o.modes for o in every_pair]
    assert len(every_pair) == len(analyze(load_scene(name)).overlaps)


@pytest.mark.parametrize("name", ["rod_on_table", "snake_climb"])
def test_the_lifted_overlap_lp_is_motion_margins(name):
    """``_interiors_meet`` builds its LP in place: the same LP, bit for bit, as ``motion_margin`` of the
    two modes' rows stacked in (u, w_a, w_b) with every row a motion row (where the interiors meet;
    else ``(0.0, None)``); and the same answer through the lean LP path the overlap stage makes once
    for every pair."""
    import frcontrol.engine as engine

    analysis = analyze(load_scene(name), ambiguity=False)
    shared = engine.margin_lps(analysis.settings)
    modes = [mode for mode in analysis.feasible_modes if mode.inputs_full_dimensional][:24]
    m = modes[0].m
    rows = [engine._input_rows(mode) for mode in modes]
    for i in range(len(rows)):
        for j in range(i + 1, len(rows)):
            (Ha, ha, pa), (Hb, hb, pb) = rows[i], rows[j]
            H = np.vstack([np.hstack([Ha, np.zeros((Ha.shape[0], pb))]),
                           np.hstack([Hb[:, :m], np.zeros((Hb.shape[0], pa)), Hb[:, m:]])])
            stacked = engine.motion_margin(H, np.concatenate([ha, hb]), np.ones(H.shape[0], dtype=bool),
                                           np.zeros((0, H.shape[1])), np.zeros(0), settings=analysis.settings)
            margin, point = engine._interiors_meet(rows[i], rows[j], m, analysis.settings)
            again = engine._interiors_meet(rows[i], rows[j], m, analysis.settings, shared)
            assert again[0] == margin and (again[1] is None) == (point is None)
            assert point is None or np.array_equal(again[1], point)
            if stacked.verdict == "infeasible" or not stacked.margin > engine.DOMAIN_TOLERANCE:
                assert (margin, point) == (0.0, None)  # the interiors do not meet
            else:
                assert margin == stacked.margin and np.array_equal(point, stacked.point[:m])
