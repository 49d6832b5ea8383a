"""An atlas's numeric path (a loaded scene's state and friction set in place) against loading the
scene at every point: the same columns at every point of every shipped scene, errors included.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import needs_kernel

from frcontrol.atlas import AtlasWorkers, build_atlas, run_atlas
from frcontrol.atlas.points import columns, evaluate_chunk, numeric_axes
from frcontrol.errors import SceneError
from frcontrol.scene import load_scene, shipped_scene_names
from frcontrol.scene_numbers import is_numeric_path, scene_with_numbers


def _both_ways(plan):
    """Every chunk's rows by the numeric path and by loading the scene at every point."""
    fast = [evaluate_chunk(plan, c) for c in range(plan.chunk_count)]
    slow = [evaluate_chunk(plan, c, reload=True) for c in range(plan.chunk_count)]
    return fast, slow


def _assert_same_rows(plan, fast, slow):
    for a, b in zip(fast, slow, strict=True):
        assert a["index"] == b["index"]
        for name in columns(plan.what):
            for k, x, y in zip(a["index"], a[name], b[name], strict=True):
                assert repr(x) == repr(y), (plan.scene, name, k, plan.point(k))  # to the bit


def _random_axes(name, rng):
    """A state coordinate (locked joints too), a contact's mu and an input, near the scene's values."""
    scene = load_scene(name)
    raw_q = scene.raw["state"]["q"]
    from frcontrol.model import PlanarRobot

    bare = PlanarRobot(scene.robot.urdf_path, base=scene.robot.base).coordinate_names
    j = int(rng.integers(len(bare)))
    span = float(rng.choice([0.02, 0.3]))
    q0 = float(raw_q[j])
    axes = [f"state.q.{bare[j]}={q0 - span}:{q0 + span}:5"]
    contact = scene.contacts[int(rng.integers(len(scene.contacts)))]
    axes.append(f"contacts.{contact.name}.mu={rng.uniform(0, 0.3):.3f}:{rng.uniform(0.5, 1.5):.3f}:2")
    if scene.inputs.count:
        i = int(rng.integers(scene.inputs.count))
        lo, hi = max(scene.inputs.lower[i], -5.0), min(scene.inputs.upper[i], 5.0)
        axes.append(f"input.{scene.inputs.coordinates[i]}={lo}:{hi}:2")
    moving = [c for c in scene.coordinate_names if c not in scene.robot.locked]
    overrides = {f"state.v.{moving[int(rng.integers(len(moving)))]}": float(rng.choice([0.0, 0.3, -0.5]))}
    return axes, overrides


@pytest.mark.parametrize("name", shipped_scene_names())
def test_the_numeric_path_gives_every_column_of_a_reloaded_scene(name):
    rng = np.random.default_rng(sum(map(ord, name)))
    axes, overrides = _random_axes(name, rng)
    # the velocity as an axis too on every other scene (a fixed --set on the others)
    if rng.integers(2):
        path, value = next(iter(overrides.items()))
        axes, overrides = axes + [f"{path}={value}:{value + 0.25}:2"], {}
    plan = build_atlas(name, axes, overrides=overrides, chunk_size=5)
    assert numeric_axes(plan)
    fast, slow = _both_ways(plan)
    _assert_same_rows(plan, fast, slow)


def test_statics_columns_are_the_same_on_the_numeric_path():
    plan = build_atlas("box_on_ground", ["state.q.theta=-0.05:0.05:3", "contacts.left.mu=0.2:0.9:2",
                                         "input.x=-3:3:2"], what="statics")
    fast, slow = _both_ways(plan)
    _assert_same_rows(plan, fast, slow)
    assert any(v is not None for c in fast for v in c["force_closure"])


def test_errors_stay_per_point_and_are_the_loaders_own():
    # the box lowered into the ground penetrates (the loader's SceneError), raised it lifts off
    plan = build_atlas("box_on_ground", ["state.q.y=0.2:0.3:5", "contacts.right.mu=0.1:0.5:2"])
    fast, slow = _both_ways(plan)
    _assert_same_rows(plan, fast, slow)
    errors = [e for c in fast for e in c["error"]]
    assert sum("penetrates" in (e or "") for e in errors) == 4 and errors.count(None) == 6
    counts = [n for c in fast for n in c["count"]]
    assert counts[-1] == 1  # lifted off: one solution, the free fall


def test_a_numeric_sweep_loads_the_scene_once():
    # a fixed value no other test uses: the scene is not yet among the kept ones
    plan = build_atlas("rod_on_table", ["state.q.theta=0.3:2.8:7", "contacts.tip.mu=0:2:5"],
                       overrides={"state.v.x": -0.9871})
    result = run_atlas(plan, where=AtlasWorkers(1))
    assert result.run["scene_loads"] == 1
    slow = [evaluate_chunk(plan, c, reload=True) for c in range(plan.chunk_count)]
    assert [n for c in slow for n in c["count"]] == result.rows["count"]


def test_a_state_moves_a_problem_without_a_scene_where_the_contacts_follow_it(monkeypatch):
    # rod_on_table's tip touches a table through its own point at any pitch: a solutions atlas
    # makes each pitch's problem from the state alone (no scene), the loaded scene's to the bit; a
    # scene whose contact sits on a fixed surface (box_on_ground) makes the scene at each state
    import frcontrol.atlas.points as points
    from frcontrol.modes import ContactProblem
    from frcontrol.scene_numbers import state_with_numbers

    made = []
    original = points.scene_with_numbers
    monkeypatch.setattr(points, "scene_with_numbers", lambda *args: made.append(1) or original(*args))
    plan = build_atlas("rod_on_table", ["state.q.theta=0.3:2.8:6", "state.v.theta=-0.5:0.5:2"],
                       overrides={"state.v.x": -0.7})
    paths = numeric_axes(plan)
    for k in range(plan.size):
        overrides, _ = plan.point(k)
        _, problem = points.scene_at(plan, overrides, paths, scene_needed=False)
        loaded = load_scene("rod_on_table", overrides={"state.v.x": -0.7, **overrides})
        _same_problem(problem, ContactProblem.from_scene(loaded))
    assert len(made) <= 1  # at most the first point's, made before any point to move from
    box = load_scene("box_on_ground")
    assert state_with_numbers(box, {"state.q.theta": 0.01}) is None
    rod = load_scene("rod_on_table")
    assert state_with_numbers(rod, {"state.q.theta": math.nan}) is None  # the loader's error, then
    assert state_with_numbers(rod, {"gravity": 9.0}) is None
    q, v, mu = state_with_numbers(rod, {"state.q.theta": 1.0, "contacts.tip.mu": 0.25})
    assert q[rod.coordinate_names.index("theta")] == 1.0 and mu.tolist() == [0.25] and v is rod.v


def test_a_locked_joint_or_a_mass_is_not_numeric_and_loads_the_scene():
    scene = load_scene("rhex_flip")
    assert not is_numeric_path(scene, "state.q.hip_front")  # locked: welded into the model
    assert is_numeric_path(scene, "state.q.hip_middle") and is_numeric_path(scene, "contacts.front_toe.mu")
    assert not is_numeric_path(scene, "contacts[0].mu") and not is_numeric_path(scene, "gravity")
    plan = build_atlas("rhex_flip", ["state.q.hip_front=0:0.2:2", "gravity=9:10:2"])
    assert numeric_axes(plan) == frozenset({"state.q.hip_front"})
    fast, slow = _both_ways(plan)
    _assert_same_rows(plan, fast, slow)


def test_scene_with_numbers_is_the_loaded_scene():
    base = load_scene("rod_on_table", overrides={"state.v.x": -1.0})
    numbers = {"state.q.theta": 1.1, "contacts.tip.mu": 0.3, "state.v.theta": 0.5}
    made = scene_with_numbers(base, numbers, base.coordinate_names)
    loaded = load_scene("rod_on_table", overrides={"state.v.x": -1.0, **numbers})
    assert made.q.tobytes() == loaded.q.tobytes() and made.v.tobytes() == loaded.v.tobytes()
    assert dict(made.raw) == dict(loaded.raw)
    for a, b in zip(made.contacts, loaded.contacts, strict=True):
        assert (a.gap, a.active, a.mu) == (b.gap, b.active, b.mu)
        assert a.point.surface_point_in_world.tobytes() == b.point.surface_point_in_world.tobytes()
    assert [c.mu for c in made.robot.contacts] == [0.3]
    with pytest.raises(SceneError, match="must be >= 0"):
        scene_with_numbers(base, {"contacts.tip.mu": -0.1}, base.coordinate_names)
    with pytest.raises(SceneError, match="expected a finite number"):
        scene_with_numbers(base, {"state.q.theta": math.nan}, base.coordinate_names)
    with pytest.raises(SceneError, match="not a numeric override"):
        scene_with_numbers(base, {"gravity": 3.0}, base.coordinate_names)
    box = load_scene("box_on_ground")
    with pytest.raises(SceneError, match="penetrates its surface"):
        scene_with_numbers(box, {"state.q.y": 0.2}, box.coordinate_names)


def _same_problem(a, b):
    """Every field of two contact problems equal, arrays to the bit."""
    for name in a.__dataclass_fields__:
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), name
        else:
            assert x == y, name


@pytest.mark.parametrize("name", shipped_scene_names())
def test_a_problem_at_another_state_is_the_scenes_problem_there(name):
    # at_state: the state's arrays anew, the rest shared; from_scene's problem to the bit (drives,
    # springs and elastic transmissions included), at states near the scene's
    from frcontrol.modes import ContactProblem

    scene = load_scene(name)
    problem = ContactProblem.from_scene(scene)
    rng = np.random.default_rng(sum(map(ord, name)))
    for _ in range(3):
        q = scene.q + rng.normal(scale=0.02, size=scene.q.shape)
        v = scene.v + rng.normal(scale=0.3, size=scene.v.shape)
        _same_problem(problem.at_state(scene, q, v), ContactProblem.from_scene(scene, q, v))


@pytest.mark.parametrize("name, axes", [
    ("rod_on_table", ["state.q.theta=0.3:2.8:4", "contacts.tip.mu=0:2:3", "input.x=-1:1:2"]),
    ("box_on_ground", ["contacts.left.mu=0.2:0.9:3", "state.v.x=-0.5:0.5:3", "contacts.right.mu=0.1:0.4:2"]),
])
def test_each_point_of_a_chunk_has_the_problem_of_its_loaded_scene(name, axes):
    # one point after another as a chunk makes them: from the last point when only friction or an
    # input changed, from the state when it moved; the problem is the loaded scene's to the bit
    from frcontrol.atlas.points import scene_at
    from frcontrol.modes import ContactProblem

    # (a solutions atlas needs no scene: a point that changes only friction makes none, and the
    # next point that needs one brings the last one up to date; needed or not, at random)
    plan = build_atlas(name, axes)
    paths = numeric_axes(plan)
    rng = np.random.default_rng(3)
    made = 0
    for k in range(plan.size):
        overrides, _ = plan.point(k)
        needed = bool(rng.integers(2))
        scene, problem = scene_at(plan, overrides, paths, scene_needed=needed)
        loaded = load_scene(name, overrides=overrides)
        _same_problem(problem, ContactProblem.from_scene(loaded))
        if scene is None:
            assert not needed
            continue
        made += 1
        assert [c.mu for c in scene.contacts] == [c.mu for c in loaded.contacts]
        assert scene.q.tobytes() == loaded.q.tobytes() and dict(scene.raw) == dict(loaded.raw)
        assert [c.mu for c in scene.robot.contacts] == [c.mu for c in loaded.contacts]
    assert made >= plan.size // 4


def test_a_record_replaced_is_the_dataclass_replaced():
    from dataclasses import replace

    from frcontrol.errors import InputError
    from frcontrol.modes import ContactProblem
    from frcontrol.records import replaced

    scene = load_scene("rod_on_table")
    problem = ContactProblem.from_scene(scene)
    assert problem.row_table is not None  # found once and kept: not carried to the new record
    mu = np.array([0.3])
    fast, slow = replaced(problem, mu=mu), replace(problem, mu=mu)
    _same_problem(fast, slow)
    assert "row_table" not in fast.__dict__
    assert fast.row_table.valid.tobytes() == slow.row_table.valid.tobytes()
    moved = replaced(scene, q=scene.q + 0.1)
    assert moved.q.tobytes() == (scene.q + 0.1).tobytes() and moved.robot is scene.robot
    with pytest.raises(InputError, match="has no field 'mus'; its fields: coordinates"):
        replaced(problem, mus=mu)


def test_friction_set_at_once_is_the_loaders_friction():
    # plain floats are set without the loader's reader; every other value takes its checks and errors
    from frcontrol.modes import ContactProblem
    from frcontrol.scene_numbers import _checked_friction, friction_with_numbers

    scene = load_scene("box_on_ground")
    for values in ({"contacts.left.mu": 0.7}, {"contacts.right.mu": 0.0, "contacts.left.mu": 2.5},
                   {"contacts.left.mu": -0.0}, {"contacts.left.mu": 3}):
        fast, checked = friction_with_numbers(scene, values), _checked_friction(scene, values)
        assert fast.tobytes() == checked.tobytes(), values
        loaded = load_scene("box_on_ground", overrides=values)
        assert fast.tobytes() == ContactProblem.from_scene(loaded).mu.tobytes()
    for value, message in ((-0.1, "must be >= 0"), (math.nan, "expected a finite number"),
                           (math.inf, "expected a finite number"), (True, "expected a number")):
        with pytest.raises(SceneError, match=message):
            friction_with_numbers(scene, {"contacts.left.mu": value})
    with pytest.raises(SceneError, match="not a friction override of this scene"):
        friction_with_numbers(scene, {"contacts.lefty.mu": 0.5})


def test_a_problem_with_other_friction_shares_its_states_cache():
    from dataclasses import replace

    from frcontrol.modes import ContactProblem
    from frcontrol.stability import stable_verdicts

    problem = ContactProblem.from_scene(load_scene("rod_on_table", overrides={"state.v.x": -1.0}))
    rough = problem.with_friction(np.array([0.9]))
    assert rough.state_cache is problem.state_cache and rough.kernel_cache is not problem.kernel_cache
    assert replace(problem, mu=np.array([0.9])).state_cache is not problem.state_cache
    from frcontrol.engine import solutions_at

    found = solutions_at(rough, {})
    assert stable_verdicts(rough, found) == stable_verdicts(replace(problem, mu=np.array([0.9])), found)


@needs_kernel
def test_a_problems_family_shares_its_plans_by_friction():
    # with_friction and at_state make problems that share their compiled plans, one per coefficients;
    # a plan found again gives the answers a new plan gives (the same solutions, to the bit)
    from dataclasses import replace

    from frcontrol.engine import solutions_at
    from frcontrol.modes import ContactProblem

    scene = load_scene("rod_on_table", overrides={"state.v.x": -1.0})
    problem = ContactProblem.from_scene(scene)
    q = scene.q.copy()
    q[scene.coordinate_names.index("theta")] = 1.3
    family = [problem.with_friction(np.array([0.4])), problem.at_state(scene, q, scene.v, np.array([0.4])),
              problem.with_friction(np.array([0.7]))]
    assert all(member.plans_by_friction is problem.plans_by_friction for member in family)
    assert replace(problem, mu=np.array([0.4])).plans_by_friction is not problem.plans_by_friction
    for member in family:
        fresh = replace(member)  # its own, empty caches: a new plan
        for a, b in zip(solutions_at(member, {}), solutions_at(fresh, {}), strict=True):
            assert a.mode == b.mode and a.dv.tobytes() == b.dv.tobytes()
            assert a.lambda_n.tobytes() == b.lambda_n.tobytes()
    plans = problem.plans_by_friction
    assert set(plans) == {np.array([0.4]).tobytes(), np.array([0.7]).tobytes()}
    assert family[0].kernel_cache["one_call"] is family[1].kernel_cache["one_call"]
    # coefficients as a list, or as integers whose bytes are another float's: their own plans
    rough = ContactProblem.from_scene(load_scene("rod_on_table", overrides={"state.v.x": -1.0,
                                                                            "contacts.tip.mu": 1.0}))
    expected = [s.dv.tobytes() for s in solutions_at(rough, {})]
    solutions_at(problem.with_friction(np.array([5e-324])), {})  # the bytes of the integer 1
    for mu in (np.array([1]), [1.0]):
        assert [s.dv.tobytes() for s in solutions_at(problem.with_friction(mu), {})] == expected
