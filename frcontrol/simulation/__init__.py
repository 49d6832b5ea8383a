"""Simulation: rigid time stepping and compliant contact, producing :class:`Trajectory` objects."""

from .trajectory import ContactEvent, Trajectory

__all__ = ["ContactEvent", "Trajectory"]
