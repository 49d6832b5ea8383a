r"""The flip's pitch search: per piece of a candidate's unambiguous set, the best pitch acceleration.

:func:`branch_and_bound` explores the candidate modes by decreasing bound (:func:`candidate_bounds`,
one LP over the shrunk T_c), builds each one's margin pieces
(:func:`~frcontrol.planning.core.pieces.margin_pieces`), maximises the pitch acceleration on each
(:func:`maximise_pitch`: one LP, or the worst case over the mode's ambiguity variables at the piece's
vertices), rounds the optimum (:func:`round_inputs`) and verifies it (:func:`verify_piece`). The
maths is in :mod:`frcontrol.planning.flip`'s docstring.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .. import polytope as poly
from ..engine import DynamicResponse, ModeAnalysis, solutions_at
from ..geometry import vertices_from_halfspaces
from ..kernel import backend
from ..modes import VELOCITY_TOLERANCE, ContactProblem
from ..response import OUTPUT_TOLERANCE
from ..solvers import DEFAULT_SETTINGS, RETRY_ERRORS, DoorOptions, SolverSettings, solve_lp
from .core.pieces import margin_pieces, mode_allowed, shrunk_input_domain
from .core.tolerances import TORQUE_ROUNDING

__all__ = [
    "MAX_VERTEX_CANDIDATES",
    "PITCH_TOLERANCE",
    "FlipPiece",
    "FlipSettings",
    "PieceSearch",
    "branch_and_bound",
    "candidate_bounds",
    "maximise_pitch",
    "pitch_row",
    "round_inputs",
    "torque_text",
    "verify_piece",
    "worst_case_pitch",
]


@dataclass(frozen=True)
class FlipSettings:
    """How :func:`~frcontrol.planning.flip.plan_flip` searches, beyond its margin.

    Attributes:
        rounding: [N m] the torques are rounded to multiples of this, >= 0.
        min_pitch_acceleration: [rad/s^2] a plan must exceed this by more than
            :data:`PITCH_TOLERANCE` (default 0: it must pitch the body up); None accepts the best
            plan whatever its sign (re-planning mid-flip).
        velocity_tolerance: [m/s] contact velocities at most this count as zero (velocity pruning).
        exhaustive: build the pieces of every candidate (default: only of the candidates whose
            bound exceeds the best verified plan so far: the same plan, found faster).
        free: per contact name, the letters the plan also allows it
            (:func:`~frcontrol.planning.core.pieces.mode_allowed`, ``"S"``: a toe may separate);
            the unambiguity constraint and the verification accept those modes beside the planned
            one. Default: none (one rigid solution, planned).
        solvers: the solver settings of every LP (the analysis' when it is computed here).
    """

    rounding: float = TORQUE_ROUNDING
    min_pitch_acceleration: float | None = 0.0
    velocity_tolerance: float = VELOCITY_TOLERANCE
    exhaustive: bool = False
    free: Mapping[str, str] | None = None
    solvers: SolverSettings = DEFAULT_SETTINGS


@dataclass(frozen=True)
class PieceSearch:
    """What :func:`branch_and_bound` needs besides the analysis.

    Attributes:
        margin: [N m] the distance kept; rounding: [N m] the torques' quantum; exhaustive, free: as
        in :class:`FlipSettings`; settings: the solver settings.
    """

    margin: float
    rounding: float
    exhaustive: bool
    settings: SolverSettings
    free: Mapping[str, str] | None = None


PITCH_TOLERANCE = 1e-9
"""[rad/s^2] Relative agreement (times ``1 + |pitch|``) required between the planned pitch
acceleration and the one :func:`~frcontrol.engine.solutions_at` reports at the rounded torques."""


MAX_VERTEX_CANDIDATES = 200_000
"""Most row subsets tried to enumerate a piece's vertices in the worst-case (w-dependent) plan."""




@dataclass(frozen=True)
class FlipPiece:
    """One convex piece of a candidate's unambiguous set shrunk by the margin, and its optimum.

    Attributes:
        mode: the candidate mode.
        region: the piece, over the planned inputs (``FlipPlan.planned_inputs``).
        pitch_acceleration: [rad/s^2] the best (worst-case, if ``worst_case``) pitch acceleration
            on the piece, at the unrounded optimum; ``-inf`` if the LP failed.
        optimum: the unrounded optimum (None if the LP failed).
        worst_case: the pitch depends on the mode's ambiguity variables w.
    """

    mode: str
    region: poly.Polytope
    pitch_acceleration: float
    optimum: np.ndarray | None
    worst_case: bool


def pitch_row(mode: ModeAnalysis, pitch_index: int) -> tuple[np.ndarray, np.ndarray, float, bool]:
    """``(c_u, c_w, c_0, depends_on_w)``: the pitch row of the mode's response."""
    r = mode.response
    c_u = r.X_u[pitch_index].copy()
    c_w = r.X_w[pitch_index].copy()
    c_0 = float(r.x_0[pitch_index])
    depends = False
    if r.X_w.size:
        scale = float(np.max(np.abs(r.X_w)))
        depends = bool(np.max(np.abs(c_w)) > OUTPUT_TOLERANCE * max(scale, 1e-300))
    if not depends:
        c_w = np.zeros_like(c_w)
    return c_u, c_w, c_0, depends


def worst_case_pitch(
    mode: ModeAnalysis, pitch_index: int, u: np.ndarray, *, settings: SolverSettings = DEFAULT_SETTINGS
) -> float:
    """``c_u^T u + c_0 + min { c_w^T w : (u, w) in D_c }``: the least pitch acceleration at u.

    One LP over w on the slice of the mode's domain D_c at u; ``-inf`` if u is outside T_c.
    """
    c_u, c_w, c_0, depends = pitch_row(mode, pitch_index)
    base = float(c_u @ u) + c_0
    if not depends:
        return base
    D = mode.domain
    if D is None:  # an infeasible mode: no u is in T_c
        return -math.inf
    m = mode.m
    H_u, H_w = D.A[:, :m], D.A[:, m:]
    result = solve_lp(c_w, H_w, D.b - H_u @ u,
                      door=DoorOptions(settings, fallback=RETRY_ERRORS, check=backend().lp_check))
    if not result.found:
        return -math.inf
    return base + float(result.objective)


def maximise_pitch(mode: ModeAnalysis, piece: poly.Polytope, pitch_index: int,
                   settings: SolverSettings = DEFAULT_SETTINGS) -> FlipPiece:
    """The best pitch acceleration of ``mode`` on one piece of inputs.

    ``max c_u^T u + c_0`` over the piece by one LP when the pitch row does not depend on w; else the
    worst case ``c_u^T u + c_0 + g(u)``, ``g(u) = min {c_w^T w : (u, w) in D_c}`` (convex in u), at
    the best vertex of the piece (see the module's docstring).

    Args:
        mode: the mode's analysis (its response ``X_u, X_w, x_0``, its domain D_c over (u, w)).
        piece: a bounded polytope of inputs inside T_c.
        pitch_index: the pitch coordinate's index in ``dv``.
        settings: the solver settings.
    """
    c_u, _, c_0, depends = pitch_row(mode, pitch_index)
    if not depends:
        result = solve_lp(-c_u, piece.A, piece.b,
                          door=DoorOptions(settings, fallback=RETRY_ERRORS, check=backend().lp_check))
        if not result.found or result.x is None:
            return FlipPiece(mode.mode, piece, -math.inf, None, False)
        return FlipPiece(mode.mode, piece, float(c_u @ result.x) + c_0, result.x.copy(), False)
    reduced = poly.minimal_representation(piece, settings=settings)
    best, best_u = -math.inf, None
    for vertex in vertices_from_halfspaces(reduced.A, reduced.b, max_candidates=MAX_VERTEX_CANDIDATES):
        value = worst_case_pitch(mode, pitch_index, vertex, settings=settings)
        if value > best:
            best, best_u = value, vertex
    return FlipPiece(mode.mode, piece, best, best_u, True)


def round_inputs(u: np.ndarray, lower: np.ndarray, upper: np.ndarray, quantum: float) -> np.ndarray:
    """Round to multiples of ``quantum`` and keep within the limits.

    A quantum of ``10^-k`` rounds to ``k`` decimals, giving the double nearest to the printed
    decimal (``-1.3072``, not ``-1.3072000000000001``): what a user types back is what was checked.
    """
    if quantum <= 0:
        rounded = u.copy()
    else:
        digits = -math.log10(quantum)
        if abs(digits - round(digits)) < 1e-12 and digits >= 0:
            rounded = np.array([round(float(x), int(round(digits))) for x in u])
        else:
            rounded = np.round(u / quantum) * quantum
    rounded = np.minimum(np.maximum(rounded, lower), upper)
    return rounded + 0.0  # no negative zeros


def candidate_bounds(analysis: DynamicResponse, candidates: Sequence[str], pitch_index: int, margin: float,
                      settings: SolverSettings) -> dict[str, float]:
    """Per candidate mode, an upper bound of its pitch acceleration over its shrunk T_c (one LP).

    ``inf`` when the pitch row depends on w (no cheap bound), ``-inf`` when the shrunk T_c is empty.
    """
    bounds: dict[str, float] = {}
    for name in candidates:
        c_u, _, c_0, depends = pitch_row(analysis.mode(name), pitch_index)
        if depends:
            bounds[name] = math.inf
            continue
        A, b = shrunk_input_domain(analysis, name, margin)
        result = solve_lp(-c_u, A, b,
                          door=DoorOptions(settings, fallback=RETRY_ERRORS, check=backend().lp_check))
        bounds[name] = float(c_u @ result.x) + c_0 if result.x is not None else -math.inf
    return bounds


def branch_and_bound(analysis: DynamicResponse, problem: ContactProblem, candidates: Sequence[str],
                     bounds: Mapping[str, float], pitch_index: int, search: PieceSearch,
                     timings: dict[str, float]) -> tuple[list[FlipPiece], list[str], list[tuple[str, str]],
                                                         tuple[FlipPiece, np.ndarray, float] | None]:
    """The best verified piece, exploring candidates by decreasing bound.

    Returns:
        (every piece found, the modes explored, the rejected optima with why, the chosen
        (piece, rounded inputs, pitch acceleration) or None).
    """
    pieces: list[FlipPiece] = []
    explored: list[str] = []
    rejected: list[tuple[str, str]] = []
    chosen: tuple[FlipPiece, np.ndarray, float] | None = None
    margin, rounding, exhaustive, settings, free = (search.margin, search.rounding, search.exhaustive,
                                                    search.settings, search.free)
    for name in sorted(candidates, key=lambda c: -bounds[c]):
        if bounds[name] == -math.inf:
            break
        if chosen is not None and not exhaustive and bounds[name] <= chosen[0].pitch_acceleration:
            break
        explored.append(name)
        t0 = time.perf_counter()
        regions = margin_pieces(analysis, name, margin, settings=settings, free=free)
        t1 = time.perf_counter()
        found = sorted((maximise_pitch(analysis.mode(name), piece, pitch_index, settings)
                        for piece in regions), key=lambda p: -p.pitch_acceleration)
        t2 = time.perf_counter()
        timings["unambiguous_sets"] += t1 - t0
        timings["lps"] += t2 - t1
        pieces += found
        for piece in found:
            if chosen is not None and piece.pitch_acceleration <= chosen[0].pitch_acceleration:
                break
            if piece.optimum is None:
                rejected.append((piece.mode, "the LP found no optimum"))
                continue
            u = round_inputs(piece.optimum, problem.lower, problem.upper, rounding)
            verdict, pitch = verify_piece(analysis, piece, u, pitch_index, settings, free)
            if verdict is None:
                chosen = (piece, u, pitch)
                break
            rejected.append((piece.mode, verdict))
        timings["verification"] += time.perf_counter() - t2
    return pieces, explored, rejected, chosen


def torque_text(torques: Mapping[str, float]) -> str:
    """``name = value N m, ...`` (four decimals: the printed torques)."""
    return ", ".join(f"{name} = {value:.4f} N m" for name, value in torques.items())


def verify_piece(analysis: DynamicResponse, piece: FlipPiece, u: np.ndarray, pitch_index: int,
            settings: SolverSettings, free: Mapping[str, str] | None = None) -> tuple[str | None, float]:
    """``(None, pitch)`` if the rigid solutions at u are as the plan allows, else why.

    That is: one solution in the piece's mode and the others only in modes ``free`` allows
    (:func:`mode_allowed`; without ``free``: exactly one solution).
    """
    mode = analysis.mode(piece.mode)
    pitch = worst_case_pitch(mode, pitch_index, u, settings=settings)
    solutions = solutions_at(analysis, u, settings=settings)
    modes = [s.mode for s in solutions]
    contacts = analysis.problem.contacts
    if modes.count(piece.mode) != 1 or not all(mode_allowed(m, piece.mode, contacts, free) for m in modes):
        return f"solutions at the rounded torques: {', '.join(modes) or 'none'}", pitch
    found = float(solutions[modes.index(piece.mode)].dv[pitch_index])
    if piece.worst_case:
        if found < pitch - PITCH_TOLERANCE * (1.0 + abs(pitch)):
            return f"the solution's pitch {found:.9g} is below the worst case {pitch:.9g}", pitch
    elif abs(found - pitch) > PITCH_TOLERANCE * (1.0 + abs(pitch)):
        return f"the solution's pitch {found:.12g} differs from the plan's {pitch:.12g}", pitch
    return None, pitch
