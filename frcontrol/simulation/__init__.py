"""Simulation: rigid time stepping and compliant contact, producing :class:`Trajectory` objects."""

from .compliant import INTEGRATORS, simulate_compliant
from .options import ContactParameters, ModelOptions, model_options
from .rigid import simulate_rigid
from .trajectory import ContactEvent, SimulationWarning, Trajectory

__all__ = [
    "INTEGRATORS",
    "ContactEvent",
    "ContactParameters",
    "ModelOptions",
    "SimulationWarning",
    "Trajectory",
    "model_options",
    "simulate_compliant",
    "simulate_rigid",
]
