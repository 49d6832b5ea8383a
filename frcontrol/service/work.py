"""The work behind each endpoint, as it runs in a worker process: JSON text in, JSON text out.

A worker receives the endpoint's name and the request's JSON text (already checked by the server,
checked again here by the same model), loads the scene (never from a path the request names),
calls the same library functions as the matching command (:mod:`frcontrol.answers`) and returns
the command's ``--json`` document as text. Only text crosses the process boundary; a request is
parsed as JSON, never unpickled or evaluated.

An error the library raises on purpose (:class:`~frcontrol.FrcontrolError`) becomes a 422 whose
message is the CLI's one-line error (without ``frc: error:``) and whose ``loc`` is the field path.

``POST /atlas`` is checked here too (``"atlas"``: the plan is built, nothing is computed, and its
``to_dict()`` is the answer); the job itself is driven from the server's process
(:mod:`.atlas_job`).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from pydantic import ValidationError

from frcontrol.answers import OptionConflict
from frcontrol.errors import CoordinateNotFound, FrcontrolError, InputError, LimitExceeded, SceneError

from . import models

if TYPE_CHECKING:
    from frcontrol.atlas import AtlasPlan
    from frcontrol.scene import Scene
    from frcontrol.scene_source import SceneSource

Progress = Callable[[float | None, str], None]
"""Called by long work with (fraction done or None, what it is doing)."""

log = logging.getLogger(__name__)

BLAS_WARM_UP = 512
"""[-] The size of the products :func:`warm_up` makes, so that BLAS allocates its buffers (and
starts its threads) before a worker's memory limit is set."""

OUT_OF_MEMORY = 507
"""The status of a request that ran out of its process's memory limit (``frc serve --worker-memory``)."""

REQUESTS: dict[str, type[models.Strict]] = {
    "show": models.ShowRequest,
    "validate": models.ValidateRequest,
    "analyze": models.AnalyzeRequest,
    "solutions": models.SolutionsRequest,
    "statics": models.StaticsRequest,
    "simulate": models.SimulateRequest,
    "flip": models.FlipRequest,
    "climb": models.ClimbRequest,
    "standup": models.StandUpRequest,
    "plan": models.PlanRequest,
    "atlas": models.AtlasRequest,
}
"""Each kind of work and the request it takes."""


class FieldError(FrcontrolError):
    """A library error about one field of a request: its message, and the field's path (``loc``)."""

    def __init__(self, loc: Sequence[str | int], err: FrcontrolError) -> None:
        self.loc = list(loc)
        self.kind = type(err).__name__
        super().__init__(str(err))


def scene_source(scene: str | models.SceneContent) -> SceneSource:
    """A request's scene as a :class:`~frcontrol.scene_source.SceneSource`.

    A shipped scene's name (checked against the shipped list, never used as a path) or the content.

    Raises:
        SceneError: an unknown shipped name (the nearest named), malformed TOML.
    """
    from frcontrol.scene_source import SceneSource

    if isinstance(scene, str):
        return SceneSource.shipped(scene)
    return SceneSource.content(toml=scene.toml, document=None if scene.toml is not None else scene.json_,
                               robots=scene.robots)


@contextmanager
def request_scene(request: models.SceneRequest) -> Iterator[Scene]:
    """The request's scene with its overrides: a shipped scene by name, or the content sent.

    URDF texts sent with the scene are written to a private temporary folder for the time of the
    request (Pinocchio reads files); nothing is read from a path the request names.

    Raises:
        SceneError: an unknown shipped name, malformed TOML, a robot given as a path, and
            everything :func:`frcontrol.scene.scene_from_document` refuses.
    """
    with scene_source(request.scene).loaded(request.set) as scene:
        yield scene


def _show(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import show_answer

    return show_answer(scene).document


def _analyze(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import analyze_answer

    return analyze_answer(scene, request.inputs,
                          progress=lambda mode: progress(None, f"analysing mode {mode}"),
                          stage=lambda text: progress(None, text)).document


def _solutions(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import solutions_answer

    return solutions_answer(scene, request.inputs).document


def _statics(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import statics_answer

    return statics_answer(scene, request.inputs, lateral_acceleration=request.lateral_acceleration,
                          strong=not request.no_strong).document


def _simulate(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import SimulationOptions, simulate_answer, simulation_failure

    answer = simulate_answer(scene, request.inputs, SimulationOptions(
        model=request.model, stiffness=request.stiffness, damping=request.damping, duration=request.duration,
        dt=request.dt, integrator=request.integrator), every=request.every)
    failure = simulation_failure(answer.result)
    if failure is not None:
        raise InputError(failure)
    return answer.document


def _simulated(what: str, progress: Progress) -> Callable[[float, float], None]:
    """The library's (done, total) progress as the job's fraction and message."""

    def report(done: float, total: float) -> None:
        progress(done / total if total > 0 else None, f"{what}: {done:g} / {total:g}")

    return report


def _flip(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import FlipOptions, flip_answer

    try:
        options = FlipOptions(margin=request.margin, max_time=request.max_time, dt=request.dt,
                              replan_every=request.replan_every, pump=request.pump,
                              compliant=request.compliant)
        return flip_answer(scene, options, progress=_simulated("simulating the flip [s]", progress)).document
    except LimitExceeded as err:  # the flip's simulated time is its max_time
        raise FieldError(["max_time"], err) from err


def _climb(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import climb_answer

    what = "the climb [s]" if request.cycles is None else "the gait [s]"
    return climb_answer(scene, margin=request.margin, duration=request.duration, seed=request.seed,
                        cycles=request.cycles, scale=request.scale,
                        on_simulation=lambda: progress(None, f"simulating {what}"),
                        progress=_simulated(f"simulating {what}", progress)).document


def _standup(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import standup_answer

    try:
        return standup_answer(scene, duration=request.duration, dt=request.dt,
                              replan_every=request.replan_every, margin=request.margin,
                              progress=_simulated("the stand-up [s]", progress)).document
    except LimitExceeded as err:
        raise FieldError(["duration"], err) from err


def _plan(request: Any, scene: Scene, progress: Progress) -> dict[str, Any]:
    from frcontrol.answers import plan_answer

    try:
        return plan_answer(scene, dt=request.dt, replan_every=request.replan_every, max_time=request.max_time,
                           margin=request.margin, compliant=request.compliant, cycles=request.cycles,
                           progress=_simulated("running the task [s]", progress)).document
    except LimitExceeded as err:  # the task's simulated time is its max_time
        raise FieldError(["max_time"], err) from err


def validate_scene(request: models.ValidateRequest) -> dict[str, Any]:
    """``POST /validate``: ``frc validate --json``'s document, a 200 when valid, else a 422.

    The scene is checked, not loaded first. A scene with problems is refused as every endpoint
    refuses a bad scene (as ``frc validate`` exits 1): ``{"status": 422, "detail": [...]}`` with one
    item per problem (``loc`` ``["body", "scene", FIELD]``, ``msg`` the command's line without
    ``frc: error:``), and beside ``detail`` the document itself (``valid``, ``files``).

    Raises:
        SceneError: an unknown shipped name (the nearest named), malformed TOML.
    """
    from frcontrol.answers import validation_answer, validation_problems

    document = validation_answer([scene_source(request.scene)]).document
    if document["valid"]:
        return {"status": 200, "answer": document}
    detail = [{"loc": ["body", "scene", field] if field else ["body", "scene"], "msg": line,
               "type": "SceneError"} for field, line in validation_problems(document)]
    return {"status": 422, "detail": detail, **document}


def plan_atlas(request: models.AtlasRequest) -> AtlasPlan:
    """The plan of a ``POST /atlas`` request, checked as ``frc atlas`` checks its arguments.

    Raises:
        FieldError: an axis that is malformed, names no field or input (the nearest in the
            message), conflicts with ``set`` or ``inputs``, or a grid of more than
            :data:`~frcontrol.atlas.MAX_ATLAS_POINTS` points (``loc`` ``["vary", i]`` or ``["vary"]``).
        SceneError, CoordinateNotFound, InputError: the scene, ``set`` or ``inputs`` refused.
    """
    import math

    from frcontrol.atlas import MAX_ATLAS_POINTS, build_atlas, parse_axis

    axes = []
    for i, text in enumerate(request.vary):
        try:
            axes.append(parse_axis(text))
        except InputError as err:
            raise FieldError(["vary", i], err) from err
    points = math.prod(a.count for a in axes)
    if points > MAX_ATLAS_POINTS:
        raise FieldError(["vary"], InputError(
            f"the grid has {points} points; a job of this service takes at most {MAX_ATLAS_POINTS} "
            "(frcontrol.atlas.MAX_ATLAS_POINTS): sweep fewer points, or run frc atlas --max-points N "
            "on a machine or a Dask cluster"))
    try:
        return build_atlas(scene_source(request.scene), axes, what=request.what, inputs=request.inputs,
                           overrides=request.set, chunk_size=request.chunk_size)
    except (SceneError, InputError) as err:
        for i, axis in enumerate(axes):
            if getattr(err, "field", None) == axis.path or str(err).startswith(f"--vary {axis.path}"):
                raise FieldError(["vary", i], err) from err
        raise


WORK: dict[str, Callable[[Any, Scene, Progress], dict[str, Any]]] = {
    "show": _show, "analyze": _analyze, "solutions": _solutions, "statics": _statics, "simulate": _simulate,
    "flip": _flip, "climb": _climb, "standup": _standup, "plan": _plan,
}
"""Each kind of work: (checked request, scene, progress) -> the command's ``--json`` document."""


def error_document(err: FrcontrolError, overrides: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """A refused request as ``{"status": 422, "detail": [{loc, msg, type}]}``.

    ``loc`` is the field's path in the request: ``["body", "set", PATH]`` for a refused override,
    ``["body", "scene", FIELD]`` for a scene's field, ``["body", "inputs", NAME]`` for an input,
    ``["body", "vary", i]`` for an atlas's axis.
    """
    if isinstance(err, FieldError):
        return {"status": 422, "detail": [{"loc": ["body", *err.loc], "msg": str(err), "type": err.kind}]}
    loc: list[str | int] = ["body"]
    if isinstance(err, SceneError) and err.field and err.field in (overrides or {}):
        loc += ["set", err.field]
    elif isinstance(err, SceneError):
        loc += ["scene", err.field] if err.field else ["scene"]
    elif isinstance(err, CoordinateNotFound):
        loc += ["inputs", err.name]
    elif isinstance(err, (LimitExceeded, OptionConflict)):
        loc += [err.field]
    return {"status": 422, "detail": [{"loc": loc, "msg": str(err), "type": type(err).__name__}]}


def validation_document(err: ValidationError) -> dict[str, Any]:
    """A request the models refuse, as a 422 in FastAPI's shape."""
    return {"status": 422, "detail": [{"loc": ["body", *e["loc"]], "msg": e["msg"], "type": e["type"]}
                                      for e in err.errors(include_url=False)]}


def execute(kind: str, text: str, progress: Progress | None = None) -> str:
    """Run one request: ``{"status": 200, "answer": {...}}`` or an error document, as JSON text.

    Never raises for a bad request; a request that ran out of the process's memory limit is a
    :data:`OUT_OF_MEMORY` (507) naming the limit; an unexpected failure is a 500 naming the
    exception's type (logged in the server's log with its traceback, never sent).
    """
    from frcontrol.jsonable import to_jsonable

    report = progress if progress is not None else (lambda fraction, message: None)
    request: models.Strict | None = None
    try:
        request = REQUESTS[kind].model_validate_json(text)
        if isinstance(request, models.AtlasRequest):
            answer = plan_atlas(request).to_dict()
        elif isinstance(request, models.ValidateRequest):
            return json.dumps(to_jsonable(validate_scene(request)))
        else:  # every other request names a scene and its overrides
            with request_scene(cast(models.SceneRequest, request)) as scene:
                answer = WORK[kind](request, scene, report)
        return json.dumps({"status": 200, "answer": to_jsonable(answer)})
    except ValidationError as err:
        return json.dumps(validation_document(err))
    except FrcontrolError as err:
        return json.dumps(error_document(err, getattr(request, "set", None)))
    except MemoryError:
        release_reserve()
        return json.dumps({"status": OUT_OF_MEMORY, "detail": _memory_message()})
    except Exception as err:
        release_reserve()
        if near_memory_limit():  # an extension that ran out of memory and said it otherwise
            return json.dumps({"status": OUT_OF_MEMORY, "detail": _memory_message()})
        keep_reserve()
        log.exception("request %s failed", kind)  # a bug: the client gets its type, the log the traceback
        return json.dumps({"status": 500, "detail": f"internal error ({type(err).__name__}); see the "
                                                    "server's log"})


MEMORY_RESERVE = 4 * 2**20
"""[bytes] Memory a worker under a memory limit keeps allocated and frees when a request fails, so
that it can still answer (and log) after the request has used up the limit."""

_reserve: list[bytearray] = []


def keep_reserve() -> None:
    """Hold :data:`MEMORY_RESERVE` (a worker calls this once its memory limit is set)."""
    if not _reserve:
        try:
            _reserve.append(bytearray(MEMORY_RESERVE))
        except MemoryError:
            pass  # too close to the limit to hold it: the next failure is answered without it


def release_reserve() -> None:
    """Free :data:`MEMORY_RESERVE`, for the answer to a failed request."""
    _reserve.clear()


def address_space() -> int:
    """[bytes] This process's address space now (Linux: ``VmSize`` of ``/proc/self/status``; else 0)."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def near_memory_limit() -> bool:
    """Whether this process's address space is within 2 :data:`MEMORY_RESERVE` of its limit.

    The limit is ``RLIMIT_AS``. A failure there is taken for running out of memory, whatever its
    type: an extension that fails to allocate may raise SystemError or a library's own error.
    """
    import resource

    limit = resource.getrlimit(resource.RLIMIT_AS)[0]
    return limit != resource.RLIM_INFINITY and address_space() + 2 * MEMORY_RESERVE >= limit


def _memory_message() -> str:
    import resource

    limit = resource.getrlimit(resource.RLIMIT_AS)[0]
    cap = "" if limit == resource.RLIM_INFINITY else f" ({limit // 2**20} MiB of address space in all)"
    return (f"the request needed more memory than a worker may use{cap}, the service's limit (frc serve "
            "--worker-memory); its work was stopped and its worker replaced: ask for less (a shorter "
            "run, a larger step)")


def out_of_memory(reply: str) -> bool:
    """Whether :func:`execute`'s reply says that the request ran out of memory (its worker then ends)."""
    return reply.startswith(f'{{"status": {OUT_OF_MEMORY},')


def warm_up() -> None:
    """Import what the work needs, so that a worker's first request does not pay for it.

    Also before a worker's memory limit is set: the libraries' address space is then its own.
    """
    import scipy.linalg
    import scipy.spatial  # noqa: F401  (the statics' hulls import it on first use)

    import frcontrol.answers  # noqa: F401
    import frcontrol.atlas  # noqa: F401
    import frcontrol.engine  # noqa: F401
    import frcontrol.planning.climb  # noqa: F401
    import frcontrol.planning.core  # noqa: F401
    import frcontrol.planning.flip  # noqa: F401
    import frcontrol.planning.gait  # noqa: F401
    import frcontrol.planning.gait_timing  # noqa: F401
    import frcontrol.planning.pump  # noqa: F401
    import frcontrol.planning.standup  # noqa: F401
    import frcontrol.scene  # noqa: F401
    import frcontrol.simulation.compliant  # noqa: F401
    import frcontrol.simulation.rigid  # noqa: F401
    import frcontrol.stability  # noqa: F401
    import frcontrol.statics  # noqa: F401

    square = np.eye(BLAS_WARM_UP) + 1.0  # NumPy's and SciPy's BLAS allocate their buffers on first use
    product = square @ square
    np.linalg.solve(product, square[0])
    scipy.linalg.cho_solve(scipy.linalg.cho_factor(product), square[0])
    scipy.linalg.lu_solve(scipy.linalg.lu_factor(product), square[0])
    scipy.linalg.blas.dgemm(1.0, square, square)


__all__ = [
    "BLAS_WARM_UP",
    "address_space",
    "FieldError",
    "OUT_OF_MEMORY",
    "out_of_memory",
    "Progress",
    "REQUESTS",
    "WORK",
    "error_document",
    "execute",
    "plan_atlas",
    "request_scene",
    "scene_source",
    "validate_scene",
    "validation_document",
    "warm_up",
]
