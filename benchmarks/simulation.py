"""Simulation speed: ``python -m benchmarks.simulation [--runs N] [--no-compliant]``.

The real-time factor (simulated time over compute time) of:

- **the pumping flip** (``rhex_flip_drives``, ``simulate_pump`` for :data:`PUMP_DURATION`): its
  closed-loop run once (the planner's re-plans included, its ``timings`` reported), then its rigid
  simulation alone: the voltages the run applied, replayed step by step through a
  :class:`~frcontrol.simulation.rigid.RigidStepper` with the run's settings (the replay's samples
  are checked equal to the closed loop's, bit for bit: it is the same simulation);
- **the rigid flip** (``rhex_flip``, ``simulate_flip``: ``frc flip rhex_flip``'s closed loop), the
  same way (the stepper of the flip's loop: no impact law, the flip's armature);
- ``simulate_rigid`` of ``box_on_slope``, ``rod_drop`` (it lands: impacts) and ``snake_climb`` at
  zero input;
- **the compliant replay** of the pumping flip (``verify_compliant``: Radau, k = 1e6 N/m, the
  rigid run's voltages held per millisecond), one run (it takes seconds).

Every figure is a median of ``--runs`` CPU-time samples (the compliant replay: one), each preceded
by a sample of ``benchmarks.ci``'s calibration workload, and is given as a ratio to the
calibration's median and at machine factor 1.0 (scaled by
:data:`benchmarks.query.REFERENCE_CALIBRATION` over that median). Prints one line per case and
writes ``benchmarks/results/simulation.json``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.ci import InvalidAnswer, calibration_workload, versions
from benchmarks.query import REFERENCE_CALIBRATION

RESULTS = Path(__file__).resolve().parent / "results"

RUNS = 5
"""CPU-time samples per figure (their median is the figure)."""

PUMP_DURATION = 3.0
"""[s] Simulated time of the pumping flip (``simulate_pump``'s ``max_time``)."""

RIGID_RUNS = (("box_on_slope", 1.0), ("rod_drop", 1.0), ("snake_climb", 0.5))
"""``simulate_rigid`` cases at zero input: scene and duration [s]."""

TARGET_REAL_TIME_FACTOR = 10.0
"""[-] The target: the rigid simulations of the two flips run at least this many times faster than
real time at machine factor 1.0."""


@dataclass(frozen=True)
class Replay:
    """A closed loop's rigid simulation, replayed: ``call()`` steps it, ``check`` verifies it."""

    duration: float
    call: Callable[[], Any]
    check: Callable[[Any], None]
    closed_loop: dict[str, float]


def _replay(scene: Any, trajectory: Any, settings: Any, armature: float | None, max_time: float,
            closed_loop: dict[str, float]) -> Replay:
    """The stepper of a closed loop, fed the inputs it applied, step for step (the loops' steps:
    ``dt``, the last one shortened to end at ``max_time``)."""
    from frcontrol.simulation.rigid import RigidStepper

    inputs, dt = trajectory.inputs[1:], float(trajectory.info["dt"])

    def call() -> Any:
        stepper = RigidStepper(scene, settings, armature=armature)
        for u in inputs:
            if not stepper.step(u, min(dt, max_time - stepper.t)):
                break
        return stepper

    def check(stepper: Any) -> None:
        run = stepper.trajectory(dt)
        for field in ("q", "v", "contact_forces"):
            if not np.array_equal(getattr(run, field), getattr(trajectory, field)):
                raise InvalidAnswer(f"the replay's {field} differ from the closed loop's")

    return Replay(float(trajectory.times[-1]), call, check, closed_loop)


def pump_replay(duration: float = PUMP_DURATION) -> Replay:
    """The pumping flip's rigid simulation (``simulate_pump``'s stepper and voltages)."""
    from frcontrol.planning.flip import REPLAN_GAP_TOLERANCE
    from frcontrol.planning.pump import simulate_pump
    from frcontrol.scene import load_scene
    from frcontrol.simulation.rigid import RigidSettings

    scene = load_scene("rhex_flip_drives")
    result = simulate_pump(scene, max_time=duration)
    stepped = replace(scene, gap_tolerance=REPLAN_GAP_TOLERANCE)
    return _replay(stepped, result.trajectory, RigidSettings(max_ambiguity_checks=0), None, duration,
                   dict(result.timings))


def flip_replay() -> Replay:
    """``rhex_flip``'s flip's rigid simulation (``simulate_flip``'s stepper and applied torques)."""
    from frcontrol.planning.flip import REPLAN_GAP_TOLERANCE
    from frcontrol.planning.flip_loop import simulate_flip
    from frcontrol.scene import load_scene
    from frcontrol.simulation.rigid import RigidSettings

    scene = load_scene("rhex_flip")
    result = simulate_flip(scene)
    if result.trajectory is None:
        raise InvalidAnswer(f"the flip found no first plan: {result.reason}")
    stepped = replace(scene, gap_tolerance=REPLAN_GAP_TOLERANCE)
    settings = RigidSettings(max_ambiguity_checks=0, impact_law=False)
    return _replay(stepped, result.trajectory, settings, result.armature, result.max_time,
                   dict(result.timings))


def _cpu(call: Callable[[], Any]) -> tuple[float, Any]:
    start = time.process_time()
    answer = call()
    return time.process_time() - start, answer


def measure_case(duration: float, call: Callable[[], Any], check: Callable[[Any], None], runs: int
                 ) -> dict[str, Any]:
    """Median CPU time of ``runs`` samples, each after a calibration sample; the real-time factors."""
    seconds, calibrations = [], []
    for _ in range(runs):
        calibrations.append(_cpu(calibration_workload)[0])
        elapsed, answer = _cpu(call)
        check(answer)
        seconds.append(elapsed)
    median, calibration = statistics.median(seconds), statistics.median(calibrations)
    at_reference = median * REFERENCE_CALIBRATION / calibration
    return {"simulated_s": duration, "median_cpu_s": median, "calibration_cpu_s": calibration,
            "ratio_to_calibration": median / calibration, "cpu_s_at_factor_1": at_reference,
            "real_time_factor": duration / median, "real_time_factor_at_factor_1": duration / at_reference,
            "runs": runs}


def _rigid_case(name: str, duration: float) -> tuple[Callable[[], Any], Callable[[Any], None]]:
    from frcontrol.scene import load_scene
    from frcontrol.simulation import simulate_rigid

    scene = load_scene(name)

    def check(trajectory: Any) -> None:
        if trajectory.status != "completed":
            raise InvalidAnswer(f"{name}: the simulation {trajectory.status}")

    return (lambda: simulate_rigid(scene, None, duration, 1e-3)), check


def _compliant_case() -> dict[str, Any]:
    """The compliant replay of the pumping flip, once, with its calibration."""
    from frcontrol.planning.pump import simulate_pump, verify_compliant
    from frcontrol.scene import load_scene

    scene = load_scene("rhex_flip_drives")
    result = simulate_pump(scene, max_time=PUMP_DURATION)
    calibration = statistics.median(_cpu(calibration_workload)[0] for _ in range(3))
    elapsed, check = _cpu(lambda: verify_compliant(scene, result))
    at_reference = elapsed * REFERENCE_CALIBRATION / calibration
    return {"simulated_s": check["duration"], "median_cpu_s": elapsed, "calibration_cpu_s": calibration,
            "ratio_to_calibration": elapsed / calibration, "cpu_s_at_factor_1": at_reference,
            "real_time_factor": check["duration"] / elapsed,
            "real_time_factor_at_factor_1": check["duration"] / at_reference, "runs": 1,
            "max_pitch": check["max_pitch"], "status": check["status"]}


def run(runs: int, compliant: bool) -> dict[str, Any]:
    """Every case; prints one line per case."""
    cases: dict[str, dict[str, Any]] = {}
    for label, make in (("pump rigid (rhex_flip_drives, 3 s)", pump_replay),
                        ("flip rigid (rhex_flip)", flip_replay)):
        replay = make()
        cases[label] = {**measure_case(replay.duration, replay.call, replay.check, runs),
                        "closed_loop_timings_s": replay.closed_loop}
        _print(label, cases[label])
    for name, duration in RIGID_RUNS:
        call, check = _rigid_case(name, duration)
        cases[f"simulate_rigid {name}"] = measure_case(duration, call, check, runs)
        _print(f"simulate_rigid {name}", cases[f"simulate_rigid {name}"])
    if compliant:
        cases["compliant replay (rhex_flip_drives)"] = _compliant_case()
        _print("compliant replay (rhex_flip_drives)", cases["compliant replay (rhex_flip_drives)"])
    return {"benchmark": "simulation", "command": "python -m benchmarks.simulation",
            "reference_calibration_s": REFERENCE_CALIBRATION,
            "target_real_time_factor": TARGET_REAL_TIME_FACTOR,
            "versions": versions(), "cases": cases}


def _print(label: str, case: dict[str, Any]) -> None:
    steps = case["simulated_s"] / 1e-3
    print(f"{label}: {case['simulated_s']:.3g} s simulated in {case['median_cpu_s']:.3g} s CPU "
          f"(calibration {case['calibration_cpu_s'] * 1e3:.2f} ms): real-time factor "
          f"{case['real_time_factor']:.3g}, at factor 1.0 {case['real_time_factor_at_factor_1']:.3g} "
          f"({case['cpu_s_at_factor_1'] / steps * 1e6:.0f} us per ms simulated)", flush=True)


def main(argv: list[str] | None = None) -> int:
    """Measure, print, write ``results/simulation.json``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=RUNS, help="CPU-time samples per figure")
    parser.add_argument("--no-compliant", action="store_true", help="skip the compliant replay (seconds)")
    args = parser.parse_args(argv)
    result = run(args.runs, not args.no_compliant)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "simulation.json").write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
