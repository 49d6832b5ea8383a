"""Benchmark: loading a scene (``load_scene``) and the atlas's numeric override, in one process.

Run from the repository root (with frcontrol installed)::

    python -m benchmarks.scene_load [--rounds 7]

For each scene, times a warm ``load_scene`` (the process has loaded it once: the URDF's parse and
the Pinocchio model are cached, as in every load of a sweep or of ``frc serve``) and
``scene_with_numbers`` setting one coordinate of the state (the atlas's fast path, no load). Each
figure is the best of ``--rounds`` rounds, and its ratio to a calibration measured in the same
process: parsing the scene's own TOML text with ``tomllib``. Compare two versions by their ratios,
never by their absolute times (the machine is shared). Prints one line per scene; writes nothing.
"""

from __future__ import annotations

import argparse
import time
import tomllib
from collections.abc import Callable
from functools import partial

from frcontrol.scene import load_scene, resolve_scene_path
from frcontrol.scene_numbers import scene_with_numbers

SCENES = ("rod_on_table", "rhex_flip_drives", "snake_climb", "solo_standup")
"""The timed scenes: one body, a driven robot, nine links, a 3-D robot mapped onto its plane."""


def best(call: Callable[[], object], repeats: int, rounds: int) -> float:
    """The least mean time [s] of ``call`` over ``rounds`` rounds of ``repeats`` calls."""
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        for _ in range(repeats):
            call()
        times.append((time.perf_counter() - start) / repeats)
    return min(times)


def main() -> None:
    """Time every scene of :data:`SCENES` and print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    rounds = parser.parse_args().rounds
    for name in SCENES:
        text = resolve_scene_path(name).read_text()
        scene = load_scene(name)
        reference = best(partial(tomllib.loads, text), 200, rounds)
        load = best(partial(load_scene, name), 50, rounds)
        path = f"state.q.{scene.coordinate_names[2]}"
        numbers = {path: float(scene.q[2]) + 1e-9}
        moved = best(partial(scene_with_numbers, scene, numbers, scene.robot.coordinates_before_locking),
                     300, rounds)
        print(f"{name:17s} load_scene {load * 1e3:7.3f} ms = {load / reference:6.2f} x calibration   "
              f"{path} {moved * 1e6:6.1f} us = {moved / reference:6.3f} x calibration")


if __name__ == "__main__":
    main()
