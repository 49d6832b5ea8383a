"""Simulation: rigid time stepping and compliant contact, producing :class:`Trajectory` objects."""

from typing import Any

from ..scene import Scene
from .compliant import INTEGRATORS, simulate_compliant
from .options import ContactParameters, ModelOptions, model_options
from .rigid import simulate_rigid
from .trajectory import ContactEvent, SimulationWarning, Trajectory


def simulate(scene: Scene, inputs: Any = None, duration: float = 1.0, dt: float = 1e-3,
             **options: Any) -> Trajectory:
    """Simulate a scene with the contact model its ``[model]`` table names (rigid by default).

    Args:
        scene: the loaded scene.
        inputs: constant inputs (a vector or ``{name: value}``) or a callable ``(t, q, v) -> u``.
        duration: [s] simulated time.
        dt: [s] the rigid model's time step; the compliant model's sample interval.
        **options: passed to :func:`simulate_rigid` or :func:`simulate_compliant`.

    Returns:
        The trajectory (its ``info["model"]`` says which model ran).
    """
    if model_options(scene).contact == "compliant":
        return simulate_compliant(scene, inputs, duration, dt, **options)
    return simulate_rigid(scene, inputs, duration, dt, **options)


__all__ = [
    "INTEGRATORS",
    "ContactEvent",
    "ContactParameters",
    "ModelOptions",
    "SimulationWarning",
    "Trajectory",
    "model_options",
    "simulate",
    "simulate_compliant",
    "simulate_rigid",
]
