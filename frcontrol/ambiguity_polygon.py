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

POLYGON_MAX_ROWS = 24
"""[-] A mode with two ambiguity variables is decided in closed form when it has at most this many
rows in ``w`` (its ``C(rows + 2, 3)`` candidate vertices, 2,600 at 24 rows); beyond, by the LPs."""

VERTEX_TOLERANCE = 1e-9
"""[units of w, rows of unit norm in w] A candidate vertex is feasible when it violates no row by more
than this times ``max(1, |b_i|)`` (the LP back-ends' feasibility tolerance); it is optimal when its
margin is within this of the best one's."""

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


@dataclass(frozen=True, eq=False)
class _VertexLPs:
    """LPs ``max s`` over ``rows[j] @ (w, s) <= b[j]``, all decided at once by their vertices.

    With ``R_j`` the LP's rows (its live rows ``(a_i, c_i)``, then the bounds ``s <= s_max`` and
    ``-s <= 0``), the vertex of three rows ``T`` is ``inv(R_j[T]) b[j][T]`` and every row's slack
    there is ``b[j] - R_j vertex``: both are linear in ``b[j]``. ``maps[j]`` is that linear map, for
    every three rows at once, so that one product gives every candidate and its slacks.

    Attributes:
        maps: (J, K (3 + L + 2), L + 2): per LP and triple of rows, the vertex ``(w, s)`` then the
            slack of every row, as a function of ``b[j]`` (NaN where the three rows meet at no point:
            never a candidate).
        candidates: K, the number of triples.
    """

    maps: np.ndarray
    candidates: int

    @classmethod
    def build(cls, a: np.ndarray, c: np.ndarray) -> _VertexLPs:
        """The LPs of the rows ``a_i w + c[j, i] s`` (``a``: (L, 2), ``c``: (J, L)) and the bounds on s."""
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
        maps = np.concatenate([vertex, slack], axis=2).reshape(count, -1, size)
        return cls(np.ascontiguousarray(maps), triples.shape[0])

    def optimum(self, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per LP (``b``: (J, L + 2)), the largest ``s`` (-inf: infeasible) and the optimal vertex
        nearest to ``w = 0`` (its ``w``; (J, 2))."""
        count = b.shape[0]
        found = np.matmul(self.maps, b[:, :, None]).reshape(count, self.candidates, -1)
        bound = np.abs(b)
        np.maximum(bound, 1.0, out=bound)
        bound *= -VERTEX_TOLERANCE
        with np.errstate(invalid="ignore"):  # NaN: no vertex, never feasible
            feasible = (found[:, :, 3:] >= bound[:, None, :]).all(axis=2)
            s = np.where(feasible, found[:, :, 2], -np.inf)
            best = s.max(axis=1)
            distance = np.where(s >= best[:, None] - VERTEX_TOLERANCE,
                                (found[:, :, :2] ** 2).sum(axis=2), np.inf)
        nearest = np.argmin(distance, axis=1)
        return best, found[np.arange(count), nearest, :2]


@dataclass(frozen=True, eq=False)
class PolygonRule:
    """The engine's rule for the ``w`` of one mode with two ambiguity variables (module docstring).

    Build it once per mode (:meth:`build`, from the rows in ``w``); :meth:`decide` answers one input.

    Attributes:
        zero: (rows,) the rows with coefficients below the zero-row threshold (judged by ``h``).
        motion: (rows,) the motion rows.
        live: (L,) the other rows; norms: (L,) their norms in ``w``.
        lps: the motion LP and the Chebyshev LP over the live rows (in that order).
        domain_tolerance: [units of u] the engine's membership distance.
        radius_cap: the Chebyshev radius cap.
    """

    zero: np.ndarray
    motion: np.ndarray
    live: np.ndarray
    norms: np.ndarray
    lps: _VertexLPs
    domain_tolerance: float
    radius_cap: float

    @classmethod
    def build(cls, H_w: np.ndarray, motion: np.ndarray, *, domain_tolerance: float, zero_row_tolerance: float,
              radius_cap: float) -> PolygonRule | None:
        """The rule for ``H_w w <= h`` (rows normalised in (u, w)); None where the LPs must decide.

        None when ``H_w`` does not have two columns, has more than :data:`POLYGON_MAX_ROWS` rows, or
        its live rows do not span the plane.
        """
        if H_w.ndim != 2 or H_w.shape[1] != 2 or H_w.shape[0] > POLYGON_MAX_ROWS:
            return None
        norms = np.sqrt((H_w * H_w).sum(axis=1))
        zero = norms <= zero_row_tolerance * max(1.0, float(norms.max(initial=0.0)))
        live = np.flatnonzero(~zero)
        unit = H_w[live] / norms[live, None]
        spans = unit.shape[0] >= 2 and float(np.abs(np.outer(unit[:, 0], unit[:, 1])
                                                    - np.outer(unit[:, 1], unit[:, 0])).max()) > SINGULAR_DETERMINANT
        if not spans:
            return None
        c = np.stack([motion[live].astype(float), np.ones(live.size)])
        return cls(zero, motion.astype(bool), live, norms[live], _VertexLPs.build(unit, c), domain_tolerance,
                   radius_cap)

    def decide(self, h: np.ndarray) -> np.ndarray | None:
        """The representative ``w`` at the rows' right-hand sides ``h`` (the input's), or None.

        None when no ``w`` makes the mode's motion strict (the motion LP's verdict); else the
        Chebyshev centre of the relaxed set, or the motion LP's vertex when that set is thinner than
        ``2 domain_tolerance``.
        """
        tol, motion, zero = self.domain_tolerance, self.motion, self.zero
        relaxed = h + np.where(motion, 0.0, tol)
        if np.count_nonzero(zero & ((~motion & (relaxed < 0.0)) | (motion & (h <= tol)))):
            return None
        live, norms = self.live, self.norms
        b = np.empty((2, live.size + 2))
        np.divide(relaxed[live], norms, out=b[0, :-2])
        np.divide(h[live] + tol, norms, out=b[1, :-2])
        b[:, -2], b[:, -1] = (1.0, self.radius_cap), 0.0
        best, vertex = self.lps.optimum(b)
        if best[0] == -np.inf or (best[0] <= tol and np.count_nonzero(motion[live])):
            return None  # the motion LP: infeasible, or no w moving as the mode says
        return vertex[1] if best[1] > tol else vertex[0]


__all__ = ["POLYGON_MAX_ROWS", "PolygonRule", "SINGULAR_DETERMINANT", "VERTEX_TOLERANCE"]
