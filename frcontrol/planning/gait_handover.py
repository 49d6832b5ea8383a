r"""The climbing gait's hand-overs: the next phase's torques and the exclusion of every slip mode.

See :mod:`frcontrol.planning.gait`, "Certificates".

The check is a small module of its own: :func:`hand_overs` gives every hand-over of a planned gait
its :class:`HandOver` record.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..scene import Scene
from ..solvers import DEFAULT_LP_SOLVER
from .disturbances import (
    DisturbanceSet,
    augmented_problem,
)
from .exclusions import mode_exclusions, mode_systems
from .gait_control import TRACKING_MARGIN, TrackingRequest, tracking_step
from .gait_geometry import STROKE, GaitGeometry

__all__ = [
    "HAND_OVERS",
    "PHASE_ROLES",
    "HandOver",
    "check_hand_over",
    "hand_overs",
]

# ============================================================================ the plan
PHASE_ROLES = {
    "extend": ("lower", "upper", ""),
    "upper_brace": ("lower", "", "upper"),
    "pull": ("upper", "lower", ""),
    "lower_brace": ("upper", "", "lower"),
}
"""Per phase: which brace is held (F), which opens (S while it touches), which closes."""

HAND_OVERS = (("upper_brace", "pull"), ("lower_brace", "extend"))
"""The hand-overs between braces: (the phase that closes a brace, the phase that opens the other)."""


@dataclass(frozen=True)
class HandOver:
    """The ambiguity check at a hand-over (module docstring, "Certificates").

    Attributes:
        name: ``"<phase>-><phase>"``; cycle: the cycle of the first phase.
        q: the planned configuration (both braces touching, at rest).
        mode: the next phase's mode over ``contacts`` (F held, S opening).
        contacts: the touching contacts.
        torques: [N m] the tracking LP's torques there.
        deficit: [N m or N] its robustness deficit (0: the mode holds with the margin).
        modes_checked: how many other modes were checked.
        held_modes: the other modes that hold for some disturbance of ``conv(V_s)``.
        slip_modes: those of them in which a brace contact slides (L or R).
    """

    name: str
    cycle: int
    q: np.ndarray
    mode: str
    contacts: tuple[str, ...]
    torques: np.ndarray
    deficit: float
    modes_checked: int
    held_modes: tuple[str, ...]
    slip_modes: tuple[str, ...]

    @property
    def unambiguous(self) -> bool:
        """No mode in which a brace contact slides holds anywhere on the robust set."""
        return not self.slip_modes

    def to_dict(self, inputs: Sequence[str]) -> dict[str, Any]:
        """The check as JSON."""
        return {"name": self.name, "cycle": self.cycle, "q": self.q, "contacts": list(self.contacts),
                "mode": self.mode,
                "torques": dict(zip(inputs, self.torques.tolist(), strict=True)), "deficit": self.deficit,
                "modes_checked": self.modes_checked, "held_modes": list(self.held_modes),
                "slip_modes": list(self.slip_modes), "unambiguous": self.unambiguous}


def hand_overs(scene: Scene, geometry: GaitGeometry, dist: DisturbanceSet,
               braces: tuple[tuple[str, ...], tuple[str, ...]], cycles: int, scale: float, *,
               solver: str = DEFAULT_LP_SOLVER) -> tuple[HandOver, ...]:
    """The hand-overs' checks of a gait of ``cycles`` cycles, each distinct one computed once.

    ``braces`` is ``(lower, upper)``; ``scale`` the disturbance scale the checks hold for.
    """
    lower, upper = braces
    d_min, d_max = STROKE
    rise = d_max - d_min
    points = dist.robust_points(scale)
    checks: dict[str, HandOver] = {}
    out = []
    for c in range(cycles):
        for first, second in HAND_OVERS:
            if second == "extend" and c == cycles - 1:
                continue
            y = c * rise + (rise if second == "extend" else 0.0)
            name = f"{first}->{second}"
            if name not in checks:
                shape = geometry.nominal(y, d_max if second == "pull" else d_min)
                held, released, _ = ((lower if r == "lower" else upper if r == "upper" else ())
                                     for r in PHASE_ROLES[second])
                checks[name] = check_hand_over(scene, dist, geometry.configuration(shape), (held, released),
                                               points, name, solver=solver)
            out.append(replace(checks[name], cycle=c + 1, q=checks[name].q + np.array([0.0, y] + [0.0] * 9)))
    return tuple(out)


def check_hand_over(scene: Scene, dist: DisturbanceSet, q: np.ndarray,
                    roles: tuple[Sequence[str], Sequence[str]], points: np.ndarray, name: str, *,
                    solver: str = DEFAULT_LP_SOLVER) -> HandOver:
    """Torques of the next phase at the hand-over (at rest), then every other mode's exclusion.

    ``roles`` is ``(held, released)``: the next phase's contacts in F and in S.
    """
    held, released = roles
    n = scene.robot.nv
    rest = np.zeros(n)
    request = TrackingRequest(q, rest, held, released, rest, points, TRACKING_MARGIN, solver)
    step = tracking_step(scene, dist, request)
    at = scene.at(q, np.zeros(n))
    touching = tuple(replace(c, active=c.name in step.contacts) for c in at.contacts)
    problem = augmented_problem(replace(at, contacts=touching), dist, np.minimum(0.0, points.min(axis=0)),
                                np.maximum(0.0, points.max(axis=0)))
    systems = mode_systems(problem)
    exclusions = mode_exclusions(problem, step.mode, step.torques, points, systems=systems, solver=solver,
                                 confirm=True)
    brace = set(held) | set(released)
    held_modes = tuple(e.mode for e in exclusions if e.held)
    slip = tuple(m for m in held_modes if any(letter in "LR" and contact in brace
                                              for letter, contact in zip(m, step.contacts, strict=True)))
    q0 = q - np.array([0.0, q[1]] + [0.0] * (n - 2))
    return HandOver(name, 0, q0, step.mode, step.contacts, step.torques, step.deficit, len(exclusions),
                    held_modes, slip)


