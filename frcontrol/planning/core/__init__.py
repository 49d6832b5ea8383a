"""One planner for any robot: a scene's task as phases, planned along a rigid closed loop.

- :mod:`.task`: the ``[task]`` format (``max_time``, ``repeat``, ``[[task.phases]]``) read into records;
- :mod:`.objective`: a phase's objective as rows over the accelerations;
- :mod:`.decision`: one decision, the LP over the allowed modes' unambiguous inputs, verified;
- :mod:`.loop`: the decisions along one rigid run, phases advanced on ``until``;
- :mod:`.report`: :class:`PlanResult` and :func:`plan_task`, the ``frc plan`` / ``POST /plan`` answer.
"""

from .decision import Decision, decide
from .report import PlanResult, plan_task
from .task import Phase, Task, read_task

__all__ = ["Decision", "Phase", "PlanResult", "Task", "decide", "plan_task", "read_task"]
