"""Seeing it: meshcat scenes and animations, matplotlib figures.

Modules, the heavy ones imported on demand (each imports its library inside its functions, so
``import frcontrol`` stays light):

- :mod:`frcontrol.viz.meshcat_view`: a scene or a :class:`~frcontrol.simulation.trajectory.Trajectory`
  in meshcat's 3-D viewer, as a self-contained HTML file or on a local server;
- :mod:`frcontrol.viz.plots`: 2-D figures for reports (trajectories, scenes, input-space polygons)
  and the text-overlap check; :mod:`frcontrol.viz.figures`: the figures of results;
- :mod:`frcontrol.viz.errors`, :mod:`frcontrol.viz.geometry` (plane geometry: poses, surface
  lines, friction cones, hulls) and :mod:`frcontrol.viz.visuals` (link shapes from the URDF), with
  numpy only, shared by both.

This module holds the colours and re-exports the shared names.
"""

from __future__ import annotations

from collections.abc import Sequence

from .errors import OutputFileError, PortInUse, ViewerServerError, VizError
from .geometry import (
    LINE_MERGE_TOLERANCE,
    SurfaceLine,
    convex_hull,
    friction_cone_directions,
    pose_matrix,
    surface_lines,
    surface_segments,
)
from .visuals import DEFAULT_VISUAL_COLOR, LinkVisual, link_visuals, visual_depth, visual_outline

__all__ = [
    "CONE_COLOR",
    "CONTACT_COLOR",
    "DEFAULT_VISUAL_COLOR",
    "FORCE_COLOR",
    "INACTIVE_CONTACT_COLOR",
    "LINE_MERGE_TOLERANCE",
    "MODE_COLORS",
    "SURFACE_COLOR",
    "LinkVisual",
    "OutputFileError",
    "PortInUse",
    "SurfaceLine",
    "ViewerServerError",
    "VizError",
    "convex_hull",
    "friction_cone_directions",
    "link_visuals",
    "hex_color",
    "pose_matrix",
    "rgba_hex",
    "surface_lines",
    "surface_segments",
    "visual_depth",
    "visual_outline",
]

# ---------------------------------------------------------------------------------------- colours

MODE_COLORS: dict[str, str] = {"S": "#7f7f7f", "F": "#2ca02c", "L": "#1f77b4", "R": "#ff7f0e"}
"""Colour of a contact force drawn in each contact mode: Separate grey, Fixed green, sliding Left
blue, sliding Right orange."""

FORCE_COLOR = "#d62728"
"""Colour of a contact force when no mode is given (red)."""

CONTACT_COLOR = "#ffbf00"
"""Colour of a contact point that touches its surface (amber)."""

INACTIVE_CONTACT_COLOR = "#b0b0b0"
"""Colour of a contact point off its surface (light grey)."""

SURFACE_COLOR = "#8c7a6b"
"""Colour of the fixed contact surfaces (ground, walls)."""

CONE_COLOR = "#6baed6"
"""Colour of the friction cones (drawn translucent)."""


def hex_color(color: str) -> int:
    """``"#rrggbb"`` as the integer ``0xrrggbb`` meshcat takes."""
    return int(color.lstrip("#"), 16)


def rgba_hex(rgba: Sequence[float]) -> str:
    """An RGBA tuple in [0, 1] as ``"#rrggbb"`` (alpha dropped)."""
    r, g, b = (min(255, max(0, round(255 * float(c)))) for c in rgba[:3])
    return f"#{r:02x}{g:02x}{b:02x}"
