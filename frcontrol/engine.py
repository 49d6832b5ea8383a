"""The mode-domain engine: every contact mode's response, domain and ambiguity (METHOD §2-5).

:func:`analyze` takes a scene at its state and returns a :class:`DynamicResponse`:

1. Modes are grown contact by contact (depth first, letters in S, L, R, F order). Velocity pruning
   removes letters a contact's velocity forbids; a *partial* assignment (the first j contacts) is a
   relaxation of every mode completing it, so when its equalities are inconsistent ("freedom") or
   its domain is empty ("infeasible") the whole subtree is dropped without enumerating it.
2. Each surviving mode's affine response ``x = X_u u + X_w w + x_0`` on ``E u = e``
   (:mod:`frcontrol.response`).
3. Its domain ``D_c = {(u, w): G (X_u u + X_w w + x_0) <= g, input limits, E u = e}`` in minimal
   form, its Chebyshev ball (emptiness, full-dimensionality) and ``T_c``, the projection onto the
   inputs.
4. Ambiguity: pairs of modes whose ``T_c`` interiors intersect, each mode's unambiguous set
   (``T_c`` minus the others, as convex pieces) and within-mode ambiguity (w).

:func:`solutions_at` answers one input: every mode whose domain holds it, with its accelerations,
forces and contact accelerations.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from . import polytope as poly
from .errors import InputError
from .modes import ContactProblem, ModeSystem, build_mode_system, mode_outputs
from .response import RANK_TOLERANCE, AffineSolution, ambiguous_outputs, solve_affine
from .scene import Scene, parse_input_assignments
from .solvers import DEFAULT_LP_SOLVER, solve_lp

DOMAIN_TOLERANCE = 1e-7
"""Membership: an input (u, w) is in a domain if no normalised half-space of it is violated by
more than this distance [units of u: N or N m]; also the radius below which a Chebyshev ball
counts as empty interior."""


@dataclass(frozen=True)
class ModeAnalysis:
    """Everything the engine knows about one contact mode.

    Attributes:
        mode: one letter per active contact.
        response: the affine response (None if never computed).
        ambiguous_outputs: ``"none"``, ``"forces"`` or ``"accelerations"``.
        feasible: D_c is non-empty.
        full_dimensional: D_c has an interior in (u, w) space (no consistency equalities and a
            Chebyshev radius above :data:`DOMAIN_TOLERANCE`).
        chebyshev_radius: the radius of D_c's Chebyshev ball within its affine hull.
        domain: D_c over (u, w), minimal (None if infeasible).
        input_domain: T_c over u, minimal (None if infeasible).
        inputs_full_dimensional: T_c has an interior in input space.
        pruned: why an infeasible mode is infeasible: ``"freedom"`` (its equalities admit no
            solution for any input) or ``"infeasible"`` (its domain is empty); None if feasible.
    """

    mode: str
    system: ModeSystem
    response: AffineSolution
    ambiguous_outputs: str
    feasible: bool
    full_dimensional: bool
    chebyshev_radius: float
    domain: poly.Polytope | None
    input_domain: poly.Polytope | None
    inputs_full_dimensional: bool
    pruned: str | None = None

    @property
    def ambiguity_dim(self) -> int:
        """Number of ambiguity variables w."""
        return self.response.ambiguity_dim

    @property
    def halfspaces(self) -> int:
        """Half-spaces of D_c's minimal representation (0 if infeasible)."""
        return 0 if self.domain is None else int(self.domain.A.shape[0])


@dataclass(frozen=True)
class Enumeration:
    """How the modes were found.

    Attributes:
        total: 4^k, every letter combination.
        after_velocity: modes left by velocity pruning.
        evaluated: modes whose full response and domain were computed.
        feasible: of those, the ones with a non-empty domain.
        pruned_freedom: modes dropped because their equalities admit no solution (counting the
            modes in subtrees dropped at a partial assignment).
        pruned_infeasible: modes dropped because their domain (or a partial one) is empty.
        partial_checks: partial assignments tested.
    """

    total: int
    after_velocity: int
    evaluated: int
    feasible: int
    pruned_freedom: int
    pruned_infeasible: int
    partial_checks: int

    @property
    def pruned_velocity(self) -> int:
        """Modes removed by velocity pruning."""
        return self.total - self.after_velocity


@dataclass(frozen=True)
class Overlap:
    """Two modes whose input domains T_c share an interior: between-mode ambiguity."""

    modes: tuple[str, str]
    chebyshev_radius: float
    center: np.ndarray


@dataclass(frozen=True)
class DynamicResponse:
    """The dynamic response of a scene at one state: every mode, its domain and the ambiguity."""

    problem: ContactProblem
    modes: tuple[ModeAnalysis, ...]
    enumeration: Enumeration
    overlaps: tuple[Overlap, ...]
    unambiguous: Mapping[str, tuple[poly.Polytope, ...]]
    timings: Mapping[str, float]
    tolerances: Mapping[str, float] = field(default_factory=dict)

    @property
    def feasible_modes(self) -> tuple[ModeAnalysis, ...]:
        """The modes with a non-empty domain."""
        return tuple(m for m in self.modes if m.feasible)

    def mode(self, name: str) -> ModeAnalysis:
        """The analysis of one mode.

        Raises:
            InputError: the mode was not evaluated (pruned, or not a mode of this scene).
        """
        for m in self.modes:
            if m.mode == name:
                return m
        raise InputError(f"mode {name!r} is not among the evaluated modes of this scene")

    def overlapping(self, name: str) -> tuple[str, ...]:
        """The modes whose T_c interior meets that of ``name``."""
        out = []
        for o in self.overlaps:
            if name in o.modes:
                out.append(o.modes[1] if o.modes[0] == name else o.modes[0])
        return tuple(out)


# ---------------------------------------------------------------------------- domain assembly
def domain_polytope(problem: ContactProblem, system: ModeSystem, response: AffineSolution) -> poly.Polytope:
    """D_c over z = (u, w): the mode's inequalities after substituting its response."""
    m, p = problem.m, response.ambiguity_dim
    G, g = system.G, system.g
    H = np.hstack([G @ response.X_u, G @ response.X_w])
    h = g - G @ response.x_0
    C, d = problem.input_bound_rows()
    H = np.vstack([H, np.hstack([C, np.zeros((C.shape[0], p))])])
    h = np.concatenate([h, d])
    A_eq = np.hstack([response.E, np.zeros((response.E.shape[0], p))])
    return poly.Polytope(H.reshape(-1, m + p), h, A_eq.reshape(-1, m + p), response.e.copy())


def _subtree_size(allowed: Sequence[str], depth: int) -> int:
    size = 1
    for letters in allowed[depth:]:
        size *= len(letters)
    return size


# ---------------------------------------------------------------------------- analyze
def analyze(
    scene: Scene | ContactProblem,
    *,
    solver: str = DEFAULT_LP_SOLVER,
    prune_partial: bool = True,
    ambiguity: bool = True,
    rank_tolerance: float = RANK_TOLERANCE,
    progress: Callable[[str], None] | None = None,
) -> DynamicResponse:
    """The dynamic response of a scene at its state.

    Args:
        scene: a loaded scene (its active contacts at its state) or a prepared problem.
        solver: the LP back-end for every domain computation.
        prune_partial: grow modes contact by contact and drop infeasible partial assignments
            (False: evaluate every mode velocity pruning leaves, the naive reference).
        ambiguity: also compute the overlaps and unambiguous sets.
        rank_tolerance: relative singular-value threshold of the rank decisions.
        progress: called with each mode's name as its evaluation starts (for progress displays).

    Raises:
        ImpactState: a contact moves into its surface.
        IllConditioned: a mode's system is too ill-conditioned to decide its rank.
    """
    timings = {"model": 0.0, "response": 0.0, "domain": 0.0, "projection": 0.0,
               "partial": 0.0, "ambiguity": 0.0}
    start = time.perf_counter()
    problem = scene if isinstance(scene, ContactProblem) else ContactProblem.from_scene(scene)
    timings["model"] = time.perf_counter() - start
    allowed = problem.allowed_modes()
    counts = {"freedom": 0, "infeasible": 0, "partial": 0, "evaluated": 0}
    analyses: list[ModeAnalysis] = []

    def evaluate(mode: str) -> None:
        t0 = time.perf_counter()
        counts["evaluated"] += 1
        if progress is not None:
            progress(mode)
        system = build_mode_system(problem, mode)
        response = solve_affine(system.A, system.B, system.c, rank_tolerance=rank_tolerance,
                                name=f"the system of mode {mode}")
        t1 = time.perf_counter()
        timings["response"] += t1 - t0
        outputs = ambiguous_outputs(response, problem.n)

        def infeasible(reason: str) -> None:
            counts[reason] += 1
            analyses.append(ModeAnalysis(
                mode=mode, system=system, response=response, ambiguous_outputs=outputs,
                feasible=False, full_dimensional=False, chebyshev_radius=0.0, domain=None,
                input_domain=None, inputs_full_dimensional=False, pruned=reason))

        if not response.consistent:
            infeasible("freedom")
            return
        domain = domain_polytope(problem, system, response)
        minimal = poly.minimal_representation(domain, solver=solver)
        t2 = time.perf_counter()
        timings["domain"] += t2 - t1
        if poly.is_empty(minimal):
            infeasible("infeasible")
            return
        ball = poly.chebyshev_ball(minimal, solver=solver)
        full = bool(ball.found and ball.radius > DOMAIN_TOLERANCE and minimal.A_eq.shape[0] == 0)
        t3 = time.perf_counter()
        timings["domain"] += t3 - t2
        if response.ambiguity_dim:
            inputs = poly.minimal_representation(
                poly.project(minimal, range(problem.m)), solver=solver)
        else:
            inputs = minimal
        input_ball = poly.chebyshev_ball(inputs, solver=solver)
        timings["projection"] += time.perf_counter() - t3
        analyses.append(ModeAnalysis(
            mode=mode, system=system, response=response, ambiguous_outputs=outputs, feasible=True,
            full_dimensional=full, chebyshev_radius=float(ball.radius) if ball.found else 0.0,
            domain=minimal, input_domain=inputs,
            inputs_full_dimensional=bool(input_ball.found and input_ball.radius > DOMAIN_TOLERANCE
                                         and inputs.A_eq.shape[0] == 0),
        ))

    def partial_feasible(prefix: str) -> str | None:
        """None if the partial assignment may be completed, else why not."""
        t0 = time.perf_counter()
        counts["partial"] += 1
        system = build_mode_system(problem, prefix)
        response = solve_affine(system.A, system.B, system.c, rank_tolerance=rank_tolerance,
                                name=f"the system of the partial mode {prefix}")
        reason = None
        if not response.consistent:
            reason = "freedom"
        elif poly.is_empty(domain_polytope(problem, system, response), solver=solver):
            reason = "infeasible"
        timings["partial"] += time.perf_counter() - t0
        return reason

    def grow(prefix: str) -> None:
        depth = len(prefix)
        if depth == problem.k:
            evaluate(prefix)
            return
        for letter in allowed[depth]:
            child = prefix + letter
            if prune_partial and depth + 1 < problem.k:
                reason = partial_feasible(child)
                if reason is not None:
                    counts[reason] += _subtree_size(allowed, depth + 1)
                    continue
            grow(child)

    grow("")
    after_velocity = _subtree_size(allowed, 0)
    feasible = [a for a in analyses if a.feasible]
    enumeration = Enumeration(
        total=4 ** problem.k, after_velocity=after_velocity, evaluated=counts["evaluated"],
        feasible=len(feasible), pruned_freedom=counts["freedom"], pruned_infeasible=counts["infeasible"],
        partial_checks=counts["partial"],
    )
    overlaps: list[Overlap] = []
    unambiguous: dict[str, tuple[poly.Polytope, ...]] = {}
    if ambiguity:
        t0 = time.perf_counter()
        overlaps, unambiguous = _ambiguity(feasible, solver)
        timings["ambiguity"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - start
    return DynamicResponse(
        problem=problem, modes=tuple(analyses), enumeration=enumeration, overlaps=tuple(overlaps),
        unambiguous=unambiguous, timings=timings,
        tolerances={"rank": rank_tolerance, "domain": DOMAIN_TOLERANCE,
                    "velocity": problem.velocity_tolerance},
    )


def _ambiguity(
    feasible: Sequence[ModeAnalysis], solver: str
) -> tuple[list[Overlap], dict[str, tuple[poly.Polytope, ...]]]:
    """Pairwise interior overlaps of the T_c, and each mode's unambiguous pieces."""
    candidates = [a for a in feasible if a.inputs_full_dimensional]
    overlaps: list[Overlap] = []
    partners: dict[str, list[poly.Polytope]] = {a.mode: [] for a in candidates}
    for i, a in enumerate(candidates):
        for b in candidates[i + 1:]:
            both = poly.intersect(a.input_domain, b.input_domain)
            ball = poly.chebyshev_ball(both, solver=solver)
            if ball.found and ball.radius > DOMAIN_TOLERANCE:
                overlaps.append(Overlap((a.mode, b.mode), float(ball.radius), ball.center))
                partners[a.mode].append(b.input_domain)
                partners[b.mode].append(a.input_domain)
    unambiguous = {
        a.mode: tuple(poly.set_difference(a.input_domain, partners[a.mode], solver=solver))
        for a in candidates
    }
    return overlaps, unambiguous


# ---------------------------------------------------------------------------- one input
@dataclass(frozen=True)
class RigidSolution:
    """One rigid-body solution at a given input: a mode whose domain holds the input.

    Attributes:
        mode: one letter per active contact.
        dv: accelerations [m/s^2, rad/s^2], shape (n,).
        lambda_n, lambda_t: contact forces [N], shape (k,).
        a_n, a_t: contact accelerations [m/s^2], shape (k,).
        ambiguity_dim: number of ambiguity variables of the mode.
        ambiguous_outputs: which outputs depend on them.
        w: the representative ambiguity values used (the Chebyshev centre of the admissible w).
        equality_residual: max |A x - B u - c| at the representative.
        inequality_violation: max violation of the mode's inequalities (<= tolerance).
    """

    mode: str
    dv: np.ndarray
    lambda_n: np.ndarray
    lambda_t: np.ndarray
    a_n: np.ndarray
    a_t: np.ndarray
    ambiguity_dim: int
    ambiguous_outputs: str
    w: np.ndarray
    equality_residual: float
    inequality_violation: float


def _input_vector(problem: ContactProblem, scene: Scene | None, inputs) -> np.ndarray:
    if isinstance(inputs, Mapping):
        if scene is None:
            raise InputError("named inputs need a scene; pass an input vector instead")
        return parse_input_assignments(scene, inputs)
    u = np.asarray(inputs, dtype=float).reshape(-1)
    if u.shape != (problem.m,):
        raise InputError(f"the input vector has {u.size} entries; the scene has {problem.m} inputs "
                         f"({', '.join(problem.inputs)})")
    if not np.all(np.isfinite(u)):
        raise InputError(f"the input vector has a NaN or infinite entry: {u.tolist()}")
    if np.any(u < problem.lower - DOMAIN_TOLERANCE) or np.any(u > problem.upper + DOMAIN_TOLERANCE):
        raise InputError(f"the input {u.tolist()} is outside the limits [{problem.lower.tolist()}, "
                         f"{problem.upper.tolist()}]")
    return u


def _slice_in_w(system: ModeSystem, response: AffineSolution, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mode's inequalities at fixed u as ``H_w w <= h_w``, rows normalised by their (u, w) norm."""
    G = system.G
    H_u = G @ response.X_u
    H_w = G @ response.X_w
    h = system.g - G @ response.x_0 - H_u @ u
    norms = np.sqrt(np.sum(H_u**2, axis=1) + np.sum(H_w**2, axis=1))
    norms[norms == 0.0] = 1.0
    return H_w / norms[:, None], h / norms


def _representative_w(H_w: np.ndarray, h_w: np.ndarray, solver: str) -> np.ndarray | None:
    """A w inside the slice (its Chebyshev centre), or None if the slice is empty."""
    p = H_w.shape[1]
    if p == 0:
        return np.zeros(0) if np.all(h_w >= -DOMAIN_TOLERANCE) else None
    ball = poly.chebyshev_ball(poly.Polytope(H_w, h_w + DOMAIN_TOLERANCE, np.zeros((0, p)), np.zeros(0)),
                               solver=solver)
    return ball.center if ball.found else None


def solutions_at(
    scene: Scene | ContactProblem,
    inputs: Mapping[str, float] | Sequence[float] | np.ndarray,
    *,
    solver: str = DEFAULT_LP_SOLVER,
    rank_tolerance: float = RANK_TOLERANCE,
) -> list[RigidSolution]:
    """Every rigid-body solution at one input: all modes whose domain holds it.

    Args:
        scene: a scene (at its state) or a prepared problem.
        inputs: ``{name: value}`` (names not given are 0) or the full input vector.

    Raises:
        CoordinateNotFound / InputError: unknown input names, wrong length, NaN, outside limits.
        ImpactState: a contact moves into its surface.
    """
    problem = scene if isinstance(scene, ContactProblem) else ContactProblem.from_scene(scene)
    u = _input_vector(problem, scene if isinstance(scene, Scene) else None, inputs)
    allowed = problem.allowed_modes()
    found: list[RigidSolution] = []

    def admissible(system: ModeSystem, response: AffineSolution) -> np.ndarray | None:
        if not response.consistent:
            return None
        if response.E.shape[0] and np.max(np.abs(response.E @ u - response.e)) > DOMAIN_TOLERANCE:
            return None
        H_w, h_w = _slice_in_w(system, response, u)
        return _representative_w(H_w, h_w, solver)

    def grow(prefix: str) -> None:
        depth = len(prefix)
        for letter in allowed[depth]:
            mode = prefix + letter
            system = build_mode_system(problem, mode)
            response = solve_affine(system.A, system.B, system.c, rank_tolerance=rank_tolerance,
                                    name=f"the system of mode {mode}")
            w = admissible(system, response)
            if w is None:
                continue
            if depth + 1 < problem.k:
                grow(mode)
                continue
            x = response.X_u @ u + response.X_w @ w + response.x_0
            out = mode_outputs(problem, x)
            violation = system.G @ x - system.g
            found.append(RigidSolution(
                mode=mode, dv=out["dv"], lambda_n=out["lambda_n"], lambda_t=out["lambda_t"],
                a_n=out["a_n"], a_t=out["a_t"], ambiguity_dim=response.ambiguity_dim,
                ambiguous_outputs=ambiguous_outputs(response, problem.n), w=w,
                equality_residual=float(np.max(np.abs(system.A @ x - system.B @ u - system.c),
                                               initial=0.0)),
                inequality_violation=float(np.max(violation, initial=0.0)),
            ))

    if problem.k == 0:
        system = build_mode_system(problem, "")
        response = solve_affine(system.A, system.B, system.c, rank_tolerance=rank_tolerance)
        if admissible(system, response) is not None:
            x = response.X_u @ u + response.x_0
            out = mode_outputs(problem, x)
            found.append(RigidSolution("", out["dv"], out["lambda_n"], out["lambda_t"], out["a_n"],
                                       out["a_t"], response.ambiguity_dim,
                                       ambiguous_outputs(response, problem.n), np.zeros(0),
                                       float(np.max(np.abs(system.A @ x - system.B @ u - system.c))), 0.0))
        return found
    grow("")
    return found
