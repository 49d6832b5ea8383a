"""The quick benchmark CI runs, and its regression gate: ``python -m benchmarks.ci``.

Run from the repository root, with frcontrol installed::

    python -m benchmarks.ci                                  # measure, write results/ci.json and ci.png
    python -m benchmarks.ci --check benchmarks/baseline.json # ... then exit 1 on a regression
    python -m benchmarks.ci --update-baseline                # ... and write benchmarks/baseline.json
    python -m benchmarks.ci --readme                         # docs/benchmarks.md's table from results/ci.json

It takes about a minute on the 2-core development machine (at most 90 s) and measures every
figure of the speed targets (:data:`FIGURES`):

- every rigid solution at one input, from scratch (``solutions_at`` on a loaded scene, no prior
  analysis): the rod on the table, the box on the slope, the RHex flip scene, all at zero input;
- every rigid solution at one input on an analysis already made (``solutions_at(analysis, u)``,
  the analysis not timed): the same three scenes at zero input, and RHex at
  :data:`QUERY_GENERIC_INPUT` too (at zero input its one mode with two ambiguity variables holds and
  needs its LPs); and at :data:`BATCH_POINTS` random inputs at once (``solutions_at(analysis, U)``),
  checked against the single query at :data:`BATCH_CHECKED_POINTS` of them;
- the full analysis (``analyze`` with its defaults, overlaps included) of the RHex flip scene and
  of the snake climb with every feasible mode's domain D_c and input domain T_c computed ("forced":
  both are lazy properties of :class:`frcontrol.engine.ModeAnalysis`), and the lazy ``analyze``
  alone as an extra figure (the targets hold for the forced one);
- the snake lying on the ground with 8 contacts (``benchmarks/engine.py``'s scene), measured as
  ``benchmarks/engine.py`` measures it: ``analyze`` without overlaps, lazy (forcing its 248
  domains takes about 13 s here, too long for this run);
- model assembly: ``Scene.state`` (M, h, every active contact's rows and drifts) of the RHex scene
  against the bare Pinocchio calls it makes (``benchmarks/engine.py``'s), whose median is reported
  too; the assembly's target is :data:`ASSEMBLY_TARGET_VS_BARE` times the bare calls' median;
- a compliant answer to :data:`benchmarks.trade.TARGET_FORCE_ERROR` relative force error, rod and
  box, with one of the cheapest configurations of ``benchmarks/trade.py``'s sweep for each
  (:data:`COMPLIANT_CONFIGS`); every timed answer's error is checked;
- an atlas's grid point, as a worker computes it in a chunk (the scene loaded once, each point's
  pitch and friction set on it: :mod:`frcontrol.scene_numbers`), for a solutions atlas and a statics
  atlas of the rod (:data:`ATLAS_FIGURE_AXES`; points :data:`ATLAS_FIGURE_STRIDE` grid steps apart,
  and for the solutions atlas also in the grid's order, as a chunk has them), against the query each
  point is made of (``solutions_at`` from scratch, and ``analyze_statics`` of the rod, a figure
  too; a point's stability verdicts are not part of the query, they are of the point): the target is
  :data:`ATLAS_TARGET_VS_QUERY` times the query's median of the same run; every timed point is
  checked against the scene loaded at that point;
- the rigid simulation of the pumping flip (``rhex_flip_drives``, 3 s) and of `rhex_flip`'s flip
  (``rhex_flip``'s closed loop to vertical): each closed loop is run once when the figures are
  built, and its applied inputs are replayed through its stepper (``benchmarks/simulation.py``),
  the replay checked equal to the closed loop's samples bit for bit; the target is
  :data:`SIMULATION_TARGET_REAL_TIME` times faster than real time;
- the start-up of ``frc --help`` and ``frc show rod_on_table`` as processes.

Every answer is checked after it is timed (outside the timed region): the solutions against those
found from a finished analysis, the analyses against the warm-up run's feasible modes, the
compliant forces against the rigid reference, the processes' exit codes. A figure whose answer
fails its check is reported invalid, and the gate fails on it: a broken answer cannot look fast.

Calibration
-----------
Absolute times move with the machine and its load, so each figure is also given as a ratio to a
*calibration workload* measured in the same run: :func:`calibration_workload`, a fixed,
deterministic mix of pure-Python integer arithmetic with dictionary and list traffic and of small
dense NumPy solves and SVDs, the same kind of work as the engine's (about 3.7 ms of CPU here). It
is measured interleaved with the figures: every timed sample of a figure is preceded by a
calibration sample (:data:`CALIBRATION_CALLS` calls), and the rounds go over all the figures in
turn, so the drift of the machine during the run affects a figure and its calibration alike.

Each sample is timed twice: wall time (``time.perf_counter``: the figures, ``median_s``, are what a
user waits) and CPU time (``time.process_time`` plus the finished child processes' user and system
time, for the start-up figures). A figure's ``ratio_to_calibration``, the one the gate compares, is
the median of its CPU times over the median of the CPU times of the calibration samples taken just
before them; ``wall_ratio_to_calibration`` is the same with wall times. On a shared machine, wall
time also counts the time other processes hold the cores: four runs here at a load average of 5-8
on 2 cores (one of them a fresh clone's ``.ci/run``) moved the CPU-time ratios by at most 1.13x for
the in-process figures and 1.24x for the start-up processes, the wall-time ratios by up to 1.48x
(and an earlier run gated on wall-time ratios failed on a false 1.56x "regression"). CPU time
misses what is not computation (waiting for a disk or a lock); the figures are computation, and
the start-up figures' wall times are still reported.

The gate
--------
``--check BASELINE`` compares every figure's ratio with the committed baseline's and exits 1, with
one line per regression on stderr, when a ratio exceeds :data:`REGRESSION_FACTOR` times the
baseline's, when a figure's answer failed its check, or when a figure of the baseline is missing.
It compares ratios measured in one run, never absolute times across machines. Updating the baseline
(``--update-baseline``) is a deliberate commit whose message says why. pytest-benchmark's
``--benchmark-compare-fail`` and asv compare the absolute times of stored runs; neither divides a
figure by a workload measured in the same run, so the gate is :func:`regressions`, with no new
dependency.

Writes ``benchmarks/results/ci.json`` (per figure: ``median_s`` [s, wall], ``runs``,
``ratio_to_calibration`` [-, CPU time], ``target_s``, ``met`` (the wall-time median against the
target), and ``median_cpu_s``, ``wall_ratio_to_calibration``, ``min_s``, ``max_s``; the calibration,
versions, cores and date) and ``benchmarks/results/ci.png``.

This module imports only the standard library and NumPy at its top, so that the tests can load it
for the gate and the benchmarks page's table without running anything.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import resource
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
RESULT_JSON = RESULTS / "ci.json"
RESULT_PNG = RESULTS / "ci.png"
BASELINE = ROOT / "benchmarks" / "baseline.json"
README = ROOT / "docs" / "benchmarks.md"
"""The page that holds the figures table (between README_BEGIN and README_END)."""

RUNS = 7
"""Timed samples per figure (their median is the figure), after one warm-up round."""

REGRESSION_FACTOR = 1.5
"""[-] The gate fails when a figure's ratio to the calibration (CPU time) exceeds this many times
the baseline's: the gate's limit. Between runs on the loaded 2-core development machine the ratios
moved by at most 1.24x (module docstring), so 1.5x flags a regression of half again the time and not
the noise."""

CALIBRATION_CALLS = 3
"""Calls of :func:`calibration_workload` per calibration sample (one sample before each figure
sample)."""

CALIBRATION_SEED = 20261125
"""Seed of the calibration workload's fixed data (a local generator: nothing global is seeded)."""

CALIBRATION_PYTHON_STEPS = 4000
"""Iterations of the calibration workload's pure-Python loop."""

CALIBRATION_SYSTEMS = 120
"""Small dense systems the calibration workload solves (and decomposes) one call at a time."""

CALIBRATION_SIZE = 8
"""[-] Their size (n x n), about that of the engine's per-mode systems."""

CALIBRATION_RESIDUAL_TOLERANCE = 1e-10
"""[-] Largest relative error of the calibration's solves against their known solutions (the
systems are diagonally dominant, condition numbers below 10)."""

ASSEMBLY_TARGET_VS_BARE = 2.0
"""[-] Target of model assembly: ``Scene.state`` at most this many times the bare Pinocchio calls."""

SOLUTION_AGREEMENT = 1e-8
"""[-] Accelerations of a timed solution and of the same mode's solution from a finished analysis
must agree to this, relative to the larger norm (and absolutely below 1)."""

ATLAS_TARGET_VS_QUERY = 2.0
"""[-] Target of an atlas's point: at most this many times the query it is made of, measured in the same
run (``solutions_at`` from scratch for a solutions atlas, ``analyze_statics`` for a statics one)."""

SIMULATION_TARGET_REAL_TIME = 10.0
"""[-] Target of the rigid simulation figures: at least this many times faster than real time (their
``target_s`` is the simulated time over this)."""

SIMULATED_SECONDS: dict[str, float] = {}
"""[s] The simulated time of each simulation figure, filled when the figures are built."""

ATLAS_FIGURE_POINTS = 64
"""Grid points per timed sample of an atlas figure: one chunk's worth, each a different point."""

ATLAS_FIGURE_STRIDE = 37
"""Grid steps between the points of ``atlas_rod_per_point`` (and the statics one): a new friction at
every point and a new pitch at about every third (101 frictions per pitch), distinct points."""

ATLAS_CHUNK_STRIDE = 1
"""Grid steps between the points of ``atlas_rod_chunk_per_point``: the grid's order, as a worker
computes a chunk (the last axis, the friction, varies fastest)."""

ATLAS_FIGURE_AXES = ("state.q.theta=0.1:3.0:181", "contacts.tip.mu=0:2:101")
"""The atlas figures' grid: the rod's pitch [rad] and its tip's friction [-] (with ``state.v.x = -1``)."""

README_BEGIN = "<!-- benchmarks.ci figures: begin (generated by python -m benchmarks.ci --readme) -->"
README_END = "<!-- benchmarks.ci figures: end -->"


BATCH_POINTS = 100_000
"""Inputs of the batch figures (uniform within the scene's limits, a fixed seed)."""

BATCH_CHECKED_POINTS = 200
"""Points of a batch figure's answer checked against the single query, outside the timing."""

QUERY_GENERIC_INPUT = (2.0, -3.0)
"""[N m] The RHex hips' torques of the second RHex query figure: an input where no mode with two
ambiguity variables holds (at u = 0 the mode LSS does, and its LPs dominate)."""


@dataclass(frozen=True)
class Figure:
    """One figure of the quick benchmark.

    Attributes:
        name: its key in the JSON.
        label: what it is, for the benchmarks page's table.
        target_s: the target [s] of its median (None: no target); model assembly's is computed in
            the run (:data:`ASSEMBLY_TARGET_VS_BARE` times the bare calls' median).
        calls: calls per timed sample (a sample is their total time over their number, so that fast
            figures are not timed one call at a time).
        gated: whether the gate checks it (the bare Pinocchio calls are a reference, not ours).
    """

    name: str
    label: str
    target_s: float | None
    calls: int = 1
    gated: bool = True


FIGURES = (
    Figure("solutions_at_rod_on_table", "every rigid solution at one input, from scratch: rod on a table "
           "(u = 0)", 100e-6, calls=20),
    Figure("solutions_at_box_on_slope", "every rigid solution at one input, from scratch: box on a slope "
           "(u = 0)", 200e-6, calls=4),
    Figure("solutions_at_rhex_flip", "every rigid solution at one input, from scratch: RHex flip scene "
           "(u = 0)", 300e-6, calls=2),
    Figure("query_rod_on_table", "every rigid solution at one input on an analysis made: rod on a table "
           "(u = 0)", 10e-6, calls=200),
    Figure("query_box_on_slope", "every rigid solution at one input on an analysis made: box on a slope "
           "(u = 0)", 15e-6, calls=200),
    Figure("query_rhex_flip", "every rigid solution at one input on an analysis made: RHex flip scene "
           "(u = 0, where its two-variable mode LSS holds)", 50e-6, calls=20),
    Figure("query_rhex_flip_generic", "every rigid solution at one input on an analysis made: RHex flip "
           f"scene (u = {QUERY_GENERIC_INPUT})", 50e-6, calls=200),
    Figure("batch_rod_on_table", f"every rigid solution at {BATCH_POINTS:,} random inputs on an analysis "
           "(`solutions_at(analysis, U)`): rod on a table; target 1 us per point", BATCH_POINTS * 1e-6),
    Figure("batch_box_on_slope", f"the same, {BATCH_POINTS:,} inputs: box on a slope; target 1 us per point",
           BATCH_POINTS * 1e-6),
    Figure("batch_rhex_flip", f"the same, {BATCH_POINTS:,} inputs: RHex flip scene; target 10 us per point",
           BATCH_POINTS * 10e-6),
    Figure("analysis_rhex_flip_forced", "RHex flip scene, full analysis with every feasible mode's "
           "domain and input domain computed", 40e-3),
    Figure("analysis_rhex_flip_lazy", "RHex flip scene, `analyze` alone (domains on demand)", None),
    Figure("analysis_snake_climb_forced", "snake_climb, full analysis with every feasible mode's "
           "domain and input domain computed", 0.4),
    Figure("analysis_snake_climb_lazy", "snake_climb, `analyze` alone (domains on demand)", None),
    Figure("analysis_snake_ground_8", "snake on the ground with 8 contacts (`analyze` without overlaps, "
           "domains on demand); target 0.1 ms per evaluated mode", 0.15),
    Figure("analysis_snake_ground_8_forced", "snake on the ground with 8 contacts, every feasible mode's "
           "domain and input domain computed (without overlaps); target 4 ms per feasible mode", 1.0),
    Figure("analysis_snake_ground_10", "snake on the ground with 10 contacts (`analyze` without overlaps, "
           "domains on demand); target 0.1 ms per evaluated mode", 0.6),
    Figure("analysis_snake_ground_10_forced", "snake on the ground with 10 contacts, every feasible mode's "
           "domain and input domain computed (without overlaps); target 4 ms per feasible mode", 4.0),
    Figure("model_assembly_rhex_flip", "model assembly (`Scene.state`), RHex flip scene; target "
           f"{ASSEMBLY_TARGET_VS_BARE:g}x the bare Pinocchio calls", None, calls=300),
    Figure("bare_pinocchio_rhex_flip", "the bare Pinocchio calls of that assembly (reference, "
           "not gated)", None, calls=1000, gated=False),
    Figure("compliant_rod_on_table", "compliant answer to 1e-3 force error: rod on a table", 2e-3, calls=2),
    Figure("compliant_box_on_slope", "compliant answer to 1e-3 force error: box on a slope", 2e-3, calls=2),
    Figure("atlas_rod_per_point", "frc atlas, one point of a chunk: rod, pitch x friction, sliding left; "
           f"target {ATLAS_TARGET_VS_QUERY:g}x the rod's `solutions_at`", None, calls=ATLAS_FIGURE_POINTS),
    Figure("atlas_rod_chunk_per_point", "frc atlas, one point of a chunk in grid order (the friction new at "
           "each point, the pitch every 101): rod, sliding left; "
           f"target {ATLAS_TARGET_VS_QUERY:g}x the rod's `solutions_at`", None, calls=ATLAS_FIGURE_POINTS),
    Figure("statics_rod_on_table", "`analyze_statics` from scratch: rod on a table (u = 0)", None, calls=4),
    Figure("atlas_statics_rod_per_point", "frc atlas --what statics, one point of a chunk: rod, pitch x "
           f"friction; target {ATLAS_TARGET_VS_QUERY:g}x `analyze_statics`", None, calls=ATLAS_FIGURE_POINTS),
    Figure("simulation_rigid_pump", "rigid simulation of the pumping flip (`rhex_flip_drives`, 3 s: the "
           "closed loop's voltages replayed through its stepper); target 10x real time", None),
    Figure("simulation_rigid_flip", "rigid simulation of `rhex_flip`'s flip (`frc flip rhex_flip`'s "
           "closed loop to vertical, replayed); target 10x real time", None),
    Figure("startup_frc_help", "start-up of `frc --help` (a process)", 0.3),
    Figure("startup_frc_show_rod_on_table", "start-up of `frc show rod_on_table` (a process)", 0.6),
)
"""Every figure, in the order of the benchmark table (docs/benchmarks.md)."""

COMPLIANT_CONFIGS: dict[str, dict[str, Any]] = {
    "rod_on_table": {"stiffness": 1e12, "integrator": "implicit", "step_omega": 100.0, "steps": 2},
    "box_on_slope": {"stiffness": 1e10, "integrator": "implicit", "step_omega": 100.0, "steps": 2},
}
"""The compliant configuration per scene: stiffness [N/m], the linearly implicit integrator, its
step in units of ``1/omega_min`` (``omega_min = sqrt(k lambda_min)`` of ``benchmarks/trade.py``'s
reference) and the number of steps. Each is among the cheapest reaching 1e-3 force error in a sweep
(k = 1e8, 1e10, 1e12 N/m; steps of 3, 10, 30 and 100 / omega_min; 2 to 6 steps) on 2026-11-25,
chosen with its error at least 2x below 1e-3 (rod 3.1e-4, box 7.5e-5) so that round-off changes
do not flip its check. Before the implicit integrator the cheapest were lsoda at rtol 1e-3,
k = 1e7 (rod) and 1e5 (box), window 12: 16-42 ms."""


class InvalidAnswer(Exception):
    """A timed answer failed its check."""


# ------------------------------------------------------------------------------------ calibration
@dataclass(frozen=True)
class Calibration:
    """The result of one calibration workload: the same on every call."""

    checksum: int
    solution_error: float
    singular_value_sum: float


def calibration_workload() -> Calibration:
    """The fixed workload every figure is compared with (module docstring, "Calibration").

    A pure-Python part (a linear congruential sequence of :data:`CALIBRATION_PYTHON_STEPS` integers
    binned into a dictionary and a list) and a NumPy part (:data:`CALIBRATION_SYSTEMS` diagonally
    dominant n x n systems with known solutions, from a generator seeded with
    :data:`CALIBRATION_SEED`, each solved and decomposed by SVD one call at a time, like the
    engine's per-mode work). Returns a checksum, the largest relative error of the solves and the
    sum of the singular values: deterministic, and checked by the tests.
    """
    state = CALIBRATION_SEED
    bins: dict[int, int] = {}
    trail: list[int] = []
    for _ in range(CALIBRATION_PYTHON_STEPS):
        state = (1103515245 * state + 12345) % 2147483648
        key = state % 97
        bins[key] = bins.get(key, 0) + 1
        if key < 5:
            trail.append(state)
    checksum = sum(k * v for k, v in bins.items()) + sum(trail) % 1000003
    rng = np.random.default_rng(CALIBRATION_SEED)
    n = CALIBRATION_SIZE
    matrices = rng.uniform(-1.0, 1.0, (CALIBRATION_SYSTEMS, n, n)) + 2.0 * n * np.eye(n)
    solutions = rng.uniform(-1.0, 1.0, (CALIBRATION_SYSTEMS, n))
    error, singular = 0.0, 0.0
    for A, x in zip(matrices, solutions, strict=True):
        found = np.linalg.solve(A, A @ x)
        error = max(error, float(np.linalg.norm(found - x) / np.linalg.norm(x)))
        singular += float(np.linalg.svd(A, compute_uv=False).sum())
    return Calibration(checksum, error, singular)


# ------------------------------------------------------------------------------------ measuring
Call = Callable[[], Any]
Check = Callable[[Any], None]


def _prefer_installed_frcontrol() -> None:
    """Import frcontrol as installed, not from the source tree.

    ``python -m benchmarks.ci`` from the repository root puts the root first on ``sys.path``,
    where ``frcontrol/`` is the source tree without the ``cli/`` and ``robots/`` folders the install
    maps into it. ``benchmarks`` is imported already (this module is in it), so dropping the root
    keeps it and measures the installed package (an editable install maps back to the source).
    """
    sys.path[:] = [p for p in sys.path if Path(p or os.getcwd()).resolve() != ROOT]


def _solutions_figure(name: str) -> tuple[Call, Check]:
    from frcontrol.engine import analyze, solutions_at
    from frcontrol.scene import load_scene

    scene = load_scene(name)
    u = np.zeros(scene.inputs.count)
    _, check = _checked_against(solutions_at(analyze(scene, ambiguity=False), u, method="batch"))
    return (lambda: solutions_at(scene, u)), check


def _query_figure(name: str, u: tuple[float, ...] | None = None) -> tuple[Call, Check]:
    """One input on an analysis made (not timed), checked against the from-scratch path's modes."""
    from frcontrol.engine import analyze, solutions_at
    from frcontrol.scene import load_scene

    scene = load_scene(name)
    analysis = analyze(scene, ambiguity=False)
    inputs = np.zeros(scene.inputs.count) if u is None else np.array(u, dtype=float)
    _, check = _checked_against(solutions_at(scene, inputs))
    return (lambda: solutions_at(analysis, inputs)), check


def _checked_against(reference_solutions: list) -> tuple[dict[str, np.ndarray], Check]:
    """A check that solutions have the reference's modes and accelerations."""
    reference = {s.mode: s.dv for s in reference_solutions}

    def check(solutions: list) -> None:
        found = {s.mode: s.dv for s in solutions}
        if set(found) != set(reference):
            raise InvalidAnswer(f"modes {sorted(found)}, expected {sorted(reference)}")
        for mode, dv in found.items():
            scale = max(1.0, float(np.linalg.norm(dv)), float(np.linalg.norm(reference[mode])))
            if np.linalg.norm(dv - reference[mode]) > SOLUTION_AGREEMENT * scale:
                raise InvalidAnswer(f"mode {mode}: accelerations differ")

    return reference, check


def _batch_figure(name: str) -> tuple[Call, Check]:
    """:data:`BATCH_POINTS` random inputs on an analysis made; a sample checked against single queries."""
    from frcontrol.engine import analyze, solutions_at
    from frcontrol.scene import load_scene

    analysis = analyze(load_scene(name), ambiguity=False)
    problem = analysis.problem
    rng = np.random.default_rng(CALIBRATION_SEED)
    U = rng.uniform(problem.lower, problem.upper, (BATCH_POINTS, problem.m))
    sample = np.linspace(0, BATCH_POINTS - 1, BATCH_CHECKED_POINTS).astype(int)
    expected = [tuple(s.mode for s in solutions_at(analysis, U[i])) for i in sample]

    def check(batch: Any) -> None:
        if len(batch) != BATCH_POINTS:
            raise InvalidAnswer(f"{len(batch)} points, expected {BATCH_POINTS}")
        for i, modes in zip(sample.tolist(), expected, strict=True):
            if batch.modes_at(i) != modes:
                raise InvalidAnswer(f"point {i}: modes {batch.modes_at(i)}, the single query's {modes}")

    return (lambda: solutions_at(analysis, U)), check


def _analysis_figure(scene: Any, forced: bool, ambiguity: bool = True) -> tuple[Call, Check]:
    from frcontrol.engine import analyze

    expected: list[frozenset[str]] = []

    def call() -> Any:
        result = analyze(scene, ambiguity=ambiguity)
        if forced:
            for mode in result.feasible_modes:
                _ = mode.domain, mode.input_domain
        return result

    def check(result: Any) -> None:
        feasible = frozenset(m.mode for m in result.feasible_modes)
        if not feasible:
            raise InvalidAnswer("no feasible mode")
        if forced and any(m.domain is None or m.input_domain is None for m in result.feasible_modes):
            raise InvalidAnswer("a feasible mode without a domain")
        if not expected:
            expected.append(feasible)  # the warm-up run's answer
        elif feasible != expected[0]:
            raise InvalidAnswer("the feasible modes differ from the warm-up run's")

    return call, check


def _assembly_figures() -> tuple[tuple[Call, Check], tuple[Call, Check]]:
    from benchmarks.engine import bare_pinocchio
    from frcontrol.scene import load_scene

    scene = load_scene("rhex_flip")
    bare = bare_pinocchio(scene)
    expected_rows = 2 * len(scene.active_indices)

    def check_state(state: Any) -> None:
        if not np.all(np.isfinite(state.mass_matrix)):
            raise InvalidAnswer("non-finite mass matrix")
        rows = np.vstack([state.jacobian_normal, state.jacobian_tangent]).shape[0]
        if rows != expected_rows:
            raise InvalidAnswer(f"{rows} contact rows, expected {expected_rows}")

    return (scene.state, check_state), (bare, lambda _: None)


def _compliant_figure(name: str) -> tuple[Call, Check]:
    import math

    from benchmarks import trade
    from frcontrol.scene import load_scene

    scenario = next(s for s in trade.SCENARIOS if s.name == name)
    ref = trade.build_reference(scenario, load_scene(name))
    config = COMPLIANT_CONFIGS[name]
    dt = config["step_omega"] / math.sqrt(config["stiffness"] * ref.slowest_eigenvalue)
    t_r = config["steps"] * dt  # fixed steps, read at the last one

    def check(trajectory: Any) -> None:
        if trajectory.status != "completed":
            raise InvalidAnswer(f"simulation {trajectory.status}")
        error = trade.force_error(ref, trade.readout_forces(ref, trajectory))
        if not error <= trade.TARGET_FORCE_ERROR:
            raise InvalidAnswer(f"force error {error:.2e} above {trade.TARGET_FORCE_ERROR:g}")

    return (lambda: trade.compliant_run(ref, config, t_r, dt)), check


def _simulation_figure(name: str) -> tuple[Call, Check]:
    """A flip's closed loop, run once here; its rigid simulation replayed (``benchmarks/simulation.py``),
    checked equal to the closed loop's samples."""
    from benchmarks.simulation import flip_replay, pump_replay

    replay = pump_replay() if name == "simulation_rigid_pump" else flip_replay()
    SIMULATED_SECONDS[name] = replay.duration
    return replay.call, replay.check


def _startup_figure(label: str) -> tuple[Call, Check]:
    import subprocess
    import tempfile

    from benchmarks.startup import commands

    argv = commands()[label]
    folder = tempfile.mkdtemp()

    def call() -> Any:
        return subprocess.run(argv, capture_output=True, cwd=folder, timeout=120)

    def check(done: Any) -> None:
        if done.returncode != 0 or not done.stdout:
            raise InvalidAnswer(f"{label} exited {done.returncode}: {done.stderr.decode()[-300:]}")

    return call, check


def _atlas_figure(what: str, stride: int = ATLAS_FIGURE_STRIDE) -> tuple[Call, Check]:
    """One grid point after another, ``stride`` grid steps apart (the chunk path), checked against
    loading the scene at that point."""
    from frcontrol.atlas import build_atlas
    from frcontrol.atlas.points import evaluate_point, numeric_axes

    plan = build_atlas("rod_on_table", list(ATLAS_FIGURE_AXES), overrides={"state.v.x": -1.0}, what=what)
    paths = numeric_axes(plan)
    points = iter(range(10**9))

    def call() -> Any:
        index = next(points) * stride % plan.size
        return index, evaluate_point(plan, index, numeric_paths=paths)

    def check(answer: Any) -> None:
        index, row = answer
        if row != evaluate_point(plan, index, reload=True):
            raise InvalidAnswer(f"point {index}: the chunk's columns differ from the scene loaded there")

    return call, check


def _statics_figure(name: str) -> tuple[Call, Check]:
    from frcontrol.scene import load_scene
    from frcontrol.statics import analyze_statics

    scene = load_scene(name)

    def verdicts(report: Any) -> dict[str, Any]:
        return {key: value for key, value in report.to_dict().items() if key != "timings"}

    expected = verdicts(analyze_statics(scene, {}))

    def check(report: Any) -> None:
        if verdicts(report) != expected:
            raise InvalidAnswer("the statics report differs from the warm-up's")

    return (lambda: analyze_statics(scene, {})), check


def build_figures() -> dict[str, tuple[Call, Check]]:
    """The call and the check of every figure of :data:`FIGURES`, set up (scenes loaded)."""
    from benchmarks.contacts import snake_scene
    from benchmarks.engine import snake_on_ground
    from frcontrol.scene import load_scene

    rhex, snake = load_scene("rhex_flip"), load_scene("snake_climb")
    ground_8, ground_10 = load_scene(snake_on_ground(8)), load_scene(snake_scene(10))
    state, bare = _assembly_figures()
    built = {
        "solutions_at_rod_on_table": _solutions_figure("rod_on_table"),
        "solutions_at_box_on_slope": _solutions_figure("box_on_slope"),
        "solutions_at_rhex_flip": _solutions_figure("rhex_flip"),
        "query_rod_on_table": _query_figure("rod_on_table"),
        "query_box_on_slope": _query_figure("box_on_slope"),
        "query_rhex_flip": _query_figure("rhex_flip"),
        "query_rhex_flip_generic": _query_figure("rhex_flip", QUERY_GENERIC_INPUT),
        "batch_rod_on_table": _batch_figure("rod_on_table"),
        "batch_box_on_slope": _batch_figure("box_on_slope"),
        "batch_rhex_flip": _batch_figure("rhex_flip"),
        "analysis_rhex_flip_forced": _analysis_figure(rhex, forced=True),
        "analysis_rhex_flip_lazy": _analysis_figure(rhex, forced=False),
        "analysis_snake_climb_forced": _analysis_figure(snake, forced=True),
        "analysis_snake_climb_lazy": _analysis_figure(snake, forced=False),
        "analysis_snake_ground_8": _analysis_figure(ground_8, forced=False, ambiguity=False),
        "analysis_snake_ground_8_forced": _analysis_figure(ground_8, forced=True, ambiguity=False),
        "analysis_snake_ground_10": _analysis_figure(ground_10, forced=False, ambiguity=False),
        "analysis_snake_ground_10_forced": _analysis_figure(ground_10, forced=True, ambiguity=False),
        "model_assembly_rhex_flip": state,
        "bare_pinocchio_rhex_flip": bare,
        "compliant_rod_on_table": _compliant_figure("rod_on_table"),
        "compliant_box_on_slope": _compliant_figure("box_on_slope"),
        "atlas_rod_per_point": _atlas_figure("solutions"),
        "atlas_rod_chunk_per_point": _atlas_figure("solutions", ATLAS_CHUNK_STRIDE),
        "statics_rod_on_table": _statics_figure("rod_on_table"),
        "atlas_statics_rod_per_point": _atlas_figure("statics"),
        "simulation_rigid_pump": _simulation_figure("simulation_rigid_pump"),
        "simulation_rigid_flip": _simulation_figure("simulation_rigid_flip"),
        "startup_frc_help": _startup_figure("frc --help"),
        "startup_frc_show_rod_on_table": _startup_figure("frc show rod_on_table"),
    }
    if set(built) != {f.name for f in FIGURES}:
        raise RuntimeError("build_figures and FIGURES disagree")
    return built


def _cpu_seconds() -> float:
    """CPU time [s] of this process and of its finished child processes (user + system)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def _time_batch(call: Call, calls: int) -> tuple[float, float, Any]:
    """Wall time and CPU time [s] per call of ``calls`` calls in a row, and the last result."""
    result = None
    wall, cpu = time.perf_counter(), _cpu_seconds()
    for _ in range(calls):
        result = call()
    return (time.perf_counter() - wall) / calls, (_cpu_seconds() - cpu) / calls, result


def measure(runs: int = RUNS, progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run every figure ``runs`` times (after a warm-up round), interleaved with the calibration."""
    started = time.perf_counter()
    built = build_figures()
    names = [f.name for f in FIGURES]
    wall: dict[str, list[float]] = {name: [] for name in names}
    cpu: dict[str, list[float]] = {name: [] for name in names}
    calibration_wall: dict[str, list[float]] = {name: [] for name in names}
    calibration_cpu: dict[str, list[float]] = {name: [] for name in names}
    invalid: dict[str, str] = {}
    for round_ in range(runs + 1):  # round 0 is the warm-up
        for figure in FIGURES:
            if figure.name in invalid:
                continue
            calibration = _time_batch(calibration_workload, CALIBRATION_CALLS)
            call, check = built[figure.name]
            try:
                seconds, cpu_seconds, answer = _time_batch(call, figure.calls)
                check(answer)
            except Exception as err:  # any failure makes the figure invalid, reported, never timed
                invalid[figure.name] = f"{type(err).__name__}: {err}"
                continue
            if round_:
                wall[figure.name].append(seconds)
                cpu[figure.name].append(cpu_seconds)
                calibration_wall[figure.name].append(calibration[0])
                calibration_cpu[figure.name].append(calibration[1])
        if progress:
            progress(f"round {round_}/{runs} done")
    figures: dict[str, dict[str, Any]] = {}
    for figure in FIGURES:
        name = figure.name
        entry: dict[str, Any] = {"label": figure.label, "calls_per_run": figure.calls,
                                 "gated": figure.gated}
        if name in invalid or not wall[name]:
            entry.update(valid=False, reason=invalid.get(name, "no sample"), median_s=None,
                         runs=len(wall[name]), ratio_to_calibration=None, target_s=figure.target_s,
                         met=None)
        else:
            median = statistics.median(wall[name])
            median_cpu = statistics.median(cpu[name])
            entry.update(
                valid=True, median_s=median, runs=len(wall[name]), min_s=min(wall[name]),
                max_s=max(wall[name]), median_cpu_s=median_cpu,
                ratio_to_calibration=median_cpu / statistics.median(calibration_cpu[name]),
                wall_ratio_to_calibration=median / statistics.median(calibration_wall[name]),
                target_s=figure.target_s,
                met=None if figure.target_s is None else median <= figure.target_s)
        figures[name] = entry
    assembly, bare = figures["model_assembly_rhex_flip"], figures["bare_pinocchio_rhex_flip"]
    if assembly["valid"] and bare["valid"]:
        assembly["ratio_to_bare_pinocchio"] = assembly["median_s"] / bare["median_s"]
        assembly["target_s"] = ASSEMBLY_TARGET_VS_BARE * bare["median_s"]
        assembly["met"] = assembly["median_s"] <= assembly["target_s"]
    _relative_targets(figures)
    return {
        "benchmark": "ci",
        "command": "python -m benchmarks.ci",
        "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "cores": os.cpu_count(),
        "machine": platform.machine(),
        "versions": versions(),
        "runs": runs,
        "calibration": {
            "workload": "benchmarks.ci.calibration_workload",
            "calls_per_sample": CALIBRATION_CALLS,
            "median_s": _median_of(calibration_wall),
            "median_cpu_s": _median_of(calibration_cpu),
            "samples": sum(len(values) for values in calibration_wall.values()),
        },
        "regression_factor": REGRESSION_FACTOR,
        "wall_time_s": time.perf_counter() - started,
        "figures": figures,
        "notes": {
            "inputs": "the rigid solutions are at zero input (u = 0) for every scene, and the RHex query "
                      f"also at u = {QUERY_GENERIC_INPUT}; the batches at {BATCH_POINTS} inputs uniform "
                      "within the limits",
            "analysis": "forced: analyze() with its defaults (overlaps included), then every feasible "
                        "mode's domain and input_domain; lazy: analyze() alone",
            "snake_ground_8": "(and snake_ground_10) as benchmarks/engine.py measures it: "
                              "analyze(ambiguity=False), lazy; _forced: "
                              "the same with every feasible mode's domain and input_domain (as "
                              "benchmarks/contacts.py's forced figure)",
            "compliant": COMPLIANT_CONFIGS,
            "atlas": f"one grid point of {', '.join(ATLAS_FIGURE_AXES)} with state.v.x = -1, computed as a "
                     f"chunk computes it, {ATLAS_FIGURE_STRIDE} grid steps after the last (chunk: "
                     f"{ATLAS_CHUNK_STRIDE}, the grid's order); target_s is {ATLAS_TARGET_VS_QUERY:g}x the "
                     "median of its query (solutions_at_rod_on_table, statics_rod_on_table) of the same run; "
                     "the point's stability verdicts are in its time, not in the query's",
            "model_assembly": f"target_s is {ASSEMBLY_TARGET_VS_BARE:g}x the bare Pinocchio calls' median "
                              "of the same run",
        },
    }


def _relative_targets(figures: dict[str, dict[str, Any]]) -> None:
    """The atlas figures' targets: :data:`ATLAS_TARGET_VS_QUERY` times their query's median (this run);
    the simulation figures': their simulated time over :data:`SIMULATION_TARGET_REAL_TIME`.

    Met when the ratio of the CPU medians is at most the target (``ratio_to_query``): on a machine
    shared with other work, a sample of 64 points waits for a core more often than the query's
    short one, which the wall times would count against the atlas. ``target_s`` is the target in
    the query's wall time, for the table.
    """
    for name, simulated in SIMULATED_SECONDS.items():
        entry = figures[name]
        if entry["valid"]:
            entry["simulated_s"] = simulated
            entry["real_time_factor"] = simulated / entry["median_s"]
            entry["target_s"] = simulated / SIMULATION_TARGET_REAL_TIME
            entry["met"] = entry["median_s"] <= entry["target_s"]
    for name, query in (("atlas_rod_per_point", "solutions_at_rod_on_table"),
                        ("atlas_rod_chunk_per_point", "solutions_at_rod_on_table"),
                        ("atlas_statics_rod_per_point", "statics_rod_on_table")):
        entry, reference = figures[name], figures[query]
        if entry["valid"] and reference["valid"]:
            entry["ratio_to_query"] = entry["median_cpu_s"] / reference["median_cpu_s"]
            entry["target_s"] = ATLAS_TARGET_VS_QUERY * reference["median_s"]
            entry["met"] = entry["ratio_to_query"] <= ATLAS_TARGET_VS_QUERY


def _median_of(samples: dict[str, list[float]]) -> float | None:
    """The median of every list's samples together (None if there is none)."""
    values = [x for xs in samples.values() for x in xs]
    return statistics.median(values) if values else None


def versions() -> dict[str, str]:
    """Python and the releases of the packages the figures depend on."""
    out = {"python": platform.python_version()}
    for package in ("frcontrol", "numpy", "scipy", "pin", "daqp", "highspy", "proxsuite"):
        try:
            out[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            out[package] = "not installed"
    return out


# ------------------------------------------------------------------------------------ the gate
def regressions(result: dict[str, Any], baseline: dict[str, Any],
                factor: float = REGRESSION_FACTOR) -> list[str]:
    """One line per regression of ``result`` against ``baseline`` (both as written by this module).

    A gated figure regresses when its answer failed its check, when it is missing from the run, or
    when its ratio to the calibration exceeds ``factor`` times the baseline's.
    """
    lines = []
    for name, base in baseline["figures"].items():
        if not base.get("gated", True):
            continue
        now = result["figures"].get(name)
        if now is None:
            lines.append(f"regression: {name}: in the baseline, not measured in this run")
        elif not now.get("valid", True) or now.get("ratio_to_calibration") is None:
            lines.append(f"regression: {name}: invalid answer ({now.get('reason', 'no ratio')})")
        else:
            # a figure with a reference of its own in the same run (the model assembly against the
            # bare Pinocchio calls it wraps) is gated on that ratio: a few microseconds' CPU time
            # against the calibration varied 3x between two idle runs, its wall time by 0.3 %
            key = ("ratio_to_bare_pinocchio" if base.get("ratio_to_bare_pinocchio") is not None
                   and now.get("ratio_to_bare_pinocchio") is not None else "ratio_to_calibration")
            if base.get(key) is None:
                continue  # no baseline ratio to compare with (it was invalid when the baseline was made)
            if now[key] > factor * base[key]:
                lines.append(f"regression: {name}: {key.replace('_', ' ')} {now[key]:.4g} is "
                             f"{now[key] / base[key]:.2f}x the baseline's {base[key]:.4g} (limit "
                             f"{factor:g}x); median {format_seconds(now['median_s'])}")
    return lines


def baseline_from(result: dict[str, Any]) -> dict[str, Any]:
    """What ``--update-baseline`` writes: the run's provenance and every figure's ratio."""
    keep = ("label", "gated", "valid", "median_s", "median_cpu_s", "runs", "ratio_to_calibration",
            "wall_ratio_to_calibration", "ratio_to_bare_pinocchio")
    return {
        "about": "baseline of python -m benchmarks.ci --check; update it with --update-baseline, in "
                 "a commit whose message says why",
        **{key: result[key] for key in ("date", "cores", "machine", "versions", "runs", "calibration",
                                         "regression_factor")},
        "figures": {name: {key: entry[key] for key in keep if key in entry}
                    for name, entry in result["figures"].items()},
    }


# ------------------------------------------------------------------------------------ reports
def format_seconds(seconds: float | None) -> str:
    """A duration with a unit that keeps 2-3 significant digits (``0.72 ms``, ``45 us``, ``1.1 s``)."""
    if seconds is None:
        return "-"
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6)):
        if seconds >= scale or unit == "us":
            value = seconds / scale
            return f"{value:.3g} {unit}" if value < 100 else f"{value:.0f} {unit}"
    raise AssertionError("unreachable")


def summary_line(name: str, entry: dict[str, Any]) -> str:
    """One line per figure for the console."""
    if not entry.get("valid", True):
        return f"{name:32s} INVALID: {entry.get('reason')}"
    target = "" if entry["target_s"] is None else (
        f"  target {format_seconds(entry['target_s'])}: {'met' if entry['met'] else 'not met'}")
    return (f"{name:32s} {format_seconds(entry['median_s']):>9s}  {entry['ratio_to_calibration']:8.3g}x "
            f"calibration (CPU){target}")


def render_table(result: dict[str, Any]) -> str:
    """The benchmarks page's figures table (markdown) from a result as written by :func:`measure`."""
    calibration = result["calibration"]
    lines = [
        f"Measured by `python -m benchmarks.ci` on {result['date'][:10]} ({result['cores']} cores, Python "
        f"{result['versions']['python']}, frcontrol {result['versions']['frcontrol']}): medians of "
        f"{result['runs']} runs (wall time), each also as a ratio of CPU times to the calibration workload "
        f"measured in the same run (median {format_seconds(calibration['median_cpu_s'])} of CPU, "
        f"{format_seconds(calibration['median_s'])} of wall time); CI fails when a ratio exceeds "
        f"{result['regression_factor']:g}x `benchmarks/baseline.json`'s.",
        "",
        "| figure | median | ratio to calibration (CPU) | target | met |",
        "| --- | --- | --- | --- | --- |",
    ]
    for entry in result["figures"].values():
        if not entry.get("valid", True):
            lines.append(f"| {entry['label']} | invalid: {entry.get('reason')} | | | |")
            continue
        met = "" if entry["met"] is None else ("yes" if entry["met"] else "no")
        target = "" if entry["target_s"] is None else f"<= {format_seconds(entry['target_s'])}"
        median = format_seconds(entry["median_s"])
        if "ratio_to_bare_pinocchio" in entry:
            median += f" ({entry['ratio_to_bare_pinocchio']:.2g}x the bare calls)"
        if "ratio_to_query" in entry:
            median += f" ({entry['ratio_to_query']:.3g}x the query in CPU time)"
            target = f"<= {ATLAS_TARGET_VS_QUERY:g}x the query ({format_seconds(entry['target_s'])})"
        lines.append(f"| {entry['label']} | {median} | "
                     f"{entry['ratio_to_calibration']:.3g} | {target} | {met} |")
    return "\n".join(lines)


def readme_block(text: str) -> str:
    """The text between the benchmarks page's two markers (without them).

    Raises:
        ValueError: the markers are missing or out of order.
    """
    begin, end = text.find(README_BEGIN), text.find(README_END)
    if begin < 0 or end < begin:
        raise ValueError(f"docs/benchmarks.md needs the lines {README_BEGIN!r} and {README_END!r}, "
                         "in that order")
    return text[begin + len(README_BEGIN):end].strip("\n")


def rewrite_readme(text: str, result: dict[str, Any]) -> str:
    """``text`` with the block between the markers replaced by :func:`render_table`."""
    readme_block(text)  # checks the markers
    begin = text.find(README_BEGIN) + len(README_BEGIN)
    end = text.find(README_END)
    return text[:begin] + "\n" + render_table(result) + "\n" + text[end:]


def plot(result: dict[str, Any], path: Path) -> None:
    """Median per figure (log scale) with its target, coloured by whether it is met."""
    from matplotlib.figure import Figure as MplFigure

    entries = [(name, e) for name, e in result["figures"].items() if e.get("valid", True)]
    fig = MplFigure(figsize=(9.0, 1.0 + 0.38 * len(entries)), layout="constrained")
    ax = fig.add_subplot()
    colors = ["#9e9e9e" if e["met"] is None else ("#2ca02c" if e["met"] else "#d62728") for _, e in entries]
    ax.barh([name for name, _ in entries], [e["median_s"] for _, e in entries], color=colors)
    for i, (_, e) in enumerate(entries):
        if e["target_s"] is not None:
            ax.plot([e["target_s"]] * 2, [i - 0.4, i + 0.4], color="k", lw=2)
        ax.annotate(f"{e['ratio_to_calibration']:.3g}x cal.", (e["median_s"], i), xytext=(3, 0),
                    textcoords="offset points", va="center", fontsize=7)
    ax.set_xscale("log")
    longest = max([e["median_s"] for _, e in entries] + [e["target_s"] or 0.0 for _, e in entries])
    ax.set_xlim(right=10.0 * longest)  # room for the ratio labels
    ax.invert_yaxis()
    ax.tick_params(axis="y", labelsize=7)
    ax.set_xlabel("median wall time [s] (black: target; green met, red not met, grey no target)")
    ax.set_title(f"python -m benchmarks.ci, {result['date']}, {result['runs']} runs; labels: ratio of CPU "
                 f"times to the calibration ({format_seconds(result['calibration']['median_cpu_s'])} CPU)",
                 fontsize=9)
    fig.savefig(path, dpi=110)


# ------------------------------------------------------------------------------------ main
def main(argv: list[str] | None = None) -> int:
    """Measure (unless only ``--readme``), write the results, gate; the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", type=Path, metavar="BASELINE",
                        help="exit 1 when a figure regressed against this baseline")
    parser.add_argument("--update-baseline", action="store_true",
                        help=f"write {BASELINE.relative_to(ROOT)} from this run")
    parser.add_argument("--readme", action="store_true",
                        help=f"only rewrite docs/benchmarks.md's figures table from "
                             f"{RESULT_JSON.relative_to(ROOT)}")
    parser.add_argument("--runs", type=int, default=RUNS, help="timed samples per figure")
    parser.add_argument("--verbose", action="store_true", help="report each round")
    args = parser.parse_args(argv)
    if args.readme:
        result = json.loads(RESULT_JSON.read_text())
        README.write_text(rewrite_readme(README.read_text(), result))
        print(f"rewrote the figures table of {README} from {RESULT_JSON}")
        return 0
    if args.check is not None and not args.check.exists():
        print(f"benchmarks.ci: no baseline at {args.check}", file=sys.stderr)
        return 1
    _prefer_installed_frcontrol()
    result = measure(args.runs, progress=(lambda m: print(m, flush=True)) if args.verbose else None)
    RESULTS.mkdir(parents=True, exist_ok=True)
    RESULT_JSON.write_text(json.dumps(result, indent=1) + "\n")
    plot(result, RESULT_PNG)
    print(f"benchmarks.ci: {len(result['figures'])} figures, {result['runs']} runs each, calibration "
          f"{format_seconds(result['calibration']['median_cpu_s'])} CPU / "
          f"{format_seconds(result['calibration']['median_s'])} wall, {result['wall_time_s']:.0f} s; "
          f"wrote {RESULT_JSON.relative_to(ROOT)}")
    for name, entry in result["figures"].items():
        print(summary_line(name, entry))
    if args.update_baseline:
        BASELINE.write_text(json.dumps(baseline_from(result), indent=1) + "\n")
        print(f"wrote {BASELINE.relative_to(ROOT)}")
    if args.check is not None:
        lines = regressions(result, json.loads(args.check.read_text()))
        for line in lines:
            print(line, file=sys.stderr)
        if lines:
            return 1
        print(f"benchmarks.ci: no regression against {args.check} (limit {REGRESSION_FACTOR:g}x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
