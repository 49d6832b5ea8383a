"""Pictures of a flip plan: the input space with every mode's domain, and the simulated flip.

matplotlib is imported inside the functions (through :mod:`frcontrol.viz.plots`), figures are
made without pyplot, and every function raises :class:`~frcontrol.viz.VizError` when matplotlib
is missing.

- :func:`plot_flip_inputs`: a 2-D slice of the input space through the plan: each feasible mode's
  input domain T_c (filled and labelled when it has an interior, a thick grey segment or point when
  it is flat), the overlaps of two modes' T_c hatched (between-mode ambiguity), the pieces the
  plan chose among outlined, and the plan marked with a star. With two inputs the slice is the
  whole input box.
- :func:`plot_flip_motion`: the pitch over the simulated time (with the vertical to pass) and the
  contact forces.
- :func:`plot_flip`: both, side by side, in one file.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, reason_from_exception
from ..polytope import Polytope
from .flip import FlipPlan, FlipResult

__all__ = ["input_slice", "plot_flip", "plot_flip_inputs", "plot_flip_motion"]


def input_slice(
    polytope: Polytope, axes: tuple[int, int], through: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The 2-D slice ``{(u_a, u_b) : u in P, u_k = through_k for the other k}`` as ``(A, b)``.

    Equalities are written as two opposite rows (a flat set is drawn as a segment).
    """
    A = np.vstack([polytope.A, polytope.A_eq, -polytope.A_eq])
    b = np.concatenate([polytope.b, polytope.b_eq, -polytope.b_eq])
    others = [k for k in range(A.shape[1]) if k not in axes]
    rhs = b - A[:, others] @ through[others] if others else b
    return A[:, list(axes)], rhs


def _figure(**kwargs: Any) -> Any:
    """A matplotlib Figure (no pyplot)."""
    from ..viz import VizError

    try:
        from matplotlib.figure import Figure
    except ImportError as err:
        raise VizError("plotting needs matplotlib (a dependency): pip install matplotlib") from err
    return Figure(**kwargs)


def _save(figure: Any, path: str | Path) -> Path:
    from ..viz import OutputFileError

    target = Path(path)
    try:
        figure.savefig(target, dpi=120, bbox_inches="tight")
    except (OSError, ValueError) as err:  # ValueError: an unknown format suffix
        raise OutputFileError(target, reason_from_exception(err)) from err
    return target


def plot_flip_inputs(
    plan: FlipPlan,
    path: str | Path | None = None,
    ax: Any = None,
    *,
    axes: tuple[int, int] = (0, 1),
) -> Any:
    """Draw the plan's input space: the modes' T_c, the overlaps (hatched) and the plan (a star).

    Args:
        plan: a plan with its analysis (found or not).
        path: the file to write (None: do not write).
        ax: matplotlib Axes to draw into (default: a new figure).
        axes: the two planned inputs spanning the slice (indices into ``plan.planned_inputs``).

    Returns:
        The Axes drawn into.

    Raises:
        InputError: the plan has no analysis, fewer than two planned inputs, or bad axes.
        VizError: matplotlib is missing.
        OutputFileError: the file cannot be written.
    """
    from ..viz.plots import plot_polygons

    analysis = plan.analysis
    if analysis is None:
        raise InputError("the plan has no analysis to draw (no input was planned at this state)")
    m = analysis.problem.m
    if m < 2:
        raise InputError(f"the input-space picture needs two planned inputs; the plan has {m} "
                         f"({', '.join(plan.planned_inputs) or 'none'})")
    if len(set(axes)) != 2 or not all(0 <= a < m for a in axes):
        raise InputError(f"axes must be two different indices below {m}, got {axes}")
    problem = analysis.problem
    names = problem.inputs
    through = (np.array([plan.torques[n] for n in names]) if plan.mode is not None
               else 0.5 * (problem.lower + problem.upper))
    lo, hi = problem.lower[list(axes)], problem.upper[list(axes)]
    pad = 0.03 * (hi - lo)
    box = (lo[0] - pad[0], hi[0] + pad[0], lo[1] - pad[1], hi[1] + pad[1])
    if ax is None:
        ax = _figure(figsize=(7.0, 6.0), layout="constrained").add_subplot()

    full = [mode for mode in analysis.feasible_modes if mode.inputs_full_dimensional]
    flat = [mode for mode in analysis.feasible_modes if not mode.inputs_full_dimensional]
    labels = (f"{names[axes[0]]} [N m]", f"{names[axes[1]]} [N m]")
    sets = [input_slice(mode.input_domain, axes, through) for mode in full]
    plot_polygons(sets, ax=ax, labels=[mode.mode for mode in full], box=box, alpha=0.25,
                  axis_labels=labels)
    if flat:
        plot_polygons([input_slice(mode.input_domain, axes, through) for mode in flat], ax=ax,
                      colors=["0.35"] * len(flat), box=box, alpha=0.0, axis_labels=labels)
    overlaps = []
    for overlap in analysis.overlaps:
        first, second = (analysis.mode(name).input_domain for name in overlap.modes)
        A1, b1 = input_slice(first, axes, through)
        A2, b2 = input_slice(second, axes, through)
        overlaps.append((np.vstack([A1, A2]), np.concatenate([b1, b2])))
    if overlaps:
        plot_polygons(overlaps, ax=ax, hatches=["xxx"] * len(overlaps), colors=["0.1"] * len(overlaps),
                      box=box, alpha=0.0, axis_labels=labels)
    chosen = [p for p in plan.pieces if p.mode == plan.mode]
    if chosen:
        plot_polygons([input_slice(p.region, axes, through) for p in chosen], ax=ax,
                      colors=["black"] * len(chosen), box=box, alpha=0.0, axis_labels=labels)
    if plan.mode is not None:
        ax.plot([through[axes[0]]], [through[axes[1]]], linestyle="none", marker="*", markersize=16,
                color="gold", markeredgecolor="black", zorder=7)
    if flat:
        ax.plot([], [], color="0.35", linewidth=3.0, label="flat T_c (e.g. a toe S: hip torque 0)")
    if overlaps:
        ax.fill([], [], facecolor="none", hatch="xxx", edgecolor="0.1", label="two modes (ambiguous)")
    ax.legend(loc="best", fontsize="x-small")
    status = (f"plan: {plan.mode}, pitch acceleration {plan.pitch_acceleration:.4g} rad/s$^2$"
              if plan.found else f"no flip plan{f' (best: {plan.mode})' if plan.mode else ''}")
    others = [k for k in range(m) if k not in axes]
    sliced = ("; slice at " + ", ".join(f"{names[k]} = {through[k]:.4g}" for k in others)) if others else ""
    ax.set_title(f"input domains T_c (hatched: two modes), margin {plan.margin:g} N m\n{status}{sliced}",
                 fontsize="small")
    if path is not None:
        _save(ax.figure, path)
    return ax


def plot_flip_motion(result: FlipResult, axes: Sequence[Any]) -> None:
    """The pitch (top Axes) and the contact forces (bottom Axes) over the simulated time.

    Raises:
        InputError: the result has no trajectory.
    """
    traj = result.trajectory
    if traj is None:
        raise InputError("the flip was not simulated (no first plan): nothing to draw over time")
    top, bottom = axes
    pitch_name = result.plan.pitch or "theta"
    times = np.asarray(traj.times)
    pitch = traj.coordinate(pitch_name)
    top.plot(times, pitch, color="C0", label=pitch_name)
    top.axhline(result.vertical, color="0.3", linestyle="--", linewidth=0.9,
                label=f"vertical ({result.vertical:.4f} rad)")
    if result.time_to_vertical is not None:
        top.axvline(result.time_to_vertical, color="C2", linestyle=":", linewidth=1.0,
                    label=f"vertical at {result.time_to_vertical:.3f} s")
    if result.separation is not None:
        top.axvline(result.separation[0], color="C3", linestyle=":", linewidth=1.0,
                    label=f"{result.separation[1]} separates")
    top.set_ylabel("pitch [rad]")
    top.legend(loc="best", fontsize="x-small")
    forces = np.asarray(traj.contact_forces)
    for j, name in enumerate(traj.contacts):
        if not np.any(forces[:, j, 0] > 0):
            continue
        bottom.plot(times, forces[:, j, 0], color=f"C{j % 10}", label=f"{name} $\\lambda_n$")
        bottom.plot(times, forces[:, j, 1], color=f"C{j % 10}", linestyle="--", linewidth=0.8,
                    label=f"{name} $\\lambda_t$")
    bottom.axhline(0.0, color="0.6", linewidth=0.8)
    # impacts are impulses over one step (thousands of N): keep the sustained forces readable
    sustained = float(np.percentile(np.abs(forces), 99.0)) if forces.size else 0.0
    if sustained > 0 and np.max(np.abs(forces)) > 2.0 * sustained:
        bottom.set_ylim(-1.5 * sustained, 1.5 * sustained)
        bottom.text(0.01, 0.02, "impact spikes clipped", transform=bottom.transAxes, fontsize="x-small",
                    color="0.4")
    bottom.set_ylabel("contact force [N]")
    bottom.set_xlabel("time [s]")
    bottom.legend(loc="best", fontsize="x-small", ncol=2)
    verdict = ("flipped" if result.flipped else "not flipped") + (
        ", body contact kept" if result.body_contact_kept else ", body contact lost")
    top.set_title(f"closed loop: {verdict} ({result.replans} re-plans, dt = {result.dt:g} s)",
                  fontsize="small")
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)


def plot_flip(result: FlipResult | FlipPlan, path: str | Path, *, axes: tuple[int, int] = (0, 1)) -> Path:
    """One figure: the input space (left) and, for a simulated flip, the pitch and forces (right).

    Returns:
        The path written.

    Raises:
        VizError: matplotlib is missing. OutputFileError: the file cannot be written.
        InputError: see :func:`plot_flip_inputs`.
    """
    plan = result.plan if isinstance(result, FlipResult) else result
    simulated = isinstance(result, FlipResult) and result.trajectory is not None
    figure = _figure(figsize=(13.0 if simulated else 7.0, 6.0), layout="constrained")
    if simulated:
        grid = figure.add_gridspec(2, 2, width_ratios=[1.0, 1.1])
        left = figure.add_subplot(grid[:, 0])
        top = figure.add_subplot(grid[0, 1])
        bottom = figure.add_subplot(grid[1, 1], sharex=top)
        plot_flip_motion(result, (top, bottom))
    else:
        left = figure.add_subplot()
    if plan.analysis is not None and plan.analysis.problem.m >= 2:
        plot_flip_inputs(plan, ax=left, axes=axes)
    else:
        left.text(0.5, 0.5, plan.reason or "no input space to draw", ha="center", va="center",
                  wrap=True, transform=left.transAxes)
        left.set_axis_off()
    figure.suptitle(f"{_scene_name(result)}: the flip plan", fontsize="medium")
    return _save(figure, path)


def _scene_name(result: FlipResult | FlipPlan) -> str:
    if isinstance(result, FlipResult) and result.trajectory is not None:
        return result.trajectory.scene_name
    return "flip"
