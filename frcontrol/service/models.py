"""The service's request and response models (pydantic): what each endpoint accepts, for OpenAPI.

Every request is strict: an unknown key, a wrong type (a string or a boolean where a number is
asked: no conversion), a number that is not finite (NaN, Infinity, anywhere in the body) or JSON
nested deeper than :data:`MAX_JSON_DEPTH` is a 422 naming the field. A command's options are its long
names with underscores (``--max-time`` is ``"max_time"``), with the command's defaults and ranges.
Responses are the commands' ``--json`` documents, built by the library's ``to_dict()``:
``/solutions``' is typed here in full (:class:`SolutionsAnswer`; the tests hold every answer to it),
the other commands' are JSON objects whose shape each command's ``to_dict()`` documents.
"""

from __future__ import annotations

import math
import re
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, field_validator, model_validator

from frcontrol.atlas.grid import MAX_ATLAS_POINTS
from frcontrol.planning import (
    DEFAULT_CLIMB_DURATION,
    DEFAULT_CLIMB_MARGIN,
    DEFAULT_FLIP_MARGIN,
)

MAX_URDF_NAME = 100
"""Longest file name of a URDF sent with a scene."""

URDF_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]*\.urdf")
"""A URDF file name sent with a scene: ASCII letters, digits, ``_ . + -``, ending in ``.urdf``."""

MAX_JSON_DEPTH = 32
"""The deepest nesting of arrays and objects in a request body (a scene's tables need 4)."""



def too_deep(value: Any, limit: int = MAX_JSON_DEPTH) -> tuple[str | int, ...] | None:
    """The path to the first array or object nested deeper than ``limit`` in a JSON value, or None.

    Walked without recursion, so that any depth is measured.
    """
    stack: list[tuple[Any, tuple[str | int, ...]]] = [(value, ())]
    while stack:
        item, where = stack.pop()
        if not isinstance(item, (dict, list)):
            continue
        if len(where) >= limit:
            return where
        children = item.items() if isinstance(item, dict) else enumerate(item)
        stack.extend((child, (*where, key)) for key, child in children)
    return None


def first_non_finite(value: Any, where: tuple[str | int, ...] = ()) -> tuple[str | int, ...] | None:
    """The path of the first float that is NaN or infinite in a JSON value, or None."""
    if isinstance(value, float) and not math.isfinite(value):
        return where
    if isinstance(value, dict):
        items: Any = value.items()
    elif isinstance(value, list):
        items = enumerate(value)
    else:
        return None
    for key, item in items:
        found = first_non_finite(item, (*where, key))
        if found is not None:
            return found
    return None


class Strict(BaseModel):
    """A request part: unknown keys refused, every number finite."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)

    @model_validator(mode="before")
    @classmethod
    def _finite(cls, data: Any) -> Any:
        found = first_non_finite(data)
        if found is not None:
            where = ".".join(str(k) for k in found)
            raise ValueError(f"{where}: expected a finite number (NaN and Infinity are not accepted)")
        return data


class SceneContent(Strict):
    """A scene sent as content: its TOML text or its JSON form, and URDFs it may name as its robot."""

    toml: str | None = Field(None, description="The scene file's TOML text.")
    json_: dict[str, Any] | None = Field(
        None, alias="json", description="The scene as JSON: the tables of the scene schema (`frc schema`).")
    robots: dict[str, str] = Field(
        default_factory=dict,
        description="URDF texts by file name (`{\"arm.urdf\": \"<robot ...>\"}`) that the scene may name "
                    "as its `robot`; otherwise the robot is a shipped URDF (`GET /robots`). Never a path.")

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, populate_by_name=True, strict=True)

    @model_validator(mode="after")
    def _one_form(self) -> SceneContent:
        if (self.toml is None) == (self.json_ is None):
            raise ValueError("give the scene as exactly one of 'toml' (its text) or 'json' (its tables)")
        return self

    @field_validator("robots")
    @classmethod
    def _urdf_names(cls, robots: dict[str, str]) -> dict[str, str]:
        for name in robots:
            if URDF_NAME.fullmatch(name) is None or len(name) > MAX_URDF_NAME:
                raise ValueError(f"robots: {name!r} is not a URDF file name (a bare name ending in .urdf, "
                                 f"of ASCII letters, digits and _.+-, at most {MAX_URDF_NAME} characters)")
        return robots


def _scene_form(value: Any) -> str:
    """Which form a request's scene takes: ``"name"`` (a string) or ``"content"`` (an object)."""
    return "name" if isinstance(value, str) else "content"


SceneField = Annotated[
    Annotated[str, Tag("name")] | Annotated[SceneContent, Tag("content")], Discriminator(_scene_form)
]
"""A request's scene: a shipped scene's name, or its content (errors name the form: ``content``)."""


class SceneRequest(Strict):
    """The fields every scene endpoint takes: the scene and its overrides."""

    scene: SceneField = Field(
        description="A shipped scene's name (`\"rod_on_table\"`, see `GET /robots`) or the scene's content.",
        examples=["rod_on_table"])
    set: dict[str, Any] = Field(
        default_factory=dict,
        description="Overrides by dotted path, as `frc --set` (`{\"contacts.tip.mu\": 0.5}`), checked "
                    "exactly like the scene's own values.")


class InputsRequest(SceneRequest):
    """A scene and named inputs (inputs not named are 0)."""

    inputs: dict[str, float] = Field(default_factory=dict,
                                     description="Input values by coordinate name [N or N m], as `--input`.")


class ShowRequest(SceneRequest):
    """`POST /show`: `frc show SCENE --json`."""


class ValidateRequest(Strict):
    """`POST /validate`: `frc validate SCENE --json`, for one scene (one with problems: a 422)."""

    scene: SceneField = Field(
        description="A shipped scene's name or the scene's content, as for every scene endpoint.",
        examples=["rod_on_table"])


class AnalyzeRequest(SceneRequest):
    """`POST /analyze`: `frc analyze SCENE [--input ...] --json`."""

    inputs: dict[str, float] | None = Field(
        None, description="Input values by name [N or N m]: with them, the answer adds `solutions`.")


class SolutionsRequest(InputsRequest):
    """`POST /solutions`: every rigid-body solution at the inputs."""


class StaticsRequest(InputsRequest):
    """`POST /statics`: `frc statics SCENE --json`."""

    lateral_acceleration: float = Field(0.0, ge=0.0, description="[m/s^2] as `--lateral-acceleration`.")
    no_strong: bool = Field(False, description="Skip the strong-stability test, as `--no-strong`.")


class SimulateRequest(InputsRequest):
    """`POST /simulate`: `frc simulate SCENE --json`."""

    model: str | None = Field(None, description="`rigid` or `compliant` (default: the scene's [model]).")
    stiffness: float | None = Field(None, description="[N/m] compliant contact stiffness, as `--stiffness`.")
    damping: float | None = Field(None, description="[N s/m] compliant contact damping, as `--damping`.")
    dt: float = Field(1e-3, description="[s] the rigid step; the compliant sample interval.")
    duration: float = Field(1.0, description="[s] simulated time.")
    integrator: str = Field("radau", description="The compliant model's integrator.")
    every: int = Field(1, ge=1, description="Keep every N-th sample (and the last), as `--every`.")


class FlipRequest(SceneRequest):
    """`POST /plan/flip`: `frc flip SCENE --json`."""

    scene: SceneField = Field("rhex_flip", description="As for every scene endpoint.")
    margin: float = Field(DEFAULT_FLIP_MARGIN, ge=0.0, description="[N m] as `--margin`.")
    max_time: float = Field(2.0, ge=0.0, description="[s] as `--max-time` (0: plan only).")
    dt: float = Field(1e-3, ge=1e-6, description="[s] as `--dt`.")
    replan_every: int = Field(10, ge=1, description="Steps between two plans, as `--replan-every`.")
    pump: bool | None = Field(None, description="Pump over several leg strokes, as `--pump`/`--no-pump` "
                              "(default: on for a scene whose inputs all have drives).")
    compliant: bool = Field(False, description="With the pump: replay the run on the compliant model, as "
                            "`--compliant`.")


class ClimbRequest(SceneRequest):
    """`POST /plan/climb`: `frc climb SCENE --json`."""

    scene: SceneField = Field("snake_climb", description="As for every scene endpoint.")
    margin: float | None = Field(None, ge=0.0, description="[N m or N] as `--margin` (null: the task's, "
                                 f"the gait's {DEFAULT_CLIMB_MARGIN:g}).")
    duration: float | None = Field(None, ge=0.0, description="[s] as `--duration` (null: the task's "
                                   f"max_time, {DEFAULT_CLIMB_DURATION:g} s on snake_climb).")
    seed: int | None = Field(None, ge=0, description="With `cycles`: seed of the gait's sampled "
                             "disturbances, as `--seed` (>= 0; null: 0).")
    cycles: int | None = Field(None, ge=1, description="Climb by this many cycles of the gait, as "
                               "`--cycles` (then `duration` is not used).")
    scale: float | None = Field(None, ge=0.0, description="With `cycles`: the gait's simulated disturbance "
                                "scale, as `--scale`.")


class StandUpRequest(SceneRequest):
    """`POST /plan/standup`: `frc standup SCENE --json`."""

    scene: SceneField = Field("solo_standup", description="As for every scene endpoint: a scene whose task "
                                                          "is a stand-up (a phase tracking y, feet held F).")
    margin: float | None = Field(None, ge=0.0, description="[N m] as `--margin` (default: the phase's).")
    duration: float | None = Field(None, ge=0.0, description="[s] as `--duration` (default: [task] "
                                   "max_time; 0: the first plan only).")
    dt: float = Field(2e-3, ge=1e-6, description="[s] as `--dt`.")
    replan_every: int = Field(10, ge=1, description="Steps between two plans, as `--replan-every`.")


class PlanRequest(SceneRequest):
    """`POST /plan`: `frc plan SCENE --json`."""

    scene: SceneField = Field("box_slide", description="As for every scene endpoint: a scene with [task] "
                                                       "phases.")
    margin: float | None = Field(None, ge=0.0, description="[input units] as `--margin` (default: each "
                                 "phase's margin).")
    max_time: float | None = Field(None, ge=0.0, description="[s] as `--max-time` (default: [task] "
                                   "max_time).")
    dt: float = Field(1e-3, ge=1e-6, description="[s] as `--dt`.")
    replan_every: int = Field(10, ge=1, description="Steps between two plans, as `--replan-every`.")
    compliant: bool = Field(False, description="Replay the inputs on the compliant model, as `--compliant`.")
    cycles: int | None = Field(None, ge=1, description="As `--cycles`: the scene's gait (`[task.gait]`) run "
                               "this many times, or its task's phases (`repeat`); null: the task as given.")


class AtlasRequest(InputsRequest):
    """`POST /atlas`: `frc atlas SCENE --vary ... --json`, run as a job."""

    vary: list[str] = Field(
        min_length=1,
        description="The grid's axes as `--vary`: `PATH=START:STOP:N` (`numpy.linspace(START, STOP, N)` "
                    "for PATH, a `set` path such as `contacts.tip.mu` or `state.q.theta`, or "
                    "`input.NAME`); the first is the outermost axis of every array. At most "
                    f"{MAX_ATLAS_POINTS} points in all.",
        examples=[["state.q.theta=0.3:2.8:13", "contacts.tip.mu=0:2:9"]])
    what: Literal["solutions", "statics", "flip", "climb"] = Field(
        "solutions", description="What to compute at every point, as `--what`.")
    chunk_size: int | None = Field(
        None, ge=1, description="Grid points per chunk, as `--chunk-size` (default: the grid in about "
                                "256 chunks of at most 64 points). Each chunk must finish within the "
                                "service's time limit.")


class ContactAnswer(BaseModel):
    """One contact's forces [N] and accelerations [m/s^2] in a rigid solution."""

    model_config = ConfigDict(extra="forbid")

    lambda_n: float
    lambda_t: float
    a_n: float
    a_t: float


class SolutionAnswer(BaseModel):
    """One rigid-body solution (:meth:`frcontrol.engine.RigidSolution.to_dict`) with its stability."""

    model_config = ConfigDict(extra="forbid")

    mode: str = Field(description="The contact mode, one of S, L, R, F per active contact.")
    scene_mode: str = Field(description="The same mode over every contact of the scene, in scene order "
                            "(S for those apart): the form the text outputs print.")
    dv: list[float] = Field(description="The accelerations of the coordinates [m/s^2 or rad/s^2].")
    contacts: dict[str, ContactAnswer] = Field(description="Forces and accelerations by contact name.")
    ambiguity_dim: int
    ambiguous_outputs: str = Field(description="none, forces or accelerations (what w moves).")
    w: list[float] = Field(description="The representative ambiguity values used.")
    equality_residual: float
    stable: bool | None = Field(description="Stable under contact compliance; null: not analysable.")
    stability_reason: str


class SolutionsAnswer(BaseModel):
    """`POST /solutions`: the `"solutions"` and `"input_units"` of `frc analyze SCENE --input ... --json`."""

    model_config = ConfigDict(extra="forbid")

    solutions: list[SolutionAnswer]
    input_units: dict[str, str] = Field(
        default_factory=dict, description="each input's unit: N, N m, or V for a DC motor's voltage")


class ErrorItem(BaseModel):
    """One problem with a request: where (the field path) and what (the CLI's message)."""

    loc: list[str | int]
    msg: str
    type: str


class ErrorResponse(BaseModel):
    """A refused request (4xx/5xx): FastAPI's shape, `{"detail": [...]}` or `{"detail": "..."}`."""

    detail: list[ErrorItem] | str


class JobState(BaseModel):
    """A job: `GET /jobs/{id}`."""

    id: str
    kind: str
    state: str = Field(description="queued, running, done, failed or cancelled")
    progress: float | None = Field(description="The fraction done, when the work reports it.")
    points_done: int | None = Field(None, description="An atlas: the grid points computed so far.")
    points_total: int | None = Field(None, description="An atlas: the grid's points.")
    message: str
    elapsed: float = Field(description="[s] since the job started.")
    result: dict[str, Any] | None = Field(None, description="The answer, when done: the endpoint's JSON.")
    error: ErrorResponse | None = Field(None, description="Why it failed, when failed.")


class Health(BaseModel):
    """`GET /health`."""

    status: str = Field(description="ok, or degraded while a dead worker is being replaced")
    workers: int = Field(description="The worker processes alive.")
    workers_configured: int = Field(description="The worker processes the service runs (--workers).")
    jobs_running: int


class Version(BaseModel):
    """`GET /version`."""

    frcontrol: str
    api: str


class Robots(BaseModel):
    """`GET /robots`: `frc robots --json` without the folder (the service reveals no paths)."""

    robots: list[str]
    scenes: list[str]
    catalog: list[dict[str, str]] = Field(description="Every robot and scene a scene can name: `kind`, "
                                          "`name`, `description`.")


__all__ = [
    "AnalyzeRequest",
    "AtlasRequest",
    "ClimbRequest",
    "ContactAnswer",
    "ErrorItem",
    "ErrorResponse",
    "FlipRequest",
    "Health",
    "first_non_finite",
    "MAX_JSON_DEPTH",
    "too_deep",
    "URDF_NAME",
    "InputsRequest",
    "JobState",
    "MAX_ATLAS_POINTS",
    "Robots",
    "SceneContent",
    "SceneField",
    "SceneRequest",
    "ShowRequest",
    "SimulateRequest",
    "SolutionAnswer",
    "SolutionsAnswer",
    "SolutionsRequest",
    "StandUpRequest",
    "StaticsRequest",
    "Strict",
    "ValidateRequest",
    "Version",
]
