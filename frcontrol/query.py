"""Queries on a finished analysis: point location among the mode domains and an affine evaluation.

Once :func:`frcontrol.engine.analyze` has found the feasible modes of a scene at its state, the rigid
solutions at an input ``u`` are the modes whose domain ``D_c`` holds ``(u, w)`` for some ``w``,
each at ``x = X_u u + X_w w + x_0``. :class:`QueryTable` keeps, once per analysis, what that takes:
for every feasible mode its inequalities over ``(u, w)`` with the response substituted,
``H_u u + H_w w <= h_0`` (rows normalised by their norm in ``(u, w)``, numerically constant rows by
1, as :func:`frcontrol.engine.solutions_at` slices them), its consistency conditions ``E u = e``
(two rows each, without ``w``), its affine response, and its system ``A, B, c, G, g`` for the
residuals. The modes' rows are stacked into one ``(modes, rows, m)`` array (padded rows always hold).

At one input (:meth:`QueryTable.locate`), one product gives every row's slack
``h = (h_0 - H_u u) / norm``; then, with :data:`BOUNDARY_TOLERANCE` ``tol``:

- a mode without ambiguity variables holds ``u`` when every non-motion row has ``h >= -tol`` and
  every motion row ``h > tol`` (its solution moves as the mode says);
- a mode with one ambiguity variable: the interval rule of
  :func:`frcontrol.mode_batch.decide_intervals` (also its representative ``w``), for all such
  modes at once;
- a mode with two or more: its consistency rows first, then the engine's LPs (``decide_w``), one
  mode at a time.

These are the rules, the tolerances and the representatives of the engine's path on an analysis,
so the answers are the same up to the round-off of the sums (a point exactly at a threshold may be
decided either way). :meth:`QueryTable.locate_batch` does the same for ``N`` inputs at once, mode by
mode, and returns a :class:`BatchSolutions`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from .ambiguity_polygon import PolygonRule
from .errors import InputError
from .geometry import constant_rows
from .jsonable import to_jsonable
from .kernel import backend, compiled, twin
from .mode_batch import decide_intervals
from .modes import ContactProblem, ModeSystem
from .response import AffineSolution, AmbiguousOutputs

BOUNDARY_TOLERANCE = 1e-7
"""[units of u: N or N m] An input that lies at most this distance outside a facet of a mode's
domain (a row normalised in (u, w)) is in it; on a motion facet (the mode's motion strict, e.g.
``a_N > 0`` of a separating contact) it must lie more than this inside. The engine's
:data:`~frcontrol.engine.DOMAIN_TOLERANCE`, with which the from-scratch path decides: both paths
hold a point on a facet to the same rule (checked in tests/test_query.py)."""

WDecider = Callable[[np.ndarray, np.ndarray, np.ndarray], "np.ndarray | None"]
"""``decide(H_w, h_w, motion) -> w or None``: the engine's rule for a mode with two or more
ambiguity variables at one input (rows normalised in (u, w))."""


@dataclass(frozen=True)
class QueryMode:
    """One feasible mode as the table takes it: its name, system, response and what w moves."""

    mode: str
    system: ModeSystem
    response: AffineSolution
    ambiguous_outputs: AmbiguousOutputs


@dataclass(frozen=True)
class Located:
    """Solutions found by the table: solution s is mode ``index[s]``, in row ``rows[s]`` of the arrays.

    Attributes:
        index: the modes (indices into the table's modes), one per solution.
        rows: each solution's row in the arrays below (``range(S)`` unless the arrays hold a row for
            every mode, as :meth:`QueryTable.locate` with the compiled kernel).
        x: ``(dv, lambda_n, lambda_t)`` per row; w: (rows, p_max) the ambiguity values (padded by 0).
        a_n, a_t: (rows, k) contact accelerations [m/s^2].
        equality_residual, inequality_violation: per row, as in :class:`BatchSolutions`.
    """

    index: np.ndarray
    rows: Sequence[int]
    x: np.ndarray
    w: np.ndarray
    a_n: np.ndarray
    a_t: np.ndarray
    equality_residual: np.ndarray
    inequality_violation: np.ndarray


class PointSolutions(NamedTuple):
    """The solutions at one input as :meth:`QueryTable.point` finds them: row ``i`` is mode ``i``.

    Attributes:
        modes: the modes holding the input (indices into the table's modes, in its order).
        x: (modes, nx) ``(dv, lambda_n, lambda_t)``; w: (modes, p_max) the ambiguity values;
        acc: (modes, 2 k) ``(a_n, a_t)`` [m/s^2]; equality_residual, inequality_violation: (modes,).
        Only the rows of ``modes`` hold solutions.
    """

    modes: list[int]
    x: np.ndarray
    w: np.ndarray
    acc: np.ndarray
    equality_residual: np.ndarray
    inequality_violation: np.ndarray


@dataclass(frozen=True)
class BatchSolutions:
    """Every rigid solution at each of N inputs, as arrays (``solutions_at(analysis, U)``).

    The solutions are stored point after point, in the analysis's mode order within a point:
    solution ``s`` belongs to point ``point[s]``, and the solutions of point ``i`` are the rows
    ``offsets[i]:offsets[i + 1]`` of every per-solution array (S solutions in all).

    Attributes:
        inputs: the inputs (N, m) [N or N m].
        modes: the analysis's feasible modes; ``mode_index`` points into it.
        count: number of solutions per point (N,).
        offsets: (N + 1,) where each point's solutions start.
        point: (S,) the point of each solution.
        mode_index: (S,) its mode, an index into ``modes``.
        dv: (S, n) accelerations [m/s^2, rad/s^2].
        lambda_n, lambda_t: (S, k) contact forces [N].
        a_n, a_t: (S, k) contact accelerations [m/s^2].
        ambiguity_dim: (S,) the mode's number of ambiguity variables p.
        w: (S, p_max) the representative ambiguity values, the first ``ambiguity_dim[s]`` entries
            of row s (the rest 0).
        equality_residual: (S,) max ``|A x - B u - c|``.
        inequality_violation: (S,) max violation of the mode's inequalities (at most the tolerance).
        ambiguous_outputs: per mode (like ``modes``): ``"none"``, ``"forces"`` or ``"accelerations"``.
        tolerance: :data:`BOUNDARY_TOLERANCE`, the membership distance used.
    """

    inputs: np.ndarray
    modes: tuple[str, ...]
    count: np.ndarray
    offsets: np.ndarray
    point: np.ndarray
    mode_index: np.ndarray
    dv: np.ndarray
    lambda_n: np.ndarray
    lambda_t: np.ndarray
    a_n: np.ndarray
    a_t: np.ndarray
    ambiguity_dim: np.ndarray
    w: np.ndarray
    equality_residual: np.ndarray
    inequality_violation: np.ndarray
    ambiguous_outputs: tuple[str, ...]
    tolerance: float = BOUNDARY_TOLERANCE

    def __len__(self) -> int:
        """The number of points N."""
        return int(self.count.shape[0])

    def rows(self, i: int) -> slice:
        """The rows of point ``i``'s solutions in the per-solution arrays."""
        return slice(int(self.offsets[i]), int(self.offsets[i + 1]))

    def modes_at(self, i: int) -> tuple[str, ...]:
        """The modes of point ``i``'s solutions, in the analysis's order."""
        return tuple(self.modes[j] for j in self.mode_index[self.rows(i)].tolist())

    def to_dict(self) -> dict[str, Any]:
        """The arrays as nested lists (JSON values), with the field names above."""
        return to_jsonable({name: getattr(self, name) for name in (
            "inputs", "modes", "count", "offsets", "point", "mode_index", "dv", "lambda_n", "lambda_t",
            "a_n", "a_t", "ambiguity_dim", "w", "equality_residual", "inequality_violation",
            "ambiguous_outputs", "tolerance")})


def _mode_rows(entry: QueryMode, zero_row_tolerance: float
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One mode's rows ``(H_u, H_w, h_0, norms, motion)``: its inequalities, then ``E u = e`` twice.

    The inequalities as the engine slices them (:func:`frcontrol.engine.solutions_at`): ``H_w``
    divided by the row's norm in (u, w), zero on a constant row, whose norm counts as 1.
    """
    G, response = entry.system.G, entry.response
    H_u, H_w = G @ response.X_u, G @ response.X_w
    norms, constant = constant_rows(np.hstack([H_u, H_w]), zero_row_tolerance)
    norms[constant] = 1.0
    H_w = H_w / norms[:, None]
    H_w[constant] = 0.0
    E, e = response.E, response.e
    H_u = np.vstack([H_u, E, -E])
    H_w = np.vstack([H_w, np.zeros((2 * e.size, H_w.shape[1]))])
    h_0 = np.concatenate([entry.system.g - G @ response.x_0, e, -e])
    norms = np.concatenate([norms, np.ones(2 * e.size)])
    motion = np.concatenate([entry.system.motion, np.zeros(2 * e.size, dtype=bool)])
    return H_u, H_w, h_0, norms, motion


def _padded(arrays: Sequence[np.ndarray], rows: int, tail: tuple[int, ...], fill: Any, dtype: Any = float
            ) -> np.ndarray:
    """Arrays of shapes ``(r_i, *tail)`` stacked into ``(len, rows, *tail)``, padded with ``fill``."""
    out = np.full((len(arrays), rows, *tail), fill, dtype=dtype)
    for i, a in enumerate(arrays):
        out[i, :a.shape[0]] = a
    return out


def _output_map(problem: ContactProblem, system: ModeSystem, rows: int) -> np.ndarray:
    """``K`` with ``K [x; u; 1] = [a_n; a_t; A x - B u - c; G x - g]`` (G padded to ``rows`` rows).

    One product gives a solution's contact accelerations, its equation residuals and its
    inequality slacks, each a dot product of the same terms as the separate formulas.
    """
    n, k, m = problem.n, problem.k, problem.m
    nx = system.A.shape[1]
    K = np.zeros((2 * k + nx + rows, nx + m + 1))
    K[:k, :n] = problem.jacobian_normal
    K[:k, -1] = problem.drift_normal
    K[k:2 * k, :n] = problem.jacobian_tangent
    K[k:2 * k, -1] = problem.drift_tangent
    K[2 * k:2 * k + nx, :nx] = system.A
    K[2 * k:2 * k + nx, nx:nx + m] = -system.B
    K[2 * k:2 * k + nx, -1] = -system.c
    G = system.G
    K[2 * k + nx:2 * k + nx + G.shape[0], :nx] = G
    K[2 * k + nx:2 * k + nx + G.shape[0], -1] = -system.g
    return K


class QueryTable:
    """The feasible modes of one analysis, stacked for point location (module docstring).

    Build it once per analysis (:func:`frcontrol.engine.query_table` caches it on the analysis);
    :meth:`locate` answers one input, :meth:`locate_batch` many. Both run in the kernel
    ``FRC_KERNEL`` chooses (:mod:`frcontrol.kernel`): ``locate_points`` and ``evaluate_points`` of the
    compiled one, or their NumPy twins :meth:`decide` and :meth:`evaluate`.

    Args:
        problem: the analysis's contact problem.
        modes: its feasible modes, in its order (inconsistent ones are left out).
        zero_row_tolerance: the engine's constant-row threshold.
        radius_cap: the Chebyshev LP's radius cap (the interval rule's unbounded side).
        solution_type: the class of a solution (the engine's ``RigidSolution``: :meth:`solutions`).
        input_slack: [units of u] how far outside its limits an input is still taken as given
            (the scene's ``INPUT_LIMIT_SLACK``: :func:`plain_input`).
        tolerance: the membership distance (:data:`BOUNDARY_TOLERANCE`).
    """

    def __init__(self, problem: ContactProblem, modes: Sequence[QueryMode], *, zero_row_tolerance: float,
                 radius_cap: float, solution_type: type, input_slack: float,
                 tolerance: float = BOUNDARY_TOLERANCE) -> None:
        modes = [m for m in modes if m.response.consistent]
        self.problem, self.tolerance = problem, tolerance
        self.solution_type, self.input_slack = solution_type, input_slack
        self.n, self.k = problem.n, problem.k
        self.zero_row_tolerance, self.radius_cap = zero_row_tolerance, radius_cap
        self.modes = tuple(m.mode for m in modes)
        self.ambiguous_outputs = tuple(m.ambiguous_outputs for m in modes)
        self.p = np.array([m.response.ambiguity_dim for m in modes], dtype=np.int64)
        self.p_max = int(self.p.max(initial=0))
        self.p_list = self.p.tolist()
        self.mode_rows = [_mode_rows(m, zero_row_tolerance) for m in modes]
        self.row_count = np.array([r[2].size for r in self.mode_rows], dtype=np.int64)
        self.inequality_rows = np.array([m.system.G.shape[0] for m in modes], dtype=np.int64)
        m, nx, width = problem.m, problem.n + 2 * problem.k, int(self.row_count.max(initial=0))
        rows = self.mode_rows
        self.H_u = _padded([r[0] for r in rows], width, (m,), 0.0)
        self.h_0 = _padded([r[2] for r in rows], width, (), 1.0)  # a padded row always holds
        self.norms = _padded([r[3] for r in rows], width, (), 1.0)
        self.motion = _padded([r[4] for r in rows], width, (), False, bool)
        self.valid = _padded([np.ones(r[2].size, bool) for r in rows], width, (), False, bool)
        self.one = np.flatnonzero(self.p == 1)
        self.many = np.flatnonzero(self.p >= 2).tolist()
        self.many_rows = {i: tuple(a[:self.inequality_rows[i]] for a in rows[i]) for i in self.many}
        """Per mode with two or more ambiguity variables, its inequality rows ``(H_u, H_w, h_0,
        norms, motion)`` (without the consistency rows, decided before)."""
        rules = {i: PolygonRule.build(self.many_rows[i][1], self.many_rows[i][4], domain_tolerance=tolerance,
                                      zero_row_tolerance=zero_row_tolerance, radius_cap=radius_cap)
                 for i in self.many if self.p[i] == 2}
        self.polygons = {i: rule for i, rule in rules.items() if rule is not None}
        """The closed-form rule of each mode with two ambiguity variables where it applies (the
        engine's, :func:`frcontrol.engine.polygon_rule`, built once: it does not depend on u)."""
        self.H_w1 = _padded([r[1][:, 0] if r[1].shape[1] == 1 else np.zeros(0) for r in rows], width, (), 0.0)
        self.X_u = _padded([x.response.X_u for x in modes], nx, (m,), 0.0)
        self.x_0 = _padded([x.response.x_0 for x in modes], nx, (), 0.0)
        self.X_w = np.ascontiguousarray(
            _padded([x.response.X_w.T for x in modes], self.p_max, (nx,), 0.0).transpose(0, 2, 1))
        g_rows = int(self.inequality_rows.max(initial=0))
        self.K = _padded([_output_map(problem, x.system, g_rows) for x in modes], 2 * problem.k + nx + g_rows,
                         (nx + m + 1,), 0.0)
        self.kernel_arguments = (self.H_u, self.h_0, self.norms, self.motion, self.H_w1, self.p,
                                 self.row_count, self.inequality_rows, self.X_u, self.X_w, self.x_0, self.K,
                                 tolerance, zero_row_tolerance, radius_cap)
        """The table as the compiled kernel's ``locate_points``, ``evaluate_points`` and
        ``query_point`` take it (their first 15 arguments)."""
        self.plan = self._plan()
        """The compiled kernel's hold on the table for the single query in one call
        (``query_solutions``), or None without a compiled kernel."""

    def _plan(self) -> Any:
        """:attr:`plan`: the compiled kernel's ``query_plan`` of this table."""
        if compiled is None:
            return None
        limits = (np.ascontiguousarray(self.problem.lower, dtype=float),
                  np.ascontiguousarray(self.problem.upper, dtype=float))
        names = tuple(self.problem.inputs)
        made_of = (self.solution_type, self.modes, self.ambiguous_outputs, np.empty, names, np.float64)
        sizes = (self.input_slack, self.n, self.k)
        return compiled.query_plan(*self.kernel_arguments, *made_of, *limits, *sizes)

    def solutions(self, found: PointSolutions) -> list[Any]:
        """:meth:`point`'s answer as solutions, one ``solution_type`` per mode holding, in mode order.

        Each is made by ``object.__new__`` with its fields set at once in its ``__dict__`` (what the
        frozen dataclass's ``__init__`` makes, equal and still frozen, without its eleven
        ``object.__setattr__`` calls: tests/test_query.py); its arrays are views of ``found``'s.
        """
        rows, x, w, acc, residual, violation = found
        n, k, dims, outputs, modes = self.n, self.k, self.p_list, self.ambiguous_outputs, self.modes
        made = []
        for i in rows:
            solution: Any = object.__new__(self.solution_type)
            solution.__dict__.update({
                "mode": modes[i], "dv": x[i, :n], "lambda_n": x[i, n:n + k], "lambda_t": x[i, n + k:],
                "a_n": acc[i, :k], "a_t": acc[i, k:], "ambiguity_dim": dims[i],
                "ambiguous_outputs": outputs[i], "w": w[i, :dims[i]], "equality_residual": float(residual[i]),
                "inequality_violation": float(violation[i])})
            made.append(solution)
        return made

    def slacks(self, U: np.ndarray) -> np.ndarray:
        """Every row's slack ``(h_0 - H_u u) / norm`` at the inputs ``U`` (C, m): (C, modes, rows)."""
        count, rows, m = self.H_u.shape
        if count * rows == 0:
            return np.ones((U.shape[0], count, rows))
        return (self.h_0 - (U @ self.H_u.reshape(count * rows, m).T).reshape(-1, count, rows)) / self.norms

    def decide(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The NumPy twin of the kernel's ``locate_points``: a status per input and mode, and w.

        Per input of ``U`` (C, m) and mode: ``QUERY_OUTSIDE`` 0, ``QUERY_INSIDE`` 1 or
        ``QUERY_NEEDS_PYTHON`` 2 (two or more ambiguity variables, consistent), and the
        representative w of a one-variable mode: (C, modes) each.
        """
        h, tol = self.slacks(U), self.tolerance
        ok = np.asarray(~np.where(self.motion, h <= tol, h < -tol).any(axis=-1))
        w = np.zeros(ok.shape)
        one = self.one
        if one.size:
            points, rows = h.shape[0], h.shape[2]
            flat = (points * one.size, rows)
            a, h_one, motion, valid = (part.reshape(flat) for part in np.broadcast_arrays(
                self.H_w1[one], h[:, one], self.motion[one], self.valid[one]))
            admissible, centre = decide_intervals(a, h_one, motion, valid, tol, self.zero_row_tolerance,
                                                  self.radius_cap)
            ok[:, one] = admissible.reshape(points, one.size)
            w[:, one] = centre.reshape(points, one.size)
        status: np.ndarray = ok.astype(np.int8)
        for i in self.many:
            start, end = self.inequality_rows[i], self.row_count[i]
            status[:, i] = 2 * np.all(h[:, i, start:end] >= -tol, axis=1)
        return status, w

    def _located(self, U: np.ndarray, decide_w: WDecider) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The (point, mode) pairs holding, in point then mode order, and their w (S, p_max)."""
        status, w1 = backend().locate_points(self, U)
        point, index = (np.ascontiguousarray(a) for a in np.nonzero(status))  # views of one (S, 2) array
        w = np.zeros((point.size, self.p_max))
        if self.one.size:
            w[:, 0] = w1[point, index]
        if self.many:
            keep = self._decide_many(U, point, index, w, decide_w)
            point, index, w = point[keep], index[keep], w[keep]
        return point, index, w

    def _decide_many(self, U: np.ndarray, point: np.ndarray, index: np.ndarray, w: np.ndarray,
                     decide_w: WDecider) -> np.ndarray:
        """The engine's LPs for the pairs whose mode has two or more ambiguity variables (fills ``w``).

        Returns the mask of the pairs that hold.
        """
        keep = np.ones(point.size, dtype=bool)
        for s in np.flatnonzero(self.p[index] >= 2).tolist():
            found = self._admissible_w(int(index[s]), U[point[s]], decide_w)
            if found is None:
                keep[s] = False
            else:
                w[s, :found.size] = found
        return keep

    def _admissible_w(self, i: int, u: np.ndarray, decide_w: WDecider) -> np.ndarray | None:
        """The engine's w of mode ``i`` (two or more ambiguity variables, consistent) at ``u``, or None.

        By the mode's closed-form rule where it has one (:attr:`polygons`), else by ``decide_w``.
        """
        H_u, H_w, h_0, norms, motion = self.many_rows[i]
        # the slice as the engine computes it, to the last bit: the representative is one vertex of
        # the Chebyshev centres, which round-off may move to another
        h = (h_0 - H_u @ u) / norms
        rule = self.polygons.get(i)
        return rule.decide(h) if rule is not None else decide_w(H_w, h, motion)

    def _evaluate_many(self, u: np.ndarray, i: int, decide_w: WDecider,
                       rows: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                       kernel: Any) -> int:
        """Mode ``i`` (two or more ambiguity variables, consistent at ``u``) by the engine's rule for w.

        When it holds, its solution is written into row ``i`` of ``rows`` (x, acc, residual,
        violation, w) by ``kernel.evaluate_points`` (the compiled kernel); returns 1 if it holds, else 0.
        """
        found = self._admissible_w(i, u, decide_w)
        if found is None:
            return 0
        x, acc, residual, violation, w = rows
        w[i, :found.size] = found
        kernel.evaluate_points(*self.kernel_arguments, u.reshape(1, -1), _ZERO_INDEX, np.array([i]),
                               w[i:i + 1], x[i:i + 1], acc[i:i + 1], residual[i:i + 1], violation[i:i + 1])
        return 1

    def evaluate(self, U: np.ndarray, point: np.ndarray, index: np.ndarray, w: np.ndarray) -> Located:
        """The solutions of modes ``index`` (S,) at inputs ``U[point]``, ambiguity values ``w`` (S, p_max).

        The compiled kernel's ``evaluate_points``, or its NumPy twin.
        """
        return backend().evaluate_points(self, U, point, index, w)

    def locate(self, u: np.ndarray, decide_w: WDecider) -> Located:
        """The modes holding the input ``u`` (m,), already checked, with their solutions.

        With the compiled kernel, one ``query_point`` call locates and evaluates (the LPs of modes
        with two or more ambiguity variables, where their consistency holds, then run in Python).
        """
        holding, x, w, acc, residual, violation = self.point(u, decide_w)
        k = self.k
        return Located(np.array(holding, dtype=np.int64), holding, x, w, acc[:, :k], acc[:, k:], residual,
                       violation)

    def point(self, u: np.ndarray, decide_w: WDecider) -> PointSolutions:
        """:meth:`locate` as bare arrays, row ``i`` mode ``i`` (the single query's lean path).

        The kernel's ``query_point`` (:func:`frcontrol.kernel.backend`): compiled, one call locates
        and evaluates every mode, and the modes with two or more ambiguity variables whose
        consistency holds are then decided here (:meth:`_evaluate_many`); its NumPy twin locates and
        evaluates by :meth:`_located` and :meth:`evaluate`.
        """
        return backend().query_point(self, u, decide_w)

    def locate_batch(self, U: np.ndarray, decide_w: WDecider, chunk: int | None = None) -> BatchSolutions:
        """Every solution at each input of ``U`` (N, m), already checked (:class:`BatchSolutions`).

        The points are decided :data:`BATCH_CHUNK_POINTS` at a time (``chunk`` overrides it).
        """
        chunk = chunk or BATCH_CHUNK_POINTS
        parts: list[tuple[np.ndarray, Located]] = []
        for start in range(0, U.shape[0], chunk):
            block = U[start:start + chunk]
            point, index, w = self._located(block, decide_w)
            parts.append((point + start, self.evaluate(block, point, index, w)))
        return self._batch(U, parts)

    def _batch(self, U: np.ndarray, parts: list[tuple[np.ndarray, Located]]) -> BatchSolutions:
        """The chunks' solutions joined into one :class:`BatchSolutions` (already in point order)."""
        n, k = self.problem.n, self.problem.k

        def joined(pick: Callable[[Located], np.ndarray], width: int) -> np.ndarray:
            arrays = [pick(found) for _, found in parts]
            return np.concatenate(arrays) if arrays else np.zeros((0, width))

        point = np.concatenate([p for p, _ in parts]) if parts else np.zeros(0, dtype=np.int64)
        index = joined(lambda f: f.index, 0).astype(np.int64).reshape(-1)
        x = joined(lambda f: f.x, n + 2 * k)
        count = np.bincount(point, minlength=U.shape[0])
        offsets = np.zeros(U.shape[0] + 1, dtype=np.int64)
        np.cumsum(count, out=offsets[1:])
        return BatchSolutions(
            inputs=U, modes=self.modes, count=count, offsets=offsets, point=point, mode_index=index,
            dv=x[:, :n], lambda_n=x[:, n:n + k], lambda_t=x[:, n + k:], a_n=joined(lambda f: f.a_n, k),
            a_t=joined(lambda f: f.a_t, k), ambiguity_dim=self.p[index], w=joined(lambda f: f.w, self.p_max),
            equality_residual=joined(lambda f: f.equality_residual, 0).reshape(-1),
            inequality_violation=joined(lambda f: f.inequality_violation, 0).reshape(-1),
            ambiguous_outputs=self.ambiguous_outputs, tolerance=self.tolerance)


_ZERO_INDEX = np.zeros(1, dtype=np.int64)
"""Point 0: the one input of a single query (read only by the kernel)."""

BATCH_CHUNK_POINTS = 2048
"""Inputs decided together by :meth:`QueryTable.locate_batch`: its temporary arrays hold this many
points times every mode's rows (about 0.3 MB per 1000 row-points), so memory stays bounded at any N."""


def check_inputs(problem: ContactProblem, inputs: Any, tolerance: float = BOUNDARY_TOLERANCE) -> np.ndarray:
    """A batch of inputs as a float (N, m) array, checked: finite and within the limits (to ``tolerance``).

    Raises:
        InputError: not an (N, m) array of numbers, a NaN or infinite entry, or an input outside its
            limits (the first such point and input are named).
    """
    try:
        U = np.asarray(inputs, dtype=float)
    except (TypeError, ValueError) as err:
        raise InputError(f"a batch of inputs must be an (N, {problem.m}) array of numbers: {err}") from err
    if U.ndim != 2 or U.shape[1] != problem.m:
        raise InputError(f"a batch of inputs must have shape (N, {problem.m}) (inputs "
                         f"{', '.join(problem.inputs) or 'none'}); got shape {U.shape}")
    bad = ~np.isfinite(U)
    if bad.any():
        i, j = np.argwhere(bad)[0].tolist()
        raise InputError(f"point {i} of the batch has a NaN or infinite entry: {U[i].tolist()}")
    outside = (U < problem.lower - tolerance) | (U > problem.upper + tolerance)
    if outside.any():
        i, j = np.argwhere(outside)[0].tolist()
        raise InputError(f"point {i} of the batch: input {problem.inputs[j]!r} = {U[i, j]:g} is outside its "
                         f"limits [{problem.lower[j]:g}, {problem.upper[j]:g}]")
    return np.ascontiguousarray(U)  # the kernel reads it row by row


# ------------------------------------------------------------------ the kernel's functions
# Each query step has its compiled implementation and its NumPy twin (the reference), registered
# with the kernel (frcontrol.kernel.twin) and called through frcontrol.kernel.backend().


def _locate_points_numpy(table: QueryTable, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every point of ``U`` (N, m) against every mode: status (N, modes) and w (N, modes), in NumPy."""
    return table.decide(U)


def _locate_points_compiled(table: QueryTable, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_locate_points_numpy` by the compiled kernel's ``locate_points``."""
    status = np.empty((U.shape[0], len(table.modes)), dtype=np.int8)
    w1 = np.empty(status.shape)
    compiled.locate_points(*table.kernel_arguments, U, status, w1)  # type: ignore[union-attr]
    return status, w1


def _evaluate_points_numpy(table: QueryTable, U: np.ndarray, point: np.ndarray, index: np.ndarray,
                           w: np.ndarray) -> Located:
    """:meth:`QueryTable.evaluate` in NumPy (the reference twin)."""
    k, u = table.problem.k, U[point]
    x = (np.matmul(table.X_u[index], u[:, :, None]) + np.matmul(table.X_w[index], w[:, :, None]))[:, :, 0]
    x += table.x_0[index]
    z = np.concatenate([x, u, np.ones((x.shape[0], 1))], axis=1)
    y = np.matmul(table.K[index], z[:, :, None])[:, :, 0]
    nx = x.shape[1]
    return Located(index, range(index.size), x, w, y[:, :k], y[:, k:2 * k],
                   np.abs(y[:, 2 * k:2 * k + nx]).max(axis=1, initial=0.0),
                   y[:, 2 * k + nx:].max(axis=1, initial=0.0))


def _evaluate_points_compiled(table: QueryTable, U: np.ndarray, point: np.ndarray, index: np.ndarray,
                              w: np.ndarray) -> Located:
    """:meth:`QueryTable.evaluate` by the compiled kernel's ``evaluate_points``."""
    k = table.problem.k
    x = np.empty((point.size, table.X_u.shape[1]))
    acc, residual, violation = np.empty((point.size, 2 * k)), np.empty(point.size), np.empty(point.size)
    compiled.evaluate_points(  # type: ignore[union-attr]
        *table.kernel_arguments, U, point, index, w, x, acc, residual, violation)
    return Located(index, range(index.size), x, w, acc[:, :k], acc[:, k:], residual, violation)


def _query_point_numpy(table: QueryTable, u: np.ndarray, decide_w: WDecider) -> PointSolutions:
    """:meth:`QueryTable.point` in NumPy (the reference twin), each solution in its mode's row."""
    U = u.reshape(1, -1)
    point, index, w = table._located(U, decide_w)
    found = table.evaluate(U, point, index, w)
    count, k = len(table.modes), table.k
    holding = found.index.tolist()
    rows = list(found.rows)
    x, every_w = np.zeros((count, found.x.shape[1])), np.zeros((count, max(found.w.shape[1], 1)))
    acc, residual, violation = np.zeros((count, 2 * k)), np.zeros(count), np.zeros(count)
    x[holding] = found.x[rows]
    every_w[holding, :found.w.shape[1]] = found.w[rows]
    acc[holding, :k], acc[holding, k:] = found.a_n[rows], found.a_t[rows]
    residual[holding], violation[holding] = found.equality_residual[rows], found.inequality_violation[rows]
    return PointSolutions(holding, x, every_w, acc, residual, violation)


def _query_point_compiled(table: QueryTable, u: np.ndarray, decide_w: WDecider) -> PointSolutions:
    """:meth:`QueryTable.point` by the compiled kernel's ``query_point``."""
    count, nx, k = len(table.modes), table.X_u.shape[1], table.k
    status = np.empty(count, dtype=np.int8)
    w1, residual, violation = np.empty(count), np.empty(count), np.empty(count)
    x, acc = np.empty((count, nx)), np.empty((count, 2 * k))
    compiled.query_point(  # type: ignore[union-attr]
        *table.kernel_arguments, u, status, w1, x, acc, residual, violation)
    codes = status.tolist()
    w = w1[:, None] if table.p_max <= 1 else np.zeros((count, table.p_max))
    if table.many:
        w[:, 0] = w1
        for i in [i for i, code in enumerate(codes) if code == 2]:
            codes[i] = table._evaluate_many(u, i, decide_w, (x, acc, residual, violation, w), compiled)
    holding = [i for i, code in enumerate(codes) if code == 1]
    return PointSolutions(holding, x, w, acc, residual, violation)


def plain_input(table: QueryTable, inputs: Any) -> np.ndarray | None:
    """The input vector of ``inputs`` when the single query's one call takes it, else None.

    Plain: a list or tuple of m plain numbers, a one-dimensional float64 buffer (a NumPy array) of
    m entries, or a dict ``{input name: plain number}`` (the others 0), where a plain number is an
    ``int``, a ``float`` or a ``numpy.float64`` and a name a ``str``, each of exactly that type (not
    a subclass, whose methods could differ); every entry finite and within its limits to the
    table's ``input_slack``. Anything else (a batch, another type, an unknown name, a bad value) goes
    the general way, which raises the typed error of a bad one. The compiled kernel's
    ``query_solutions`` applies the same rule.
    """
    m, names = table.problem.m, list(table.problem.inputs)
    if type(inputs) is dict:
        u = np.zeros(m)
        for name, value in inputs.items():
            if type(name) is not str or name not in names or type(value) not in _PLAIN_NUMBERS:
                return None
            try:
                u[names.index(name)] = float(value)
            except OverflowError:  # an int too large for a float
                return None
    elif type(inputs) in (list, tuple):
        if len(inputs) != m or any(type(value) not in _PLAIN_NUMBERS for value in inputs):
            return None
        try:
            u = np.array([float(value) for value in inputs])
        except OverflowError:  # an int too large for a float
            return None
    else:
        try:
            view = memoryview(inputs)
        except (TypeError, ValueError, BufferError):  # not a buffer, or a dtype no buffer can hold
            return None
        code = view.format[1:] if view.format[:1] in ("@", "=", "<") else view.format
        if view.ndim != 1 or view.shape is None or view.shape[0] != m or code != "d":
            return None
        u = np.array(view, dtype=float)
    slack, problem = table.input_slack, table.problem
    if not np.isfinite(u).all() or (u < problem.lower - slack).any() or (u > problem.upper + slack).any():
        return None
    return u


_PLAIN_NUMBERS = (float, int, np.float64)
"""The types of a plain input's numbers (:func:`plain_input`)."""


def _no_lp(H_w: np.ndarray, h: np.ndarray, motion: np.ndarray) -> np.ndarray | None:
    """The one call's w decider, never called.

    The call declines where a mode of two or more ambiguity variables is consistent, the only mode
    that asks for w.
    """
    raise AssertionError("a mode with two or more ambiguity variables in the single query's one call")


def _query_solutions_numpy(table: QueryTable, inputs: Any) -> list[Any] | None:
    """The single query on an analysis in one call, in NumPy (the reference of ``query_solutions``).

    Every solution at ``inputs`` (:meth:`QueryTable.solutions`), or None where the general path
    answers: ``inputs`` not plain (:func:`plain_input`), or a mode with two or more ambiguity
    variables whose consistency rows hold there (its w is the engine's LP).
    """
    u = plain_input(table, inputs)
    if u is None or (table.many and (table.decide(u[None])[0] == 2).any()):
        return None
    return table.solutions(_query_point_numpy(table, u, _no_lp))


def _query_solutions_compiled(table: QueryTable, inputs: Any) -> list[Any] | None:
    """:func:`_query_solutions_numpy` by the compiled kernel's ``query_solutions`` on the table's plan."""
    return None if table.plan is None else compiled.query_solutions(table.plan, inputs)  # type: ignore[union-attr]


twin("locate_points", numpy=_locate_points_numpy, compiled=_locate_points_compiled)
twin("evaluate_points", numpy=_evaluate_points_numpy, compiled=_evaluate_points_compiled)
twin("query_point", numpy=_query_point_numpy, compiled=_query_point_compiled)
twin("query_solutions", numpy=_query_solutions_numpy, compiled=_query_solutions_compiled)


__all__ = ["BATCH_CHUNK_POINTS", "BatchSolutions", "BOUNDARY_TOLERANCE", "check_inputs", "Located",
           "plain_input", "PointSolutions", "QueryMode", "QueryTable", "WDecider"]
