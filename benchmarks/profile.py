"""Where the time goes: ``python -m benchmarks.profile SCENE``.

Run from the repository root, with frcontrol installed::

    python -m benchmarks.profile rhex_flip                 # a forced analysis and an atlas chunk
    python -m benchmarks.profile snake_climb --runs 3      # medians of three runs
    python -m benchmarks.profile rod_on_table --json       # the shares as JSON on stdout

Two workloads, each timed by stage:

- **a forced analysis**: ``analyze(scene)`` (overlaps included) from the loaded scene, then every
  feasible mode's domain ``D_c`` in minimal form and input domain ``T_c``;
- **an atlas chunk**: the public atlas call, ``run_atlas(build_atlas(...), where=AtlasWorkers(1))`` in this
  process, over a grid of about :data:`ATLAS_POINTS` points (:func:`atlas_chunk`: the first
  contact's friction coefficient, and the first input), every point's rigid solutions and their
  stability.

The stages are library functions wrapped, for the run only, by a timer that keeps *exclusive* time
(a stage's time without the stages it calls, so nothing is counted twice):

======================  ==========================================================================
stage                   the functions
======================  ==========================================================================
assembly                ``ContactProblem.from_scene`` (the state: M, h, the contacts' rows)
scene loading           ``load_scene`` and the atlas's per-point scene rebuilds (atlas only)
mode enumeration        ``analyze``'s tree: every (partial) mode's system, response and test
domains                 ``ModeAnalysis.domain``: D_c in minimal form
projection              ``ModeAnalysis.input_domain``: T_c, the projection onto the inputs
overlaps                the pairs of modes whose T_c meet (``analyze(..., ambiguity=True)``)
solutions               ``solutions_at`` (atlas only)
stability               ``stability_of``, ``classify_solutions``, ``stable_verdicts`` (atlas only)
LPs                     the LP door ``frcontrol.solvers.solve`` and its lean path
                        ``InequalityLPs.solve`` (back-end and residual check; a lean call that
                        falls back counts twice)
Python overhead         everything outside those functions: the loops and the bookkeeping
                        between them (and the timers' own cost, measured and reported)
======================  ==========================================================================

Each stage's own time is NumPy and Python around its LPs; the LPs it runs are counted under LPs.
The timer's cost per wrapped call is measured at the start (:func:`timer_cost`) and reported with
the call counts; it is small against every stage here but lands in the stage that calls.
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

ATLAS_POINTS = 200
"""Grid points of the profiled atlas chunk (one chunk, in this process)."""


@dataclass
class StageTimer:
    """Exclusive wall time [s] and calls per stage (a stack of running stages)."""

    seconds: dict[str, float] = field(default_factory=dict)
    calls: dict[str, int] = field(default_factory=dict)
    stack: list[list[float]] = field(default_factory=list)  # per running stage: [start, child time]

    def wrap(self, stage: str, function: Callable[..., Any]) -> Callable[..., Any]:
        """``function`` timed under ``stage``."""
        def timed(*args: Any, **kwargs: Any) -> Any:
            frame = [time.perf_counter(), 0.0]
            self.stack.append(frame)
            try:
                return function(*args, **kwargs)
            finally:
                self.stack.pop()
                total = time.perf_counter() - frame[0]
                self.seconds[stage] = self.seconds.get(stage, 0.0) + total - frame[1]
                self.calls[stage] = self.calls.get(stage, 0) + 1
                if self.stack:
                    self.stack[-1][1] += total

        return timed


@contextmanager
def instrumented(timer: StageTimer) -> Iterator[None]:
    """The library's stage functions wrapped by ``timer`` while the block runs, then restored."""
    from frcontrol import engine, scene, solvers, stability
    from frcontrol.modes import ContactProblem

    patches: list[tuple[Any, str, Any]] = []

    def patch(owner: Any, name: str, stage: str, kind: str = "function") -> None:
        original = owner.__dict__[name] if isinstance(owner, type) else getattr(owner, name)
        patches.append((owner, name, original))
        if kind == "property" and isinstance(original, functools.cached_property):  # derived once
            wrapped = functools.cached_property(timer.wrap(stage, original.func))
            wrapped.__set_name__(owner, name)
            setattr(owner, name, wrapped)
        elif kind == "property":
            setattr(owner, name, property(timer.wrap(stage, original.fget)))
        elif kind == "classmethod":
            setattr(owner, name, classmethod(timer.wrap(stage, original.__func__)))
        else:
            setattr(owner, name, timer.wrap(stage, original))

    patch(ContactProblem, "from_scene", "assembly", "classmethod")
    patch(scene, "load_scene", "scene loading")
    patch(engine._ModeEnumerator, "grow", "mode enumeration")
    patch(engine.ModeAnalysis, "domain", "domains", "property")
    patch(engine.ModeAnalysis, "input_domain", "projection", "property")
    patch(engine, "_overlaps", "overlaps")
    patch(engine, "solutions_at", "solutions")
    patch(stability, "stability_of", "stability")
    patch(stability, "classify_solutions", "stability")
    patch(stability, "stable_verdicts", "stability")  # an atlas point's (stability_of's verdicts)
    patch(solvers, "solve", "LPs")
    patch(solvers.InequalityLPs, "solve", "LPs")
    try:
        yield
    finally:
        for owner, name, original in reversed(patches):
            setattr(owner, name, original)


def timer_cost(samples: int = 20000) -> float:
    """[s] The wrapper's own cost per call (a wrapped no-op against a bare one)."""
    timer = StageTimer()

    def nothing() -> None:
        return None

    wrapped = timer.wrap("x", nothing)
    start = time.perf_counter()
    for _ in range(samples):
        nothing()
    bare = time.perf_counter() - start
    start = time.perf_counter()
    for _ in range(samples):
        wrapped()
    return max(0.0, (time.perf_counter() - start - bare) / samples)


def forced_analysis(name: str) -> Callable[[], Any]:
    """The forced analysis of a shipped scene (loaded once, outside the timing)."""
    from frcontrol.engine import analyze
    from frcontrol.scene import load_scene

    loaded = load_scene(name)

    def run() -> Any:
        result = analyze(loaded)
        for mode in result.feasible_modes:
            _ = mode.domain, mode.input_domain
        return result

    return run


def atlas_chunk(name: str, points: int = ATLAS_POINTS) -> Callable[[], Any]:
    """One atlas chunk of about ``points`` points through ``run_atlas``, in this process.

    The axes: the first contact's friction coefficient (0.2 to 1.5: the scene is rebuilt per
    value) and, when the scene has inputs, its first input over its limits (or +-10 where it has
    none); ``points / 10`` values of each.
    """
    import math

    from frcontrol.atlas import AtlasWorkers, build_atlas, run_atlas
    from frcontrol.scene import load_scene

    loaded = load_scene(name)
    contact = loaded.contacts[0].name
    inputs = loaded.inputs.coordinates
    per_axis = max(2, points // 10) if inputs else points
    axes = [f"contacts.{contact}.mu=0.2:1.5:{per_axis}"]
    if inputs:
        low, high = float(loaded.inputs.lower[0]), float(loaded.inputs.upper[0])
        low, high = (low, high) if math.isfinite(low) and math.isfinite(high) else (-10.0, 10.0)
        axes.append(f"input.{inputs[0]}={low}:{high}:{max(2, points // per_axis)}")
    plan = build_atlas(name, axes, chunk_size=points)

    def run() -> Any:
        return run_atlas(plan, where=AtlasWorkers(1))

    return run


def profile(run: Callable[[], Any], runs: int) -> dict[str, Any]:
    """The stages of the median run of ``runs`` (by total time, after a warm-up run), with shares."""
    run()
    timed: list[tuple[float, StageTimer]] = []
    for _ in range(runs):
        timer = StageTimer()
        with instrumented(timer):
            start = time.perf_counter()
            run()
            total = time.perf_counter() - start
        timer.seconds["Python overhead"] = total - sum(timer.seconds.values())
        timed.append((total, timer))
    timed.sort(key=lambda entry: entry[0])
    total, timer = timed[len(timed) // 2]
    return {"total_s": total, "runs": runs, "totals_s": [t for t, _ in timed],
            "stages": {stage: {"seconds": s, "share": s / total, "calls": timer.calls.get(stage, 0)}
                       for stage, s in sorted(timer.seconds.items(), key=lambda item: -item[1])}}


def render(title: str, result: dict[str, Any], cost: float) -> str:
    """A text table of one profile."""
    lines = [f"{title}: {result['total_s'] * 1e3:.1f} ms (the median of {result['runs']} runs)",
             f"  {'stage':20s} {'time':>10s} {'share':>7s} {'calls':>8s}"]
    for stage, entry in result["stages"].items():
        lines.append(f"  {stage:20s} {entry['seconds'] * 1e3:8.2f} ms {100 * entry['share']:6.1f}% "
                     f"{entry['calls']:8d}")
    wrapped = sum(entry["calls"] for entry in result["stages"].values())
    lines.append(f"  (the timers cost about {cost * 1e6:.2f} us per call: "
                 f"{wrapped * cost * 1e3:.2f} ms here)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Profile a shipped scene; print the tables (or JSON)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", help="a shipped scene's name (frc list)")
    parser.add_argument("--runs", type=int, default=5, help="timed runs per workload (median)")
    parser.add_argument("--points", type=int, default=ATLAS_POINTS, help="points of the atlas chunk")
    parser.add_argument("--json", action="store_true", help="print the profiles as JSON")
    args = parser.parse_args(argv)
    from frcontrol.errors import FrcontrolError

    try:
        workloads = {"forced analysis": forced_analysis(args.scene),
                     "atlas chunk": atlas_chunk(args.scene, args.points)}
        cost = timer_cost()
        results = {title: profile(run, args.runs) for title, run in workloads.items()}
    except FrcontrolError as err:
        print(f"benchmarks.profile: {err}", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps({"scene": args.scene, "timer_cost_s": cost, "profiles": results}, indent=1))
    else:
        for title, result in results.items():
            print(render(f"{args.scene}, {title}", result, cost))
    return 0


if __name__ == "__main__":
    sys.exit(main())
