r"""Inputs over time, and the checks of a simulation's duration, step and size.

``inputs`` is a constant vector (one value per scene input), a mapping ``name -> value`` (inputs
not named are 0) or a callable ``(t, q, v) -> u``. :func:`input_schedule` turns any of them into
a validated callable; a value outside the scene's input limits raises
:class:`~frcontrol.errors.InputError` (a callable's value, with the time at which it happened).

Every simulation's size is bounded before it starts (:func:`check_simulation_times`): at most
:data:`MAX_SIMULATION_SAMPLES` samples (``duration / dt``) and, with the scene, at most
:data:`MAX_TRAJECTORY_BYTES` of sampled arrays; above either the run is refused with
:class:`~frcontrol.errors.LimitExceeded` naming the field, the cap and the value.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError, LimitExceeded
from ..scene import Scene, parse_input_assignments

INPUT_LIMIT_TOLERANCE = 1e-9
"""[N or N m] An input may exceed its limit by this much (round-off) before it is an error."""

STEP_COUNT_TOLERANCE = 1e-9
"""[-] ``duration / dt`` within this of an integer counts as that integer (no sliver of a last
step from round-off)."""

MAX_SIMULATION_SAMPLES = 10_000_000
"""[-] The most samples (steps of ``dt``: ``duration / dt``) of one simulation; a longer run is
refused before it starts (1e4 s at the default dt of 1 ms)."""

MAX_TRAJECTORY_BYTES = 1 << 30
"""[bytes] The most memory a simulation's sampled arrays may take (1 GiB): times, q, v, inputs,
each contact's two forces and two point coordinates, and :data:`SAMPLE_DIAGNOSTICS` figures per
sample, 8 bytes each; a run that needs more is refused before it starts."""

SAMPLE_DIAGNOSTICS = 4
"""[-] Figures a simulator records per sample besides the trajectory's arrays (energies,
penetration), counted by :data:`MAX_TRAJECTORY_BYTES`."""


InputSchedule = Callable[[float, np.ndarray, np.ndarray], np.ndarray]
"""``(t, q, v) -> u``: the validated input at a time and state."""


@dataclass(frozen=True)
class InitialState:
    """Where a simulated run starts (each None: the scene's own).

    Attributes:
        q: the initial configuration, one value per coordinate [m or rad].
        v: the initial velocity, one value per coordinate [m/s or rad/s].
    """

    q: Sequence[float] | np.ndarray | None = None
    v: Sequence[float] | np.ndarray | None = None


def check_input_vector(scene: Scene, u: Any, when: str) -> np.ndarray:
    """``u`` as a float vector of the scene's inputs, checked (``when`` starts the message).

    Raises:
        InputError: not numbers, a wrong length, NaN or infinity, a value outside the limits.
    """
    try:
        arr = np.asarray(u, dtype=float).reshape(-1)
    except (TypeError, ValueError) as err:
        raise InputError(f"{when}: the input is not a vector of numbers: {u!r}") from err
    m = scene.inputs.count
    if arr.shape != (m,):
        raise InputError(f"{when}: expected {m} input values ({', '.join(scene.inputs.coordinates)}), "
                         f"got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{when}: the input has a NaN or infinite entry: {arr.tolist()}")
    lower, upper = scene.inputs.lower, scene.inputs.upper
    bad = np.nonzero((arr < lower - INPUT_LIMIT_TOLERANCE) | (arr > upper + INPUT_LIMIT_TOLERANCE))[0]
    if bad.size:
        j = int(bad[0])
        raise InputError(f"{when}: input {scene.inputs.coordinates[j]!r} = {arr[j]:.6g} is outside its "
                         f"limits [{lower[j]:.6g}, {upper[j]:.6g}]")
    return arr


def input_schedule(
    scene: Scene,
    inputs: Mapping[str, float] | Sequence[float] | np.ndarray | InputSchedule | None,
) -> tuple[InputSchedule, bool]:
    """A validated ``(t, q, v) -> u`` for a constant vector, a mapping or a callable.

    Returns:
        The schedule, and whether it is constant (the compliant integrator then needs no
        zero-order hold).

    Raises:
        InputError: wrong length, NaN, a value outside the scene's input limits.
        CoordinateNotFound: a mapping names an unknown input.
    """
    if inputs is None:
        inputs = np.zeros(scene.inputs.count)
    if callable(inputs):
        func = inputs

        def schedule(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
            return check_input_vector(scene, func(t, q, v), f"the input at t = {t:.6g} s")

        return schedule, False
    u: Any = parse_input_assignments(scene, inputs) if isinstance(inputs, Mapping) else inputs
    constant = check_input_vector(scene, u, "the constant input")
    constant.setflags(write=False)
    return (lambda t, q, v: constant), True


def step_lengths(duration: float, dt: float) -> Iterator[tuple[int, float]]:
    """``(step index, length [s])`` of each step of a run of ``duration``.

    Every step is ``dt`` long but the last, shortened to end at ``duration`` (the time reached
    summed step by step, as a stepper sums it).
    """
    steps = max(1, int(np.ceil(duration / dt - STEP_COUNT_TOLERANCE)))
    t = 0.0
    for step in range(steps):
        h = min(dt, duration - t) if step == steps - 1 else dt
        yield step, h
        t = t + h


def check_simulation_times(duration: float, dt: float, dt_name: str = "dt", scene: Scene | None = None
                           ) -> tuple[float, float]:
    """Validate a duration and a step, and the run's size they ask for.

    Args:
        duration: [s] the simulated time.
        dt: [s] the step (the sample interval).
        dt_name: what messages call the step.
        scene: when given, the sampled arrays' memory is checked too (their width depends on it).

    Raises:
        InputError: a non-finite or non-positive duration or step, or a step longer than the
            duration.
        LimitExceeded: more than :data:`MAX_SIMULATION_SAMPLES` samples, or more than
            :data:`MAX_TRAJECTORY_BYTES` of sampled arrays (``field`` ``"duration"``).
    """
    for label, value in (("duration", duration), (dt_name, dt)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(f"{label} must be a finite number [s], got {value!r}")
        if value <= 0:
            raise InputError(f"{label} must be > 0 [s], got {value}")
    if dt > duration:
        raise InputError(f"{dt_name} = {dt} s exceeds the duration {duration} s: use a smaller step")
    samples = math.ceil(duration / dt - STEP_COUNT_TOLERANCE)
    if samples > MAX_SIMULATION_SAMPLES:
        raise LimitExceeded("duration", samples, MAX_SIMULATION_SAMPLES, (
            f"duration / {dt_name} = {duration:g} s / {dt:g} s asks for {samples:.4g} samples; a simulation "
            f"takes at most {MAX_SIMULATION_SAMPLES:.4g} (MAX_SIMULATION_SAMPLES): shorten the duration or "
            f"lengthen {dt_name}"))
    if scene is not None:
        check_trajectory_memory(scene, samples, dt_name)
    return float(duration), float(dt)


def check_seed(seed: Any) -> int:
    """A random generator's seed, checked: an integer >= 0.

    Raises:
        InputError: not an integer, or negative.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be an integer >= 0, got {seed!r}")
    return int(seed)


def trajectory_bytes(scene: Scene, samples: int) -> int:
    """[bytes] The sampled arrays of a run of ``samples`` steps (see :data:`MAX_TRAJECTORY_BYTES`)."""
    n, m, k = scene.robot.nv, scene.inputs.count, len(scene.contacts)
    return (samples + 1) * (1 + 2 * n + m + 4 * k + SAMPLE_DIAGNOSTICS) * 8


def check_trajectory_memory(scene: Scene, samples: int, dt_name: str = "dt") -> None:
    """Refuse a run whose sampled arrays would exceed :data:`MAX_TRAJECTORY_BYTES`.

    Raises:
        LimitExceeded: ``field`` ``"duration"``, value and limit in bytes.
    """
    needed = trajectory_bytes(scene, samples)
    if needed > MAX_TRAJECTORY_BYTES:
        raise LimitExceeded("duration", needed, MAX_TRAJECTORY_BYTES, (
            f"{samples} samples of this scene need {needed / 2**20:.4g} MiB of sampled arrays; a simulation "
            f"takes at most {MAX_TRAJECTORY_BYTES / 2**20:.4g} MiB (MAX_TRAJECTORY_BYTES): shorten the "
            f"duration or lengthen {dt_name}"))


__all__ = [
    "INPUT_LIMIT_TOLERANCE",
    "InitialState",
    "InputSchedule",
    "MAX_SIMULATION_SAMPLES",
    "MAX_TRAJECTORY_BYTES",
    "SAMPLE_DIAGNOSTICS",
    "check_input_vector",
    "check_seed",
    "check_trajectory_memory",
    "trajectory_bytes",
    "STEP_COUNT_TOLERANCE",
    "check_simulation_times",
    "input_schedule",
    "step_lengths",
]
