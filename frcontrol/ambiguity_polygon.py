"""The engine's rule for two ambiguity variables in closed form: its two LPs decided by their vertices.

A mode whose response leaves two variables ``w`` free is admissible at an input when ``(u, w)``
lies in its domain for some ``w`` moving as the mode says; its representative ``w`` is the
Chebyshev centre of the admissible ``w``. The engine decides that with two LPs
(:func:`frcontrol.engine.motion_margin`, then :func:`frcontrol.polytope.chebyshev_ball`). Each is
an LP in three variables, ``(w, t)`` or ``(w, r)``, over the rows ``a_i w + c_i s <= b_i`` and the
bounds ``0 <= s <= s_max``, where only ``b`` depends on the input:

- the motion LP: ``max t`` in ``[0, 1]``, a motion row with ``c_i = 1`` (``a_i`` of unit norm), the
  other rows with ``c_i = 0`` and relaxed by ``DOMAIN_TOLERANCE``;
- the Chebyshev LP: ``max r`` in ``[0, CHEBYSHEV_RADIUS_CAP]``, every row with ``c_i = 1``, relaxed.

When the rows' ``a_i`` span the plane, the set is pointed and its optimum is at a vertex: three
rows (or bounds) met with equality. :class:`PolygonRule` inverts every such 3x3 system once per
mode (they do not depend on the input); at an input, one product gives every candidate vertex,
one more their feasibility (to :data:`VERTEX_TOLERANCE`), and the best is the LP's optimum. Where
the optimum is one point this is the LP's answer to round-off. Where a face is optimal (a capped
radius: a set wider than twice the cap, where every point that far inside is a Chebyshev centre),
the representative is the optimal vertex nearest to ``w = 0`` (the LP reports one of the vertices,
whichever its iterations reach). Rows whose coefficients in ``w`` are below the zero-row threshold
are judged by their right-hand side alone, as :func:`frcontrol.mode_batch.decide_intervals` does
for one variable (normalising them would turn round-off into bounds near 1e16).

Where the rows do not span the plane (the set holds a line) or there are more than
:data:`POLYGON_MAX_ROWS` rows, :meth:`PolygonRule.build` returns None and the LPs decide.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from itertools import combinations

import numpy as np

POLYGON_MAX_ROWS = 8
"""[-] A mode with two ambiguity variables is decided in closed form when it has at most this many
rows in ``w`` (its ``C(rows + 2, 3)`` candidate vertices, 120 at 8 rows; building the rule then costs
about ten of the LPs it replaces, deciding by it a third of one); beyond, by the LPs."""

VERTEX_TOLERANCE = 1e-9
"""[units of w, rows of unit norm in w] A candidate vertex is feasible when it violates no row by more
than this times ``max(1, |b_i|)`` (the LP back-ends' feasibility tolerance); it is optimal when its
margin is within this of the best one's."""

LP_NEAR_OPTIMAL = 1e-6
"""[units of w: rows of unit norm] The LP back-ends reach the Chebyshev LP's optimum radius to about a
tenth of this (DAQP, the default, to about 1e-7), and stop at whichever vertex they reach there. The
compiled one-call query takes that LP's point (a ball neither thin nor capped) as the engine's only
where no other vertex lies within this of the optimum radius away from it; else it leaves the input
to the general path, whose LP answers."""

SINGULAR_DETERMINANT = 1e-12
"""[-] Three rows (unit norm in w) whose 3x3 determinant is at most this in magnitude meet at no
vertex (parallel rows): they are not a candidate. Two rows spanning the plane have a 2x2
determinant above it."""


@lru_cache(maxsize=64)
def _triples(count: int) -> np.ndarray:
    """Every set of three of ``count`` rows, as a (C(count, 3), 3) index array (shared: read only)."""
    triples = np.array(list(combinations(range(count), 3)), dtype=np.int64).reshape(-1, 3)
    triples.setflags(write=False)
    return triples


def _vertex_maps(a: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Per LP ``j``, every candidate vertex and its slacks as a linear map of the LP's ``b[j]``.

    The LP's rows ``R_j`` are its live rows ``(a_i, c[j, i])`` (``a``: (L, 2), ``c``: (J, L)), then
    the bounds ``s <= s_max`` and ``-s <= 0``. Three rows ``T`` meet at ``inv(R_j[T]) b[j][T]``, where
    every row's slack is ``b[j] - R_j vertex``: both are linear in ``b[j]``.

    Returns:
        (J, K, 3 + L + 2, L + 2): per LP and triple of rows (K of them), the vertex ``(w, s)`` then
        every row's slack there, as a map of ``b[j]`` (NaN where the three rows meet at no point:
        never feasible).
    """
    count, size = c.shape[0], a.shape[0] + 2
    rows = np.zeros((count, size, 3))
    rows[:, :-2, :2], rows[:, :-2, 2] = a, c
    rows[:, -2, 2], rows[:, -1, 2] = 1.0, -1.0
    triples = _triples(size)
    systems = rows[:, triples]
    meeting = np.abs(np.linalg.det(systems)) > SINGULAR_DETERMINANT
    inverse = np.full(systems.shape, np.nan)
    inverse[meeting] = np.linalg.inv(systems[meeting])
    weights = np.zeros((count, triples.shape[0], size, 3))  # the vertex as a map of b, transposed
    for column in range(3):  # the three rows of a triple are distinct
        weights[:, np.arange(triples.shape[0]), triples[:, column], :] = inverse[:, :, :, column]
    vertex = weights.transpose(0, 1, 3, 2)
    slack = np.eye(size) - np.einsum("jid,jkdl->jkil", rows, vertex)  # b - R vertex
    return np.concatenate([vertex, slack], axis=2)


@dataclass(frozen=True, eq=False)
class PolygonRule:
    """The engine's rule for the ``w`` of one mode with two ambiguity variables (module docstring).

    Build it once per mode (:meth:`build`, from the rows in ``w``); :meth:`decide` answers one input.
    Everything :meth:`decide` needs is affine in the rows' right-hand sides ``h``: ``map @ [h, 1]``
    stacks the checks of the constant rows, then per LP (the motion LP, the Chebyshev LP) its
    right-hand sides ``b`` and, for every triple of its rows, the vertex and the slacks there.

    Attributes:
        map: (checks + 2 (L + 2) + 2 K (5 + L), rows + 1) that affine map.
        checks: the constant rows' checks first (each must be >= 0; ``strict`` of them > 0).
        strict: the constant motion rows among the checks (the last ones).
        size: L + 2, the rows of each LP (its L live rows and the two bounds).
        candidates: K, the triples of rows per LP.
        moving: some live row is a motion row (the motion LP's margin must then exceed the tolerance).
        domain_tolerance: [units of u] the engine's membership distance.
    """

    map: np.ndarray
    checks: int
    strict: int
    size: int
    candidates: int
    moving: bool
    domain_tolerance: float

    @classmethod
    def build(cls, H_w: np.ndarray, motion: np.ndarray, *, domain_tolerance: float, zero_row_tolerance: float,
              radius_cap: float) -> PolygonRule | None:
        """The rule for ``H_w w <= h`` (rows normalised in (u, w)); None where the LPs must decide.

        None when ``H_w`` does not have two columns, has more than :data:`POLYGON_MAX_ROWS` rows, or
        its live rows do not span the plane.
        """
        if H_w.ndim != 2 or H_w.shape[1] != 2 or H_w.shape[0] > POLYGON_MAX_ROWS:
            return None
        rows, tol = H_w.shape[0], domain_tolerance
        norms = np.sqrt((H_w * H_w).sum(axis=1))
        zero = norms <= zero_row_tolerance * max(1.0, float(norms.max(initial=0.0)))
        live = np.flatnonzero(~zero)
        unit = H_w[live] / norms[live, None]
        crossings = np.outer(unit[:, 0], unit[:, 1]) - np.outer(unit[:, 1], unit[:, 0])  # 2x2 determinants
        if unit.shape[0] < 2 or float(np.abs(crossings).max()) <= SINGULAR_DETERMINANT:
            return None
        motion = motion.astype(bool)
        # a constant row holds by its right-hand side: h + tol >= 0, or h - tol > 0 for a motion row
        constant = [np.flatnonzero(zero & ~motion), np.flatnonzero(zero & motion)]
        checks = np.zeros((constant[0].size + constant[1].size, rows + 1))
        checks[np.arange(constant[0].size), constant[0]] = 1.0
        checks[np.arange(constant[0].size, checks.shape[0]), constant[1]] = 1.0
        checks[:, -1] = np.concatenate([np.full(constant[0].size, tol), np.full(constant[1].size, -tol)])
        size = live.size + 2
        b = np.zeros((2, size, rows + 1))  # the motion LP's b, then the Chebyshev LP's: (h + offset) / norm
        b[:, np.arange(live.size), live] = 1.0 / norms[live]
        b[0, :-2, -1] = np.where(motion[live], 0.0, tol) / norms[live]
        b[1, :-2, -1] = tol / norms[live]
        b[:, -2, -1] = (1.0, radius_cap)
        maps = _vertex_maps(unit, np.stack([motion[live].astype(float), np.ones(live.size)]))
        found = np.einsum("jkrl,jlc->jkrc", maps, b)
        full = np.concatenate([checks, b.reshape(-1, rows + 1), found.reshape(-1, rows + 1)])
        return cls(np.ascontiguousarray(full), checks.shape[0], constant[1].size, size, maps.shape[1],
                   bool(np.count_nonzero(motion[live])), domain_tolerance)

    def decide(self, h: np.ndarray) -> np.ndarray | None:
        """The representative ``w`` at the rows' right-hand sides ``h`` (the input's), or None.

        None when no ``w`` makes the mode's motion strict (the motion LP's verdict); else the
        Chebyshev centre of the relaxed set, or the motion LP's vertex when that set is thinner than
        ``2 domain_tolerance``.
        """
        h_ext = np.empty(h.size + 1)
        h_ext[:-1], h_ext[-1] = h, 1.0
        out = self.map @ h_ext
        checks, strict, size = self.checks, self.strict, self.size
        if checks and (np.count_nonzero(out[:checks] < 0.0)
                       or np.count_nonzero(out[checks - strict:checks] <= 0.0)):
            return None
        b = out[checks:checks + 2 * size].reshape(2, 1, size)
        found = out[checks + 2 * size:].reshape(2, self.candidates, size + 3)
        with np.errstate(invalid="ignore"):  # NaN: no vertex, never feasible
            feasible = (found[:, :, 3:] >= np.maximum(np.abs(b), 1.0) * -VERTEX_TOLERANCE).all(axis=2)
        s = np.where(feasible, found[:, :, 2], -np.inf)
        best = s.max(axis=1)
        tol = self.domain_tolerance
        if best[0] == -np.inf or (best[0] <= tol and self.moving):
            return None  # the motion LP: infeasible, or no w moving as the mode says
        j = 1 if best[1] > tol else 0  # the Chebyshev centre, or the motion LP's vertex in a thin set
        optimal = np.flatnonzero(s[j] >= best[j] - VERTEX_TOLERANCE)
        if optimal.size > 1:  # an optimal face: its vertex nearest to w = 0
            optimal = optimal[np.argmin((found[j, optimal, :2] ** 2).sum(axis=1)):]
        return found[j, optimal[0], :2].copy()

__all__ = ["LP_NEAR_OPTIMAL", "POLYGON_MAX_ROWS", "PolygonRule", "SINGULAR_DETERMINANT", "VERTEX_TOLERANCE"]
