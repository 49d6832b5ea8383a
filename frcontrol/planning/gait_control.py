r"""The climbing gait's control step: the robust tracking LP (:mod:`frcontrol.planning.gait`).

Control (the robust LP along the motion)
----------------------------------------
Every control step, at the simulated state ``(q, v)``, the phase's mode (``F`` for every held
contact that touches, ``S`` for every releasing one that still touches) has the affine response
``x = X z + x_0`` over ``z = (u, d)`` (:func:`~frcontrol.planning.disturbances.augmented_problem`, the
disturbances as inputs) and the domain rows ``H z <= h`` (normalised). The torques solve::

    minimise   sum_i |ddq_i(u, 0) - ddq_ref,i|  +  W sigma
    subject to H (u, v_j) <= h - margin + sigma     for every vertex v_j of s P
               u within the torque limits, 0 <= sigma

with ``ddq_ref = a_ref + K_p (q_ref - q) + K_d (v_ref - v)`` (:data:`TRACKING_STIFFNESS`,
:data:`TRACKING_DAMPING`). The mode's rows use friction cones of ``FRICTION_SAFETY mu``
(:data:`FRICTION_SAFETY`). ``sigma`` is 0 whenever the mode can be held robustly at scale ``s``
with the margin: then, by convexity, every disturbance of ``s P`` keeps the held contacts loaded
inside their (reduced) friction cones and the opening ones opening. The largest ``sigma`` of a run
is reported (``max_deficit``). Contacts that have opened and are within :data:`GUARD_DISTANCE` of
their wall are *guarded* at the zero disturbance: their approach is limited so that they do not
strike the wall (:func:`_guard_rows`; held at every vertex, the guard left the motion no room).
A contact that carried force in the last step is in the mode whatever its gap.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import InputError
from ..geometry import row_norms
from ..modes import build_mode_system
from ..response import solve_affine
from ..scene import Scene
from ..solvers import DEFAULT_LP_SOLVER, RETRY_ERRORS, DoorOptions, settings_from, solve_lp
from . import DEFAULT_CLIMB_MARGIN
from .disturbances import (
    DisturbanceSet,
    augmented_problem,
)

__all__ = [
    "FRICTION_SAFETY",
    "GUARD_DISTANCE",
    "GUARD_GAP",
    "GUARD_RATE",
    "ROBUSTNESS_PENALTY",
    "ROW_NORM_FLOOR",
    "TOUCH_GAP",
    "TRACKING_DAMPING",
    "TRACKING_MARGIN",
    "TRACKING_STIFFNESS",
    "TrackingRequest",
    "TrackingStep",
    "tracking_step",
]

TRACKING_STIFFNESS = 400.0
"""[1/s^2] K_p of the reference acceleration (a critically damped 20 rad/s loop)."""

TRACKING_DAMPING = 40.0
"""[1/s] K_d of the reference acceleration."""

ROBUSTNESS_PENALTY = 1e5
"""[-] Weight W of the robustness deficit sigma against the tracking error in the LP's cost."""

TOUCH_GAP = 1e-5
"""[m] A contact with a gap at most this takes part in the controller's mode."""

TRACKING_MARGIN = DEFAULT_CLIMB_MARGIN
"""[N m or N] The robustness radius the tracking LP asks of every vertex (the distance, in the
lifted ``(u, d)`` space, rows normalised, from the mode's boundary)."""

FRICTION_SAFETY = 0.8
"""[-] The tracking LP holds the held contacts inside friction cones of ``FRICTION_SAFETY mu``: a
sticking contact at the edge of its true cone creeps in the time stepper (its discretisation), so
the LP keeps this much of the cone in reserve."""

GUARD_DISTANCE = 0.03
"""[m] An opened contact nearer its wall than this is guarded (its approach is limited)."""

GUARD_GAP = 0.002
"""[m] The gap the guard keeps an opened contact away from."""

GUARD_RATE = 20.0
"""[1/s] alpha of the guard: the gap's approach is critically damped at this rate."""

ROW_NORM_FLOOR = 1e-12
"""[-] A domain row whose norm over ``(u, d)`` is at most this does not depend on them: dropped."""

# ============================================================================ control
@dataclass(frozen=True)
class TrackingStep:
    """One solution of the tracking LP.

    Attributes:
        torques: u [N m] in the scene's input order.
        mode: the letters of the contacts in the mode (``contacts``), e.g. ``"FFFS"``.
        contacts: the contacts in the mode.
        deficit: sigma [N m or N], 0 when the mode holds robustly with the margin.
        tracking_error: [rad/s^2 or m/s^2] ``sum |ddq(u, 0) - ddq_ref|``.
    """

    torques: np.ndarray
    mode: str
    contacts: tuple[str, ...]
    deficit: float
    tracking_error: float


@dataclass(frozen=True)
class TrackingRequest:
    """What one tracking LP is asked (:func:`tracking_step`).

    Attributes:
        q: the configuration.
        v: the velocity.
        held: contacts in mode F (those that touch).
        released: contacts in S (those that touch).
        desired: ddq_ref (n,).
        points: the vertices V_s of the disturbances (N, dim).
        margin: [N m or N] the robustness radius asked of every vertex.
        solver: the LP back-end.
        loaded: contacts that carried force in the last step: in the mode whatever their gap (a
            loaded contact drifts off its wall by a few micrometres in a time step).
    """

    q: np.ndarray
    v: np.ndarray
    held: Sequence[str]
    released: Sequence[str]
    desired: np.ndarray
    points: np.ndarray
    margin: float = TRACKING_MARGIN
    solver: str = DEFAULT_LP_SOLVER
    loaded: Sequence[str] = ()


def tracking_step(scene: Scene, disturbances: DisturbanceSet, request: TrackingRequest) -> TrackingStep:
    """The tracking LP at ``(q, v)`` (module docstring): torques holding the phase's mode robustly.

    Args:
        scene: the gait's scene.
        disturbances: the polytope P.
        request: the state, the contacts' roles, the target, the vertices, the margin, the back-end.
    """
    q, v, held, released, loaded = request.q, request.v, request.held, request.released, request.loaded
    desired, points, margin, solver = request.desired, request.points, request.margin, request.solver
    at = scene.at(q, v)
    chosen = [i for i, c in enumerate(at.contacts)
              if (c.name in held or c.name in released) and (c.gap <= TOUCH_GAP or c.name in loaded)]
    local = replace(at, contacts=tuple(replace(c, active=i in chosen) for i, c in enumerate(at.contacts)))
    contacts = local.active_contacts
    problem = augmented_problem(local, disturbances)
    problem = replace(problem, mu=FRICTION_SAFETY * problem.mu)
    mode = "".join("F" if c.name in held else "S" for c in contacts)
    m_u, n = scene.inputs.count, scene.robot.nv
    X, x0, H, h = _mode_rows(problem, mode)
    opened = [c.name for c in at.contacts if c.name in released and c.name not in {k.name for k in contacts}]
    guard = _unit_rows(*_guard_rows(local, X[:n], x0[:n], opened))
    H, h = _unit_rows(H, h)
    # variables (u, e, sigma): the mode's rows at every vertex, the guard's at the zero disturbance
    nvar = m_u + n + 1
    rows, rhs = [], []
    for (A, b), vertices in (((H, h), points), (guard, np.zeros((1, points.shape[1])))):
        for point in vertices:
            block = np.zeros((A.shape[0], nvar))
            block[:, :m_u] = A[:, :m_u]
            block[:, -1] = -1.0
            rows.append(block)
            rhs.append(b - A[:, m_u:] @ point - margin)
    Xq, a0 = X[:n, :m_u], x0[:n] - desired
    for sign in (1.0, -1.0):
        block = np.zeros((n, nvar))
        block[:, :m_u] = sign * Xq
        block[:, m_u:m_u + n] = -np.eye(n)
        rows.append(block)
        rhs.append(-sign * a0)
    cost = np.concatenate([np.zeros(m_u), np.ones(n), [ROBUSTNESS_PENALTY]])
    lb = np.concatenate([scene.inputs.lower, np.zeros(n + 1)])
    ub = np.concatenate([scene.inputs.upper, np.full(n + 1, np.inf)])
    result = solve_lp(cost, np.vstack(rows), np.concatenate(rhs), None, None, lb, ub,
                      door=DoorOptions(settings_from(solver), fallback=RETRY_ERRORS))
    if not result.found or result.x is None:
        raise InputError(f"the gait's tracking LP found no torques in mode {mode}: {result.status}")
    u = result.x[:m_u]
    return TrackingStep(u, mode, tuple(c.name for c in contacts), float(result.x[-1]),
                        float(np.sum(result.x[m_u:m_u + n])))


def _mode_rows(problem: Any, mode: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(X, x_0, H, h)``: the mode's response ``x = X z + x_0`` and its domain rows ``H z <= h``."""
    if not mode:
        X = np.linalg.solve(problem.mass_matrix, problem.input_map)
        return X, -np.linalg.solve(problem.mass_matrix, problem.bias), np.zeros((0, problem.m)), np.zeros(0)
    system = build_mode_system(problem, mode)
    response = solve_affine(system.A, system.B, system.c, name=f"the system of mode {mode}")
    X, x0 = response.X_u, response.x_0
    return X, x0, system.G @ X, system.g - system.G @ x0


def _unit_rows(H: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows ``H z <= h`` with unit norms (rows that do not depend on z dropped).

    Not :func:`~frcontrol.geometry.unit_rows`, which keeps zero rows: a row whose norm is at most
    :data:`ROW_NORM_FLOOR` is dropped here (its constraint ``0 <= h`` does not involve the LP's
    variables).
    """
    norms = row_norms(H)
    keep = norms > ROW_NORM_FLOOR
    return H[keep] / norms[keep, None], h[keep] / norms[keep]


def _guard_rows(scene: Scene, X: np.ndarray, x0: np.ndarray, names: Sequence[str]
                ) -> tuple[np.ndarray, np.ndarray]:
    """Rows ``A z <= b`` keeping opened contacts off their walls (module docstring, "Control").

    For each contact of ``names`` within :data:`GUARD_DISTANCE` of its wall, its normal
    acceleration ``a_N(z) = J_N (X z + x_0) + drift`` is kept above
    ``-2 alpha v_N - alpha^2 (gap - GUARD_GAP)`` (``alpha`` = :data:`GUARD_RATE`).
    """
    index = [i for i, c in enumerate(scene.contacts) if c.name in names and c.gap <= GUARD_DISTANCE]
    if not index:
        return np.zeros((0, X.shape[1])), np.zeros(0)
    state = scene.robot.state(scene.q, scene.v, index)
    gaps = np.array([scene.contacts[i].gap for i in index])
    alpha = GUARD_RATE
    floor = -2.0 * alpha * state.normal_velocities - alpha * alpha * (gaps - GUARD_GAP)
    A = -state.jacobian_normal @ X
    b = state.jacobian_normal @ x0 + state.drift_normal - floor
    return A, b


