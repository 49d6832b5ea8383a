"""The FastAPI application of ``frc serve``: endpoints, the token check and the body-size cap.

:func:`create_app` builds it from a :class:`ServiceConfig`; ``frc serve`` runs it with uvicorn.
The endpoints and their JSON are documented in docs/service.md and in the
OpenAPI schema the app serves at ``/openapi.json`` (pages at ``/docs``).
"""

from __future__ import annotations

import asyncio
import hmac
import itertools
import json
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from dataclasses import dataclass
from typing import Any

from fastapi import FastAPI, HTTPException, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from . import models
from .models import first_non_finite, too_deep
from .pool import (
    DEFAULT_MAX_RESULT_BYTES,
    DEFAULT_WORKER_MEMORY,
    Job,
    JobRunner,
    TimeLimitExceeded,
    WorkerLost,
    WorkerPool,
)
from .work import scene_source

API_VERSION = "1"
"""The version of the HTTP API (its paths and request fields), apart from frcontrol's."""

ANSWERS: dict[str, Any] = {"solutions": models.SolutionsAnswer}
"""The typed answers (the others are JSON objects: their command's ``to_dict()``)."""

ENDPOINTS: dict[str, tuple[str, type[models.Strict], str]] = {
    "show": ("/show", models.ShowRequest, "`frc show SCENE --json`: the coordinates, M(q), h(q, v) and every "
             "contact's gap, velocities and rows at the scene's state."),
    "validate": ("/validate", models.ValidateRequest, "`frc validate SCENE --json`: a valid "
                 "scene's document; a scene with problems is a 422 (as `frc validate` exits 1), one `detail` "
                 "item per problem, with the same document beside `detail`."),
    "analyze": ("/analyze", models.AnalyzeRequest, "`frc analyze SCENE [--input ...] --json`: every "
                "contact mode at the scene's state; with `inputs`, every rigid-body solution too."),
    "solutions": ("/solutions", models.SolutionsRequest, "Every rigid-body solution at the inputs: "
                  "`{\"solutions\": [...]}`, the `solutions` of `frc analyze --input ... --json`."),
    "statics": ("/statics", models.StaticsRequest, "`frc statics SCENE --json`: closure, equilibrium, "
                "support region, weak and strong stability at rest."),
    "simulate": ("/simulate", models.SimulateRequest, "`frc simulate SCENE --json`: a trajectory with "
                 "contact events, checked against the model's validity (a diverged run is a 422)."),
    "flip": ("/plan/flip", models.FlipRequest, "`frc flip SCENE --json`: the flip plan and its "
             "closed-loop simulation; the pumping run (`pump`) by default on a scene whose inputs all have "
             "drives."),
    "climb": ("/plan/climb", models.ClimbRequest, "`frc climb SCENE [--cycles N] --json`: the climb plan and "
              "its simulated check, or (`cycles`) the gait's plan and simulation."),
    "standup": ("/plan/standup", models.StandUpRequest, "`frc standup SCENE --json`: the stand-up's first "
                "plan and its re-planned rigid run."),
    "plan": ("/plan", models.PlanRequest, "`frc plan SCENE --json`: the scene's task (its [task] phases) "
             "planned along a rigid run: phases, plans, outcome and samples."),
}
"""Each kind of work: its path, its request model and what it answers."""

COMMAND_ENDPOINTS: dict[str, str] = {
    "robots": "/robots", "schema": "/schema", "validate": "/validate", "show": "/show", "analyze": "/analyze",
    "statics": "/statics", "simulate": "/simulate", "flip": "/plan/flip", "climb": "/plan/climb",
    "standup": "/plan/standup", "plan": "/plan", "atlas": "/atlas",
}
"""Each ``frc`` command and the endpoint answering as its ``--json`` does, by the same
:mod:`frcontrol.answers` function (docs/service.md has the table)."""

COMMANDS_WITHOUT_ENDPOINT: dict[str, str] = {
    "view": "opens a page in a browser on the machine it runs on; its data is frc show's and frc simulate's",
    "serve": "runs this service",
}
"""The ``frc`` commands no endpoint answers for, and why."""

ENDPOINTS_WITHOUT_COMMAND: dict[str, str] = {
    "/solutions": "the solutions of frc analyze --input alone, typed in full (SolutionsAnswer)",
    "/health": "the service's own state",
    "/version": "the versions of frcontrol and of the API (frc --version prints the first)",
    "/jobs/{job_id}": "a job's state and result",
}
"""The endpoints no ``frc`` command answers as (besides ``/jobs`` + an endpoint's path: the same work
as a job), and why."""

REFUSALS: dict[int | str, dict[str, Any]] = {
    401: {"model": models.ErrorResponse, "description": "No or a wrong `Authorization: Bearer` token "
          "(when the service has one)."},
    413: {"model": models.ErrorResponse, "description": "The body exceeds the size cap."},
    422: {"model": models.ErrorResponse, "description": "Bad input: the field path and the CLI's message."},
}
WORK_REFUSALS: dict[int | str, dict[str, Any]] = {
    **REFUSALS,
    500: {"model": models.ErrorResponse, "description": "The worker process ended during the request "
          "(it is replaced)."},
    504: {"model": models.ErrorResponse, "description": "The request exceeded the time limit (named)."},
    507: {"model": models.ErrorResponse, "description": "The request needed more memory than a worker may "
          "use (the limit named; the worker is replaced)."},
}
JOB_REFUSALS: dict[int | str, dict[str, Any]] = {
    **REFUSALS,
    429: {"model": models.ErrorResponse, "description": "Too many jobs running."},
}


@dataclass(frozen=True)
class ServiceConfig:
    """How the service runs.

    Attributes:
        workers: worker processes answering requests.
        time_limit: [s] each request's limit, waiting for a worker included (then a 504).
        job_time_limit: [s] each job's limit (then the job fails, saying so).
        max_jobs: jobs running at once (another one is a 429).
        max_body: [bytes] the largest request body (a larger one is a 413).
        token: when set, every request needs ``Authorization: Bearer <token>`` (else a 401).
        scheduler: a Dask scheduler's address for the atlas jobs' chunks (None: a local pool of
            ``workers`` processes per job).
        worker_memory: [MiB] the address space each worker and job process may add to what it
            uses once the library is loaded (``RLIMIT_AS``); None: no limit.
        max_result_bytes: [bytes] finished jobs' results kept in all (the oldest go first).
    """

    workers: int = 2
    time_limit: float = 60.0
    job_time_limit: float = 3600.0
    max_jobs: int = 2
    max_body: int = 1_000_000
    token: str | None = None
    scheduler: str | None = None
    worker_memory: int | None = DEFAULT_WORKER_MEMORY
    max_result_bytes: int = DEFAULT_MAX_RESULT_BYTES


def _refusal_body(reply: dict[str, Any]) -> dict[str, Any]:
    """A worker's refusal as the response's body: ``detail``, and any document beside it (``/validate``'s)."""
    return {key: value for key, value in reply.items() if key != "status"}


def _error(status: int, message: str, headers: dict[str, str] | None = None) -> JSONResponse:
    return JSONResponse({"detail": message}, status_code=status, headers=headers)


async def _refused(request: Request, err: Exception) -> JSONResponse:
    """A request the models refuse: 422 with each problem's field path and message.

    The input is not echoed: it may hold what JSON cannot carry back, such as NaN.
    """
    problems = err.errors() if isinstance(err, RequestValidationError) else []
    return JSONResponse({"detail": [{"loc": list(e["loc"]), "msg": e["msg"], "type": e["type"]}
                                    for e in problems]}, status_code=422)


class _Guard:
    """ASGI middleware: the bearer token (when configured) and the body-size cap, before any parsing."""

    def __init__(self, app: ASGIApp, config: ServiceConfig) -> None:
        self.app = app
        self.config = config

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}
        refusal = self._refusal(headers)
        if refusal is None:
            body, refusal = await self._body(receive)
        if refusal is not None:
            await refusal(scope, receive, send)
            return
        sent = False

        async def replay() -> Message:
            nonlocal sent
            if sent:
                return await receive()
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}

        await self.app(scope, replay, send)

    def _refusal(self, headers: dict[str, str]) -> JSONResponse | None:
        token = self.config.token
        if token is not None:
            given = headers.get("authorization", "")
            scheme, _, value = given.partition(" ")
            if scheme.lower() != "bearer" or not hmac.compare_digest(value.strip().encode(), token.encode()):
                return _error(401, "this service needs 'Authorization: Bearer <token>' with the token of "
                              "its --token-file", {"WWW-Authenticate": "Bearer"})
        length = headers.get("content-length")
        if length is not None and (not length.isdigit() or int(length) > self.config.max_body):
            return self._too_large()
        return None

    def _too_large(self) -> JSONResponse:
        return _error(413, f"the request body exceeds the service's cap of {self.config.max_body} bytes "
                      "(frc serve --max-body)")

    async def _body(self, receive: Receive) -> tuple[bytes, JSONResponse | None]:
        chunks, size = [], 0
        while True:
            message = await receive()
            if message["type"] != "http.request":
                return b"", None
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > self.config.max_body:
                return b"", self._too_large()
            chunks.append(chunk)
            if not message.get("more_body", False):
                body = b"".join(chunks)
                return body, _non_finite(body)


def _too_deep(where: tuple[str | int, ...]) -> JSONResponse:
    field = list(itertools.takewhile(lambda key: isinstance(key, str), where))[:3]
    return JSONResponse({"detail": [{"loc": ["body", *field], "type": "json_too_deep",
                                     "msg": f"the JSON nests deeper than {models.MAX_JSON_DEPTH} levels "
                                            "(the service's cap, MAX_JSON_DEPTH)"}]}, status_code=422)


def _non_finite(body: bytes) -> JSONResponse | None:
    """A 422 naming the field of a NaN or an infinite number in a JSON body, else None.

    NaN and Infinity are not JSON, though Python reads them. A body nested deeper than
    :data:`~.models.MAX_JSON_DEPTH` is a 422 naming the field where it does; malformed JSON is
    left to the endpoint.
    """
    try:
        document = json.loads(body) if body else None
    except RecursionError:
        return _too_deep(())
    except ValueError:
        return None
    deep = too_deep(document)
    if deep is not None:
        return _too_deep(deep)
    where = first_non_finite(document)
    if where is None:
        return None
    return JSONResponse({"detail": [{"loc": ["body", *where], "type": "finite_number",
                                     "msg": "expected a finite number: NaN and Infinity are not JSON "
                                            "numbers and are not accepted"}]}, status_code=422)


def create_app(config: ServiceConfig | None = None) -> FastAPI:
    """The service's application: worker pool and jobs started with it, stopped with it."""
    config = config or ServiceConfig()
    pool = WorkerPool(config.workers, config.time_limit, config.worker_memory)
    jobs = JobRunner(config.max_jobs, config.job_time_limit, max_result_bytes=config.max_result_bytes,
                     memory=config.worker_memory)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        await pool.start()
        try:
            yield
        finally:
            jobs.stop()
            pool.stop()

    app = FastAPI(title="frcontrol planning service", version=API_VERSION, lifespan=lifespan,
                  docs_url=None, redoc_url=None,  # served from installed files: _add_docs_routes
                  description="Contact modes, mode domains, plans and simulations of planar robots in "
                              "contact, as JSON: each answer is the matching `frc` command's `--json`.")
    app.add_middleware(_Guard, config=config)
    app.add_exception_handler(RequestValidationError, _refused)
    _add_info_routes(app, config, pool, jobs)
    _add_docs_routes(app)
    for kind, (path, request_model, summary) in ENDPOINTS.items():
        _add_work_routes(app, pool, jobs, kind, path, request_model, summary)
    _add_job_routes(app, jobs)
    _add_atlas_route(app, config, pool, jobs)
    return app


DOCS_ASSETS = "/docs-assets"
"""Where the service serves the Swagger UI's script and style sheet (from the fastapi-offline package)."""


def _add_docs_routes(app: FastAPI) -> None:
    """``/docs``: the Swagger UI from installed files (no CDN: it works offline).

    The assets come from the ``fastapi-offline`` package (the ``serve`` extra); without it the
    page says so and links the schema.
    """
    from pathlib import Path

    from fastapi.openapi.docs import get_swagger_ui_html
    from fastapi.responses import HTMLResponse

    try:
        import fastapi_offline
    except ImportError:
        assets = None
    else:
        assets = Path(fastapi_offline.__file__).parent / "static"
    if assets is not None and (assets / "swagger-ui-bundle.js").is_file():
        from fastapi.staticfiles import StaticFiles

        app.mount(DOCS_ASSETS, StaticFiles(directory=assets), name="docs-assets")

    @app.get("/docs", include_in_schema=False)
    async def docs() -> HTMLResponse:
        if assets is None:
            return HTMLResponse("<!doctype html><title>frcontrol planning service</title><p>The API pages "
                                'need fastapi-offline: pip install "frcontrol[serve]". The schema: '
                                '<a href="/openapi.json">/openapi.json</a></p>')
        return get_swagger_ui_html(openapi_url="/openapi.json", title=f"{app.title} - API",
                                   swagger_js_url=f"{DOCS_ASSETS}/swagger-ui-bundle.js",
                                   swagger_css_url=f"{DOCS_ASSETS}/swagger-ui.css",
                                   swagger_favicon_url=f"{DOCS_ASSETS}/favicon.png")


def _add_info_routes(app: FastAPI, config: ServiceConfig, pool: WorkerPool, jobs: JobRunner) -> None:
    background: set[asyncio.Task[None]] = set()  # held until done (the loop keeps weak references)

    @app.get("/health", response_model=models.Health, responses=REFUSALS)
    async def health() -> dict[str, Any]:
        """Answers at once, also while every worker is busy: `workers` counts those alive.

        A worker that died while idle is replaced in the background (and before a request is sent
        to it); until then `status` is `degraded`.
        """
        alive = pool.alive()
        if alive < pool.size:
            healing = asyncio.get_running_loop().create_task(pool.heal())
            background.add(healing)
            healing.add_done_callback(background.discard)
        return {"status": "ok" if alive == pool.size else "degraded", "workers": alive,
                "workers_configured": pool.size, "jobs_running": jobs.running()}

    @app.get("/version", response_model=models.Version, responses=REFUSALS)
    async def version() -> dict[str, Any]:
        """The version of frcontrol and of the API."""
        from frcontrol import __version__

        return {"frcontrol": __version__, "api": API_VERSION}

    @app.get("/robots", response_model=models.Robots, responses=REFUSALS)
    async def robots() -> dict[str, Any]:
        """What ships: `frc robots --json` without the folder (the service takes no paths)."""
        from frcontrol.answers import robots_answer

        return robots_answer().document

    @app.get("/schema", response_model=dict[str, Any], responses=REFUSALS)
    async def schema() -> dict[str, Any]:
        """The scene format as a JSON Schema (draft 2020-12): `frc schema`."""
        from frcontrol.answers import schema_answer

        return schema_answer().document


def _add_work_routes(app: FastAPI, pool: WorkerPool, jobs: JobRunner, kind: str, path: str,
                     request_model: type[models.Strict], summary: str) -> None:
    async def answer(request: models.Strict) -> Any:
        text = request.model_dump_json(by_alias=True)
        try:
            reply = json.loads(await pool.run(kind, text))
        except TimeLimitExceeded as err:
            return _error(504, str(err))
        except WorkerLost as err:
            return _error(500, str(err))
        if reply["status"] == 200:
            return JSONResponse(reply["answer"])
        return JSONResponse(_refusal_body(reply), status_code=reply["status"])

    async def start_job(request: models.Strict) -> Any:
        job = jobs.start(kind, request.model_dump_json(by_alias=True))
        if job is None:
            return _too_many_jobs(jobs)
        return JSONResponse(job.public(), status_code=202)

    answer.__annotations__ = {"request": request_model, "return": Any}
    start_job.__annotations__ = {"request": request_model, "return": Any}
    app.add_api_route(path, answer, methods=["POST"], summary=summary, responses=WORK_REFUSALS,
                      response_model=ANSWERS.get(kind, dict[str, Any]), name=kind)
    app.add_api_route(f"/jobs{path}", start_job, methods=["POST"], status_code=202,
                      summary=f"Start {path} as a job (its id, then GET /jobs/{{id}})",
                      response_model=models.JobState, name=f"job_{kind}", responses=JOB_REFUSALS)


def _add_job_routes(app: FastAPI, jobs: JobRunner) -> None:
    def found(job_id: str) -> dict[str, Any]:
        job = jobs.jobs.get(job_id)
        if job is None:
            raise HTTPException(404, f"no job {job_id!r} (a finished job is kept until {jobs.keep} newer "
                                "ones end)")
        return job.public()

    @app.get("/jobs/{job_id}", response_model=models.JobState, responses=REFUSALS)
    async def job_state(job_id: str) -> dict[str, Any]:
        """A job's state and progress; its result when done, its error when failed."""
        return found(job_id)

    @app.delete("/jobs/{job_id}", response_model=models.JobState, responses=REFUSALS)
    async def cancel_job(job_id: str) -> dict[str, Any]:
        """Cancel a job (its process, or an atlas's workers, stopped); a finished job stays as it was."""
        found(job_id)
        jobs.cancel(job_id)
        return found(job_id)


def _too_many_jobs(jobs: JobRunner) -> JSONResponse:
    return _error(429, f"{jobs.max_running} jobs are running, the service's limit (frc serve --max-jobs): "
                  "wait for one to end or cancel one")


def _add_atlas_route(app: FastAPI, config: ServiceConfig, pool: WorkerPool, jobs: JobRunner) -> None:
    @app.post("/atlas", status_code=202, response_model=models.JobState,
              responses={**JOB_REFUSALS, **WORK_REFUSALS})
    async def atlas(request: models.AtlasRequest) -> Any:
        """`frc atlas SCENE --vary ... --json` as a job: its id, then `GET /jobs/{id}`.

        The request is checked at once (a 422 names the field); the sweep then runs on a local
        pool of `--workers` processes started for the job, or on the `--scheduler` Dask cluster.
        Each chunk must finish within the service's time limit; the whole job within the job time
        limit. `GET /jobs/{id}` shows `points_done` of `points_total` and, when done, the result.
        """
        if jobs.running() >= jobs.max_running:
            return _too_many_jobs(jobs)
        try:
            reply = json.loads(await pool.run("atlas", request.model_dump_json(by_alias=True)))
        except TimeLimitExceeded as err:
            return _error(504, str(err))
        except WorkerLost as err:
            return _error(500, str(err))
        if reply["status"] != 200:
            return JSONResponse(_refusal_body(reply), status_code=reply["status"])
        job = await asyncio.to_thread(_start_atlas, jobs, config, reply["answer"], request)
        if job is None:
            return _too_many_jobs(jobs)
        return JSONResponse(job.public(), status_code=202)


def _start_atlas(jobs: JobRunner, config: ServiceConfig, plan: dict[str, Any],
                 request: models.AtlasRequest) -> Job | None:
    """Start the atlas job of a checked request (in a thread: the first one imports the atlas)."""
    from .atlas_job import atlas_work

    work = atlas_work(plan, scene_source(request.scene), workers=config.workers,
                      scheduler=config.scheduler, chunk_time_limit=config.time_limit)
    return jobs.start_thread("atlas", work)


__all__ = [
    "API_VERSION",
    "COMMAND_ENDPOINTS",
    "COMMANDS_WITHOUT_ENDPOINT",
    "ENDPOINTS",
    "ENDPOINTS_WITHOUT_COMMAND",
    "ServiceConfig",
    "create_app",
]
