"""``frc serve``: the planning service, frcontrol's commands as JSON over HTTP for other programs."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from frcontrol.errors import reason_from_exception

from . import common, options
from .atlas_cmd import check_scheduler_address
from .options import in_range

LOOPBACK = "127.0.0.1"
"""The only address ``frc serve`` binds to without a token."""


def _check_host(host: str) -> str:
    """``--host``: an IP address or a host name (whether it can be bound is checked at the start)."""
    import ipaddress
    import re

    try:
        ipaddress.ip_address(host)
    except ValueError:
        if not re.fullmatch(r"[A-Za-z0-9]([A-Za-z0-9.-]{0,252})", host):
            raise typer.BadParameter(f"expected an IP address or a host name, got {host!r}") from None
    return host


def _check_token_file(path: Path | None) -> Path | None:
    """``--token-file``: a readable file (an empty first line is refused once it is read)."""
    import os

    if path is not None and not (path.is_file() and os.access(path, os.R_OK)):
        raise typer.BadParameter(f"{str(path)!r}: expected a readable file holding the token")
    return path


HostOpt = Annotated[
    str,
    typer.Option("--host", callback=_check_host,
                 help=f"Address to listen on. Any other than {LOOPBACK} needs --token-file."),
]
ServePortOpt = Annotated[int, typer.Option("--port", callback=in_range(1, 65535), help="Port to listen on.")]
WorkersOpt = Annotated[
    int, typer.Option("--workers", callback=in_range(1, 64), help="Worker processes answering requests."),
]
SchedulerOpt = Annotated[
    str | None,
    typer.Option("--scheduler", metavar="ADDRESS", callback=check_scheduler_address,
                 help="Run the chunks of POST /atlas jobs on the Dask cluster at tcp://HOST:PORT (checked "
                      'at the start; pip install "frcontrol[cluster]"); default: a local pool of '
                      "--workers processes per job."),
]
TokenFileOpt = Annotated[
    Path | None,
    typer.Option("--token-file", metavar="FILE", callback=_check_token_file,
                 help="A file holding the token every request must bring as 'Authorization: Bearer "
                      "<token>' (its first line). Required to listen on any address but 127.0.0.1."),
]
TimeLimitOpt = Annotated[
    float,
    typer.Option("--time-limit", callback=in_range(0.1, unit="[s]"),
                 help="[s] Each request's time limit (waiting included); past "
                 "it the answer is a 504 naming the limit and the work is stopped. Also each chunk's "
                 "limit in an atlas job on the local pool."),
]
JobTimeLimitOpt = Annotated[
    float, typer.Option("--job-time-limit", callback=in_range(0.1, unit="[s]"),
                        help="[s] Each job's time limit (an atlas job's "
                        "whole run)."),
]
MaxJobsOpt = Annotated[
    int, typer.Option("--max-jobs", callback=in_range(1), help="Jobs running at once (another is a 429)."),
]
MaxBodyOpt = Annotated[
    int,
    typer.Option("--max-body", callback=in_range(1024, unit="[bytes]"),
                 help="[bytes] The largest request body (a larger one is a 413)."),
]
WorkerMemoryOpt = Annotated[
    int | None,
    typer.Option("--worker-memory", callback=in_range(0, unit="[MiB]"), metavar="MIB",
                 help="[MiB] The address space each worker and job process may add to what it uses "
                      "once the library is loaded (RLIMIT_AS; about 500 MiB); a request that needs "
                      "more is a 507 and its worker is replaced. 0: no limit. Default: 4096."),
]
MaxResultBytesOpt = Annotated[
    int | None,
    typer.Option("--max-result-bytes", callback=in_range(1024, unit="[bytes]"), metavar="BYTES",
                 help="[bytes] Finished jobs' results kept in memory in all; the oldest finished jobs "
                      "are forgotten first, and a larger result alone fails its job. Default: 256 MiB."),
]
OpenApiOpt = Annotated[
    bool,
    typer.Option("--openapi", help="Print the API's OpenAPI schema (JSON) and exit, serving nothing."),
]


def read_token(path: Path) -> str:
    """The token in ``--token-file``: its first line, stripped.

    Raises:
        typer.Exit: the file cannot be read or its first line is empty (exit 1, one line on stderr).
    """
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as err:
        reason = reason_from_exception(err)
        raise common.fail(f"--token-file {str(path)!r}: cannot read it: {reason}") from None
    token = lines[0].strip() if lines else ""
    if not token:
        raise common.fail(f"--token-file {str(path)!r}: its first line is empty; expected the token")
    return token


def _check_port_free(host: str, port: int) -> None:
    """Refuse, before starting any worker, a port another program holds (exit 1, one line)."""
    import socket

    try:
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            probe.bind((host, port))
    except OSError as err:
        raise common.fail(f"cannot listen on {host}:{port}: {reason_from_exception(err)}") from None


@common.handle_errors
def serve_command(
    host: HostOpt = LOOPBACK,
    port: ServePortOpt = 8000,
    workers: WorkersOpt = 2,
    scheduler: SchedulerOpt = None,
    token_file: TokenFileOpt = None,
    time_limit: TimeLimitOpt = 60.0,
    job_time_limit: JobTimeLimitOpt = 3600.0,
    max_jobs: MaxJobsOpt = 2,
    max_body: MaxBodyOpt = 1_000_000,
    worker_memory: WorkerMemoryOpt = None,
    max_result_bytes: MaxResultBytesOpt = None,
    openapi: OpenApiOpt = False,
    json: options.JsonOpt = False,
    quiet: options.QuietOpt = False,
) -> None:
    """Serve frcontrol's commands as JSON over HTTP, until Ctrl-C or SIGTERM.

    POST /analyze, /solutions, /statics, /simulate, /plan/flip, /plan/climb answer with the
    matching command's --json; POST /jobs/... runs the same as a job, POST /atlas runs frc atlas
    as one (GET /jobs/{id} for its progress and result, DELETE to cancel); GET /health, /version,
    /robots. API pages at /docs.
    Needs pip install "frcontrol[serve]". The URL goes to stdout (with --json: {"url", "docs"}).

    \b
    Examples:
      frc serve --openapi --json
    Serving (until Ctrl-C or SIGTERM):
      frc serve --port 8000 --workers 2
      frc serve --host 0.0.0.0 --token-file token.txt
      frc serve --scheduler tcp://head-node:8786
    """
    common.set_quiet(quiet)
    try:
        from frcontrol.service import ServiceConfig, create_app
    except ImportError as err:
        raise common.fail(f"frc serve needs FastAPI and uvicorn ({err.name} is missing): "
                          'pip install "frcontrol[serve]"') from None
    if host != LOOPBACK and token_file is None:
        raise common.fail(f"--host {host}: listening on an address other than {LOOPBACK} needs "
                          "--token-file FILE (every request then brings 'Authorization: Bearer <token>')")
    token = read_token(token_file) if token_file is not None else None
    limits: dict[str, Any] = {}  # the service's defaults unless given
    if worker_memory is not None:
        limits["worker_memory"] = worker_memory or None
    if max_result_bytes is not None:
        limits["max_result_bytes"] = max_result_bytes
    config = ServiceConfig(workers=workers, time_limit=time_limit, job_time_limit=job_time_limit,
                           max_jobs=max_jobs, max_body=max_body, token=token, scheduler=scheduler, **limits)
    app = create_app(config)
    if openapi:
        common.print_json(app.openapi())
        return
    _check_port_free(host, port)
    if scheduler is not None:
        from frcontrol.atlas.executors import check_scheduler

        check_scheduler(scheduler)  # a typo'd address fails here, not in every job
    _run(app, host, port, json=json, quiet=quiet)


def _logs_on_stderr() -> dict[str, Any]:
    """Uvicorn's logging configuration with every log, the access log too, on stderr (stdout: answers)."""
    import copy

    from uvicorn.config import LOGGING_CONFIG

    config = copy.deepcopy(LOGGING_CONFIG)
    for handler in config["handlers"].values():
        handler["stream"] = "ext://sys.stderr"
    return config


def _run(app: object, host: str, port: int, *, json: bool, quiet: bool) -> None:
    """Serve ``app`` with uvicorn; say where once it listens; stop on Ctrl-C or SIGTERM."""
    import signal
    import threading

    import uvicorn

    shown = f"[{host}]" if ":" in host else host
    url = f"http://{shown}:{port}"
    level = "warning" if quiet else "info"
    server = uvicorn.Server(uvicorn.Config(app, host=host, port=port, log_level=level, access_log=not quiet,
                                           lifespan="on", log_config=_logs_on_stderr()))

    def announce() -> None:
        while not server.started and not server.should_exit:
            threading.Event().wait(0.05)
        if not server.started:
            return
        import json as json_module
        import sys

        if json:  # one line, flushed: a program reads it while the service runs
            sys.stdout.write(json_module.dumps({"url": url, "docs": f"{url}/docs"}) + "\n")
        else:
            common.tell(f"serving {url} (API pages at {url}/docs); Ctrl-C or SIGTERM stops")
        sys.stdout.flush()

    threading.Thread(target=announce, daemon=True).start()
    # uvicorn shuts down gracefully on SIGINT/SIGTERM, then raises the signal again for the handlers
    # it found: these ones end the wait quietly, so a stop by signal is an ordinary exit (code 0).
    previous = {sig: signal.signal(sig, lambda signum, frame: None)
                for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        server.run()
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    if not server.started:
        raise common.fail(f"the service could not start on {url} (see the log above)")


__all__ = [
    "LOOPBACK",
    "read_token",
    "serve_command",
]
