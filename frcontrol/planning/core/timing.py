"""Phase timings by name: the modules that plug into the loop where a task needs more than ``until``.

``[task] timing = "pump"`` names :mod:`frcontrol.planning.pump_timing`, the pumping flip's: when a
push ends (the toes lift off), when the legs recirculate and push again, the land phase past
vertical, and the energy per cycle. A timing module has ``timing(scene, task)``, which returns a
:class:`~.loop.PhaseTiming`. The core names the modules here and loads the one a task asks for when
it runs (it imports no planner of its own).
"""

from __future__ import annotations

import importlib

from ...errors import SceneError
from ...scene import Scene
from .loop import PhaseTiming
from .task import Task

__all__ = ["TIMINGS", "load_timing"]

TIMINGS = {"pump": "frcontrol.planning.pump_timing"}
"""``[task] timing`` name -> the module that holds its ``timing(scene, task)``."""


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
