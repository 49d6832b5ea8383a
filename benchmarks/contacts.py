"""More contacts: ``python -m benchmarks.contacts [--counts 6 8 10 12] [--forced-budget S]``.

The scene set: the straight snake of ``robots/snake_planar.urdf`` (9 links of 0.2 m, 8 actuated
joints, inputs within +-5 N m) lying on the ground y = 0 with k contacts (:func:`snake_scene`):
the first min(k, 9) link origins (as ``benchmarks/engine.py``'s scenes), then, past 9, the links'
midpoints from the head down. Per contact count it measures, in this process:

- **analysis**: ``analyze(scene, ambiguity=False)`` (domains on demand, as
  ``benchmarks/engine.py`` measures it), with the modes evaluated and feasible and the time per
  evaluated mode;
- **forced**: the same analysis with every feasible mode's minimal D_c and its projection T_c
  computed (``ModeAnalysis.domain``, ``input_domain``), with the time per feasible mode; skipped
  for a count whose analysis predicts more than ``--forced-budget`` seconds (the analysis's
  per-feasible-mode cost at the previous count, times the feasible modes, the cost growing with
  the count), and reported as out of memory past :data:`FORCED_MEMORY` of address space; up to
  :data:`REFERENCE_MAX_CONTACTS` contacts, also by the former rule (T_c
  projected by Fourier-Motzkin steps each pruned by LP, :func:`forced_reference`), and, up to
  :data:`GENERAL_DOOR_MAX_CONTACTS`, the analysis and the forced analysis with every LP through the
  general door instead of its lean path (``benchmarks.lp_door.general_door``:
  ``analysis_general_door_s``, ``forced_general_door_s``), for a before and after measured in one
  process.

Every figure is a median of ``--runs`` runs (a long one, above :data:`SINGLE_RUN_SECONDS`, runs once)
and is also given as a ratio to ``benchmarks/ci.py``'s calibration workload measured in the same
process. An analysis that takes more than :data:`PROGRESS_AFTER` seconds reports its progress on
stderr (modes evaluated so far), as ``frc analyze`` does.

Writes ``benchmarks/results/contacts.json`` and ``contacts.png`` (times against the contact count,
log scale, with the modes evaluated and feasible).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from benchmarks.ci import calibration_workload, versions
from benchmarks.lp_door import general_door
from frcontrol import polytope as poly
from frcontrol.engine import analyze
from frcontrol.scene import load_scene, shipped_robots_dir

RESULTS = Path(__file__).resolve().parent / "results"
COUNTS = (6, 8, 10, 12)
"""The contact counts of the scene set."""

PROGRESS_AFTER = 2.0
"""[s] An analysis running longer than this reports its progress on stderr (at most once a second)."""

SINGLE_RUN_SECONDS = 20.0
"""[s] A measurement whose first run took longer than this is not repeated."""

REFERENCE_MAX_CONTACTS = 10
"""Up to this contact count the forced analysis is also timed by the former rule
(:func:`forced_reference`, ``forced_reference_s``), in the same process."""

GENERAL_DOOR_MAX_CONTACTS = 8
"""Up to this contact count the analysis and the forced analysis are also timed with every LP through
the general door (``analysis_general_door_s``, ``forced_general_door_s``)."""

FORCED_BUDGET = 120.0
"""[s] Default largest predicted time of a forced analysis that is run."""

FORCED_MEMORY = 8 * 2**30
"""[bytes] The address space a forced analysis may use (``RLIMIT_AS`` while it runs): past it the
count is reported as out of memory instead of the machine's OOM killer ending the run (the
12-contact snake's projections grew past 20 GB)."""

LINK_LENGTH = 0.2
"""[m] The snake's link length (robots/snake_planar.urdf)."""

LINKS = 9
"""The snake's links."""


def snake_scene(k: int) -> Path:
    """A scene file: the straight snake on y = 0 touching at k points (see the module docstring)."""
    if not 1 <= k <= 2 * LINKS:
        raise ValueError(f"the snake has room for 1 to {2 * LINKS} contacts, not {k}")
    points = [(i, 0.0) for i in range(min(k, LINKS))]
    points += [(LINKS - 1 - j, LINK_LENGTH / 2) for j in range(k - len(points))]
    contacts = "".join(
        f'\n[[contacts]]\nname = "c{n}"\nlink = "link{link}"\npoint = [{x}, 0.0]\nnormal = [0.0, 1.0]\n'
        f"mu = 0.5\nsurface_point = [0.0, 0.0]\n"
        for n, (link, x) in enumerate(points))
    joints = [f"j{i}" for i in range(1, LINKS)]
    text = (f'name = "snake on the ground, {k} contacts"\n'
            f'robot = "{shipped_robots_dir() / "snake_planar.urdf"}"\n'
            f"[state]\nq = {[0.0] * (LINKS + 2)}\n{contacts}\n"
            f"[inputs]\ncoordinates = {json.dumps(joints)}\nlower = {[-5.0] * 8}\nupper = {[5.0] * 8}\n")
    path = Path(tempfile.mkdtemp()) / f"snake_ground_{k}.toml"
    path.write_text(text)
    return path


class Progress:
    """``analyze``'s progress callback: past :data:`PROGRESS_AFTER` s, a line on stderr per second."""

    def __init__(self, label: str) -> None:
        self.label, self.start, self.said, self.modes = label, time.perf_counter(), 0.0, 0

    def __call__(self, mode: str) -> None:
        self.modes += 1
        elapsed = time.perf_counter() - self.start
        if elapsed > PROGRESS_AFTER and elapsed - self.said >= 1.0:
            self.said = elapsed
            print(f"{self.label}: {self.modes} modes done (mode {mode}), {elapsed:.0f} s", file=sys.stderr,
                  flush=True)


def timed(call: Callable[[], Any], runs: int) -> tuple[float, list[float], Any]:
    """Median wall time [s] of up to ``runs`` calls (one when the first exceeds SINGLE_RUN_SECONDS)."""
    times, result = [], None
    for _ in range(runs):
        start = time.perf_counter()
        result = call()
        times.append(time.perf_counter() - start)
        if times[0] > SINGLE_RUN_SECONDS:
            break
    return statistics.median(times), times, result


def measure(k: int, runs: int, forced_budget: float, previous: dict[str, Any] | None) -> dict[str, Any]:
    """The analysis and (within the budget) the forced analysis of the k-contact snake."""
    scene = load_scene(snake_scene(k))
    analyze(load_scene(snake_scene(min(k, 4))), ambiguity=False)  # warm-up of the code paths
    seconds, times, result = timed(
        lambda: analyze(scene, ambiguity=False, progress=Progress(f"{k} contacts, analysis")), runs)
    e = result.enumeration
    entry: dict[str, Any] = {
        "contacts": k, "modes_total": e.total, "modes_evaluated": e.evaluated, "modes_feasible": e.feasible,
        "partial_checks": e.partial_checks, "analysis_s": seconds, "analysis_runs": len(times),
        "analysis_per_evaluated_mode_s": seconds / max(1, e.evaluated)}
    per_feasible = previous.get("forced_per_feasible_mode_s") if previous else None
    predicted = None if per_feasible is None else 1.5 * per_feasible * e.feasible + seconds
    entry["forced_predicted_s"] = predicted
    if predicted is not None and predicted > forced_budget:
        entry["forced_s"] = None
        entry["forced_skipped"] = f"predicted {predicted:.0f} s, over the budget of {forced_budget:g} s"
        return entry

    def forced() -> Any:
        progress = Progress(f"{k} contacts, forced")
        done = analyze(scene, ambiguity=False, progress=progress)
        for mode in done.feasible_modes:
            _ = mode.domain, mode.input_domain
            progress(mode.mode)  # the domains' stage counts on: evaluated, then forced
        return done

    try:
        with memory_limit(FORCED_MEMORY):
            seconds, times, _ = timed(forced, runs)
    except MemoryError:
        entry["forced_s"] = None
        entry["forced_skipped"] = f"out of memory (over {FORCED_MEMORY / 2**30:g} GiB of address space)"
        return entry
    entry.update(forced_s=seconds, forced_runs=len(times),
                 forced_per_feasible_mode_s=seconds / max(1, e.feasible))
    if k <= REFERENCE_MAX_CONTACTS:
        seconds, times, _ = timed(lambda: forced_reference(scene), runs)
        entry.update(forced_reference_s=seconds, forced_reference_runs=len(times))
    if k <= GENERAL_DOOR_MAX_CONTACTS:
        with general_door():
            seconds, times, _ = timed(forced, runs)
            entry.update(forced_general_door_s=seconds, forced_general_door_runs=len(times))
            seconds, times, _ = timed(lambda: analyze(scene, ambiguity=False), runs)
            entry.update(analysis_general_door_s=seconds, analysis_general_door_runs=len(times))
    return entry


@contextmanager
def memory_limit(size: int) -> Iterator[None]:
    """``RLIMIT_AS`` lowered to ``size`` bytes for the block (where the platform has it), then restored."""
    try:
        import resource
    except ImportError:  # not on this platform: no limit
        yield
        return
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    limited = size if hard == resource.RLIM_INFINITY else min(size, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limited, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def forced_reference(scene: Any) -> Any:
    """The forced analysis by the former rule: each T_c projected from D_c by Fourier-Motzkin steps
    each pruned by LP (``project(..., method="fourier_motzkin")``), instead of keeping the extreme
    rays of the projection cone and pruning once."""
    done = analyze(scene, ambiguity=False)
    for mode in done.feasible_modes:
        if mode.ambiguity_dim:
            poly.project(mode.domain, range(mode.m), method="fourier_motzkin", solver=mode.solver,
                         minimal=True)
    return done


def plot(payload: dict[str, Any], path: Path) -> None:
    """Analysis and forced times against the contact count (log), labelled with the mode counts."""
    from matplotlib.figure import Figure

    rows = payload["counts"]
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    ks = [r["contacts"] for r in rows]
    ax.plot(ks, [r["analysis_s"] for r in rows], "o-", label="analysis (domains on demand)")
    forced = [(r["contacts"], r["forced_s"]) for r in rows if r.get("forced_s")]
    if forced:
        ax.plot(*zip(*forced, strict=True), "s-", label="forced (every D_c and T_c)")
    for r in rows:
        ax.annotate(f"{r['modes_evaluated']} eval.\n{r['modes_feasible']} feas.",
                    (r["contacts"], r["analysis_s"]), xytext=(4, -18), textcoords="offset points", fontsize=7)
    ax.set_yscale("log")
    ax.set_xticks(ks)
    ax.set_xlabel("contacts (the snake lying on the ground)")
    ax.set_ylabel("wall time [s]")
    ax.set_title(f"python -m benchmarks.contacts, {payload['date']} (calibration "
                 f"{payload['calibration_s'] * 1e3:.2f} ms)", fontsize=9)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    """Measure every count, write the JSON and the figure, print a table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--counts", type=int, nargs="+", default=list(COUNTS), help="contact counts")
    parser.add_argument("--runs", type=int, default=3, help="runs per figure (median)")
    parser.add_argument("--forced-budget", type=float, default=FORCED_BUDGET,
                        help="[s] skip a forced analysis predicted to take longer")
    parser.add_argument("--out", type=Path, default=RESULTS, help="the results folder")
    args = parser.parse_args(argv)
    calibration = statistics.median(
        _seconds(calibration_workload) for _ in range(9))
    rows: list[dict[str, Any]] = []
    for k in sorted(args.counts):
        rows.append(measure(k, args.runs, args.forced_budget, rows[-1] if rows else None))
        r = rows[-1]
        forced = (f"{r['forced_s']:.2f} s, {1e3 * r['forced_per_feasible_mode_s']:.2f} ms per feasible mode"
                  if r.get("forced_s") is not None else r.get("forced_skipped", "-"))
        if r.get("forced_reference_s") is not None:
            forced += f" (former rule {r['forced_reference_s']:.2f} s)"
        if r.get("forced_general_door_s") is not None:
            forced += (f" (general LP door: analysis {r['analysis_general_door_s']:.3f} s, forced "
                       f"{r['forced_general_door_s']:.2f} s)")
        print(f"{k:2d} contacts: {r['modes_evaluated']:6d} modes evaluated, {r['modes_feasible']:5d} "
              f"feasible; analysis {r['analysis_s']:.3f} s "
              f"({1e3 * r['analysis_per_evaluated_mode_s']:.3f} ms per evaluated mode); forced {forced}",
              flush=True)
    for r in rows:
        for key in ("analysis_s", "forced_s", "forced_reference_s", "analysis_general_door_s",
                    "forced_general_door_s"):
            if r.get(key) is not None:
                r[key.replace("_s", "_ratio_to_calibration")] = r[key] / calibration
    command = "python -m benchmarks.contacts " + " ".join(argv or sys.argv[1:])
    payload = {"benchmark": "contacts", "command": command.strip(),
               "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "versions": versions(),
               "calibration_s": calibration, "runs": args.runs, "forced_budget_s": args.forced_budget,
               "counts": rows}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "contacts.json").write_text(json.dumps(payload, indent=1) + "\n")
    plot(payload, args.out / "contacts.png")
    print(f"wrote {args.out / 'contacts.json'} and contacts.png")
    return 0


def _seconds(call: Callable[[], Any]) -> float:
    start = time.perf_counter()
    call()
    return time.perf_counter() - start


if __name__ == "__main__":
    sys.exit(main())
