"""The simulators' view of a scene's ``[model]`` table (parsed at load: :mod:`frcontrol.scene_tables`)."""

from __future__ import annotations

from ..scene import Scene
from ..scene_tables import (
    CONTACT_MODELS,
    DEFAULT_DAMPING_RATIO,
    DEFAULT_STIFFNESS,
    ContactParameters,
    ModelOptions,
)

__all__ = [
    "CONTACT_MODELS",
    "ContactParameters",
    "DEFAULT_DAMPING_RATIO",
    "DEFAULT_STIFFNESS",
    "ModelOptions",
    "model_options",
]


def model_options(scene: Scene) -> ModelOptions:
    """The scene's ``[model]`` table, as it was validated when the scene was loaded."""
    return scene.model
