"""Queries on a finished analysis (frcontrol/query.py): the same answers as the other paths.

``solutions_at(analysis, u)`` locates u among the stacked mode domains; it is held to the engine's
mode-by-mode path on the same analysis (``method="batch"``: the same rules one mode at a time), to
the from-scratch path (``solutions_at(scene, u)``: other factorisations, the same modes and
motions) and to the batch ``solutions_at(analysis, U)``, at random inputs, on the facets of the
domains (within and beyond BOUNDARY_TOLERANCE) and in the overlaps of several modes, on every
shipped scene; and the compiled kernel to its NumPy twin.
"""

from __future__ import annotations

import ctypes
import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from conftest import needs_kernel
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from frcontrol.engine import DOMAIN_TOLERANCE, analyze, query_table, solutions_at, solutions_at_batch
from frcontrol.errors import InputError, KernelError
from frcontrol.kernel import compiled
from frcontrol.query import BOUNDARY_TOLERANCE, BatchSolutions
from frcontrol.scene import load_scene, shipped_robots_dir
from frcontrol.solvers import DEFAULT_SETTINGS

SCENES = sorted(p.stem for p in (shipped_robots_dir() / "scenes").glob("*.toml"))

AGREEMENT = 1e-9
"""[-] Accelerations, forces and w of two paths agree to this, relative to max(1, |value|): the
same formulas summed in other orders (the from-scratch path's LU against the analysis's SVD)."""


@cache
def analysed(name: str):
    scene = load_scene(name)
    return scene, analyze(scene, ambiguity=name == "rod_on_table")


def random_inputs(name: str, count: int, seed: int) -> np.ndarray:
    """Inputs within the limits, a third of them with some entries zeroed (where lower-dimensional
    domains live: E u = e holds at u = 0 on the RHex scenes)."""
    problem = analysed(name)[1].problem
    rng = np.random.default_rng(seed)
    U = rng.uniform(problem.lower, problem.upper, (count, problem.m))
    U[: count // 3] *= rng.integers(0, 2, (count // 3, problem.m))
    return U


def close(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.all(np.abs(a - b) <= AGREEMENT * np.maximum(1.0, np.maximum(np.abs(a), np.abs(b)))))


def assert_same(found: list, expected: list, *, w: bool = True, where: str = "", w_sign: bool = True) -> None:
    """Same modes in the same order, the same outputs (and w, in the same basis; ``w_sign`` False:
    in orthonormal bases of the same null space, which may differ by an orthogonal map: the same
    norm, for one direction up to its sign)."""
    assert [s.mode for s in found] == [s.mode for s in expected], where
    for s, r in zip(found, expected, strict=True):
        fields = ["dv", "a_n", "a_t"]
        if s.ambiguous_outputs == "none":
            fields += ["lambda_n", "lambda_t"]
        if w:
            fields += ["lambda_n", "lambda_t", "w"]
            assert s.ambiguity_dim == r.ambiguity_dim and s.ambiguous_outputs == r.ambiguous_outputs, where
        for name in fields:
            if name == "w" and not w_sign:
                assert close(np.linalg.norm(s.w), np.linalg.norm(r.w)), f"{where} mode {s.mode}: w"
                continue
            assert close(getattr(s, name), getattr(r, name)), f"{where} mode {s.mode}: {name}"
        if w:  # the same x: the same residuals (of a point on E u = e within the tolerance, not 0)
            scale = max(1.0, float(np.abs(s.dv).max(initial=0.0)), float(np.abs(s.lambda_n).max(initial=0.0)))
            assert abs(s.equality_residual - r.equality_residual) <= 1e-9 * scale
            assert abs(s.inequality_violation - r.inequality_violation) <= 1e-9 * scale


def assert_batch_matches(batch: BatchSolutions, U: np.ndarray, singles: list[list]) -> None:
    """Point by point, the batch's arrays are the single path's solutions."""
    assert len(batch) == U.shape[0] and batch.offsets[-1] == batch.point.size
    assert np.array_equal(batch.count, np.diff(batch.offsets))
    for i, single in enumerate(singles):
        rows = batch.rows(i)
        assert batch.modes_at(i) == tuple(s.mode for s in single), f"point {i}"
        assert np.all(batch.point[rows] == i)
        for j, s in zip(range(rows.start, rows.stop), single, strict=True):
            for name in ("dv", "lambda_n", "lambda_t", "a_n", "a_t"):
                assert close(getattr(batch, name)[j], getattr(s, name)), f"point {i} {s.mode} {name}"
            assert close(batch.w[j, :s.ambiguity_dim], s.w) and batch.ambiguity_dim[j] == s.ambiguity_dim
            assert batch.ambiguous_outputs[batch.mode_index[j]] == s.ambiguous_outputs


def check_paths(name: str, U: np.ndarray, scratch: bool = True) -> None:
    """Every path at every input of U: located == mode by mode == from scratch, and the batch."""
    scene, analysis = analysed(name)
    singles = []
    for i, u in enumerate(U):
        located = solutions_at(analysis, u)
        assert_same(located, solutions_at(analysis, u, method="batch"), where=f"{name} point {i}")
        if scratch:  # the from-scratch path's w lives in its own basis: compare the motion and forces
            assert_same(located, solutions_at(scene, u), w=False, where=f"{name} point {i} from scratch")
        singles.append(located)
    assert_batch_matches(solutions_at(analysis, U), U, singles)


@pytest.mark.parametrize("name", SCENES)
def test_random_inputs_agree_on_every_shipped_scene(name):
    check_paths(name, random_inputs(name, 24, seed=29))


def facet_points(name: str, count: int, seed: int) -> np.ndarray:
    """Inputs on the facets of the modes' input domains, and BOUNDARY_TOLERANCE / 2 and 2 x it outside.

    For a mode without ambiguity variables each row of D_c is a half-space of u (normalised here
    by its norm); the point on it is the Chebyshev centre of the facet (the other rows hold there by
    the largest margin).
    """
    _, analysis = analysed(name)
    problem = analysis.problem
    rng = np.random.default_rng(seed)
    points: list[np.ndarray] = []
    eligible = [m for m in analysis.feasible_modes
                if not m.ambiguity_dim and m.raw_domain is not None and m.chebyshev_radius > DOMAIN_TOLERANCE]
    for j in rng.permutation(len(eligible)).tolist():
        if len(points) >= 2 * count:  # enough: a sample of the modes (the snake has 64, Solo 144)
            break
        mode = eligible[j]
        H, h = mode.raw_domain.A, mode.raw_domain.b
        norms = np.linalg.norm(H, axis=1)
        for r in np.flatnonzero(norms > 1e-9):
            a = H[r] / norms[r]
            on_facet = on_the_facet(H, h, r)
            if on_facet is None:
                continue
            for offset in (0.0, 0.5 * BOUNDARY_TOLERANCE, -0.5 * BOUNDARY_TOLERANCE, 2 * BOUNDARY_TOLERANCE):
                u = on_facet + offset * a  # outside the facet by ``offset``
                if np.all(u >= problem.lower) and np.all(u <= problem.upper):
                    points.append(u)
    points = np.array(points).reshape(-1, problem.m)
    return points[rng.permutation(len(points))[:count]]


def on_the_facet(H: np.ndarray, h: np.ndarray, r: int) -> np.ndarray | None:
    """The Chebyshev centre of the facet ``H[r] u = h[r]`` of {u: H u <= h} (HiGHS), None if it is
    lower-dimensional (a radius below 1e-6)."""
    from frcontrol.polytope import Polytope, chebyshev_ball

    others = np.delete(np.arange(H.shape[0]), r)
    ball = chebyshev_ball(Polytope(H[others], h[others], H[r:r + 1], h[r:r + 1]), solver="highs")
    return ball.center if ball.found and ball.radius > 1e-6 else None


@pytest.mark.parametrize("name", ["rod_on_table", "box_on_slope", "table_on_ground", "rhex_flip_drives",
                                  "peg_on_surface", "snake_climb"])
def test_points_on_facets_agree(name):
    U = facet_points(name, 60, seed=7)
    assert U.shape[0] >= 6, "too few facet points to test"
    check_paths(name, U, scratch=name != "snake_climb")


def test_a_point_just_outside_a_facet_holds_and_one_beyond_the_tolerance_does_not():
    """The rule itself, on the rod's modes: a non-motion facet's point moved out by half the
    tolerance holds, by twice it does not; a motion facet's point moved in by half the tolerance
    does not hold (the motion must be strict), by twice it does."""
    _, analysis = analysed("rod_on_table")
    tested = 0
    for mode in analysis.feasible_modes:
        system, response = mode.system, mode.response
        H_u = system.G @ response.X_u
        norms = np.linalg.norm(H_u, axis=1)
        H, h = H_u / norms[:, None], (system.g - system.G @ response.x_0) / norms
        for r in range(H.shape[0]):
            on_facet = on_the_facet(np.vstack([H, analysis.problem.input_bound_rows()[0]]),
                                    np.concatenate([h, analysis.problem.input_bound_rows()[1]]), r)
            if on_facet is None:
                continue
            cases = ((-0.5, False), (-2.0, True)) if system.motion[r] else ((0.5, True), (2.0, False))
            for outside, holds in cases:
                u = on_facet + outside * BOUNDARY_TOLERANCE * H[r]
                tested += 1
                assert (mode.mode in [s.mode for s in solutions_at(analysis, u)]) is holds, (mode.mode, r)
                assert (mode.mode in solutions_at(analysis, u[None]).modes_at(0)) is holds
                assert (mode.mode in [s.mode for s in solutions_at(analysis, u, method="batch")]) is holds
    assert tested >= 8


def test_overlaps_report_every_mode():
    """The rod's overlapping modes: at each overlap's centre both modes (and the paths agree)."""
    _, analysis = analysed("rod_on_table")
    assert analysis.overlaps, "the rod on the table has overlapping modes"
    centres = np.array([o.center for o in analysis.overlaps])
    for overlap, u in zip(analysis.overlaps, centres, strict=True):
        assert set(overlap.modes) <= {s.mode for s in solutions_at(analysis, u)}
    check_paths("rod_on_table", centres)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_property_single_and_batch_agree(data):
    name = data.draw(st.sampled_from(["rod_on_table", "box_on_slope", "rhex_flip", "peg_on_surface"]))
    problem = analysed(name)[1].problem
    U = np.array([[data.draw(st.floats(lo, hi, allow_nan=False)) for lo, hi in
                   zip(problem.lower.tolist(), problem.upper.tolist(), strict=True)] for _ in range(3)])
    check_paths(name, U, scratch=False)


@needs_kernel
@pytest.mark.parametrize("name", SCENES)
def test_the_compiled_query_agrees_with_its_numpy_twin(name, monkeypatch):
    _, analysis = analysed(name)
    U = np.vstack([random_inputs(name, 40, seed=3), facet_points(name, 20, seed=5)])
    answers = {}
    for kernel in ("numpy", "compiled"):
        monkeypatch.setenv("FRC_KERNEL", kernel)
        answers[kernel] = ([solutions_at(analysis, u) for u in U], solutions_at(analysis, U))
    for single_numpy, single_compiled in zip(answers["numpy"][0], answers["compiled"][0], strict=True):
        assert_same(single_compiled, single_numpy)
    assert_batch_matches(answers["compiled"][1], U, answers["numpy"][0])


def by_name(analysis, u: np.ndarray) -> dict[str, float]:
    """``u`` as ``{name: value}``."""
    return dict(zip(analysis.problem.inputs, u.tolist(), strict=True))


def assert_bitwise(found: list, expected: list, where: str) -> None:
    """The same solutions to the last bit: modes, arrays and numbers."""
    assert [s.mode for s in found] == [s.mode for s in expected], where
    for s, r in zip(found, expected, strict=True):
        assert type(s) is type(r) and vars(s).keys() == vars(r).keys(), where
        for field, value in vars(r).items():
            got = getattr(s, field)
            if isinstance(value, np.ndarray):
                assert got.dtype == value.dtype and np.array_equal(got, value), f"{where} {s.mode} {field}"
            else:
                assert got == value and type(got) is type(value), f"{where} {s.mode} {field}"


@needs_kernel
@pytest.mark.parametrize("name", SCENES)
def test_the_one_call_query_agrees_with_its_numpy_twin(name, monkeypatch):
    """``query_solutions``, the single query in one call: the compiled kernel's answer is its NumPy
    twin's to round-off, and to the last bit the general path's on the same kernel (the same
    locate_mode and evaluate_mode arithmetic). Where a mode with two or more ambiguity variables is
    consistent, both leave the query to the general path (None)."""
    from frcontrol.kernel import COMPILED, NUMPY

    _, analysis = analysed(name)
    table = query_table(analysis)
    U = np.vstack([random_inputs(name, 30, seed=13), facet_points(name, 20, seed=17)])
    answered = 0
    for i, u in enumerate(U):
        monkeypatch.setenv("FRC_KERNEL", "numpy")  # the twin's inner steps on NumPy too
        numpy = NUMPY.query_solutions(table, u)
        monkeypatch.delenv("FRC_KERNEL")
        fast = COMPILED.query_solutions(table, u)
        assert (numpy is None) == (fast is None), f"{name} point {i}"
        if fast is None:
            assert table.many, f"{name} point {i}"
            continue
        answered += 1
        assert_same(fast, numpy, where=f"{name} point {i}")
        monkeypatch.setenv("FRC_KERNEL", "compiled")
        general = solutions_at(analysis, u, settings=DEFAULT_SETTINGS)  # settings given: the general path
        monkeypatch.delenv("FRC_KERNEL")
        assert_bitwise(fast, general, f"{name} point {i}")
        assert_bitwise(solutions_at(analysis, u.tolist()), fast, f"{name} point {i} as a list")
        assert_bitwise(solutions_at(analysis, by_name(analysis, u)), fast, f"{name} point {i} by name")
    assert answered > len(U) // 2, name


@pytest.mark.parametrize("kernel", ["numpy", pytest.param("compiled", marks=needs_kernel)])
def test_a_consistent_two_variable_mode_takes_the_general_path(kernel):
    """RHex at u = 0, where its mode LSS (two ambiguity variables) holds: the one call leaves it to
    the general path (its w is the engine's rule); at u = (2, -3), where no such mode holds, it answers."""
    from frcontrol import kernel as kernels

    _, analysis = analysed("rhex_flip")
    table = query_table(analysis)
    one_call = getattr(kernels, kernel.upper()).query_solutions
    assert one_call(table, [0.0, 0.0]) is None
    assert "LSS" in [s.mode for s in solutions_at(analysis, [0.0, 0.0])]
    found = one_call(table, [2.0, -3.0])
    general = solutions_at(analysis, {"hip_middle": 2.0, "hip_rear": -3.0})
    assert found is not None and [s.mode for s in found] == [s.mode for s in general]


class _Float(float):
    def __float__(self) -> float:  # a subclass may answer otherwise than its stored value
        return 2.0 * float.__float__(self)


class _Int(int):
    pass


class _Dict(dict):
    pass


PLAIN = [
    ("a list", [0.5, -1.0, 0.25], True), ("a tuple of ints", (0, 1, -2), True),
    ("NumPy floats", [np.float64(0.5)] * 3, True), ("an array", np.array([0.5, -1.0, 0.25]), True),
    ("a reversed array", np.array([0.25, -1.0, 0.5])[::-1], True),
    ("every second entry", (np.arange(6.0) / 10)[::2], True),
    ("a ctypes array", (ctypes.c_double * 3)(0.5, 0.0, 0.25), True),
    ("a big-endian array", np.zeros(3, dtype=">f8"), False), ("float32s", [np.float32(0.5)] * 3, False),
    ("a float32 array", np.zeros(3, dtype=np.float32), False),
    ("a datetime array", np.zeros(3, "M8[s]"), False),
    ("bools", [True, False, 0], False), ("a float subclass", [_Float(0.5)] * 3, False),
    ("an int subclass", [_Int(1), 0, 0], False),
    ("a list subclass", type("L", (list,), {})([0.0] * 3), False),
    ("None", None, False), ("a batch", np.zeros((1, 3)), False), ("a short list", [0.0, 0.0], False),
    ("a NaN", [0.0, float("nan"), 0.0], False), ("an infinity", np.array([0.0, 0.0, -np.inf]), False),
    ("an int too large", [10**400, 0, 0], False), ("a string", "abc", False), ("bytes", b"\x00" * 24, False),
    ("a list of strings", ["0", "0", "0"], False), ("a mapping", {"theta": 0.5, "x": -1}, True),
    ("a mapping to NumPy", {"y": np.float64(0.1)}, True), ("an empty mapping", {}, True),
    ("an unknown name", {"tau": 1.0}, False), ("a mapping to a string", {"x": "1"}, False),
    ("a mapping to a NaN", {"x": float("nan")}, False), ("a mapping outside", {"y": 1e9}, False),
    ("a non-str key", {0: 1.0}, False), ("a dict subclass", _Dict(x=0.5), False),
    ("a mapping to a float subclass", {"x": _Float(0.5)}, False),
]


@pytest.mark.parametrize("what, inputs, plain", PLAIN, ids=[p[0] for p in PLAIN])
def test_the_one_call_takes_plain_inputs_only(what, inputs, plain, monkeypatch):
    """Both kernels' ``query_solutions`` answer the same inputs (plain vectors of m numbers, or dicts of
    them, within the limits; each of exactly its type, so that no Python code runs while they are
    read) and leave the rest to the general path (None); where they answer, it is the general
    path's answer on the NumPy kernel, to round-off."""
    from frcontrol.kernel import COMPILED, NUMPY

    _, analysis = analysed("rod_on_table")
    table = query_table(analysis)
    monkeypatch.setenv("FRC_KERNEL", "numpy")  # the twin's inner steps on NumPy too
    answers = [NUMPY.query_solutions(table, inputs)]
    if plain:
        if isinstance(inputs, dict):
            vector = np.array([float(inputs.get(name, 0.0)) for name in analysis.problem.inputs])
        else:
            vector = np.array(list(inputs), dtype=float)
        general = solutions_at(analysis, vector, settings=DEFAULT_SETTINGS)  # settings: the general path
    monkeypatch.delenv("FRC_KERNEL")
    if compiled is not None:
        answers.append(COMPILED.query_solutions(table, inputs))
    assert all((a is not None) == plain for a in answers), what
    for answer in answers if plain else []:
        assert_same(answer, general, where=what)


def test_a_strided_or_fortran_input_on_every_path():
    """A vector that is not contiguous, and a batch that is not C-ordered, on the one call, the general
    path on an analysis (RHex at u = 0, where a two-variable mode holds; a solver given), from
    scratch and as a batch: the answers of their contiguous copies."""
    for name in ("rod_on_table", "rhex_flip"):
        scene, analysis = analysed(name)
        m = analysis.problem.m
        u = np.zeros(2 * m)[::2]
        for where in (analysis, scene):
            expected = solutions_at(where, np.zeros(m))
            assert_same(solutions_at(where, u), expected, w=where is analysis, where=name)
        assert_same(solutions_at(analysis, u, solver="daqp"), solutions_at(analysis, np.zeros(m)), where=name)
        U = random_inputs(name, 8, seed=31)
        for odd in (np.repeat(U, 2, axis=0)[::2], np.asfortranarray(U)):
            assert_batch_matches(solutions_at(analysis, odd), U, [solutions_at(analysis, x) for x in U])


@pytest.mark.parametrize("inputs, error", [
    ([0.0, float("nan"), 0.0], "must be finite"), ([1e9, 0.0, 0.0], "outside its limits"),
    ([0.0, 0.0], "the input vector has 2 entries"), ({"tau_x": 1.0}, "unknown coordinate 'tau_x'"),
])
def test_a_bad_input_on_an_analysis_still_raises_its_typed_error(inputs, error):
    from frcontrol.errors import FrcontrolError

    _, analysis = analysed("rod_on_table")
    with pytest.raises(FrcontrolError, match=error):
        solutions_at(analysis, inputs)


def test_a_batch_in_chunks_is_the_same_batch():
    _, analysis = analysed("box_on_slope")
    U = random_inputs("box_on_slope", 50, seed=11)
    table = query_table(analysis)
    whole = table.locate_batch(U, lambda H, h, motion: None)
    chunked = table.locate_batch(U, lambda H, h, motion: None, chunk=7)
    for name in ("count", "point", "mode_index", "dv", "lambda_n", "lambda_t", "w"):
        assert np.array_equal(getattr(whole, name), getattr(chunked, name)), name


def test_the_batch_shape_and_json():
    _, analysis = analysed("rhex_flip")
    U = random_inputs("rhex_flip", 12, seed=2)
    batch = solutions_at_batch(analysis, U)
    S, n, k = batch.point.size, analysis.problem.n, analysis.problem.k
    assert batch.count.shape == (12,) and batch.offsets.shape == (13,)
    assert batch.dv.shape == (S, n) and batch.lambda_n.shape == (S, k) and batch.a_t.shape == (S, k)
    assert batch.w.shape == (S, 2) and batch.mode_index.shape == (S,)
    assert batch.tolerance == BOUNDARY_TOLERANCE
    assert np.all(np.diff(batch.point) >= 0)
    document = json.loads(json.dumps(batch.to_dict()))
    assert document["count"] == batch.count.tolist() and len(document["dv"]) == S


def test_an_empty_batch_and_a_scene_batch():
    scene, analysis = analysed("rod_on_table")
    empty = solutions_at(analysis, np.zeros((0, 3)))
    assert len(empty) == 0 and empty.point.size == 0 and empty.offsets.tolist() == [0]
    U = random_inputs("rod_on_table", 5, seed=1)
    on_scene = solutions_at(scene, U)  # analysed first
    expected = [tuple(s.mode for s in solutions_at(analysis, u)) for u in U]
    assert [on_scene.modes_at(i) for i in range(5)] == expected


@pytest.mark.parametrize("bad, text", [
    (np.zeros((4, 2)), r"shape \(N, 3\)"),
    (np.array([[0.0, np.nan, 0.0]]), "point 0 of the batch has a NaN"),
    (np.array([[0.0, 0.0, 0.0], [1e9, 0.0, 0.0]]), "point 1 of the batch: input"),
    ([["a", "b", "c"]], "array of numbers"),
])
def test_bad_batches_are_input_errors(bad, text):
    _, analysis = analysed("rod_on_table")
    with pytest.raises(InputError, match=text):
        solutions_at_batch(analysis, bad)


@needs_kernel
def test_the_query_kernel_refuses_bad_buffers():
    _, analysis = analysed("box_on_slope")
    table = query_table(analysis)
    args = list(table.kernel_arguments)
    status, w = np.empty((1, len(table.modes)), dtype=np.int8), np.empty((1, len(table.modes)))
    with pytest.raises(KernelError, match="locate_points takes 18 arguments"):
        compiled.locate_points(*args)
    with pytest.raises(KernelError, match="kernel buffer U"):
        compiled.locate_points(*args, np.zeros((1, 2)), status, w)
    with pytest.raises(KernelError, match="kernel buffer status"):
        compiled.locate_points(*args, np.zeros((1, 3)), np.empty((1, len(table.modes))), w)
    bad = list(args)
    bad[6] = table.row_count + 1000  # more rows than the table holds
    with pytest.raises(KernelError, match="mode 0 has"):
        compiled.locate_points(*bad, np.zeros((1, 3)), status, w)
    one = np.zeros(1)
    with pytest.raises(KernelError, match="solution 0 has mode 99"):
        compiled.evaluate_points(*args, np.zeros((1, 3)), np.zeros(1, dtype=np.int64), np.array([99]),
                                 np.zeros((1, table.p_max)), np.empty((1, table.X_u.shape[1])),
                                 np.empty((1, 2 * analysis.problem.k)), one, one.copy())
    problem = analysis.problem
    from frcontrol.engine import INPUT_LIMIT_SLACK, RigidSolution

    plan = [*args, RigidSolution, table.modes, table.ambiguous_outputs, np.empty, problem.inputs,
            np.float64, problem.lower, problem.upper, INPUT_LIMIT_SLACK, problem.n, problem.k]
    assert compiled.query_solutions(compiled.query_plan(*plan), [0.0, 0.0, 0.0])  # as the table makes it
    with pytest.raises(KernelError, match="query_plan takes 26 arguments"):
        compiled.query_plan(*plan[:-1])
    with pytest.raises(KernelError, match="kernel buffer upper"):
        compiled.query_plan(*plan[:22], np.zeros(2), *plan[23:])
    with pytest.raises(KernelError, match="names must be a tuple of 3 input names"):
        compiled.query_plan(*plan[:19], problem.inputs[:2], *plan[20:])
    with pytest.raises(KernelError, match="input name 1 is not a str"):
        compiled.query_plan(*plan[:19], ("x", 1, "theta"), *plan[20:])
    with pytest.raises(KernelError, match="solution_type must be a type"):
        compiled.query_plan(*plan[:16], table.modes[:-1], *plan[17:])
    with pytest.raises(KernelError, match="n \\+ 2k"):
        compiled.query_plan(*plan[:-1], problem.k + 1)
    with pytest.raises(KernelError, match="mode 0 has no name"):
        compiled.query_plan(*plan[:16], (0,) * len(table.modes), *plan[17:])
    with pytest.raises(KernelError, match="query_solutions takes 2 arguments"):
        compiled.query_solutions(table.plan)
    with pytest.raises(KernelError, match="not a query_plan"):
        compiled.query_solutions(object(), np.zeros(3))
    with pytest.raises(KernelError, match="must be bytes"):
        compiled.environment_value("FRC_KERNEL")
    for solution_type in (type, int, tuple):  # not made by object.__new__: refused, never half made
        with pytest.raises(KernelError, match="solution_type must be a class made by object.__new__"):
            compiled.query_plan(*plan[:15], solution_type, *plan[16:])
    with pytest.raises(KernelError, match="float64 must be a subclass of float"):
        compiled.query_plan(*plan[:20], int, *plan[21:])

    def no_memory(shape):
        raise MemoryError("no room")

    failing = compiled.query_plan(*plan[:18], no_memory, *plan[19:])
    with pytest.raises(MemoryError, match="no room"):  # the error itself, not a SystemError
        compiled.query_solutions(failing, [0.0, 0.0, 0.0])


def test_the_docs_page_names_the_tolerance():
    text = (Path(__file__).resolve().parent.parent / "docs" / "speed.md").read_text()
    assert "BOUNDARY_TOLERANCE" in text and f"{BOUNDARY_TOLERANCE:g}" in text


@pytest.mark.parametrize("inputs", [
    [0.0, 1.0, 2.0], (0.0, 1.0, 2.0), np.zeros(3), np.zeros((4, 3)), [[0.0, 1.0, 2.0]], ((0.0, 1.0, 2.0),),
    [np.zeros(3), np.zeros(3)], [np.array(0.0), np.array(1.0), np.array(2.0)], [np.float64(1.0)] * 3, [],
    np.zeros((2, 2, 3)), [[[0.0]]], [range(3), range(3)],
])
def test_a_batch_is_told_apart_as_numpy_would(inputs):
    """``solutions_at``'s cheap test of a batch answers as ``np.ndim(inputs) == 2`` does."""
    from frcontrol.engine import _is_batch

    assert _is_batch(inputs) == (np.ndim(inputs) == 2)
    assert not _is_batch({"x": 1.0})


@pytest.mark.parametrize("name", ["rod_on_table", "box_on_slope", "rhex_flip"])
def test_the_querys_solutions_are_ordinary_frozen_solutions(name):
    """The query fills each RigidSolution's fields at once (QueryTable.solutions, and the kernel's
    query_solutions on the compiled kernel): the same object as the
    dataclass's own ``__init__`` makes, equal, with the same repr, and frozen."""
    import dataclasses

    from frcontrol.engine import RigidSolution

    analysis = analyze(load_scene(name))
    found = solutions_at(analysis, np.zeros(analysis.problem.m))
    assert found
    for solution in found:
        fields = {f.name: getattr(solution, f.name) for f in dataclasses.fields(RigidSolution)}
        made = RigidSolution(**fields)
        assert type(solution) is RigidSolution and repr(solution) == repr(made)
        assert vars(solution).keys() == vars(made).keys()
        with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign"):
            solution.mode = "S"  # type: ignore[misc]


# ------------------------------------------------------------------ the single query from scratch
def scratch_states(name: str, count: int, seed: int) -> list:
    """The scene at its state, then at ``count`` states near it: the velocities perturbed (a moving
    contact keeps fewer letters), a contact lifted or sliding now and then."""
    scene = load_scene(name)
    rng = np.random.default_rng(seed)
    states = [scene]
    for _ in range(count):
        v = scene.v + rng.normal(0.0, 0.05, scene.v.size) * rng.integers(0, 2, scene.v.size)
        states.append(scene.at(scene.q, v))
    return states


def assert_scratch_is_general(fast: list, general: list, where: str) -> None:
    """The one call's solutions are the general path's on the same kernel: to the last bit but the
    contact accelerations, which it sums in index order (to round-off), and a mode with ambiguity
    variables, which it certifies by its rows instead of the SVD: its x to round-off, w in another
    orthonormal basis of the same null space (up to its sign for one variable; its norm the same)."""
    assert [s.mode for s in fast] == [s.mode for s in general], where
    for s, r in zip(fast, general, strict=True):
        assert type(s) is type(r) and vars(s).keys() == vars(r).keys(), where
        if s.ambiguity_dim:
            assert r.ambiguity_dim == s.ambiguity_dim and s.ambiguous_outputs == r.ambiguous_outputs, where
            for name in ("dv", "lambda_n", "lambda_t", "a_n", "a_t"):
                assert close(getattr(s, name), getattr(r, name)), f"{where} {s.mode} {name}"
            assert close(np.linalg.norm(s.w), np.linalg.norm(r.w)), f"{where} {s.mode} w"
            scale = max(1.0, float(np.abs(r.dv).max(initial=0.0)), float(np.abs(r.lambda_n).max(initial=0.0)))
            assert abs(s.equality_residual - r.equality_residual) <= AGREEMENT * scale, where
            assert abs(s.inequality_violation - r.inequality_violation) <= AGREEMENT * scale, where
            continue
        for field, value in vars(r).items():
            got = getattr(s, field)
            if field in ("a_n", "a_t"):
                assert got.dtype == value.dtype and close(got, value), f"{where} {s.mode} {field}"
            elif isinstance(value, np.ndarray):
                assert got.dtype == value.dtype and np.array_equal(got, value), f"{where} {s.mode} {field}"
            else:
                assert got == value and type(got) is type(value), f"{where} {s.mode} {field}"


def problem_arrays(problem) -> tuple:
    """``problem_solutions``'s arrays of a contact problem."""
    return (problem.mass_matrix, problem.jacobian_normal, problem.jacobian_tangent, problem.drift_normal,
            problem.drift_tangent, problem.normal_velocities, problem.tangential_velocities, problem.bias)


def left_to_the_svd(problem, u: np.ndarray) -> bool:
    """Whether the batch path's certificate leaves a full mode of ``problem`` to the SVD at ``u``."""
    from frcontrol.mode_batch import CERTIFIED_MARGIN, _compiled_rows, full_modes
    from frcontrol.response import ILL_CONDITIONED_BAND, RANK_TOLERANCE

    _, letters = full_modes(problem.allowed_modes())
    count, nx = letters.shape[0], problem.n + 2 * problem.k
    status = np.empty(count, dtype=np.int8)
    out = [np.empty((count, nx)), np.empty(count), np.empty(count), np.empty((count, nx, nx)),
           np.empty((count, nx)), np.empty((count, nx))]
    compiled.certified_modes(*_compiled_rows(problem), letters, np.ascontiguousarray(problem.input_map),
                             problem.bias, u, status, *out, CERTIFIED_MARGIN,
                             max(RANK_TOLERANCE, ILL_CONDITIONED_BAND), DOMAIN_TOLERANCE, 1e-12)
    return bool((status == compiled.NOT_CERTIFIED).any())


@needs_kernel
@pytest.mark.parametrize("name", SCENES)
def test_the_scratch_query_is_the_general_paths(name, monkeypatch):
    """``scratch_solutions`` and ``problem_solutions``, the single query from scratch in one call (from
    a scene, from its contact problem), against the general path (the batch path on the scene's
    ``ContactProblem``, the reference their NumPy twins decline to): they decline (False) only where
    the batch path's certificate leaves a mode to the SVD and its rows do not certify it either
    (None at an impact or beyond ``BATCH_MAX_MODES``), answer everywhere else (the rows certifying
    some of the modes the SVD would take), and then with the general path's solutions (its bits on
    the compiled kernel, to round-off on NumPy's; a mode certified by its rows to round-off);
    ``solutions_at`` on the scene and on the problem is the general path's answer either way."""
    from frcontrol.engine import _problem_plan, _scratch_plan
    from frcontrol.errors import ImpactState
    from frcontrol.kernel import NUMPY
    from frcontrol.mode_batch import BATCH_MAX_MODES
    from frcontrol.modes import ContactProblem

    answered = expected = svd = by_rows = 0
    for j, scene in enumerate(scratch_states(name, 4, seed=sum(name.encode()))):
        problem, plan = ContactProblem.from_scene(scene), _scratch_plan(scene)
        U = np.random.default_rng(j).uniform(problem.lower, problem.upper, (6, problem.m))
        U[:2] *= np.random.default_rng(j).integers(0, 2, (2, problem.m))
        for i, u in enumerate(U):
            where = f"{name} state {j} input {i}"
            assert NUMPY.scratch_solutions(scene, u) is None, where
            assert NUMPY.problem_solutions(problem, u) is None, where
            fast = None if plan is None else compiled.scratch_solutions(
                plan, scene.robot.pinocchio_pass(scene.q, scene.v), u)
            from_problem = compiled.problem_solutions(_problem_plan(problem), *problem_arrays(problem), u)
            try:
                general = solutions_at(problem, u, method="batch")
            except ImpactState:
                assert fast is None and from_problem is None, where
                continue
            assert fast is None or (from_problem is False) == (fast is False), where
            if isinstance(from_problem, list):
                assert_scratch_is_general(from_problem, general, f"{where} (problem)")
            if plan is not None and np.prod([len(a) for a in problem.allowed_modes()]) <= BATCH_MAX_MODES:
                expected += 1
                svd += fast is False
                by_rows += isinstance(fast, list) and left_to_the_svd(problem, u)
                assert fast is not False or left_to_the_svd(problem, u), where
            if isinstance(fast, list):
                answered += 1
                assert_scratch_is_general(fast, general, where)
                monkeypatch.setenv("FRC_KERNEL", "numpy")
                assert_same(fast, solutions_at(problem, u), where=where, w_sign=False)
                monkeypatch.delenv("FRC_KERNEL")
            assert_scratch_is_general(solutions_at(scene, u), general, where)
            assert_scratch_is_general(solutions_at(problem, u), general, f"{where} (problem)")
    assert answered + svd == expected, name  # None only at an impact or beyond the batch's modes
    if name in ("box_on_slope", "box_tip", "table_on_ground", "peg_on_surface"):
        assert by_rows, f"{name}: its fixed modes (rank-deficient) are certified by their rows"


@needs_kernel
@pytest.mark.parametrize("what, inputs, plain", PLAIN, ids=[p[0] for p in PLAIN])
def test_the_scratch_query_takes_plain_inputs_only(what, inputs, plain):
    """The one call from scratch takes the inputs the one call on an analysis takes (the same
    ``plain_input``) and leaves the rest to the general path (None), which raises a bad one's typed
    error; where it answers, it is the general path's answer."""
    from frcontrol.engine import _scratch_plan
    from frcontrol.modes import ContactProblem

    scene = load_scene("rod_on_table")
    problem = ContactProblem.from_scene(scene)
    v = scene.robot.pinocchio_pass(scene.q, scene.v)
    fast = compiled.scratch_solutions(_scratch_plan(scene), v, inputs)
    assert (fast is not None) == plain, what
    if plain:
        if isinstance(inputs, dict):
            vector = np.array([float(inputs.get(name, 0.0)) for name in problem.inputs])
        else:
            vector = np.array(list(inputs), dtype=float)
        assert_scratch_is_general(fast, solutions_at(problem, vector), what)


def test_the_scratch_query_leaves_impacts_springs_and_the_svd_to_the_general_path():
    """An impact raises the general path's ImpactState; a scene with elastic drives gets no plan (its
    bias has their torques); the box's FF (four contact rows on three coordinates: one force
    undetermined) is certified by its rows, and so is RHex with a massless leg in the air (its hip
    torque must be 0: a consistency condition; two legs in the air: two ambiguity variables, decided
    by the polygon rule; RHex in the air, where no row bounds them: w = 0, as the engine's LPs
    report); a state where the rows certify nothing (RHex with rough toes: a sliding toe
    rougher than BALANCING_FRICTION beside a leg in the air, a system the SVD may balance) is
    remembered, and the scene's later queries go the general way at once, with its answers."""
    from frcontrol.engine import _SCRATCH_PLANS, _scratch_plan
    from frcontrol.errors import ImpactState
    from frcontrol.modes import ContactProblem

    rod = load_scene("rod_on_table")
    falling = rod.at(rod.q, np.array([0.0, -1.0, 0.0]))
    with pytest.raises(ImpactState, match="moves into its surface|impact"):
        solutions_at(falling, {})
    assert _scratch_plan(load_scene("rhex_flip_drives")) is None
    box = load_scene("box_on_slope")
    first = solutions_at(box, {})
    assert [s.mode for s in first] == ["FF"] and s_ambiguous(first)
    if compiled is not None:
        assert _SCRATCH_PLANS[box] is not None
    assert_scratch_is_general(first, solutions_at(ContactProblem.from_scene(box), {}, method="batch"), "box")
    rhex = load_scene("rhex_flip")
    for u in ([2.0, -3.0], [0.0, 0.0]):
        first = solutions_at(rhex, u)
        if compiled is not None:
            assert _SCRATCH_PLANS[rhex] is not None, u
        general = solutions_at(ContactProblem.from_scene(rhex), u, method="batch")
        assert_scratch_is_general(first, general, "rhex")
    assert max(s.ambiguity_dim for s in solutions_at(rhex, {})) == 2  # LSS: two legs in the air
    air = rhex.at(rhex.q + np.array([0.0, 0.3, 0.0, 0.0, 0.0]), rhex.v)  # no row bounds w: the LPs give 0
    for u in ([0.0, 0.0], [1.0, -2.0]):  # the legs' torques must be 0: falling, or no mode
        first = solutions_at(air, u)
        if compiled is not None:
            assert _SCRATCH_PLANS[air] is not None, u
        general = solutions_at(ContactProblem.from_scene(air), u, method="batch")
        assert_scratch_is_general(first, general, "air")
    assert [(s.mode, s.w.tolist()) for s in solutions_at(air, [0.0, 0.0])] == [("", [0.0, 0.0])]
    rough = load_scene("rhex_flip", overrides={"contacts.middle_toe.mu": 1.5, "contacts.rear_toe.mu": 1.5})
    first = solutions_at(rough, [2.0, -3.0])
    if compiled is not None:
        assert rough in _SCRATCH_PLANS and _SCRATCH_PLANS[rough] is None
    general = solutions_at(ContactProblem.from_scene(rough), [2.0, -3.0], method="batch")
    assert_scratch_is_general(first, general, "rough rhex")
    assert_scratch_is_general(solutions_at(rough, [2.0, -3.0]), general, "rough rhex again")


def s_ambiguous(solutions: list) -> bool:
    return all(s.ambiguity_dim == 1 for s in solutions)


@needs_kernel
def test_the_scratch_kernel_refuses_bad_arguments():
    """A wrong plan, velocity or plan argument raises KernelError naming it."""
    from frcontrol.engine import _problem_plan, _scratch_plan
    from frcontrol.modes import ContactProblem

    scene = load_scene("rod_on_table")
    plan = _scratch_plan(scene)
    with pytest.raises(KernelError, match="not a scratch_plan"):
        compiled.scratch_solutions(object(), scene.v, {})
    with pytest.raises(KernelError, match="kernel buffer v: axis 0 has 2 entries, expected 3"):
        compiled.scratch_solutions(plan, np.zeros(2), {})
    with pytest.raises(KernelError, match="takes 3 arguments"):
        compiled.scratch_solutions(plan, scene.v)
    problem = ContactProblem.from_scene(scene)
    with pytest.raises(KernelError, match="not a problem's scratch_plan"):
        compiled.problem_solutions(plan, *problem_arrays(problem), {})
    problem_plan = _problem_plan(problem)
    with pytest.raises(KernelError, match="the plan is a problem's"):
        compiled.scratch_solutions(problem_plan, scene.v, {})
    with pytest.raises(KernelError, match="kernel buffer bias: axis 0 has 2 entries, expected 3"):
        compiled.problem_solutions(problem_plan, *problem_arrays(problem)[:-1], np.zeros(2), {})
    with pytest.raises(KernelError, match="the arrays are of n = 2, k = 1; the plan's of n = 3"):
        compiled.problem_solutions(problem_plan, np.eye(2), np.ones((1, 2)), np.ones((1, 2)), *problem_arrays(
            problem)[3:7], np.zeros(2), {})
    with pytest.raises(KernelError, match="without a robot, frames, positions and lines must be None"):
        compiled.scratch_plan(None, (), None, None, *_plan_tail(scene))
    good = [*scene.robot.kernel_state_plan(scene.active_indices)[:4], *_plan_tail(scene)]
    assert compiled.scratch_plan(*good) is not None
    mu_error = "kernel buffer mu: axis 0 has 2 entries, expected 1|frames and positions must be"
    for index, bad, message in [(1, (), "frames and positions must be tuples of 1"),
                                (6, np.array([0.5, 0.5]), mu_error),
                                (3, (1.0,), "lines must be a tuple of 5 floats"),
                                (9, int, "solution_type must be a class"),
                                (11, ("x",), "names must be a tuple"),
                                (2, (), "frames and positions must be tuples of 1"),
                                (13, ("none", "forces"), "outputs a tuple of 3 str"),
                                (31, 13, r"polygon_max_rows must be in \[0, 12\], got 13"),
                                (31, -1, r"polygon_max_rows must be in \[0, 12\], got -1")]:
        args = list(good)
        args[index] = bad
        with pytest.raises(KernelError, match=message):
            compiled.scratch_plan(*args)


def _plan_tail(scene) -> list:
    """``scratch_plan``'s arguments after the robot, frames, positions and lines, for the rod."""
    inputs = scene.inputs
    return [None, np.ascontiguousarray(inputs.selection_transpose(3)), np.array([0.5]), inputs.lower,
            inputs.upper, type("S", (), {}), np.empty, tuple(inputs.coordinates), np.float64,
            ("none", "forces", "accelerations"), 1e-9, 1e-9, 10.0, 1e-9, 1e-9, 1e-12, 1024, 1e-9, 2.2e-16,
            5e-11, 2.2e-15, 1.0, 1e-9, 1.0, 1e-9, 1e-9, 1e-12, 8, 1e-12, 1e-6]


@needs_kernel
def test_the_one_call_agrees_with_the_batch_path_on_random_problems():
    """``problem_solutions`` on random contact problems (two contacts on one point now and then: forces
    undetermined; friction up to 5, past the balancing threshold; sliding and separating contacts)
    against the batch path: where it answers, the same modes, the same x to round-off (a mode
    certified by its rows at the same centre of its w-interval or polygon), w up to an orthogonal map;
    where the engine's w is its Chebyshev LP's point and that is one of several (an optimal face), it
    leaves this input to the general path (None): only that path's LP says which point it gives."""
    from test_mode_batch import random_problem

    from frcontrol.engine import _problem_plan

    rng = np.random.default_rng(20261128)
    answered = by_rows = declined = faces = 0
    for i in range(400):
        problem = random_problem(rng)
        u = rng.normal(size=problem.m) * 5.0
        general = solutions_at(problem, u, method="batch")
        fast = compiled.problem_solutions(_problem_plan(problem), *problem_arrays(problem), u)
        if fast is False or fast is None:
            declined += fast is False
            faces += fast is None
            assert left_to_the_svd(problem, u), f"problem {i}"
            assert fast is False or any(s.ambiguity_dim == 2 for s in general), f"problem {i}"
            continue
        assert isinstance(fast, list), f"problem {i}"
        answered += 1
        by_rows += left_to_the_svd(problem, u)
        assert_scratch_is_general(fast, general, f"problem {i}")
    assert answered > 150 and by_rows > 10 and declined > 5, (answered, by_rows, declined, faces)


BAD_NUMBERS = [(field, bad) for field in ("mass_matrix", "bias", "input_map", "jacobian_normal",
                                          "jacobian_tangent", "drift_normal", "drift_tangent",
                                          "normal_velocities", "tangential_velocities", "mu")
               for bad in (np.nan, np.inf)] + [("lower", np.nan), ("upper", np.nan), ("mu", -0.5)]


@pytest.mark.parametrize("field, bad", BAD_NUMBERS, ids=[f"{f}={b}" for f, b in BAD_NUMBERS])
def test_a_hand_made_problem_with_a_bad_number_is_an_input_error(field, bad):
    """A ContactProblem made by hand with a NaN or infinite number (a NaN limit, a negative friction
    coefficient): ``solutions_at`` and ``analyze`` raise InputError naming the array, whichever path
    would have answered (the one call declines such a problem; before, the batch path listed no
    mode, or modes, or raised NumPy's LinAlgError)."""
    import dataclasses

    from frcontrol.engine import _problem_plan

    problem = problem_of("rod_on_table")
    values = np.array(getattr(problem, field), dtype=float)
    values.flat[0] = bad
    broken = dataclasses.replace(problem, **{field: values})
    message = rf"ContactProblem\.{field} has (a NaN|a negative)"
    with pytest.raises(InputError, match=message):
        solutions_at(broken, np.zeros(broken.m))
    with pytest.raises(InputError, match=message):
        analyze(broken)
    if compiled is not None:
        plan = _problem_plan(broken)
        assert plan is None or compiled.problem_solutions(plan, *problem_arrays(broken), np.zeros(3)) is None


def test_a_hand_made_problem_of_wrong_shapes_is_an_input_error():
    import dataclasses

    problem = problem_of("rod_on_table")
    with pytest.raises(InputError, match=r"ContactProblem\.bias has shape \(2,\); .* make it \(3,\)"):
        solutions_at(dataclasses.replace(problem, bias=np.zeros(2)), {})
    with pytest.raises(InputError, match=r"ContactProblem\.jacobian_tangent has shape \(1, 2\)"):
        analyze(dataclasses.replace(problem, jacobian_tangent=np.zeros((1, 2))))


def problem_of(name: str):
    from frcontrol.modes import ContactProblem

    return ContactProblem.from_scene(load_scene(name))


def legged_problem(rng: np.random.Generator, legs: int):
    """A body on massless legs, as RHex's: three body coordinates with mass, one coordinate per leg
    with none (its hip torque the input), a toe per leg and maybe a body corner in contact."""
    from frcontrol.modes import ContactProblem

    n, corners = 3 + legs, int(rng.integers(0, 2))
    k = corners + legs
    L = rng.normal(size=(3, 3))
    M = np.zeros((n, n))
    M[:3, :3] = L @ L.T + 0.5 * np.eye(3)
    jn, jt = rng.normal(size=(k, n)), rng.normal(size=(k, n))
    jn[:corners, 3:] = jt[:corners, 3:] = 0.0  # a corner is on the body
    for leg in range(legs):  # a toe moves with the body and its own leg only
        toe = corners + leg
        jn[toe, 3:], jt[toe, 3:] = 0.0, 0.0
        jn[toe, 3 + leg], jt[toe, 3 + leg] = rng.normal(), rng.normal()
    bias = np.concatenate([rng.normal(size=3) * 5.0, np.zeros(legs)])  # massless: no weight on a leg
    input_map = np.zeros((n, legs))
    input_map[3 + np.arange(legs), np.arange(legs)] = 1.0
    return ContactProblem(
        coordinates=tuple(f"q{i}" for i in range(n)), contacts=tuple(f"c{i}" for i in range(k)),
        inputs=tuple(f"q{3 + i}" for i in range(legs)), mass_matrix=M, bias=bias, input_map=input_map,
        jacobian_normal=jn, jacobian_tangent=jt, drift_normal=rng.normal(size=k),
        drift_tangent=rng.normal(size=k),
        normal_velocities=np.zeros(k), tangential_velocities=np.zeros(k),
        mu=rng.choice([0.3, 0.8, 1.0], size=k), lower=np.full(legs, -np.inf), upper=np.full(legs, np.inf))


@needs_kernel
def test_the_one_call_decides_massless_legs_as_the_batch_path():
    """Random bodies on one or two massless legs (RHex's structure): a leg in the air leaves its
    acceleration free (an exactly zero column: one ambiguity variable per leg) and its hip torque
    bound to 0 (a consistency condition). ``problem_solutions`` certifies such modes by their rows
    and the left null space, decides two variables by the polygon rule, and gives the batch path's
    modes and x to round-off; the conditions, held (a torque of 0) or not, decide as there. Where
    the engine's w is an LP's point among several, it leaves the input to the general path."""
    from frcontrol.engine import _problem_plan
    from frcontrol.modes import build_mode_system
    from frcontrol.response import solve_affine

    rng = np.random.default_rng(20261129)
    counts = {"answered": 0, "declined": 0, "faces": 0, "two": 0, "conditions": 0}
    for i in range(150):
        problem = legged_problem(rng, int(rng.integers(1, 3)))
        u = np.where(rng.random(problem.m) < 0.5, 0.0, rng.normal(size=problem.m) * 3.0)
        general = solutions_at(problem, u, method="batch")
        fast = compiled.problem_solutions(_problem_plan(problem), *problem_arrays(problem), u)
        if fast is False or fast is None:  # a certificate refused (e.g. every foot fixed: dependent rows
            counts["declined" if fast is False else "faces"] += 1  # whose residual is near round-off's bound)
            continue
        counts["answered"] += 1
        assert_scratch_is_general(fast, general, f"legged problem {i}")
        for solution in fast:
            counts["two"] += solution.ambiguity_dim == 2
            system = build_mode_system(problem, solution.mode)
            counts["conditions"] += solve_affine(system.A, system.B, system.c).E.shape[0] > 0
    # seen: 140 answered, 18 with two variables, 122 with consistency conditions
    assert counts["answered"] > 120 and counts["two"] > 10 and counts["conditions"] > 30, counts


def _two_on_one_point(rng: np.random.Generator, mu: np.ndarray, load: float):
    """A body with two contacts on one point, sticking (FF: the split of their forces is two ambiguity
    variables, a polygon centrally symmetric about its centre) and a hinge torque as its input."""
    from frcontrol.modes import ContactProblem

    L = rng.normal(size=(3, 3))
    jn, jt = rng.normal(size=3), rng.normal(size=3)
    return ContactProblem(
        coordinates=("x", "y", "t"), contacts=("a", "b"), inputs=("t",),
        mass_matrix=L @ L.T + 0.5 * np.eye(3),
        bias=np.array([0.0, load, 0.0]), input_map=np.array([[0.0], [0.0], [1.0]]),
        jacobian_normal=np.array([jn, jn]), jacobian_tangent=np.array([jt, jt]), drift_normal=np.zeros(2),
        drift_tangent=np.zeros(2), normal_velocities=np.zeros(2), tangential_velocities=np.zeros(2), mu=mu,
        lower=np.full(1, -np.inf), upper=np.full(1, np.inf))


@needs_kernel
@pytest.mark.parametrize("case", ["equal", "tapered"])
def test_the_one_call_leaves_a_two_variable_choice_it_cannot_make_to_the_general_path(case):
    """Where the engine's w for two variables is one of several points, only the general path gives
    it: a capped radius whose optimal vertices nearest to w = 0 tie (contacts on one point: a
    symmetric polygon, where round-off in the w basis breaks the tie), or the Chebyshev LP's own point
    on a face nearly optimal (friction mu and mu (1 + delta) on the two contacts: a polygon tapering
    by delta, whose LP stops within its tolerance, ``LP_NEAR_OPTIMAL``). The one call then answers None
    at that input, and elsewhere the batch path's x to round-off. Without the checks, 5 of 100 (equal)
    and 9 of 160 (tapered, small loads) answers differed, x by up to 91%."""
    from frcontrol.engine import _problem_plan

    rng = np.random.default_rng(3 if case == "equal" else 8)
    counts = {"answered": 0, "left": 0}
    for i in range(100):
        mu = rng.uniform(0.3, 1.0)
        if case == "equal":
            load, delta = 9.81 * rng.uniform(0.5, 5), 0.0
        else:
            load = float(rng.choice([0.01, 0.1, 0.5]))
            delta = float(rng.choice([0.0, 1e-9, 1e-7, 1e-6, 1e-4]))
        problem = _two_on_one_point(rng, np.array([mu, mu * (1 + delta)]), load)
        u = rng.normal(size=1) * (1.0 if case == "equal" else load)
        fast = compiled.problem_solutions(_problem_plan(problem), *problem_arrays(problem), u)
        if not isinstance(fast, list):
            counts["left"] += fast is None
            continue
        counts["answered"] += 1
        assert_scratch_is_general(fast, solutions_at(problem, u, method="batch"), f"{case} {i}")
    assert counts["answered"] > 50 and counts["left"] > 5, counts
