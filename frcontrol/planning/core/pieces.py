r"""The unambiguous inputs of a mode, kept a margin from every other mode: convex pieces.

``U_c(margin) = { u : B(u, margin) in T_c  and  B(u, margin) misses T_j for every j in O_c }``, with
B(u, r) the ball of radius r and O_c the modes whose T_j meets T_c in more than a boundary (the modes
that overlap T_c, and the lower-dimensional modes). T_c's rows are pulled in by the margin, except
the input limits (:func:`shrunk_input_domain`); each T_j is grown by the margin row by row and cut
out by the region difference (METHOD §5), pieces without an interior (Chebyshev radius at most
:data:`~frcontrol.polytope.INTERIOR_TOLERANCE`) dropped. :mod:`frcontrol.planning.flip`'s docstring
derives it; every decision of the core (:mod:`.decision`) and the flip's plans build on it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from ... import polytope as poly
from ...engine import DynamicResponse, ModeAnalysis
from ...geometry import chebyshev_rows, max_margin, unit_rows
from ...solvers import DEFAULT_SETTINGS, SolverSettings, must_solve
from .tolerances import INPUT_LIMIT_TOLERANCE

__all__ = ["margin_pieces", "mode_allowed", "shrunk_input_domain", "unit_halfspaces"]


def unit_halfspaces(P: poly.Polytope) -> tuple[np.ndarray, np.ndarray]:
    """Unit rows ``a u <= b`` of P, an equality ``E u = e`` written as ``E u <= e, -E u <= -e``."""
    A = np.vstack([P.A_eq, -P.A_eq, P.A])
    b = np.concatenate([P.b_eq, -P.b_eq, P.b])
    return unit_rows(A, b)


def _limit_rows(A: np.ndarray, b: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Mask of the unit rows that are input limits ``u_i <= upper_i`` or ``-u_i <= -lower_i``."""
    mask = np.zeros(A.shape[0], dtype=bool)
    for r, (row, rhs) in enumerate(zip(A, b, strict=True)):
        i = int(np.argmax(np.abs(row)))
        if abs(abs(row[i]) - 1.0) > INPUT_LIMIT_TOLERANCE:
            continue
        limit = upper[i] if row[i] > 0 else -lower[i]
        if math.isfinite(limit) and abs(rhs - limit) <= INPUT_LIMIT_TOLERANCE * (1.0 + abs(limit)):
            mask[r] = True
    return mask


def _has_interior(A: np.ndarray, b: np.ndarray, settings: SolverSettings) -> bool:
    """Whether ``{u : A u <= b}`` (unit rows) holds a ball of radius > ``INTERIOR_TOLERANCE``.

    One Chebyshev LP (:func:`frcontrol.geometry.max_margin` of :func:`~frcontrol.geometry.chebyshev_rows`,
    the radius capped at :data:`~frcontrol.geometry.CHEBYSHEV_RADIUS_CAP`). Zero rows are judged by
    their right-hand side.
    """
    zero = ~np.any(A, axis=1)
    if np.any(b[zero] < -poly.CONTAINMENT_TOLERANCE):
        return False
    result = max_margin(chebyshev_rows(A[~zero]), b[~zero], settings=settings,
                        fallback=must_solve("an interior test of the planner"))
    if result.status == "infeasible" or result.x is None:
        return False
    return bool(result.x[-1] > poly.INTERIOR_TOLERANCE)


def shrunk_input_domain(
    analysis: DynamicResponse, mode: str, margin: float
) -> tuple[np.ndarray, np.ndarray]:
    """T_c of ``mode`` with every row but the input limits pulled in by ``margin``: ``(A, b)``, unit rows.

    ``{u : a_i^T u <= b_i - margin}`` for the mode boundaries, ``a_i^T u <= b_i`` for the limits:
    the inputs whose ball of radius ``margin`` lies in T_c (within the limits).
    """
    problem = analysis.problem
    A, b = unit_halfspaces(analysis.mode(mode).feasible_input_domain)
    limits = _limit_rows(A, b, problem.lower, problem.upper)
    return A, b - margin * (~limits)


def margin_pieces(
    analysis: DynamicResponse,
    mode: str,
    margin: float,
    *,
    settings: SolverSettings = DEFAULT_SETTINGS,
    free: Mapping[str, str] | None = None,
) -> list[poly.Polytope]:
    """The unambiguous inputs of ``mode`` kept ``margin`` away from every other mode, as pieces.

    See the module's docstring: ``U_c(margin)`` from T_c shrunk (input limits excepted,
    :func:`shrunk_input_domain`) by the region difference against the overlapping and the
    lower-dimensional modes, each grown by ``margin`` row by row. A lower-dimensional T_j lies in
    its affine hull ``E_j u = e_j``; when the band ``|E_j u - e_j| <= margin`` misses a piece's
    interior, T_j is not needed there (and its projection is not computed).

    Args:
        analysis: the engine's analysis (with its overlaps).
        mode: a feasible mode whose T_c has an interior.
        margin: [units of u] the distance to keep, >= 0.
        settings: the solver settings of its LPs.
        free: per contact name, the letters a plan in ``mode`` also allows that contact
            (:func:`mode_allowed`): the modes so allowed are not kept away from (default: none).

    Returns:
        Convex pieces with disjoint interiors, each with an interior (unit rows, not minimal).
    """
    if not analysis.mode(mode).inputs_full_dimensional:
        return []
    A, start_b = shrunk_input_domain(analysis, mode, margin)
    if not _has_interior(A, start_b, settings):
        return []
    others = [analysis.mode(name) for name in analysis.overlapping(mode)]
    others += [m for m in analysis.lower_dimensional_modes() if m.mode != mode]
    contacts = analysis.problem.contacts
    others = [m for m in others if not mode_allowed(m.mode, mode, contacts, free)]
    pieces: list[tuple[np.ndarray, np.ndarray]] = [(A, start_b)]
    for other in others:
        hull = _hull_band(other, margin)
        rows: tuple[np.ndarray, np.ndarray] | None = None
        next_pieces: list[tuple[np.ndarray, np.ndarray]] = []
        for R_A, R_b in pieces:
            if hull is not None and not _has_interior(np.vstack([R_A, hull[0]]),
                                                      np.concatenate([R_b, hull[1]]), settings):
                next_pieces.append((R_A, R_b))  # T_j's hull is margin away from this piece
                continue
            if rows is None:
                A_j, b_j = unit_halfspaces(other.feasible_input_domain)
                rows = (A_j, b_j + margin)
            A_j, grown = rows
            if not _has_interior(np.vstack([R_A, A_j]), np.concatenate([R_b, grown]), settings):
                next_pieces.append((R_A, R_b))  # already margin away from T_j
                continue
            kept_A, kept_b = R_A, R_b
            for row, rhs in zip(A_j, grown, strict=True):
                child_A = np.vstack([kept_A, -row])
                child_b = np.append(kept_b, -rhs)
                if _has_interior(child_A, child_b, settings):
                    next_pieces.append((child_A, child_b))
                kept_A, kept_b = np.vstack([kept_A, row]), np.append(kept_b, rhs)
        pieces = next_pieces
        if not pieces:
            break
    return [poly.Polytope(P_A, P_b) for P_A, P_b in pieces]


def mode_allowed(mode: str, planned: str, contacts: Sequence[str], free: Mapping[str, str] | None) -> bool:
    """Whether a plan in mode ``planned`` allows ``mode`` (both one letter per contact of ``contacts``).

    It does when every contact has the planned letter or one of the letters ``free`` gives it
    (``{"rear_toe": "S"}``: the rear toe may also separate). Without ``free``, only ``planned``.
    """
    free = free or {}
    return all(a == b or a in free.get(name, "") for a, b, name in zip(mode, planned, contacts, strict=True))


def _hull_band(mode: ModeAnalysis, margin: float) -> tuple[np.ndarray, np.ndarray] | None:
    """``|E u - e| <= margin`` (unit rows) around a mode's consistency hull, or None if it has none."""
    E, e = mode.response.E, mode.response.e
    if E.shape[0] == 0:
        return None
    A, b = unit_rows(np.vstack([E, -E]), np.concatenate([e, -e]))
    return A, b + margin
