"""The names the simulators accept, importable without SciPy or Pinocchio (the CLI's options list them)."""

from __future__ import annotations

INTEGRATORS = ("radau", "bdf", "lsoda", "rk45", "dop853", "euler", "implicit")
"""The integrators :func:`~frcontrol.simulation.compliant.simulate_compliant` accepts."""

TRAJECTORY_FORMATS = (".npz", ".csv")
"""The file suffixes :func:`~frcontrol.simulation.export.save_trajectory` writes."""

__all__ = ["INTEGRATORS", "TRAJECTORY_FORMATS"]
