"""Benchmark: how long the command line takes to start, as whole processes.

Run from the repository root (with frcontrol installed)::

    python -m benchmarks.startup [--runs 9]

Times ``frc --help``, ``frc robots``, ``frc show rod_on_table`` and ``python -c "import frcontrol"``
as subprocesses, interleaved run by run, with ``python -c pass`` as the calibration workload of the
same run (the interpreter's own start-up): each figure is the median wall time and its ratio to the
calibration's median. The targets are the front-door issue's: ``frc --help`` and ``frc robots``
<= 0.3 s, ``frc show rod_on_table`` <= 0.6 s. Each command's exit code is checked (0), so a broken
command cannot look fast.

Writes ``benchmarks/results/startup.json`` and ``benchmarks/results/startup.png``.
"""

from __future__ import annotations

import argparse
import json
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
TARGETS_S = {"frc --help": 0.3, "frc robots": 0.3, "frc show rod_on_table": 0.6}
"""Targets [s] of the median wall time."""


def commands() -> dict[str, list[str]]:
    """The timed commands, by label (``frc`` next to this interpreter, else on the PATH)."""
    frc = shutil.which("frc", path=str(Path(sys.executable).parent)) or shutil.which("frc")
    if frc is None:
        raise SystemExit("frc is not installed: pip install .")
    return {
        "python -c pass": [sys.executable, "-c", "pass"],
        "import frcontrol": [sys.executable, "-c", "import frcontrol"],
        "frc --help": [frc, "--help"],
        "frc robots": [frc, "robots"],
        "frc show rod_on_table": [frc, "show", "rod_on_table"],
    }


def run(runs: int) -> dict:
    """Time every command ``runs`` times, interleaved, after one warm-up each."""
    table = commands()
    times: dict[str, list[float]] = {label: [] for label in table}
    folder = tempfile.mkdtemp()
    for round_ in range(runs + 1):
        for label, argv in table.items():
            start = time.perf_counter()
            done = subprocess.run(argv, capture_output=True, cwd=folder, timeout=120)
            elapsed = time.perf_counter() - start
            if done.returncode != 0:
                raise SystemExit(f"{label} exited {done.returncode}: {done.stderr.decode()[-500:]}")
            if round_:  # round 0 is the warm-up
                times[label].append(elapsed)
    calibration = statistics.median(times["python -c pass"])
    rows = []
    for label, samples in times.items():
        median = statistics.median(samples)
        rows.append({"command": label, "median_s": median, "min_s": min(samples), "max_s": max(samples),
                     "ratio_to_calibration": median / calibration, "target_s": TARGETS_S.get(label),
                     "met": None if label not in TARGETS_S else median <= TARGETS_S[label]})
    return {"benchmark": "startup", "runs": runs, "calibration": "python -c pass",
            "calibration_median_s": calibration, "rows": rows, "python": platform.python_version(),
            "machine": platform.machine()}


def plot(result: dict, path: Path) -> None:
    """Median wall time per command, with the targets."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.5, 3.6))
    ax = fig.add_subplot()
    rows = result["rows"]
    labels = [r["command"] for r in rows]
    ax.barh(labels, [r["median_s"] for r in rows], xerr=[[r["median_s"] - r["min_s"] for r in rows],
                                                          [r["max_s"] - r["median_s"] for r in rows]],
            color=["#9e9e9e" if r["target_s"] is None else ("#2ca02c" if r["met"] else "#d62728")
                   for r in rows])
    for i, r in enumerate(rows):
        if r["target_s"] is not None:
            ax.plot([r["target_s"]] * 2, [i - 0.4, i + 0.4], color="k", lw=2)
    ax.invert_yaxis()
    ax.set_xlabel("median wall time [s] (bars: min-max; black: target)")
    ax.set_title(f"start-up, {result['runs']} runs each, calibration python -c pass = "
                 f"{result['calibration_median_s'] * 1e3:.0f} ms", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=9)
    args = parser.parse_args()
    result = run(args.runs)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "startup.json").write_text(json.dumps(result, indent=1))
    plot(result, RESULTS / "startup.png")
    for r in result["rows"]:
        verdict = "met" if r["met"] else "NOT met"
        target = "" if r["target_s"] is None else f"  target {r['target_s']:.1f} s: {verdict}"
        print(f"{r['command']:24s} {r['median_s'] * 1e3:7.0f} ms  "
              f"({r['ratio_to_calibration']:.1f}x python){target}")


if __name__ == "__main__":
    main()
