"""Every mode system decided rank-deficient, and how far from round-off.

``python -m benchmarks.rank_decisions [SCENE ...]``.

For every shipped scene, at its own friction and with every contact's mu set to each decade from
1 to 1e8, every system the engine factorises (each full mode and each partial mode the tree grows)
is decided as :mod:`frcontrol.response` decides it. Each one decided rank-deficient is printed with
its largest dropped singular value relative to the largest one, under the first (max-abs) scaling and
under :func:`frcontrol.response.balanced_scaling` (nan for a system with a singular value exactly
0, which is not balanced), that value over
:func:`frcontrol.response.round_off_bound` (``roundoff``: at most 1 for a rank drop a change of
each entry by ``n`` eps of itself explains), and the verdict of
:func:`frcontrol.response.rebalance_undecided` (``dropped``: decided rank-deficient; ``undecided``:
the analysis raises IllConditioned). ``--all`` also prints, per scene and friction, the count of
systems.
"""

from __future__ import annotations

import argparse
import itertools
import sys

import numpy as np

FRICTIONS = (None, *(10.0**k for k in range(9)))


def _systems(problem):
    """Every full mode and every partial mode of ``problem``: (mode, A)."""
    from frcontrol.modes import build_mode_system

    allowed = problem.allowed_modes()
    for depth in range(1, problem.k + 1):
        for letters in itertools.product(*allowed[:depth]):
            mode = "".join(letters)
            yield mode, build_mode_system(problem, mode).A


def _row(A: np.ndarray) -> dict | None:
    """The rank decision of one system, with its balanced figures when it drops rank."""
    from frcontrol.response import (
        ILL_CONDITIONED_BAND,
        RANK_TOLERANCE,
        _equilibrate,
        balanced_scaling,
        rebalance_undecided,
        round_off_bound,
    )

    r, c = _equilibrate(A)
    A_hat = A * r[:, None] * c[None, :]
    U, s, Vt = np.linalg.svd(A_hat, full_matrices=True)
    undecided = np.zeros(0, dtype=int)
    decided = s
    if s[-1] <= ILL_CONDITIONED_BAND * s[0]:
        svd = (U[None].copy(), s[None].copy(), Vt[None].copy())
        undecided, _ = rebalance_undecided(A_hat[None].copy(), r[None].copy(), c[None].copy(), svd,
                                           RANK_TOLERANCE)
        decided = svd[1][0]
    rank = int(np.count_nonzero(decided > RANK_TOLERANCE * decided[0]))
    if rank == min(A.shape):
        return None
    row = {"size": min(A.shape), "rank": rank, "first": s[rank] / s[0],
           "verdict": "undecided" if undecided.size else "dropped"}
    if s[-1] == 0.0:  # not balanced: the first scaling's figures
        row.update(balanced=float("nan"), roundoff=s[rank] / round_off_bound(A_hat[None])[0])
        return row
    rows, cols = balanced_scaling(A_hat[None], (U[None], s[None], Vt[None]))
    balanced = A_hat[None] * rows[:, :, None] * cols[:, None, :]
    s_b = np.linalg.svd(balanced[0], compute_uv=False)
    row.update(balanced=s_b[rank] / s_b[0], roundoff=s_b[rank] / round_off_bound(balanced)[0])
    return row


def measure(scenes: list[str], show_all: bool) -> list[tuple]:
    """Rows (scene, mu, mode, size, rank, first, balanced, roundoff) of every rank-deficient system."""
    from frcontrol.modes import ContactProblem
    from frcontrol.scene import load_scene, shipped_scene_names

    found = []
    for name in scenes or shipped_scene_names():
        contacts = [contact.name for contact in load_scene(name).contacts]
        for mu in FRICTIONS:
            overrides = {} if mu is None else {f"contacts.{c}.mu": mu for c in contacts}
            problem = ContactProblem.from_scene(load_scene(name, overrides=overrides))
            count = 0
            for mode, A in _systems(problem):
                count += 1
                row = _row(A)
                if row is not None:
                    found.append((name, mu, mode, row))
            if show_all:
                print(f"# {name} mu={mu}: {count} systems", file=sys.stderr)
    return found


def main(argv: list[str] | None = None) -> int:
    """Print the table."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("scenes", nargs="*", help="shipped scene names (default: all)")
    parser.add_argument("--all", action="store_true", help="also count the systems per point")
    args = parser.parse_args(argv)
    print(f"{'scene':16} {'mu':>8} {'mode':10} {'n':>3} {'rank':>4} {'first':>9} {'balanced':>9} "
          f"{'roundoff':>9} verdict")
    for name, mu, mode, row in measure(args.scenes, args.all):
        label = "default" if mu is None else f"{mu:.0e}"
        print(f"{name:16} {label:>8} {mode:10} {row['size']:>3} {row['rank']:>4} {row['first']:9.2e} "
              f"{row['balanced']:9.2e} {row['roundoff']:9.2e} {row['verdict']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
