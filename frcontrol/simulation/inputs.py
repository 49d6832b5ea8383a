r"""Inputs over time, and the checks of a simulation's duration and step.

``inputs`` is a constant vector (one value per scene input), a mapping ``name -> value`` (inputs
not named are 0) or a callable ``(t, q, v) -> u``. :func:`input_schedule` turns any of them into
a validated callable; a value outside the scene's input limits raises
:class:`~frcontrol.errors.InputError` (a callable's value, with the time at which it happened).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import InputError
from ..scene import Scene, parse_input_assignments

INPUT_LIMIT_TOLERANCE = 1e-9
"""[N or N m] An input may exceed its limit by this much (round-off) before it is an error."""

STEP_COUNT_TOLERANCE = 1e-9
"""[-] ``duration / dt`` within this of an integer counts as that integer (no sliver of a last
step from round-off)."""


InputSchedule = Callable[[float, np.ndarray, np.ndarray], np.ndarray]
"""``(t, q, v) -> u``: the validated input at a time and state."""


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


def check_simulation_times(duration: float, dt: float, dt_name: str = "dt") -> tuple[float, float]:
    """Validate a duration and a step.

    Raises:
        InputError: a non-finite or non-positive duration or step, or a step longer than the
            duration.
    """
    for label, value in (("duration", duration), (dt_name, dt)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(f"{label} must be a finite number [s], got {value!r}")
        if value <= 0:
            raise InputError(f"{label} must be > 0 [s], got {value}")
    if dt > duration:
        raise InputError(f"{dt_name} = {dt} s exceeds the duration {duration} s: use a smaller step")
    return float(duration), float(dt)


__all__ = [
    "INPUT_LIMIT_TOLERANCE",
    "InputSchedule",
    "check_input_vector",
    "STEP_COUNT_TOLERANCE",
    "check_simulation_times",
    "input_schedule",
    "step_lengths",
]
