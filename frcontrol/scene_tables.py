r"""A scene's optional tables, parsed into typed records when the scene is loaded.

``[model]`` (:class:`ModelOptions`), ``[task]`` (:class:`TaskTable`) and ``[[disturbances]]``
(:class:`DisturbanceTable`) are checked against the scene schema first (types, ranges, names that
refer to links, contacts and coordinates); this module turns them into records and checks what the
schema cannot (duplicate names, a box or a polygon, ``lower <= upper``, finiteness). What a
planner requires of them (a flip needs ``body_contacts``...) is checked by the planner. With numpy
only: loading a scene imports no solver.

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
    restitution = 0.5            # e [-] in [0, 1]: the rigid model's impact law (default 0)
    armature = 1e-4              # [kg m^2 or kg], >= 0: rotor inertia added to massless coordinates

    [model.contacts.front_toe]   # per-contact overrides (the contact must exist in the scene)
    stiffness = 2e5
    damping = 50.0
    zone = "one_stage"           # the compliant model's contact zone (ZONES; simulation/zones.py)
    mass_robot = 0.01            # m'_r [kg], > 0
    stiffness_internal_robot = 2e5   # k''_r [N/m], > 0 (the zone's parameters: ZONE_PARAMETERS)

:func:`read_model` parses and validates it and raises
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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import FrameNotFound, SceneError

DEFAULT_ARMATURE = 1e-4
"""[kg m^2 for revolute, kg for prismatic coordinates] Default rotor inertia for massless ones."""

CONTACT_MODELS = ("rigid", "compliant")
"""The contact models a scene's ``[model] contact`` may name."""

DEFAULT_STIFFNESS = 1e5
"""[N/m] Default normal (and tangential) contact stiffness of the compliant model."""

DEFAULT_DAMPING_RATIO = 1.0
"""[-] Default damping ratio zeta: critical damping for each contact's effective mass."""

_MODEL_KEYS = {"contact", "stiffness", "damping", "damping_ratio", "tangential_stiffness",
               "tangential_damping", "armature", "contacts", "drives", "springs"}
ZONES = ("rigid", "compliant", "one_stage", "two_stage")
"""The contact zones ``[model.contacts.NAME] zone`` may name (:mod:`frcontrol.simulation.zones`)."""

ZONE_PARAMETERS = ("mass_robot", "stiffness_internal_robot", "damping_internal_robot",
                   "stiffness_external_robot", "damping_external_robot", "mass_environment",
                   "stiffness_internal_environment", "damping_internal_environment",
                   "stiffness_external_environment", "damping_external_environment")
"""A zone's masses [kg], stiffnesses [N/m] and dampers [N s/m] (Vukobratović and Potkonjak's m', k'',
b'', k', b' on the robot side r and the environment side e); dampers default to 0."""

ZONE_REQUIRED = {
    "one_stage": ("mass_robot", "stiffness_internal_robot"),
    "two_stage": ("mass_robot", "stiffness_internal_robot", "stiffness_external_robot", "mass_environment",
                  "stiffness_internal_environment", "stiffness_external_environment"),
}
"""The parameters each zone needs."""

_CONTACT_KEYS = {"stiffness", "damping", "damping_ratio", "tangential_stiffness", "tangential_damping",
                 "restitution", "zone", *ZONE_PARAMETERS}
_MODEL_KEYS |= _CONTACT_KEYS  # [model] gives every contact's defaults


@dataclass(frozen=True)
class ContactParameters:
    """The compliant model's parameters of one contact (None: derived at the initial state).

    Attributes:
        stiffness: k_N [N/m], > 0.
        damping: b_N [N s/m], >= 0, or None for ``2 zeta sqrt(k_N m_N)``.
        damping_ratio: zeta [-], > 0, used when a damping is None.
        tangential_stiffness: k_T [N/m], > 0, or None for ``stiffness``.
        tangential_damping: b_T [N s/m], > 0, or None for ``2 zeta sqrt(k_T m_T)``.
        restitution: e [-] in [0, 1], Newton's coefficient of the rigid model's impact law.
        zone: the compliant model's contact zone (one of :data:`ZONES`), None: Kelvin–Voigt.
        zone_parameters: the zone's masses, stiffnesses and dampers given (:data:`ZONE_PARAMETERS`).
    """

    stiffness: float = DEFAULT_STIFFNESS
    damping: float | None = None
    damping_ratio: float = DEFAULT_DAMPING_RATIO
    tangential_stiffness: float | None = None
    tangential_damping: float | None = None
    restitution: float = 0.0
    zone: str | None = None
    zone_parameters: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class ModelOptions:
    """A scene's ``[model]`` table, validated.

    Attributes:
        contact: ``"rigid"`` or ``"compliant"``.
        defaults: the parameters of every contact without an override.
        contacts: per-contact parameters (the defaults with the overrides applied), by name.
        armature: rotor inertia [kg m^2 or kg] added to massless coordinates, >= 0.
        armature_given: whether the file gave it (planners have their own default otherwise).
    """

    contact: str = "rigid"
    defaults: ContactParameters = field(default_factory=ContactParameters)
    contacts: Mapping[str, ContactParameters] = field(default_factory=dict)
    armature: float = DEFAULT_ARMATURE
    armature_given: bool = False

    def parameters(self, contact: str) -> ContactParameters:
        """The parameters of one contact (its override, else the defaults)."""
        return self.contacts.get(contact, self.defaults)


def _number(path: str, value: Any, field_name: str, *, positive: bool = False,
            non_negative: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SceneError(path, field_name, f"expected a finite number, got {value!r}")
    x = float(value)
    if positive and x <= 0:
        raise SceneError(path, field_name, f"expected a value > 0, got {x}")
    if non_negative and x < 0:
        raise SceneError(path, field_name, f"expected a value >= 0, got {x}")
    return x


def _parameters(path: str, table: Mapping[str, Any], where: str, base: ContactParameters,
                allowed: set[str]) -> ContactParameters:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise SceneError(path, f"{where}.{unknown[0]}",
                         f"unknown key; known keys: {', '.join(sorted(allowed))}")
    values: dict[str, Any] = {
        "stiffness": base.stiffness, "damping": base.damping, "damping_ratio": base.damping_ratio,
        "tangential_stiffness": base.tangential_stiffness,
        "tangential_damping": base.tangential_damping, "restitution": base.restitution,
        "zone": base.zone, "zone_parameters": dict(base.zone_parameters),
    }
    for key in ("stiffness", "tangential_stiffness", "damping_ratio", "tangential_damping"):
        if key in table:
            values[key] = _number(path, table[key], f"{where}.{key}", positive=True)
    if "damping" in table:
        values["damping"] = _number(path, table["damping"], f"{where}.damping", non_negative=True)
    if "restitution" in table:
        e = _number(path, table["restitution"], f"{where}.restitution", non_negative=True)
        if e > 1.0:
            raise SceneError(path, f"{where}.restitution", f"expected a value in [0, 1], got {e}")
        values["restitution"] = e
    _zone(path, table, where, values)
    return ContactParameters(**values)


def _zone(path: str, table: Mapping[str, Any], where: str, values: dict[str, Any]) -> None:
    """Read a table's ``zone`` and zone parameters into ``values``, and check what the zone needs."""
    if "zone" in table:
        if table["zone"] not in ZONES:
            raise SceneError(path, f"{where}.zone",
                             f"expected one of {', '.join(map(repr, ZONES))}, got {table['zone']!r}")
        values["zone"] = table["zone"]
    for key in ZONE_PARAMETERS:
        if key in table:
            values["zone_parameters"][key] = _number(path, table[key], f"{where}.{key}",
                                                     positive=not key.startswith("damping"),
                                                     non_negative=True)
    missing = [key for key in ZONE_REQUIRED.get(values["zone"], ()) if key not in values["zone_parameters"]]
    if missing and ("zone" in table or any(key in table for key in ZONE_PARAMETERS)):
        raise SceneError(path, f"{where}.{missing[0]}",
                         f"the {values['zone']} zone needs {', '.join(missing)} (see the scene schema)")


def read_model(path: str, raw: Any, contact_names: Sequence[str]) -> ModelOptions:
    """Parse and validate a scene's ``[model]`` table (None: every default).

    Raises:
        SceneError: ``[model]`` is not a table, an unknown key, an unknown contact model or
            contact name, a non-positive stiffness or damping ratio, a negative damping or
            armature, a zero tangential damping (the slider-in-series friction law needs b_T > 0).
    """
    if raw is None:
        return ModelOptions()
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
    armature = _number(path, raw.get("armature", DEFAULT_ARMATURE), "model.armature",
                       non_negative=True)
    defaults = _parameters(path, {k: v for k, v in raw.items() if k in _CONTACT_KEYS}, "model",
                           ContactParameters(), _CONTACT_KEYS)
    overrides = raw.get("contacts", {})
    if not isinstance(overrides, dict):
        raise SceneError(path, "model.contacts", "expected tables [model.contacts.NAME]")
    names = list(contact_names)
    per_contact = {}
    for name, table in overrides.items():
        where = f"model.contacts.{name}"
        if name not in names:
            raise SceneError(path, where, f"unknown contact {name!r}; the contacts are: {', '.join(names)}")
        if not isinstance(table, dict):
            raise SceneError(path, where, f"expected a table, got {table!r}")
        per_contact[name] = _parameters(path, table, where, defaults, _CONTACT_KEYS)
    return ModelOptions(contact=contact, defaults=defaults, contacts=per_contact, armature=armature,
                        armature_given="armature" in raw)

# -------------------------------------------------------------------------------------- [task]
@dataclass(frozen=True)
class TaskTable:
    """A scene's ``[task]`` table: the fields each planner reads (None: not given).

    Attributes:
        body_contacts: flip: the body's contacts, which must stay loaded.
        pitch: flip: the body's pitch coordinate.
        brace_contacts: climb: the contacts held in mode F.
        upper_brace_contacts: climb's gait: the upper brace's contacts.
        head_link: climb: the link of the point that must rise.
        head_point: climb: that point [m] in the link's frame.
        min_head_acceleration: climb: a_min [m/s^2].
    """

    body_contacts: tuple[str, ...] | None = None
    pitch: str | None = None
    brace_contacts: tuple[str, ...] | None = None
    upper_brace_contacts: tuple[str, ...] | None = None
    head_link: str | None = None
    head_point: np.ndarray | None = None
    min_head_acceleration: float | None = None


def read_task(path: str, raw: Any) -> TaskTable:
    """The ``[task]`` table as a record (None: an empty one).

    Raises:
        SceneError: ``[task]`` is not a table, a list of names that is not one, a bad point or
            acceleration.
    """
    if raw is None:
        return TaskTable()
    if not isinstance(raw, Mapping):
        raise SceneError(path, "task", f"expected a table [task], got {raw!r}")

    def names(key: str) -> tuple[str, ...] | None:
        value = raw.get(key)
        if value is None:
            return None
        if not isinstance(value, list) or not all(isinstance(x, str) for x in value):
            raise SceneError(path, f"task.{key}", f"expected a list of contact names, got {value!r}")
        return tuple(value)

    pitch, head_link = raw.get("pitch"), raw.get("head_link")
    a_min = raw.get("min_head_acceleration")
    if a_min is not None:
        a_min = _number(path, a_min, "task.min_head_acceleration")
    return TaskTable(
        body_contacts=names("body_contacts"),
        pitch=None if pitch is None else str(pitch),
        brace_contacts=names("brace_contacts"),
        upper_brace_contacts=names("upper_brace_contacts"),
        head_link=None if head_link is None else str(head_link),
        head_point=(None if "head_point" not in raw
                    else finite_pair(raw["head_point"], path, "task.head_point")),
        min_head_acceleration=a_min,
    )


# ----------------------------------------------------------------------------- [[disturbances]]
DISTURBANCE_KEYS = {"name", "link", "point", "lower", "upper", "vertices"}
"""The keys of a ``[[disturbances]]`` table."""


@dataclass(frozen=True)
class DisturbanceTable:
    """One ``[[disturbances]]`` table: a force on a link's point, in a box or a polygon.

    Attributes:
        name: its name.
        link: the link it acts on.
        point: [m] the point of application in the link's frame.
        corners: [N] the box's four corners or the polygon's vertices as given, shape (V, 2).
    """

    name: str
    link: str
    point: np.ndarray
    corners: np.ndarray


def finite_pair(value: Any, path: str, where: str) -> np.ndarray:
    """Two finite numbers (a point [m] or a force [N]).

    Raises:
        SceneError: not a list of two numbers, a NaN, or an infinite value (naming ``where``).
    """
    if not isinstance(value, list) or len(value) != 2:
        raise SceneError(path, where, f"expected two numbers [fx, fy] or [x, y], got {value!r}")
    out = []
    for i, x in enumerate(value):
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            raise SceneError(path, f"{where}[{i}]", f"expected a number, got {x!r}")
        if math.isnan(x):
            raise SceneError(path, f"{where}[{i}]", "got NaN; expected a finite number")
        if math.isinf(x):
            raise SceneError(path, f"{where}[{i}]", f"got {x}: the disturbance polytope would be "
                             "unbounded; give finite bounds or vertices")
        out.append(float(x))
    return np.array(out)


def read_disturbances(path: str, raw: Any, link_names: Sequence[str]) -> tuple[DisturbanceTable, ...]:
    """The ``[[disturbances]]`` tables as records (None: none).

    Raises:
        SceneError: not a non-empty array of tables, an unknown key, a missing or duplicate name,
            an unknown link, a bad point, both or neither of bounds and vertices, an empty
            polytope (``lower > upper``, no vertex), an unbounded one or a NaN.
    """
    if raw is None:
        return ()
    if not isinstance(raw, list) or not raw:
        raise SceneError(path, "disturbances", "expected a non-empty array of tables [[disturbances]]")
    items: list[DisturbanceTable] = []
    seen: set[str] = set()
    for i, table in enumerate(raw):
        where = f"disturbances[{i}]"
        if not isinstance(table, dict):
            raise SceneError(path, where, f"expected a table, got {table!r}")
        unknown = sorted(set(table) - DISTURBANCE_KEYS)
        if unknown:
            raise SceneError(path, f"{where}.{unknown[0]}",
                             f"unknown key; known keys: {', '.join(sorted(DISTURBANCE_KEYS))}")
        name = table.get("name")
        if not isinstance(name, str) or not name:
            raise SceneError(path, f"{where}.name", f"expected a non-empty string, got {name!r}")
        if name in seen:
            raise SceneError(path, f"{where}.name", f"duplicate disturbance name {name!r}")
        seen.add(name)
        link = table.get("link")
        if not isinstance(link, str) or not link:
            raise SceneError(path, f"{where}.link", f"expected a link name, got {link!r}")
        if link not in link_names:
            raise SceneError(path, f"{where}.link", str(FrameNotFound(link, link_names)))
        if "point" not in table:
            raise SceneError(path, f"{where}.point", "missing: the point of application [x, y] "
                             "[m] in the link's frame")
        point = finite_pair(table["point"], path, f"{where}.point")
        items.append(DisturbanceTable(name, link, point, _corners(path, table, where)))
    return tuple(items)


def _corners(path: str, table: Mapping[str, Any], where: str) -> np.ndarray:
    """The force polygon's corners: a box's four, or the vertices given."""
    has_box = "lower" in table or "upper" in table
    if has_box and "vertices" in table:
        raise SceneError(path, f"{where}.vertices", "give either lower/upper (a box) or "
                         "vertices (a polygon), not both")
    if has_box:
        for key in ("lower", "upper"):
            if key not in table:
                raise SceneError(path, f"{where}.{key}", "missing: a box needs both lower and upper")
        lower = finite_pair(table["lower"], path, f"{where}.lower")
        upper = finite_pair(table["upper"], path, f"{where}.upper")
        bad = np.nonzero(lower > upper)[0]
        if bad.size:
            j = int(bad[0])
            raise SceneError(path, f"{where}.lower[{j}]", f"the disturbance polytope is empty: "
                             f"lower {lower[j]} exceeds upper {upper[j]}")
        return np.array([[x, y] for x in (lower[0], upper[0]) for y in (lower[1], upper[1])])
    if "vertices" in table:
        raw = table["vertices"]
        if not isinstance(raw, list):
            raise SceneError(path, f"{where}.vertices", f"expected a list of [fx, fy], got {raw!r}")
        if not raw:
            raise SceneError(path, f"{where}.vertices", "the disturbance polytope is empty: "
                             "give at least one vertex [fx, fy]")
        return np.array([finite_pair(v, path, f"{where}.vertices[{j}]") for j, v in enumerate(raw)])
    raise SceneError(path, where, "missing: the forces, as lower = [fx, fy] and upper = "
                     "[fx, fy] (a box, [N]) or vertices = [[fx, fy], ...] (a polygon, [N])")


def read_tables(path: str, raw: Mapping[str, Any], contact_names: Sequence[str], link_names: Sequence[str]
                ) -> tuple[ModelOptions, TaskTable, tuple[DisturbanceTable, ...]]:
    """A scene document's ``[model]``, ``[task]`` and ``[[disturbances]]`` as records, at once.

    Raises:
        SceneError: as :func:`read_model`, :func:`read_task` and :func:`read_disturbances`.
    """
    return (read_model(path, raw.get("model"), contact_names), read_task(path, raw.get("task")),
            read_disturbances(path, raw.get("disturbances"), link_names))


__all__ = [
    "CONTACT_MODELS",
    "ContactParameters",
    "ZONES",
    "ZONE_PARAMETERS",
    "ZONE_REQUIRED",
    "DEFAULT_ARMATURE",
    "DEFAULT_DAMPING_RATIO",
    "DEFAULT_STIFFNESS",
    "DISTURBANCE_KEYS",
    "DisturbanceTable",
    "ModelOptions",
    "TaskTable",
    "finite_pair",
    "read_disturbances",
    "read_model",
    "read_tables",
    "read_task",
]
