"""The planning core's named tolerances (units and meanings below; ``docs/tasks.md`` lists them).

Every planner on the core (and the dedicated ones: :mod:`frcontrol.planning.flip` re-exports them)
uses these; the report of a run (``tolerances``) repeats them.
"""

from __future__ import annotations

__all__ = [
    "FORCED_INPUT_TOLERANCE",
    "INPUT_LIMIT_TOLERANCE",
    "REPLAN_GAP_TOLERANCE",
    "REPLAN_VELOCITY_TOLERANCE",
    "SEPARATION_GAP",
    "TORQUE_ROUNDING",
]

TORQUE_ROUNDING = 1e-4
"""[input units: N m, N or V] A plan's inputs are rounded to multiples of this (as printed) before
verification."""

INPUT_LIMIT_TOLERANCE = 1e-9
"""[-] A unit row of a mode's input domain T_c is an input-limit row (not shrunk by the margin) when
it equals ``±e_i`` and its right-hand side equals the limit to this (relative to ``1 + |limit|``)."""

REPLAN_VELOCITY_TOLERANCE = 1e-3
"""[m/s] In a closed loop, a contact velocity (normal or tangential) of at most this counts as zero
when re-planning (the normal velocity of a contact the last step loaded is taken as 0 in any case)."""

REPLAN_GAP_TOLERANCE = 1e-5
"""[m] In a closed loop, a contact with gap at most this is active when re-planning (the time
stepper keeps closed contacts within about ``g dt^2`` = 1e-5 m of their surface)."""

SEPARATION_GAP = 1e-4
"""[m] A contact *touches* (is *closed*) at a sample when its gap is at most this; once touching, a
gap above it is a separation. One step of chatter (a resting contact opening for one step, about
``g dt^2`` = 1e-5 m at 1 ms) stays below it."""

FORCED_INPUT_TOLERANCE = 1e-9
"""[-] Relative tolerance of the forced-input tests: a zero row or column of the dynamics, and an
input direction ``e_i`` lying in the row space of a mode's consistency rows ``E`` (``1 - |E e_i|^2``
at most this), with the same value in every feasible mode (to this times ``1 + |value|``)."""
