"""The scene format as a JSON Schema, and the strict check every scene passes when it is loaded.

:data:`SCENE_SCHEMA` is the published format (``frc schema`` prints it; the same document ships as
``frcontrol/robots/scene.schema.json``). It is the one place that lists every table and key of a
scene, including the late-read ``[model]``, ``[task]`` and ``[[disturbances]]``. A scene is a TOML
file; the schema describes the document TOML parses to.

:func:`schema_problems` checks a parsed document against it: unknown keys (with the nearest valid
key), wrong types, out-of-range values, missing required keys and non-finite numbers (TOML has
``nan`` and ``inf``; JSON Schema cannot say "finite", so every number here must be finite unless
the key says otherwise). It returns every problem, in document order, so ``frc validate`` can list
them all; :func:`~frcontrol.scene.load_scene` raises the first as a
:class:`~frcontrol.errors.SceneError`.

The check is made by pydantic's validator (pydantic-core), compiled once per process from
:data:`SCENE_SCHEMA` (:func:`_core_schema`: strict types, finite numbers, no unknown keys); its
errors are worded here as the scene's fields. The tests read the same schema with ``jsonschema``
and agree. Checks that need the robot (a link's name, the number of coordinates, a contact named
in ``[task]``) are :func:`~frcontrol.scene.load_scene`'s second step, in one place, once the
robot's names are read from its URDF. Keys marked ``"x-refers"`` in the schema name a ``link``,
``joint``, ``coordinate`` or ``contact``; :func:`~frcontrol.scene.reference_problems` checks them
there.
"""

from __future__ import annotations

import difflib
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

__all__ = [
    "MAX_NUMBER",
    "NEAREST_KEY_CUTOFF",
    "apply_override",
    "beyond_float",
    "document_problems",
    "parse_override",
    "SCENE_SCHEMA",
    "SchemaProblem",
    "nearest",
    "unknown_message",
    "schema_problems",
]

MAX_NUMBER = int(sys.float_info.max)
"""The largest integer a scene's number may be (a float's range, about 1.8e308): a larger one is
refused as not finite."""

def beyond_float(value: int | float) -> str:
    """Why an integer beyond :data:`MAX_NUMBER` is no number of a scene ("" for any other value)."""
    if isinstance(value, int) and not -MAX_NUMBER <= value <= MAX_NUMBER:
        return f"expected a finite number, got an integer of {value.bit_length()} bits (beyond a float)"
    return ""


NEAREST_KEY_CUTOFF = 0.5
"""[-] Least ``difflib`` similarity ratio for a valid name to be offered as "did you mean"."""

_NUMBER = {"type": "number"}
_PAIR = {"type": "array", "items": _NUMBER, "minItems": 2, "maxItems": 2}
_NUMBERS = {"type": "array", "items": _NUMBER}
_NAMES = {"type": "array", "items": {"type": "string", "minLength": 1}}

_OBJECTIVE = {
    "type": "object",
    "additionalProperties": False,
    "description": "a coordinate's acceleration, or a point's acceleration along a direction",
    "properties": {
        "coordinate": {"type": "string", "x-refers": "coordinate",
                       "description": "the coordinate whose acceleration is the objective"},
        "link": {"type": "string", "x-refers": "link", "description": "the link of the point"},
        "point": {**_PAIR, "description": "[m] the point, in the link's frame"},
        "direction": {**_PAIR, "description": "[-] the world direction of its acceleration"},
        "at_least": {"type": "number",
                     "description": "a plan's objective must be at least this (worst case when robust)"},
    },
}
_REQUIREMENT = {
    "type": "object",
    "additionalProperties": False,
    "description": "a coordinate's acceleration, or a point's along a direction, kept within bounds "
                   "by every plan (at every disturbance vertex when robust)",
    "properties": {
        "coordinate": {"type": "string", "x-refers": "coordinate", "description": "the coordinate"},
        "link": {"type": "string", "x-refers": "link", "description": "the link of the point"},
        "point": {**_PAIR, "description": "[m] the point, in the link's frame"},
        "direction": {**_PAIR, "description": "[-] the world direction of its acceleration"},
        "at_least": {"type": "number", "description": "[m/s^2 or rad/s^2] the quantity's floor"},
        "at_most": {"type": "number", "description": "[m/s^2 or rad/s^2] the quantity's ceiling"},
    },
}
_PHASE = {
    "type": "object",
    "additionalProperties": False,
    "required": ["name", "until"],
    "properties": {
        "name": {"type": "string", "minLength": 1, "description": "the phase's name"},
        "modes": {"type": "object", "x-refers-keys": "contact",
                  "description": "allowed mode letters (S, L, R, F) per contact; a contact not named: any",
                  "additionalProperties": {"type": "string", "minLength": 1, "pattern": "^[SLRF]+$"}},
        "margin": {"type": "number", "minimum": 0,
                   "description": "[input units] distance kept inside the allowed modes' unambiguous set"},
        "robust": {"type": "boolean",
                   "description": "hold the allowed modes for every vertex of every [[disturbances]]"},
        "largest_scale": {
            "type": "object",
            "additionalProperties": False,
            "required": ["upper"],
            "description": "robust phases: at the phase's first decision, also find the largest scale of "
                           "the [[disturbances]] polytope at which a plan exists",
            "properties": {
                "upper": {"type": "number", "exclusiveMinimum": 0,
                          "description": "[-] the largest scale searched"},
            },
        },
        "require": {"type": "array", "items": _REQUIREMENT,
                    "description": "conditions on the accelerations every plan of the phase meets"},
        "maximize": {**_OBJECTIVE, "description": "maximise an acceleration"},
        "minimize": {**_OBJECTIVE, "description": "minimise an acceleration"},
        "track": {
            "type": "object",
            "additionalProperties": False,
            "required": ["coordinates"],
            "description": "least squares of the accelerations to a PD target",
            "properties": {
                "coordinates": {"type": "object", "x-refers-keys": "coordinate", "minProperties": 1,
                                "additionalProperties": {"type": "number"},
                                "description": "[m or rad] the target of each coordinate"},
                "stiffness": {"type": "number", "minimum": 0, "description": "[1/s^2] the PD stiffness"},
                "damping": {"type": "number", "minimum": 0, "description": "[1/s] the PD damping"},
                "weights": {"type": "object", "x-refers-keys": "coordinate",
                            "additionalProperties": {"type": "number", "minimum": 0},
                            "description": "[-] each coordinate's error is multiplied by this before "
                                           "it is squared (default 1)"},
            },
        },
        "until": {
            "type": "object",
            "additionalProperties": False,
            "description": "when the phase ends: one of coordinate (with above or below), time, contact",
            "properties": {
                "coordinate": {"type": "string", "x-refers": "coordinate",
                               "description": "the coordinate compared"},
                "above": {"type": "number", "description": "ends when the coordinate passes above this"},
                "below": {"type": "number", "description": "ends when the coordinate passes below this"},
                "time": {"type": "number", "exclusiveMinimum": 0,
                         "description": "[s] ends this long after the phase starts"},
                "contact": {"type": "object", "x-refers-keys": "contact", "minProperties": 1,
                            "additionalProperties": {"enum": ["closed", "open"]},
                            "description": "ends when every named contact is closed or open"},
            },
        },
    },
}


def _number(description: str, **bounds: float) -> dict[str, Any]:
    return {"type": "number", "description": description, **bounds}


_CONTACT_PARAMETERS: dict[str, Any] = {
    "stiffness": _number("k_N [N/m], normal contact stiffness", exclusiveMinimum=0),
    "damping": _number("b_N [N s/m]; absent: critical for each contact's effective mass", minimum=0),
    "damping_ratio": _number("zeta [-], used when damping is absent", exclusiveMinimum=0),
    "tangential_stiffness": _number("k_T [N/m]; absent: = stiffness", exclusiveMinimum=0),
    "tangential_damping": _number("b_T [N s/m]; absent: critical", exclusiveMinimum=0),
    "restitution": _number("e [-], Newton's restitution of the rigid model's impact law", minimum=0,
                           maximum=1, default=0),
    "zone": {"enum": ["rigid", "compliant", "one_stage", "two_stage"],
             "description": "the compliant model's contact zone (Vukobratovic-Potkonjak Fig. 6): compliant "
                            "(Kelvin-Voigt, massless), one_stage (a robot-side mass on its internal "
                            "spring-damper, rigid against the surface), two_stage (masses, internal and "
                            "external spring-dampers on both sides); rigid: only the rigid model"},
    "mass_robot": _number("m'_r [kg], the robot side's contact mass (one_stage, two_stage)",
                          exclusiveMinimum=0),
    "stiffness_internal_robot": _number("k''_r [N/m], the robot side's internal stiffness (one_stage, "
                                        "two_stage)", exclusiveMinimum=0),
    "damping_internal_robot": _number("b''_r [N s/m], the robot side's internal damping; absent: 0",
                                      minimum=0),
    "stiffness_external_robot": _number("k'_r [N/m], the robot side's external stiffness (two_stage)",
                                        exclusiveMinimum=0),
    "damping_external_robot": _number("b'_r [N s/m], the robot side's external damping; absent: 0",
                                      minimum=0),
    "mass_environment": _number("m'_e [kg], the environment side's contact mass (two_stage)",
                                exclusiveMinimum=0),
    "stiffness_internal_environment": _number("k''_e [N/m], the environment side's internal stiffness "
                                              "(two_stage)", exclusiveMinimum=0),
    "damping_internal_environment": _number("b''_e [N s/m], the environment side's internal damping; "
                                            "absent: 0", minimum=0),
    "stiffness_external_environment": _number("k'_e [N/m], the environment side's external stiffness "
                                              "(two_stage)", exclusiveMinimum=0),
    "damping_external_environment": _number("b'_e [N s/m], the environment side's external damping; "
                                            "absent: 0", minimum=0),
}

_STAGE: dict[str, Any] = {
    "type": "object",
    "additionalProperties": False,
    "description": "a gear pair, then a torsion element (rigid without stiffness); motor side first",
    "properties": {
        "ratio": _number("N [-], input speed / output speed (33 for 33:1)", exclusiveMinimum=0,
                         default=1),
        "efficiency": _number("eta [-], in (0, 1]: factor on the driving torque through the gears",
                              exclusiveMinimum=0, maximum=1, default=1),
        "inertia_in": _number("I' [kg m^2], input gear's inertia", minimum=0, default=0),
        "inertia_out": _number("I'' [kg m^2], output gear's inertia", minimum=0, default=0),
        "stiffness": _number("c [N m/rad] of the torsion element after the gears; absent: rigid",
                             exclusiveMinimum=0),
        "damping": _number("d [N m s/rad] of the torsion element", minimum=0, default=0),
        "deflection": _number("[rad] the torsion element's twist at the scene's state", default=0),
    },
}

_DRIVE: dict[str, Any] = {
    "type": "object",
    "additionalProperties": False,
    "description": "a DC motor (voltage input [V]) and its transmission, driving the joint named by "
                   "the table's key",
    "required": ["resistance", "torque_constant", "back_emf_constant", "rotor_inertia", "voltage_limit"],
    "properties": {
        "kind": {"enum": ["dc_motor"], "default": "dc_motor"},
        "resistance": _number("R [ohm], terminal resistance", exclusiveMinimum=0),
        "torque_constant": _number("C_M [N m/A]", exclusiveMinimum=0),
        "back_emf_constant": _number("C_E [V s/rad]", minimum=0),
        "rotor_inertia": _number("J_r [kg m^2]", minimum=0),
        "voltage_limit": _number("u_max [V]: the voltage lies in [-u_max, u_max]", exclusiveMinimum=0),
        "stages": {"type": "array", "items": _STAGE,
                   "description": "the transmission, motor side first; absent: direct drive"},
    },
}

_SPRING: dict[str, Any] = {
    "type": "object",
    "additionalProperties": False,
    "description": "a linear spring and damper on the unactuated joint named by the table's key: the "
                   "generalized force -stiffness (q - rest) - damping v on its coordinate",
    "required": ["stiffness"],
    "properties": {
        "stiffness": _number("k [N/m] on a prismatic joint, [N m/rad] on a revolute one", minimum=0),
        "damping": _number("c [N s/m] or [N m s/rad]", minimum=0, default=0),
        "rest": _number("[m] or [rad] the coordinate's value at which the spring is relaxed", default=0),
    },
}

SCENE_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "$id": "frcontrol-scene.schema.json",
    "title": "frcontrol scene",
    "description": "A planar robot in contact: robot, base, state, contacts against fixed lines, inputs; "
                   "optionally the simulation model, a planner's task and disturbances. Every number "
                   "must be finite.",
    "type": "object",
    "additionalProperties": False,
    "required": ["robot", "state"],
    "properties": {
        "name": {"type": "string", "minLength": 1, "description": "a human-readable name"},
        "description": {"type": "string", "description": "free text"},
        "robot": {"type": "string", "minLength": 1,
                  "description": "URDF file, relative to the scene, else a shipped robot's name, "
                                 "or example-robot-data:NAME (a 3-D robot: give plane)"},
        "plane": {"enum": ["xz", "yz", "xy", "zx", "zy", "yx"],
                  "description": "a 3-D robot's plane: the world axes that become the planar x and y "
                                 "(y up); xz is the sagittal plane of a robot with x forward, z up"},
        "plane_locked": {"type": "object", "additionalProperties": _number("[rad or m]"),
                         "description": "3-D joints welded at a value [rad or m] before the plane "
                                        "mapping (joints that do not move in the plane)"},
        "base": {"enum": ["planar", "fixed"], "default": "planar",
                 "description": "planar: floating x, y, theta; fixed: bolted to the world"},
        "gravity": _number("[m/s^2] along -y", minimum=0, default=9.81),
        "gap_tolerance": _number("[m] a contact with a larger gap is inactive", exclusiveMinimum=0,
                                 default=1e-6),
        "locked_joints": {**_NAMES, "x-refers": "joint",
                          "description": "joints welded at their state value (no coordinate)"},
        "state": {
            "type": "object",
            "additionalProperties": False,
            "required": ["q"],
            "properties": {
                "q": {**_NUMBERS, "description": "[m, rad] minimal coordinates: base, then joints"},
                "v": {**_NUMBERS, "description": "[m/s, rad/s] minimal velocities; absent: zeros"},
            },
        },
        "contacts": {
            "type": "array",
            "items": {
                "type": "object",
                "additionalProperties": False,
                "required": ["link", "point", "normal", "mu"],
                "properties": {
                    "name": {"type": "string", "minLength": 1, "description": "unique; absent: c<i>"},
                    "link": {"type": "string", "minLength": 1, "x-refers": "link"},
                    "point": {**_PAIR, "description": "[m] in the link's frame"},
                    "normal": {**_PAIR, "description": "surface normal in the world, towards the robot"},
                    "mu": _number("Coulomb coefficient [-]", minimum=0),
                    "surface_point": {**_PAIR, "description": "[m] a point of the surface line; "
                                      "absent: the contact point at the scene's state (gap 0)"},
                },
            },
        },
        "inputs": {
            "type": "object",
            "additionalProperties": False,
            "required": ["coordinates"],
            "properties": {
                "coordinates": {**_NAMES, "x-refers": "coordinate",
                                "description": "the coordinates u acts on (generalized forces)"},
                "lower": {**_NUMBERS, "description": "[N or N m; V if driven] lower limits, same order"},
                "upper": {**_NUMBERS, "description": "[N or N m; V if driven] upper limits, same order"},
            },
        },
        "model": {
            "type": "object",
            "additionalProperties": False,
            "description": "the contact model for simulation",
            "properties": {
                "contact": {"enum": ["rigid", "compliant"], "default": "rigid"},
                **_CONTACT_PARAMETERS,
                "armature": _number("[kg m^2 or kg] rotor inertia added to massless coordinates",
                                    minimum=0),
                "drives": {
                    "type": "object",
                    "description": "DC-motor drives, by joint name: the joint's input is then a voltage [V]",
                    "additionalProperties": _DRIVE,
                },
                "springs": {
                    "type": "object",
                    "description": "joint springs, by joint name (unactuated joints only)",
                    "additionalProperties": _SPRING,
                },
                "contacts": {
                    "type": "object",
                    "description": "per-contact overrides, by contact name",
                    "x-refers-keys": "contact",
                    "additionalProperties": {
                        "type": "object",
                        "additionalProperties": False,
                        "properties": dict(_CONTACT_PARAMETERS),
                    },
                },
            },
        },
        "task": {
            "type": "object",
            "additionalProperties": False,
            "description": "what the planners need: either a task as phases (frc plan: max_time, "
                           "repeat, phases) or a dedicated planner's keys (frc flip, climb, standup), "
                           "not both",
            "properties": {
                "max_time": _number("plan: [s] the longest simulated time of the task", exclusiveMinimum=0),
                "repeat": {"type": "integer", "minimum": 1,
                           "description": "plan: how many times the phases run, in order"},
                "phases": {"type": "array", "minItems": 1, "items": _PHASE,
                           "description": "plan: the task's phases, run in order"},
                "timing": {"type": "string", "enum": ["pump"],
                           "description": "plan: the phase timing that ends the phases and drives those "
                                          "without an objective (pump: frcontrol.planning.pump_timing; "
                                          "repeat is then the most cycles)"},
                "gait": {"type": "object", "additionalProperties": False, "required": ["upper_brace"],
                         "description": "plan: the snake's climbing gait beside the phases, a second task "
                                        "(frc plan --cycles N, frc climb --cycles N: repeat = N); without "
                                        "phases: the shipped four, its lower brace the first phase's F "
                                        "contacts",
                         "properties": {
                             "upper_brace": {**_NAMES, "minItems": 1, "x-refers": "contact",
                                             "description": "the gait's upper brace, separated at the "
                                                            "scene's state"},
                             "timing": {"type": "string", "enum": ["gait"],
                                        "description": "the gait's phase timing "
                                                       "(frcontrol.planning.gait_timing; the default)"},
                             "repeat": {"type": "integer", "minimum": 1,
                                        "description": "the gait's cycles (--cycles overrides it)"},
                             "max_time": _number("[s] the longest simulated time (default: the cycles' "
                                                 "time plus 1 s)", exclusiveMinimum=0),
                             "seed": {"type": "integer", "minimum": 0,
                                      "description": "seed of the run's sampled disturbances (--seed)"},
                             "scale": _number("[-] the run's disturbance scale (--scale; default 0.02, "
                                              "at most the weakest phase's planned scale)", minimum=0),
                             "phases": {"type": "array", "minItems": 4, "maxItems": 4, "items": _PHASE,
                                        "description": "extend, upper_brace, pull, lower_brace: each "
                                                       "one's modes (held and closing brace F, opened "
                                                       "brace S), margin, robust and until = { time }"},
                         }},
                "body_contacts": {**_NAMES, "minItems": 1, "x-refers": "contact",
                                  "description": "flip: the body's contacts"},
                "pitch": {"type": "string", "x-refers": "coordinate",
                          "description": "flip: the body's pitch coordinate"},
                "brace_contacts": {**_NAMES, "minItems": 1, "x-refers": "contact",
                                   "description": "climb: the contacts held in mode F"},
                "upper_brace_contacts": {**_NAMES, "minItems": 1, "x-refers": "contact",
                                         "description": "climb --cycles: the gait's upper brace, "
                                                        "separated at the scene's state"},
                "head_link": {"type": "string", "x-refers": "link",
                              "description": "climb: the link of the point that must rise"},
                "head_point": {**_PAIR, "description": "climb: [m] that point, in the link's frame"},
                "min_head_acceleration": _number("climb: [m/s^2] least upward acceleration of the head"),
                "feet": {**_NAMES, "minItems": 1, "x-refers": "contact",
                         "description": "standup: the contacts held in mode F (the feet)"},
                "stand_height": _number("standup: [m] the height y of the base to stand at"),
            },
        },
        "disturbances": {
            "type": "array",
            "minItems": 1,
            "description": "the climb planner's disturbance forces: a box (lower/upper) or a polygon",
            "items": {
                "type": "object",
                "additionalProperties": False,
                "required": ["name", "link", "point"],
                "properties": {
                    "name": {"type": "string", "minLength": 1},
                    "link": {"type": "string", "minLength": 1, "x-refers": "link"},
                    "point": {**_PAIR, "description": "[m] in the link's frame"},
                    "lower": {**_PAIR, "description": "[N] (fx, fy) in the world"},
                    "upper": {**_PAIR, "description": "[N] (fx, fy) in the world"},
                    "vertices": {"type": "array", "items": _PAIR, "minItems": 1,
                                 "description": "[N] polygon vertices (fx, fy)"},
                },
            },
        },
    },
}


@dataclass(frozen=True)
class SchemaProblem:
    """One way a scene document breaks the format.

    Attributes:
        field: the dotted path of the offending field (``contacts[0].muu``), ``""`` for the document.
        reason: what is wrong, what was expected and, for an unknown key, the nearest valid one.
    """

    field: str
    reason: str


def nearest(name: str, valid: Sequence[str]) -> str | None:
    """The valid name closest to ``name`` (:data:`NEAREST_KEY_CUTOFF`), or None."""
    match = difflib.get_close_matches(name, list(valid), n=1, cutoff=NEAREST_KEY_CUTOFF)
    return match[0] if match else None


def unknown_message(kind: str, name: str, where: str, valid: Sequence[str]) -> str:
    """``unknown KIND 'NAME'WHERE; did you mean 'NEAREST'? valid: ...`` (the nearest by :func:`nearest`)."""
    guess = nearest(name, valid)
    hint = f"did you mean {guess!r}? " if guess else ""
    return f"unknown {kind} {name!r}{where}; {hint}valid: {', '.join(valid) or '(none)'}"


def _table_label(path: str, doc: Any) -> str:
    """How a message names a table: ``[inputs]``, ``[[contacts]] 'tip'``, ``[model.contacts.x]``."""
    if not path:
        return ""
    head = path.split("[")[0].split(".")[0]
    if path.endswith("]") and head in ("contacts", "disturbances"):
        name = doc.get("name") if isinstance(doc, Mapping) else None
        return f" in [[{head}]]" + (f" {name!r}" if isinstance(name, str) else f" {path[len(head):]}")
    return f" in [{path}]"


def _type_name(value: Any) -> str:
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, Mapping):
        return "a table"
    return type(value).__name__


def _core_schema(schema: Mapping[str, Any]) -> Any:
    """The pydantic-core schema that checks what the JSON Schema ``schema`` says, strictly.

    Strict: no value is converted (``"0.5"`` is not a number, ``1`` is not ``true``); a number
    must be finite (TOML has ``nan`` and ``inf``); a table with ``additionalProperties = false``
    forbids other keys.
    """
    from pydantic_core import core_schema as cs

    if "enum" in schema:
        return cs.literal_schema(list(schema["enum"]))
    kind = schema.get("type")
    if kind == "number":
        bounds = {name: schema[key] for key, name in _BOUNDS.items() if key in schema}
        return cs.float_schema(allow_inf_nan=False, strict=True, **bounds)
    if kind == "integer":
        return cs.int_schema(strict=True, ge=schema.get("minimum"))
    if kind == "boolean":
        return cs.bool_schema(strict=True)
    if kind == "string":
        return cs.str_schema(strict=True, min_length=schema.get("minLength"), pattern=schema.get("pattern"))
    if kind == "array":
        return cs.list_schema(_core_schema(schema["items"]), min_length=schema.get("minItems"),
                              max_length=schema.get("maxItems"), strict=True)
    if kind != "object":
        raise ValueError(f"the scene schema uses a type the check does not know: {schema!r}")
    extra = schema.get("additionalProperties", True)
    if "properties" not in schema:
        values = _core_schema(extra) if isinstance(extra, Mapping) else cs.any_schema()
        return cs.dict_schema(cs.str_schema(), values, min_length=schema.get("minProperties"), strict=True)
    required = set(schema.get("required", ()))
    fields = {key: cs.typed_dict_field(_core_schema(sub), required=key in required)
              for key, sub in schema["properties"].items()}
    return cs.typed_dict_schema(fields, extra_behavior="forbid" if extra is False else "allow", strict=True)


_BOUNDS = {"minimum": "ge", "exclusiveMinimum": "gt", "maximum": "le"}
"""JSON Schema's bounds of a number and pydantic-core's names for them."""


@lru_cache(maxsize=1)
def _validator() -> Any:
    """The validator of :data:`SCENE_SCHEMA` (pydantic-core, built once per process)."""
    from pydantic_core import SchemaValidator

    return SchemaValidator(_core_schema(SCENE_SCHEMA))


def _path_text(path: Sequence[str | int]) -> str:
    """``contacts[0].mu`` for the path ``("contacts", 0, "mu")``."""
    text = ""
    for part in path:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def _schema_at(path: Sequence[str | int]) -> Mapping[str, Any]:
    """The part of :data:`SCENE_SCHEMA` that describes the value at ``path``."""
    schema: Mapping[str, Any] = SCENE_SCHEMA
    for part in path:
        if isinstance(part, int):
            schema = schema["items"]
        else:
            extra = schema.get("additionalProperties")
            schema = schema.get("properties", {}).get(part, extra if isinstance(extra, Mapping) else {})
    return schema


def _value_at(root: Any, path: Sequence[str | int]) -> Any:
    """The value at ``path`` in the document ``root``."""
    for part in path:
        root = root[part]
    return root


_EXPECTED = {"float_type": "a number", "int_type": "an integer", "string_type": "a string",
             "list_type": "a list", "dict_type": "a table"}
"""pydantic-core's error types for a value of the wrong type, and what the value should be."""

_BOUND_ERRORS = {"greater_than_equal": (">=", "ge"), "greater_than": (">", "gt"),
                 "less_than_equal": ("<=", "le")}
"""pydantic-core's error types for a number out of bounds: the sign and the bound's name."""


def _value_reason(kind: str, context: Mapping[str, Any], schema: Mapping[str, Any], value: Any) -> str:
    """What is wrong with a value that fails the check ``kind`` (a type, an enum, a bound, a length)."""
    if kind == "literal_error":
        options = [repr(x) for x in schema["enum"]]
        choice = " or ".join(options) if len(options) == 2 else "one of " + ", ".join(options)
        return f"expected {choice}, got {value!r}"
    if kind == "finite_number" or (kind == "float_type" and isinstance(value, int) and beyond_float(value)):
        return beyond_float(value) or f"expected a finite number, got {value!r}"
    if kind in _EXPECTED:
        return f"expected {_EXPECTED[kind]}, got {_type_name(value)} ({value!r})"
    if kind == "bool_type":
        return f"expected true or false, got {_type_name(value)} ({value!r})"
    if kind in _BOUND_ERRORS:
        sign, name = _BOUND_ERRORS[kind]
        return f"expected {sign} {context[name]:g}, got {value!r}"
    if kind == "string_too_short":
        return "expected a non-empty string"
    if kind == "string_pattern_mismatch":
        return f"expected a string matching {schema['pattern']}, got {value!r}"
    if kind == "too_short":
        return f"expected at least {context['min_length']} item(s), got {len(value)}"
    if kind == "too_long":
        return f"expected at most {context['max_length']} items, got {len(value)}"
    return f"does not hold: {kind}"


def _problem_of(error: Mapping[str, Any], root: Any) -> tuple[tuple[int, ...], SchemaProblem]:
    """The problem a pydantic-core error in the document ``root`` stands for, with its place.

    A place is the index of each key or item on the value's path (:func:`_document_order`); a
    table's missing keys are placed after its own keys, its own problems before them.
    """
    path = list(error["loc"])
    kind, value = error["type"], error["input"]
    if kind in ("extra_forbidden", "missing"):
        table_path, key = path[:-1], path[-1]
        table, schema = _value_at(root, table_path), _schema_at(table_path)
        label, properties = _table_label(_path_text(table_path), table), schema.get("properties", {})
        if kind == "extra_forbidden":
            reason = unknown_message("field" if not table_path else "key", str(key), label, list(properties))
            return _document_order(root, path), SchemaProblem(_path_text(path), reason)
        about = properties.get(key, {}).get("description")
        order = _document_order(root, table_path) + (len(table) + 1, list(schema["required"]).index(key))
        return order, SchemaProblem(_path_text(path), f"missing{label}" + (f": {about}" if about else ""))
    where = _path_text(path)
    if kind == "too_short" and isinstance(value, Mapping):
        reason = f"expected at least {error['ctx']['min_length']} key(s){_table_label(where, value)}"
        return _document_order(root, path) + (len(value),), SchemaProblem(where, reason)
    reason = _value_reason(kind, error.get("ctx") or {}, _schema_at(path), value)
    return _document_order(root, path) + (-1,), SchemaProblem(where, reason)


def _document_order(root: Any, path: Sequence[str | int]) -> tuple[int, ...]:
    """The place of the value at ``path`` in the document ``root``: each key's or item's index."""
    order = []
    node = root
    for part in path:
        order.append(part if isinstance(part, int) else list(node).index(part))
        node = node[part]
    return tuple(order)


def _schema_errors(doc: Any) -> list[SchemaProblem]:
    """The problems the validator of :data:`SCENE_SCHEMA` finds in ``doc``, in document order."""
    from pydantic_core import ValidationError

    try:
        _validator().validate_python(doc)
    except ValidationError as err:
        placed = sorted((_problem_of(e, doc) for e in err.errors()), key=lambda item: item[0])
        return [problem for _, problem in placed]
    return []


def document_problems(doc: dict[str, Any], overrides: Mapping[str, Any]) -> list[SchemaProblem]:
    """Set ``overrides`` on the parsed scene ``doc`` (:func:`apply_override`), then check it.

    Returns:
        The first override's problems if one cannot be set, else :func:`schema_problems`.
    """
    for key, value in overrides.items():
        problems = apply_override(doc, key, value)
        if problems:
            return problems
    return schema_problems(doc)


def schema_problems(doc: Any) -> list[SchemaProblem]:
    """Every way the parsed scene ``doc`` breaks :data:`SCENE_SCHEMA`, in document order."""
    out = _schema_errors(doc)
    if isinstance(doc, Mapping) and isinstance(doc.get("disturbances"), list):
        for i, table in enumerate(doc["disturbances"]):
            if isinstance(table, Mapping):
                out.extend(_disturbance_shape(table, f"disturbances[{i}]"))
    if isinstance(doc, Mapping) and isinstance(doc.get("task"), Mapping):
        out.extend(_task_shape(doc["task"]))
    return out


PHASED_TASK_KEYS = ("max_time", "repeat", "phases", "timing", "gait")
"""The keys of a task given as phases (``frc plan``; ``timing``: the phase timing, ``gait``: the
snake's climbing gait beside the phases); the other ``[task]`` keys are the dedicated planners'
(``frc flip``, ``frc climb``, ``frc standup``)."""


def _task_shape(task: Mapping[str, Any]) -> list[SchemaProblem]:
    """A ``[task]`` is phases or a dedicated planner's keys, not both; a phase has one objective."""
    out = []
    phased = [k for k in task if k in PHASED_TASK_KEYS]
    dedicated = [k for k in task if k not in PHASED_TASK_KEYS]
    if phased and dedicated:
        out.append(SchemaProblem(f"task.{dedicated[0]}", f"a [task] with {phased[0]} is a task as "
                                 "phases (frc plan): give either phases or a dedicated planner's keys "
                                 f"({', '.join(dedicated)}), not both"))
    if phased and "phases" not in task:
        out.append(SchemaProblem("task.phases", "missing: a task as phases needs [[task.phases]]"))
    phases = task.get("phases")
    for i, phase in enumerate(phases if isinstance(phases, list) else []):
        if isinstance(phase, Mapping):
            out.extend(_phase_shape(phase, f"task.phases[{i}]", timed="timing" in task))
    gait = task.get("gait")
    phases = gait.get("phases") if isinstance(gait, Mapping) else None
    for i, phase in enumerate(phases if isinstance(phases, list) else []):
        if isinstance(phase, Mapping):
            out.extend(_phase_shape(phase, f"task.gait.phases[{i}]", timed=True))
    return out


def _phase_shape(phase: Mapping[str, Any], where: str, *, timed: bool = False) -> list[SchemaProblem]:
    """One of maximize, minimize, track (or none, under a timing); ``until`` one condition."""
    objectives = [k for k in ("maximize", "minimize", "track") if k in phase]
    if len(objectives) != 1 and not (timed and not objectives):
        got = ", ".join(objectives) or "none"
        return [SchemaProblem(where, f"a phase needs exactly one of maximize, minimize, track (got {got})")]
    out = []
    objective = phase[objectives[0]] if objectives else None
    if objectives and objectives[0] != "track":
        out.extend(_quantity_shape(objective, f"{where}.{objectives[0]}"))
    requires = phase.get("require")
    for i, requirement in enumerate(requires if isinstance(requires, list) else []):
        out.extend(_quantity_shape(requirement, f"{where}.require[{i}]"))
        if isinstance(requirement, Mapping) and not {"at_least", "at_most"} & set(requirement):
            out.append(SchemaProblem(f"{where}.require[{i}]", "missing: at_least = X or at_most = X"))
    until = phase.get("until")
    if isinstance(until, Mapping):
        kinds = [k for k in ("coordinate", "time", "contact") if k in until]
        bounds = [k for k in ("above", "below") if k in until]
        if len(kinds) != 1 or (kinds == ["coordinate"]) != (len(bounds) == 1) or (bounds and not kinds):
            out.append(SchemaProblem(f"{where}.until", "expected one condition: coordinate = NAME with "
                                     "above = X or below = X, or time = T [s], or contact = { NAME = "
                                     "'closed' | 'open' }"))
    return out


def _quantity_shape(quantity: Any, where: str) -> list[SchemaProblem]:
    """An acceleration is a coordinate's, or a point's (link, point, direction): one of them."""
    if not isinstance(quantity, Mapping):
        return []
    point = [k for k in ("link", "point", "direction") if k in quantity]
    if ("coordinate" in quantity) == bool(point) or (point and len(point) != 3):
        return [SchemaProblem(where, "expected either coordinate = NAME, or link, point = [x, y] and "
                              "direction = [dx, dy]")]
    return []


def _disturbance_shape(table: Mapping[str, Any], where: str) -> list[SchemaProblem]:
    """A disturbance is a box (lower and upper, lower <= upper) or a polygon (vertices), not both."""
    has_box = "lower" in table or "upper" in table
    if has_box and "vertices" in table:
        return [SchemaProblem(f"{where}.vertices", "give either lower/upper (a box) or vertices "
                              "(a polygon), not both")]
    if not has_box and "vertices" not in table:
        return [SchemaProblem(where, "missing: the forces, as lower = [fx, fy] and upper = [fx, fy] "
                              "(a box, [N]) or vertices = [[fx, fy], ...] (a polygon, [N])")]
    if has_box:
        for key in ("lower", "upper"):
            if key not in table:
                return [SchemaProblem(f"{where}.{key}", "missing: a box needs both lower and upper")]
        lower, upper = table["lower"], table["upper"]
        try:
            for j in range(2):
                if lower[j] > upper[j]:
                    return [SchemaProblem(f"{where}.lower[{j}]", f"the disturbance polytope is empty: "
                                          f"lower {lower[j]} exceeds upper {upper[j]}")]
        except (TypeError, IndexError, KeyError):
            pass  # a malformed pair: reported by the schema check
    return []


# ---------------------------------------------------------------------------------------- overrides
def parse_override(assignment: str) -> tuple[str, Any]:
    """Split ``PATH=VALUE`` (the ``--set`` grammar): VALUE is read as TOML, else as a bare string.

    ``contacts.tip.mu=0.5`` gives ``("contacts.tip.mu", 0.5)``; ``state.q=[0, 0.45, 2.0]`` a list;
    ``model.contact=compliant`` the string ``"compliant"`` (TOML would need the quotes).

    Raises:
        ValueError: no ``=``, or an empty path.
    """
    import tomllib

    path, sep, text = assignment.partition("=")
    path = path.strip()
    if not sep or not path:
        raise ValueError(f"expected PATH=VALUE, got {assignment!r}")
    try:
        value = tomllib.loads(f"value = {text.strip()}")["value"]
    except tomllib.TOMLDecodeError:
        value = text.strip()
    return path, value


def _segments(path: str) -> list[str]:
    return path.replace("[", ".").replace("]", "").split(".")


def apply_override(doc: dict[str, Any], path: str, value: Any) -> list[SchemaProblem]:
    """Set the field at a dotted ``path`` of a parsed scene to ``value``, in place.

    Tables are addressed by key (``model.stiffness``, ``state.q``), entries of ``[[contacts]]`` and
    ``[[disturbances]]`` by name or by index (``contacts.tip.mu``, ``contacts[0].mu``), items of a
    list by index (``state.q[1]``). A path the schema does not know, or a name no entry has, is a
    problem naming the nearest valid one; the value itself is checked afterwards like the file's.

    Returns:
        The problems (empty when the value was set).
    """
    parts = _segments(path)
    if any(not p for p in parts):
        return [SchemaProblem(path, "malformed path: empty segment")]
    node: Any = doc
    schema: Mapping[str, Any] = SCENE_SCHEMA
    walked: list[str] = []
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        where = _path_text([int(p) if p.isdigit() else p for p in walked]) or "the scene"
        kind = schema.get("type")
        if kind == "object":
            properties = schema.get("properties", {})
            extra = schema.get("additionalProperties", True)
            if part in properties:
                sub = properties[part]
            elif isinstance(extra, Mapping):
                sub = extra
            else:
                return [SchemaProblem(path, unknown_message("field" if not walked else "key", part,
                                                     f" in {where}", list(properties)))]
            if last:
                node[part] = value
                return []
            default: Any = [] if sub.get("type") == "array" else {}
            if not isinstance(node.get(part, default), (dict, list)):
                return [SchemaProblem(path, f"{'.'.join(walked + [part])} is not a table or a list")]
            node = node.setdefault(part, default)
        elif kind == "array":
            if not isinstance(node, list):
                return [SchemaProblem(path, f"{where} is not a list")]
            sub = schema["items"]
            if part.isdigit():
                index = int(part)
            else:
                names = [e.get("name") for e in node if isinstance(e, Mapping)]
                if part not in names:
                    return [SchemaProblem(path, unknown_message("entry", part, f" in {where}",
                                                         [str(n) for n in names if n is not None]))]
                index = names.index(part)
            if index >= len(node):
                return [SchemaProblem(path, f"index {index} is out of range: {where} has "
                                      f"{len(node)} entries")]
            if last:
                node[index] = value
                return []
            node = node[index]
        else:
            return [SchemaProblem(path, f"{'.'.join(walked)} is a value, not a table or a list")]
        schema = sub
        walked.append(part)
    return []
