"""Scene files: the one door for user input, where every field is validated.

A scene is a TOML file naming a robot (URDF), its base, a state, contact points against fixed lines
and the control inputs (the format: docs/scenes.md and docs/scene-reference.md).
:func:`load_scene` reads it, builds the robot model and returns a :class:`Scene`, or raises
:class:`~frcontrol.errors.SceneError` naming the file, the field and what is wrong.

A contact whose gap at the scene's state exceeds :data:`GAP_TOLERANCE` is *inactive*: it is kept in
``Scene.contacts`` (and reported) but not in ``Scene.active_contacts``, so the contact layers model
only what the scene needs. A contact penetrating deeper than the tolerance is an error.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property, lru_cache
from importlib import resources
from pathlib import Path
from typing import Any, cast

import numpy as np

from .drives import Drive, DrivenJoints, read_drives
from .errors import (
    CoordinateNotFound,
    FrameNotFound,
    FrcontrolError,
    InputError,
    RobotModelError,
    SceneError,
    reason_from_exception,
)
from .model import ContactPoint, PlanarRobot, RobotState
from .plane import EXAMPLE_ROBOT_DATA_PREFIX, PLANES, planar_urdf
from .scene_schema import (
    MAX_NUMBER,
    SCENE_SCHEMA,
    SchemaProblem,
    beyond_float,
    document_problems,
    nearest,
    schema_problems,
    unknown_message,
)
from .scene_tables import DisturbanceTable, ModelOptions, TaskTable, read_tables
from .springs import read_joint_terms
from .urdf import RobotOutline, robot_outline

GAP_TOLERANCE = 1e-6
"""[m] A contact with gap <= this is active (touching); a gap < -this is a penetration error."""

INPUT_LIMIT_SLACK = 1e-7
"""[N, N m or V] How far an input may lie outside its limits and still be taken as given: the
round-off of a value computed from the limits (a vertex of a domain, a planner's rounded torque).
The one slack of :func:`input_vector`, the check of every input vector against its limits."""

DEFAULT_GRAVITY = 9.81
"""[m/s^2] Gravity along -y when the scene does not say."""

SCENE_TEXT_CACHE_SIZE = 64
"""How many scene files' parsed TOML (by their text) are kept: a sweep reloads one scene per point."""



@dataclass(frozen=True)
class Contact:
    """A contact of a scene, as loaded, with its situation at the scene's state.

    Attributes:
        point: the contact point's geometry (link, point, surface, mu).
        gap: [m] the gap at the scene's state.
        active: whether the contact touches at the scene's state (|gap| <= tolerance).
    """

    point: ContactPoint
    gap: float
    active: bool

    @property
    def name(self) -> str:
        """The contact's name."""
        return self.point.name

    @property
    def mu(self) -> float:
        """Coulomb coefficient [-]."""
        return self.point.mu


@dataclass(frozen=True)
class Inputs:
    """Control inputs u: generalized forces on named coordinates, with optional box limits.

    A coordinate driven by a DC motor (``[model.drives.JOINT]``) takes a voltage [V]; its column
    of ``S^T`` is the drive's gain ``eta N C_M / R`` [N m/V] (:mod:`frcontrol.drives`).

    Attributes:
        coordinates: the coordinates u acts on, in order.
        indices: their indices in the minimal coordinates.
        lower: lower limits [N, N m or V] (``-inf`` where absent).
        upper: upper limits [N, N m or V] (``+inf`` where absent).
        gains: generalized force per unit of each input (1 for a force or torque; [N m/V] for a
            voltage); None: all 1.
        units: each input's unit (``"N"``, ``"N m"``, ``"V"``); empty: not known.
    """

    coordinates: tuple[str, ...]
    indices: tuple[int, ...]
    lower: np.ndarray
    upper: np.ndarray
    gains: tuple[float, ...] | None = None
    units: tuple[str, ...] = ()

    @property
    def count(self) -> int:
        """Number of inputs m."""
        return len(self.coordinates)

    def selection_transpose(self, n: int) -> np.ndarray:
        """S^T (n x m): maps inputs to generalized forces (a shared, read-only array)."""
        return _selection_transpose(self.indices, n, self.gains)

    def unit_map(self) -> dict[str, str]:
        """Each input's unit, by name (``{"hip_rear": "V"}``)."""
        return dict(zip(self.coordinates, self.units, strict=True)) if self.units else {}


@lru_cache(maxsize=256)
def _selection_transpose(indices: tuple[int, ...], n: int, gains: tuple[float, ...] | None = None
                         ) -> np.ndarray:
    st = np.zeros((n, len(indices)))
    st[list(indices), np.arange(len(indices))] = 1.0 if gains is None else gains
    st.setflags(write=False)
    return st


@dataclass(frozen=True, eq=False)
class Scene:
    """A validated scene: robot model, state, contacts and inputs.

    Attributes:
        path: the scene file.
        name: a human-readable name.
        robot: the robot model (owns the Pinocchio model and data).
        q: the state's minimal configuration [m, rad].
        v: the state's minimal velocity [m/s, rad/s].
        contacts: every contact of the file, in file order.
        inputs: the control inputs.
        gap_tolerance: [m] the activity tolerance used.
        raw: the parsed TOML, as read (after ``--set`` overrides).
        model: the ``[model]`` table (defaults when absent).
        task: the ``[task]`` table (empty when absent).
        disturbances: the ``[[disturbances]]`` tables (none when absent).
        drives: the ``[model.drives]`` tables, by joint (none when absent).
    """

    path: Path
    name: str
    robot: PlanarRobot
    q: np.ndarray
    v: np.ndarray
    contacts: tuple[Contact, ...]
    inputs: Inputs
    gap_tolerance: float = GAP_TOLERANCE
    raw: Mapping[str, Any] = field(default_factory=dict)
    model: ModelOptions = field(default_factory=ModelOptions)
    task: TaskTable = field(default_factory=TaskTable)
    disturbances: tuple[DisturbanceTable, ...] = ()
    drives: Mapping[str, Drive] = field(default_factory=dict)

    @property
    def coordinate_names(self) -> tuple[str, ...]:
        """Names of the minimal coordinates."""
        return self.robot.coordinate_names

    @property
    def active_contacts(self) -> tuple[Contact, ...]:
        """The contacts that touch at the scene's state, in file order."""
        return tuple(c for c in self.contacts if c.active)

    @cached_property
    def active_indices(self) -> tuple[int, ...]:
        """Indices (into ``contacts``) of the active contacts (found once: a scene is frozen)."""
        return tuple(i for i, c in enumerate(self.contacts) if c.active)

    def at(self, q: np.ndarray, v: np.ndarray | None = None) -> Scene:
        """The same scene at another state: gaps and activity recomputed (e.g. along a simulation).

        A contact is active when its gap is at most the tolerance (a penetration, which a time
        stepper may leave, counts as touching rather than as an error here).

        Raises:
            InputError: q or v has the wrong length or a non-finite entry.
        """
        q, v = self.robot.check_state(q, v)
        points = self.robot.contact_points_in_world(q)
        contacts = []
        for contact, point in zip(self.contacts, points, strict=True):
            p = contact.point
            gap = float(p.normal_in_world @ (point - p.surface_point_in_world))
            contacts.append(Contact(p, gap, gap <= self.gap_tolerance))
        return replace(self, q=q, v=v, contacts=tuple(contacts))

    def state(self, q: np.ndarray | None = None, v: np.ndarray | None = None) -> RobotState:
        """The robot state with the active contacts' kinematics (default: the scene's state)."""
        return self.robot.state(
            self.q if q is None else q, self.v if v is None else v, self.active_indices
        )


@lru_cache(maxsize=1)
def shipped_robots_dir() -> Path:
    """The folder of robots and scenes shipped with frcontrol (found once: the package stays put)."""
    return Path(str(resources.files("frcontrol.robots")))


def shipped_scene_names() -> list[str]:
    """The names of the scenes shipped with frcontrol (``rhex_flip``, ...), sorted."""
    return sorted(p.stem for p in (shipped_robots_dir() / "scenes").glob("*.toml"))


def resolve_scene_path(name_or_path: str | Path) -> Path:
    """A scene file by path, or by the name of a shipped scene (``rhex_flip``, ``rhex_flip.toml``).

    Raises:
        SceneError: neither a file of that path nor a shipped scene of that name exists; the
            message lists the shipped scenes with the nearest name first.
    """
    path = Path(name_or_path)
    if path.exists():
        return path
    scenes = shipped_robots_dir() / "scenes"
    if len(path.parts) == 1:
        for candidate in (scenes / path.name, scenes / f"{path.name}.toml"):
            if candidate.exists():
                return candidate
    names = shipped_scene_names()
    guess = nearest(path.stem, names)
    hint = f"did you mean {guess!r}? " if guess else ""
    raise SceneError(str(path), "", f"no such file, and no shipped scene of that name; {hint}"
                     f"shipped scenes: {', '.join(names)}")


class _Reader:
    """Typed access to a parsed TOML table, raising SceneError with the field's dotted name."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, field_name: str, reason: str) -> SceneError:
        return SceneError(str(self.path), field_name, reason)

    def number(self, value: Any, field_name: str) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(field_name, f"expected a number, got {value!r}")
        if isinstance(value, int) and not -MAX_NUMBER <= value <= MAX_NUMBER:
            raise self.fail(field_name, beyond_float(value))
        x = float(value)
        if not math.isfinite(x):
            raise self.fail(field_name, f"expected a finite number, got {value!r}")
        return x

    def vector(self, value: Any, field_name: str, length: int | None = None) -> np.ndarray:
        if not isinstance(value, list):
            raise self.fail(field_name, f"expected a list of numbers, got {value!r}")
        arr = np.array([self.number(x, f"{field_name}[{i}]") for i, x in enumerate(value)], dtype=float)
        if length is not None and arr.size != length:
            raise self.fail(field_name, f"expected {length} numbers, got {arr.size}")
        return arr

    def string(self, value: Any, field_name: str) -> str:
        if not isinstance(value, str) or not value:
            raise self.fail(field_name, f"expected a non-empty string, got {value!r}")
        return value


def _resolve_robot(reader: _Reader, scene_path: Path, robot: str) -> Path:
    if robot.startswith(EXAMPLE_ROBOT_DATA_PREFIX):
        return Path(robot)  # found in mapping it onto its plane (_mapped_robot)
    candidate = (scene_path.parent / robot).resolve()
    if candidate.is_file():
        return candidate
    shipped = shipped_robots_dir() / robot
    if shipped.is_file():
        return shipped
    raise reader.fail(
        "robot", f"no URDF {robot!r} next to the scene nor among the shipped robots "
        f"({', '.join(sorted(p.name for p in shipped_robots_dir().glob('*.urdf')))})"
    )


def _mapped_robot(reader: _Reader, raw: Mapping[str, Any], robot_file: Path) -> Path:
    """``robot_file``, or its planar URDF in the scene's ``plane`` (:func:`frcontrol.plane.planar_urdf`).

    ``robot_file`` may be the reference ``example-robot-data:NAME``, found as it is mapped.

    Raises:
        SceneError: ``plane_locked`` without ``plane``, a 3-D robot of example-robot-data without
            ``plane`` or unknown to it, or a plane the robot does not move in (the joint is named).
    """
    plane = raw.get("plane")
    if plane is None:
        if "plane_locked" in raw:
            raise reader.fail("plane_locked", "plane_locked welds joints of a 3-D robot before its plane "
                              "mapping: give the plane too (plane = \"xz\")")
        if str(raw.get("robot", "")).startswith(EXAMPLE_ROBOT_DATA_PREFIX):
            raise reader.fail("plane", f"missing: {raw['robot']} is a 3-D robot; give the plane it moves "
                              f"in, one of {', '.join(PLANES)} (plane = \"xz\": x forward, z up)")
        return robot_file
    try:
        return planar_urdf(robot_file, str(plane), raw.get("plane_locked", {}))
    except RobotModelError as err:
        if err.path == str(robot_file) and str(robot_file).startswith(EXAMPLE_ROBOT_DATA_PREFIX):
            raise reader.fail("robot", err.reason) from err  # no such robot in example-robot-data
        where = "plane_locked" if "cannot lock" in err.reason else "plane"
        raise reader.fail(where, f"{robot_file.name}: {err.reason}") from err


def read_scene_document(path: Path) -> dict[str, Any]:
    """The parsed TOML of a scene file, unchecked.

    Raises:
        SceneError: the file is missing, a directory, unreadable, not UTF-8 or not TOML (one line,
            no errno dump).
    """
    reader = _Reader(path)
    if path.is_dir():
        raise reader.fail("", "cannot read: it is a directory, not a scene file")
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError as err:
        raise reader.fail("", "no such file") from err
    except PermissionError as err:
        raise reader.fail("", "cannot read the file: permission denied") from err
    except UnicodeDecodeError as err:
        raise reader.fail("", f"cannot read the file: not UTF-8 text (byte {err.start})") from err
    except OSError as err:
        raise reader.fail("", f"cannot read the file: {reason_from_exception(err)}") from err
    return scene_toml(text, str(path))


def scene_toml(text: str, source: str) -> dict[str, Any]:
    """The parsed TOML of a scene's text, unchecked (``source`` names the scene in messages).

    Raises:
        SceneError: not TOML, or nested too deeply to parse (any depth is an error, not a crash).
    """
    try:
        return _fresh_copy(_parsed_toml(text))
    except tomllib.TOMLDecodeError as err:
        raise SceneError(source, "", f"malformed TOML: {err}") from err
    except RecursionError as err:
        raise SceneError(source, "", "the TOML nests too deeply to be a scene") from err


@lru_cache(maxsize=SCENE_TEXT_CACHE_SIZE)
def _parsed_toml(text: str) -> dict[str, Any]:
    """The TOML document ``text``, parsed once per content (never handed out: see :func:`_fresh_copy`)."""
    return tomllib.loads(text)


def _fresh_copy(value: Any) -> Any:
    """A copy of a parsed TOML value with new tables and arrays (the loader edits them in place).

    The leaves (str, int, float, bool, dates and times) are immutable and shared.
    """
    if isinstance(value, dict):
        return {key: _fresh_copy(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_fresh_copy(item) for item in value]
    return value


def load_scene(
    path: str | Path,
    *,
    gap_tolerance: float | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> Scene:
    """Read and validate a scene file.

    Args:
        path: the TOML file, or the name of a shipped scene.
        gap_tolerance: [m] overrides the scene's ``gap_tolerance`` (default :data:`GAP_TOLERANCE`).
        overrides: values to set before validation, by dotted path (``{"contacts.tip.mu": 0.5,
            "gravity": 3.7}``; see :func:`~frcontrol.scene_schema.apply_override`), checked exactly
            like the file's own values. ``state.q.NAME`` and ``state.v.NAME`` set one coordinate
            by name (``state.q.theta``); a contact without ``surface_point`` then follows its
            contact point to that state (gap 0).

    Returns:
        The validated scene.

    Raises:
        SceneError: the file is missing or unreadable, the TOML or URDF is malformed, or a field is
            wrong: an unknown key in any table (with the nearest valid key), a wrong type, an
            out-of-range value (:data:`~frcontrol.scene_schema.SCENE_SCHEMA`), an unknown link,
            joint, coordinate or contact (also in ``[model]``, ``[task]`` and
            ``[[disturbances]]``), a wrong length, NaN, a zero normal, lower > upper, a
            penetrating contact... The message names the file and the field.
    """
    scene_path = resolve_scene_path(path)
    reader = _Reader(scene_path)
    raw = read_scene_document(scene_path)
    robot, coordinates = _checked_document(reader, raw, overrides)
    robot_file = _resolve_robot(reader, scene_path, robot)
    return _scene_from_checked(reader, scene_path, raw, robot_file, gap_tolerance, coordinates)


def _checked_document(reader: _Reader, raw: dict[str, Any], overrides: Mapping[str, Any] | None
                      ) -> tuple[str, dict[str, Any]]:
    """Apply ``overrides`` to a scene document and check it against the schema.

    Returns:
        The robot's name, and the overrides of single coordinates (``state.q.NAME``), which are
        applied once the robot's coordinates are known (:func:`_apply_coordinate_overrides`).

    Raises:
        SceneError: an override or a field is wrong (see :func:`load_scene`).
    """
    coordinate_overrides = {k: v for k, v in (overrides or {}).items() if _coordinate_path(k) is not None}
    # state.q.NAME: set once the robot's coordinates are known; the others before the schema check
    others = {k: v for k, v in (overrides or {}).items() if k not in coordinate_overrides}
    problems = document_problems(raw, others)
    if problems:
        raise reader.fail(_set_path(problems[0].field, raw, overrides or {}), problems[0].reason)
    return reader.string(raw["robot"], "robot"), coordinate_overrides


def _set_path(field: str, raw: Mapping[str, Any], overrides: Mapping[str, Any]) -> str:
    """``field`` as the override that set it names it (``contacts.tip.mu`` for ``contacts[0].mu``).

    A field no override set keeps its own name.
    """
    for key in overrides:
        parts = key.split(".")
        entries = raw.get(parts[0]) if len(parts) > 1 else None
        if isinstance(entries, list):  # an entry of [[contacts]] or [[disturbances]] by its name
            named = [i for i, e in enumerate(entries) if isinstance(e, Mapping) and e.get("name") == parts[1]]
            index = named[0] if named else None
            if index is not None:
                parts = [f"{parts[0]}[{index}]", *parts[2:]]
        if ".".join(parts) == field or field.startswith(".".join(parts) + "["):
            return key
    return field


def scene_from_document(
    document: Mapping[str, Any],
    *,
    source: str = "scene",
    robot_files: Mapping[str, Path] | None = None,
    gap_tolerance: float | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> Scene:
    """Validate a scene given as a document (the parsed TOML, or its JSON form), not as a file.

    Nothing is read from a path named by the document: its ``robot`` must be a bare file name,
    either a key of ``robot_files`` (URDF files the caller wrote, e.g. from text it received) or a
    robot shipped with frcontrol. This is how a scene from another program (``frc serve``) loads.

    Args:
        document: the scene's tables, as :func:`read_scene_document` returns them (copied, not changed).
        source: what error messages name in place of a file (``"scene"``, or a shipped scene's path).
        robot_files: URDF files by the bare name a scene may give as its ``robot``.
        gap_tolerance: [m] overrides the scene's ``gap_tolerance``.
        overrides: values to set before validation, by dotted path, as for :func:`load_scene`.

    Raises:
        SceneError: everything :func:`load_scene` refuses, and a ``robot`` that is a path
            (``../../etc/passwd``) or names neither a given nor a shipped URDF.
    """
    import copy

    scene_path = Path(source)
    reader = _Reader(scene_path)
    raw = copy.deepcopy(dict(document))
    robot, coordinates = _checked_document(reader, raw, overrides)
    files = dict(robot_files or {})
    shipped = sorted(p.name for p in shipped_robots_dir().glob("*.urdf"))
    if robot.startswith(EXAMPLE_ROBOT_DATA_PREFIX):
        return _scene_from_checked(reader, scene_path, raw, Path(robot), gap_tolerance, coordinates)
    if robot != Path(robot).name or robot in ("", ".", ".."):
        raise reader.fail("robot", f"{robot!r} is a path: a scene loaded from a document names its robot "
                          f"by the file name of a shipped URDF ({', '.join(shipped)}) or of a URDF sent "
                          "with it")
    if robot in files:
        robot_file = files[robot]
    elif robot in shipped:
        robot_file = shipped_robots_dir() / robot
    else:
        given = f"the URDFs sent with it ({', '.join(sorted(files))}) nor " if files else ""
        raise reader.fail("robot", f"no URDF {robot!r} among {given}the shipped robots "
                          f"({', '.join(shipped)})")
    return _scene_from_checked(reader, scene_path, raw, robot_file, gap_tolerance, coordinates)


def _scene_from_checked(reader: _Reader, scene_path: Path, raw: dict[str, Any], robot_file: Path,
                        gap_tolerance: float | None, coordinates: Mapping[str, Any]) -> Scene:
    """The scene of a document that passed the schema, on the URDF ``robot_file``.

    ``coordinates``: the single-coordinate overrides (``state.q.NAME``) to apply to its state.
    """
    name = reader.string(raw.get("name", scene_path.stem), "name")
    base, gravity, tol = _read_model_settings(reader, raw, gap_tolerance)
    robot_file = _mapped_robot(reader, raw, robot_file)
    try:
        bare = robot_outline(robot_file, base)
    except RobotModelError as err:
        raise SceneError(str(scene_path), "robot", f"{robot_file.name}: {err.reason}") from err
    # The second step: what the schema cannot say, against the robot's names (here, in this order).
    _apply_coordinate_overrides(reader, raw, bare, coordinates)
    q, v = _read_state(reader, raw, bare)
    locked, q, v = _read_locked_joints(reader, raw, bare, q, v)
    outline = _without(bare, locked)
    coords = outline.coordinate_names
    points = _read_contact_points(reader, raw, outline)
    names = {"link": outline.link_names, "contact": [p.name for p in points], "coordinate": coords}
    inputs = _read_inputs(reader, raw.get("inputs"), coords, locked)
    model_table: Mapping[str, Any] = raw["model"] if isinstance(raw.get("model"), dict) else {}
    driven = read_drives(str(scene_path), model_table.get("drives"), outline.joint_names, tuple(locked))
    inputs = _driven_inputs(reader, outline, inputs, driven)
    terms = read_joint_terms(str(scene_path), model_table.get("springs"), coords, outline.joint_names,
                             inputs.coordinates, tuple(locked), driven)
    references = reference_problems(raw, names)
    if references:
        raise reader.fail(references[0].field, references[0].reason)
    model, task, disturbances = read_tables(str(scene_path), raw, names["contact"], outline.link_names)
    # The robot, built once; surfaces not given pass through the contact point at the state (gap 0).
    robot = PlanarRobot(robot_file, base=base, gravity=gravity, contacts=points, locked=locked, terms=terms,
                        surfaces_through=q)
    world = cast(np.ndarray, robot.placed_points_in_world)  # set: the robot was placed at q
    contacts = _contacts_at_state(reader, list(robot.contacts), world, tol)
    return Scene(scene_path, name, robot, q, v, tuple(contacts), inputs, tol, raw, model=model, task=task,
                 disturbances=disturbances, drives=driven.drives)


def _without(outline: RobotOutline, locked: Mapping[str, float]) -> RobotOutline:
    """``outline`` with the ``locked`` joints welded (no coordinate)."""
    if not locked:
        return outline
    keep = [i for i, name in enumerate(outline.coordinate_names) if name not in locked]
    return replace(outline, joint_names=tuple(j for j in outline.joint_names if j not in locked),
                   coordinate_names=tuple(outline.coordinate_names[i] for i in keep),
                   force_units=tuple(outline.force_units[i] for i in keep))


def _references(doc: Any, schema: Mapping[str, Any], path: str, names: Mapping[str, Sequence[str]],
                out: list[SchemaProblem]) -> None:
    refers = schema.get("x-refers")
    if isinstance(refers, str) and refers in names:
        values = doc if isinstance(doc, list) else [doc]
        for i, value in enumerate(values):
            if isinstance(value, str) and value not in names[refers]:
                where = f"{path}[{i}]" if isinstance(doc, list) else path
                out.append(SchemaProblem(where, unknown_message(refers, value, "", list(names[refers]))))
        return
    if schema.get("type") == "array" and isinstance(doc, list) and "items" in schema:
        for i, item in enumerate(doc):
            _references(item, schema["items"], f"{path}[{i}]", names, out)
    elif schema.get("type") == "object" and isinstance(doc, Mapping):
        keys_refer = schema.get("x-refers-keys")
        properties = schema.get("properties", {})
        extra = schema.get("additionalProperties")
        for key, value in doc.items():
            where = f"{path}.{key}" if path else str(key)
            if isinstance(keys_refer, str) and keys_refer in names and key not in names[keys_refer]:
                valid = list(names[keys_refer])
                out.append(SchemaProblem(where, unknown_message(keys_refer, str(key), "", valid)))
                continue
            sub = properties.get(key, extra if isinstance(extra, Mapping) else None)
            if sub is not None:
                _references(value, sub, where, names, out)


def reference_problems(doc: Any, names: Mapping[str, Sequence[str]]) -> list[SchemaProblem]:
    """Names in ``doc`` that refer to no ``link``, ``joint``, ``coordinate`` or ``contact``.

    Args:
        doc: a parsed scene that passed :func:`~frcontrol.scene_schema.schema_problems`.
        names: the valid names of each kind (kinds absent from it are not checked).
    """
    out: list[SchemaProblem] = []
    _references(doc, SCENE_SCHEMA, "", names, out)
    return out


def _driven_inputs(reader: _Reader, outline: RobotOutline, inputs: Inputs, driven: DrivenJoints) -> Inputs:
    """The inputs with their units and gains.

    A driven joint's input is a voltage: its limits (default: the drive's ``voltage_limit``) must
    lie within ``[-voltage_limit, voltage_limit]``.

    Raises:
        SceneError: a driven joint that is not an input, or a voltage limit beyond the drive's.
    """
    units = tuple(outline.force_units[i] for i in inputs.indices)
    if not driven.drives:
        return replace(inputs, units=units)
    lower, upper = inputs.lower.copy(), inputs.upper.copy()
    gains, unit_list = [1.0] * inputs.count, list(units)
    for joint, drive in driven.drives.items():
        if joint not in inputs.coordinates:
            raise reader.fail(f"model.drives.{joint}", f"the driven joint {joint!r} is not an input: add "
                              "it to [inputs] coordinates (its input is the motor's voltage [V])")
        j = inputs.coordinates.index(joint)
        limit = drive.voltage_limit
        lower[j] = max(lower[j], -limit) if math.isinf(lower[j]) else lower[j]
        upper[j] = min(upper[j], limit) if math.isinf(upper[j]) else upper[j]
        for label, value in (("lower", lower[j]), ("upper", upper[j])):
            if abs(value) > limit:
                raise reader.fail(f"inputs.{label}[{j}]", f"{value:g} V for the driven joint {joint!r} is "
                                  f"beyond its drive's voltage_limit {limit:g} V")
        gains[j], unit_list[j] = driven.gains[joint], "V"
    return replace(inputs, lower=lower, upper=upper, gains=tuple(gains), units=tuple(unit_list))


def _read_model_settings(reader: _Reader, raw: Mapping[str, Any], gap_tolerance: float | None
                         ) -> tuple[str, float, float]:
    """(base, gravity [m/s^2], gap tolerance [m]) of a scene document."""
    base = raw.get("base", "planar")
    if base not in ("planar", "fixed"):
        raise reader.fail("base", f"expected 'planar' or 'fixed', got {base!r}")
    gravity = reader.number(raw.get("gravity", DEFAULT_GRAVITY), "gravity")
    if gravity < 0:
        raise reader.fail("gravity", f"expected >= 0 [m/s^2] (it acts along -y), got {gravity}")
    tol = reader.number(raw.get("gap_tolerance", GAP_TOLERANCE), "gap_tolerance")
    if gap_tolerance is not None:
        tol = float(gap_tolerance)
    if tol <= 0:
        raise reader.fail("gap_tolerance", f"expected > 0 [m], got {tol}")
    return str(base), gravity, tol


def _coordinate_path(path: str) -> tuple[str, str] | None:
    """``("q", "theta")`` for ``state.q.theta`` (one coordinate by name), else None."""
    parts = path.split(".")
    if len(parts) == 3 and parts[0] == "state" and parts[1] in ("q", "v") and not parts[2].isdigit():
        return parts[1], parts[2]
    return None


def _apply_coordinate_overrides(reader: _Reader, raw: dict[str, Any], bare: RobotOutline,
                                overrides: Mapping[str, Any]) -> None:
    """Set single coordinates of ``[state]`` by name (``state.q.theta``, ``state.v.x``), in place.

    The names are the robot's coordinates before locking (``q`` and ``v`` list locked joints too);
    an absent ``v`` starts from zeros.
    """
    coords = bare.coordinate_names
    for path, value in overrides.items():
        vector, name = _coordinate_path(path) or ("", "")
        if name not in coords:
            guess = nearest(name, coords)
            hint = f"did you mean {guess!r}? " if guess else ""
            raise reader.fail(path, f"unknown coordinate {name!r}; {hint}the coordinates are: "
                              f"{', '.join(coords)}")
        state = raw.setdefault("state", {})
        if not isinstance(state, dict):
            raise reader.fail("state", "expected a table [state]")
        if vector == "v" and "v" not in state:
            state["v"] = [0.0] * len(coords)
        values = state.get(vector)
        if not isinstance(values, list) or len(values) != len(coords):
            raise reader.fail(f"state.{vector}", f"expected {len(coords)} numbers ({', '.join(coords)}) "
                              f"before setting {path}")
        values = list(values)  # a copy: the list may be a caller's override value
        values[coords.index(name)] = reader.number(value, path)
        state[vector] = values


def _read_state(reader: _Reader, raw: Mapping[str, Any], bare: RobotOutline) -> tuple[np.ndarray, np.ndarray]:
    """The ``[state]``'s q and v (v defaults to zeros), one entry per coordinate of ``bare``."""
    coords = bare.coordinate_names
    n = len(coords)
    state = raw.get("state")
    if not isinstance(state, dict) or "q" not in state:
        raise reader.fail("state.q", f"missing: {n} numbers ({', '.join(coords)})")
    q = reader.vector(state["q"], "state.q")
    if q.size != n:
        raise reader.fail("state.q", f"expected {n} numbers ({', '.join(coords)}), got {q.size}")
    v = reader.vector(state["v"], "state.v") if "v" in state else np.zeros(n)
    if v.size != n:
        raise reader.fail("state.v", f"expected {n} numbers ({', '.join(coords)}), got {v.size}")
    return q, v


def _read_locked_joints(reader: _Reader, raw: Mapping[str, Any], bare: RobotOutline, q: np.ndarray,
                        v: np.ndarray) -> tuple[dict[str, float], np.ndarray, np.ndarray]:
    """Locked joints, held at their state value (welded into the model: no coordinate).

    Returns:
        (joint -> its value, q and v without the locked coordinates).
    """
    coords = bare.coordinate_names
    locked_names = raw.get("locked_joints", [])
    if not isinstance(locked_names, list) or not all(isinstance(x, str) for x in locked_names):
        raise reader.fail("locked_joints", f"expected a list of joint names from {list(bare.joint_names)}")
    locked: dict[str, float] = {}
    for i, joint in enumerate(locked_names):
        if joint not in bare.joint_names:
            raise reader.fail(f"locked_joints[{i}]", f"unknown joint {joint!r}; the joints are: "
                              f"{', '.join(bare.joint_names)}")
        j = coords.index(joint)
        if v[j] != 0.0:
            raise reader.fail("state.v", f"locked joint {joint!r} must have zero velocity, got {v[j]}")
        locked[joint] = float(q[j])
    if not locked:
        return locked, q, v
    keep = [j for j, name in enumerate(coords) if name not in locked]
    return locked, q[keep], v[keep]


def _read_contact_points(reader: _Reader, raw: Mapping[str, Any], bare: RobotOutline) -> list[ContactPoint]:
    """The ``[[contacts]]`` as contact points.

    A contact without ``surface_point`` has NaN for it: the robot places its surface through the
    contact point at the state (``surfaces_through``).
    """
    contact_tables = raw.get("contacts", [])
    if not isinstance(contact_tables, list):
        raise reader.fail("contacts", "expected an array of tables [[contacts]]")
    points: list[ContactPoint] = []
    seen: set[str] = set()
    for i, table in enumerate(contact_tables):
        where = f"contacts[{i}]"
        if not isinstance(table, dict):
            raise reader.fail(where, "expected a table")
        cname = reader.string(table.get("name", f"c{i}"), f"{where}.name")
        if cname in seen:
            raise reader.fail(f"{where}.name", f"duplicate contact name {cname!r}")
        seen.add(cname)
        for key in ("link", "point", "normal", "mu"):
            if key not in table:
                raise reader.fail(f"{where}.{key}", "missing")
        link = reader.string(table["link"], f"{where}.link")
        if link not in bare.link_names:
            raise reader.fail(f"{where}.link", str(FrameNotFound(link, bare.link_names)))
        point = reader.vector(table["point"], f"{where}.point", 2)
        normal = reader.vector(table["normal"], f"{where}.normal", 2)
        norm = float(np.linalg.norm(normal))
        if norm < 1e-12:
            raise reader.fail(f"{where}.normal", f"the normal must be non-zero, got {normal.tolist()}")
        mu = reader.number(table["mu"], f"{where}.mu")
        if mu < 0:
            raise reader.fail(f"{where}.mu", f"friction coefficient must be >= 0, got {mu}")
        surface = (
            reader.vector(table["surface_point"], f"{where}.surface_point", 2)
            if "surface_point" in table else np.full(2, np.nan)
        )
        points.append(ContactPoint(cname, link, point, normal / norm, surface, mu))
    return points


def _contacts_at_state(reader: _Reader, points: list[ContactPoint], world: np.ndarray, tol: float
                       ) -> list[Contact]:
    """Each contact with its gap at the state and whether it is active (gap within ``tol``).

    Raises:
        SceneError: a contact penetrates its surface by more than ``tol``.
    """
    contacts = []
    gaps = np.einsum("kj,kj->k", np.array([p.normal_in_world for p in points]).reshape(-1, 2),
                     world - np.array([p.surface_point_in_world for p in points]).reshape(-1, 2))
    for i, (p, gap) in enumerate(zip(points, gaps, strict=True)):
        if gap < -tol:
            raise reader.fail(
                f"contacts[{i}]", f"contact {p.name!r} penetrates its surface by {-gap:.3g} m "
                f"(tolerance {tol:.3g} m): fix the state or the surface_point"
            )
        contacts.append(Contact(p, float(gap), bool(gap <= tol)))
    return contacts


def scene_problems(path: str | Path) -> list[SchemaProblem]:
    """Every problem of a scene file, for ``frc validate``: an empty list when it loads.

    Every schema problem (unknown keys, types, ranges) is listed; when there is none, the scene is
    loaded, and the first problem found against the robot (a link, a length, a penetration) is
    listed.
    """
    try:
        scene_path = resolve_scene_path(path)
        problems = schema_problems(read_scene_document(scene_path))
        if problems:
            return problems
        load_scene(scene_path)
    except SceneError as err:
        return [SchemaProblem(err.field, err.reason)]
    return []


def _read_inputs(reader: _Reader, table: Any, coords: Sequence[str], locked: Mapping[str, float]) -> Inputs:
    if table is None:
        return Inputs((), (), np.zeros(0), np.zeros(0))
    if not isinstance(table, dict):
        raise reader.fail("inputs", "expected a table [inputs]")
    names = table.get("coordinates")
    if not isinstance(names, list) or not all(isinstance(s, str) for s in names):
        raise reader.fail("inputs.coordinates", f"expected a list of coordinate names from {list(coords)}")
    indices = []
    for i, s in enumerate(names):
        if s in locked:
            raise reader.fail(f"inputs.coordinates[{i}]", f"joint {s!r} is locked (locked_joints): "
                              "it cannot take an input")
        if s not in coords:
            raise reader.fail(f"inputs.coordinates[{i}]",
                              f"unknown coordinate {s!r}; the coordinates are: {', '.join(coords)}")
        indices.append(coords.index(s))
    if len(set(names)) != len(names):
        raise reader.fail("inputs.coordinates", "a coordinate is listed twice")
    m = len(names)
    lower = reader.vector(table["lower"], "inputs.lower", m) if "lower" in table else np.full(m, -np.inf)
    upper = reader.vector(table["upper"], "inputs.upper", m) if "upper" in table else np.full(m, np.inf)
    bad = np.nonzero(lower > upper)[0]
    if bad.size:
        j = int(bad[0])
        raise reader.fail(f"inputs.lower[{j}]", f"lower limit {lower[j]} exceeds upper limit {upper[j]} "
                          f"for {names[j]!r}")
    return Inputs(tuple(names), tuple(indices), lower, upper)


InputValues = Mapping[str, float] | Sequence[float] | np.ndarray | None
"""Inputs as ``{name: value}`` (others 0), the full input vector, or None (all 0)."""


def input_vector(names: Sequence[str], lower: np.ndarray, upper: np.ndarray, values: InputValues
                 ) -> np.ndarray:
    """The input vector u of ``values``, checked: every input known, finite and within its limits.

    The one check of inputs against their limits: an input may lie :data:`INPUT_LIMIT_SLACK`
    outside ``[lower, upper]`` and is taken as given.

    Args:
        names: the inputs, in order (a scene's ``inputs.coordinates``).
        lower: [N, N m or V] their lower limits.
        upper: [N, N m or V] their upper limits.
        values: ``{name: value}`` (names not given are 0), the full vector, or None (all 0).

    Raises:
        CoordinateNotFound: a name is not one of the inputs (the nearest is named).
        InputError: a vector of the wrong length, a NaN or infinite entry, or a value outside its
            limits by more than :data:`INPUT_LIMIT_SLACK`.
    """
    if values is None or isinstance(values, Mapping):
        u = np.zeros(len(names))
        for name, value in (values or {}).items():
            if name not in names:
                raise CoordinateNotFound(name, tuple(names))
            u[list(names).index(name)] = float(value)
    else:
        u = np.ascontiguousarray(np.asarray(values, dtype=float).reshape(-1))  # the kernel reads it whole
        if u.shape != (len(names),):
            raise InputError(f"the input vector has {u.size} entries; the scene has {len(names)} inputs "
                             f"({', '.join(names)})")
    entries = u.tolist()  # a few entries: Python floats are quicker than NumPy's per-call overhead
    low, high = lower.tolist(), upper.tolist()
    for j, value in enumerate(entries):
        if not math.isfinite(value):
            raise InputError(f"input {names[j]!r} must be finite, got {value!r}")
        if value < low[j] - INPUT_LIMIT_SLACK or value > high[j] + INPUT_LIMIT_SLACK:
            raise InputError(f"input {names[j]!r} = {value:g} is outside its limits "
                             f"[{low[j]:g}, {high[j]:g}]")
    return u


def parse_input_assignments(scene: Scene, assignments: Mapping[str, float]) -> np.ndarray:
    """The input vector u for named values of the scene's inputs; inputs not named are 0.

    Raises:
        CoordinateNotFound: a name is not one of the scene's inputs.
        InputError: a value is NaN or infinite, or outside the input's limits (:func:`input_vector`).
    """
    inputs = scene.inputs
    return input_vector(inputs.coordinates, inputs.lower, inputs.upper, assignments)


__all__ = [
    "GAP_TOLERANCE",
    "INPUT_LIMIT_SLACK",
    "Contact",
    "FrcontrolError",
    "InputValues",
    "Inputs",
    "Scene",
    "input_vector",
    "load_scene",
    "parse_input_assignments",
    "read_scene_document",
    "reference_problems",
    "resolve_scene_path",
    "scene_toml",
    "scene_from_document",
    "scene_problems",
    "shipped_robots_dir",
    "shipped_scene_names",
]
