"""Every rigid solution at one input, from scratch, with each kernel (``FRC_KERNEL``).

``python -m benchmarks.kernel [--runs 7] [--calls 200]``: the three ``solutions_at_*`` figures of
``benchmarks.ci`` (``solutions_at(scene, zeros)`` on a loaded scene, no prior analysis) measured
with the NumPy kernel and with the compiled one, interleaved, in one process: the median of
``--runs`` runs of ``--calls`` calls each (wall time per call), and the ratio of CPU times to
``benchmarks.ci.calibration_workload`` measured in the same process (the median of its runs).
Both kernels' answers are checked to list the same modes.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from functools import partial

import numpy as np

from benchmarks.ci import _prefer_installed_frcontrol, calibration_workload

SCENES = ("rod_on_table", "box_on_slope", "rhex_flip")
KERNEL_NAMES = ("numpy", "compiled")


def _time(call, calls: int) -> tuple[float, float]:
    wall, cpu = time.perf_counter(), time.process_time()
    for _ in range(calls):
        call()
    return (time.perf_counter() - wall) / calls, (time.process_time() - cpu) / calls


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--calls", type=int, default=200)
    args = parser.parse_args(argv)
    _prefer_installed_frcontrol()
    from frcontrol.engine import solutions_at
    from frcontrol.scene import load_scene

    scenes = {name: load_scene(name) for name in SCENES}
    inputs = {name: np.zeros(scene.inputs.count) for name, scene in scenes.items()}
    wall: dict[tuple[str, str], list[float]] = {}
    cpu: dict[tuple[str, str], list[float]] = {}
    calibration: list[float] = []
    for name, scene in scenes.items():
        answers = []
        for kernel in KERNEL_NAMES:
            os.environ["FRC_KERNEL"] = kernel
            answers.append([s.mode for s in solutions_at(scene, inputs[name])])
        if answers[0] != answers[1]:
            raise SystemExit(f"{name}: the kernels disagree: {answers}")
    for _ in range(args.runs):
        calibration.append(_time(calibration_workload, 3)[1])
        for name, scene in scenes.items():
            for kernel in KERNEL_NAMES:
                os.environ["FRC_KERNEL"] = kernel
                call = partial(solutions_at, scene, inputs[name])
                _time(call, 20)  # warm-up
                w, c = _time(call, args.calls)
                wall.setdefault((name, kernel), []).append(w)
                cpu.setdefault((name, kernel), []).append(c)
    base = statistics.median(calibration)
    print(f"calibration workload: {base * 1e3:.2f} ms of CPU (median of {args.runs})")
    print(f"{'scene':<14} {'kernel':<9} {'median':>10} {'CPU ratio':>10}")
    for name in SCENES:
        for kernel in KERNEL_NAMES:
            median = statistics.median(wall[(name, kernel)])
            ratio = statistics.median(cpu[(name, kernel)]) / base
            print(f"{name:<14} {kernel:<9} {median * 1e6:>7.0f} us {ratio:>10.4f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
