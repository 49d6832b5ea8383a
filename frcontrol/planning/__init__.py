"""Planners on the mode-domain engine: the RHex flip, the snake climb and standing up.

``plan_flip`` and ``plan_climb`` are also exported at the top level (``frcontrol.plan_flip``).
The planners' defaults live here, in a module that imports nothing, so that the command line can
show them without loading the planners.
"""

DEFAULT_FLIP_MARGIN = 0.05
"""[N m] Default distance (in input space) between the flip plan and every input where another
mode also holds: 500 times the flip's torque rounding, and small against RHex's 10 N m hip
limits (:data:`frcontrol.planning.flip.DEFAULT_MARGIN`)."""

DEFAULT_CLIMB_MARGIN = 0.05
"""[N m or N] Default robustness radius of the climb (:data:`frcontrol.planning.climb.DEFAULT_MARGIN`)."""

DEFAULT_CLIMB_DURATION = 0.1
"""[s] Default simulated time of the climb: its task's ``max_time`` on the shipped scene, and
that of :func:`frcontrol.planning.climb_check.simulate_climb`."""

__all__ = ["DEFAULT_CLIMB_DURATION", "DEFAULT_CLIMB_MARGIN", "DEFAULT_FLIP_MARGIN"]
