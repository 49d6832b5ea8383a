"""The mode-domain engine: every contact mode's response, domain and ambiguity.

The maths: docs/maths.md, *Mode domains and ambiguity*.

:func:`analyze` takes a scene at its state and returns a :class:`DynamicResponse`:

1. Modes are grown contact by contact (depth first, letters in S, L, R, F order). Velocity pruning
   removes letters a contact's velocity forbids; a *partial* assignment (the first j contacts) is a
   relaxation of every mode completing it, so when it fails the test below the whole subtree is
   dropped without enumerating it. One LP (:func:`motion_margin`) per assignment: is its domain
   empty ("infeasible"), or can no solution of it move as the mode says ("freedom": its equalities
   admit no solution, or every solution has a sliding contact with zero sliding acceleration or a
   separating contact with zero normal acceleration, e.g. one rigid body sliding two contacts in
   opposite directions)? A degenerate solution of that kind is also a solution of the mode with
   those letters replaced (L, R -> F; S -> F, L or R), so nothing is lost: every rigid-body solution
   is reported once, under the mode that describes its motion.
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

import math
import time
import weakref
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any, Literal, overload

import numpy as np
import numpy.typing as npt

from . import polytope as poly
from .ambiguity_polygon import (
    LP_NEAR_OPTIMAL,
    POLYGON_MAX_ROWS,
    SINGULAR_DETERMINANT,
    VERTEX_TOLERANCE,
    PolygonRule,
)
from .errors import IllConditioned, InputError, KernelError
from .geometry import CAPPED_FRACTION, CHEBYSHEV_RADIUS_CAP, constant_rows, max_margin, row_norms
from .jsonable import to_jsonable
from .kernel import Backend, backend, compiled, twin
from .mode_batch import (
    AMBIGUOUS_OUTPUT_CODES,
    BATCH_MAX_MODES,
    CERTIFIED_MARGIN,
    decide_modes,
    interval_admissible,
)
from .modes import (
    FRICTION_PLANS,
    VELOCITY_TOLERANCE,
    ContactProblem,
    ModeSystem,
    add_scene_modes,
    build_child_systems,
    build_mode_system,
    extend_child_systems,
    mode_outputs,
    needs_balancing,
)
from .query import BatchSolutions, QueryMode, QueryTable, check_inputs
from .response import (
    BALANCING_FRICTION,
    BY_ROWS_EXACT_FACTOR,
    BY_ROWS_VOID_FACTOR,
    CONSISTENCY_TOLERANCE,
    ILL_CONDITIONED_BAND,
    OUTPUT_TOLERANCE,
    RANK_TOLERANCE,
    ROUND_OFF_RANK_DROP,
    AffineSolution,
    AmbiguousOutputs,
    ambiguous_outputs,
    certified_by_rows,
    certified_children,
    solve_affine,
    solve_affine_stack,
)
from .scene import INPUT_LIMIT_SLACK, InputValues, Scene, input_vector
from .solvers import DEFAULT_SETTINGS, RETRY_ERRORS, InequalityLPs, SolverSettings, settings_from

DOMAIN_TOLERANCE = 1e-7
"""Membership: an input (u, w) is in a domain if no normalised half-space of it is violated by
more than this distance [units of u: N or N m]; also the radius below which a Chebyshev ball
counts as empty interior."""


ZERO_ROW_TOLERANCE = 1e-9
"""A row of a domain whose coefficients' norm is at most this times the largest row norm is a
constant row: it is judged by its right-hand side alone (normalising it would inflate round-off)."""

MARGIN_LP_BAND = 100.0
"""[-] The compiled kernel's motion LP (``frcontrol._kernel.margin_lp``) says "above" only when its
margin exceeds ``DOMAIN_TOLERANCE * MARGIN_LP_BAND``, and "below" only when its dual bound is under
``DOMAIN_TOLERANCE / MARGIN_LP_BAND``; between the two the door's LP decides. On the shipped scenes
and the snakes with 4 to 10 contacts every margin is below 3e-16 or above 9e-3, far outside."""

MARGIN_LP_RESIDUAL = 1e-9
"""[units of u] The kernel's motion LP accepts its optimum only when the point violates no unit row
(nor ``0 <= t <= 1``) by more than this, every row unscaled by more than this times ``1 + |h_i|``,
and its dual certificate's residual is at most this; a constant row (:data:`ZERO_ROW_TOLERANCE`)
may read down to ``-MARGIN_LP_RESIDUAL``. Otherwise the door's LP decides. The dual residual bounds
the margin of a point z only up to this times ``|z|_1``: with inputs near 1e9 (no physical
scene's) a margin just above the band could read as below it."""

MARGIN_LP_EMPTY = 1e-4
"""[units of u] The kernel's motion LP calls a set empty only when its Farkas ray shows that every
point violates some unit row by about this or more; a set closer to feasible goes to the door's LP,
whose residual test is relative (:data:`~frcontrol.solvers.FEASIBILITY_TOLERANCE` times the LP's
scale) and may accept a point of such a set. On the shipped scenes and the snakes with 8 and 10
contacts every empty set misses by 7e-3 or more."""

MARGIN_LP_PIVOT = 1e-9
"""[-] The kernel's motion LP pivots on no tableau entry smaller than this (its columns are unit
rows)."""

MARGIN_LP_OPTIMALITY = 1e-12
"""[units of u] The kernel's motion LP stops when no reduced cost is below minus this: every row's
slack at the basis' point (its reduced cost) is then at least ``-MARGIN_LP_OPTIMALITY``."""

MODES_LISTED = 8
"""[modes] How many feasible modes the error of :meth:`DynamicResponse.mode` lists by name."""


def mode_response(problem: ContactProblem, system: ModeSystem, rank_tolerance: float) -> AffineSolution:
    """The mode's response by :func:`solve_affine` (the SVD and its rank rule, balanced where needed).

    Raises:
        IllConditioned: the mode's system, named as messages name a mode (the scene's letters and
            the contacts' names: :meth:`~frcontrol.modes.ContactProblem.named_mode`).
    """
    try:
        return solve_affine(system.A, system.B, system.c, rank_tolerance=rank_tolerance,
                            name=f"the system of mode {system.mode}",
                            balance=bool(needs_balancing(problem, [system.mode])[0]))
    except IllConditioned as err:
        raise IllConditioned(f"the system of mode {problem.named_mode(system.mode)}", err.condition_number,
                             err.tolerance) from None


def _row_norms(H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row norms, and the mask of numerically constant rows (see :data:`ZERO_ROW_TOLERANCE`)."""
    return constant_rows(H, ZERO_ROW_TOLERANCE)


PruneReason = Literal["freedom", "infeasible"]
"""Why a mode was pruned: its equalities admit no solution, or none moves as the mode says
(``freedom``); or its domain is empty (``infeasible``)."""

MarginVerdict = Literal["ok", "freedom", "infeasible"]
""":func:`motion_margin`'s verdict: ``ok``, or why not (a :data:`PruneReason`)."""


@dataclass(frozen=True)
class ModeAnalysis:
    """Everything the engine knows about one contact mode.

    Attributes:
        mode: one letter per active contact.
        system: the mode's linear system (equalities and inequalities over x).
        response: the affine response.
        ambiguous_outputs: ``"none"``, ``"forces"`` or ``"accelerations"``.
        feasible: D_c is non-empty (and some solution moves as the mode says).
        full_dimensional: D_c has an interior in (u, w) space (no consistency equalities and a
            Chebyshev radius above :data:`DOMAIN_TOLERANCE`).
        chebyshev_radius: the radius of D_c's Chebyshev ball within its affine hull (capped at
            :data:`frcontrol.polytope.CHEBYSHEV_RADIUS_CAP`).
        raw_domain: D_c over (u, w) as assembled: every row of the mode's inequalities and the
            input limits, redundant ones included (None if infeasible).
        inputs_full_dimensional: T_c has an interior in input space.
        pruned: why an infeasible mode is infeasible: ``"freedom"`` (its equalities admit no
            solution, or no solution moves as the mode says) or ``"infeasible"`` (its domain is
            empty); None if feasible.
        m: the number of inputs (the first m coordinates of D_c).

        raw_ball: the Chebyshev ball of ``raw_domain`` found when the mode was evaluated (the
            minimal form's emptiness test is this same LP), or None.
        named: the mode as messages name it, over every scene contact with the contacts' names
            (:meth:`~frcontrol.modes.ContactProblem.named_mode`); empty: :attr:`mode`.

    ``domain`` (D_c in minimal form) and ``input_domain`` (T_c, its projection onto the inputs)
    are derived from the fields on first use (``functools.cached_property``: kept in the instance,
    never a field, so ``==``, ``repr`` and :func:`dataclasses.replace` see the fields alone):
    reducing and projecting are the costliest stages, and feasibility, full-dimensionality,
    overlaps and the solutions at an input do not need them.
    """

    mode: str
    system: ModeSystem
    response: AffineSolution
    ambiguous_outputs: AmbiguousOutputs
    feasible: bool
    full_dimensional: bool
    chebyshev_radius: float
    raw_domain: poly.Polytope | None
    inputs_full_dimensional: bool
    pruned: PruneReason | None = None
    m: int = 0
    settings: SolverSettings = DEFAULT_SETTINGS
    raw_ball: poly.ChebyshevBall | None = field(default=None, repr=False, compare=False)
    named: str = field(default="", repr=False, compare=False)

    @property
    def solver(self) -> str:
        """The LP back-end of its domain computations (``settings.lp``)."""
        return self.settings.lp

    @property
    def ambiguity_dim(self) -> int:
        """Number of ambiguity variables w."""
        return self.response.ambiguity_dim

    @property
    def halfspaces(self) -> int:
        """Half-spaces of D_c's minimal representation (0 if infeasible)."""
        return 0 if self.domain is None else int(self.domain.A.shape[0])

    @cached_property
    def domain(self) -> poly.Polytope | None:
        """D_c over (u, w) in minimal form (None if infeasible)."""
        if self.raw_domain is None:
            return None
        return poly.minimal_representation(self.raw_domain, settings=self.settings, ball=self.raw_ball)

    @cached_property
    def input_domain(self) -> poly.Polytope | None:
        """T_c: the inputs u for which some w puts (u, w) in D_c (minimal; None if infeasible)."""
        if self.domain is None:
            return None
        if self.ambiguity_dim:
            # self.domain is D_c in minimal form already: the projection starts from it
            return poly.project(self.domain, range(self.m), settings=self.settings, minimal=True)
        return self.domain

    @property
    def feasible_domain(self) -> poly.Polytope:
        """D_c of a feasible mode (:attr:`domain`, which is None for an infeasible one).

        Raises:
            InputError: the mode is infeasible.
        """
        if self.domain is None:
            raise InputError(f"mode {self.named or self.mode} is infeasible: it has no domain")
        return self.domain

    @property
    def feasible_input_domain(self) -> poly.Polytope:
        """T_c of a feasible mode (:attr:`input_domain`, which is None for an infeasible one).

        Raises:
            InputError: the mode is infeasible.
        """
        domain = self.input_domain
        if domain is None:
            raise InputError(f"mode {self.named or self.mode} is infeasible: it has no input domain")
        return domain


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
    """The dynamic response of a scene at one state: every mode, its domain and the ambiguity.

    Unambiguous sets are computed on demand (:meth:`unambiguous_set`, on each call: keep the
    result). :attr:`query` is the feasible modes stacked for point location
    (:class:`~frcontrol.query.QueryTable`), built on the first query.
    """

    problem: ContactProblem
    modes: tuple[ModeAnalysis, ...]
    enumeration: Enumeration
    overlaps: tuple[Overlap, ...]
    timings: Mapping[str, float]
    settings: SolverSettings = DEFAULT_SETTINGS
    tolerances: Mapping[str, float] = field(default_factory=dict)

    @cached_property
    def query(self) -> QueryTable:
        """The feasible modes stacked for point location (:func:`build_query_table`), built once.

        Built on the first query, not with the analysis (from ten queries' cost to hundreds, that an
        analysis never queried does not pay); ``timings["query_table"]`` then holds its time [s] (0 before;
        not part of ``timings["total"]``, the analysis's own time; a copy made by
        ``dataclasses.replace`` shares the timings and builds its own table).
        """
        t0 = time.perf_counter()
        table = build_query_table(self.problem, self.feasible_modes)
        if isinstance(self.timings, dict):
            self.timings["query_table"] = time.perf_counter() - t0
        return table

    @property
    def solver(self) -> str:
        """The LP back-end of the analysis (``settings.lp``)."""
        return self.settings.lp

    def to_dict(self, inactive_contacts: Sequence[str] = ()) -> dict[str, Any]:
        """The analysis as JSON values (the ``frc analyze --json`` document, without solutions).

        Args:
            inactive_contacts: the scene's contacts that do not touch (reported, not modelled).
        """
        problem = self.problem
        e = self.enumeration
        modes = [{
            "mode": m.mode,
            "feasible": m.feasible,
            "full_dimensional": m.full_dimensional,
            "ambiguity_dim": m.ambiguity_dim,
            "ambiguous_outputs": m.ambiguous_outputs,
            "halfspaces": m.halfspaces,
            "rank_case": m.response.case,
            "rank": m.response.rank,
            "consistency_constraints": int(m.response.E.shape[0]),
            "chebyshev_radius": m.chebyshev_radius,
            "inputs_full_dimensional": m.inputs_full_dimensional,
            "input_halfspaces": 0 if m.input_domain is None else int(m.input_domain.A.shape[0]),
            "overlaps": list(self.overlapping(m.mode)),
            "pruned": m.pruned,
        } for m in self.modes]
        return add_scene_modes(to_jsonable({
            "coordinates": list(problem.coordinates),
            "contacts": list(problem.contacts),
            "inactive_contacts": list(inactive_contacts),
            "inputs": list(problem.inputs),
            "input_units": dict(zip(problem.inputs, problem.input_units, strict=True)) if problem.input_units
            else {},
            **({"drives": dict(problem.drives)} if problem.drives else {}),
            **({"springs": dict(problem.springs)} if problem.springs else {}),
            "modes": modes,
            "overlaps": [list(o.modes) for o in self.overlaps],
            "enumeration": {
                "total": e.total, "pruned_velocity": e.pruned_velocity, "after_velocity": e.after_velocity,
                "partial_checks": e.partial_checks, "evaluated": e.evaluated, "feasible": e.feasible,
                "pruned_freedom": e.pruned_freedom, "pruned_infeasible": e.pruned_infeasible,
            },
            "timings": dict(self.timings),
            "tolerances": dict(self.tolerances),
        }), problem.scene_contacts or (*problem.contacts, *inactive_contacts))

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
        raise InputError(self._unevaluated(name))

    def _unevaluated(self, name: str) -> str:
        """The message for a mode :meth:`mode` does not hold: the letters it takes, the modes it has."""
        problem = self.problem
        touching = ", ".join(problem.contacts) or "none"
        scene = problem.scene_contacts
        if (isinstance(name, str) and scene and len(name) == len(scene) != problem.k
                and all(letter == "S" for contact, letter in zip(scene, name, strict=True)
                        if contact not in problem.contacts)):
            own = "".join(name[scene.index(contact)] for contact in problem.contacts)
            return (f"mode {name!r} has one letter per scene contact ({', '.join(scene)}); mode() takes "
                    f"one per touching contact ({touching}): {own!r}")
        feasible = self.feasible_modes
        shown = [m.named if m.named.startswith(f"{m.mode} ") else f"{m.mode!r} = {m.named}"
                 for m in feasible[:MODES_LISTED]]
        more = f"; and {len(feasible) - MODES_LISTED} more" if len(feasible) > MODES_LISTED else ""
        return (f"mode {name!r} was not evaluated (mode() takes one letter S, L, R, F per touching contact: "
                f"{touching}; the contacts' velocities or a partial mode's test pruned the others); "
                f"{len(self.modes)} evaluated, {len(feasible)} feasible: {'; '.join(shown) or 'none'}{more}")

    def overlapping(self, name: str) -> tuple[str, ...]:
        """The modes whose T_c interior meets that of ``name``."""
        out = []
        for o in self.overlaps:
            if name in o.modes:
                out.append(o.modes[1] if o.modes[0] == name else o.modes[0])
        return tuple(out)

    def unambiguous_set(self, name: str) -> tuple[poly.Polytope, ...]:
        """T_c of mode ``name`` minus every other mode's T_j, as closed convex pieces.

        Lower-dimensional T_j remove nothing here (they have no volume): see
        :meth:`lower_dimensional_modes` for the inputs where such a mode also holds.
        """
        mode = self.mode(name)
        if not mode.inputs_full_dimensional:
            return ()
        others = [self.mode(other).feasible_input_domain for other in self.overlapping(name)]
        return tuple(poly.set_difference(mode.feasible_input_domain, others, settings=self.settings))

    def lower_dimensional_modes(self) -> tuple[ModeAnalysis, ...]:
        """Feasible modes whose T_c has no interior (e.g. consistency conditions E u = e)."""
        return tuple(m for m in self.feasible_modes if not m.inputs_full_dimensional)


# ---------------------------------------------------------------------------- domain assembly
def domain_polytope(
    problem: ContactProblem, system: ModeSystem, response: AffineSolution
) -> tuple[poly.Polytope, np.ndarray]:
    """D_c over z = (u, w) after substituting the mode's response, and its motion-row mask."""
    H, h, A_eq, b_eq, motion = domain_rows(system, response, problem.input_bound_rows())
    return poly.Polytope(H, h, A_eq, b_eq), motion


def domain_rows(system: ModeSystem, response: AffineSolution, bounds: tuple[np.ndarray, np.ndarray]
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The arrays of :func:`domain_polytope` (``H, h, A_eq, b_eq, motion``), not yet a polytope.

    ``bounds``: the problem's input limits ``(C, d)`` (:meth:`ContactProblem.input_bound_rows`).
    """
    C, d = bounds
    m, p = C.shape[1], response.ambiguity_dim
    G = system.G
    rows = G.shape[0]
    H = np.zeros((rows + C.shape[0], m + p))
    H[:rows, :m] = G @ response.X_u
    H[:rows, m:] = G @ response.X_w
    H[rows:, :m] = C
    h = np.concatenate([system.g - G @ response.x_0, d])
    motion = np.zeros(h.size, dtype=bool)
    motion[:rows] = system.motion
    # explicit row counts: with no input and no ambiguity (m + p = 0) the domain lives in R^0
    A_eq = np.zeros((response.e.size, m + p))
    A_eq[:, :m] = response.E
    return H, h, A_eq, response.e.copy(), motion


@dataclass(frozen=True)
class MotionMargin:
    """The answer of :func:`motion_margin`.

    Attributes:
        verdict: ``"infeasible"`` (the set is empty), ``"freedom"`` (no point satisfies every
            motion row strictly) or ``"ok"``.
        point: a point of the set with the largest motion margin (None when infeasible).
        margin: that margin t* [units of z] (None when infeasible).
    """

    verdict: MarginVerdict
    point: np.ndarray | None
    margin: float | None


def motion_margin(
    H: np.ndarray,
    h: np.ndarray,
    motion: np.ndarray,
    A_eq: np.ndarray,
    b_eq: np.ndarray,
    *,
    solver: str | None = None,
    settings: SolverSettings | None = None,
) -> MotionMargin:
    """Test ``{z: H z <= h, A_eq z = b_eq}`` and the strictness of its motion rows.

    One LP: maximise ``t`` in [0, 1] subject to the rows, the motion rows tightened by ``t`` times
    their norm (so t is a distance [units of z]). The verdict is ``"infeasible"`` if the set is
    empty, ``"freedom"`` if no point satisfies every motion row strictly (t* <=
    :data:`DOMAIN_TOLERANCE`; a motion row with zero coefficients counts by its constant), else
    ``"ok"``, with a point whose motion margin is t*.
    """
    d = H.shape[1]
    norms, zero = _row_norms(H)
    constant = motion & zero
    degenerate_constant = False
    if np.count_nonzero(constant):
        fixed = h[constant]
        if np.count_nonzero(fixed < -DOMAIN_TOLERANCE):
            return MotionMargin("infeasible", None, None)
        degenerate_constant = bool(np.count_nonzero(fixed <= DOMAIN_TOLERANCE))
    moving = motion ^ constant  # the motion rows with coefficients (constant is within motion)
    A_ub = np.empty((H.shape[0], d + 1))
    A_ub[:, :d] = H
    np.multiply(norms, moving, out=A_ub[:, d])  # the norm on a moving row, 0 elsewhere
    return _margin_lp(A_ub, h, A_eq, b_eq, degenerate_constant, bool(np.count_nonzero(moving)),
                      settings_from(solver, settings))


def _margin_lp(A_ub: np.ndarray, h: np.ndarray, A_eq: np.ndarray | None, b_eq: np.ndarray | None,
               degenerate_constant: bool, moving: bool, settings: SolverSettings,
               lps: InequalityLPs | None = None) -> MotionMargin:
    """:func:`motion_margin`'s LP over ``(z, t)`` with its rows ``A_ub`` (the last column t's) built.

    ``degenerate_constant``: a constant motion row is not strict; ``moving``: some motion row has
    coefficients; ``lps``: the lean path of a run of such LPs (:func:`~frcontrol.geometry.max_margin`).
    """
    d = A_ub.shape[1] - 1
    result = max_margin(A_ub, h, A_eq=A_eq, b_eq=b_eq, settings=settings, fallback=RETRY_ERRORS, lps=lps)
    if not result.found or result.x is None:
        return MotionMargin("infeasible", None, None)
    z, t = result.x[:d], float(result.x[-1])
    if degenerate_constant or (t <= DOMAIN_TOLERANCE and moving):
        return MotionMargin("freedom", z, t)
    return MotionMargin("ok", z, t)


def mode_margin(system: ModeSystem, response: AffineSolution, bounds: tuple[np.ndarray, np.ndarray], *,
                solver: str | None = None, settings: SolverSettings | None = None,
                kernel: Backend | None = None, lps: InequalityLPs | None = None) -> MotionMargin:
    """:func:`motion_margin` of the mode's domain (:func:`domain_rows`), its rows built in one call.

    By the kernel's ``mode_margin`` (:func:`frcontrol.kernel.backend`): with the compiled kernel
    the LP's rows come from ``frcontrol._kernel.margin_rows`` (the same sums in another order:
    equal to round-off, see tests/test_kernel.py); its NumPy twin builds them by
    :func:`domain_rows` and :func:`motion_margin`. ``kernel``: the backend when the caller has it;
    ``solver`` or ``settings``: the LP's back-end (:func:`~frcontrol.solvers.settings_from`);
    ``lps``: the lean LP path of a caller testing many modes (:func:`margin_lps`: made once, the
    same answers).
    """
    return (kernel or backend()).mode_margin(system, response, bounds, settings_from(solver, settings), lps)


def margin_lps(settings: SolverSettings, kernel: Backend | None = None) -> InequalityLPs:
    """The lean LP path of :func:`mode_margin` for a run of modes with these ``settings``, made once."""
    return InequalityLPs(settings=settings, fallback=RETRY_ERRORS, check=(kernel or backend()).lp_check)


def _mode_margin_numpy(system: ModeSystem, response: AffineSolution, bounds: tuple[np.ndarray, np.ndarray],
                       settings: SolverSettings, lps: InequalityLPs | None = None) -> MotionMargin:
    """:func:`mode_margin` in NumPy (the reference twin)."""
    H, h, A_eq, b_eq, motion = domain_rows(system, response, bounds)
    return motion_margin(H, h, motion, A_eq, b_eq, settings=settings)


def _mode_margin_compiled(system: ModeSystem, response: AffineSolution, bounds: tuple[np.ndarray, np.ndarray],
                          settings: SolverSettings, lps: InequalityLPs | None = None) -> MotionMargin:
    """:func:`mode_margin` with its rows by the compiled kernel's ``margin_rows``."""
    C, d = bounds
    X_u, X_w, e = response.X_u, response.X_w, response.e
    m, p = X_u.shape[1], X_w.shape[1]
    rows = system.G.shape[0] + C.shape[0]
    A_ub, h = np.empty((rows, m + p + 1)), np.empty(rows)
    flags = compiled.margin_rows(  # type: ignore[union-attr]
        system.G, X_u if X_u.flags.c_contiguous else np.ascontiguousarray(X_u),
        X_w if X_w.flags.c_contiguous else np.ascontiguousarray(X_w), response.x_0, system.g, C, d,
        system.motion, A_ub, h, ZERO_ROW_TOLERANCE, DOMAIN_TOLERANCE)
    if flags < 0:
        return MotionMargin("infeasible", None, None)
    if e.shape[0]:
        A_eq = np.zeros((e.shape[0], m + p))
        A_eq[:, :m] = response.E
        return _margin_lp(A_ub, h, A_eq, e, bool(flags & 1), bool(flags & 2), settings, lps)
    return _motion_lp_compiled(A_ub, h, bool(flags & 1), bool(flags & 2), settings, lps)


twin("mode_margin", numpy=_mode_margin_numpy, compiled=_mode_margin_compiled)


_LP_BELOW, _LP_EMPTY = 2, 3
"""``margin_lp``'s codes: the margin is below the band, the set is empty (0: undecided, 1: above)."""


def _default_settings(settings: SolverSettings) -> bool:
    """Whether ``settings`` are the default ones: the kernel's motion LP may stand in for the door's."""
    return settings is DEFAULT_SETTINGS or settings == DEFAULT_SETTINGS


def _kernel_margin(A_ub: np.ndarray, h: np.ndarray) -> tuple[int, np.ndarray]:
    """The kernel's checked motion LP (``frcontrol._kernel.margin_lp``) on built rows: its code and point."""
    x = np.empty(A_ub.shape[1])
    code = compiled.margin_lp(  # type: ignore[union-attr]
        A_ub, h, x, CHEBYSHEV_RADIUS_CAP, DOMAIN_TOLERANCE, MARGIN_LP_BAND, MARGIN_LP_RESIDUAL,
        MARGIN_LP_EMPTY, MARGIN_LP_PIVOT, MARGIN_LP_OPTIMALITY, ZERO_ROW_TOLERANCE)
    return code, x


def _motion_lp_compiled(A_ub: np.ndarray, h: np.ndarray, degenerate_constant: bool, moving: bool,
                        settings: SolverSettings, lps: InequalityLPs | None) -> MotionMargin:
    """:func:`_margin_lp` without equalities by the kernel's motion LP, the door's where it leaves it open.

    With a solver named (settings other than the default ones) the door decides every LP.
    """
    if _default_settings(settings):
        code, x = _kernel_margin(A_ub, h)
        if code == _LP_EMPTY:
            return MotionMargin("infeasible", None, None)
        if code:
            verdict: MarginVerdict = ("freedom" if degenerate_constant or (code == _LP_BELOW and moving)
                                      else "ok")
            return MotionMargin(verdict, x[:-1], float(x[-1]))
    return _margin_lp(A_ub, h, None, None, degenerate_constant, moving, settings, lps)


LETTER_ROW_GUESS = 1.5e-8
"""[-] :func:`letter_rows_kept` guesses a letter row independent of the rows kept above it when its
part outside their row space (its product with their null space, unit columns) exceeds this times
its norm (about the square root of the machine epsilon). Only a guess: :func:`certified_by_rows`
checks the rows it picks, and a wrong guess costs the SVD, never a wrong answer."""


def letter_rows_kept(rows: np.ndarray, null: np.ndarray) -> np.ndarray:
    """Which of each child's two letter rows ``rows`` (count, 2, nx) a certificate should keep.

    ``null`` (nx, p) spans the null space of the rows kept above (the prefix's). A row is kept when
    it moves that null space (:data:`LETTER_ROW_GUESS`); the second only beyond what the first
    already takes. Returns a (count, 2) mask.
    """
    norms = np.sqrt((null * null).sum(axis=0))
    T = np.matmul(rows, null / np.where(norms > 0.0, norms, 1.0))  # (count, 2, p)
    size = np.sqrt((rows * rows).sum(axis=2))
    first, second = T[:, 0], T[:, 1]
    first_norm2 = (first * first).sum(axis=1)
    kept = np.empty((rows.shape[0], 2), dtype=bool)
    kept[:, 0] = np.sqrt(first_norm2) > LETTER_ROW_GUESS * size[:, 0]
    along = np.where(kept[:, 0], (first * second).sum(axis=1) / np.where(kept[:, 0], first_norm2, 1.0), 0.0)
    rest = second - along[:, None] * first
    kept[:, 1] = np.sqrt((rest * rest).sum(axis=1)) > LETTER_ROW_GUESS * size[:, 1]
    return kept


def _root_null_space(problem: ContactProblem) -> np.ndarray:
    """A basis of the null space of the dynamics' rows (every mode's first ``n`` rows): the tree's root."""
    D = problem.dynamics
    if D.shape[0] == 0:
        return np.eye(D.shape[1])
    _, s, Vt = np.linalg.svd(D)
    rank = int(np.count_nonzero(s > RANK_TOLERANCE * s[0])) if s.size and s[0] > 0.0 else 0
    return np.ascontiguousarray(Vt[rank:].T)


def _subtree_size(allowed: Sequence[str], depth: int) -> int:
    size = 1
    for letters in allowed[depth:]:
        size *= len(letters)
    return size


# ---------------------------------------------------------------------------- analyze
def analyze(
    scene: Scene | ContactProblem,
    *,
    solver: str | None = None,
    settings: SolverSettings | None = None,
    prune_partial: bool = True,
    ambiguity: bool = True,
    rank_tolerance: float = RANK_TOLERANCE,
    progress: Callable[[str], None] | None = None,
    stage: Callable[[str], None] | None = None,
) -> DynamicResponse:
    """The dynamic response of a scene at its state.

    Args:
        scene: a loaded scene (its active contacts at its state) or a prepared problem.
        solver: the LP back-end for every domain computation (a name; or ``settings``).
        settings: the solver settings (:class:`~frcontrol.solvers.SolverSettings`).
        prune_partial: grow modes contact by contact and drop infeasible partial assignments
            (False: evaluate every mode velocity pruning leaves, the naive reference).
        ambiguity: also compute the overlaps and unambiguous sets.
        rank_tolerance: relative singular-value threshold of the rank decisions.
        progress: called with each mode's name as its evaluation starts (for progress displays), in
            the scene's letters (:meth:`~frcontrol.modes.ContactProblem.scene_mode`), as outputs print it.
        stage: called with a description of each stage after the modes' as it starts (the
            overlaps: ``"finding the overlaps of N modes"``), for progress displays.

    Raises:
        ImpactState: a contact moves into its surface.
        IllConditioned: a mode's system is too ill-conditioned to decide its rank.
    """
    settings = settings_from(solver, settings)
    timings = {"model": 0.0, "response": 0.0, "feasibility": 0.0, "domain": 0.0, "projection": 0.0,
               "ambiguity": 0.0}
    start = time.perf_counter()
    problem = scene if isinstance(scene, ContactProblem) else ContactProblem.from_scene(scene)
    problem.check_numbers()
    timings["model"] = time.perf_counter() - start
    enumerator = _ModeEnumerator(problem, settings, rank_tolerance, prune_partial, progress, timings)
    enumerator.grow("")
    counts, analyses = enumerator.counts, enumerator.analyses
    feasible = [a for a in analyses if a.feasible]
    enumeration = Enumeration(
        total=4 ** problem.k, after_velocity=_subtree_size(enumerator.allowed, 0),
        evaluated=counts["evaluated"],
        feasible=len(feasible), pruned_freedom=counts["freedom"], pruned_infeasible=counts["infeasible"],
        partial_checks=counts["partial"],
    )
    overlaps: list[Overlap] = []
    if ambiguity:
        t0 = time.perf_counter()
        if stage is not None:
            stage(f"finding the overlaps of {sum(a.inputs_full_dimensional for a in feasible)} modes")
        overlaps = _overlaps(feasible, settings)
        timings["ambiguity"] = time.perf_counter() - t0
    timings["query_table"] = 0.0  # built on the first query (DynamicResponse.query)
    timings["total"] = time.perf_counter() - start
    return DynamicResponse(
        problem=problem, modes=tuple(analyses), enumeration=enumeration, overlaps=tuple(overlaps),
        timings=timings, settings=settings,
        tolerances={"rank": rank_tolerance, "domain": DOMAIN_TOLERANCE, "input_limit": INPUT_LIMIT_SLACK,
                    "velocity": problem.velocity_tolerance, "ill_conditioned_band": ILL_CONDITIONED_BAND,
                    "round_off_rank_drop": ROUND_OFF_RANK_DROP, "motion_lp_band": MARGIN_LP_BAND,
                    "motion_lp_residual": MARGIN_LP_RESIDUAL, "motion_lp_empty": MARGIN_LP_EMPTY,
                    "motion_lp_pivot": MARGIN_LP_PIVOT, "motion_lp_optimality": MARGIN_LP_OPTIMALITY},
    )


class _ModeEnumerator:
    """The tree of modes: letters contact by contact, partial modes pruned, full ones analysed."""

    def __init__(self, problem: ContactProblem, settings: SolverSettings, rank_tolerance: float,
                 prune_partial: bool, progress: Callable[[str], None] | None,
                 timings: dict[str, float]) -> None:
        self.problem, self.settings, self.rank_tolerance = problem, settings, rank_tolerance
        self.prune_partial, self.progress, self.timings = prune_partial, progress, timings
        self.allowed = problem.allowed_modes()
        self.bounds = problem.input_bound_rows()
        self.kernel = backend()  # read once for the whole tree
        self.lps = margin_lps(settings, self.kernel)  # the motion LPs' lean path, made once
        self.margin = self.kernel.mode_margin  # mode_margin on this kernel (settings given)
        self.prepared: dict[str, tuple[ModeSystem, AffineSolution | None]] = {}
        self.deficient: set[str] = set()  # tested modes whose equalities lack full row rank
        self.kept: dict[str, np.ndarray] = {}  # a certified mode's independent rows (certified_by_rows)
        self.null_spaces: dict[str, np.ndarray] = {}  # a tested partial mode's X_w, while it has kept rows
        self.root_null = _root_null_space(problem)
        # a partial mode's system, from its test until its children's are built from it
        self.parents: dict[str, ModeSystem] = {"": build_mode_system(problem, "")} if prune_partial else {}
        self.counts = {"freedom": 0, "infeasible": 0, "partial": 0, "evaluated": 0}
        self.analyses: list[ModeAnalysis] = []

    def response(self, system: ModeSystem) -> AffineSolution:
        """The mode's response by :func:`solve_affine` (the SVD and its rank rule)."""
        return mode_response(self.problem, system, self.rank_tolerance)

    def prepare(self, prefix: str, letters: str) -> None:
        """Build the systems of ``prefix``'s children and certify their responses together.

        :func:`certified_children` factorises the children at once. A child it does not certify
        (its rows dependent) is tried by :func:`certified_by_rows` on the rows the prefix's own
        certificate kept and its letter's rows (:meth:`_by_rows`). Below a mode without full row
        rank (so every child's rows are dependent too) only the second is tried. A child neither
        certifies gets the SVD: when it is tested, or, below such a mode, at once for all of them
        (:func:`solve_affine_stack`, the same answers as one by one).
        """
        t0 = time.perf_counter()
        children = [prefix + letter for letter in letters]
        parent = self.parents.pop(prefix, None)
        systems = (build_child_systems(self.problem, prefix, letters) if parent is None
                   else extend_child_systems(self.problem, parent, letters))
        A, B, c = systems.A, systems[0].B, systems.c  # the children's stacks, as built
        deficient = prefix in self.deficient
        responses: list[AffineSolution | None]
        partial = len(prefix) + 1 < self.problem.k  # the children's responses decide only their verdicts
        if deficient:  # every child's rows are dependent too
            responses = [None] * len(children)
        else:
            responses = certified_children(A, B, c, rank_tolerance=self.rank_tolerance, kernel=self.kernel)
            if partial:
                for child, response in zip(children, responses, strict=True):
                    if response is not None:
                        self.kept[child] = np.arange(A.shape[1])
        open_ = [i for i, response in enumerate(responses) if response is None]
        if open_:
            balance = needs_balancing(self.problem, children)
            self._by_rows(prefix, children, (A, B, c), balance, responses, keep=partial)
            open_ = [i for i in open_ if responses[i] is None]
            if deficient and open_:
                stacked = solve_affine_stack(A[open_], B, c[open_], rank_tolerance=self.rank_tolerance,
                                             balance=balance[open_])
                for i, response in zip(open_, stacked, strict=True):
                    responses[i] = response
        self.prepared.update(zip(children, zip(systems, responses, strict=True), strict=True))
        self.kept.pop(prefix, None)  # read by the children's certificates only
        self.null_spaces.pop(prefix, None)
        self.timings["response"] += time.perf_counter() - t0

    def _by_rows(self, prefix: str, children: list[str], stack: tuple[np.ndarray, np.ndarray, np.ndarray],
                 balance: np.ndarray, responses: list[AffineSolution | None], *, keep: bool) -> None:
        """Certify, in place, children without a response by the rows they keep (:func:`certified_by_rows`).

        The rows guessed: those the prefix's certificate kept, and each of the child's two letter
        rows that moves the prefix's null space (:func:`letter_rows_kept`); children with the
        same guess are certified together. A child that :func:`rebalance_undecided` might balance
        is left to the SVD. ``keep``: record the rows kept (for a partial child, whose own children's
        certificates start from them). A full mode certified here reports its certificate's response
        (:meth:`evaluate`).
        """
        open_ = [i for i, response in enumerate(responses) if response is None and not balance[i]]
        base, null = self.kept.get(prefix), self.null_spaces.get(prefix)
        if not prefix:  # the root: its rows are the dynamics', its null space the forces'
            base, null = np.arange(self.problem.n), self.root_null
        if base is None or null is None or not open_:
            return
        A, B, c = stack
        own = self.problem.n + 2 * len(prefix)  # the prefix's rows; the letter's follow
        letters = letter_rows_kept(A[open_, own:own + 2], null)
        groups: dict[int, list[int]] = {}
        for i, (first, second) in zip(open_, letters.tolist(), strict=True):
            groups.setdefault(first + 2 * second, []).append(i)
        for pattern, group in groups.items():
            rows = np.concatenate([base, [own + j for j in (0, 1) if pattern >> j & 1]]).astype(np.int64)
            found = certified_by_rows(A[group], B, c[group], np.tile(rows, (len(group), 1)),
                                      rank_tolerance=self.rank_tolerance, kernel=self.kernel)
            for i, response in zip(group, found, strict=True):
                if response is not None:
                    responses[i] = response
                    if keep:  # a partial child: its own children's certificates start from these rows
                        self.kept[children[i]] = rows

    def test(self, mode: str) -> tuple[MarginVerdict, ModeSystem, AffineSolution]:
        """Build and solve a (partial) mode: 'ok', 'freedom' or 'infeasible'.

        The system and a certified response come from :meth:`prepare` when it ran for the mode.
        """
        t0 = time.perf_counter()
        system, response = self.prepared.pop(mode, (None, None))
        if system is None:
            system = build_mode_system(self.problem, mode)
        if response is None:
            response = self.response(system)
        if response.rank < system.A.shape[0]:
            self.deficient.add(mode)
        if mode in self.kept and len(mode) < self.problem.k:  # its children's certificates start from it
            self.null_spaces[mode] = response.X_w
        t1 = time.perf_counter()
        self.timings["response"] += t1 - t0
        if not response.consistent:
            return "freedom", system, response
        verdict = self.margin(system, response, self.bounds, self.settings, self.lps).verdict
        self.timings["feasibility"] += time.perf_counter() - t1
        return verdict, system, response

    def evaluate(self, modes: list[str]) -> None:
        """Analyse full modes (siblings): responses, domains, and whether each T_c has an interior.

        Each is tested, then finished, in order. A mode certified by :meth:`prepare` reports its
        certificate's response (no SVD): its solutions are the SVD's to round-off and its ``w`` an
        orthonormal basis of the same null space (scaled coordinates), the QR's instead of the SVD's.
        """
        for mode in modes:
            self.counts["evaluated"] += 1
            if self.progress is not None:
                self.progress(self.problem.scene_mode(mode))
            self.finish(mode, *self.test(mode))

    def finish(self, mode: str, verdict: MarginVerdict, system: ModeSystem, response: AffineSolution) -> None:
        """Record a tested full mode: pruned, or feasible with its domain and whether T_c has an interior."""
        problem, settings, timings = self.problem, self.settings, self.timings
        outputs = ambiguous_outputs(response, problem.n)
        if verdict != "ok":
            self.counts[verdict] += 1
            self.analyses.append(ModeAnalysis(
                mode=mode, system=system, response=response, ambiguous_outputs=outputs,
                feasible=False, full_dimensional=False, chebyshev_radius=0.0, raw_domain=None,
                inputs_full_dimensional=False, pruned=verdict, m=problem.m, settings=settings,
                named=problem.named_mode(mode)))
            return
        t0 = time.perf_counter()
        # the domain in NumPy on either kernel (the test's rows decided only the verdict); a numerically
        # constant row (ZERO_ROW_TOLERANCE) is judged by its right side alone, as the test judged it: its
        # coefficients, round-off of one factorisation or another, are zero
        H, h, A_eq, b_eq, _ = domain_rows(system, response, self.bounds)
        H[_row_norms(H)[1]] = 0.0
        domain = poly.Polytope(H, h, A_eq, b_eq)
        ball = poly.chebyshev_ball(domain, settings=settings)
        full = bool(ball.found and ball.radius > DOMAIN_TOLERANCE and domain.A_eq.shape[0] == 0)
        timings["domain"] += time.perf_counter() - t0
        analysis = ModeAnalysis(
            mode=mode, system=system, response=response, ambiguous_outputs=outputs, feasible=True,
            full_dimensional=full, chebyshev_radius=float(ball.radius) if ball.found else 0.0,
            raw_domain=domain, inputs_full_dimensional=full, m=problem.m, settings=settings, raw_ball=ball,
            named=problem.named_mode(mode),
        )
        if not full and domain.A_eq.shape[0] == 0 and response.ambiguity_dim:
            # D_c flat in (u, w) without input equalities: its projection may still have volume
            t1 = time.perf_counter()
            input_ball = poly.chebyshev_ball(analysis.feasible_input_domain, settings=settings)
            timings["projection"] += time.perf_counter() - t1
            if input_ball.found and input_ball.radius > DOMAIN_TOLERANCE:  # (its domains derived anew)
                analysis = replace(analysis, inputs_full_dimensional=True)
        self.analyses.append(analysis)

    def grow(self, prefix: str) -> None:
        """Every mode below ``prefix``, depth first; a partial mode that fails prunes its subtree."""
        depth = len(prefix)
        if depth == self.problem.k:
            self.evaluate([prefix])
            return
        if self.prune_partial or depth + 1 == self.problem.k:  # the children are tested
            self.prepare(prefix, self.allowed[depth])
        if depth + 1 == self.problem.k:  # the children are full modes: evaluated together
            self.evaluate([prefix + letter for letter in self.allowed[depth]])
            return
        for letter in self.allowed[depth]:
            child = prefix + letter
            if self.prune_partial:
                self.counts["partial"] += 1
                verdict, system, _ = self.test(child)
                if verdict != "ok":
                    self.counts[verdict] += _subtree_size(self.allowed, depth + 1)
                    self.kept.pop(child, None)  # no children to certify
                    self.null_spaces.pop(child, None)
                    continue
                self.parents[child] = system
            self.grow(child)


InputRows = tuple[np.ndarray, np.ndarray, int]
"""A mode's rows (H, h) over (u, w) whose projection is T_c with an interior, and the count of w."""


def _input_rows(mode: ModeAnalysis) -> InputRows:
    """Rows (H, h) over (u, w) whose projection is T_c with an interior.

    D_c itself when it is full-dimensional, else T_c (projected) with no w.
    """
    if mode.full_dimensional and mode.raw_domain is not None:
        H, h, p = mode.raw_domain.A, mode.raw_domain.b, mode.ambiguity_dim
    else:
        T = mode.feasible_input_domain
        H, h, p = T.A, T.b, 0
    _, constant = _row_norms(H)  # rows 0 <= h (h >= 0 in a feasible mode) cut nothing
    return H[~constant], h[~constant], p


def _input_box(rows: InputRows, m: int, settings: SolverSettings) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of T_c per input: support LPs on D_c (its :func:`_input_rows`) in the input directions."""
    H, h, p = rows
    P = poly.Polytope(H, h)
    eye = np.eye(m + p)[:m]
    lps = poly.support_lps(settings)  # the lean path: the same answers
    upper = np.array([poly.support(P, eye[i], settings=settings, lps=lps) for i in range(m)])
    lower = -np.array([poly.support(P, -eye[i], settings=settings, lps=lps) for i in range(m)])
    return lower, upper


def _boxes_apart(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> bool:
    """Whether two input boxes (:func:`_input_box`) meet in less than ``2 DOMAIN_TOLERANCE`` of an input.

    A side where both bounds are the same infinity (a support LP found the box unbounded one way
    and the opposite way infeasible, which happens at large friction) tells nothing: that input
    does not set the boxes apart.
    """
    return bool(_boxes_apart_from(a[0], a[1], b[0][None, :], b[1][None, :])[0])


def _boxes_apart_from(lower: np.ndarray, upper: np.ndarray, lowers: np.ndarray, uppers: np.ndarray
                      ) -> np.ndarray:
    """:func:`_boxes_apart` of the box ``(lower, upper)`` and each of ``(lowers[j], uppers[j])``, at once."""
    lo = np.maximum(lower, lowers)
    hi = np.minimum(upper, uppers)
    width = np.full(lo.shape, np.inf)
    np.subtract(hi, lo, out=width, where=~(np.isinf(hi) & (hi == lo)))
    return np.any(width <= 2 * DOMAIN_TOLERANCE, axis=1)


RowNorms = tuple[np.ndarray, float, float]
"""A mode's row norms for :func:`interiors_meet`: the norms, the smallest and the largest (inf and 0
without rows)."""


def row_norms_of(H: np.ndarray) -> RowNorms:
    """:data:`RowNorms` of the rows ``H``."""
    norms = row_norms(H)
    if not norms.shape[0]:
        return norms, math.inf, 0.0
    return norms, float(np.minimum.reduce(norms)), float(np.maximum.reduce(norms))


def _any_constant(first: RowNorms, second: RowNorms) -> bool:
    """Whether two modes' rows, stacked, have a constant row (:func:`_row_norms`' rule)."""
    return min(first[1], second[1]) <= ZERO_ROW_TOLERANCE * max(1.0, first[2], second[2])


def interiors_meet(a: InputRows, b: InputRows, m: int, settings: SolverSettings,
                   lps: InequalityLPs | None = None, norms: tuple[RowNorms, RowNorms] | None = None
                   ) -> tuple[float, np.ndarray | None]:
    """Whether int(T_a) and int(T_b) meet: one LP in the lifted space (u, w_a, w_b).

    maximise t <= 1 s.t. every row of D_a and of D_b tightened by t times its norm. For
    full-dimensional D, int(T) is the projection of int(D), so t* > 0 iff the interiors meet; t* is
    a lower bound of the radius of a ball of inputs in both. Returns (t*, a common input) where
    t* > :data:`DOMAIN_TOLERANCE`, else ``(0.0, None)``. ``lps``: the lean LP path of a run of
    pairs (:func:`margin_lps`, the same answers); ``norms``: each mode's :data:`RowNorms`, when the
    caller has them.

    By the kernel's ``interiors_meet`` (:func:`frcontrol.kernel.backend`): the compiled kernel first
    asks its motion LP (``frcontrol._kernel.margin_lp``, default settings only) and answers
    ``(0.0, None)`` where that LP shows the interiors apart; every other pair, and every pair on
    NumPy, is the door's LP: the same overlaps, margins and common inputs on either kernel (on every
    shipped scene). Where the door's own answer is off (an ill-conditioned pair whose point misses
    a unit row by more than :data:`DOMAIN_TOLERANCE`: its residual test is relative), the two may
    differ, and the compiled kernel's "apart" is the one HiGHS finds.
    """
    return backend().interiors_meet(a, b, m, settings, lps, norms)


def _interiors_meet(a: InputRows, b: InputRows, m: int, settings: SolverSettings,
                    lps: InequalityLPs | None = None, norms: tuple[RowNorms, RowNorms] | None = None
                    ) -> tuple[float, np.ndarray | None]:
    """:func:`interiors_meet` by the door's LP (the reference twin; ``norms`` is not read)."""
    H, h, d = _pair_rows(a, b, m)
    lifted, constant = _row_norms(H[:, :d])
    if np.count_nonzero(constant):  # (rows the pair's scale makes constant: motion_margin's own rules)
        found = motion_margin(H[:, :d], h, np.ones(H.shape[0], dtype=bool), np.zeros((0, d)), np.zeros(0),
                              settings=settings)
    else:  # motion_margin's LP, every row a moving motion row: its rows built in place
        H[:, d] = lifted
        found = _margin_lp(H, h, None, None, False, H.shape[0] > 0, settings, lps)
    if found.verdict == "infeasible" or found.margin is None or found.point is None:
        return 0.0, None
    if not found.margin > DOMAIN_TOLERANCE:
        return 0.0, None
    return found.margin, found.point[:m]


def _pair_rows(a: InputRows, b: InputRows, m: int) -> tuple[np.ndarray, np.ndarray, int]:
    """The lifted LP's rows over (u, w_a, w_b, t) (t's column zero), their right sides, d = m + pa + pb."""
    Ha, ha, pa = a
    Hb, hb, pb = b
    ra, d = Ha.shape[0], m + pa + pb
    H = np.zeros((ra + Hb.shape[0], d + 1))  # the LP's rows, with t's column last
    H[:ra, :m + pa] = Ha
    H[ra:, :m] = Hb[:, :m]
    H[ra:, m + pa:d] = Hb[:, m:]
    return H, np.concatenate([ha, hb]), d


def _interiors_meet_compiled(a: InputRows, b: InputRows, m: int, settings: SolverSettings,
                             lps: InequalityLPs | None = None,
                             norms: tuple[RowNorms, RowNorms] | None = None
                             ) -> tuple[float, np.ndarray | None]:
    """:func:`interiors_meet`: the kernel's motion LP first, on the rows with each mode's norms.

    Only for pairs without a constant row (a norm at most :data:`ZERO_ROW_TOLERANCE` times the
    larger of 1 and the largest: the door judges those rows by :func:`motion_margin`'s rules), so
    "below" or "empty" there is the door's "no common interior" too.
    """
    if norms is not None and _default_settings(settings) and not _any_constant(*norms):
        H, h, d = _pair_rows(a, b, m)
        ra = a[0].shape[0]
        H[:ra, d], H[ra:, d] = norms[0][0], norms[1][0]
        if _kernel_margin(H, h)[0] in (_LP_BELOW, _LP_EMPTY):
            return 0.0, None
    return _interiors_meet(a, b, m, settings, lps, norms)


twin("interiors_meet", numpy=_interiors_meet, compiled=_interiors_meet_compiled)


BOX_FILTER_MODES_PER_INPUT = 16
"""Bounding boxes of the T_c filter the pairs of modes before their lifted LPs only when there are
more than this many candidate modes per input (``n - 1 > 16 m``). The boxes cost 2 m support LPs
per mode and save one LP per pair they prune, so they pay off when they prune more than
``4 m / (n - 1)`` of the pairs: at this threshold, a quarter. Measured: 13 % pruned on snake_climb
(64 modes, m = 8: the boxes cost 1024 LPs to save 256), 50 % on the snake lying on the ground
with 6 and 8 contacts (62 and 248 modes)."""


def _overlaps(feasible: Sequence[ModeAnalysis], settings: SolverSettings) -> list[Overlap]:
    """Pairs of full-dimensional T_c whose interiors intersect (one lifted LP per pair).

    With many modes (:data:`BOX_FILTER_MODES_PER_INPUT`), pairs whose bounding boxes do not meet
    are dropped first.
    """
    candidates = [a for a in feasible if a.inputs_full_dimensional]
    m = candidates[0].m if candidates else 0
    rows = [_input_rows(a) for a in candidates]
    boxes = ([_input_box(r, m, settings) for r in rows]
             if len(candidates) - 1 > BOX_FILTER_MODES_PER_INPUT * m else None)
    lower = None if boxes is None else np.array([box[0] for box in boxes]).reshape(len(candidates), m)
    upper = None if boxes is None else np.array([box[1] for box in boxes]).reshape(len(candidates), m)
    overlaps: list[Overlap] = []
    lps = margin_lps(settings)  # one lean LP path for every pair
    norms = [row_norms_of(r[0]) for r in rows]
    for i, a in enumerate(candidates):
        later: Sequence[int] = range(i + 1, len(candidates))
        if lower is not None and upper is not None:  # the pairs whose boxes meet, all at once
            later = (np.flatnonzero(~_boxes_apart_from(lower[i], upper[i], lower[i + 1:], upper[i + 1:]))
                     + i + 1).tolist()
        for j in later:
            margin, center = interiors_meet(rows[i], rows[j], m, settings, lps, (norms[i], norms[j]))
            if margin > DOMAIN_TOLERANCE and center is not None:
                overlaps.append(Overlap((a.mode, candidates[j].mode), float(margin), center))
    return overlaps


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
    ambiguous_outputs: AmbiguousOutputs
    w: np.ndarray
    equality_residual: float
    inequality_violation: float

    def to_dict(self, contacts: Sequence[str]) -> dict[str, Any]:
        """The solution as JSON values, its forces and accelerations by contact name.

        Args:
            contacts: the active contacts' names, in the order of the solution's rows.
        """
        return to_jsonable({
            "mode": self.mode,
            "dv": self.dv,
            "contacts": {
                name: {"lambda_n": self.lambda_n[i], "lambda_t": self.lambda_t[i],
                       "a_n": self.a_n[i], "a_t": self.a_t[i]}
                for i, name in enumerate(contacts)
            },
            "ambiguity_dim": self.ambiguity_dim,
            "ambiguous_outputs": self.ambiguous_outputs,
            "w": self.w,
            "equality_residual": self.equality_residual,
        })


def _input_vector(problem: ContactProblem, inputs: InputValues) -> np.ndarray:
    """The input vector of ``{name: value}`` (others 0) or a full vector, checked (:func:`input_vector`)."""
    return input_vector(problem.inputs, problem.lower, problem.upper, inputs)


def _slice_in_w(system: ModeSystem, response: AffineSolution, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mode's inequalities at fixed u as ``H_w w <= h_w``, rows normalised by their (u, w) norm."""
    G = system.G
    H_u = G @ response.X_u
    H_w = G @ response.X_w
    h = system.g - G @ response.x_0 - H_u @ u
    norms, constant = _row_norms(np.hstack([H_u, H_w]))
    norms[constant] = 1.0
    H_w = H_w / norms[:, None]
    H_w[constant] = 0.0
    return H_w, h / norms


def _admissible_w(
    system: ModeSystem, response: AffineSolution, u: np.ndarray, settings: SolverSettings,
    closed_form: bool = True,
) -> np.ndarray | None:
    """A representative w with (u, w) in the mode's domain, moving as the mode says; else None.

    See :func:`_admissible_in_w`.
    """
    if not response.consistent:
        return None
    if response.E.shape[0] and np.max(np.abs(response.E @ u - response.e)) > DOMAIN_TOLERANCE:
        return None
    H_w, h_w = _slice_in_w(system, response, u)
    return _admissible_in_w(H_w, h_w, system.motion, settings, closed_form)


def _admissible_in_w(H_w: np.ndarray, h_w: np.ndarray, motion: np.ndarray, settings: SolverSettings,
                     closed_form: bool = True) -> np.ndarray | None:
    """A representative w of ``{w: H_w w <= h_w}`` (rows normalised in (u, w)) moving as the mode says.

    Non-motion rows hold to :data:`DOMAIN_TOLERANCE`, motion rows strictly (:func:`motion_margin`).
    The representative is the Chebyshev centre of the admissible w (the most central internal
    forces), or the motion LP's point when the admissible set has no interior. With one ambiguity
    variable and ``closed_form``, both are decided on the interval of admissible w without an LP
    (:func:`frcontrol.mode_batch.interval_admissible`); with two, by the rule of
    :mod:`frcontrol.ambiguity_polygon` (the LPs' vertices): where the LPs' point is one of several
    (a capped radius, a thin set), the rule's nearest vertex to w = 0 is reported and the rule kept
    for the mode's rows, which then decide by it alone; the reference path sets it False.
    """
    p = H_w.shape[1]
    if p == 0:
        if np.any(h_w[~motion] < -DOMAIN_TOLERANCE) or np.any(h_w[motion] <= DOMAIN_TOLERANCE):
            return None
        return np.zeros(0)
    if p == 1 and closed_form:
        return interval_admissible(H_w, h_w, motion, DOMAIN_TOLERANCE, ZERO_ROW_TOLERANCE,
                                   poly.CHEBYSHEV_RADIUS_CAP)
    two = p == 2 and closed_form
    key = H_w.tobytes() + motion.tobytes() if two else b""
    rule = _POLYGON_RULES.get(key) if two else None
    if rule is not None:
        return rule.decide(h_w)
    found = motion_margin(H_w, h_w + np.where(motion, 0.0, DOMAIN_TOLERANCE), motion,
                          np.zeros((0, p)), np.zeros(0), settings=settings)
    if found.verdict != "ok":
        return None
    z = found.point
    ball = poly.chebyshev_ball(poly.Polytope(H_w, h_w + DOMAIN_TOLERANCE), settings=settings)
    unique = ball.found and DOMAIN_TOLERANCE < ball.radius and not ball.capped
    if two and not unique and (rule := polygon_rule(H_w, motion)) is not None:
        # the LPs' point is one of several: the rule's (built once per mode's rows, then reused)
        if len(_POLYGON_RULES) >= POLYGON_RULES_KEPT:
            _POLYGON_RULES.clear()
        _POLYGON_RULES[key] = rule
        return rule.decide(h_w)
    if ball.found and ball.radius > DOMAIN_TOLERANCE:
        return ball.center
    return z


POLYGON_RULES_KEPT = 256
"""[-] :func:`_admissible_in_w` keeps the closed-form rules of up to this many two-variable modes
(by their rows in w), built where the LPs' answer is one of several (a capped Chebyshev radius, a
thin set); past this many it starts afresh. A mode's rule is a few kB."""

_POLYGON_RULES: dict[bytes, PolygonRule] = {}
"""The rules kept (see :data:`POLYGON_RULES_KEPT`): a rule depends only on the rows, not on u."""


def polygon_rule(H_w: np.ndarray, motion: np.ndarray) -> PolygonRule | None:
    """The closed-form rule of :func:`_admissible_in_w` for two ambiguity variables, or None.

    :meth:`frcontrol.ambiguity_polygon.PolygonRule.build` with the engine's tolerances (None: the
    LPs decide).
    """
    return PolygonRule.build(H_w, motion, domain_tolerance=DOMAIN_TOLERANCE,
                             zero_row_tolerance=ZERO_ROW_TOLERANCE, radius_cap=poly.CHEBYSHEV_RADIUS_CAP)


def _solution(problem: ContactProblem, system: ModeSystem, response: AffineSolution, u: np.ndarray,
              w: np.ndarray) -> RigidSolution:
    x = response.X_u @ u + response.X_w @ w + response.x_0
    out = mode_outputs(problem, x)
    return RigidSolution(
        mode=system.mode, dv=out["dv"], lambda_n=out["lambda_n"], lambda_t=out["lambda_t"],
        a_n=out["a_n"], a_t=out["a_t"], ambiguity_dim=response.ambiguity_dim,
        ambiguous_outputs=ambiguous_outputs(response, problem.n), w=w,
        equality_residual=float(np.max(np.abs(system.A @ x - system.B @ u - system.c), initial=0.0)),
        inequality_violation=float(np.max(system.G @ x - system.g, initial=0.0)),
    )


SOLUTION_METHODS = ("auto", "batch", "reference")
"""How :func:`solutions_at` decides the modes: ``"batch"`` stacks every full mode and decides them
together (:mod:`frcontrol.mode_batch`; at most :data:`~frcontrol.mode_batch.BATCH_MAX_MODES`);
``"reference"`` grows modes contact by contact with an LP per (partial) mode; ``"auto"`` (the
default) takes the batch when the modes fit in it. On a finished analysis: ``"auto"`` locates the input
among the feasible modes' domains (:mod:`frcontrol.query`), ``"batch"`` decides the modes one at a
time by the same rules, ``"reference"`` with an LP per mode."""


@overload
def solutions_at(scene: Scene | ContactProblem | DynamicResponse,
                 inputs: Mapping[str, float] | Sequence[float], *, solver: str | None = ...,
                 settings: SolverSettings | None = ...,
                 rank_tolerance: float = ..., method: str = ...) -> list[RigidSolution]: ...


@overload
def solutions_at(scene: Scene | ContactProblem | DynamicResponse, inputs: np.ndarray, *,
                 solver: str | None = ..., settings: SolverSettings | None = ...,
                 rank_tolerance: float = ...,
                 method: str = ...) -> Any: ...  # a list for one input, a BatchSolutions for (N, m)


def solutions_at(
    scene: Scene | ContactProblem | DynamicResponse,
    inputs: Mapping[str, float] | Sequence[float] | np.ndarray,
    *,
    solver: str | None = None,
    settings: SolverSettings | None = None,
    rank_tolerance: float = RANK_TOLERANCE,
    method: str = "auto",
) -> list[RigidSolution] | BatchSolutions:
    """Every rigid-body solution at one input: all modes whose domain holds it.

    Each solution is reported once, under the mode that describes its motion (see
    :func:`analyze` on degenerate modes). On a finished analysis, with no solver or settings given
    and a plain input (:func:`frcontrol.query.plain_input`), one call of the kernel answers
    (``query_solutions``): the same answer, in about a microsecond.

    Args:
        scene: a scene (at its state), a prepared problem, or a finished analysis (only its
            feasible modes are tested).
        inputs: ``{name: value}`` (names not given are 0) or the full input vector; or an (N, m)
            array of N input vectors: then the answer is one :class:`~frcontrol.query.BatchSolutions`
            (:func:`solutions_at_batch`; a scene is analysed first, without overlaps).
        solver: the LP back-end (for modes with two or more ambiguity variables).
        settings: the solver settings (instead of ``solver``).
        rank_tolerance: relative singular-value threshold of the rank decisions.
        method: one of :data:`SOLUTION_METHODS`. Every method gives the same modes, the same
            accelerations and the same forces wherever they are unique. Where they are not (a
            mode with ambiguity variables w), each reports a Chebyshev centre of the admissible
            w; the ball's radius is capped at ``CHEBYSHEV_RADIUS_CAP``, so on a set wider than
            twice the cap any point that far inside is one: the batch reports the midpoint of a
            one-variable interval, the LPs one vertex of those centres.

    Raises:
        CoordinateNotFound / InputError: unknown input names, wrong length, NaN, outside limits,
            an unknown method.
        ImpactState: a contact moves into its surface.
        IllConditioned: a mode's rank cannot be decided.
    """
    if method == "auto" and solver is None and settings is None:  # one call; None: the general path answers
        if isinstance(scene, DynamicResponse):
            found = backend().query_solutions(scene.query, inputs)
            if found is not None:
                return found
        elif rank_tolerance == RANK_TOLERANCE:
            found = (backend().scratch_solutions(scene, inputs) if isinstance(scene, Scene)
                     else backend().problem_solutions(scene, inputs))
            if found is not None:
                return found
    if method not in SOLUTION_METHODS:
        raise InputError(f"unknown solution method {method!r}; valid: {', '.join(SOLUTION_METHODS)}")
    settings = settings_from(solver, settings)
    if not isinstance(inputs, Mapping) and _is_batch(inputs):
        analysis = scene if isinstance(scene, DynamicResponse) else analyze(
            scene, settings=settings, ambiguity=False, rank_tolerance=rank_tolerance)
        return solutions_at_batch(analysis, inputs, settings=settings)
    closed_form = method != "reference"
    if isinstance(scene, DynamicResponse):
        problem = scene.problem
        u = _input_vector(problem, inputs)
        if method == "auto":
            return _located_solutions(scene, u, settings)
        listed = []
        for mode in scene.feasible_modes:
            w = _admissible_w(mode.system, mode.response, u, settings, closed_form)
            if w is not None:
                listed.append(_solution(problem, mode.system, mode.response, u, w))
        return listed
    problem = scene if isinstance(scene, ContactProblem) else ContactProblem.from_scene(scene)
    problem.check_numbers()
    u = _input_vector(problem, inputs)
    if method != "reference":
        allowed = problem.allowed_modes()
        if math.prod(len(letters) for letters in allowed) <= BATCH_MAX_MODES:
            found = _batch_solutions(problem, u, settings, rank_tolerance, allowed)
            if found is not None:
                return found
    return _tree_solutions(problem, u, settings, rank_tolerance, closed_form)


def build_query_table(problem: ContactProblem, feasible: Sequence[ModeAnalysis]) -> QueryTable:
    """The feasible modes stacked for point location (:mod:`frcontrol.query`).

    :attr:`DynamicResponse.query` builds it on an analysis's first query (ten to hundreds of
    queries' cost; ``timings`` then reports it as ``query_table``).
    """
    modes = [QueryMode(m.mode, m.system, m.response, m.ambiguous_outputs) for m in feasible]
    return QueryTable(problem, modes, zero_row_tolerance=ZERO_ROW_TOLERANCE,
                      radius_cap=poly.CHEBYSHEV_RADIUS_CAP, solution_type=RigidSolution,
                      input_slack=INPUT_LIMIT_SLACK, tolerance=DOMAIN_TOLERANCE)


def query_table(analysis: DynamicResponse) -> QueryTable:
    """The analysis's feasible modes stacked for point location (:attr:`DynamicResponse.query`)."""
    return analysis.query


def _is_batch(inputs: Mapping[str, float] | Sequence[float] | np.ndarray) -> bool:
    """Whether :func:`solutions_at`'s ``inputs`` are an (N, m) batch (``np.ndim(inputs) == 2``).

    Without NumPy's conversion of a list to an array where the first entry decides (0.8 us, a
    tenth of a query on an analysis).
    """
    if isinstance(inputs, Mapping):
        return False
    if isinstance(inputs, np.ndarray):
        return inputs.ndim == 2
    if isinstance(inputs, (list, tuple)) and inputs and isinstance(inputs[0], (int, float, np.number)):
        return False  # a vector of numbers
    return bool(np.ndim(inputs) == 2)


def _located_solutions(analysis: DynamicResponse, u: np.ndarray, settings: SolverSettings
                       ) -> list[RigidSolution]:
    """:func:`solutions_at` on an analysis: point location in its :func:`query_table`."""
    table = query_table(analysis)

    def decide_w(H: np.ndarray, h: np.ndarray, motion: np.ndarray) -> np.ndarray | None:
        return _admissible_in_w(H, h, motion, settings)

    return table.solutions(table.point(u, decide_w))


_SCRATCH_PLANS: weakref.WeakKeyDictionary[Scene, Any] = weakref.WeakKeyDictionary()
"""Each scene's compiled ``scratch_plan`` (None: the general path answers), made on its first query."""

_NO_PLAN = object()
"""A scene or problem without a plan yet (:data:`_SCRATCH_PLANS`, ``ContactProblem.kernel_cache``)."""


def _scratch_plan(scene: Scene) -> Any:
    """The compiled kernel's ``scratch_plan`` of ``scene``, or None for a scene the general path answers.

    The plan holds what the one-call query reads that does not change with the state. None: joint
    springs, elastic drives, or the state assembled in NumPy.
    """
    robot, indices, inputs = scene.robot, scene.active_indices, scene.inputs
    held = robot.kernel_state_plan(indices)
    if held is None or any(drive.elastic for drive in scene.drives.values()):
        return None
    return compiled.scratch_plan(  # type: ignore[union-attr]  # only on the compiled path
        *held, np.ascontiguousarray(inputs.selection_transpose(robot.nv)),
        np.array([scene.contacts[i].mu for i in indices], dtype=float),
        np.ascontiguousarray(inputs.lower, dtype=float), np.ascontiguousarray(inputs.upper, dtype=float),
        RigidSolution, np.empty, tuple(inputs.coordinates), *_plan_numbers(VELOCITY_TOLERANCE))


def _plan_numbers(velocity_tolerance: float) -> tuple[Any, ...]:
    """The last arguments of the compiled ``scratch_plan``.

    numpy.float64, the ambiguous outputs' names (as ``rank_modes`` codes them), and the tolerances
    and constants of the batch path it reproduces (:mod:`frcontrol.mode_batch`,
    :func:`frcontrol.response.certified_by_rows`).
    """
    return (np.float64, AMBIGUOUS_OUTPUT_CODES, INPUT_LIMIT_SLACK, velocity_tolerance, CERTIFIED_MARGIN,
            max(RANK_TOLERANCE, ILL_CONDITIONED_BAND), DOMAIN_TOLERANCE, ZERO_ROW_TOLERANCE, BATCH_MAX_MODES,
            RANK_TOLERANCE, ROUND_OFF_RANK_DROP, BY_ROWS_VOID_FACTOR, BY_ROWS_EXACT_FACTOR,
            BALANCING_FRICTION, OUTPUT_TOLERANCE, CHEBYSHEV_RADIUS_CAP, CONSISTENCY_TOLERANCE,
            VERTEX_TOLERANCE, SINGULAR_DETERMINANT, POLYGON_MAX_ROWS, CAPPED_FRACTION, LP_NEAR_OPTIMAL)


def _scratch_solutions_compiled(scene: Scene, inputs: Any) -> list[RigidSolution] | None:
    """:func:`solutions_at` on a scene in one call of the compiled kernel (``scratch_solutions``).

    After Pinocchio's pass at the scene's state, the kernel assembles the state, prunes the letters
    by velocity and decides every full mode as the batch path does (:mod:`frcontrol.mode_batch`):
    a mode its LU certifies, to the bit (the contact accelerations ``J dv + drift`` summed in index
    order: to round-off); a rank-deficient mode with up to two ambiguity variables certified by its
    rows and its left null space (:func:`frcontrol.response.certified_by_rows`, on rows the kernel
    picks, its consistency conditions included), two variables decided by
    :class:`frcontrol.ambiguity_polygon.PolygonRule`'s vertices: x to round-off, w up to an
    orthogonal map (so, within round-off of a domain's facet, a mode may be decided otherwise, as
    between the batch and reference paths). None where the general path answers: an input that is
    not plain (:func:`frcontrol.query.plain_input`'s rule), an impact, more than ``BATCH_MAX_MODES``
    modes, a scene :func:`_scratch_plan` declines, a two-variable mode whose engine answer is an
    LP's point among several (at this input), or a mode neither certifies. The last depends on the
    state alone (the modes' ``A``), not on the input: the kernel says so (False) and the scene's
    later queries go the general way at once.
    """
    plan = _SCRATCH_PLANS.get(scene, _NO_PLAN)
    if plan is _NO_PLAN:
        plan = _SCRATCH_PLANS[scene] = _scratch_plan(scene)
    if plan is None:
        return None
    found = compiled.scratch_solutions(  # type: ignore[union-attr]
        plan, scene.robot.pinocchio_pass(scene.q, scene.v), inputs)
    if found is False:
        _SCRATCH_PLANS[scene] = None
        return None
    return found


def _problem_solutions_compiled(problem: ContactProblem, inputs: Any) -> list[RigidSolution] | None:
    """:func:`solutions_at` on a contact problem in one call of the compiled kernel (``problem_solutions``).

    :func:`_scratch_solutions_compiled` from the problem's arrays, its plan kept in
    :attr:`~frcontrol.modes.ContactProblem.kernel_cache`. None where the general path answers, also
    for arrays the kernel does not take (not float64, or of other shapes: that path says why).
    """
    cache = problem.kernel_cache
    plan = cache.get("one_call", _NO_PLAN)
    if plan is _NO_PLAN:  # the family's plan for these coefficients (ContactProblem.plans_by_friction)
        plans, key = problem.plans_by_friction, np.asarray(problem.mu, dtype=float).tobytes()
        plan = plans.get(key, _NO_PLAN)
        if plan is _NO_PLAN:
            if len(plans) >= FRICTION_PLANS:
                plans.clear()
            plan = plans[key] = _problem_plan(problem)
        cache["one_call"] = plan
    if plan is None:
        return None
    try:
        found = compiled.problem_solutions(  # type: ignore[union-attr]  # only on the compiled path
            plan, problem.mass_matrix, problem.jacobian_normal, problem.jacobian_tangent,
            problem.drift_normal, problem.drift_tangent, problem.normal_velocities,
            problem.tangential_velocities, problem.bias, inputs)
    except KernelError:  # arrays of another type or shape: the general path reads (or refuses) them
        found = False
    if found is False:
        cache["one_call"] = None
        return None
    return found


def _problem_plan(problem: ContactProblem) -> Any:
    """The compiled kernel's ``scratch_plan`` of a contact problem: without a robot (it has the state).

    None where its numbers are not arrays the kernel takes.
    """
    try:
        return compiled.scratch_plan(  # type: ignore[union-attr]
            None, None, None, None, None, np.ascontiguousarray(problem.input_map, dtype=float),
            np.ascontiguousarray(problem.mu, dtype=float), np.ascontiguousarray(problem.lower, dtype=float),
            np.ascontiguousarray(problem.upper, dtype=float), RigidSolution, np.empty, tuple(problem.inputs),
            *_plan_numbers(problem.velocity_tolerance))
    except (KernelError, ValueError, TypeError):  # shapes the kernel refuses: the general path says why
        return None


def _scratch_solutions_numpy(scene: Scene, inputs: Any) -> list[RigidSolution] | None:
    """The NumPy twin of ``scratch_solutions``: it declines (None).

    The general path, the reference the compiled call reproduces, then answers.
    """
    return None


def _problem_solutions_numpy(problem: ContactProblem, inputs: Any) -> list[RigidSolution] | None:
    """The NumPy twin of ``problem_solutions``: it declines (None), as :func:`_scratch_solutions_numpy`."""
    return None


twin("scratch_solutions", numpy=_scratch_solutions_numpy, compiled=_scratch_solutions_compiled)
twin("problem_solutions", numpy=_problem_solutions_numpy, compiled=_problem_solutions_compiled)


def solutions_at_batch(analysis: DynamicResponse, inputs: npt.ArrayLike, *,
                       solver: str | None = None, settings: SolverSettings | None = None) -> BatchSolutions:
    """Every rigid solution at each of N inputs on a finished analysis, as arrays.

    The same modes, accelerations, forces and representatives w as :func:`solutions_at` at each
    point (to round-off); ``solutions_at(analysis, U)`` with a 2-D ``U`` calls this.

    Args:
        analysis: a finished :func:`analyze`.
        inputs: an (N, m) array of full input vectors [N or N m].
        solver: the LP back-end (for modes with two or more ambiguity variables).
        settings: the solver settings (instead of ``solver``).

    Raises:
        InputError: not an (N, m) array, a NaN or infinite entry, an input outside its limits.
    """
    settings = settings_from(solver, settings)
    table = query_table(analysis)
    U = check_inputs(analysis.problem, inputs, INPUT_LIMIT_SLACK)
    return table.locate_batch(U, lambda H, h, motion: _admissible_in_w(H, h, motion, settings))


def _batch_solutions(problem: ContactProblem, u: np.ndarray, settings: SolverSettings, rank_tolerance: float,
                     allowed: tuple[str, ...] | None = None) -> list[RigidSolution] | None:
    """The batch path; None when a mode's rank is undecidable (the reference path then decides)."""
    batch = decide_modes(problem, u, lambda H, h, motion: _admissible_in_w(H, h, motion, settings),
                         rank_tolerance=rank_tolerance, domain_tolerance=DOMAIN_TOLERANCE,
                         zero_row_tolerance=ZERO_ROW_TOLERANCE, radius_cap=poly.CHEBYSHEV_RADIUS_CAP,
                         allowed=allowed)
    if batch.ill_conditioned:
        return None
    n, k = problem.n, problem.k
    found = []
    for sol in batch.solutions:
        x = sol.x
        dv = x[:n]
        found.append(RigidSolution(
            mode=sol.mode, dv=dv, lambda_n=x[n:n + k], lambda_t=x[n + k:],
            a_n=problem.jacobian_normal @ dv + problem.drift_normal,
            a_t=problem.jacobian_tangent @ dv + problem.drift_tangent,
            ambiguity_dim=sol.w.size, ambiguous_outputs=sol.ambiguous_outputs, w=sol.w,
            equality_residual=sol.equality_residual, inequality_violation=sol.inequality_violation))
    return found


def _tree_solutions(problem: ContactProblem, u: np.ndarray, settings: SolverSettings, rank_tolerance: float,
                    closed_form: bool) -> list[RigidSolution]:
    """The reference path: modes grown contact by contact, a partial mode pruning its subtree."""
    allowed = problem.allowed_modes()
    found: list[RigidSolution] = []

    def grow(prefix: str) -> None:
        depth = len(prefix)
        for letter in allowed[depth]:
            mode = prefix + letter
            system = build_mode_system(problem, mode)
            response = mode_response(problem, system, rank_tolerance)
            w = _admissible_w(system, response, u, settings, closed_form)
            if w is None:
                continue
            if depth + 1 < problem.k:
                grow(mode)
            else:
                found.append(_solution(problem, system, response, u, w))

    if problem.k == 0:
        system = build_mode_system(problem, "")
        response = solve_affine(system.A, system.B, system.c, rank_tolerance=rank_tolerance)
        w = _admissible_w(system, response, u, settings, closed_form)
        return [] if w is None else [_solution(problem, system, response, u, w)]
    grow("")
    return found


__all__ = [
    "MotionMargin",
    "analyze",
    "BOX_FILTER_MODES_PER_INPUT",
    "domain_polytope",
    "domain_rows",
    "DOMAIN_TOLERANCE",
    "DynamicResponse",
    "Enumeration",
    "ModeAnalysis",
    "interiors_meet",
    "mode_margin",
    "motion_margin",
    "Overlap",
    "RigidSolution",
    "MODES_LISTED",
    "SOLUTION_METHODS",
    "build_query_table",
    "query_table",
    "solutions_at",
    "solutions_at_batch",
    "ZERO_ROW_TOLERANCE",
]
