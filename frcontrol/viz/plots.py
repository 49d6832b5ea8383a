"""2-D figures for reports: trajectories over time, a scene in its plane, input-space polygons.

matplotlib is imported inside the functions, and figures are made with
:class:`matplotlib.figure.Figure` directly (Agg canvas, no pyplot, no global state), so plotting
works headless and changes nothing for a program that uses pyplot itself. Every function takes
an optional ``path`` (the file to write; the format follows its suffix: ``.png``, ``.pdf``,
``.svg``...) and, where a single panel is drawn, an optional ``ax`` to draw into an existing
figure (planners overlay their own marks). Every function raises
:class:`~frcontrol.viz.VizError` when matplotlib is not installed (a dependency of frcontrol:
``pip install matplotlib``).

- :func:`plot_trajectory`: chosen coordinates, and the contact forces (normal and tangential),
  over time.
- :func:`plot_scene`: the robot at a configuration, its contact points, surfaces and friction
  cones (and optionally the contact forces as arrows).
- :func:`plot_polygons`: 2-D H-polytopes ``A x <= b`` clipped to a box, filled, hatched and
  labelled; their vertices come from :func:`polygon_from_halfplanes`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from frcontrol.errors import CoordinateNotFound, InputError, reason_from_exception
from frcontrol.geometry import clip_polygon
from frcontrol.scene import Scene
from frcontrol.simulation.trajectory import Trajectory

from . import colors as palette
from .picture_errors import OutputFileError, VizError
from .shapes import friction_cone_directions, pose_matrix, surface_lines, surface_segments
from .visuals import link_visuals, visual_depth, visual_outline

__all__ = [
    "HALFPLANE_TOLERANCE",
    "new_figure",
    "save_figure",
    "text_overlaps",
    "LABEL_CLEARANCE",
    "frame_axes",
    "REGION_LABEL_STYLE",
    "place_labels",
    "PolygonPanel",
    "plot_polygons",
    "plot_scene",
    "plot_trajectory",
    "polygon_from_halfplanes",
]

HALFPLANE_TOLERANCE = 1e-9
"""[units of x] A vertex within this distance of a half-plane's boundary counts as on it, and
vertices closer than this to each other are merged (rows are normalised first)."""

_DEFAULT_BOX_HALF_WIDTH = 1e6
"""Half width of the clipping box when none is given: a set reaching it is unbounded."""


def new_figure(**kwargs: Any) -> Any:
    """A matplotlib :class:`~matplotlib.figure.Figure` (no pyplot); ``kwargs`` go to it.

    Raises:
        VizError: matplotlib is not installed.
    """
    try:
        from matplotlib.figure import Figure
    except ImportError as err:
        raise VizError("plotting needs matplotlib (a dependency): pip install matplotlib") from err
    return Figure(**kwargs)


def _polygon_patch() -> Any:
    try:
        from matplotlib.patches import Polygon
    except ImportError as err:
        raise VizError("plotting needs matplotlib (a dependency): pip install matplotlib") from err
    return Polygon


def save_figure(figure: Any, path: str | Path) -> Path:
    """Write a figure (its format by the file's suffix) at 120 dpi, cropped to what is drawn.

    Raises:
        OutputFileError: the file cannot be written, or its suffix is no format matplotlib knows.
    """
    target = Path(path)
    try:
        figure.savefig(target, dpi=120, bbox_inches="tight")
    except (OSError, ValueError) as err:  # ValueError: an unknown format suffix
        raise OutputFileError(target, reason_from_exception(err)) from err
    return target


# ------------------------------------------------------------------------------ text layout

LABEL_CLEARANCE = 1.0
"""[px] Two texts whose boxes come closer than this overlap (:func:`text_overlaps`)."""


def _drawn_texts(figure: Any) -> list[tuple[str, Any, Any]]:
    """(what, Text, window box) of every visible, non-empty text of the laid-out figure.

    Titles, axis labels, the tick labels inside the view, annotations and legend entries.
    """
    figure.draw_without_rendering()
    renderer = figure._get_renderer()
    found: list[tuple[str, Any]] = []
    if figure._suptitle is not None:
        found.append(("suptitle", figure._suptitle))
    for i, ax in enumerate(figure.axes):
        if not ax.get_visible() or not ax.axison and not ax.texts:
            continue
        found += [(f"axes{i} title", t) for t in (ax.title, ax._left_title, ax._right_title)]
        found += [(f"axes{i} xlabel", ax.xaxis.label), (f"axes{i} ylabel", ax.yaxis.label)]
        for name, axis, (low, high) in (("x", ax.xaxis, ax.get_xlim()), ("y", ax.yaxis, ax.get_ylim())):
            low, high = min(low, high), max(low, high)
            span = high - low
            for tick in axis.get_major_ticks():
                at = tick.get_loc()
                if low - 1e-9 * span <= at <= high + 1e-9 * span:
                    found += [(f"axes{i} {name}tick {tick.label1.get_text()}", tick.label1)]
        found += [(f"axes{i} text {t.get_text()!r}", t) for t in ax.texts]
        legend = ax.get_legend()
        if legend is not None:
            found += [(f"axes{i} legend {t.get_text()!r}", t) for t in legend.get_texts()]
    for legend in figure.legends:
        found += [(f"figure legend {t.get_text()!r}", t) for t in legend.get_texts()]
    out = []
    for what, text in found:
        if text.get_visible() and text.get_text().strip():
            out.append((what, text, text.get_window_extent(renderer)))
    return out


def text_overlaps(figure: Any, clearance: float = LABEL_CLEARANCE) -> list[tuple[str, str]]:
    """Pairs of a figure's texts that overlap once it is laid out (or that a legend covers).

    Checks titles, axis labels, the tick labels in view, annotations and legend entries, through
    matplotlib's text extents (``Text.get_window_extent``) with the layout the saved file gets.

    Returns:
        ``(first, second)`` descriptions of each overlapping pair (empty: none).
    """
    texts = _drawn_texts(figure)
    pairs = []
    for i, (what_a, _, box_a) in enumerate(texts):
        for what_b, _, box_b in texts[i + 1:]:
            if (box_a.x0 < box_b.x1 - clearance and box_b.x0 < box_a.x1 - clearance
                    and box_a.y0 < box_b.y1 - clearance and box_b.y0 < box_a.y1 - clearance):
                pairs.append((what_a, what_b))
    renderer = figure._get_renderer()
    for ax in figure.axes:
        legend = ax.get_legend()
        if legend is None:
            continue
        frame = legend.get_window_extent(renderer)
        for what, text, box in texts:
            if text in ax.texts and frame.overlaps(box):
                pairs.append((what, "its axes' legend"))
    return pairs


REGION_LABEL_STYLE = {"fontsize": 8, "zorder": 5,
                      "bbox": {"boxstyle": "round,pad=0.2", "facecolor": "white", "alpha": 0.7,
                               "linewidth": 0}}
"""How :func:`plot_polygons` writes a region's label."""


def place_labels(ax: Any, labels: Sequence[tuple[str, np.ndarray, float]], **style: Any) -> list[str]:
    """Write labels at points of an Axes, most important first, leaving out colliding ones.

    A label that would overlap a text already there, or leave the Axes, is not written.

    Args:
        ax: the Axes (its figure is laid out to measure the texts).
        labels: ``(text, point in data coordinates, importance)``, e.g. a region's area.
        **style: passed to :meth:`matplotlib.axes.Axes.annotate`.

    Returns:
        The labels written, in the given order (they are added to the Axes in that order).
    """
    figure = ax.figure
    taken = [box for _, _, box in _drawn_texts(figure)]
    renderer = figure._get_renderer()
    inside = ax.get_window_extent(renderer)
    kept: set[int] = set()
    for index in sorted(range(len(labels)), key=lambda i: -labels[i][2]):
        text, point, _ = labels[index]
        label = ax.annotate(text, point, ha="center", va="center", **style)
        box = label.get_window_extent(renderer)
        label.remove()
        grown = box.expanded(1.0 + 2 * LABEL_CLEARANCE / max(box.width, 1.0),
                             1.0 + 2 * LABEL_CLEARANCE / max(box.height, 1.0))
        if (inside.x0 <= box.x0 and box.x1 <= inside.x1 and inside.y0 <= box.y0 and box.y1 <= inside.y1
                and not any(grown.overlaps(other) for other in taken)):
            taken.append(box)
            kept.add(index)
    written = [labels[i][0] for i in range(len(labels)) if i in kept]  # in the given order
    for i in sorted(kept):
        ax.annotate(labels[i][0], labels[i][1], ha="center", va="center", **style)
    return written


# ----------------------------------------------------------------------------- trajectories


def plot_trajectory(
    trajectory: Trajectory,
    path: str | Path,
    coordinates: Sequence[str] = ("theta",),
    title: str | None = None,
) -> Path:
    """Two panels over time: chosen coordinates (top) and contact forces (bottom).

    The force panel shows, per contact, the normal force ``lambda_n`` (solid) and the tangential
    force ``lambda_t`` (dashed) [N], in one colour per contact; contact events are dotted
    vertical lines on both panels.

    Args:
        trajectory: the motion.
        path: the file to write.
        coordinates: names of the coordinates to plot [m or rad].
        title: the figure's title (default: the scene's name).

    Returns:
        The path written.

    Raises:
        CoordinateNotFound: a name is not one of the trajectory's coordinates.
        InputError: the trajectory's arrays have inconsistent shapes.
        OutputFileError: the file cannot be written.
    """
    names = list(coordinates)
    for name in names:
        if name not in trajectory.coordinates:
            raise CoordinateNotFound(name, trajectory.coordinates)
    times = np.asarray(trajectory.times, dtype=float)
    q = np.asarray(trajectory.q, dtype=float)
    forces = np.asarray(trajectory.contact_forces, dtype=float)
    k = len(trajectory.contacts)
    if q.shape != (len(times), len(trajectory.coordinates)) or forces.shape != (len(times), k, 2):
        raise InputError(f"inconsistent trajectory: times {times.shape}, q {q.shape}, "
                         f"contact_forces {forces.shape} for {k} contacts")
    marker = "o" if len(times) < 2 else None
    figure = new_figure(figsize=(8.0, 6.0), layout="constrained")
    top, bottom = figure.subplots(2, 1, sharex=True)
    for name in names:
        top.plot(times, q[:, trajectory.coordinates.index(name)], marker=marker, label=name)
    top.set_ylabel("coordinate [m or rad]")
    if names:
        top.legend(loc="best", fontsize="small")
    colors = [f"C{i % 10}" for i in range(k)]
    for j, name in enumerate(trajectory.contacts):
        bottom.plot(times, forces[:, j, 0], color=colors[j], marker=marker, label=f"{name} $\\lambda_n$")
        bottom.plot(times, forces[:, j, 1], color=colors[j], linestyle="--", marker=marker,
                    label=f"{name} $\\lambda_t$")
    bottom.axhline(0.0, color="0.6", linewidth=0.8)
    bottom.set_ylabel("contact force [N]")
    bottom.set_xlabel("time [s]")
    if k:
        bottom.legend(loc="best", fontsize="x-small", ncol=2)
    for event in trajectory.events:
        for ax in (top, bottom):
            ax.axvline(event.time, color="0.5", linestyle=":", linewidth=0.8)
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
    figure.suptitle(title if title is not None else trajectory.scene_name)
    return save_figure(figure, path)


# ---------------------------------------------------------------------------------- scenes


def plot_scene(
    scene: Scene,
    path: str | Path | None = None,
    ax: Any = None,
    *,
    q: Any = None,
    contact_forces: Any = None,
    force_scale: float | None = None,
    title: str | None = None,
    labels: bool = True,
) -> Any:
    """The robot in its plane: links, contact points, surfaces and friction cones.

    Links are filled with their URDF colours (their outlines projected onto the plane, nearest
    to the viewer on top); surfaces are drawn as lines hatched on the obstacle side (cut where
    they meet, see :func:`frcontrol.viz.surface_segments`); every contact that touches its
    surface at ``q`` gets its friction cone (half angle atan(mu)) and an amber dot, the others a
    grey ring.

    Args:
        scene: the scene.
        path: the file to write (None: do not write).
        ax: matplotlib Axes to draw into (default: a new figure).
        q: the configuration (default: the scene's).
        contact_forces: (lambda_n, lambda_t) per contact [N], shape (k, 2), drawn as arrows.
        force_scale: [m/N] arrow length per newton (default: the largest is 30 % of the robot).
        title: the panel's title (default: the scene's name).
        labels: write the contacts' names.

    Returns:
        The Axes drawn into.

    Raises:
        InputError: ``q`` or ``contact_forces`` has the wrong shape or non-finite values.
        OutputFileError: the file cannot be written.
    """
    config, forces = _checked_state_and_forces(scene, q, contact_forces)
    if ax is None:
        ax = new_figure(figsize=(7.0, 5.0), layout="constrained").add_subplot()
    points = [c.point for c in scene.contacts]
    world = scene.robot.contact_points_in_world(config).reshape(-1, 2)
    normals = np.array([p.normal_in_world for p in points]).reshape(-1, 2)
    surfaces = np.array([p.surface_point_in_world for p in points]).reshape(-1, 2)
    touching = np.einsum("kj,kj->k", normals, world - surfaces) <= scene.gap_tolerance
    shapes = _link_shapes(scene, config)
    lines = surface_lines(points)
    lower, upper = _scene_extent(shapes, world, lines)
    size = max(float(np.max(upper - lower)), 0.1)
    arrows = None
    if forces is not None:
        arrows, force_scale = _force_arrows(points, forces, size, force_scale)
        tips = world + force_scale * arrows
        lower, upper = np.minimum(lower, tips.min(axis=0)), np.maximum(upper, tips.max(axis=0))
    margin = 0.08 * max(float(np.max(upper - lower)), 0.1)
    lower, upper = lower - margin, upper + margin

    _draw_surface_lines(ax, lines, (lower + upper) / 2, float(np.hypot(*(upper - lower))), 0.03 * size)
    _draw_link_outlines(ax, shapes)
    _draw_contact_points(ax, points, world, touching, 0.12 * size, labels)
    if arrows is not None and force_scale:
        _draw_force_arrows(ax, world, arrows, force_scale)
    frame_axes(ax, (lower[0], upper[0], lower[1], upper[1]), ("x [m]", "y [m]"),
               title if title is not None else scene.name)
    ax.set_aspect("equal")
    if path is not None:
        save_figure(ax.figure, path)
    return ax


def _scene_extent(shapes: Sequence[tuple[float, np.ndarray, Any]], world: np.ndarray,
                  lines: Sequence[Any]) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners [m] of the links, the contact points and their feet on the surfaces."""
    outlines = [s[1] for s in shapes] + [world]
    outlines += [np.array([line.foot(p) for p in world]) for line in lines if len(world)]
    xy = np.vstack([o for o in outlines if len(o)]) if any(len(o) for o in outlines) else np.zeros((1, 2))
    return xy.min(axis=0), xy.max(axis=0)


def _force_arrows(points: Sequence[Any], forces: np.ndarray, size: float, force_scale: float | None
                  ) -> tuple[np.ndarray, float]:
    """The contact forces as world vectors [N], and the arrows' scale [m/N].

    The default scale draws the largest force at 30 % of ``size`` [m] (0 when every force is 0).

    Raises:
        InputError: ``force_scale`` is given and is not a positive number.
    """
    normals = np.array([p.normal_in_world for p in points]).reshape(-1, 2)
    tangents = np.array([p.tangent_in_world for p in points]).reshape(-1, 2)
    arrows = forces[:, :1] * normals + forces[:, 1:] * tangents
    if force_scale is None:
        peak = float(np.max(np.hypot(arrows[:, 0], arrows[:, 1]), initial=0.0))
        return arrows, 0.3 * size / peak if peak > 0 else 0.0
    if not (math.isfinite(force_scale) and force_scale > 0):
        raise InputError(f"force_scale must be a positive number of metres per newton, got {force_scale}")
    return arrows, force_scale


def _checked_state_and_forces(scene: Scene, q: Any, contact_forces: Any
                              ) -> tuple[np.ndarray, np.ndarray | None]:
    """The configuration (default: the scene's) and the contact forces, checked.

    Raises:
        InputError: ``q`` or ``contact_forces`` has the wrong shape or non-finite values.
    """
    n, k = len(scene.coordinate_names), len(scene.contacts)
    config = np.asarray(scene.q if q is None else q, dtype=float)
    if config.shape != (n,) or not np.all(np.isfinite(config)):
        raise InputError(f"q must be {n} finite numbers ({', '.join(scene.coordinate_names)}), "
                         f"got shape {config.shape}")
    if contact_forces is None:
        return config, None
    forces = np.asarray(contact_forces, dtype=float)
    if forces.shape != (k, 2) or not np.all(np.isfinite(forces)):
        raise InputError(f"contact_forces must have shape ({k}, 2) and be finite, got {forces.shape}")
    return config, forces


def _link_shapes(scene: Scene, config: np.ndarray) -> list[tuple[float, np.ndarray, Any]]:
    """Each link visual at ``config``: (its front depth, its outline in the plane, the visual)."""
    poses = scene.robot.link_poses(config)
    shapes = []
    for link, visuals in link_visuals(scene.robot, [c.point for c in scene.contacts]).items():
        origin, angle = poses[link]
        for visual in visuals:
            outline = visual_outline(visual, pose_matrix(origin, angle))
            shapes.append((visual_depth(visual)[1], outline, visual))
    return shapes


def _draw_force_arrows(ax: Any, world: np.ndarray, arrows: np.ndarray, force_scale: float) -> None:
    """Each contact force as an arrow from its point, ``force_scale`` [m/N], and the scale as text."""
    for j in range(len(world)):
        if np.hypot(*arrows[j]) > 0:
            ax.annotate("", xy=world[j] + force_scale * arrows[j], xytext=world[j], zorder=4,
                        arrowprops={"arrowstyle": "-|>", "color": palette.FORCE_COLOR, "linewidth": 1.5})
    ax.text(0.01, 0.01, f"forces: {force_scale:.3g} m/N", transform=ax.transAxes, fontsize=7,
            color=palette.FORCE_COLOR)


def _draw_surface_lines(ax: Any, lines: Sequence[Any], center: np.ndarray, reach: float, band: float) -> None:
    """Each surface as a line, hatched on the obstacle side, cut to ``reach`` around ``center``."""
    PolygonPatch = _polygon_patch()
    for line, (start, end) in zip(lines, surface_segments(lines, center, reach), strict=True):
        behind = -band * line.normal
        strip = np.array([start, end, end + behind, start + behind])
        ax.add_patch(PolygonPatch(strip, closed=True, facecolor="none", edgecolor=palette.SURFACE_COLOR,
                                  hatch="////", linewidth=0.0, zorder=1))
        ax.plot([start[0], end[0]], [start[1], end[1]], color=palette.SURFACE_COLOR, linewidth=2.0,
                zorder=1.5)


def _draw_link_outlines(ax: Any, shapes: Sequence[tuple[float, np.ndarray, Any]]) -> None:
    """Link visuals ``(front depth, outline, visual)``, the ones nearer the viewer on top."""
    PolygonPatch = _polygon_patch()
    for depth_rank, (_, outline, visual) in enumerate(sorted(shapes, key=lambda s: s[0])):
        if len(outline) >= 3:
            ax.add_patch(PolygonPatch(outline, closed=True, facecolor=palette.rgba_hex(visual.rgba),
                                      edgecolor="0.15", linewidth=0.6, alpha=max(0.3, visual.rgba[3]),
                                      zorder=2 + 0.01 * depth_rank))
        else:
            ax.plot(outline[:, 0], outline[:, 1], color=palette.rgba_hex(visual.rgba), zorder=2)


def _draw_contact_points(ax: Any, points: Sequence[Any], world: np.ndarray, touching: np.ndarray,
                         cone_length: float, labels: bool) -> None:
    """Contact points (filled when touching, with their friction cone), and their names."""
    PolygonPatch = _polygon_patch()
    for j, point in enumerate(points):
        p = world[j]
        if touching[j]:
            e1, e2 = friction_cone_directions(point.normal_in_world, point.mu)
            ax.add_patch(PolygonPatch(np.array([p, p + cone_length * e1, p + cone_length * e2]),
                                      closed=True, facecolor=palette.CONE_COLOR, edgecolor="#2171b5",
                                      alpha=0.35, linewidth=0.8, zorder=3))
            ax.plot(*p, marker="o", markersize=5, color=palette.CONTACT_COLOR, markeredgecolor="0.2",
                    zorder=5)
        else:
            ax.plot(*p, marker="o", markersize=5, markerfacecolor="none",
                    markeredgecolor=palette.INACTIVE_CONTACT_COLOR, zorder=5)
        if labels:
            ax.annotate(point.name, p, xytext=(4, -10), textcoords="offset points", fontsize=7,
                        color="0.25", zorder=6)


# -------------------------------------------------------------------------------- polygons


def polygon_from_halfplanes(
    A: Any, b: Any, box: Sequence[float], tolerance: float = HALFPLANE_TOLERANCE
) -> np.ndarray:
    """Vertices of ``{x in R^2 : A x <= b}`` inside a box: :func:`frcontrol.geometry.clip_polygon`.

    The box ``(xmin, xmax, ymin, ymax)`` is clipped by each half-plane in turn
    (Sutherland-Hodgman on a convex polygon): exact up to ``tolerance``, with no LP and no
    external package. Rows are normalised first; a zero row ``0 . x <= b_i`` empties the set if
    ``b_i < -tolerance`` and is ignored otherwise. Vertices closer than ``tolerance`` are merged.

    Args:
        A: rows, shape (m, 2).
        b: right-hand side, shape (m,).
        box: the clipping window (xmin, xmax, ymin, ymax).
        tolerance: see :data:`HALFPLANE_TOLERANCE`.

    Returns:
        The vertices, shape (V, 2): V = 0 for an empty set, 1 or 2 for a point or a segment
        (a set of empty interior), 3 or more for a polygon.

    Raises:
        InputError: wrong shapes, non-finite values, or an empty or inverted box.
    """
    return clip_polygon(A, b, box, tolerance)


def _halfplanes(item: Any, index: int) -> tuple[np.ndarray, np.ndarray]:
    """(A, b) of one polygon given as (A, b) or as an object with A, b (and A_eq, b_eq)."""
    if hasattr(item, "A") and hasattr(item, "b"):
        A, b = np.asarray(item.A, dtype=float), np.asarray(item.b, dtype=float)
        A_eq = getattr(item, "A_eq", None)
        if A_eq is not None and np.asarray(A_eq).size:
            A_eq, b_eq = np.asarray(A_eq, dtype=float), np.asarray(item.b_eq, dtype=float)
            A, b = np.vstack([A, A_eq, -A_eq]), np.concatenate([b, b_eq, -b_eq])
        return A, b
    try:
        A, b = item
    except (TypeError, ValueError) as err:
        raise InputError(f"polygons[{index}]: expected (A, b) or an object with A and b") from err
    return np.asarray(A, dtype=float), np.asarray(b, dtype=float)


_PolygonStyle = tuple[str, str | None, str | None]
"""How :func:`plot_polygons` draws one set: (colour, hatch or None, label or None)."""


@dataclass(frozen=True)
class PolygonPanel:
    """The panel :func:`plot_polygons` draws into: its window, names and look.

    Attributes:
        box: the window (xmin, xmax, ymin, ymax); default: the sets' extent plus 10 %, in which
            case every set must be bounded.
        axis_labels: the axes' names (with units).
        title: the panel's title.
        alpha: the fills' opacity.
        legend: add the Axes' legend (False: the caller makes its own).
        label_regions: write the labels in the regions now (False: the caller places them with
            :func:`place_labels` once its figure is laid out; they are kept as
            ``(label, centroid, area)`` in the Axes' ``_frcontrol_region_labels``).
    """

    box: Sequence[float] | None = None
    axis_labels: tuple[str, str] = ("$u_1$", "$u_2$")
    title: str | None = None
    alpha: float = 0.35
    legend: bool = True
    label_regions: bool = True


def plot_polygons(
    polygons: Sequence[Any],
    path: str | Path | None = None,
    ax: Any = None,
    *,
    labels: Sequence[str | None] | None = None,
    hatches: Sequence[str | None] | None = None,
    colors: Sequence[str | None] | None = None,
    points: Any = None,
    panel: PolygonPanel = PolygonPanel(),
) -> Any:
    """Draw 2-D H-polytopes ``A x <= b`` (e.g. input-space slices of mode domains).

    Each set is clipped to ``box`` (:func:`polygon_from_halfplanes`) and drawn filled and
    outlined; a set of empty interior is drawn as a thick segment or a point, an empty set is
    listed in the legend as "(empty)". Labels are in the legend, and written at the polygons'
    centroids, the largest first, where they collide with no other text (:func:`place_labels`).

    Args:
        polygons: each an ``(A, b)`` pair (A of shape (m, 2)) or an object with ``A`` and ``b``
            (and optionally ``A_eq``, ``b_eq``), such as :class:`frcontrol.polytope.Polytope`.
        path: the file to write (None: do not write).
        ax: matplotlib Axes to draw into (default: a new figure).
        labels: one label per polygon (None entries: unlabelled).
        hatches: one matplotlib hatch pattern per polygon (``"//"``, ``"xx"``...; None: none).
        colors: one colour per polygon (default: matplotlib's cycle).
        points: optional points (N, 2) to mark (e.g. an optimum).
        panel: the window, the axes' names, the title, the fills' opacity and the labels' placing.

    Returns:
        The Axes drawn into.

    Raises:
        InputError: malformed sets or options, or an unbounded set with no ``box``.
        OutputFileError: the file cannot be written.
    """
    styles = _polygon_styles(len(polygons), labels, hatches, colors)
    vertices, window = _clipped_polygons([_halfplanes(item, i) for i, item in enumerate(polygons)],
                                         panel.box)
    if ax is None:
        ax = new_figure(figsize=(6.0, 5.0), layout="constrained").add_subplot()
    to_label = _draw_polygons(ax, vertices, styles, panel.alpha)
    if points is not None:
        marks = np.asarray(points, dtype=float).reshape(-1, 2)
        ax.plot(marks[:, 0], marks[:, 1], linestyle="none", marker="*", markersize=10, color="black",
                zorder=6)
    frame_axes(ax, window, panel.axis_labels, panel.title)
    if panel.legend and any(label is not None for _, _, label in styles):
        ax.legend(loc="best", fontsize="small")
    ax.grid(True, alpha=0.3)
    if to_label and panel.label_regions:
        place_labels(ax, to_label, **REGION_LABEL_STYLE)
    ax._frcontrol_region_labels = to_label  # for a caller that places them once its figure is laid out
    if path is not None:
        save_figure(ax.figure, path)
    return ax


def frame_axes(ax: Any, window: Sequence[float], axis_labels: tuple[str, str], title: str | None = None
               ) -> None:
    """Show ``window`` (xmin, xmax, ymin, ymax) of an Axes, name its axes and give it a title."""
    ax.set_xlim(window[0], window[1])
    ax.set_ylim(window[2], window[3])
    ax.set_xlabel(axis_labels[0])
    ax.set_ylabel(axis_labels[1])
    if title is not None:
        ax.set_title(title)


def _polygon_styles(count: int, labels: Sequence[str | None] | None, hatches: Sequence[str | None] | None,
                    colors: Sequence[str | None] | None) -> list[_PolygonStyle]:
    """Each polygon's (colour, hatch, label) from :func:`plot_polygons`' options.

    Raises:
        InputError: an option does not have one entry per polygon.
    """
    for name, values in (("labels", labels), ("hatches", hatches), ("colors", colors)):
        if values is not None and len(values) != count:
            raise InputError(f"{name} has {len(values)} entries for {count} polygons")
    styles: list[_PolygonStyle] = []
    for i in range(count):
        color = colors[i] if colors is not None else None
        styles.append((color if color is not None else f"C{i % 10}",
                       hatches[i] if hatches is not None else None,
                       labels[i] if labels is not None else None))
    return styles


def _clipped_polygons(sets: Sequence[tuple[np.ndarray, np.ndarray]], box: Sequence[float] | None
                      ) -> tuple[list[np.ndarray], tuple[float, float, float, float]]:
    """Each set's vertices inside the window, and the window: ``box``, or the sets' extent + 10 %.

    Raises:
        InputError: with no ``box``, a set reaches :data:`_DEFAULT_BOX_HALF_WIDTH` (unbounded).
    """
    if box is not None:
        x0, x1, y0, y1 = (float(v) for v in box)
        window = (x0, x1, y0, y1)
        return [polygon_from_halfplanes(A, b, window) for A, b in sets], window
    big = _DEFAULT_BOX_HALF_WIDTH
    vertices = [polygon_from_halfplanes(A, b, (-big, big, -big, big)) for A, b in sets]
    for i, v in enumerate(vertices):
        if len(v) and np.max(np.abs(v)) >= big * (1 - 1e-9):
            raise InputError(f"polygons[{i}] is unbounded: pass box=(xmin, xmax, ymin, ymax)")
    stacked = np.vstack([v for v in vertices if len(v)] or [np.zeros((1, 2))])
    low, high = stacked.min(axis=0), stacked.max(axis=0)
    pad = 0.1 * np.maximum(high - low, 1e-3) + np.where(high - low > 0, 0.0, 0.5)
    return vertices, (low[0] - pad[0], high[0] + pad[0], low[1] - pad[1], high[1] + pad[1])


def _draw_polygons(ax: Any, vertices: Sequence[np.ndarray], styles: Sequence[_PolygonStyle],
                   alpha: float) -> list[tuple[str, np.ndarray, float]]:
    """Each clipped set with its ``(colour, hatch, label)``: filled and outlined, a segment or a point.

    Returns:
        ``(label, centroid, area)`` of every labelled set that is drawn (empty sets are only
        listed in the legend, as "(empty)").
    """
    PolygonPatch = _polygon_patch()
    to_label: list[tuple[str, np.ndarray, float]] = []
    for v, (color, hatch, label) in zip(vertices, styles, strict=True):
        if len(v) >= 3:
            ax.add_patch(PolygonPatch(v, closed=True, facecolor=color, alpha=alpha, hatch=hatch,
                                      edgecolor=color, linewidth=0.0, label=label, zorder=2))
            ax.add_patch(PolygonPatch(v, closed=True, fill=False, edgecolor=color, linewidth=1.2, zorder=3))
        elif len(v) >= 1:
            ax.plot(v[:, 0], v[:, 1], color=color, linewidth=3.0, marker="o" if len(v) == 1 else None,
                    label=label, zorder=3)
        elif label is not None:
            ax.plot([], [], color=color, label=f"{label} (empty)")
        if label is not None and len(v):
            to_label.append((label, _centroid(v) if len(v) >= 3 else v.mean(axis=0),
                             _area(v) if len(v) >= 3 else 0.0))
    return to_label


def _area(vertices: np.ndarray) -> float:
    """Area of a simple polygon (shoelace)."""
    x, y = vertices[:, 0], vertices[:, 1]
    return float(abs(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)) / 2)


def _centroid(vertices: np.ndarray) -> np.ndarray:
    """Area centroid of a simple polygon (its vertex mean if the area vanishes)."""
    x, y = vertices[:, 0], vertices[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = cross.sum() / 2
    if abs(area) < 1e-15:
        return vertices.mean(axis=0)
    return np.array([((x + xn) * cross).sum(), ((y + yn) * cross).sum()]) / (6 * area)
