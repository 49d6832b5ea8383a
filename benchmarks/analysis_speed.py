"""The full analysis's speed, LP counts and answers: ``python -m benchmarks.analysis_speed``.

Three sub-commands:

- ``measure [--runs N]``: the figures ``analysis_rhex_flip_forced``, ``analysis_snake_ground_8`` and
  ``analysis_snake_climb_forced`` of :mod:`benchmarks.ci` (the same calls), each the median of N
  runs (default 7) after a warm-up, with its CPU-time ratio to
  :func:`benchmarks.ci.calibration_workload` measured just before it in the same process, and the
  number of LPs each run hands to the solver door (every back-end call, fallbacks included).
- ``snapshot FILE``: every shipped scene's analysis (and the snake lying on the ground with 1-8
  contacts) written to FILE (pickle): per mode its verdict, rank case, and the minimal
  H-representations of D_c and T_c of the feasible ones.
- ``compare FILE``: the same analyses now against FILE: the same modes with the same verdicts, and
  D_c and T_c with the same rows in the same order, equal to :data:`RELATIVE_TOLERANCE` of the
  largest entry (round-off of a different factorisation), and how many are bitwise equal.

Take a snapshot on the commit before a speed change and compare after it.
"""

from __future__ import annotations

import argparse
import pickle
import statistics
import sys
from pathlib import Path
from typing import Any

import numpy as np

RELATIVE_TOLERANCE = 1e-9
"""[-] Two representations' entries may differ by this times the largest magnitude of the array."""

FIGURES = ("analysis_rhex_flip_forced", "analysis_snake_ground_8", "analysis_snake_climb_forced")


def _figures() -> dict[str, Any]:
    from benchmarks.ci import _analysis_figure
    from benchmarks.engine import snake_on_ground
    from frcontrol.scene import load_scene

    return {
        "analysis_rhex_flip_forced": _analysis_figure(load_scene("rhex_flip"), forced=True),
        "analysis_snake_ground_8": _analysis_figure(load_scene(snake_on_ground(8)), forced=False,
                                                    ambiguity=False),
        "analysis_snake_climb_forced": _analysis_figure(load_scene("snake_climb"), forced=True),
    }


class _LPCounter:
    """Counts the LPs the door hands to a back-end (wraps ``frcontrol.solvers._solve_once``)."""

    def __init__(self) -> None:
        import frcontrol.solvers as door

        self.door, self.original, self.count = door, door._solve_once, 0

        def counted(*args: Any, **kwargs: Any) -> Any:
            self.count += 1
            return self.original(*args, **kwargs)

        door._solve_once = counted

    def close(self) -> None:
        self.door._solve_once = self.original


def measure(runs: int) -> dict[str, dict[str, float]]:
    """Median wall and CPU time, CPU ratio to the calibration and LPs per call of each figure."""
    from benchmarks.ci import CALIBRATION_CALLS, _time_batch, calibration_workload

    built = _figures()
    out: dict[str, dict[str, float]] = {}
    counter = _LPCounter()
    try:
        for name in FIGURES:
            call, check = built[name]
            counter.count = 0
            check(call())  # warm-up, and the answer every run is checked against
            lps = counter.count
            wall, cpu, calibration = [], [], []
            for _ in range(runs):
                calibration.append(_time_batch(calibration_workload, CALIBRATION_CALLS)[1])
                seconds, cpu_seconds, answer = _time_batch(call, 1)
                check(answer)
                wall.append(seconds)
                cpu.append(cpu_seconds)
            out[name] = {"median_s": statistics.median(wall), "median_cpu_s": statistics.median(cpu),
                         "ratio_to_calibration": statistics.median(cpu) / statistics.median(calibration),
                         "lps": lps}
    finally:
        counter.close()
    return out


def _scenes() -> dict[str, Any]:
    from benchmarks.engine import snake_on_ground
    from frcontrol.scene import load_scene, shipped_scene_names

    scenes = {name: load_scene(name) for name in shipped_scene_names()}
    scenes.update({f"snake_ground_{k}": load_scene(snake_on_ground(k)) for k in range(1, 9)})
    return scenes


def _polytope(P: Any) -> tuple[np.ndarray, ...] | None:
    return None if P is None else (P.A, P.b, P.A_eq, P.b_eq)


def snapshot() -> dict[str, Any]:
    """Every scene's modes, verdicts, D_c and T_c (minimal forms), and enumeration counts."""
    from frcontrol.engine import analyze
    from frcontrol.errors import FrcontrolError

    answers: dict[str, Any] = {}
    for name, scene in _scenes().items():
        try:
            result = analyze(scene, ambiguity=False)
        except FrcontrolError as err:  # a scene whose state the engine refuses (an impact)
            answers[name] = f"{type(err).__name__}: {err}"
            continue
        modes = []
        for m in result.modes:
            modes.append({"mode": m.mode, "feasible": m.feasible, "pruned": m.pruned, "case": m.response.case,
                          "full_dimensional": m.full_dimensional,
                          "inputs_full_dimensional": m.inputs_full_dimensional,
                          "domain": _polytope(m.domain), "input_domain": _polytope(m.input_domain)})
        answers[name] = {"modes": modes, "enumeration": result.to_dict()["enumeration"]}
    return answers


def _same(a: tuple[np.ndarray, ...] | None, b: tuple[np.ndarray, ...] | None) -> tuple[bool, bool]:
    """(equal to the tolerance, bitwise equal)."""
    if a is None or b is None:
        return a is b, a is b
    close = bitwise = True
    for x, y in zip(a, b, strict=True):
        if x.shape != y.shape:
            return False, False
        scale = max(1.0, float(np.max(np.abs(x), initial=0.0)))
        close &= bool(np.all(np.abs(x - y) <= RELATIVE_TOLERANCE * scale))
        bitwise &= bool(np.array_equal(x, y))
    return close, bitwise


def compare(before: dict[str, Any], now: dict[str, Any]) -> list[str]:
    """Every difference between two snapshots (empty: identical to the tolerance); prints a summary."""
    problems: list[str] = []
    polytopes = bitwise = 0
    for name, old in before.items():
        new = now.get(name)
        if isinstance(old, str) or isinstance(new, str):
            if old != new:
                problems.append(f"{name}: {old!r} -> {new!r}")
            continue
        if new is None or old["enumeration"] != new["enumeration"]:
            after = None if new is None else new["enumeration"]
            problems.append(f"{name}: enumeration {old['enumeration']} -> {after}")
            continue
        for a, b in zip(old["modes"], new["modes"], strict=True):
            plain = ("mode", "feasible", "pruned", "case", "full_dimensional", "inputs_full_dimensional")
            if any(a[key] != b[key] for key in plain):
                problems.append(f"{name} {a['mode']}: {[a[k] for k in plain]} -> {[b[k] for k in plain]}")
                continue
            for key in ("domain", "input_domain"):
                close, same_bits = _same(a[key], b[key])
                polytopes += a[key] is not None
                bitwise += same_bits and a[key] is not None
                if not close:
                    problems.append(f"{name} {a['mode']}: {key} differs")
    print(f"{len(before)} scenes, {polytopes} polytopes compared, {bitwise} bitwise equal, "
          f"{len(problems)} differences")
    return problems


def main(argv: list[str] | None = None) -> int:
    """The command line (see the module docstring)."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.analysis_speed", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    timing = sub.add_parser("measure")
    timing.add_argument("--runs", type=int, default=7)
    for name in ("snapshot", "compare"):
        sub.add_parser(name).add_argument("file", type=Path)
    args = parser.parse_args(argv)
    if args.command == "measure":
        for name, entry in measure(args.runs).items():
            print(f"{name:30s} median {entry['median_s'] * 1e3:8.1f} ms  "
                  f"cpu {entry['median_cpu_s'] * 1e3:8.1f} ms  "
                  f"ratio {entry['ratio_to_calibration']:6.3f}  LPs {entry['lps']}")
        return 0
    if args.command == "snapshot":
        args.file.write_bytes(pickle.dumps(snapshot()))
        return 0
    problems = compare(pickle.loads(args.file.read_bytes()), snapshot())
    for line in problems:
        print(line)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
