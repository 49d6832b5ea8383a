"""Simulation: rigid time stepping and compliant contact, producing :class:`Trajectory` objects.

The simulators load on first use (``frcontrol.simulation.simulate_rigid``...), so that this package
and :data:`INTEGRATORS` import without SciPy.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ..errors import InputError
from .choices import INTEGRATORS, TRAJECTORY_FORMATS

if TYPE_CHECKING:
    from ..scene import Scene
    from .trajectory import Trajectory


_LAZY = {
    "simulate_compliant": ".compliant",
    "simulate_rigid": ".rigid",
    "CompliantSettings": ".compliant",
    "RigidSettings": ".rigid",
    "InitialState": ".inputs",
    "ContactParameters": ".model_table",
    "ModelOptions": ".model_table",
    "model_options": ".model_table",
    "sample_modes": ".samples",
    "save_trajectory": ".export",
    "ContactEvent": ".trajectory",
    "SimulationWarning": ".trajectory",
    "Trajectory": ".trajectory",
}


def __getattr__(name: str) -> Any:
    """The simulators and their types, imported on first use."""
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def simulate(scene: Scene, inputs: Any = None, duration: float = 1.0, dt: float = 1e-3,
             **options: Any) -> Trajectory:
    """Simulate a scene with the contact model its ``[model]`` table names (rigid by default).

    Args:
        scene: the loaded scene.
        inputs: constant inputs (a vector or ``{name: value}``) or a callable ``(t, q, v) -> u``.
        duration: [s] simulated time.
        dt: [s] the rigid model's time step; the compliant model's sample interval.
        **options: passed to :func:`simulate_rigid` or :func:`simulate_compliant` (``settings``: a
            :class:`RigidSettings` or a :class:`CompliantSettings`, as the model; ``start``...).

    Returns:
        The trajectory (its ``model`` says which model ran).
    """
    from .compliant import CompliantSettings, simulate_compliant
    from .model_table import model_options
    from .rigid import simulate_rigid

    compliant = model_options(scene).contact == "compliant"
    settings = options.get("settings")
    if settings is not None and isinstance(settings, CompliantSettings) != compliant:
        raise InputError(f"the scene's [model] contact is {'compliant' if compliant else 'rigid'}: "
                         f"its settings are {'CompliantSettings' if compliant else 'RigidSettings'}, "
                         f"got {type(settings).__name__}")
    if compliant:
        return simulate_compliant(scene, inputs, duration, dt, **options)
    return simulate_rigid(scene, inputs, duration, dt, **options)


__all__ = [
    "INTEGRATORS",
    "TRAJECTORY_FORMATS",
    "CompliantSettings",
    "ContactEvent",
    "ContactParameters",
    "InitialState",
    "ModelOptions",
    "RigidSettings",
    "SimulationWarning",
    "Trajectory",
    "model_options",
    "sample_modes",
    "save_trajectory",
    "simulate",
    "simulate_compliant",
    "simulate_rigid",
]
