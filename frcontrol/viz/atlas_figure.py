"""The map of an atlas: one of its arrays over the grid's first two axes.

A figure whose values are few and discrete (``counts``, flags, ``ambiguous``, a plan's mode, the
modes) gets one colour per value and a legend entry per value; a number (a margin, a scale) gets a
colour scale. Grid points that recorded an error are grey, named in the legend. With more than two
axes the map is the slice at the first value of the others (the title says which); with one axis
it is a strip.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .plots import new_figure, save_figure

ERROR_COLOUR = "#9e9e9e"
"""Grid points whose evaluation raised an error."""

DISCRETE_COLOURS = ("#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860", "#da8bc3",
                    "#8c8c8c", "#ccb974", "#64b5cd")
"""One colour per discrete value, in the values' order (count 0 first)."""

MAX_DISCRETE_VALUES = len(DISCRETE_COLOURS)
"""A figure with more distinct values than this (and numbers) gets a colour scale instead."""

ERROR_LABEL = "error at this point"


def _slice(doc: Mapping[str, Any], figure: str) -> tuple[np.ndarray, list[str]]:
    """The figure's values on the first two axes (an object array) and what the slice fixes."""
    if figure not in doc or not isinstance(doc[figure], list):
        arrays = [k for k, v in doc.items() if isinstance(v, list) and k != "axes"]
        raise InputError(f"--figure {figure!r}: no such array; valid: {', '.join(arrays)}")
    shape = tuple(doc["shape"])
    flat: list[Any] = []

    def walk(node: Any, depth: int) -> None:
        if depth == len(shape):
            flat.append(node)
            return
        for item in node:
            walk(item, depth + 1)

    walk(doc[figure], 0)
    values = np.empty(len(flat), dtype=object)
    values[:] = [" ".join(map(str, v)) if isinstance(v, list) else v for v in flat]
    values = values.reshape(shape)
    fixed = [f"{a['path']} = {a['values'][0]:.4g}" for a in doc["axes"][2:]]
    values = values[(slice(None),) * min(2, len(shape)) + (0,) * max(0, len(shape) - 2)]
    return (values.reshape(-1, 1) if values.ndim == 1 else values), fixed


def _edges(values: Sequence[float]) -> np.ndarray:
    """Cell edges around grid values (a single value gets a unit-wide cell)."""
    v = np.asarray(values, dtype=float)
    if v.size == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5])
    mid = (v[1:] + v[:-1]) / 2
    return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])


def _label(figure: str, value: Any) -> str:
    if figure == "counts":
        return f"{value} solution{'' if value == 1 else 's'}"
    if isinstance(value, bool):
        return "yes" if value else "no"
    return str(value) if value != "" else "(none)"


def _is_discrete(values: np.ndarray) -> bool:
    present = [v for v in values.ravel() if v is not None]
    numbers = [v for v in present if isinstance(v, float) and not isinstance(v, bool)]
    return not numbers or len(set(present)) <= MAX_DISCRETE_VALUES and len(numbers) < len(present)


def plot_atlas(doc: Mapping[str, Any], path: str | Path | None = None, *, figure: str = "counts") -> Any:
    """Draw one array of an atlas (its ``to_dict()``) over the first two axes.

    Args:
        doc: :meth:`frcontrol.atlas.AtlasResult.to_dict`.
        path: where to write the figure (PNG, PDF, SVG... by suffix), or None.
        figure: the array to draw: ``counts`` (default), ``ambiguous``, ``modes``, ``stable``, or a
            kind's own (``found``, ``max_disturbance_scale``...).

    Returns:
        The matplotlib figure.

    Raises:
        InputError: no such array.
    """
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    values, fixed = _slice(doc, figure)
    axes = doc["axes"]
    x = _edges(axes[0]["values"])
    y = _edges(axes[1]["values"]) if len(axes) > 1 else np.array([0.0, 1.0])
    fig = new_figure(figsize=(7.5, 5.0))
    ax = fig.add_subplot()
    errors = np.vectorize(lambda v: v is None, otypes=[bool])(values)
    if _is_discrete(values):
        present = sorted({v for v in values.ravel() if v is not None}, key=lambda v: (str(type(v)), v))
        code = np.full(values.shape, len(present), dtype=float)
        for i, v in enumerate(present):
            code[np.vectorize(lambda w, v=v: w is not None and w == v and type(w) is type(v),
                              otypes=[bool])(values)] = i
        colours = [DISCRETE_COLOURS[i % len(DISCRETE_COLOURS)] for i in range(len(present))] + [ERROR_COLOUR]
        cmap = ListedColormap(colours)
        norm = BoundaryNorm(np.arange(len(colours) + 1) - 0.5, len(colours))
        ax.pcolormesh(x, y, code.T, cmap=cmap, norm=norm)
        handles = [Patch(color=colours[i], label=_label(figure, v)) for i, v in enumerate(present)]
        if errors.any():
            handles.append(Patch(color=ERROR_COLOUR, label=ERROR_LABEL))
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
                  title=figure)
    else:
        numbers = np.array([np.nan if v is None else float(v) for v in values.ravel()]).reshape(values.shape)
        mesh = ax.pcolormesh(x, y, np.ma.masked_invalid(numbers).T, cmap="viridis")
        fig.colorbar(mesh, ax=ax, label=figure + ("  (white: error at this point)" if errors.any() else ""))
    ax.set_xlabel(axes[0]["path"])
    ax.set_ylabel(axes[1]["path"] if len(axes) > 1 else "")
    if len(axes) == 1:
        ax.set_yticks([])
    title = f"{doc['scene']}: {figure} ({doc['what']})"
    ax.set_title(title + (f"\nat {', '.join(fixed)}" if fixed else ""), fontsize=10)
    if path is not None:
        save_figure(fig, path)
    return fig


__all__ = [
    "DISCRETE_COLOURS",
    "ERROR_COLOUR",
    "ERROR_LABEL",
    "MAX_DISCRETE_VALUES",
    "plot_atlas",
]
