"""Seeing it: meshcat scenes and animations, matplotlib figures.

Modules, the heavy ones imported on demand (each imports its library inside its functions, so
``import frcontrol`` stays light):

- :mod:`frcontrol.viz.meshcat_view`: a scene or a :class:`~frcontrol.simulation.trajectory.Trajectory`
  in meshcat's 3-D viewer, as a self-contained HTML file or on a local server;
- :mod:`frcontrol.viz.plots`: 2-D figures for reports (trajectories, scenes, input-space polygons)
  and the text-overlap check; :mod:`frcontrol.viz.figures`: the figures of results;
- :mod:`frcontrol.viz.colors`, :mod:`frcontrol.viz.picture_errors`, :mod:`frcontrol.viz.shapes` (plane
  geometry: poses, surface lines, friction cones, hulls) and :mod:`frcontrol.viz.visuals` (link
  shapes from the URDF), with numpy only, shared by both.

This module re-exports the shared names; the colours live in :mod:`frcontrol.viz.colors`.
"""

from __future__ import annotations

from .colors import (
    CONE_COLOR,
    CONTACT_COLOR,
    FORCE_COLOR,
    INACTIVE_CONTACT_COLOR,
    MODE_COLORS,
    SURFACE_COLOR,
    hex_color,
    rgba_hex,
)
from .picture_errors import OutputFileError, PortInUse, ViewerServerError, VizError
from .shapes import (
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
