"""Figures of results: the flip plan and its simulation, the climb plan, a statics report.

matplotlib is imported inside the functions (through :mod:`frcontrol.viz.plots`), figures are
made without pyplot, and every function raises :class:`~frcontrol.viz.VizError` when matplotlib
is missing. No text of a figure overlaps another (:func:`frcontrol.viz.plots.text_overlaps` is
the check the tests run); regions are bounded (clipped to the input or analysis box, drawn);
geometry and force planes have equal aspect.

- :func:`plot_flip_inputs`: a 2-D slice of the input space through the plan: each feasible mode's
  input domain T_c (filled and labelled when it has an interior, a thick grey segment or point when
  it is flat), the overlaps of two modes' T_c hatched (between-mode ambiguity), the pieces the
  plan chose among outlined, and the plan marked with a star. With two inputs the slice is the
  whole input box.
- :func:`plot_flip_motion`: the pitch over the simulated time (with the vertical to pass) and the
  contact forces.
- :func:`plot_flip`: both, side by side, in one file.
- :func:`plot_climb`: per disturbance, P, the largest scale's s P and the plan's robust region.
- :func:`plot_statics`: the body, its contacts and friction cones, the equilibrium forces, the
  support interval and region.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..geometry import row_norms
from ..modes import mode_heading, scene_mode
from ..planning.climb import ClimbPlan
from ..planning.climb_check import robust_region
from ..planning.flip import FlipPlan
from ..planning.flip_loop import FlipResult
from ..polytope import Polytope
from ..scene import Scene
from ..statics import StaticsReport
from .plots import (
    REGION_LABEL_STYLE,
    PolygonPanel,
    frame_axes,
    place_labels,
    plot_polygons,
    polygon_from_halfplanes,
)
from .plots import new_figure as _figure
from .plots import save_figure as _save
from .shapes import pose_matrix
from .visuals import link_visuals, visual_outline

__all__ = [
    "BODY_EDGE",
    "BODY_FACE",
    "CLIMB_WINDOW_MARGIN",
    "STATICS_WINDOW_MARGIN",
    "SUPPORT_REGION_TOLERANCE",
    "NO_MODE_LABEL",
    "FLIP_ZOOM_FRACTION",
    "FLIP_ZOOM_MARGIN",
    "flip_figure",
    "flip_zoom_window",
    "input_slice",
    "plot_climb",
    "plot_flip",
    "plot_flip_inputs",
    "plot_flip_motion",
    "plot_flip_zoom",
    "plot_statics",
]

NO_MODE_LABEL = "no mode: no rigid solution"
"""Legend entry of the input space's white: inputs outside every feasible mode's T_c, where the
rigid model has no solution (the analysis covers every mode)."""


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


@dataclass(frozen=True)
class _InputSpace:
    """The 2-D slice of a plan's input space that the flip figure draws.

    Attributes:
        plan: the plan (with its analysis).
        axes: the two planned inputs spanning the slice (indices).
        through: [N m] the point the slice passes through (the plan, else the box's middle).
        box: the input box on the two axes, padded by 3 %: (xmin, xmax, ymin, ymax).
        axis_labels: the two axes' names with their unit.
    """

    plan: FlipPlan
    axes: tuple[int, int]
    through: np.ndarray
    box: tuple[float, float, float, float]
    axis_labels: tuple[str, str]


def _input_space(plan: FlipPlan, axes: tuple[int, int]) -> _InputSpace:
    """The slice of ``plan``'s input space spanned by ``axes``, checked.

    Raises:
        InputError: the plan has no analysis, fewer than two planned inputs, or bad axes.
    """
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
    return _InputSpace(plan, axes, through, box, (f"{names[axes[0]]} [N m]", f"{names[axes[1]]} [N m]"))


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
    space = _input_space(plan, axes)
    if ax is None:
        ax = _figure(figsize=(7.0, 6.0), layout="constrained").add_subplot()
    region_labels = _draw_input_space(ax, space, space.box)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize="x-small", ncol=4,
              title=_mode_legend_title(plan), title_fontsize="x-small")
    mode = _scene_mode(plan, plan.mode) if plan.mode is not None else None
    status = (f"plan: {mode}, pitch acceleration {plan.pitch_acceleration:.4g} rad/s$^2$"
              if plan.found else f"no flip plan{f' (best: {mode})' if mode else ''}")
    names = plan.analysis.problem.inputs if plan.analysis is not None else ()
    others = [k for k in range(len(names)) if k not in axes]
    sliced = ("; slice at " + ", ".join(f"{names[k]} = {space.through[k]:.4g}" for k in others)
              if others else "")
    ax.set_title(f"input domains T_c (hatched: two modes), margin {plan.margin:g} N m\n{status}{sliced}",
                 fontsize="small")
    # last: the layout is final, so labels are measured where they will be
    place_labels(ax, region_labels, **REGION_LABEL_STYLE)
    if path is not None:
        _save(ax.figure, path)
    return ax


def _scene_mode(plan: FlipPlan, mode: str) -> str:
    """The plan's mode over every scene contact (as every output shows it), or as it is without them."""
    return scene_mode(mode, plan.contacts, plan.scene_contacts) if plan.scene_contacts else mode


def _mode_legend_title(plan: FlipPlan) -> str:
    """The legend's title: which contact each mode letter is."""
    return mode_heading(plan.scene_contacts or plan.contacts) + ": S separate, L/R slide, F fixed"


def _draw_input_space(ax: Any, space: _InputSpace, window: tuple[float, float, float, float]
                      ) -> list[tuple[str, np.ndarray, float]]:
    """Every mode's T_c, the overlaps, the chosen pieces and the plan, in ``window``, equal aspect.

    Returns:
        The region labels ``(mode, centroid, area)`` to place once the figure is laid out.
    """
    analysis = space.plan.analysis
    assert analysis is not None  # checked by _input_space
    full = [mode for mode in analysis.feasible_modes if mode.inputs_full_dimensional]
    flat = [mode for mode in analysis.feasible_modes if not mode.inputs_full_dimensional]
    sets = [input_slice(mode.feasible_input_domain, space.axes, space.through) for mode in full]
    plot_polygons(sets, ax=ax, labels=[_scene_mode(space.plan, mode.mode) for mode in full],
                  panel=PolygonPanel(box=window, alpha=0.25, axis_labels=space.axis_labels, legend=False,
                                     label_regions=False))
    region_labels = ax._frcontrol_region_labels
    _draw_flat_overlapping_and_chosen(ax, space.plan, flat, space.axes, space.through, window,
                                      space.axis_labels)
    ax.set_aspect("equal", adjustable="box")
    ax.xaxis.set_major_locator(_locator())
    ax.yaxis.set_major_locator(_locator())
    return list(region_labels)


FLIP_ZOOM_FRACTION = 0.4
"""The flip figure adds a panel zoomed on the smaller input domains (every full-dimensional T_c
but the largest) when their box spans less than this fraction of the input box on both axes:
at that size their colours and labels would not be readable in the whole box."""

FLIP_ZOOM_MARGIN = 0.08
"""The zoom panel shows the smaller domains' box enlarged by this fraction of its size on every side."""


def flip_zoom_window(plan: FlipPlan, *, axes: tuple[int, int] = (0, 1)
                     ) -> tuple[float, float, float, float] | None:
    """The window (xmin, xmax, ymin, ymax) of the flip figure's zoom panel, or None if none is needed.

    It frames every full-dimensional T_c of the slice but the largest (by the area of its box), when
    they span less than :data:`FLIP_ZOOM_FRACTION` of the input box on both axes.

    Raises:
        InputError: see :func:`plot_flip_inputs`.
    """
    space = _input_space(plan, axes)
    analysis = plan.analysis
    assert analysis is not None  # checked by _input_space
    boxes = []
    for mode in analysis.feasible_modes:
        if mode.inputs_full_dimensional:
            A, b = input_slice(mode.feasible_input_domain, axes, space.through)
            vertices = polygon_from_halfplanes(A, b, space.box)
            if len(vertices) >= 3:
                boxes.append((vertices.min(axis=0), vertices.max(axis=0)))
    boxes.sort(key=lambda lohi: float(np.prod(lohi[1] - lohi[0])))
    if len(boxes) < 2:
        return None
    lo = np.min([low for low, _ in boxes[:-1]], axis=0)
    hi = np.max([high for _, high in boxes[:-1]], axis=0)
    whole = np.array([space.box[1] - space.box[0], space.box[3] - space.box[2]])
    if np.any(hi - lo > FLIP_ZOOM_FRACTION * whole):
        return None
    grow = FLIP_ZOOM_MARGIN * np.maximum(hi - lo, 1e-3 * whole)
    return (lo[0] - grow[0], hi[0] + grow[0], lo[1] - grow[1], hi[1] + grow[1])


def plot_flip_zoom(plan: FlipPlan, ax: Any, window: tuple[float, float, float, float], *,
                   axes: tuple[int, int] = (0, 1)) -> list[tuple[str, np.ndarray, float]]:
    """Draw the input space in ``window`` (:func:`flip_zoom_window`), titled as a zoom.

    Returns:
        The region labels, for :func:`~frcontrol.viz.plots.place_labels` once the figure is laid out.

    Raises:
        InputError: see :func:`plot_flip_inputs`.
    """
    labels = _draw_input_space(ax, _input_space(plan, axes), window)
    ax.set_title("zoom on the smaller domains (the dashed box above)", fontsize="small")
    return labels


def _draw_flat_overlapping_and_chosen(ax: Any, plan: FlipPlan, flat: Sequence[Any], axes: tuple[int, int],
                                      through: np.ndarray, box: tuple[float, float, float, float],
                                      labels: tuple[str, str]) -> None:
    """On the input space: flat T_c, overlaps, the chosen pieces, the plan, and their legend.

    Flat T_c are thick grey, two modes' overlaps hatched, the chosen pieces outlined, the plan a
    star; the legend also explains the white.
    """
    analysis = plan.analysis
    assert analysis is not None  # checked by the caller
    outline = PolygonPanel(box=box, alpha=0.0, axis_labels=labels)
    if flat:
        plot_polygons([input_slice(mode.feasible_input_domain, axes, through) for mode in flat], ax=ax,
                      colors=["0.35"] * len(flat), panel=outline)
    overlaps = []
    for overlap in analysis.overlaps:
        first, second = (analysis.mode(name).feasible_input_domain for name in overlap.modes)
        A1, b1 = input_slice(first, axes, through)
        A2, b2 = input_slice(second, axes, through)
        overlaps.append((np.vstack([A1, A2]), np.concatenate([b1, b2])))
    if overlaps:
        plot_polygons(overlaps, ax=ax, hatches=["xxx"] * len(overlaps), colors=["0.1"] * len(overlaps),
                      panel=outline)
    chosen = [p for p in plan.pieces if p.mode == plan.mode]
    if chosen:
        plot_polygons([input_slice(p.region, axes, through) for p in chosen], ax=ax,
                      colors=["black"] * len(chosen), panel=outline)
    if plan.mode is not None:
        ax.plot([through[axes[0]]], [through[axes[1]]], linestyle="none", marker="*", markersize=16,
                color="gold", markeredgecolor="black", zorder=7,
                label="the plan's torques" if plan.found else "the best torques (not a plan)")
    if flat:
        ax.plot([], [], color="0.35", linewidth=3.0, marker="o",
                label="flat T_c (e.g. a toe S: hip torque 0)")
    if overlaps:
        ax.fill([], [], facecolor="none", hatch="xxx", edgecolor="0.1", label="two modes (ambiguous)")
    ax.fill([], [], facecolor="white", edgecolor="0.5", label=NO_MODE_LABEL)
    if chosen:
        ax.plot([], [], color="black", linewidth=1.2,
                label=f"pieces of {_scene_mode(plan, plan.mode or '')} (unambiguous)")


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
    """Write :func:`flip_figure` to ``path``.

    Returns:
        The path written.

    Raises:
        VizError: matplotlib is missing. OutputFileError: the file cannot be written.
        InputError: see :func:`plot_flip_inputs`.
    """
    return _save(flip_figure(result, axes=axes), path)


def flip_figure(result: FlipResult | FlipPlan, *, axes: tuple[int, int] = (0, 1)) -> Any:
    """One figure: the input space (left) and, for a simulated flip, the pitch and forces (right).

    When the smaller domains are small in the input box (:func:`flip_zoom_window`), a second panel
    below the input space zooms on them, and a dashed box in the first shows where.

    Raises:
        VizError: matplotlib is missing. InputError: see :func:`plot_flip_inputs`.
    """
    from matplotlib.patches import Rectangle

    plan = result.plan if isinstance(result, FlipResult) else result
    simulated = isinstance(result, FlipResult) and result.trajectory is not None
    drawable = plan.analysis is not None and plan.analysis.problem.m >= 2
    window = flip_zoom_window(plan, axes=axes) if drawable else None
    figure = _figure(figsize=(13.0 if simulated else 7.0, 6.0 if window is None else 10.5),
                     layout="constrained")
    figure.suptitle(f"{_scene_name(result)}: the flip plan", fontsize="medium")
    grid = figure.add_gridspec(2, 2 if simulated else 1, width_ratios=[1.0, 1.1] if simulated else None)
    left = figure.add_subplot(grid[:, 0] if window is None else grid[0, 0])
    zoom = None if window is None else figure.add_subplot(grid[1, 0])
    if isinstance(result, FlipResult) and result.trajectory is not None:
        top = figure.add_subplot(grid[0, 1])
        plot_flip_motion(result, (top, figure.add_subplot(grid[1, 1], sharex=top)))
    zoom_labels = [] if zoom is None or window is None else plot_flip_zoom(plan, zoom, window, axes=axes)
    if drawable:
        plot_flip_inputs(plan, ax=left, axes=axes)
    else:
        left.text(0.5, 0.5, plan.reason or "no input space to draw", ha="center", va="center",
                  wrap=True, transform=left.transAxes)
        left.set_axis_off()
    if zoom is not None and window is not None:
        left.add_patch(Rectangle((window[0], window[2]), window[1] - window[0], window[3] - window[2],
                                 fill=False, edgecolor="0.2", linestyle="--", linewidth=1.0, zorder=8,
                                 label="the zoom panel's window"))
        left.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize="x-small", ncol=4,
                    title=_mode_legend_title(plan), title_fontsize="x-small")
        place_labels(zoom, zoom_labels, **REGION_LABEL_STYLE)
    return figure


def _scene_name(result: FlipResult | FlipPlan) -> str:
    if isinstance(result, FlipResult) and result.trajectory is not None:
        return result.trajectory.scene_name
    return "flip"


# ------------------------------------------------------------------------------------ climbing

CLIMB_WINDOW_MARGIN = 0.06
"""Each climb panel shows the analysis box enlarged by this fraction of its size on every side."""


def plot_climb(plan: ClimbPlan, path: str | Path | None = None) -> Any:
    """One panel per disturbance: P, the largest scale's ``s P`` and the plan's robust region.

    The robust region (:func:`~frcontrol.planning.climb_check.robust_region`) is the set of forces of
    that disturbance that keep the planned torques in the brace mode's unambiguous piece with the
    head rising, whatever the other disturbances do in their polygons; it contains ``P`` when the
    plan is robust. It is computed inside the analysis box, drawn dashed: where it meets the box,
    the box (no physics) cuts it. Forces share one scale on both axes.

    Raises:
        InputError: the plan was not found.
        VizError: matplotlib is missing. OutputFileError: the file cannot be written.
    """
    if not plan.found:
        raise InputError(f"the climb plan was not found ({plan.reason}): nothing to plot")
    items = plan.disturbances.items
    figure = _figure(figsize=(5.0 * len(items), 5.6), layout="constrained")
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Rectangle

    s_max = plan.max_disturbance_scale
    colors = ["tab:green", "tab:orange", "tab:blue"]
    hatches = [None, "//", None]
    labels = ["robust region at the planned torques", f"largest scale s = {s_max:.3g} (its own torques)",
              f"P (scale {plan.scale:.3g})"]
    lower, upper = plan.problem.box
    for i, dist in enumerate(items):
        ax = figure.add_subplot(1, len(items), i + 1)
        low, high = lower[2 * i:2 * i + 2], upper[2 * i:2 * i + 2]
        grow = CLIMB_WINDOW_MARGIN * (high - low)
        window = (low[0] - grow[0], high[0] + grow[0], low[1] - grow[1], high[1] + grow[1])
        sets = [robust_region(plan, i), dist.polytope(s_max), dist.polytope(plan.scale)]
        robust = "robust" if plan.robust else "NOT robust"
        panel = PolygonPanel(box=window, axis_labels=(f"{dist.name}: $f_x$ [N]", f"{dist.name}: $f_y$ [N]"),
                             title=f"{dist.name} on {dist.link} ({robust})", legend=False)
        plot_polygons(sets, ax=ax, colors=colors, hatches=hatches, points=np.zeros((1, 2)), panel=panel)
        ax.add_patch(Rectangle((low[0], low[1]), high[0] - low[0], high[1] - low[1], fill=False,
                               edgecolor="0.3", linestyle="--", linewidth=1.0, zorder=4))
        ax.set_aspect("equal", adjustable="box")
        ax.xaxis.set_major_locator(_locator())
        ax.yaxis.set_major_locator(_locator())
    handles: list[Any] = [Patch(facecolor=c, alpha=0.35, hatch=h, edgecolor=c, label=label)
                          for c, h, label in zip(colors, hatches, labels, strict=True)]
    handles.append(Patch(fill=False, edgecolor="0.3", linestyle="--", label="analysis box (cuts the region)"))
    handles.append(Line2D([], [], linestyle="none", marker="*", markersize=10, color="black",
                          label="zero disturbance"))
    figure.legend(handles=handles, loc="outside lower center", ncol=2, fontsize="small")
    if path is not None:
        _save(figure, path)
    return figure


def _locator(bins: int = 6) -> Any:
    """Round tick steps, few enough that the labels never touch."""
    from matplotlib.ticker import MaxNLocator

    return MaxNLocator(nbins=bins, steps=[1, 2, 2.5, 5, 10])


# ------------------------------------------------------------------------------------- statics

BODY_FACE, BODY_EDGE = "#9ecae1", "#3182bd"
"""Colours of the body's links in the statics figure."""

SUPPORT_REGION_TOLERANCE = 1e-9
"""Relative to the statics figure's span: a support-region vertex this close to the window's
edge lies on it (the region is cut there), and a window corner this far outside the region's
half-planes still counts as inside (the region covers the whole window)."""

STATICS_WINDOW_MARGIN = 0.35
"""The statics figure shows the body's box (links, contacts, centre of mass) enlarged by this
fraction of its larger side on every side; unbounded support sets are cut at that window."""


def plot_statics(scene: Scene, report: StaticsReport, path: str | Path | None = None) -> Any:
    """The body, its contacts and friction cones, the equilibrium forces and the support sets.

    The links are drawn from their URDF visuals (:func:`frcontrol.viz.link_visuals`); the support
    interval of the centre of mass's x is a bar at the centre of mass's height (an arrow head
    where it is unbounded), the planar support region (with a lateral acceleration) is hatched,
    cut at the window when it is unbounded (a faint tint when it covers the whole window), and
    the legend says so.

    Returns:
        The figure (also written to ``path`` when given).

    Raises:
        VizError: matplotlib is missing. OutputFileError: the file cannot be written.
    """
    body = report.body
    figure = _figure(figsize=(7.0, 6.4), layout="constrained")
    ax = figure.add_subplot()
    pts = np.vstack([body.points, body.com[None, :], *_draw_body_links(ax, scene)])
    span = float(max(np.ptp(pts[:, 0]), np.ptp(pts[:, 1]), 0.2))
    lo, hi = pts.min(axis=0) - STATICS_WINDOW_MARGIN * span, pts.max(axis=0) + STATICS_WINDOW_MARGIN * span
    names = _draw_contacts_at_rest(ax, report, span)
    c = body.com
    ax.plot(*c, "k+", ms=12, mew=2, zorder=6)
    if body.weight > 0:
        ax.annotate("", c + np.array([0.0, -0.25 * span]), c,
                    arrowprops={"arrowstyle": "->", "color": "k", "lw": 1.5}, zorder=6)
    if report.support.feasible:
        _draw_support(ax, report.support, c, lo, hi, span)
    eq = report.equilibrium
    verdict = (f"form closure: {_yes(report.form_closure.closed)}, force closure: "
               f"{_yes(report.force_closure.closed)}\nequilibrium: {_yes(eq.exists)}, weakly stable: "
               f"{_yes(report.weakly_stable)}, strongly stable: {_yes(report.strongly_stable)}")
    frame_axes(ax, (lo[0], hi[0], lo[1], hi[1]), ("x [m]", "y [m]"), f"{report.scene_name}\n{verdict}")
    ax.title.set_fontsize(9)
    ax.set_aspect("equal", adjustable="box")
    ax.xaxis.set_major_locator(_locator())
    ax.yaxis.set_major_locator(_locator())
    ax.legend(handles=[*_statics_marks(report), *ax.get_legend_handles_labels()[0]],
              loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize=8, ncol=2)
    place_labels(ax, names, **{**REGION_LABEL_STYLE, "zorder": 7})
    if path is not None:
        _save(figure, path)
    return figure


def _statics_marks(report: StaticsReport) -> list[Any]:
    """Legend entries of the statics figure's marks: the body, the contacts, cones, forces and weight."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    marks = [Patch(facecolor=BODY_FACE, edgecolor=BODY_EDGE, label="the body's links"),
             Line2D([], [], color="0.3", lw=2, label="contact surface"),
             Line2D([], [], color="#e6550d", marker="o", linestyle="none", label="contact point"),
             Patch(facecolor="#fdd0a2", edgecolor="#e6550d", alpha=0.6,
                   label="friction cone (half-angle atan mu)"),
             Line2D([], [], color="k", marker="+", markersize=12, markeredgewidth=2, linestyle="none",
                    label="centre of mass")]
    if report.body.weight > 0:
        marks.append(Line2D([], [], color="k", lw=1.5, marker=">", label="gravity's direction (arrow)"))
    if report.equilibrium.lambda_n is not None:
        marks.append(Line2D([], [], color="#31a354", lw=2, marker=">",
                            label="equilibrium contact force (arrow, longest 30 % of the view)"))
    return marks


def _draw_body_links(ax: Any, scene: Scene) -> list[np.ndarray]:
    """The robot's links at the scene's state, from their URDF visuals; returns their outlines [m]."""
    from matplotlib.patches import Polygon


    poses = scene.robot.link_poses(scene.q)
    outlines = []
    for link, shapes in link_visuals(scene.robot, [c.point for c in scene.contacts]).items():
        origin, angle = poses[link]
        for visual in shapes:
            outline = visual_outline(visual, pose_matrix(origin, angle))
            ax.add_patch(Polygon(outline, closed=True, zorder=2, facecolor=BODY_FACE, edgecolor=BODY_EDGE))
            outlines.append(outline)
    return outlines


def _draw_contacts_at_rest(ax: Any, report: StaticsReport, span: float
                           ) -> list[tuple[str, np.ndarray, float]]:
    """Each contact: its surface, friction cone and point, and its equilibrium force as an arrow.

    The longest force arrow is 30 % of ``span`` [m], the cones 25 %.

    Returns:
        The contacts' name labels ``(name, point, importance)``, on the surface's side of each
        point, for :func:`~frcontrol.viz.plots.place_labels`.
    """
    from matplotlib.patches import Polygon

    body, eq = report.body, report.equilibrium
    cone_length = 0.25 * span
    forces = (None if eq.lambda_n is None or eq.lambda_t is None else
              np.column_stack([eq.lambda_n, eq.lambda_t]))
    biggest = 0.0 if forces is None else float(np.max(np.hypot(forces[:, 0], forces[:, 1]), initial=0.0))
    force_scale = 0.3 * span / biggest if biggest > 0 else 0.0
    names = []
    for i, name in enumerate(body.contact_names):
        p, n, t, mu = body.points[i], body.normals[i], body.tangents[i], body.mu[i]
        ax.plot(*np.array([p - 0.3 * span * t, p + 0.3 * span * t]).T, color="0.3", lw=2, zorder=1)
        half_angle = min(math.atan(mu), math.radians(89.0))
        edges = [math.cos(half_angle) * n + sgn * math.sin(half_angle) * t for sgn in (1.0, -1.0)]
        ax.add_patch(Polygon(np.array([p, p + cone_length * edges[0], p + cone_length * edges[1]]),
                             closed=True, facecolor="#fdd0a2", edgecolor="#e6550d", alpha=0.6, zorder=3))
        ax.plot(*p, "o", color="#e6550d", zorder=4)
        names.append((name, p - 0.08 * span * n, 1.0))  # on the surface's side, off the cone
        if force_scale > 0 and forces is not None:
            ax.annotate("", p + force_scale * (forces[i, 0] * n + forces[i, 1] * t), p, zorder=5,
                        arrowprops={"arrowstyle": "->", "color": "#31a354", "lw": 2})
    return names


def _draw_support(ax: Any, sup: Any, c: np.ndarray, lo: np.ndarray, hi: np.ndarray, span: float) -> None:
    """The support interval and region of a statics report, cut at the view ``lo``..``hi``.

    The interval of the CoM's x is a bar at the CoM's height (arrows where unbounded); the planar
    region under a lateral acceleration is hatched, and its legend entry says when it is cut. A
    region that covers the whole view is a faint tint, not a hatch over everything.
    """
    from matplotlib.patches import Polygon

    x0, x1 = max(sup.x_min, lo[0]), min(sup.x_max, hi[0])
    open_ends = [side for side, value in (("left", sup.x_min), ("right", sup.x_max))
                 if not math.isfinite(value)]
    label = "support interval of the CoM's x" + (
        f" (unbounded {' and '.join(open_ends)})" if open_ends else "")
    ax.plot([x0, x1], [c[1], c[1]], color="#31a354", lw=6, alpha=0.45, solid_capstyle="butt",
            zorder=2.5, label=label)
    for side in open_ends:
        end, step = (x0, -1.0) if side == "left" else (x1, 1.0)
        ax.annotate("", (end, c[1]), (end - step * 0.06 * span, c[1]), zorder=2.5,
                    arrowprops={"arrowstyle": "-|>", "color": "#31a354", "lw": 1.5})
    if sup.lateral_acceleration == 0.0 or sup.region is None:
        return
    window = (lo[0], hi[0], lo[1], hi[1])
    region = polygon_from_halfplanes(sup.region.A, sup.region.b, window)
    if len(region) < 3:
        return
    corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    slack = SUPPORT_REGION_TOLERANCE * span * row_norms(sup.region.A)
    whole = bool(np.all(sup.region.A @ corners.T <= (sup.region.b + slack)[:, None]))
    on_window = np.zeros(len(region), dtype=bool)
    for axis, bound in ((0, lo[0]), (0, hi[0]), (1, lo[1]), (1, hi[1])):
        on_window |= np.isclose(region[:, axis], bound, atol=SUPPORT_REGION_TOLERANCE * span)
    cut = (", cut at the view: it covers all of it" if whole else
           ", cut at the view" if np.any(on_window) else "")
    label = f"support region, |a| <= {sup.lateral_acceleration:g} m/s$^2${cut}"
    style = ({"facecolor": "#006d2c", "alpha": 0.07, "edgecolor": "none"} if whole else
             {"facecolor": "none", "edgecolor": "#006d2c", "hatch": "..", "lw": 1.5})
    ax.add_patch(Polygon(region, closed=True, zorder=1, label=label, **style))


def _yes(flag: bool | None) -> str:
    return "-" if flag is None else ("yes" if flag else "no")
