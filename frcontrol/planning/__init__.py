"""Planners on the mode-domain engine: the RHex flip and the snake climb.

``plan_flip`` and ``plan_climb`` are also exported at the top level (``frcontrol.plan_flip``).
"""

__all__: list[str] = []  # the planners live in frcontrol.planning.flip and frcontrol.planning.climb
