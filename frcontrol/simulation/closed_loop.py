r"""Closed loops on the rigid model: a policy chooses the inputs along one time-stepped run.

A *policy* looks at the run so far (a :class:`~frcontrol.simulation.rigid.RigidStepper`: its
time ``t``, state ``q``, ``v`` and the last step's contact forces ``last_forces``) and returns a
*command*, one value per scene input. :func:`run_closed_loop` asks it for a command every
``every`` steps and holds that command in between (zero-order hold); ``actuate`` may turn the
held command into each step's inputs at the step's state (for example to idle a leg in the air);
these options travel together as one :class:`LoopOptions`.
The run ends after ``duration`` (the steps of :func:`~frcontrol.simulation.inputs.step_lengths`,
as in :func:`~frcontrol.simulation.rigid.simulate_rigid`), when the stepper cannot go on (it
failed or diverged), or at the first step after which ``stop`` holds. Its trajectory passes the rigid
model's validity check (:func:`~frcontrol.simulation.validity.assess`) like any rigid run.

A constant policy called every step gives :func:`~frcontrol.simulation.rigid.simulate_rigid`'s
trajectory sample for sample. Planners build their policies (re-planning at the state reached)
on top of this loop; nothing here knows a planner.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..errors import InputError
from .inputs import check_input_vector, check_simulation_times, step_lengths
from .rigid import RigidStepper
from .trajectory import Trajectory

Policy = Callable[[RigidStepper], ArrayLike]
"""``stepper -> command``: the inputs to hold from the stepper's time on (one per scene input)."""

Actuation = Callable[[np.ndarray, RigidStepper], np.ndarray]
"""``(held command, stepper) -> inputs``: what one step applies, at the step's start."""

@dataclass(frozen=True)
class LoopOptions:
    """How :func:`run_closed_loop` asks, holds and applies the policy's commands, and when it stops.

    Attributes:
        every: steps between the policy's calls, >= 1.
        command: the command of the first ``every`` steps (default: the policy's at time 0).
        actuate: see :data:`Actuation` (default: the held command itself).
        stop: checked after every step; True ends the run (``stopped``).
    """

    every: int = 1
    command: ArrayLike | None = None
    actuate: Actuation | None = None
    stop: Callable[[RigidStepper], bool] | None = None


@dataclass(frozen=True, eq=False)
class ClosedLoopRun:
    """A closed-loop run.

    Attributes:
        trajectory: the run, checked for validity (its ``inputs`` are the applied ones).
        stopped: the ``stop`` condition ended the run.
        decisions: the policy's calls (the initial command, when given, is not one).
        timings: [s] ``policy`` (its calls), ``simulation`` (actuation and steps).
    """

    trajectory: Trajectory
    stopped: bool
    decisions: int
    timings: dict[str, float]


def run_closed_loop(
    stepper: RigidStepper,
    policy: Policy,
    duration: float,
    dt: float,
    *,
    options: LoopOptions = LoopOptions(),
    progress: Callable[[float, float], None] | None = None,
) -> ClosedLoopRun:
    """Step ``stepper`` for ``duration``, asking ``policy`` for a command every ``options.every`` steps.

    Args:
        stepper: a fresh rigid stepper (at time 0) on the scene to simulate.
        policy: see :data:`Policy`; its commands are checked against the scene's inputs
            (length, finite, within the limits).
        duration: [s] the longest simulated time.
        dt: [s] the time step.
        options: the policy's period, the first command, the actuation and the stop condition.
        progress: called with (simulated time, duration) every ``every`` steps and at a failure.

    Raises:
        InputError: a bad duration, step or ``every``; a command that is not a valid input.
    """
    duration, dt = check_simulation_times(duration, dt, scene=stepper.scene)
    every, command, actuate, stop = options.every, options.command, options.actuate, options.stop
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise InputError(f"every must be an integer >= 1 (steps), got {every!r}")
    scene = stepper.scene
    timings = {"policy": 0.0, "simulation": 0.0}
    decisions = 0
    if command is None:
        held = _decide(policy, stepper, timings)
        decisions += 1
    else:
        held = check_input_vector(scene, command, "the initial command")
    stopped = False
    for step, h in step_lengths(duration, dt):
        if step and step % every == 0:
            held = _decide(policy, stepper, timings)
            decisions += 1
        t0 = time.perf_counter()
        u = held if actuate is None else actuate(held, stepper)
        advanced = stepper.step(u, h)
        timings["simulation"] += time.perf_counter() - t0
        if progress is not None and ((step + 1) % every == 0 or not advanced):
            progress(stepper.t, duration)
        if not advanced:
            break
        if stop is not None and stop(stepper):
            stopped = True
            break
    return ClosedLoopRun(stepper.trajectory(dt), stopped, decisions, timings)


def _decide(policy: Policy, stepper: RigidStepper, timings: dict[str, float]) -> np.ndarray:
    """The policy's command at the stepper's state, checked; its time added to ``timings``."""
    t0 = time.perf_counter()
    when = f"the policy's command at t = {stepper.t:.6g} s"
    command = check_input_vector(stepper.scene, policy(stepper), when)
    timings["policy"] += time.perf_counter() - t0
    return command


__all__ = ["Actuation", "ClosedLoopRun", "LoopOptions", "Policy", "run_closed_loop"]
