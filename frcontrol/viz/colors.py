"""The colours shared by the meshcat pages and the matplotlib figures, and their conversions."""

from __future__ import annotations

from collections.abc import Sequence

__all__ = [
    "CONE_COLOR",
    "CONTACT_COLOR",
    "FORCE_COLOR",
    "INACTIVE_CONTACT_COLOR",
    "MODE_COLORS",
    "SURFACE_COLOR",
    "hex_color",
    "rgba_hex",
]

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
