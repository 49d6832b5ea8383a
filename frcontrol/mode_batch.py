"""Every full contact mode at one input, in one vectorised pass (the fast path of ``solutions_at``).

The engine's reference path grows modes contact by contact and decides each (partial) mode with
linear programs. At one input ``u`` most of that work has a closed form, and a small problem's
modes (4^k at most, 64 for RHex) fit in one stack of matrices:

1. Every full mode's ``A`` (the dynamics rows, then two rows per contact from the contact row
   table) is stacked into one ``(modes, nx, nx)`` array and equilibrated by powers of two exactly
   as :func:`frcontrol.response.solve_affine` does.
2. A mode whose equilibrated ``A`` is certified well conditioned (``||A||_F ||A^-1||_F`` a margin
   below the rank thresholds, :data:`CERTIFIED_MARGIN`: the SVD would find full rank outside the
   ill-conditioned band) is solved by one stacked LU: its unique response ``x = X_u u + x_0`` is
   checked against its inequalities at ``u``, all such modes at once (rows normalised by their
   norm in u; non-motion rows to :data:`~frcontrol.engine.DOMAIN_TOLERANCE`, motion rows
   strictly).
3. The other modes get one batched SVD and the rank rule of ``solve_affine``, grouped by rank:
   each group's responses ``x = X_u u + X_w w + x_0`` and consistency conditions ``E u = e`` by
   the formulas of ``solve_affine``, for the whole group at once, their inequalities sliced at
   ``u`` (rows normalised in (u, w)). A mode with ambiguity variables w is decided by the engine's
   rule for w, one mode at a time: with one variable the admissible set is an interval, decided
   in closed form by :func:`interval_admissible` instead of two LPs; with more, by the engine's
   LPs.

Steps 1-2, and step 3 for modes with at most one ambiguity variable, run in a compiled kernel
(:mod:`frcontrol._kernel`, chosen by ``FRC_KERNEL``: :mod:`frcontrol.kernel`) where it is built:
the same formulas one mode at a time in C, after NumPy's batched SVD for step 3. The NumPy code
here is the reference and the fallback; the tests cross-check the two.

Where the internal forces are not unique, the representative w may differ from the reference's
when its admissible set is wider than twice ``CHEBYSHEV_RADIUS_CAP``: both are Chebyshev centres
of the capped ball (the midpoint here, a vertex of the centres there). Otherwise nothing here
decides differently from the reference: the same rows, the same equilibration, the
same rank rule (a singular value in the ill-conditioned band, or a rank drop round-off does not
explain, sends the whole problem back to the reference path, which raises only where it meets that
mode) and the same tolerances. The tests cross-check both paths on random scenes and inputs.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .errors import KernelError
from .kernel import backend, compiled, twin
from .modes import MODE_LETTERS, ROWS_PER_CONTACT, ContactProblem, needs_balancing
from .response import (
    CERTIFIED_MARGIN,
    CONSISTENCY_TOLERANCE,
    ILL_CONDITIONED_BAND,
    OUTPUT_TOLERANCE,
    AmbiguousOutputs,
    equilibrate_stack,
    outputs_moved_by,
    rebalance_undecided,
)

BATCH_MAX_MODES = 1024
"""The fast path stacks every full mode when there are at most this many (4^5); larger problems
(the snake with 8 contacts: 65 536 modes) keep the reference path, whose pruning of partial modes
pays off there."""


WDecider = Callable[[np.ndarray, np.ndarray, np.ndarray], "np.ndarray | None"]
"""``decide(H_w, h_w, motion) -> w or None``: the engine's admissible ambiguity variables at one
input, from the mode's inequalities in w (rows normalised in (u, w))."""


@dataclass(frozen=True)
class BatchSolution:
    """One mode admissible at the input: ``x = (dv, lam_N, lam_T)`` at the representative ``w``.

    Attributes:
        mode: the mode string; x: (nx,); w: (p,) the ambiguity variables chosen.
        ambiguous_outputs: ``"none"``, ``"forces"`` or ``"accelerations"`` (what w moves).
        equality_residual: ``max |A x - B u - c|``; inequality_violation: ``max(G x - g, 0)``.
    """

    mode: str
    x: np.ndarray
    w: np.ndarray
    ambiguous_outputs: AmbiguousOutputs
    equality_residual: float
    inequality_violation: float


@dataclass(frozen=True)
class ModeBatch:
    """The full modes of a problem at one input, decided together.

    Attributes:
        modes: every full mode, in the reference path's order (letters S, L, R, F, contact by
            contact).
        solutions: the admissible ones, in that order.
        ill_conditioned: some mode has a singular value in the ill-conditioned band or a rank drop
            round-off does not explain (then nothing was decided: the reference path decides, and
            raises where it meets that mode).
    """

    modes: tuple[str, ...]
    solutions: tuple[BatchSolution, ...]
    ill_conditioned: bool


@lru_cache(maxsize=256)
def full_modes(allowed: tuple[str, ...]) -> tuple[tuple[str, ...], np.ndarray]:
    """Every full mode from per-contact allowed letters, and their letter indices (modes, k).

    Cached: the result is shared, do not modify the array.
    """
    k = len(allowed)
    if k == 0:
        return ("",), np.zeros((1, 0), dtype=int)
    # the first contact's letter varies slowest (numpy.meshgrid's "ij" order, without its limit of
    # 32 arrays: a robot may touch with more contacts than that)
    choices = [[MODE_LETTERS.index(ch) for ch in letters] for letters in allowed]
    letters = np.array(list(itertools.product(*choices)), dtype=int).reshape(-1, k)
    letters.setflags(write=False)
    modes = tuple("".join(MODE_LETTERS[j] for j in row) for row in letters.tolist())
    return modes, letters


_equilibrate = equilibrate_stack
"""Row and column scalings of the modes' stack (:func:`frcontrol.response.equilibrate_stack`)."""


@dataclass(frozen=True)
class _Stack:
    """Every full mode's system at one input, stacked: ``A x = B u + c``, ``G x <= g``."""

    A: np.ndarray  # (modes, nx, nx)
    B: np.ndarray  # (modes, nx, m)
    c: np.ndarray  # (modes, nx)
    rhs: np.ndarray  # (modes, nx): B u + c
    G: np.ndarray  # (modes, rows, nx), rows = ROWS_PER_CONTACT k, padded
    g: np.ndarray  # (modes, rows)
    valid: np.ndarray  # (modes, rows): which padded rows exist
    motion: np.ndarray  # (modes, rows)


def _stack(problem: ContactProblem, letters: np.ndarray, u: np.ndarray) -> _Stack:
    n, k, m = problem.n, problem.k, problem.m
    nx, count = n + 2 * k, letters.shape[0]
    table = problem.row_table
    contacts = np.arange(k)
    A = np.empty((count, nx, nx))
    A[:, :n] = problem.dynamics
    A[:, n:] = table.equalities[contacts, letters].reshape(count, 2 * k, nx)
    B = np.zeros((count, nx, m))
    B[:, :n] = problem.input_map
    c = np.empty((count, nx))
    c[:, :n] = -problem.bias
    c[:, n:] = table.equality_rhs[contacts, letters].reshape(count, 2 * k)
    rhs = c.copy()
    rhs[:, :n] += problem.input_map @ u
    return _Stack(A, B, c, rhs,
                  table.inequalities[contacts, letters].reshape(count, -1, nx),
                  table.inequality_rhs[contacts, letters].reshape(count, -1),
                  table.valid[contacts, letters].reshape(count, -1),
                  table.motion[contacts, letters].reshape(count, -1))


# CERTIFIED_MARGIN (frcontrol.response): a mode skips the SVD when ``||A||_F ||A^-1||_F`` (of the
# equilibrated A, a bound on its 2-norm condition number) is below
# ``1 / (CERTIFIED_MARGIN max(rank_tolerance, ILL_CONDITIONED_BAND))``: its smallest singular value is
# then certainly above both thresholds, so the SVD would find full rank outside the ill-conditioned
# band, and an LU solve gives the same unique response.


def decide_modes(problem: ContactProblem, u: np.ndarray, decide_w: WDecider, *, rank_tolerance: float,
                 domain_tolerance: float, zero_row_tolerance: float, radius_cap: float,
                 allowed: tuple[str, ...] | None = None) -> ModeBatch:
    """Stack, factorise and decide every full mode at ``u`` (see the module docstring).

    Well-conditioned modes are certified by a cheap bound (:data:`CERTIFIED_MARGIN`) and solved
    by LU, in the kernel ``FRC_KERNEL`` chooses (:mod:`frcontrol.kernel`); the others get the SVD
    and its rank rule.

    Args:
        problem: the contact problem.
        u: the input (m,), already checked.
        decide_w: how a mode with ambiguity variables picks its w (the engine's rule).
        rank_tolerance: relative singular-value threshold of the rank decisions.
        domain_tolerance: the engine's membership distance.
        zero_row_tolerance: the engine's constant-row threshold.
        radius_cap: the Chebyshev LP's radius cap (for a side of an interval without a bound).
        allowed: ``problem.allowed_modes()`` when the caller has it already.

    Raises:
        KernelError: ``FRC_KERNEL`` names no kernel, or the compiled one where it is not built.
    """
    modes, letters = full_modes(problem.allowed_modes() if allowed is None else allowed)
    tolerances = (domain_tolerance, zero_row_tolerance, radius_cap)
    return backend().decide_modes(problem, modes, letters, u, decide_w, rank_tolerance, tolerances)


def _numpy_modes(problem: ContactProblem, modes: tuple[str, ...], letters: np.ndarray, u: np.ndarray,
                 decide_w: WDecider, rank_tolerance: float, tolerances: tuple[float, float, float]
                 ) -> ModeBatch:
    """:func:`decide_modes` in NumPy: the reference twin of :func:`_compiled_modes`."""
    domain_tolerance, zero_row_tolerance, _ = tolerances
    st = _stack(problem, letters, u)
    r_scale, c_scale = _equilibrate(st.A)
    A_hat = st.A * r_scale[:, :, None] * c_scale[:, None, :]
    certified, x, X_u = _certified_responses(problem, st, A_hat, r_scale, c_scale, rank_tolerance)
    found = _decide_full_rank(problem, modes, st, certified, x, X_u, u, domain_tolerance,
                              zero_row_tolerance)
    rest = np.nonzero(~certified)[0]
    if rest.size:
        others = _svd_modes(problem, modes, st, A_hat, r_scale, c_scale, rest, u, decide_w, rank_tolerance,
                            tolerances)
        if others is None:
            return ModeBatch(modes, (), True)
        found.update(others)
    return ModeBatch(modes, tuple(found[i] for i in sorted(found)), False)


def _svd_modes(problem: ContactProblem, modes: tuple[str, ...], st: _Stack, A_hat: np.ndarray,
               r_scale: np.ndarray, c_scale: np.ndarray, rest: np.ndarray, u: np.ndarray,
               decide_w: WDecider, rank_tolerance: float, tolerances: tuple[float, float, float]
               ) -> dict[int, BatchSolution] | None:
    """The modes ``rest`` (indices into ``st`` and ``modes``) by one batched SVD and the rank rule.

    None when a singular value lies in the ill-conditioned band, or a rank drop is not round-off's
    (:func:`~frcontrol.response.rebalance_undecided`): nothing is decided then.
    """
    a_hat, r_scale, c_scale = A_hat[rest], r_scale[rest], c_scale[rest]
    U, s, Vt = np.linalg.svd(a_hat)
    undecided, _ = rebalance_undecided(a_hat, r_scale, c_scale, (U, s, Vt), rank_tolerance,
                                       needs_balancing(problem, [modes[i] for i in rest]))
    s_max = s[:, :1]
    kept = s > rank_tolerance * s_max
    if undecided.size or (kept & (s <= ILL_CONDITIONED_BAND * s_max)).any():
        return None
    scaled = _Scaled(U, s, Vt, r_scale, c_scale, st.B[rest] * r_scale[:, :, None], st.c[rest] * r_scale)
    return _decide_by_rank(problem, modes, st, scaled, rest, rank_tolerance, u, decide_w, tolerances)


def _decide_by_rank(problem: ContactProblem, modes: tuple[str, ...], st: _Stack, sc: _Scaled,
                    rest: np.ndarray, rank_tolerance: float, u: np.ndarray, decide_w: WDecider,
                    tolerances: tuple[float, float, float]) -> dict[int, BatchSolution]:
    """The SVD's modes (``sc``, for ``rest`` of ``st``) by :func:`_decide_rank_group`, rank by rank."""
    rank = np.where(sc.s[:, 0] > 0.0, (sc.s > rank_tolerance * sc.s[:, :1]).sum(axis=1), 0)
    found: dict[int, BatchSolution] = {}
    for r in np.unique(rank):
        group = np.nonzero(rank == r)[0]
        found.update(_decide_rank_group(problem, modes, st, sc, rest, group, int(r), u, decide_w, tolerances))
    return found


def _compiled_modes(problem: ContactProblem, modes: tuple[str, ...], letters: np.ndarray, u: np.ndarray,
                    decide_w: WDecider, rank_tolerance: float, tolerances: tuple[float, float, float]
                    ) -> ModeBatch:
    """:func:`decide_modes` with the compiled kernel (:mod:`frcontrol._kernel`).

    ``certified_modes`` does what :func:`_stack`, :func:`_equilibrate`, :func:`_certified_responses`
    and :func:`_decide_full_rank` do, one mode at a time in C; the other modes get NumPy's batched
    SVD, then ``rank_modes`` (:func:`_compiled_rank_modes`).
    """
    assert compiled is not None  # the compiled backend runs only where it is built
    domain_tolerance, zero_row_tolerance, _ = tolerances
    count, nx = letters.shape[0], problem.n + 2 * problem.k
    rows = _compiled_rows(problem)
    vectors = (np.ascontiguousarray(problem.input_map, dtype=float),
               np.ascontiguousarray(problem.bias, dtype=float), np.ascontiguousarray(u, dtype=float))
    status, residual, violation = np.empty(count, dtype=np.int8), np.empty(count), np.empty(count)
    x, a_hat = np.empty((count, nx)), np.empty((count, nx, nx))
    r_scale, c_scale = np.empty((count, nx)), np.empty((count, nx))
    compiled.certified_modes(*rows, letters, *vectors, status, x, residual, violation, a_hat, r_scale,
                             c_scale, CERTIFIED_MARGIN, max(rank_tolerance, ILL_CONDITIONED_BAND),
                             domain_tolerance, zero_row_tolerance)
    empty = np.zeros(0)
    codes = status.tolist()  # (a Python loop over the modes: cheaper than NumPy's on a few dozen)
    found = {i: BatchSolution(modes[i], x[i], empty, "none", float(residual[i]), float(violation[i]))
             for i, code in enumerate(codes) if code == compiled.CERTIFIED_ADMISSIBLE}
    if compiled.NOT_CERTIFIED in codes:
        rest = np.array([i for i, code in enumerate(codes) if code == compiled.NOT_CERTIFIED])
        others = _compiled_rank_modes(problem, modes, letters, rest, (rows, vectors),
                                      (a_hat[rest], r_scale[rest], c_scale[rest]), u, decide_w,
                                      rank_tolerance, tolerances)
        if others is None:
            return ModeBatch(modes, (), True)
        found.update(others)
    return ModeBatch(modes, tuple(found[i] for i in sorted(found)), False)


def _compiled_rows(problem: ContactProblem) -> tuple[np.ndarray, ...]:
    """``problem.dynamics`` and the arrays of ``problem.row_table``, by the compiled kernel.

    ``contact_rows`` writes :func:`frcontrol.modes.dynamics_rows` and
    :func:`~frcontrol.modes.contact_row_table` bit for bit (every entry is one of the problem's
    numbers, its negative, -max(1, mu), 0, 1 or -1), in one call instead of NumPy's gathers. A
    problem whose table is built already keeps it; one whose arrays the kernel does not take (not
    float64) gets NumPy's.
    """
    if "row_table" in problem.__dict__:  # built already (a cached property)
        table = problem.row_table
        return (problem.dynamics, table.equalities, table.equality_rhs, table.inequalities,
                table.inequality_rhs, table.valid, table.motion)
    n, k = problem.n, problem.k
    nx = n + 2 * k
    pairs, cells = (k, len(MODE_LETTERS), 2), (k, len(MODE_LETTERS), ROWS_PER_CONTACT)
    rows = (np.empty((n, nx)), np.empty(pairs + (nx,)), np.empty(pairs), np.empty(cells + (nx,)),
            np.empty(cells), np.empty(cells, dtype=bool), np.empty(cells, dtype=bool))
    try:
        compiled.contact_rows(  # type: ignore[union-attr]  # only on the compiled path
            problem.mass_matrix, problem.jacobian_normal, problem.jacobian_tangent, problem.drift_normal,
            problem.drift_tangent, problem.mu, problem.normal_velocities, problem.tangential_velocities,
            problem.velocity_tolerance, *rows)
    except KernelError:
        table = problem.row_table
        return (problem.dynamics, table.equalities, table.equality_rhs, table.inequalities,
                table.inequality_rhs, table.valid, table.motion)
    return rows


def _compiled_rank_modes(problem: ContactProblem, modes: tuple[str, ...], letters: np.ndarray,
                         rest: np.ndarray, buffers: tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]],
                         scaled: tuple[np.ndarray, np.ndarray, np.ndarray], u: np.ndarray,
                         decide_w: WDecider, rank_tolerance: float, tolerances: tuple[float, float, float]
                         ) -> dict[int, BatchSolution] | None:
    """The modes ``rest`` by NumPy's batched SVD of their ``A_hat``, then ``rank_modes`` in C.

    ``rank_modes`` applies :func:`_decide_rank_group`'s formulas to the modes with at most one
    ambiguity variable; those with more keep :func:`_decide_rank_group` (their w comes from LPs).
    None when a singular value lies in the ill-conditioned band or a rank drop is not round-off's.
    """
    assert compiled is not None
    rows, vectors = buffers
    a_hat, r_scale, c_scale = scaled
    U, s, Vt = np.linalg.svd(a_hat)
    if rebalance_undecided(a_hat, r_scale, c_scale, (U, s, Vt), rank_tolerance,
                           needs_balancing(problem, [modes[i] for i in rest]))[0].size:
        return None
    count, nx = rest.size, a_hat.shape[1]
    status, residual, violation = np.empty(count, dtype=np.int8), np.empty(count), np.empty(count)
    x, w, outputs = np.empty((count, nx)), np.empty(count), np.empty(count, dtype=np.int8)
    domain_tolerance, zero_row_tolerance, radius_cap = tolerances
    if compiled.rank_modes(*rows, letters[rest], *vectors, U, s, Vt, r_scale, c_scale, status, x, w,
                           outputs, residual, violation, rank_tolerance, ILL_CONDITIONED_BAND,
                           domain_tolerance, zero_row_tolerance, radius_cap, CONSISTENCY_TOLERANCE,
                           OUTPUT_TOLERANCE):
        return None
    empty = np.zeros(0)
    found = {}
    codes = status.tolist()
    for j, code in enumerate(codes):
        if code == compiled.ADMISSIBLE or code == compiled.ADMISSIBLE_W:
            i = int(rest[j])
            found[i] = BatchSolution(modes[i], x[j], w[j:j + 1] if code == compiled.ADMISSIBLE_W else empty,
                                     AMBIGUOUS_OUTPUT_CODES[outputs[j]], float(residual[j]),
                                     float(violation[j]))
    if compiled.NEEDS_PYTHON in codes:
        more = np.array([j for j, code in enumerate(codes) if code == compiled.NEEDS_PYTHON])
        found.update(_python_rank_modes(problem, modes, letters, rest[more], (U[more], s[more], Vt[more]),
                                        r_scale[more], c_scale[more], u, decide_w, rank_tolerance,
                                        tolerances))
    return found


AMBIGUOUS_OUTPUT_CODES: tuple[AmbiguousOutputs, ...] = ("none", "forces", "accelerations")
"""The compiled kernel's ``outputs`` codes (MOVES_NONE, MOVES_FORCES, MOVES_ACCELERATIONS): the names
``rank_modes`` and the one-call query's ``scratch_plan`` read."""


def _python_rank_modes(problem: ContactProblem, modes: tuple[str, ...], letters: np.ndarray,
                       index: np.ndarray, svd: tuple[np.ndarray, np.ndarray, np.ndarray],
                       r_scale: np.ndarray, c_scale: np.ndarray, u: np.ndarray, decide_w: WDecider,
                       rank_tolerance: float, tolerances: tuple[float, float, float]
                       ) -> dict[int, BatchSolution]:
    """The modes ``index`` (two or more ambiguity variables) by :func:`_decide_rank_group`, from their SVD."""
    U, s, Vt = svd
    st = _stack(problem, letters[index], u)
    names = tuple(modes[i] for i in index.tolist())
    scaled = _Scaled(U, s, Vt, r_scale, c_scale, st.B * r_scale[:, :, None], st.c * r_scale)
    decided = _decide_by_rank(problem, names, st, scaled, np.arange(index.size), rank_tolerance, u,
                              decide_w, tolerances)
    return {int(index[j]): sol for j, sol in decided.items()}


def _certified_responses(problem: ContactProblem, st: _Stack, A_hat: np.ndarray, r_scale: np.ndarray,
                         c_scale: np.ndarray, rank_tolerance: float
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which modes are certified well conditioned, with their ``x`` and ``X_u`` (by one LU solve).

    ``A_hat y = [I, diag(r) B, diag(r) (B u + c)]``: the identity's columns give ``A_hat^-1`` for
    the condition bound only (see :data:`CERTIFIED_MARGIN`); ``x = diag(c) y``.
    """
    count, nx, _ = A_hat.shape
    n, m = problem.n, problem.m
    certified = np.zeros(count, dtype=bool)
    x = np.zeros((count, nx))
    X_u = np.zeros((count, nx, m))
    nonsingular = np.nonzero(np.linalg.det(A_hat) != 0.0)[0]  # LU never meets a zero pivot there
    if nonsingular.size == 0:
        return certified, x, X_u
    rhs = np.zeros((nonsingular.size, nx, nx + m + 1))
    rhs[:, :, :nx] = np.eye(nx)
    rhs[:, :n, nx:nx + m] = problem.input_map * r_scale[nonsingular, :n, None]
    rhs[:, :, -1] = st.rhs[nonsingular] * r_scale[nonsingular]
    with np.errstate(over="ignore", invalid="ignore"):  # a nearly singular A: not certified
        y = np.linalg.solve(A_hat[nonsingular], rhs)
        bound = np.sqrt((A_hat[nonsingular] ** 2).sum(axis=(1, 2)) * (y[:, :, :nx] ** 2).sum(axis=(1, 2)))
        good = bound * CERTIFIED_MARGIN * max(rank_tolerance, ILL_CONDITIONED_BAND) < 1.0
    chosen = nonsingular[good]
    certified[chosen] = True
    x[chosen] = c_scale[chosen] * y[good, :, -1]
    X_u[chosen] = c_scale[chosen, :, None] * y[good, :, nx:nx + m]
    return certified, x, X_u


def _decide_full_rank(problem: ContactProblem, modes: tuple[str, ...], st: _Stack, full: np.ndarray,
                      x: np.ndarray, X_u: np.ndarray, u: np.ndarray, domain_tolerance: float,
                      zero_row_tolerance: float) -> dict[int, BatchSolution]:
    """The certified modes (unique response ``x``, ``X_u``): each inequality row at ``u``.

    A lean form of :func:`_decide_rank_group` for ``p = 0``: rows normalised by their norm in u
    alone, non-motion rows to ``domain_tolerance``, motion rows strictly.
    """
    sel = slice(None) if full.all() else np.nonzero(full)[0]
    x, X_u = x[sel], X_u[sel]
    if x.shape[0] == 0:
        return {}
    G, g, valid, motion = st.G[sel], st.g[sel], st.valid[sel], st.motion[sel]
    H_u = np.matmul(G, X_u)
    norms = np.sqrt((H_u * H_u).sum(axis=2))
    largest = np.where(valid, norms, 0.0).max(axis=1, initial=0.0)
    constant = norms <= zero_row_tolerance * np.maximum(1.0, largest)[:, None]
    norms = np.where(constant, 1.0, norms)
    violation = np.matmul(G, x[:, :, None])[:, :, 0] - g
    slack = -violation / norms
    holds = np.where(motion, slack > domain_tolerance, slack >= -domain_tolerance) | ~valid
    admissible = np.nonzero(holds.all(axis=1))[0]
    if admissible.size == 0:
        return {}
    index = np.arange(len(modes))[sel][admissible]
    xs = x[admissible]
    residual = np.max(np.abs(np.matmul(st.A[index], xs[:, :, None])[:, :, 0] - st.rhs[index]), axis=1)
    worst = np.max(np.where(valid[admissible], violation[admissible], 0.0), axis=1, initial=0.0)
    empty = np.zeros(0)
    return {int(i): BatchSolution(modes[i], x_i, empty, "none", float(res), float(bad))
            for i, x_i, res, bad in zip(index, xs, residual, worst, strict=True)}


@dataclass(frozen=True)
class _Scaled:
    """The equilibrated stack's SVD ``diag(r) A diag(c) = U diag(s) V^T`` and the scaled B, c."""

    U: np.ndarray
    s: np.ndarray
    Vt: np.ndarray
    r_scale: np.ndarray
    c_scale: np.ndarray
    Bs: np.ndarray
    cs: np.ndarray


def _decide_rank_group(problem: ContactProblem, modes: tuple[str, ...], st: _Stack, sc: _Scaled,
                       rest: np.ndarray, group: np.ndarray, r: int, u: np.ndarray, decide_w: WDecider,
                       tolerances: tuple[float, float, float]) -> dict[int, BatchSolution]:
    """The modes of one rank r: responses ``x = X_u u + X_w w + x_0`` on ``E u = e``, then their domains.

    The same formulas as :func:`frcontrol.response.solve_affine`, for the whole group at once.
    ``tolerances``: the domain and zero-row tolerances and the radius cap of :func:`decide_modes`.
    """
    domain_tolerance, zero_row_tolerance, radius_cap = tolerances
    index = rest[group]  # the group's modes (``group`` indexes the SVD's modes, ``rest``)
    U, Vt = sc.U[group], sc.Vt[group]
    inv_s = 1.0 / sc.s[group][:, :r]
    c_scale, Bs, cs = sc.c_scale[group], sc.Bs[group], sc.cs[group]
    U1, V1t = U[:, :, :r], Vt[:, :r]
    # with Bc = [B c] scaled: U1^T Bc / s, then diag(c) V1 (...): X_u and x_0 side by side
    Bc = np.concatenate([Bs, cs[:, :, None]], axis=2)
    Xc = c_scale[:, :, None] * np.matmul(np.transpose(V1t, (0, 2, 1)),
                                         inv_s[:, :, None] * np.matmul(np.transpose(U1, (0, 2, 1)), Bc))
    X_u, x_0 = Xc[:, :, :-1], Xc[:, :, -1]
    X_w = c_scale[:, :, None] * np.transpose(Vt[:, r:], (0, 2, 1))
    left = np.matmul(np.transpose(U[:, :, r:], (0, 2, 1)), Bc)  # U2^T [B c]
    ok = _consistent_at(left[:, :, :-1], -left[:, :, -1], _scale_of(Bs, cs), u, domain_tolerance)
    G, valid, motion = st.G[index], st.valid[index], st.motion[index]
    H_u = np.matmul(G, X_u)
    H_w = np.matmul(G, X_w)
    h = st.g[index] - np.matmul(G, x_0[:, :, None])[:, :, 0] - H_u @ u
    norms = np.sqrt((H_u * H_u).sum(axis=2) + (H_w * H_w).sum(axis=2))
    largest = np.where(valid, norms, 0.0).max(axis=1, initial=0.0)
    constant = norms <= zero_row_tolerance * np.maximum(1.0, largest)[:, None]
    norms = np.where(constant, 1.0, norms)
    H_w = np.where(constant[:, :, None], 0.0, H_w / norms[:, :, None])
    h = h / norms
    p = X_w.shape[2]
    if p == 0:
        ok &= np.all(np.where(motion, h > domain_tolerance, h >= -domain_tolerance) | ~valid, axis=1)
    if p == 1:
        admissible, centre = decide_intervals(H_w[:, :, 0], h, motion, valid, domain_tolerance,
                                              zero_row_tolerance, radius_cap)
        ok &= admissible
    out = {}
    for j in np.nonzero(ok)[0]:
        rows = valid[j]
        w: np.ndarray | None
        if p <= 1:
            w = centre[j:j + 1] if p == 1 else np.zeros(0)
        else:
            w = decide_w(H_w[j][rows], h[j][rows], motion[j][rows])
        if w is None:
            continue
        i = int(index[j])
        x = X_u[j] @ u + X_w[j] @ w + x_0[j]
        out[i] = BatchSolution(
            mode=modes[i], x=x, w=w, ambiguous_outputs=outputs_moved_by(X_w[j], problem.n),
            equality_residual=float(np.max(np.abs(st.A[i] @ x - st.rhs[i]), initial=0.0)),
            inequality_violation=float(np.max(st.G[i][rows] @ x - st.g[i][rows], initial=0.0)))
    return out


def _scale_of(Bs: np.ndarray, cs: np.ndarray) -> np.ndarray:
    """Per mode, the scale of ``[B c]`` (what ``CONSISTENCY_TOLERANCE`` is relative to)."""
    top_b = np.max(np.abs(Bs), axis=(1, 2), initial=0.0)
    top_c = np.max(np.abs(cs), axis=1, initial=0.0)
    return np.maximum(1.0, np.maximum(top_b, top_c))


def _consistent_at(E_raw: np.ndarray, e_raw: np.ndarray, scale: np.ndarray, u: np.ndarray,
                   domain_tolerance: float) -> np.ndarray:
    """Per mode: consistent equalities with ``|E u - e| <= domain_tolerance`` (solve_affine's rule)."""
    count, p, m = E_raw.shape
    if p == 0:
        return np.ones(count, dtype=bool)
    if m == 0:
        return ~np.any(np.abs(e_raw) > CONSISTENCY_TOLERANCE * scale[:, None], axis=1)
    if p == 1:  # one condition: its SVD is its norm (the sign cancels in |E u - e|)
        norm = np.sqrt((E_raw[:, 0] ** 2).sum(axis=1))
        kept = norm > CONSISTENCY_TOLERANCE * scale
        miss = np.abs(E_raw[:, 0] @ u - e_raw[:, 0]) / np.where(kept, norm, 1.0)
        return np.where(kept, miss <= domain_tolerance, np.abs(e_raw[:, 0]) <= CONSISTENCY_TOLERANCE * scale)
    Ue, se, Vte = np.linalg.svd(E_raw, full_matrices=True)
    q = se.shape[1]
    padded = np.zeros((count, p))
    padded[:, :q] = se
    kept = padded > CONSISTENCY_TOLERANCE * scale[:, None]
    e_rot = np.einsum("gqj,gq->gj", Ue, e_raw)
    consistent = ~np.any(~kept & (np.abs(e_rot) > CONSISTENCY_TOLERANCE * scale[:, None]), axis=1)
    miss = np.einsum("gjk,k->gj", Vte[:, :q], u) - e_rot[:, :q] / np.where(kept[:, :q], se, 1.0)
    return consistent & ~np.any(kept[:, :q] & (np.abs(miss) > domain_tolerance), axis=1)


def interval_admissible(H: np.ndarray, h: np.ndarray, motion: np.ndarray, domain_tolerance: float,
                        zero_row_tolerance: float, radius_cap: float) -> np.ndarray | None:
    """The engine's admissible ``w`` for one ambiguity variable, in closed form; None if none.

    With ``H w <= h`` (one column, rows normalised in (u, w)) this is what the engine's two LPs
    decide, on an interval (:func:`decide_intervals` for one mode).
    """
    rows = H.shape[0]
    ok, w = decide_intervals(H[None, :, 0], h[None], motion[None], np.ones((1, rows), dtype=bool),
                             domain_tolerance, zero_row_tolerance, radius_cap)
    return w[:1] if ok[0] else None


def decide_intervals(a: np.ndarray, h: np.ndarray, motion: np.ndarray, valid: np.ndarray,
                     domain_tolerance: float, zero_row_tolerance: float, radius_cap: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """For modes with one ambiguity variable: which are admissible at the input, and their ``w``.

    Per mode, the rows ``a_i w <= h_i`` (``a``, ``h``, ``motion``, ``valid``: (modes, rows); rows
    normalised in (u, w)) are decided as the engine's two LPs decide them, on an interval:

    1. the motion test (:func:`frcontrol.engine.motion_margin`): non-motion rows relaxed by
       ``domain_tolerance``; a constant motion row must hold by more than it; the largest margin
       ``t`` (capped at 1) by which the motion rows can hold must exceed it, else no solution moves
       as the mode says;
    2. the representative: the midpoint of the interval with every row relaxed by
       ``domain_tolerance`` (its Chebyshev centre), or, when it is thinner than
       ``2 domain_tolerance``, the motion test's point. A side without a bound is replaced by the
       other bound moved by the radius cap (as the capped Chebyshev LP does).

    Returns:
        ``(admissible (modes,), w (modes,))``.
    """
    scale = np.where(valid, np.abs(a), 0.0)
    zero = valid & (scale <= zero_row_tolerance * np.maximum(1.0, scale.max(axis=1, initial=0.0))[:, None])
    relaxed = h + np.where(motion, 0.0, domain_tolerance)
    ok = ~((zero & ~motion & (relaxed < 0.0)) | (zero & motion & (h <= domain_tolerance))).any(axis=1)
    live = valid & ~zero
    with np.errstate(divide="ignore", invalid="ignore"):
        ends = np.where(live, relaxed / a, np.nan)  # a_i w <= b_i: w <= end (a > 0) or w >= end (a < 0)
        ball_ends = np.where(live, (h + domain_tolerance) / a, np.nan)
    lo, hi = _bounds(ends, a, live & ~motion)
    moving = live & motion
    upper, lower = _bounds(ends, a, moving)[::-1]
    ok &= lo <= hi
    has_motion = moving.any(axis=1)
    finite_up, finite_down = np.isfinite(upper), np.isfinite(lower)
    with np.errstate(invalid="ignore"):  # inf - inf in the branches np.where does not take
        w = np.where(finite_up & finite_down, 0.5 * (upper + lower),
                     np.where(finite_up, upper - 1.0, np.where(finite_down, lower + 1.0, 0.0)))
        w = np.minimum(np.maximum(np.where(has_motion, w, 0.0), lo), hi)
        margin = np.minimum(1.0, np.minimum(upper - w, w - lower))
        ok &= ~has_motion | ((margin >= 0.0) & (margin > domain_tolerance))
        # rows with coefficients below the zero-row threshold are judged by their right-hand side
        # alone (above), as the engine does: normalising them would inflate round-off into a
        # bound of ~1e16 (massless legs' modes)
        lo_ball, hi_ball = _bounds(ball_ends, a, live)
        finite_lo, finite_hi = np.isfinite(lo_ball), np.isfinite(hi_ball)
        one_side = np.where(finite_lo, lo_ball + radius_cap, np.where(finite_hi, hi_ball - radius_cap, w))
        centre = np.where(finite_lo & finite_hi,
                          np.where(hi_ball - lo_ball > 2.0 * domain_tolerance, 0.5 * (lo_ball + hi_ball), w),
                          one_side)
    return ok, centre


def _bounds(ends: np.ndarray, a: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per mode, ``(lo, hi)`` of ``{w: a_i w <= b_i}`` over the chosen rows (``ends = b / a``)."""
    hi = np.where(rows & (a > 0), ends, np.inf).min(axis=1, initial=np.inf)
    lo = np.where(rows & (a < 0), ends, -np.inf).max(axis=1, initial=-np.inf)
    return lo, hi


twin("decide_modes", numpy=_numpy_modes, compiled=_compiled_modes)


__all__ = [
    "AMBIGUOUS_OUTPUT_CODES",
    "BATCH_MAX_MODES",
    "BatchSolution",
    "decide_intervals",
    "decide_modes",
    "full_modes",
    "interval_admissible",
    "ModeBatch",
    "WDecider",
]

