r"""Massless links: the rotor inertia (armature) that makes the mass matrix positive definite.

A link of mass 0 (RHex's legs) makes rows and columns of ``M`` zero: the forward dynamics of both
simulators need ``M`` positive definite. The coordinates whose diagonal entry of ``M`` at the
initial state is at most :data:`MASSLESS_TOLERANCE` times the largest get a *joint armature*
(rotor inertia) ``a`` added to that diagonal entry, ``M_reg = M + diag(a e_massless)``; this is
exactly what Pinocchio's CRBA does with ``model.armature`` (the scene's model is not modified).
The value (default :data:`DEFAULT_ARMATURE`) and the coordinates are reported in
``Trajectory.info["armature"]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..cholesky import cholesky_solve, cholesky_upper
from ..errors import IllConditioned, InputError
from ..scene import Scene
from ..scene_tables import DEFAULT_ARMATURE

MASSLESS_TOLERANCE = 1e-9
"""[-] A coordinate whose diagonal of M is at most this times the largest diagonal is massless."""


@dataclass(frozen=True)
class Armature:
    """The rotor inertia added to massless coordinates.

    Attributes:
        value: [kg m^2 or kg] added to each listed coordinate's diagonal of M.
        coordinates: the massless coordinates (diagonal of M at most ``tolerance`` times the
            largest at the initial state).
        indices: their indices.
        tolerance: the relative masslessness threshold used.
    """

    value: float
    coordinates: tuple[str, ...]
    indices: tuple[int, ...]
    tolerance: float = MASSLESS_TOLERANCE

    def apply(self, mass_matrix: np.ndarray) -> np.ndarray:
        """``M + diag(a on the massless coordinates)`` (a copy)."""
        out = np.array(mass_matrix, copy=True)
        if self.indices:
            idx = list(self.indices)
            out[idx, idx] += self.value
        return out

    def report(self) -> dict[str, Any]:
        """The ``info["armature"]`` entry."""
        return {"value": self.value, "coordinates": list(self.coordinates), "tolerance": self.tolerance}


def massless_armature(scene: Scene, mass_matrix: np.ndarray, value: float,
                      tolerance: float = MASSLESS_TOLERANCE) -> Armature:
    """The armature for the coordinates that are massless in ``mass_matrix``.

    Raises:
        InputError: a negative or non-finite value.
    """
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
        raise InputError(f"the armature must be a finite number >= 0 [kg m^2], got {value!r}")
    diag = np.diag(mass_matrix)
    scale = float(np.max(diag)) if diag.size else 0.0
    idx = tuple(int(i) for i in np.nonzero(diag <= tolerance * max(scale, 1e-300))[0])
    if value == 0.0:
        idx = ()
    return Armature(float(value), tuple(scene.coordinate_names[i] for i in idx), idx, tolerance)


def mass_factor(mass_matrix: np.ndarray, armature: Armature) -> tuple[np.ndarray, bool]:
    """Cholesky factor of the (regularised) mass matrix, for ``scipy.linalg.cho_solve``.

    Raises:
        IllConditioned: M is not positive definite even with the armature (a massless coordinate
            with ``armature = 0``, or a singular M whose diagonal is not zero).
    """
    try:
        factor = (cholesky_upper(mass_matrix), False)
    except np.linalg.LinAlgError as err:
        eig = np.linalg.eigvalsh(mass_matrix)
        raise IllConditioned(
            f"the mass matrix (armature {armature.value:g} on "
            f"{list(armature.coordinates) or 'no coordinate'}; set a positive armature for massless links)",
            float(eig[-1] / max(abs(eig[0]), 1e-300)), MASSLESS_TOLERANCE,
        ) from err
    return factor


def solve_mass(factor: tuple[np.ndarray, bool], rhs: np.ndarray) -> np.ndarray:
    """``M^-1 rhs`` from :func:`mass_factor`'s factor (``scipy.linalg.cho_solve``'s LAPACK call)."""
    return cholesky_solve(factor[0], rhs)


__all__ = ["Armature", "DEFAULT_ARMATURE", "MASSLESS_TOLERANCE", "mass_factor", "massless_armature",
           "solve_mass"]
