r"""What both simulators share: the scene's ``[model]`` table, inputs over time, massless links.

The ``[model]`` table
---------------------
A scene may choose its contact model and the compliant model's parameters::

    [model]
    contact = "compliant"        # "rigid" (default) or "compliant"
    stiffness = 1e5              # k_N [N/m], > 0
    damping = 120.0              # b_N [N s/m], >= 0; absent: critical for each contact's mass
    damping_ratio = 1.0          # zeta [-], > 0, used when damping is absent
    tangential_stiffness = 1e5   # k_T [N/m], > 0; absent: = stiffness
    tangential_damping = 120.0   # b_T [N s/m], > 0; absent: critical, like damping
    armature = 1e-4              # [kg m^2 or kg], >= 0: rotor inertia added to massless coordinates

    [model.contacts.front_toe]   # per-contact overrides (the contact must exist in the scene)
    stiffness = 2e5
    damping = 50.0

:func:`model_options` parses and validates it and raises
:class:`~frcontrol.errors.SceneError` (file, dotted field, reason) for a bad value.

Default damping
---------------
With no ``damping`` the normal damper of contact i is *critical* for the contact's effective mass
at the initial state::

    b_N,i = 2 zeta sqrt(k_N,i m_N,i),      m_N,i = 1 / (J_N,i M^-1 J_N,i^T)

(``J_N,i M^-1 J_N,i^T`` by a Cholesky solve; ``M`` with the armature below), and likewise
``b_T,i`` with ``J_T,i`` and ``k_T,i``. Damping then scales as ``sqrt(k)``, which is the scaling
of Kraus, Kumar and Dupont's singular perturbation (stiffness ``k/eps``, damping ``b/sqrt(eps)``),
so that a sequence of growing stiffnesses is exactly their family of compliant models.

Massless links
--------------
A link of mass 0 (RHex's legs) makes rows and columns of ``M`` zero: the forward dynamics of both
simulators need ``M`` positive definite. The coordinates whose diagonal entry of ``M`` at the
initial state is at most :data:`MASSLESS_TOLERANCE` times the largest get a *joint armature*
(rotor inertia) ``a`` added to that diagonal entry, ``M_reg = M + diag(a e_massless)``; this is
exactly what Pinocchio's CRBA does with ``model.armature`` (the scene's model is not modified).
The value (default :data:`DEFAULT_ARMATURE`) and the coordinates are reported in
``Trajectory.info["armature"]``.

Inputs over time
----------------
``inputs`` is a constant vector (one value per scene input), a mapping ``name -> value`` (inputs
not named are 0) or a callable ``(t, q, v) -> u``. :func:`input_schedule` turns any of them into
a validated callable; a value outside the scene's input limits raises
:class:`~frcontrol.errors.InputError` (a callable's value, with the time at which it happened).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg

from ..errors import IllConditioned, InputError, SceneError
from ..scene import Scene, parse_input_assignments

CONTACT_MODELS = ("rigid", "compliant")
"""The contact models a scene's ``[model] contact`` may name."""

DEFAULT_STIFFNESS = 1e5
"""[N/m] Default normal (and tangential) contact stiffness of the compliant model."""

DEFAULT_DAMPING_RATIO = 1.0
"""[-] Default damping ratio zeta: critical damping for each contact's effective mass."""

DEFAULT_ARMATURE = 1e-4
"""[kg m^2 for revolute, kg for prismatic coordinates] Default rotor inertia for massless ones."""

MASSLESS_TOLERANCE = 1e-9
"""[-] A coordinate whose diagonal of M is at most this times the largest diagonal is massless."""

INPUT_LIMIT_TOLERANCE = 1e-9
"""[N or N m] An input may exceed its limit by this much (round-off) before it is an error."""

_MODEL_KEYS = {"contact", "stiffness", "damping", "damping_ratio", "tangential_stiffness",
               "tangential_damping", "armature", "contacts"}
_CONTACT_KEYS = {"stiffness", "damping", "damping_ratio", "tangential_stiffness", "tangential_damping"}


@dataclass(frozen=True)
class ContactParameters:
    """The compliant model's parameters of one contact (None: derived at the initial state).

    Attributes:
        stiffness: k_N [N/m], > 0.
        damping: b_N [N s/m], >= 0, or None for ``2 zeta sqrt(k_N m_N)``.
        damping_ratio: zeta [-], > 0, used when a damping is None.
        tangential_stiffness: k_T [N/m], > 0, or None for ``stiffness``.
        tangential_damping: b_T [N s/m], > 0, or None for ``2 zeta sqrt(k_T m_T)``.
    """

    stiffness: float = DEFAULT_STIFFNESS
    damping: float | None = None
    damping_ratio: float = DEFAULT_DAMPING_RATIO
    tangential_stiffness: float | None = None
    tangential_damping: float | None = None


@dataclass(frozen=True)
class ModelOptions:
    """A scene's ``[model]`` table, validated.

    Attributes:
        contact: ``"rigid"`` or ``"compliant"``.
        defaults: the parameters of every contact without an override.
        contacts: per-contact parameters (the defaults with the overrides applied), by name.
        armature: rotor inertia [kg m^2 or kg] added to massless coordinates, >= 0.
    """

    contact: str = "rigid"
    defaults: ContactParameters = field(default_factory=ContactParameters)
    contacts: Mapping[str, ContactParameters] = field(default_factory=dict)
    armature: float = DEFAULT_ARMATURE

    def parameters(self, contact: str) -> ContactParameters:
        """The parameters of one contact (its override, else the defaults)."""
        return self.contacts.get(contact, self.defaults)


def _number(scene: Scene, value: Any, field_name: str, *, positive: bool = False,
            non_negative: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SceneError(str(scene.path), field_name, f"expected a finite number, got {value!r}")
    x = float(value)
    if positive and x <= 0:
        raise SceneError(str(scene.path), field_name, f"expected a value > 0, got {x}")
    if non_negative and x < 0:
        raise SceneError(str(scene.path), field_name, f"expected a value >= 0, got {x}")
    return x


def _parameters(scene: Scene, table: Mapping[str, Any], where: str, base: ContactParameters,
                allowed: set[str]) -> ContactParameters:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise SceneError(str(scene.path), f"{where}.{unknown[0]}",
                         f"unknown key; known keys: {', '.join(sorted(allowed))}")
    values: dict[str, Any] = {
        "stiffness": base.stiffness, "damping": base.damping, "damping_ratio": base.damping_ratio,
        "tangential_stiffness": base.tangential_stiffness,
        "tangential_damping": base.tangential_damping,
    }
    for key in ("stiffness", "tangential_stiffness", "damping_ratio", "tangential_damping"):
        if key in table:
            values[key] = _number(scene, table[key], f"{where}.{key}", positive=True)
    if "damping" in table:
        values["damping"] = _number(scene, table["damping"], f"{where}.damping", non_negative=True)
    return ContactParameters(**values)


def model_options(scene: Scene) -> ModelOptions:
    """Parse and validate the scene's ``[model]`` table (absent: every default).

    Raises:
        SceneError: ``[model]`` is not a table, an unknown key, an unknown contact model or
            contact name, a non-positive stiffness or damping ratio, a negative damping or
            armature, a zero tangential damping (the slider-in-series friction law needs b_T > 0).
    """
    raw = scene.raw.get("model")
    if raw is None:
        return ModelOptions()
    path = str(scene.path)
    if not isinstance(raw, dict):
        raise SceneError(path, "model", f"expected a table [model], got {raw!r}")
    unknown = sorted(set(raw) - _MODEL_KEYS)
    if unknown:
        raise SceneError(path, f"model.{unknown[0]}",
                         f"unknown key; known keys: {', '.join(sorted(_MODEL_KEYS))}")
    contact = raw.get("contact", "rigid")
    if contact not in CONTACT_MODELS:
        raise SceneError(path, "model.contact",
                         f"expected one of {', '.join(map(repr, CONTACT_MODELS))}, got {contact!r}")
    armature = _number(scene, raw.get("armature", DEFAULT_ARMATURE), "model.armature",
                       non_negative=True)
    defaults = _parameters(scene, {k: v for k, v in raw.items() if k in _CONTACT_KEYS}, "model",
                           ContactParameters(), _CONTACT_KEYS)
    overrides = raw.get("contacts", {})
    if not isinstance(overrides, dict):
        raise SceneError(path, "model.contacts", "expected tables [model.contacts.NAME]")
    names = [c.name for c in scene.contacts]
    per_contact = {}
    for name, table in overrides.items():
        where = f"model.contacts.{name}"
        if name not in names:
            raise SceneError(path, where, f"unknown contact {name!r}; the contacts are: {', '.join(names)}")
        if not isinstance(table, dict):
            raise SceneError(path, where, f"expected a table, got {table!r}")
        per_contact[name] = _parameters(scene, table, where, defaults, _CONTACT_KEYS)
    return ModelOptions(contact=contact, defaults=defaults, contacts=per_contact, armature=armature)


# ---------------------------------------------------------------------------- inputs over time
InputSchedule = Callable[[float, np.ndarray, np.ndarray], np.ndarray]
"""``(t, q, v) -> u``: the validated input at a time and state."""


def _check_input_vector(scene: Scene, u: Any, when: str) -> np.ndarray:
    try:
        arr = np.asarray(u, dtype=float).reshape(-1)
    except (TypeError, ValueError) as err:
        raise InputError(f"{when}: the input is not a vector of numbers: {u!r}") from err
    m = scene.inputs.count
    if arr.shape != (m,):
        raise InputError(f"{when}: expected {m} input values ({', '.join(scene.inputs.coordinates)}), "
                         f"got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{when}: the input has a NaN or infinite entry: {arr.tolist()}")
    lower, upper = scene.inputs.lower, scene.inputs.upper
    bad = np.nonzero((arr < lower - INPUT_LIMIT_TOLERANCE) | (arr > upper + INPUT_LIMIT_TOLERANCE))[0]
    if bad.size:
        j = int(bad[0])
        raise InputError(f"{when}: input {scene.inputs.coordinates[j]!r} = {arr[j]:.6g} is outside its "
                         f"limits [{lower[j]:.6g}, {upper[j]:.6g}]")
    return arr


def input_schedule(
    scene: Scene,
    inputs: Mapping[str, float] | Sequence[float] | np.ndarray | InputSchedule | None,
) -> tuple[InputSchedule, bool]:
    """A validated ``(t, q, v) -> u`` for a constant vector, a mapping or a callable.

    Returns:
        The schedule, and whether it is constant (the compliant integrator then needs no
        zero-order hold).

    Raises:
        InputError: wrong length, NaN, a value outside the scene's input limits.
        CoordinateNotFound: a mapping names an unknown input.
    """
    if inputs is None:
        inputs = np.zeros(scene.inputs.count)
    if callable(inputs):
        func = inputs

        def schedule(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
            return _check_input_vector(scene, func(t, q, v), f"the input at t = {t:.6g} s")

        return schedule, False
    u: Any = parse_input_assignments(scene, inputs) if isinstance(inputs, Mapping) else inputs
    constant = _check_input_vector(scene, u, "the constant input")
    constant.setflags(write=False)
    return (lambda t, q, v: constant), True


# ---------------------------------------------------------------------------- massless links
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
        factor = scipy.linalg.cho_factor(mass_matrix, check_finite=False)
    except np.linalg.LinAlgError as err:
        eig = np.linalg.eigvalsh(mass_matrix)
        raise IllConditioned(
            f"the mass matrix (armature {armature.value:g} on "
            f"{list(armature.coordinates) or 'no coordinate'}; set a positive armature for massless links)",
            float(eig[-1] / max(abs(eig[0]), 1e-300)), MASSLESS_TOLERANCE,
        ) from err
    return factor


def potential_energy(scene: Scene, q: np.ndarray) -> float:
    """Gravitational potential energy [J] at ``q`` (zero at y = 0)."""
    return scene.robot.potential_energy(q)


def check_simulation_times(duration: float, dt: float, dt_name: str = "dt") -> tuple[float, float]:
    """Validate a duration and a step.

    Raises:
        InputError: a non-finite or non-positive duration or step, or a step longer than the
            duration.
    """
    for label, value in (("duration", duration), (dt_name, dt)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(f"{label} must be a finite number [s], got {value!r}")
        if value <= 0:
            raise InputError(f"{label} must be > 0 [s], got {value}")
    if dt > duration:
        raise InputError(f"{dt_name} = {dt} s exceeds the duration {duration} s: use a smaller step")
    return float(duration), float(dt)


__all__ = [
    "Armature",
    "check_simulation_times",
    "CONTACT_MODELS",
    "ContactParameters",
    "DEFAULT_ARMATURE",
    "DEFAULT_DAMPING_RATIO",
    "DEFAULT_STIFFNESS",
    "INPUT_LIMIT_TOLERANCE",
    "input_schedule",
    "mass_factor",
    "massless_armature",
    "MASSLESS_TOLERANCE",
    "model_options",
    "ModelOptions",
    "potential_energy",
]
