r"""Inputs the rigid model forces, and massless inputs in the air: a plug-in of the core for any robot.

**Forced inputs.** Row j of the dynamics reads ``M_j dv + h_j = u_j + J_N,j^T lam_N + J_T,j^T lam_T``.
An input on a coordinate with no inertia, no bias and no active contact (a massless leg in the air)
is 0 in every solution (:func:`structurally_forced`); an input that every feasible mode's
consistency rows ``E u = e`` fix at one common value (a massless leg whose toe is lifting off) is
that value (:func:`forced_by_every_mode`). Every mode's input domain is then flat and no mode could
be planned, so such inputs are fixed at their forced value (moved into the bias, ``h - S_j^T u_j``,
:func:`fix_inputs`) and the decision plans the others (:func:`planning_problem`). The rule is the
flip's (:mod:`frcontrol.planning.flip`), with the same tolerance
(:data:`~.tolerances.FORCED_INPUT_TOLERANCE`).

**Massless inputs in the air.** Between plans the loop gives 0 to every input on a massless
coordinate (a zero row of the mass matrix at the start) none of whose contacts is within
:data:`~.tolerances.SEPARATION_GAP` of its surface (:func:`idle_in_the_air`): the rigid
model forces its torque to 0, and a held torque would spin the leg on its rotor inertia alone.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace

import numpy as np

from ...engine import DynamicResponse, analyze
from ...modes import ContactProblem
from ...scene import Scene
from ...solvers import SolverSettings
from .tolerances import FORCED_INPUT_TOLERANCE, SEPARATION_GAP

__all__ = [
    "fix_inputs",
    "forced_by_every_mode",
    "idle_in_the_air",
    "massless_inputs",
    "planning_problem",
    "structurally_forced",
]


def structurally_forced(problem: ContactProblem) -> dict[int, float]:
    """Inputs whose coordinate has no inertia, no bias and no active contact: forced to 0.

    Row j of the dynamics reads ``M_j dv + h_j = u_j + J_N,j^T lam_N + J_T,j^T lam_T``; with
    ``M_j = 0``, ``h_j = 0`` and zero contact columns, every solution has ``u_j = 0``.
    """
    M = problem.mass_matrix
    tol = FORCED_INPUT_TOLERANCE
    scale = max(1.0, float(np.max(np.abs(M), initial=0.0)))
    jac = np.vstack([problem.jacobian_normal, problem.jacobian_tangent]).reshape(-1, problem.n)
    forced = {}
    for i in range(problem.m):
        j = int(np.argmax(np.abs(problem.input_map[:, i])))
        if (np.max(np.abs(M[j]), initial=0.0) <= tol * scale and abs(problem.bias[j]) <= tol * scale
                and np.max(np.abs(jac[:, j]), initial=0.0) <= tol):
            forced[i] = 0.0
    return forced


def massless_inputs(scene: Scene) -> dict[int, list[int]]:
    """Inputs on massless coordinates (zero row of M at the scene's state) -> the contacts they move.

    Such an input is free (its torque cannot act on the body) whenever none of its contacts touches.
    """
    state = scene.robot.state(scene.q, scene.v)
    M = state.mass_matrix
    scale = max(1.0, float(np.max(np.abs(M))))
    jac = np.vstack([state.jacobian_normal, state.jacobian_tangent])
    k = len(scene.contacts)
    legs = {}
    for i, j in enumerate(scene.inputs.indices):
        if np.max(np.abs(M[j])) <= FORCED_INPUT_TOLERANCE * scale:
            rows = np.nonzero(np.abs(jac[:, j]) > FORCED_INPUT_TOLERANCE)[0]
            legs[i] = sorted({int(r % k) for r in rows})
    return legs


def forced_by_every_mode(analysis: DynamicResponse) -> dict[int, float]:
    """Inputs (index) that every feasible mode's consistency rows ``E u = e`` fix at one common value.

    ``E`` has orthonormal rows, so ``e_i`` lies in its row space when ``|E e_i| = 1``, and then
    ``u_i = (E e_i)^T e``.
    """
    modes = analysis.feasible_modes
    if not modes or any(m.response.E.shape[0] == 0 for m in modes):
        return {}
    tol = FORCED_INPUT_TOLERANCE
    forced = {}
    for i in range(analysis.problem.m):
        columns = [m.response.E[:, i] for m in modes]
        if any(1.0 - float(c @ c) > tol for c in columns):
            continue
        values = [float(c @ m.response.e) for c, m in zip(columns, modes, strict=True)]
        if max(values) - min(values) <= tol * (1.0 + max(abs(v) for v in values)):
            mean = float(np.mean(values))
            forced[i] = mean if abs(mean) > tol else 0.0
    return forced


def fix_inputs(problem: ContactProblem, fixed: Mapping[int, float]) -> ContactProblem:
    """The problem with the inputs ``fixed`` (index -> value) moved into the bias: ``h - S_i^T u_i``."""
    keep = [i for i in range(problem.m) if i not in fixed]
    idx = list(fixed)
    bias = problem.bias - problem.input_map[:, idx] @ np.array([fixed[i] for i in idx])
    return replace(
        problem,
        inputs=tuple(problem.inputs[i] for i in keep),
        bias=bias,
        input_map=problem.input_map[:, keep],
        lower=problem.lower[keep],
        upper=problem.upper[keep],
    )


def planning_problem(
    full: ContactProblem,
    settings: SolverSettings,
    lift: Callable[[ContactProblem], ContactProblem] | None = None,
) -> tuple[ContactProblem, DynamicResponse | None, dict[str, float]]:
    """The problem to plan on, its analysis (None when every input is forced) and the forced inputs.

    The structurally forced inputs are fixed first; when then no feasible mode has a
    full-dimensional input domain, the inputs every mode forces are fixed too. ``lift`` (a robust
    phase's lifted problem, the disturbances as extra inputs) is applied to the problem left.
    """
    lift = lift if lift is not None else (lambda problem: problem)
    forced = structurally_forced(full)
    planned = lift(fix_inputs(full, forced) if forced else full)
    analysis = analyze(planned, settings=settings) if planned.m else None
    if analysis is not None and not any(m.inputs_full_dimensional for m in analysis.feasible_modes):
        more = {
            full.inputs.index(planned.inputs[i]): value
            for i, value in forced_by_every_mode(analysis).items()
            if planned.inputs[i] in full.inputs
        }
        if more:
            forced.update(more)
            planned = lift(fix_inputs(full, forced))
            analysis = analyze(planned, settings=settings) if planned.m else None
    return planned, analysis, {full.inputs[i]: forced[i] for i in sorted(forced)}


def idle_in_the_air(legs: Mapping[int, list[int]], gaps: np.ndarray, command: np.ndarray) -> np.ndarray:
    """The command with 0 on every massless input none of whose contacts is within SEPARATION_GAP.

    ``legs``: :func:`massless_inputs`; ``gaps``: [m] every contact's gap.
    """
    free = [i for i, toes in legs.items() if not np.any(gaps[toes] <= SEPARATION_GAP)]
    if not free:
        return command
    out = command.copy()
    out[free] = 0.0
    return out
