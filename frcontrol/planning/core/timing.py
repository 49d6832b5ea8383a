"""Phase timings by name: the modules that plug into the loop where a task needs more than ``until``.

``[task] timing = "pump"`` names :mod:`frcontrol.planning.pump_timing`, the pumping flip's: when a
push ends (the toes lift off), when the legs recirculate and push again, the land phase past
vertical, and the energy per cycle. A timing module has ``timing(scene, task)``, which returns a
:class:`~.loop.PhaseTiming`. The core names the modules here and loads the one a task asks for when
it runs (it imports no planner of its own).

``[task] timing = "gait"`` names :mod:`frcontrol.planning.gait_timing`, the snake's climbing gait:
it drives every phase itself, every step (a robust tracking LP at the state reached, plus sampled
disturbance forces), and so also uses the two optional step hooks of :class:`StepHooks`: the scene
its rigid stepper runs on (inputs on every coordinate, for the disturbances' generalized forces)
and each step's inputs.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from ...errors import SceneError
from ...scene import Scene
from ...simulation.rigid import RigidSettings, RigidStepper
from ...simulation.trajectory import Trajectory
from .decision import Decision
from .task import Phase, Task

__all__ = ["TIMINGS", "PhaseTiming", "StepHooks", "Switch", "load_timing", "step_hooks"]

TIMINGS = {"gait": "frcontrol.planning.gait_timing", "pump": "frcontrol.planning.pump_timing"}
"""``[task] timing`` name -> the module that holds its ``timing(scene, task)``."""


@dataclass(frozen=True)
class Switch:
    """A phase timing's verdict: the current phase ends.

    Attributes:
        why: why it ends (the record's ``why``).
        to: the next phase's name; None: the run ends.
        met: the phase's ``until`` held (a run that ends with ``met`` is achieved).
    """

    why: str
    to: str | None
    met: bool = False


class PhaseTiming(Protocol):
    """A task's phase timing: when its phases end, and the inputs of the phases it drives.

    ``stepper`` is None at the run's first decision (the scene's state); ``since`` [s] is the time
    since the phase started.
    """

    settings: RigidSettings
    """The rigid stepper's settings for the run."""

    def free(self, phase: Phase) -> Mapping[str, str] | None:
        """Per contact, the letters a plan's other rigid solutions may have (None: none)."""

    def drive(self, phase: Phase, stepper: RigidStepper | None) -> np.ndarray | None:
        """The inputs of a phase the timing drives (None: the phase is planned)."""

    def before_decision(self, phase: Phase, stepper: RigidStepper) -> Switch | None:
        """At a decision, before the phase is planned or driven: end it, or not (None)."""

    def decided(
        self, phase: Phase, decision: Decision, stepper: RigidStepper | None
    ) -> tuple[np.ndarray | None, Switch | None]:
        """After a plan: other inputs to apply instead (or None), and whether the phase ends."""

    def after_step(self, phase: Phase, stepper: RigidStepper, since: float) -> Switch | None:
        """After every step: end the phase (or the run), or not (None)."""

    def report(self, scene: Scene, trajectory: Trajectory) -> dict[str, Any]:
        """What the timing reports of the run (the plan document's ``timing``)."""


class StepHooks(Protocol):
    """Optional hooks of a phase timing that acts at every step (a timing without them: the defaults).

    ``stepper_scene`` gives the scene the run's rigid stepper steps (default: the task's scene);
    its inputs are the ones ``actuate`` returns. ``actuate`` gives each step's inputs from the
    command held since the last decision (default: the command, with the massless inputs in the
    air at 0, :func:`~.forced.idle_in_the_air`).
    """

    def stepper_scene(self, scene: Scene) -> Scene:
        """The scene the rigid stepper runs on."""

    def actuate(self, phase: Phase, command: np.ndarray, stepper: RigidStepper) -> np.ndarray:
        """The inputs of the next step (in the stepper scene's input order)."""


def step_hooks(timing: PhaseTiming | None) -> StepHooks | None:
    """The timing as :class:`StepHooks` when it has both hooks, else None (the defaults apply)."""
    if timing is None or not (hasattr(timing, "stepper_scene") and hasattr(timing, "actuate")):
        return None
    hooks: StepHooks = timing  # type: ignore[assignment]
    return hooks


def load_timing(scene: Scene, task: Task) -> PhaseTiming | None:
    """The task's phase timing, built for the scene (None when the task names none).

    Raises:
        SceneError: an unknown timing (the schema names the known ones), or the timing's own
            checks of the scene and the task (its phases' names, the drives it needs).
    """
    if task.timing is None:
        return None
    if task.timing not in TIMINGS:
        raise SceneError(str(scene.path), "task.timing",
                         f"unknown timing {task.timing!r}; known: {', '.join(sorted(TIMINGS))}")
    module = importlib.import_module(TIMINGS[task.timing])
    built: PhaseTiming = module.timing(scene, task)
    return built
