"""The least hip torque at which ``frc flip``'s unambiguous plan still flips RHex: a bisection.

Each trial sets both driven hips' torque limits of the scene (``rhex_flip`` unless ``--scene``) to
``+-T`` [N m at the hip, after the gearhead: the manual's torque convention, docs/models.md] and runs the real
closed loop, :func:`frcontrol.planning.flip_loop.simulate_flip` (plan, rigid simulation, re-plan every
10 steps, ``--max-time`` seconds). A trial flips when the body pitches past vertical within that
time. The bisection keeps ``lo`` (does not flip) and ``hi`` (flips) and halves the bracket down to
``--tolerance``; it assumes one threshold, so the script then checks it: it runs ``--check``
torques evenly from ``hi`` to the bracket's upper end and lists any that do not flip (a flip that
fails again above the threshold would make the figure misleading).

Prints one JSON document: the bracket ``[lo, hi]``, every trial (torque, flipped, time to
vertical, body contact kept, highest pitch) and the torques above ``hi`` that did not flip.
Not part of ``benchmarks/ci.py``: the measurement behind the "least hip torque" figure of docs/rhex-flip.md.

    python -m benchmarks.flip_torque                 # rhex_flip, bracket [5, 40] N m, to 0.01 N m
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from typing import Any

import numpy as np

from frcontrol.planning.flip_loop import simulate_flip
from frcontrol.scene import Scene, load_scene


def with_torque_limit(scene: Scene, limit: float) -> Scene:
    """The scene with every input's limits set to ``+-limit`` [N m]."""
    count = scene.inputs.count
    return replace(scene, inputs=replace(scene.inputs, lower=np.full(count, -float(limit)),
                                         upper=np.full(count, float(limit))))


def trial(scene: Scene, limit: float, max_time: float) -> dict[str, Any]:
    """One closed-loop flip at hip torque limit ``limit`` [N m]."""
    result = simulate_flip(with_torque_limit(scene, limit), max_time=max_time)
    pitch = None if result.trajectory is None else float(np.max(result.trajectory.q[:, 2]))
    return {"torque": limit, "flipped": result.flipped, "time_to_vertical": result.time_to_vertical,
            "body_contact_kept": result.body_contact_kept, "max_pitch": pitch}


def least_torque(scene: Scene, lo: float, hi: float, tolerance: float, max_time: float,
                 check: int) -> dict[str, Any]:
    """Bisect the hip torque limit between ``lo`` (must not flip) and ``hi`` (must flip)."""
    trials = [trial(scene, lo, max_time), trial(scene, hi, max_time)]
    if trials[0]["flipped"] or not trials[1]["flipped"]:
        return {"bracket": None, "trials": trials,
                "reason": f"the bracket [{lo:g}, {hi:g}] N m does not hold the threshold"}
    top = hi
    while hi - lo > tolerance:
        middle = 0.5 * (lo + hi)
        trials.append(trial(scene, middle, max_time))
        if trials[-1]["flipped"]:
            hi = middle
        else:
            lo = middle
    checks = [trial(scene, float(t), max_time) for t in np.linspace(hi, top, check)]
    return {"bracket": [lo, hi], "tolerance": tolerance, "max_time": max_time, "trials": trials,
            "checks": checks, "not_flipped_above": [c["torque"] for c in checks if not c["flipped"]]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="rhex_flip")
    parser.add_argument("--lo", type=float, default=5.0, help="[N m] a limit that does not flip")
    parser.add_argument("--hi", type=float, default=40.0, help="[N m] a limit that flips")
    parser.add_argument("--tolerance", type=float, default=0.01, help="[N m] the bracket's final width")
    parser.add_argument("--max-time", type=float, default=2.0, help="[s] as frc flip's --max-time")
    parser.add_argument("--check", type=int, default=12, help="torques checked above the threshold")
    args = parser.parse_args()
    found = least_torque(load_scene(args.scene), args.lo, args.hi, args.tolerance, args.max_time, args.check)
    print(json.dumps({"scene": args.scene, **found}, indent=1))


if __name__ == "__main__":
    main()
