"""The work behind each endpoint, as it runs in a worker process: JSON text in, JSON text out.

A worker receives the endpoint's name and the request's JSON text (already checked by the server,
checked again here by the same model), loads the scene (never from a path the request names),
calls the same library functions as the matching command (:mod:`frcontrol.answers`) and returns
the command's ``--json`` document as text. Only text crosses the process boundary; a request is
parsed as JSON, never unpickled or evaluated.

An error the library raises on purpose (:class:`~frcontrol.FrcontrolError`) becomes a 422 whose
message is the CLI's one-line error (without ``frc: error:``) and whose ``loc`` is the field path.
"""

from __future__ import annotations

import json
import logging
import tempfile
import tomllib
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import ValidationError

from frcontrol.errors import CoordinateNotFound, FrcontrolError, SceneError

from . import models

if TYPE_CHECKING:
    from frcontrol.scene import Scene

Progress = Callable[[float | None, str], None]
"""Called by long work with (fraction done or None, what it is doing)."""

log = logging.getLogger(__name__)

REQUESTS: dict[str, type[models.SceneRequest]] = {
    "analyze": models.AnalyzeRequest,
    "solutions": models.SolutionsRequest,
    "statics": models.StaticsRequest,
    "simulate": models.SimulateRequest,
    "flip": models.FlipRequest,
    "climb": models.ClimbRequest,
}
"""Each kind of work and the request it takes."""


class NotAvailable(FrcontrolError):
    """The work exists in the API but not in this version of frcontrol (a 501)."""


@contextmanager
def request_scene(request: models.SceneRequest) -> Iterator[Scene]:
    """The request's scene with its overrides: a shipped scene by name, or the content sent.

    URDF texts sent with the scene are written to a private temporary folder for the time of the
    request (Pinocchio reads files); nothing is read from a path the request names.

    Raises:
        SceneError: an unknown shipped name, malformed TOML, a robot given as a path, and
            everything :func:`frcontrol.scene.scene_from_document` refuses.
    """
    from frcontrol.scene import (
        read_scene_document,
        scene_from_document,
        shipped_robots_dir,
        shipped_scene_names,
    )
    from frcontrol.scene_schema import nearest

    if isinstance(request.scene, str):
        name = request.scene.removesuffix(".toml")
        names = shipped_scene_names()
        if name not in names:  # checked against the list: a name is never used as a path
            guess = nearest(name, names)
            hint = f"did you mean {guess!r}? " if guess else ""
            raise SceneError(request.scene, "", f"no shipped scene of that name (a scene is sent by a "
                             f"shipped scene's name or as content); {hint}shipped scenes: {', '.join(names)}")
        path = shipped_robots_dir() / "scenes" / f"{name}.toml"
        yield scene_from_document(read_scene_document(path), source=str(path), overrides=request.set)
        return
    content = request.scene
    if content.toml is not None:
        try:
            document = tomllib.loads(content.toml)
        except tomllib.TOMLDecodeError as err:
            raise SceneError("scene", "", f"malformed TOML: {err}") from err
    else:
        document = dict(content.json_ or {})
    with tempfile.TemporaryDirectory(prefix="frc-serve-") as folder:
        files = {}
        for name, text in content.robots.items():
            files[name] = Path(folder) / Path(name).name
            files[name].write_text(text, encoding="utf-8")
        yield scene_from_document(document, source="scene", robot_files=files, overrides=request.set)


def _analyze(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import analysis_and_solutions, analysis_payload

    result, solutions = analysis_and_solutions(scene, request.inputs,
                                               progress=lambda mode: progress(None, f"analysing mode {mode}"))
    return analysis_payload(scene, result, solutions)


def _solutions(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import analysis_and_solutions, solutions_payload

    result, solutions = analysis_and_solutions(scene, request.inputs)
    return {"solutions": solutions_payload(result, solutions or [])}


def _statics(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.statics import analyze_statics

    return analyze_statics(scene, request.inputs, lateral_acceleration=request.lateral_acceleration,
                           strong=not request.no_strong).to_dict()


def _simulate(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import run_simulation, simulation_failure
    from frcontrol.errors import InputError

    trajectory = run_simulation(scene, request.inputs, model=request.model, stiffness=request.stiffness,
                                damping=request.damping, duration=request.duration, dt=request.dt,
                                integrator=request.integrator)
    failure = simulation_failure(trajectory)
    if failure is not None:
        raise InputError(failure)
    return trajectory.to_dict(scene)


def _flip(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import plan_and_fly

    def report(t: float, total: float) -> None:
        progress(t / total if total > 0 else None, f"simulating the flip: {t:.3f} / {total:g} s")

    plan, result = plan_and_fly(scene, margin=request.margin, max_time=request.max_time, dt=request.dt,
                                replan_every=request.replan_every, progress=report)
    return plan.to_dict(result)


def _climb(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import plan_and_climb

    plan, result = plan_and_climb(scene, margin=request.margin, duration=request.duration, seed=request.seed,
                                  on_simulation=lambda: progress(None, "simulating the climb"))
    return plan.to_dict(result)


def start_atlas(request: models.AtlasRequest) -> str:
    """Start a sweep of the mode atlas as a job; its id.

    Raises:
        NotAvailable: always, in this version: the atlas sweep (``frc atlas``) is not part of it yet.
    """
    raise NotAvailable("the mode atlas sweep is not available in this version of frcontrol "
                       "(POST /atlas starts it once `frc atlas` exists); the job endpoints serve "
                       "POST /jobs/{command} meanwhile")


WORK: dict[str, Callable[[Any, Scene, Progress], dict[str, Any]]] = {
    "analyze": _analyze, "solutions": _solutions, "statics": _statics, "simulate": _simulate,
    "flip": _flip, "climb": _climb,
}
"""Each kind of work: (checked request, scene, progress) -> the command's ``--json`` document."""


def error_document(err: FrcontrolError, overrides: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """A refused request as ``{"status": 422 or 501, "detail": [{loc, msg, type}]}``.

    ``loc`` is the field's path in the request: ``["body", "set", PATH]`` for a refused override,
    ``["body", "scene", FIELD]`` for a scene's field, ``["body", "inputs", NAME]`` for an input.
    """
    loc: list[str | int] = ["body"]
    if isinstance(err, SceneError) and err.field and err.field in (overrides or {}):
        loc += ["set", err.field]
    elif isinstance(err, SceneError):
        loc += ["scene", err.field] if err.field else ["scene"]
    elif isinstance(err, CoordinateNotFound):
        loc += ["inputs", err.name]
    status = 501 if isinstance(err, NotAvailable) else 422
    return {"status": status, "detail": [{"loc": loc, "msg": str(err), "type": type(err).__name__}]}


def validation_document(err: ValidationError) -> dict[str, Any]:
    """A request the models refuse, as a 422 in FastAPI's shape."""
    return {"status": 422, "detail": [{"loc": ["body", *e["loc"]], "msg": e["msg"], "type": e["type"]}
                                      for e in err.errors(include_url=False)]}


def execute(kind: str, text: str, progress: Progress | None = None) -> str:
    """Run one request: ``{"status": 200, "answer": {...}}`` or an error document, as JSON text.

    Never raises for a bad request; an unexpected failure is a 500 naming the exception's type
    (logged in the server's log with its traceback, never sent).
    """
    from frcontrol.jsonable import to_jsonable

    report = progress if progress is not None else (lambda fraction, message: None)
    request: models.SceneRequest | None = None
    try:
        request = REQUESTS[kind].model_validate_json(text)
        with request_scene(request) as scene:
            answer = WORK[kind](request, scene, report)
        return json.dumps({"status": 200, "answer": to_jsonable(answer)})
    except ValidationError as err:
        return json.dumps(validation_document(err))
    except FrcontrolError as err:
        return json.dumps(error_document(err, None if request is None else request.set))
    except Exception as err:  # a bug: the client gets its type, the server's log the traceback
        log.exception("request %s failed", kind)
        return json.dumps({"status": 500, "detail": f"internal error ({type(err).__name__}); see the "
                                                    "server's log"})


def warm_up() -> None:
    """Import what the work needs, so that a worker's first request does not pay for it."""
    import frcontrol.answers  # noqa: F401
    import frcontrol.engine  # noqa: F401
    import frcontrol.scene  # noqa: F401
    import frcontrol.stability  # noqa: F401


__all__ = [
    "NotAvailable",
    "Progress",
    "REQUESTS",
    "WORK",
    "error_document",
    "execute",
    "request_scene",
    "start_atlas",
    "validation_document",
    "warm_up",
]
