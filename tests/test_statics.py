"""Statics: closure, equilibrium, support region, weak and strong stability, against closed forms."""

from __future__ import annotations

import json
import math

import numpy as np
import pinocchio as pin
import pytest
import typer
from conftest import ROBOTS, on
from typer.testing import CliRunner

from frcontrol import polytope as poly
from frcontrol.errors import CoordinateNotFound, InputError
from frcontrol.scene import load_scene
from frcontrol.solvers import solve_lp
from frcontrol.statics import (
    BodyScale,
    analyze_statics,
    cone_rows,
    force_closure,
    form_closure,
    static_body,
    static_body_from_scene,
    static_equilibrium,
    strong_stability,
    support_region,
    weak_stability,
    wrench_matrix,
)

G = 9.81
INPUTS = {"coordinates": ["x", "y", "theta"], "lower": [-50.0, -50.0, -50.0], "upper": [50.0, 50.0, 50.0]}


# ---------------------------------------------------------------------------------------------
# scenes


def incline(alpha: float, mu: float) -> dict:
    """The 1 m x 0.5 m box (1 kg) on a slope of angle alpha through the origin, on its two lower corners."""
    n = [-math.sin(alpha), math.cos(alpha)]
    return {
        "name": "box on an incline", "robot": str(ROBOTS / "box.urdf"),
        "state": {"q": [-0.25 * math.sin(alpha), 0.25 * math.cos(alpha), alpha]},
        "contacts": [
            {"name": "lower", "link": "box", "point": [-0.5, -0.25], "normal": n, "mu": mu,
             "surface_point": [0.0, 0.0]},
            {"name": "upper", "link": "box", "point": [0.5, -0.25], "normal": n, "mu": mu,
             "surface_point": [0.0, 0.0]},
        ],
        "inputs": INPUTS,
    }


def ladder(theta: float, mu_floor: float, mu_wall: float) -> dict:
    """A uniform 1 m rod at angle theta above the floor (y = 0), its top against a wall at x = 1."""
    return {
        "name": "ladder", "robot": str(ROBOTS / "rod.urdf"),
        "state": {"q": [1.0 - 0.5 * math.cos(theta), 0.5 * math.sin(theta), theta]},
        "contacts": [
            {"name": "floor", "link": "rod", "point": [-0.5, 0.0], "normal": [0.0, 1.0], "mu": mu_floor,
             "surface_point": [0.0, 0.0]},
            {"name": "wall", "link": "rod", "point": [0.5, 0.0], "normal": [-1.0, 0.0], "mu": mu_wall,
             "surface_point": [1.0, 0.0]},
        ],
        "inputs": INPUTS,
    }


def wedge(alpha: float, mu: float, radius: float = 0.1) -> dict:
    """The disk (r = 0.1 m) in a symmetric V whose walls rise at alpha from the horizontal."""
    s, c = math.sin(alpha), math.cos(alpha)
    return {
        "name": "disk in a wedge", "robot": str(ROBOTS / "disk.urdf"),
        "state": {"q": [0.0, radius / c, 0.0]},
        "contacts": [
            {"name": "left", "link": "disk", "point": [-radius * s, -radius * c], "normal": [s, c], "mu": mu,
             "surface_point": [0.0, 0.0]},
            {"name": "right", "link": "disk", "point": [radius * s, -radius * c], "normal": [-s, c], "mu": mu,
             "surface_point": [0.0, 0.0]},
        ],
        "inputs": INPUTS,
    }


def jammed_rod(theta: float, mu: float) -> dict:
    """The 1 m rod at angle theta between two vertical walls touching its ends, no floor."""
    half = 0.5 * math.cos(theta)
    return {
        "name": "rod jammed between walls", "robot": str(ROBOTS / "rod.urdf"),
        "state": {"q": [0.0, 0.0, theta]},
        "contacts": [
            {"name": "left", "link": "rod", "point": [-0.5, 0.0], "normal": [1.0, 0.0], "mu": mu,
             "surface_point": [-half, 0.0]},
            {"name": "right", "link": "rod", "point": [0.5, 0.0], "normal": [-1.0, 0.0], "mu": mu,
             "surface_point": [half, 0.0]},
        ],
        "inputs": INPUTS,
    }


def transition(holds, lo: float, hi: float, tol: float = 1e-9) -> float:
    """Bisection on a predicate true at lo and false at hi."""
    assert holds(lo) and not holds(hi)
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if holds(mid):
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


# ---------------------------------------------------------------------------------------------
# the model: wrenches against Pinocchio's Jacobians and bias


@pytest.mark.parametrize("name", ["box_on_slope", "disk_in_wedge", "table_on_ground", "rod_on_table"])
def test_wrenches_match_the_jacobians_and_gravity_matches_the_bias(name):
    scene = load_scene(name)
    body = static_body_from_scene(scene)
    state = scene.state(scene.q, np.zeros(3))
    origin = scene.q[:2]
    # base rows of J_N^T, J_T^T are the unit-force wrenches about the base origin
    expected = np.hstack([state.jacobian_normal.T, state.jacobian_tangent.T])
    np.testing.assert_allclose(wrench_matrix(body, origin, scaled=False), expected, atol=1e-12)
    # h(q, 0) is minus gravity's wrench about the base origin
    np.testing.assert_allclose(body.external_wrench(origin), -state.bias, atol=1e-12)
    # centre of mass and radius of gyration from M's base block
    m = state.mass_matrix[0, 0]
    assert body.mass == pytest.approx(m)
    np.testing.assert_allclose(body.com - origin, [state.mass_matrix[1, 2] / m, -state.mass_matrix[0, 2] / m],
                               atol=1e-12)


def test_characteristic_length_is_the_radius_of_gyration():
    box = static_body_from_scene(load_scene("box_on_ground"))
    assert box.characteristic_length == pytest.approx(math.sqrt((1.0 + 0.25) / 12.0))
    disk = static_body_from_scene(load_scene("disk_in_wedge"))
    assert disk.characteristic_length == pytest.approx(0.1 / math.sqrt(2.0))
    given = static_body_from_scene(load_scene("box_on_ground"), characteristic_length=2.0)
    assert (given.characteristic_length, given.length_source) == (2.0, "given")


def test_a_locked_robot_is_one_body_with_pinocchios_mass_and_centre_of_mass():
    scene = load_scene("rhex_flip")
    body = static_body_from_scene(scene)
    model = scene.robot.model
    assert body.mass == pytest.approx(sum(inertia.mass for inertia in model.inertias))
    data = model.createData()
    com = pin.centerOfMass(model, data, scene.robot.pinocchio_q_from_minimal(scene.q))[:2]
    np.testing.assert_allclose(body.com, com, atol=1e-12)
    # five contacts on flat ground, all able to carry force: the force set has dimension 2k - 3
    assert static_equilibrium(body, force_ranges=False).dimension == 2 * len(body.contact_names) - 3


# ---------------------------------------------------------------------------------------------
# box on an incline: it slides at tan(alpha) = mu, tips at tan(alpha) = width / height = 2


def equilibrium_on_incline(write_scene, mu, limit):
    def holds(alpha):
        scene = load_scene(write_scene(incline(alpha, mu)))
        exists = static_equilibrium(static_body_from_scene(scene), force_ranges=False).exists
        if abs(alpha - limit) > 1e-6:  # one rigid body: the same question (up to the tolerances)
            assert weak_stability(scene).weakly_stable == exists
        return exists

    return holds


@pytest.mark.parametrize(("mu", "limit"), [(0.5, math.atan(0.5)), (1.5, math.atan(1.5)),
                                           (5.0, math.atan(2.0)), (1e8, math.atan(2.0))])
def test_box_on_an_incline_slides_or_tips_at_the_closed_form_angle(write_scene, mu, limit):
    found = transition(equilibrium_on_incline(write_scene, mu, limit), 0.0, 1.5)
    assert abs(found - limit) < 1e-6


@pytest.mark.parametrize(("mu", "limit"), [(0.5, math.atan(0.5)), (5.0, math.atan(2.0))])
def test_box_on_an_incline_is_strongly_stable_exactly_where_it_is_weakly_stable(write_scene, mu, limit):
    for alpha, expected in ((limit - 1e-3, True), (limit + 1e-3, False)):
        report = analyze_statics(load_scene(write_scene(incline(alpha, mu))), force_ranges=False)
        assert report.equilibrium.exists is expected
        assert report.weakly_stable is expected
        assert report.strongly_stable is expected
        assert report.support.contains_com is expected


def test_support_interval_on_an_incline_spans_the_contacts(write_scene):
    alpha = 0.3
    scene = load_scene(write_scene(incline(alpha, 0.5)))
    support = support_region(static_body_from_scene(scene))
    xs = scene.state().contact_points[:, 0]
    assert (support.x_min, support.x_max) == pytest.approx((xs.min(), xs.max()), abs=1e-9)
    assert support.x_max - support.x_min == pytest.approx(math.cos(alpha))


def test_frictionless_box_only_stands_on_level_ground(write_scene):
    for alpha in (1e-4, 0.1, 0.5):
        body = static_body_from_scene(load_scene(write_scene(incline(alpha, 0.0))))
        result = static_equilibrium(body)
        assert not result.exists and result.residual > 0
    level = static_equilibrium(static_body_from_scene(load_scene(write_scene(incline(0.0, 0.0)))))
    # mu = 0: lam_T = 0, and the two normal forces are fixed by the vertical and moment balances
    assert level.exists and level.dimension == 0 and not level.statically_indeterminate
    np.testing.assert_allclose(level.lambda_n, [G / 2, G / 2], atol=1e-9)
    np.testing.assert_allclose(level.lambda_t, [0.0, 0.0], atol=1e-9)


# ---------------------------------------------------------------------------------------------
# ladder: tan(theta_min) = (1 - mu_f mu_w) / (2 mu_f)


@pytest.mark.parametrize(("mu_floor", "mu_wall"), [(0.4, 0.3), (0.5, 0.0), (0.3, 0.8), (0.25, 0.5)])
def test_ladder_minimum_angle(write_scene, mu_floor, mu_wall):
    closed_form = math.atan((1.0 - mu_floor * mu_wall) / (2.0 * mu_floor))

    def slips(theta):
        body = static_body_from_scene(load_scene(write_scene(ladder(theta, mu_floor, mu_wall))))
        return not static_equilibrium(body, force_ranges=False).exists

    assert abs(transition(slips, 0.02, 1.55) - closed_form) < 1e-6


def test_ladder_forces_at_rest_are_in_the_cones_and_balance(write_scene):
    mu_f, mu_w = 0.4, 0.3
    theta = math.atan((1.0 - mu_f * mu_w) / (2.0 * mu_f))
    body = static_body_from_scene(load_scene(write_scene(ladder(theta + 1e-9, mu_f, mu_w))))
    result = static_equilibrium(body)
    assert result.exists and result.dimension == 0  # at the limit the forces are unique
    # limiting forces: N_f = m g / (1 + mu_f mu_w), N_w = mu_f N_f
    n_floor = G / (1.0 + mu_f * mu_w)
    np.testing.assert_allclose(result.lambda_n, [n_floor, mu_f * n_floor], rtol=1e-6)
    assert result.balance_residual < 1e-9


def test_ladder_with_high_friction_stands_at_any_angle(write_scene):
    body = static_body_from_scene(load_scene(write_scene(ladder(0.05, 1.2, 1.0))))
    assert static_equilibrium(body, force_ranges=False).exists


# ---------------------------------------------------------------------------------------------
# disk in a wedge: Nguyen's two-contact force closure; never form closure


@pytest.mark.parametrize("alpha_deg", [30.0, 45.0, 60.0])
def test_disk_in_a_wedge_force_closure_follows_nguyen(write_scene, alpha_deg):
    alpha = math.radians(alpha_deg)
    limit = 1.0 / math.tan(alpha)  # the segment between the contacts is horizontal: 90 deg - alpha off n
    for mu, expected in ((limit * (1 - 1e-3), False), (limit * (1 + 1e-3), True), (1e8, True)):
        body = static_body_from_scene(load_scene(write_scene(wedge(alpha, mu))))
        closure = force_closure(body)
        assert closure.closed is expected
        assert (closure.margin > 0) is expected
        assert not form_closure(body).closed


def nguyen(p1, n1, mu1, p2, n2, mu2) -> float:
    """Signed angular margin of Nguyen's condition (> 0: the segment is strictly inside both cones).

    Nguyen states it for normals pointing into a convex object (the contacts squeeze); with normals
    in any direction the pair may also pull (the segment inside both cones reversed): either way an
    internal force along the segment, strictly inside both cones, is what force closure needs.
    """
    d = (p2 - p1) / np.linalg.norm(p2 - p1)

    def inside(direction, n, mu):
        return math.atan(mu) - math.acos(np.clip(direction @ n, -1, 1))

    squeeze = min(inside(d, n1, mu1), inside(-d, n2, mu2))
    pull = min(inside(-d, n1, mu1), inside(d, n2, mu2))
    return max(squeeze, pull)


def test_two_contact_force_closure_matches_nguyen_on_random_grasps():
    rng = np.random.default_rng(7)
    checked = {True: 0, False: 0}
    for _ in range(300):
        points = rng.uniform(-0.5, 0.5, size=(2, 2))
        angles = rng.uniform(-math.pi, math.pi, size=2)
        normals = np.column_stack([np.cos(angles), np.sin(angles)])
        mu = rng.choice([0.0, 0.2, 0.5, 1.0, 3.0], size=2)
        margin = nguyen(points[0], normals[0], mu[0], points[1], normals[1], mu[1])
        if abs(margin) < 1e-3:
            continue
        body = static_body(points, normals, mu, 1.0, rng.uniform(-0.2, 0.2, 2))
        assert force_closure(body).closed is (margin > 0)
        checked[margin > 0] += 1
    assert checked[True] > 10 and checked[False] > 10


# ---------------------------------------------------------------------------------------------
# form closure: four contacts in the plane, never three, never a disk


def slot(a=0.3, b=-0.3, c=0.3, d=-0.3, mu=0.0):
    """A 1 m square with a contact on each side.

    Bottom at x = a, top at x = b, left at y = c, right at y = d; normals into the square.
    """
    points = [[a, -0.5], [b, 0.5], [-0.5, c], [0.5, d]]
    normals = [[0.0, 1.0], [0.0, -1.0], [1.0, 0.0], [-1.0, 0.0]]
    return static_body(points, normals, mu, 1.0, [0.0, 0.0], scale=BodyScale(characteristic_length=0.3))


def test_four_well_placed_contacts_are_in_form_closure_with_the_closed_form_margin():
    body = slot()
    closure = form_closure(body)
    assert closure.closed and closure.rank == 3
    # scaled wrenches (0, 1, 1), (0, -1, 1), (1, 0, -1), (-1, 0, -1): a tetrahedron whose faces all
    # lie at distance 1/sqrt(5) from the origin
    assert closure.margin == pytest.approx(1.0 / math.sqrt(5.0), abs=1e-12)
    W = closure.wrenches
    # the margin is min over directions of max_j d . w_j: above it everywhere, equal at the weakest
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(2000, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    assert np.min(np.max(directions @ W, axis=1)) >= closure.margin - 1e-12
    assert np.max(closure.weakest_direction @ W) == pytest.approx(closure.margin)
    # an LP per direction: the farthest t with t d in conv{w_j} is the support distance
    for d in [closure.weakest_direction, *directions[:20]]:
        p = W.shape[1]
        result = solve_lp(np.concatenate([np.zeros(p), [-1.0]]),
                          A_eq=np.vstack([np.hstack([W, -d[:, None]]), np.concatenate([np.ones(p), [0.0]])]),
                          b_eq=np.array([0.0, 0.0, 0.0, 1.0]), lb=np.concatenate([np.zeros(p), [0.0]]),
                          door=on("highs"))
        assert result.x[-1] >= closure.margin - 1e-9
    # with mu = 0 force closure is form closure
    frictionless = force_closure(body)
    assert frictionless.closed and frictionless.margin == pytest.approx(closure.margin)


def test_a_pinwheel_of_four_contacts_is_not_in_form_closure():
    closure = form_closure(slot(a=0.25, b=-0.25, c=-0.25, d=0.25))  # every torque has the same sign
    assert not closure.closed and closure.rank == 3 and closure.margin == 0.0


def test_three_frictionless_contacts_never_give_form_closure():
    rng = np.random.default_rng(11)
    for _ in range(200):
        angles = rng.uniform(-math.pi, math.pi, size=3)
        body = static_body(rng.uniform(-1, 1, size=(3, 2)), np.column_stack([np.cos(angles), np.sin(angles)]),
                           0.0, 1.0, rng.uniform(-0.5, 0.5, 2))
        assert not form_closure(body).closed


def test_a_disk_is_never_in_form_closure():
    for k in (3, 4, 6, 12):
        angles = np.linspace(0, 2 * math.pi, k, endpoint=False) + 0.1
        rim = 0.1 * np.column_stack([np.cos(angles), np.sin(angles)])
        body = static_body(rim, -rim, 0.0, 1.0, [0.0, 0.0])  # every normal through the centre
        closure = form_closure(body)
        assert not closure.closed and closure.rank == 2 and closure.margin == 0.0
        if k >= 4:
            assert force_closure(static_body(rim, -rim, 1.5, 1.0, [0.0, 0.0])).closed  # friction helps


# ---------------------------------------------------------------------------------------------
# statically indeterminate: the table on two legs


def test_table_on_two_legs_is_statically_indeterminate():
    body = static_body_from_scene(load_scene("table_on_ground"))
    result = static_equilibrium(body)
    assert result.exists and result.dimension == 1 and result.statically_indeterminate
    weight_half = 5.0 * G / 2  # symmetric legs: N = m g / 2 each, fixed
    np.testing.assert_allclose(result.lambda_n_range, [[weight_half, weight_half]] * 2, atol=1e-6)
    # the free internal force: lam_T,left = -lam_T,right, each within the cone of N
    np.testing.assert_allclose(result.lambda_t_range, [[-0.6 * weight_half, 0.6 * weight_half]] * 2,
                               atol=1e-6)
    assert result.lambda_t[0] == pytest.approx(-result.lambda_t[1], abs=1e-9)
    assert result.cone_slack > 0 and result.tight == ()


# ---------------------------------------------------------------------------------------------
# degenerate input


def test_duplicated_contacts_change_the_force_set_not_the_answers(write_scene):
    base = incline(0.0, 0.5)
    dup = incline(0.0, 0.5)
    dup["contacts"].append({**dup["contacts"][1], "name": "upper_again"})
    one = static_equilibrium(static_body_from_scene(load_scene(write_scene(base))))
    two_body = static_body_from_scene(load_scene(write_scene(dup)))
    two = static_equilibrium(two_body)
    assert one.exists and two.exists
    assert (one.dimension, two.dimension) == (1, 3)  # 2k - 3 for contacts that can all carry force
    assert two.lambda_n[1] + two.lambda_n[2] == pytest.approx(one.lambda_n[1], abs=1e-9)
    np.testing.assert_allclose(two.lambda_n_range[1:], [[0.0, G / 2]] * 2, atol=1e-9)
    closed = slot()
    doubled = static_body(np.vstack([closed.points, closed.points[:1]]),
                          np.vstack([closed.normals, closed.normals[:1]]), 0.0, 1.0, [0.0, 0.0],
                          scale=BodyScale(characteristic_length=0.3))
    assert form_closure(doubled).margin == pytest.approx(form_closure(closed).margin)
    assert force_closure(doubled).closed


def test_huge_friction_is_handled(write_scene):
    body = static_body_from_scene(load_scene(write_scene(incline(1.0, 1e8))))  # tan(1) < 2: no tipping
    result = static_equilibrium(body)
    assert result.exists and np.all(np.isfinite(result.lambda_n_range))
    closure = force_closure(static_body_from_scene(load_scene(write_scene(wedge(math.radians(45), 1e8)))))
    assert closure.closed and 0 < closure.margin < 10


def test_collinear_contacts(write_scene):
    # a rod clamped between two plates at points of one line: nothing resists sliding along it
    clamp = static_body([[-0.4, 0.0], [0.0, 0.0], [0.4, 0.0], [0.2, 0.0]],
                        [[0.0, 1.0], [0.0, -1.0], [0.0, 1.0], [0.0, -1.0]], 0.0, 1.0, [0.0, 0.0])
    closure = form_closure(clamp)
    assert not closure.closed and closure.rank == 2
    # three contacts on one line of the floor: the support interval spans them, the forces have 2k - 3
    floor = static_body([[-0.5, 0.0], [0.1, 0.0], [0.5, 0.0]], [[0, 1]] * 3, 0.5, 1.0, [0.0, 0.25])
    assert static_equilibrium(floor).dimension == 3
    support = support_region(floor)
    assert (support.x_min, support.x_max) == pytest.approx((-0.5, 0.5), abs=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"points": [[0.0, float("nan")]]}, "finite"),
        ({"normals": [[0.0, 0.0]]}, "non-zero"),
        ({"mu": -0.1}, ">= 0"),
        ({"mass": 0.0}, "> 0"),
        ({"com": [0.0]}, "shape"),
        ({"scale": BodyScale(characteristic_length=-1.0)}, "> 0"),
        ({"names": ["a", "b"]}, "distinct"),
    ],
)
def test_static_body_rejects_bad_input(kwargs, match):
    args = {"points": [[0.0, 0.0]], "normals": [[0.0, 1.0]], "mu": 0.5, "mass": 1.0, "com": [0.0, 0.1]}
    args.update(kwargs)
    with pytest.raises(InputError, match=match):
        static_body(**args)


def test_scene_level_errors(write_scene):
    fixed = {"name": "fixed", "robot": str(ROBOTS / "snake_planar.urdf"), "base": "fixed",
             "state": {"q": [0.0] * 8},
             "contacts": [{"name": "a", "link": "link1", "point": [0.2, 0.0], "normal": [0.0, 1.0],
                           "mu": 0.5}]}
    with pytest.raises(InputError, match="fixed base"):
        analyze_statics(load_scene(write_scene(fixed)))
    lifted = incline(0.0, 0.5)  # no active contact: an ordinary case (tests/test_degenerate.py)
    for contact in lifted["contacts"]:
        contact["surface_point"] = [0.0, -0.1]
    assert static_body_from_scene(load_scene(write_scene(lifted))).normals.shape == (0, 2)
    scene = load_scene("box_on_ground")
    with pytest.raises(CoordinateNotFound, match="unknown coordinate 'hip'"):
        analyze_statics(scene, {"hip": 1.0})
    with pytest.raises(InputError, match="entries"):
        static_body_from_scene(scene, [1.0, 2.0])
    with pytest.raises(InputError, match="outside"):
        static_body_from_scene(scene, [0.0, 0.0, 100.0])
    with pytest.raises(InputError, match="lateral_acceleration"):
        support_region(static_body_from_scene(scene), lateral_acceleration=-1.0)


# ---------------------------------------------------------------------------------------------
# inputs


def test_a_push_at_the_friction_limit(write_scene):
    # box on level ground, mu = 0.5: a horizontal push at the CoM is held up to mu m g
    scene = load_scene(write_scene(incline(0.0, 0.5)))
    for push, expected in ((0.5 * G - 1e-6, True), (0.5 * G + 1e-6, False)):
        body = static_body_from_scene(scene, {"x": push})
        assert static_equilibrium(body, force_ranges=False).exists is expected
        assert weak_stability(scene, {"x": push}).weakly_stable is expected


# ---------------------------------------------------------------------------------------------
# support region


def test_support_region_under_lateral_acceleration_is_the_closed_form_rhombus():
    body = static_body_from_scene(load_scene("box_on_ground"))  # contacts at (+-0.5, 0), mu = 0.5
    a = 2.0
    region = support_region(body, lateral_acceleration=a)
    assert region.bounded and region.method == "fourier_motzkin" and region.region_contains_com
    # |c_x| + (a / g) |c_y| <= 0.5
    expected = np.array([[-0.5, 0.0], [0.0, -0.5 * G / a], [0.5, 0.0], [0.0, 0.5 * G / a]])
    got = region.vertices[np.lexsort((region.vertices[:, 1], region.vertices[:, 0]))]
    np.testing.assert_allclose(got, expected[np.lexsort((expected[:, 1], expected[:, 0]))], atol=1e-9)
    # beyond mu g nothing holds
    too_fast = support_region(body, lateral_acceleration=0.5 * G * 1.01)
    assert too_fast.region.empty and not too_fast.region_contains_com


def lifted_support_lp(body, a, direction):
    """max direction . c over {(c, lam+, lam-): equilibrium for the loads (-+m a, -m g) at c}."""
    k2 = 2 * body.k
    G0 = wrench_matrix(body, np.zeros(2), scaled=False)  # about the world origin
    C, _ = cone_rows(body)
    A_eq, b_eq = [], []
    for block, lateral in enumerate((a, -a)):
        load = body.mass * np.array([-lateral, -G])
        row = np.zeros((3, 2 + 2 * k2))
        row[:, 2 + block * k2:2 + (block + 1) * k2] = G0
        row[2, 0], row[2, 1] = load[1], -load[0]  # c x load
        A_eq.append(row)
        b_eq.append(-np.array([load[0], load[1], 0.0]))
    A_ub = np.zeros((2 * C.shape[0], 2 + 2 * k2))
    A_ub[:C.shape[0], 2:2 + k2] = C
    A_ub[C.shape[0]:, 2 + k2:] = C
    cost = np.concatenate([-np.asarray(direction), np.zeros(2 * k2)])
    result = solve_lp(cost, A_ub, np.zeros(A_ub.shape[0]), np.vstack(A_eq), np.concatenate(b_eq),
                      door=on("highs"))
    return -result.objective


def test_fourier_motzkin_region_agrees_with_support_lps():
    body = static_body_from_scene(load_scene("table_on_ground"))
    a = 1.5
    region = support_region(body, lateral_acceleration=a).region
    for angle in np.linspace(0, 2 * math.pi, 16, endpoint=False):
        d = np.array([math.cos(angle), math.sin(angle)])
        expected = lifted_support_lp(body, a, d)
        assert poly.support(region, d, solver="highs") == pytest.approx(expected, abs=1e-7)


def test_without_lateral_acceleration_the_region_is_the_vertical_strip_of_the_interval():
    body = static_body_from_scene(load_scene("box_on_slope"))
    support = support_region(body)
    assert support.method == "interval" and not support.bounded
    # the same set by projection of {(c, lam)} with gravity only: c_y does not enter
    k2 = 2 * body.k
    C, _ = cone_rows(body)
    row = np.hstack([np.zeros((3, 2)), wrench_matrix(body, np.zeros(2), scaled=False)])
    row[2, 0] = -body.weight
    lifted = poly.Polytope(np.hstack([np.zeros((C.shape[0], 2)), C]), np.zeros(C.shape[0]), row,
                           -np.array([0.0, -body.weight, 0.0]))
    projected = poly.project(lifted, [0, 1])
    assert k2 == 4
    for d in ((1.0, 0.0), (-1.0, 0.0)):
        assert poly.support(projected, d) == pytest.approx(poly.support(support.region, d), abs=1e-9)
    assert poly.support(projected, (0.0, 1.0)) == math.inf


def test_centre_of_mass_in_the_interval_iff_equilibrium():
    rng = np.random.default_rng(5)
    alpha = 0.3
    n = [-math.sin(alpha), math.cos(alpha)]
    end = 0.5 * np.array([math.cos(alpha), math.sin(alpha)])
    points = [-end, end]
    interval = support_region(static_body(points, [n, n], 0.5, 1.0, [0.0, 0.3]))
    for cx in rng.uniform(-1.0, 1.0, 40):
        body = static_body(points, [n, n], 0.5, 1.0, [cx, 0.3])
        inside = bool(interval.x_min < cx < interval.x_max)
        if min(abs(cx - interval.x_min), abs(cx - interval.x_max)) > 1e-6:
            assert static_equilibrium(body, force_ranges=False).exists is inside
            assert support_region(body).contains_com is inside


# ---------------------------------------------------------------------------------------------
# weak vs strong stability


@pytest.mark.parametrize("mu", [0.3, 1.0])
def test_rod_jammed_between_walls_is_weakly_but_never_strongly_stable(write_scene, mu):
    limit = math.atan(mu)  # a squeeze holds it iff tan(theta) < mu; it may always fall instead
    inside = load_scene(write_scene(jammed_rod(limit * 0.98, mu)))
    report = analyze_statics(inside, force_ranges=False)
    assert report.weakly_stable and report.equilibrium.exists and not report.strongly_stable
    # free fall straight down between vertical walls: zero normal acceleration and zero force, so
    # the engine names it by its motion: sliding along both walls (R on the left wall, whose
    # tangent points down; L on the right one)
    falls = [s for s in report.strong.solutions if not s.at_rest]
    assert falls and falls[0].max_abs_dv == pytest.approx(G) and falls[0].mode == "RL"
    assert any(s.at_rest for s in report.strong.solutions)  # and it may stay
    outside = load_scene(write_scene(jammed_rod(limit * 1.02, mu)))
    assert not weak_stability(outside).weakly_stable
    assert not strong_stability(outside).strongly_stable


def test_strongly_stable_implies_weakly_stable_on_the_shipped_scenes():
    verdicts = {}
    for name in ("box_on_ground", "box_on_slope", "disk_in_wedge", "table_on_ground", "rod_on_table"):
        report = analyze_statics(load_scene(name), force_ranges=False)
        assert not report.strongly_stable or report.weakly_stable
        assert report.weakly_stable == report.equilibrium.exists  # single rigid bodies
        verdicts[name] = (report.weakly_stable, report.strongly_stable)
    assert verdicts["box_on_ground"] == (True, True)
    assert verdicts["rod_on_table"] == (False, False)  # Painleve's rod rotates about its tip


def test_a_braced_snake_is_in_equilibrium_locked_but_not_with_limp_joints():
    scene = load_scene("snake_climb")
    report = analyze_statics(scene, strong=False, force_ranges=False)
    assert report.equilibrium.exists  # the locked body is held by the channel
    assert report.force_closure.closed
    assert not report.weakly_stable  # with zero joint torques the links fold


# ---------------------------------------------------------------------------------------------
# command line


def cli_app() -> typer.Typer:
    """The real ``frc`` group: its one-line usage errors (exit 2) and error lines (exit 1)."""
    from frcontrol.cli.app import app

    return app


def test_cli_json_shape():
    result = CliRunner().invoke(cli_app(), ["statics", "table_on_ground", "--json"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    for key, kind in (("form_closure", bool), ("form_closure_margin", float), ("force_closure", bool),
                      ("force_closure_margin", float), ("static_equilibrium", bool), ("weakly_stable", bool),
                      ("strongly_stable", bool), ("support_region", dict)):
        assert isinstance(payload[key], kind), key
    assert payload["support_region"]["x_min"] == pytest.approx(-0.45)
    assert payload["equilibrium"]["dimension"] == 1


def test_cli_plot_and_errors(tmp_path):
    png = tmp_path / "statics.png"
    result = CliRunner().invoke(cli_app(), ["statics", "box_on_ground", "--plot", str(png), "--no-strong",
                                            "--lateral-acceleration", "2"])
    assert result.exit_code == 0, result.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = CliRunner().invoke(cli_app(), ["statics", "box_on_ground", "--input", "x=oops"])
    assert bad.exit_code == 2 and "not a number" in bad.output
    missing = CliRunner().invoke(cli_app(), ["statics", "no_such_scene"])
    assert missing.exit_code == 1 and "no such file" in missing.output
