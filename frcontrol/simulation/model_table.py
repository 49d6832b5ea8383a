r"""A scene's ``[model]`` table: the contact model and the compliant model's parameters.

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
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ..errors import SceneError
from ..scene import Scene
from .armature import DEFAULT_ARMATURE

CONTACT_MODELS = ("rigid", "compliant")
"""The contact models a scene's ``[model] contact`` may name."""

DEFAULT_STIFFNESS = 1e5
"""[N/m] Default normal (and tangential) contact stiffness of the compliant model."""

DEFAULT_DAMPING_RATIO = 1.0
"""[-] Default damping ratio zeta: critical damping for each contact's effective mass."""

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


__all__ = [
    "CONTACT_MODELS",
    "ContactParameters",
    "DEFAULT_DAMPING_RATIO",
    "DEFAULT_STIFFNESS",
    "ModelOptions",
    "model_options",
]
