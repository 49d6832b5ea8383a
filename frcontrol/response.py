"""The affine response of one contact mode: the four rank cases (docs/maths.md, *The four rank cases*).

A mode's equalities ``A x = B u + c`` are solved with a rank-revealing factorisation (an SVD of
the row- and column-equilibrated ``A``; nothing is ever inverted, so a singular mass matrix from
massless links is fine). With ``r`` the numerical rank::

    x = X_u u + X_w w + x_0        for every w, wherever   E u = e

- ``X_w`` spans null(A): the ambiguity variables w (within-mode ambiguity), empty if A has full
  column rank;
- ``E u = e`` are the consistency conditions from the left null space of A (empty if A has full
  row rank after removing rows that are trivially satisfied);
- a left null vector that annihilates B but not c makes the mode inconsistent for every input:
  the mode is pruned ("freedom pruning").

The four cases (full row rank?, full column rank?) are reported as ``"unique"`` (both),
``"ambiguous"`` (w only), ``"constrained"`` (E only) and ``"ambiguous_constrained"`` (both). A
contact mode's system is square (n + 2k rows and columns), so there "constrained" alone cannot
occur: a rank drop always brings both a null space and a left null space, and the left one is
either trivially satisfied (e.g. a table on two legs: "ambiguous") or a real condition on the
inputs (e.g. a massless leg in the air: its torque must vanish, "ambiguous_constrained").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from .errors import IllConditioned, KernelError
from .kernel import Backend, backend, compiled, twin

RankCase = Literal["unique", "ambiguous", "constrained", "ambiguous_constrained"]
"""A mode's rank case: ambiguity variables w (``ambiguous``), consistency conditions E u = e
(``constrained``), both, or neither (``unique``)."""

AmbiguousOutputs = Literal["none", "forces", "accelerations"]
"""Which outputs the ambiguity variables w move (:func:`ambiguous_outputs`)."""

RANK_TOLERANCE = 1e-10
"""Singular values of the equilibrated A at most this times the largest are taken as zero."""

ILL_CONDITIONED_BAND = 1e-8
"""A singular value between ``RANK_TOLERANCE`` and this (times the largest) is too close to the
rank threshold to decide the rank: :class:`~frcontrol.errors.IllConditioned` is raised."""

BALANCING_SWEEPS = 8
"""[-] Sweeps of :func:`balanced_scaling` (each a column then a row pass, powers of two): on the
shipped scenes' sliding modes the condition stops improving after four."""

ROUND_OFF_RANK_DROP = 2.220446049250313e-16
"""[-] The relative change of each entry that round-off may make, per row or column of the system
(the double's machine epsilon): a rank drop is round-off's only when the balanced system's largest
dropped singular value is at most ``n ROUND_OFF_RANK_DROP ||A_bal||_F`` (``n`` its smaller
dimension). Above that, no change of each entry by ``n`` eps of itself makes the system singular
(``||dA||_2 <= ||dA||_F <= n eps ||A_bal||_F`` for ``|dA| <= n eps |A_bal|``, under any diagonal
scaling): it is nonsingular, and too ill-conditioned to decide (:func:`rebalance_undecided`). Over the
shipped scenes at mu = 1 to 1e8 (``python -m benchmarks.rank_decisions``) the singular modes sit at
0.03 of that bound or below, and the box on the slope sliding at mu = 1e8 at 0.2 (its smallest
singular value, about 1/(0.34 mu^2) of the largest, is below round-off there); the same modes at
mu = 1e6 and 1e7 at 1870 and 19 times it, snake_climb's FLF at 1e8 at 2490 times."""

BALANCING_FRICTION = 1.0
"""[-] A contact mode's system is balanced (:func:`rebalance_undecided`) only when one of its sliding
contacts has a friction coefficient above this. A sliding contact's row ``lam_T = +-mu lam_N`` is
the one entry of a mode's system that grows with a parameter the max-abs equilibration cannot
absorb (the condition grows as mu^2 under it, as mu under a good scaling); at mu <= 1 it adds no
spread to its row, and the first scaling decides as it always has (a table on two legs, a box
sticking at both corners: each would otherwise pay a balancing and a second SVD per query, for
the same answer). Callers that do not know the mode balance every system (``balance=True``)."""

CONSISTENCY_TOLERANCE = 1e-9
"""A consistency row ``E_i u = e_i`` whose ``E_i`` has norm at most this times the scale of
``[B c]`` is void; it is inconsistent if ``|e_i|`` also exceeds this times that scale."""

CERTIFIED_MARGIN = 10.0
"""[-] :func:`certified_responses` answers without an SVD when ``||A||_F ||R_1^-1||_F`` (of the
equilibrated A of full row rank, a bound on its 2-norm condition number) is below
``1 / (CERTIFIED_MARGIN max(rank_tolerance, ILL_CONDITIONED_BAND))``: its smallest singular value
is then certainly above both thresholds, so the SVD would find full row rank outside the
ill-conditioned band. :mod:`frcontrol.mode_batch` certifies its modes with the same margin
(``||A^-1||_F`` for a square A)."""

VOID_CONDITIONS_SAFETY = 0.5
"""[-] The consistency rows are found void without their SVD only when their Frobenius norm and
that of their right-hand side are at most this times the consistency threshold: the SVD's own
round-off (relative, about 1e-16) cannot then put a singular value or a rotated entry above it."""

OUTPUT_TOLERANCE = 1e-9
"""An output depends on w if its row of ``X_w`` exceeds this times the largest entry of X_w."""


@dataclass(frozen=True)
class AffineSolution:
    """All solutions of ``A x = B u + c``: ``x = X_u u + X_w w + x_0`` where ``E u = e``.

    Attributes:
        X_u: (nx, m); X_w: (nx, p), a basis of null(A); x_0: (nx,).
        E: (r_e, m) with orthonormal rows; e: (r_e,).
        consistent: False if no input satisfies the equalities (then the rest is meaningless).
        rank: numerical rank of A; shape: A's shape.
        singular_values: of the equilibrated A, descending.
        condition_number: largest over smallest kept singular value.
        rank_tolerance: the relative tolerance used.
        certified: the rank was certified without an SVD (:func:`certified_responses`); then
            ``singular_values`` is empty and ``condition_number`` an upper bound.
    """

    X_u: np.ndarray
    X_w: np.ndarray
    x_0: np.ndarray
    E: np.ndarray
    e: np.ndarray
    consistent: bool
    rank: int
    shape: tuple[int, int]
    singular_values: np.ndarray
    condition_number: float
    rank_tolerance: float
    certified: bool = False

    @property
    def ambiguity_dim(self) -> int:
        """Number of ambiguity variables p."""
        return self.X_w.shape[1]

    @property
    def case(self) -> RankCase:
        """The rank case: unique, ambiguous, constrained or ambiguous_constrained."""
        ambiguous = self.ambiguity_dim > 0
        constrained = self.E.shape[0] > 0
        if ambiguous and constrained:
            return "ambiguous_constrained"
        if ambiguous:
            return "ambiguous"
        if constrained:
            return "constrained"
        return "unique"


def power_of_two_scale(top: np.ndarray) -> np.ndarray:
    """``2^-round(log2 t)`` of each largest magnitude ``t`` (1 where ``t`` is 0): exact scalings."""
    # np.rint is np.round at 0 decimals (halves to even), without its Python wrapper
    return np.exp2(-np.rint(np.log2(np.where(top > 0, top, 1.0))))


def _equilibrate(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row and column scalings (powers of two) making each row and column's max-abs about 1."""
    if not A.size:
        return np.ones(A.shape[0]), np.ones(A.shape[1])
    magnitude = np.abs(A)
    rows = power_of_two_scale(np.maximum.reduce(magnitude, axis=1))  # .max(axis=1) without its wrapper
    # powers of two scale exactly: |A * r| is |A| * r
    cols = power_of_two_scale(np.maximum.reduce(magnitude * rows[:, None], axis=0))
    return rows, cols


def equilibrate_stack(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row and column scalings of a stack ``(count, rows, cols)``, as :func:`_equilibrate` per matrix."""
    magnitude = np.abs(A)
    rows = power_of_two_scale(magnitude.max(axis=2))
    # powers of two scale exactly: |A * r| is |A| * r
    cols = power_of_two_scale((magnitude * rows[:, :, None]).max(axis=1))
    return rows, cols


def balanced_scaling(A_hat: np.ndarray, svd: tuple[np.ndarray, np.ndarray, np.ndarray]
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Scalings of a stack ``A_hat`` (count, rows, cols) balancing it against its pseudo-inverse.

    The max-abs equilibration of :func:`solve_affine` leaves a sliding mode's system with a
    condition number growing as mu^2 (the friction row ``lam_T - mu lam_N = 0`` sets the scale of
    the lam_N column), while under a good diagonal scaling it grows as mu. With ``X = A_hat^+``
    from the SVD ``U, s, Vt`` already made (all its singular values), each column ``j`` is scaled
    by ``sqrt(max|X_j.| / max|A_.j|)`` and each row ``i`` by ``sqrt(max|X_.i| / max|A_i.|)``, in
    powers of two (exact), :data:`BALANCING_SWEEPS` times: ``D_r A D_c`` has the inverse
    ``D_c^-1 X D_r^-1``, so no sweep needs a new factorisation (a heuristic for Bauer's optimal
    scaling, which balances ``|A|`` against ``|A^-1|``). Every smallest singular value must be > 0.

    Returns:
        Row and column factors ``D_r``, ``D_c`` (count, rows) and (count, cols), to multiply A_hat's.
    """
    U, s, Vt = svd
    count, rank = s.shape
    magnitude = np.abs(A_hat)
    # |A_hat^+| = |V diag(1/s) U^T|, (count, cols, rows)
    inverse = np.abs(np.matmul(np.swapaxes(Vt[:, :rank], 1, 2) / s[:, None, :],
                               np.swapaxes(U[:, :, :rank], 1, 2)))
    rows, cols = np.ones((count, A_hat.shape[1])), np.ones((count, A_hat.shape[2]))
    for _ in range(BALANCING_SWEEPS):
        a = (magnitude * rows[:, :, None] * cols[:, None, :]).max(axis=1)
        x = (inverse / cols[:, :, None] / rows[:, None, :]).max(axis=2)
        cols *= power_of_two_scale(np.sqrt(np.where(a > 0, a, 1.0) / np.where(x > 0, x, 1.0)))
        a = (magnitude * rows[:, :, None] * cols[:, None, :]).max(axis=2)
        x = (inverse / cols[:, :, None] / rows[:, None, :]).max(axis=1)
        rows *= power_of_two_scale(np.sqrt(np.where(a > 0, a, 1.0) / np.where(x > 0, x, 1.0)))
    return rows, cols


def _scalable(A_hat: np.ndarray, s: np.ndarray, Vt: np.ndarray) -> np.ndarray:
    """Per system: whether a diagonal scaling could lift a singular value at or below the band.

    For a right singular vector v, ``omega = max_i |A v|_i / (|A| |v|)_i`` is the smallest relative
    change of each entry of A making v a null vector (Oettli-Prager), the same under every diagonal
    scaling. When that is round-off (at most ``n`` :data:`ROUND_OFF_RANK_DROP`) for each such v,
    the system is singular to round-off under every scaling: no scaling decides otherwise, and it
    keeps its first SVD without a second one.
    """
    size = s.shape[1]
    V = np.swapaxes(Vt[:, :size], 1, 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.abs(np.matmul(A_hat, V)) / np.matmul(np.abs(A_hat), np.abs(V))
    omega = np.nan_to_num(ratio, nan=0.0, posinf=0.0).max(axis=1)
    small = s <= ILL_CONDITIONED_BAND * s[:, :1]
    return (small & (omega > size * ROUND_OFF_RANK_DROP)).any(axis=1)


def round_off_bound(A_hat: np.ndarray) -> np.ndarray:
    """``n ROUND_OFF_RANK_DROP ||A_hat||_F`` per system of a stack (count, rows, cols).

    ``n`` is the smaller dimension: a singular value at most this is round-off's
    (:data:`ROUND_OFF_RANK_DROP`).
    """
    return min(A_hat.shape[1:]) * ROUND_OFF_RANK_DROP * np.sqrt((A_hat * A_hat).sum(axis=(1, 2)))


def rebalance_undecided(A_hat: np.ndarray, r_scale: np.ndarray, c_scale: np.ndarray,
                        svd: tuple[np.ndarray, np.ndarray, np.ndarray], rank_tolerance: float,
                        balance: bool | np.ndarray = True) -> tuple[np.ndarray, np.ndarray]:
    """Decide again, under :func:`balanced_scaling`, each system whose rank the first scaling left open.

    ``A_hat`` (count, rows, cols) ``= diag(r_scale) A diag(c_scale)`` with its SVD. A system whose
    smallest singular value is at most :data:`ILL_CONDITIONED_BAND` times its largest (a rank
    drop, or a value in the band) and that a scaling could decide otherwise (:func:`_scalable`) is
    balanced and gets a second SVD (one batched call for all);
    the balanced system replaces the first, in place (``A_hat``, the scalings and ``svd``), when
    the first had a value in the band or the balanced one has the higher rank. So a system the
    first scaling decides keeps its answer bit for bit (a system singular to round-off, e.g. a
    table on two legs, keeps its rank drop under any scaling), and where the balanced system is
    still in the band, the error reports its condition.

    A rank drop that round-off does not explain (the balanced system's largest dropped singular
    value above :func:`round_off_bound`) is not decided: the system is nonsingular, too
    ill-conditioned for its rank to be read. It is replaced by the balanced system too. A system
    with a singular value exactly 0 is not balanced; the rest of its drop is checked under the
    first scaling (:func:`_unexplained_exact_drops`).

    ``balance`` (one flag, or one per system) says which systems may be balanced at all
    (:data:`BALANCING_FRICTION`); the others keep their first decision.

    Returns:
        The indices of the systems left undecided so, and the condition number of each (under the
        balanced scaling where one was made): its largest singular value over the largest one the
        rank rule dropped. The caller raises :class:`~frcontrol.errors.IllConditioned` with it.
    """
    U, s, Vt = svd
    if not s.shape[1]:
        return np.zeros(0, dtype=int), np.zeros(0)
    s_max, s_min = s[:, 0], s[:, -1]
    exact, exact_condition = _unexplained_exact_drops(A_hat, s, rank_tolerance)
    open_ = np.nonzero((s_min > 0.0) & (s_min <= ILL_CONDITIONED_BAND * s_max) & balance)[0]
    if open_.size:
        open_ = open_[~_structural_drops(A_hat[open_], s[open_], rank_tolerance)]
    if open_.size:
        open_ = open_[_scalable(A_hat[open_], s[open_], Vt[open_])]
    if not open_.size:
        return exact, exact_condition
    rows, cols = balanced_scaling(A_hat[open_], (U[open_], s[open_], Vt[open_]))
    balanced = A_hat[open_] * rows[:, :, None] * cols[:, None, :]
    U_b, s_b, Vt_b = np.linalg.svd(balanced, full_matrices=True)
    first_rank = (s[open_] > rank_tolerance * s_max[open_, None]).sum(axis=1)
    in_band = first_rank > (s[open_] > ILL_CONDITIONED_BAND * s_max[open_, None]).sum(axis=1)
    balanced_rank = (s_b > rank_tolerance * s_b[:, :1]).sum(axis=1)
    better = in_band | (balanced_rank > first_rank)
    size = s.shape[1]
    rank = np.where(better, balanced_rank, first_rank)
    dropped = s_b[np.arange(open_.size), np.minimum(rank, size - 1)]
    undecided = (rank < size) & (dropped > round_off_bound(balanced))
    replaced = better | undecided
    chosen = open_[replaced]
    A_hat[chosen], U[chosen], s[chosen], Vt[chosen] = (balanced[replaced], U_b[replaced], s_b[replaced],
                                                       Vt_b[replaced])
    r_scale[chosen] *= rows[replaced]
    c_scale[chosen] *= cols[replaced]
    return (np.concatenate([exact, open_[undecided]]),
            np.concatenate([exact_condition, s_b[undecided, 0] / dropped[undecided]]))


def _structural_drops(A_hat: np.ndarray, s: np.ndarray, rank_tolerance: float) -> np.ndarray:
    """Per system of a stack: whether exactly zero rows or columns account for its whole rank drop.

    A system with ``z`` zero columns (an unknown no equation holds, e.g. the force of a separated
    contact, a massless link's acceleration) has rank at most ``cols - z`` under every scaling, and
    likewise for zero rows. Where the first scaling's rank reaches that bound with no singular
    value in the band, no scaling decides otherwise: the system keeps its first SVD without
    balancing (on rhex_flip, 28 of the 29 rank drops of one ``solutions_at``).
    """
    s_max = s[:, :1]
    rank = (s > rank_tolerance * s_max).sum(axis=1)
    in_band = rank > (s > ILL_CONDITIONED_BAND * s_max).sum(axis=1)
    zero = A_hat == 0.0
    bound = np.minimum(A_hat.shape[1] - zero.all(axis=2).sum(axis=1),
                       A_hat.shape[2] - zero.all(axis=1).sum(axis=1))
    return ~in_band & (rank >= bound)


def _unexplained_exact_drops(A_hat: np.ndarray, s: np.ndarray, rank_tolerance: float
                             ) -> tuple[np.ndarray, np.ndarray]:
    """The systems with a singular value exactly 0 whose rank rule also drops one above round-off.

    No balancing applies to them (it needs every singular value > 0), but the bound of
    :func:`round_off_bound` holds under every diagonal scaling, the first one too: a dropped value
    above it there is not round-off's. Their indices into the stack, and their conditions (the
    largest singular value over the largest dropped one).
    """
    s_max = s[:, 0]
    candidates = np.nonzero((s[:, -1] == 0.0) & (s_max > 0.0))[0]
    rank = (s[candidates] > rank_tolerance * s_max[candidates, None]).sum(axis=1)
    dropped = s[candidates, rank]  # rank < size: the last value is 0
    found = dropped > round_off_bound(A_hat[candidates])
    return candidates[found], s_max[candidates[found]] / dropped[found]


def _void_conditions(E_raw: np.ndarray, e_raw: np.ndarray, threshold: float) -> bool:
    """Whether the SVD of the consistency rows would keep none and find them consistent.

    Every singular value of ``E_raw`` is at most its Frobenius norm, and every entry of a rotated
    ``e_raw`` at most its 2-norm: both at most ``threshold`` (times
    :data:`VOID_CONDITIONS_SAFETY`) decide it without the SVD.
    """
    bound = VOID_CONDITIONS_SAFETY * threshold
    return bool(np.sqrt((E_raw * E_raw).sum()) <= bound and np.sqrt(e_raw @ e_raw) <= bound)


def solve_affine(
    A: np.ndarray,
    B: np.ndarray,
    c: np.ndarray,
    *,
    rank_tolerance: float = RANK_TOLERANCE,
    name: str = "A",
    balance: bool = True,
) -> AffineSolution:
    """Every solution of ``A x = B u + c`` as an affine map of (u, w), with its consistency set.

    Args:
        A: the system matrix, (rows, nx).
        B: the input matrix, (rows, m).
        c: the constant term, (rows,).
        rank_tolerance: relative singular-value threshold for the rank decision.
        name: what A is called in an :class:`IllConditioned` error.
        balance: whether an undecided rank may be decided again under a balanced scaling
            (:func:`rebalance_undecided`, :data:`BALANCING_FRICTION`).

    Raises:
        IllConditioned: a singular value lies in the band where the rank cannot be decided, or the
            rank rule would drop one that round-off does not explain (:func:`rebalance_undecided`).
    """
    r_scale, c_scale = _equilibrate(A)
    A_hat = A * r_scale[:, None] * c_scale[None, :]
    U, s, Vt = np.linalg.svd(A_hat, full_matrices=True)
    if s.size and s[-1] <= ILL_CONDITIONED_BAND * s[0]:  # (views: rebalanced in place)
        undecided, condition = rebalance_undecided(A_hat[None], r_scale[None], c_scale[None],
                                                   (U[None], s[None], Vt[None]), rank_tolerance, balance)
        if undecided.size:
            raise IllConditioned(name, condition[0], ILL_CONDITIONED_BAND)
    return _affine_from_svd(A.shape, B, c, r_scale, c_scale, (U, s, Vt), rank_tolerance, name)


def solve_affine_stack(
    A: np.ndarray,
    B: np.ndarray,
    c: np.ndarray,
    *,
    rank_tolerance: float = RANK_TOLERANCE,
    balance: bool | np.ndarray = True,
) -> list[AffineSolution | None]:
    """:func:`solve_affine` of each system of a stack sharing ``B``, with one batched SVD.

    ``A`` (count, rows, nx), ``B`` (rows, m), ``c`` (count, rows): e.g. a node's children. The same
    scalings (:func:`equilibrate_stack`) and the same LAPACK call per matrix, so each answer is
    :func:`solve_affine`'s bit for bit (tests/test_fast_paths.py). A system whose rank lies in the
    ill-conditioned band, or whose rank drop round-off does not explain, gets None:
    :func:`solve_affine` raises for it when its caller asks.
    """
    r_scale, c_scale = equilibrate_stack(A)
    A_hat = A * r_scale[:, :, None] * c_scale[:, None, :]
    U, s, Vt = np.linalg.svd(A_hat, full_matrices=True)
    undecided, _ = rebalance_undecided(A_hat, r_scale, c_scale, (U, s, Vt), rank_tolerance, balance)
    undecided_set = set(undecided.tolist())
    out: list[AffineSolution | None] = []
    for i in range(A.shape[0]):
        if i in undecided_set:
            out.append(None)
            continue
        try:
            out.append(_affine_from_svd(A.shape[1:], B, c[i], r_scale[i], c_scale[i], (U[i], s[i], Vt[i]),
                                        rank_tolerance, "A"))
        except IllConditioned:
            out.append(None)
    return out


def _affine_from_svd(
    shape: tuple[int, ...],
    B: np.ndarray,
    c: np.ndarray,
    r_scale: np.ndarray,
    c_scale: np.ndarray,
    svd: tuple[np.ndarray, np.ndarray, np.ndarray],
    rank_tolerance: float,
    name: str,
) -> AffineSolution:
    """:func:`solve_affine` from the SVD ``U, s, Vt`` of ``diag(r_scale) A diag(c_scale)``."""
    rows, nx = shape
    U, s, Vt = svd
    s_max = s[0] if s.size else 0.0
    if s_max == 0.0:
        rank = 0
    else:
        rank = int(np.count_nonzero(s > rank_tolerance * s_max))
        band = (s > rank_tolerance * s_max) & (s <= ILL_CONDITIONED_BAND * s_max)
        if np.count_nonzero(band):
            raise IllConditioned(name, s_max / s[band].min(), ILL_CONDITIONED_BAND)
    condition = float(s_max / s[rank - 1]) if rank else float("inf")
    Bs = B * r_scale[:, None]
    cs = c * r_scale
    U1, U2 = U[:, :rank], U[:, rank:]
    V1 = Vt[:rank].T
    inv_s = 1.0 / s[:rank]
    # y = V1 diag(1/s) U1^T (B u + c); x = diag(c_scale) y
    X_u = c_scale[:, None] * (V1 @ (inv_s[:, None] * (U1.T @ Bs)))
    x_0 = c_scale * (V1 @ (inv_s * (U1.T @ cs)))
    X_w = c_scale[:, None] * Vt[rank:].T

    # consistency: U2^T (B u + c) = 0  ->  E u = e
    E_raw = U2.T @ Bs
    e_raw = -(U2.T @ cs)
    scale = max(1.0, float(np.maximum.reduce(np.abs(Bs), axis=None, initial=0.0)),
                float(np.maximum.reduce(np.abs(cs), axis=None, initial=0.0)))
    consistent = True
    if E_raw.shape[0] and _void_conditions(E_raw, e_raw, CONSISTENCY_TOLERANCE * scale):
        E, e = np.zeros((0, B.shape[1])), np.zeros(0)
    elif E_raw.shape[0]:
        if E_raw.shape[1]:
            Ue, se, Vte = np.linalg.svd(E_raw, full_matrices=True)
            kept = int(np.sum(se > CONSISTENCY_TOLERANCE * scale))
        else:
            Ue, se, Vte = np.eye(E_raw.shape[0]), np.zeros(0), np.zeros((0, 0))
            kept = 0
        e_rot = Ue.T @ e_raw
        if np.any(np.abs(e_rot[kept:]) > CONSISTENCY_TOLERANCE * scale):
            consistent = False
        # Ue^T E_raw = diag(se) Vte: the kept rows, divided by their singular values, are orthonormal
        E = Vte[:kept] if kept else np.zeros((0, B.shape[1]))
        e = e_rot[:kept] / se[:kept]
    else:
        E, e = np.zeros((0, B.shape[1])), np.zeros(0)
    return AffineSolution(
        X_u=X_u, X_w=X_w, x_0=x_0, E=E, e=e, consistent=consistent, rank=rank,
        shape=(rows, nx), singular_values=s, condition_number=condition, rank_tolerance=rank_tolerance,
    )


def certified_responses(
    A: np.ndarray,
    B: np.ndarray,
    c: np.ndarray,
    *,
    rank_tolerance: float = RANK_TOLERANCE,
) -> list[AffineSolution | None]:
    """:func:`solve_affine`'s answers for a stack of systems of full row rank, without an SVD.

    ``A`` (count, rows, nx) with rows <= nx, ``B`` (count, rows, m), ``c`` (count, rows): e.g. the
    modes that extend one partial mode by each letter. Each A is equilibrated as in
    :func:`solve_affine` and factorised, all at once, as ``A_hat^T = Q R``: ``A_hat = R_1^T Q_1^T``,
    its minimum-norm solution ``Q_1 R_1^-T`` (the pseudo-inverse the SVD applies) and its null
    space ``Q_2`` (empty for a square A). The identity's columns of the same solve give
    ``R_1^-T`` for the bound of :data:`CERTIFIED_MARGIN`. A certified system is one the SVD would
    find of full row rank outside the ill-conditioned band (no consistency condition,
    consistent); its ``X_u`` and ``x_0`` are the SVD's, and its ``X_w = diag(c) Q_2`` spans the
    same null space as the SVD's ``diag(c) V_2`` with ``Q_2 = V_2 O`` for an orthogonal ``O``: every
    distance in (u, w) (the engine's margins and balls) is the same.

    Returns:
        Per system its response (``certified`` True), or None when the bound does not certify it
        (the caller then takes :func:`solve_affine`).
    """
    count, rows, nx = A.shape
    out: list[AffineSolution | None] = [None] * count
    if count == 0 or rows == 0 or rows > nx:
        return out
    m = B.shape[2]
    r_scale, c_scale = equilibrate_stack(A)
    A_hat = A * r_scale[:, :, None] * c_scale[:, None, :]
    limit = 1.0 / (CERTIFIED_MARGIN * max(rank_tolerance, ILL_CONDITIONED_BAND))
    size = np.sqrt((A_hat * A_hat).sum(axis=(1, 2)))  # ||A_hat||_F = ||R_1||_F
    Q, R = np.linalg.qr(np.swapaxes(A_hat, 1, 2), mode="complete")
    # ||R_1^-1||_F >= 1 / min |R_ii|: a small pivot rules the certificate out before any solve
    pivots = np.abs(np.diagonal(R[:, :rows], axis1=1, axis2=2)).min(axis=1)
    hopeful = np.nonzero(size < limit * pivots)[0]
    if hopeful.size == 0:
        return out
    rhs = np.empty((hopeful.size, rows, rows + m + 1))
    rhs[:, :, :rows] = np.eye(rows)
    rhs[:, :, rows:rows + m] = B[hopeful] * r_scale[hopeful, :, None]
    rhs[:, :, -1] = c[hopeful] * r_scale[hopeful]
    with np.errstate(over="ignore", invalid="ignore"):  # a nearly singular R_1: not certified
        solved = np.linalg.solve(np.swapaxes(R[hopeful, :rows], 1, 2), rhs)  # R_1^-T [I, B, c]
        bound = size[hopeful] * np.sqrt((solved[:, :, :rows] ** 2).sum(axis=(1, 2)))
    y = np.matmul(Q[hopeful, :, :rows], solved)
    # x = diag(c) y for every hopeful system at once (elementwise: the same numbers as one by one)
    y *= c_scale[hopeful, :, None]
    X_u, x_0 = np.ascontiguousarray(y[:, :, rows:rows + m]), np.ascontiguousarray(y[:, :, -1])
    X_w = Q[hopeful, :, rows:] * c_scale[hopeful, :, None]
    no_conditions, no_values = np.zeros((0, m)), np.zeros(0)  # empty: shared, nothing to write
    for j, i in enumerate(hopeful.tolist()):
        if bound[j] < limit:  # False for NaN
            out[i] = AffineSolution(
                X_u=X_u[j], X_w=X_w[j], x_0=x_0[j], E=no_conditions, e=no_values,
                consistent=True, rank=rows, shape=(rows, nx), singular_values=no_values,
                condition_number=float(bound[j]), rank_tolerance=rank_tolerance, certified=True)
    return out


def certified_by_rows(
    A: np.ndarray,
    B: np.ndarray,
    c: np.ndarray,
    kept: np.ndarray,
    *,
    rank_tolerance: float = RANK_TOLERANCE,
    kernel: Backend | None = None,
) -> list[AffineSolution | None]:
    """:func:`solve_affine`'s answers for a stack of rank-deficient systems, without an SVD.

    ``A`` (count, rows, nx), ``B`` (rows, m) shared, ``c`` (count, rows); ``kept`` (count, q), the
    rows of each system guessed to be independent and to imply the others (e.g. a node's own
    independent rows and those of its letter that add to them). Each A is equilibrated as in
    :func:`solve_affine` (``A_hat``, the whole system's scalings) and its kept rows ``S`` factorised
    as ``S^T = Q R`` (:func:`by_rows_factors`). The guess is then checked, not trusted: a system is
    certified (:func:`by_rows_certified`) when

    - ``||A_hat||_F ||R_1^-1||_F < 1 / (CERTIFIED_MARGIN max(rank_tolerance, ILL_CONDITIONED_BAND))``:
      ``sigma_q(A_hat) >= sigma_q(S) >= 1 / ||R_1^-1||_F`` (a row submatrix's singular values are at
      most the matrix's), so the SVD keeps q values, none in the ill-conditioned band;
    - ``CERTIFIED_MARGIN ||A_hat Q_2||_F`` is below ``rank_tolerance ||A_hat||_F / sqrt(min(rows,
      nx))`` (at most ``rank_tolerance sigma_1``) and at most :func:`round_off_bound`: every other
      singular value is at most ``||A_hat Q_2||_2`` (``A_hat Q_1 Q_1^T`` has rank q), so the SVD drops
      it, and the drop is round-off's (the rule of :func:`_unexplained_exact_drops` cannot apply);
    - the residual of the kept rows' minimum-norm solutions ``y`` on every row,
      ``||[diag(r) B, diag(r) c] - A_hat y||`` (for B's columns and for c), is round-off's: at most
      :data:`ROWS_RESIDUAL_ROUND_OFF` machine epsilons times the bound times
      ``||[diag(r) B, diag(r) c]||_F`` (what exactly dependent rows leave), and at most
      ``VOID_CONDITIONS_SAFETY / CERTIFIED_MARGIN`` times the consistency threshold of
      :func:`solve_affine`. The SVD's consistency rows ``U_2^T [diag(r) B, diag(r) c]`` are then
      void: they are ``U_2^T`` of that residual plus ``Sigma_2 V_2^T y``, and ``y`` lies in the kept
      rows' row space, to which ``V_2`` is orthogonal but for round-off (second order).

    Then the kept rows have the system's solutions: ``X_u`` and ``x_0`` are the SVD's minimum-norm
    ones to round-off (the SVD's least squares over every row moves them by at most the residual
    times ``||R_1^-1||``), and ``X_w = diag(c) Q_2`` spans its null space in an orthonormal basis
    of the scaled coordinates, as :func:`certified_responses`' (every distance in (u, w) the same).
    The SVD this stands for is the first scaling's: a system that :func:`rebalance_undecided` might
    balance (``balance`` of :func:`solve_affine`) is the caller's to leave out.

    By the kernel's ``certified_by_rows`` (:func:`frcontrol.kernel.backend`): with the compiled
    kernel, each system in C (``frcontrol._kernel.certified_by_rows``: the same scalings and checks,
    a Householder QR of its own: equal to round-off, see tests/test_kernel.py); its NumPy twin
    is :func:`by_rows_factors`. ``kernel``: the backend when the caller has it.

    Returns:
        Per system its response (``certified`` True, ``rank`` q), or None when a check fails (the
        caller then takes the SVD).
    """
    count, rows, nx = A.shape
    q = kept.shape[1]
    if count == 0 or q == 0 or q > nx:
        return [None] * count
    X_u, x_0, X_w, info = (kernel or backend()).certified_by_rows(A, B, c, kept)
    certified = by_rows_certified(info, rows, nx, rank_tolerance)
    m = B.shape[1]
    no_conditions, no_values = np.zeros((0, m)), np.zeros(0)  # empty: shared, nothing to write
    return [AffineSolution(
        X_u=X_u[i], X_w=X_w[i], x_0=x_0[i], E=no_conditions, e=no_values, consistent=True, rank=q,
        shape=(rows, nx), singular_values=no_values, condition_number=float(info[i, 0]),
        rank_tolerance=rank_tolerance, certified=True) if ok else None for i, ok in enumerate(certified)]


BY_ROWS_INFO = ("bound", "dropped", "residual_B", "residual_c", "size", "scale", "right")
"""The seven numbers :func:`by_rows_factors` reports per system, in order: ``||A_hat||_F ||R_1^-1||_F``
(+inf when a pivot rules it out), ``||A_hat Q_2||_F``, the residuals of the kept rows' solutions
on every row (of ``diag(r) B``, Frobenius, and of ``diag(r) c``), ``||A_hat||_F``,
``max(1, max|diag(r) B|, max|diag(r) c|)`` (the consistency threshold's scale) and
``||[diag(r) B, diag(r) c]||_F``. Where the bound is at least ``1 / (CERTIFIED_MARGIN
ILL_CONDITIONED_BAND)`` (no rank tolerance certifies it) all but the bound and ``||A_hat||_F`` are
NaN, and the responses are not computed."""

ROWS_RESIDUAL_ROUND_OFF = 10.0
"""[-] :func:`certified_by_rows` takes the kept rows' solutions as the whole system's only when their
residual on every row is at most this many machine epsilons times the bound ``||A_hat||_F
||R_1^-1||_F`` times ``||[diag(r) B, diag(r) c]||_F``: what round-off leaves where the other rows
are exact combinations of the kept ones (the snakes on the ground stay below 0.06 of it). A larger
residual is a real, if tiny, inconsistency, which the SVD's least squares would spread over every
row and so move the solutions by more than round-off: such a system takes the SVD."""


BY_ROWS_VOID_FACTOR = VOID_CONDITIONS_SAFETY * CONSISTENCY_TOLERANCE / CERTIFIED_MARGIN
"""[-] :func:`certified_by_rows`' residual must be at most this times the consistency threshold's scale
(``VOID_CONDITIONS_SAFETY / CERTIFIED_MARGIN`` of ``CONSISTENCY_TOLERANCE``)."""

BY_ROWS_EXACT_FACTOR = ROWS_RESIDUAL_ROUND_OFF * float(np.finfo(float).eps)
"""[-] ... and at most this times the bound times ``||[diag(r) B, diag(r) c]||_F``
(:data:`ROWS_RESIDUAL_ROUND_OFF` machine epsilons)."""


def by_rows_certified(info: np.ndarray, rows: int, nx: int, rank_tolerance: float) -> list[bool]:
    """Per system, whether :func:`by_rows_factors`' ``info`` (count, 7) certifies it.

    The checks of :func:`certified_by_rows`, on a few systems at a time, read as Python floats (a
    NaN fails every test). The compiled kernel's one-call query applies the same checks in C
    (``by_rows_ok``, with these constants).
    """
    limit = 1.0 / (CERTIFIED_MARGIN * max(rank_tolerance, ILL_CONDITIONED_BAND))
    small = min(rows, nx)
    rank_factor, round_off = rank_tolerance / math.sqrt(small), small * ROUND_OFF_RANK_DROP
    void_factor, exact_factor = BY_ROWS_VOID_FACTOR, BY_ROWS_EXACT_FACTOR
    return [bound < limit and CERTIFIED_MARGIN * dropped < rank_factor * size
            and CERTIFIED_MARGIN * dropped <= round_off * size
            and max(residual_B, residual_c) <= min(void_factor * scale, exact_factor * bound * right)
            for bound, dropped, residual_B, residual_c, size, scale, right in info.tolist()]


def by_rows_factors(A: np.ndarray, B: np.ndarray, c: np.ndarray, kept: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`certified_by_rows`' factorisation in NumPy (the reference twin): ``X_u, x_0, X_w, info``.

    Per system the kept rows' minimum-norm ``X_u`` (nx, m) and ``x_0`` (nx,), their null space
    ``X_w`` (nx, nx - q), and :data:`BY_ROWS_INFO`; a system whose bound certifies nothing has
    responses not to be read.
    """
    count, rows, nx = A.shape
    q, m = kept.shape[1], B.shape[1]
    if kept.size and (kept.min() < 0 or kept.max() >= rows):  # as the kernel's check
        bad = int(kept.min()) if kept.min() < 0 else int(kept.max())
        raise KernelError(f"kernel buffer kept: row {bad} of a system of {rows} rows")
    X_u, x_0, X_w = np.empty((count, nx, m)), np.empty((count, nx)), np.empty((count, nx, nx - q))
    info = np.full((count, len(BY_ROWS_INFO)), np.nan)
    info[:, 0] = np.inf
    r_scale, c_scale = equilibrate_stack(A)
    A_hat = A * r_scale[:, :, None] * c_scale[:, None, :]
    limit = 1.0 / (CERTIFIED_MARGIN * ILL_CONDITIONED_BAND)  # the loosest: by_rows_certified decides
    size = np.sqrt((A_hat * A_hat).sum(axis=(1, 2)))
    info[:, 4] = size
    Q, R = np.linalg.qr(np.swapaxes(A_hat[np.arange(count)[:, None], kept], 1, 2), mode="complete")  # S^T
    pivots = np.abs(np.diagonal(R[:, :q], axis1=1, axis2=2)).min(axis=1)
    hopeful = np.nonzero(size < limit * pivots)[0]
    if hopeful.size == 0:
        return X_u, x_0, X_w, info
    right = np.empty((hopeful.size, rows, m + 1))  # [diag(r) B, diag(r) c]
    right[:, :, :m] = B * r_scale[hopeful, :, None]
    right[:, :, m] = c[hopeful] * r_scale[hopeful]
    rhs = np.empty((hopeful.size, q, q + m + 1))
    rhs[:, :, :q] = np.eye(q)
    rhs[:, :, q:] = right[np.arange(hopeful.size)[:, None], kept[hopeful]]
    with np.errstate(over="ignore", invalid="ignore"):  # a nearly singular R_1: not certified
        solved = np.linalg.solve(np.swapaxes(R[hopeful, :q], 1, 2), rhs)  # R_1^-T [I, B_S, c_S]
        y = np.matmul(Q[hopeful, :, :q], solved[:, :, q:])
        Q_2 = Q[hopeful, :, q:]
        residual = right - np.matmul(A_hat[hopeful], y)
        info[hopeful, 0] = size[hopeful] * np.sqrt((solved[:, :, :q] ** 2).sum(axis=(1, 2)))
        info[hopeful, 1] = np.sqrt((np.matmul(A_hat[hopeful], Q_2) ** 2).sum(axis=(1, 2)))
    info[hopeful, 2] = np.sqrt((residual[:, :, :m] ** 2).sum(axis=(1, 2)))
    info[hopeful, 3] = np.sqrt((residual[:, :, m] ** 2).sum(axis=1))
    info[hopeful, 5] = np.maximum(1.0, np.abs(right).max(axis=(1, 2)))
    info[hopeful, 6] = np.sqrt((right * right).sum(axis=(1, 2)))
    X_u[hopeful] = y[:, :, :m] * c_scale[hopeful, :, None]
    x_0[hopeful] = y[:, :, m] * c_scale[hopeful]
    X_w[hopeful] = Q_2 * c_scale[hopeful, :, None]
    with np.errstate(invalid="ignore"):
        info[~(info[:, 0] < limit), 1:4] = np.nan  # as the kernel: past the bound, nothing more is read
    info[~(info[:, 0] < limit), 5:] = np.nan
    return X_u, x_0, X_w, info


def _by_rows_compiled(A: np.ndarray, B: np.ndarray, c: np.ndarray, kept: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`by_rows_factors` by the compiled kernel's ``certified_by_rows``."""
    count, rows, nx = A.shape
    q, m = kept.shape[1], B.shape[1]
    X_u, x_0, X_w = np.empty((count, nx, m)), np.empty((count, nx)), np.empty((count, nx, nx - q))
    info = np.empty((count, len(BY_ROWS_INFO)))
    compiled.certified_by_rows(  # type: ignore[union-attr]
        np.ascontiguousarray(A), np.ascontiguousarray(B), np.ascontiguousarray(c),
        np.ascontiguousarray(kept, dtype=np.int64), X_u, x_0, X_w, info,
        1.0 / (CERTIFIED_MARGIN * ILL_CONDITIONED_BAND))
    return X_u, x_0, X_w, info


twin("certified_by_rows", numpy=by_rows_factors, compiled=_by_rows_compiled)


def certified_children(
    A: np.ndarray,
    B: np.ndarray,
    c: np.ndarray,
    *,
    rank_tolerance: float = RANK_TOLERANCE,
    kernel: Backend | None = None,
) -> list[AffineSolution | None]:
    """:func:`certified_responses` of systems that share ``B`` (rows, m): a node's children.

    By the kernel's ``certified_children`` (:func:`frcontrol.kernel.backend`): with the compiled
    kernel, each system in C (``frcontrol._kernel.certified_children``: the same scalings, the same
    bound, a Householder QR of its own, so the responses and bounds equal NumPy's to round-off, see
    tests/test_kernel.py); its NumPy twin is :func:`certified_responses`. ``kernel``: the backend
    when the caller has it.
    """
    return (kernel or backend()).certified_children(A, B, c, rank_tolerance)


def _certified_children_numpy(A: np.ndarray, B: np.ndarray, c: np.ndarray, rank_tolerance: float
                              ) -> list[AffineSolution | None]:
    """:func:`certified_children` in NumPy (the reference twin)."""
    stacked = np.broadcast_to(B, (A.shape[0], *B.shape))
    return certified_responses(A, stacked, c, rank_tolerance=rank_tolerance)


def _certified_children_compiled(A: np.ndarray, B: np.ndarray, c: np.ndarray, rank_tolerance: float
                                 ) -> list[AffineSolution | None]:
    """:func:`certified_children` by the compiled kernel (NumPy's for shapes it does not take)."""
    count, rows, nx = A.shape
    if count == 0 or rows == 0 or rows > nx:
        return _certified_children_numpy(A, B, c, rank_tolerance)
    m = B.shape[1]
    limit = 1.0 / (CERTIFIED_MARGIN * max(rank_tolerance, ILL_CONDITIONED_BAND))
    X_u, x_0, X_w = np.empty((count, nx, m)), np.empty((count, nx)), np.empty((count, nx, nx - rows))
    bound = np.empty(count)
    compiled.certified_children(  # type: ignore[union-attr]
        np.ascontiguousarray(A), np.ascontiguousarray(B), np.ascontiguousarray(c), X_u, x_0, X_w, bound,
        limit)
    no_conditions, no_values = np.zeros((0, m)), np.zeros(0)  # empty: shared, nothing to write
    return [AffineSolution(
        X_u=X_u[i], X_w=X_w[i], x_0=x_0[i], E=no_conditions, e=no_values, consistent=True, rank=rows,
        shape=(rows, nx), singular_values=no_values, condition_number=value, rank_tolerance=rank_tolerance,
        certified=True) if value < limit else None for i, value in enumerate(bound.tolist())]


twin("certified_children", numpy=_certified_children_numpy, compiled=_certified_children_compiled)


def ambiguous_outputs(solution: AffineSolution, n_coordinates: int) -> AmbiguousOutputs:
    """Which outputs of ``x = (dv, lam)`` depend on w: ``"none"``, ``"forces"`` or ``"accelerations"``.

    ``"accelerations"`` means the motion itself is ambiguous (forces usually too); ``"forces"``
    means a statically indeterminate mode with determined accelerations.
    """
    return outputs_moved_by(solution.X_w, n_coordinates)


def outputs_moved_by(X_w: np.ndarray, n_coordinates: int) -> AmbiguousOutputs:
    """What the ambiguity directions ``X_w`` (nx, p) move: see :func:`ambiguous_outputs`."""
    if X_w.shape[1] == 0:
        return "none"
    mags = np.maximum.reduce(np.abs(X_w), axis=1)  # np.max without its Python wrapper
    threshold = OUTPUT_TOLERANCE * max(float(np.maximum.reduce(mags)), 1e-300)
    if np.count_nonzero(mags[:n_coordinates] > threshold):
        return "accelerations"
    if np.count_nonzero(mags[n_coordinates:] > threshold):
        return "forces"
    return "none"


__all__ = [
    "AffineSolution",
    "ambiguous_outputs",
    "BY_ROWS_INFO",
    "ROWS_RESIDUAL_ROUND_OFF",
    "by_rows_certified",
    "by_rows_factors",
    "certified_by_rows",
    "balanced_scaling",
    "BALANCING_SWEEPS",
    "CERTIFIED_MARGIN",
    "certified_children",
    "certified_responses",
    "BALANCING_FRICTION",
    "CONSISTENCY_TOLERANCE",
    "equilibrate_stack",
    "ILL_CONDITIONED_BAND",
    "OUTPUT_TOLERANCE",
    "outputs_moved_by",
    "power_of_two_scale",
    "RANK_TOLERANCE",
    "rebalance_undecided",
    "ROUND_OFF_RANK_DROP",
    "round_off_bound",
    "solve_affine",
    "solve_affine_stack",
    "VOID_CONDITIONS_SAFETY",
]
