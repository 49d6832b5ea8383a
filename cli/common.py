"""Shared pieces of the command line: error handling, JSON output, the console."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from functools import wraps
from pathlib import Path
from typing import TYPE_CHECKING, Any, ParamSpec, TypeVar

import typer
from rich.console import Console

from frcontrol.errors import FrcontrolError

from .progress import Progress
from .text_table import table_lines

if TYPE_CHECKING:  # the scene, the simulators and the viewer load when a command runs
    from frcontrol.scene import Scene
    from frcontrol.simulation.trajectory import Trajectory
    from frcontrol.viz.meshcat_view import ViewerServer

console = Console()
P = ParamSpec("P")
R = TypeVar("R")


_quiet = False


def set_quiet(quiet: bool) -> None:
    """Set by a command's ``--quiet``: no progress display and no notes for the rest of the run."""
    global _quiet
    _quiet = bool(quiet)


def progress(task: str, unit: str = "") -> Progress:
    """The command's progress on stderr (:class:`cli.progress.Progress`), silent under ``--quiet``."""
    return Progress(task, unit, quiet=_quiet)


def note(text: str, *, to_stderr: bool = False) -> None:
    """An informational line ("wrote FILE"): on stdout, or stderr when stdout holds JSON; none if quiet."""
    if not _quiet:
        tell(text, to_stderr=to_stderr)


def tell(text: str, *, to_stderr: bool = False) -> None:
    """A line the user needs even under ``--quiet`` (a viewer's URL): stdout, or stderr beside JSON."""
    if to_stderr:
        sys.stderr.write(text.rstrip("\n") + "\n")
    else:
        typer.echo(text.rstrip("\n"))


WAIT_INTERVAL = 0.2
"""[s] How often a waiting command wakes up (to stop on a signal, or to poll watched files)."""


def wait_until_stopped(tick: Callable[[], None] | None = None,
                       ready: Callable[[], None] | None = None) -> None:
    """Wait until Ctrl-C (SIGINT) or SIGTERM, calling ``tick`` every :data:`WAIT_INTERVAL`.

    The signals end the wait, not the process, so the caller cleans up before frc exits. ``ready``
    (what says the command is ready, such as its URL) runs once the signals are caught: a signal
    sent as soon as that line is read ends the wait, never the process.
    """
    import signal
    import threading

    stop = threading.Event()
    handlers = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        handlers[sig] = signal.signal(sig, lambda signum, frame: stop.set())
    try:
        if ready is not None:
            ready()
        while not stop.wait(WAIT_INTERVAL):
            if tick is not None:
                tick()
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)


def serve_until_stopped(url: str, tick: Callable[[], None] | None = None,
                        ready: Callable[[], None] | None = None) -> None:
    """Keep the meshcat server at ``url`` until Ctrl-C (SIGINT) or SIGTERM, then shut it down.

    The signals end the wait, not the process: the server is stopped before frc exits, so no
    server is left behind on its port. ``ready`` runs once the signals are caught (see
    :func:`wait_until_stopped`); ``tick`` runs every :data:`WAIT_INTERVAL` meanwhile.
    """
    from frcontrol.viz.meshcat_view import stop_server

    def serving() -> None:
        if ready is not None:
            ready()
        note("serving; Ctrl-C (or SIGTERM) stops the viewer", to_stderr=True)

    try:
        wait_until_stopped(tick, serving)
    finally:
        stop_server(url)


def fail(message: str) -> typer.Exit:
    """Print one line on stderr and return the exit (code 1) to raise."""
    sys.stderr.write(f"frc: error: {message}\n")
    return typer.Exit(code=1)


def handle_errors(func: Callable[P, R]) -> Callable[P, R]:
    """Turn every FrcontrolError into one line on stderr and exit code 1 (never a traceback)."""

    @wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return func(*args, **kwargs)
        except FrcontrolError as err:
            raise fail(str(err)) from None

    return wrapper


def check_port(*, view: bool, port: int | None) -> None:
    """Refuse ``--port`` without ``--view`` (a usage error, exit 2).

    Raises:
        typer.BadParameter: ``--port`` given without ``--view``.
    """
    if port is not None and not view:
        raise typer.BadParameter("it sets the port of the --view server: add --view", param_hint="'--port'")


class Interrupted(Exception):  # noqa: N818  (a stop, not an error of the program)
    """A command stopped by a signal: ``frc`` prints ``detail`` on one line and exits 128 + the signal.

    A command raises it where it can say what it kept ("the finished chunks are kept in ...");
    Ctrl-C anywhere else becomes one with no detail.
    """

    def __init__(self, signal_name: str = "SIGINT", detail: str = "") -> None:
        import signal

        self.signal_name = signal_name
        self.exit_code = 128 + int(getattr(signal, signal_name))
        self.detail = detail
        super().__init__(f"interrupted by {signal_name}" + (f"; {detail}" if detail else ""))


def write_motion(scene: Scene, trajectory: Trajectory | None, *, html: Path | None, out: Path | None,
                 json: bool, modes: Sequence[str] | None = None) -> None:
    """Write a command's ``--html`` page and ``--out`` export of its motion, and say where.

    With no trajectory (nothing was simulated) the page shows the scene's state and ``--out`` is
    not written, which stderr says.
    """
    if html is not None:
        from frcontrol.viz.meshcat_view import write_html

        write_html(scene, trajectory, html, modes=modes)
        note(f"wrote {html}", to_stderr=json)
    if out is None:
        return
    if trajectory is None:
        note("no trajectory (nothing was simulated): --out not written", to_stderr=True)
        return
    from frcontrol.simulation.export import save_trajectory

    save_trajectory(scene, trajectory, out)
    note(f"wrote {out}", to_stderr=json)


@contextmanager
def live_viewer(view: bool, port: int | None) -> Iterator[ViewerServer | None]:
    """The ``--view`` server (None without ``--view``), stopped when the command ends in any way.

    It starts before the work, so that a taken port fails first.
    """
    if not view:
        yield None
        return
    from frcontrol.viz.meshcat_view import start_server, stop_server

    server = start_server(port)
    try:
        yield server
    finally:
        stop_server(server.url)


def show_live(server: ViewerServer, scene: Scene, trajectory: Trajectory | None, *, json: bool,
              modes: Sequence[str] | None = None) -> None:
    """Draw the motion into the ``--view`` server, print its URL and serve until Ctrl-C or SIGTERM."""
    from frcontrol.viz.meshcat_view import draw

    draw(server.visualizer(), scene, trajectory, modes=modes)
    serve_until_stopped(server.url, ready=lambda: tell(f"meshcat viewer: {server.url}", to_stderr=json))


def answer(payload: dict[str, Any], render: Callable[[dict[str, Any]], None], *, json: bool) -> None:
    """A command's answer: ``payload`` (a result's ``to_dict()``) as JSON on stdout, or ``render``ed."""
    if json:
        print_json(payload)
    else:
        render(payload)


def named_mode(record: dict[str, Any], payload: dict[str, Any]) -> str:
    """A record's mode over every scene contact, each contact's name beside its letter.

    ``record`` carries ``"scene_mode"`` (:func:`frcontrol.modes.add_scene_modes`), ``payload``
    ``"scene_contacts"``: ``"RSL (toe R, hip S, heel L)"``.
    """
    from frcontrol.modes import mode_label

    return mode_label(record["scene_mode"], payload["scene_contacts"])


def named_modes(modes: Sequence[str], contacts: Sequence[str], payload: dict[str, Any]) -> str:
    """Modes over ``contacts`` (the touching ones) as scene modes, the contacts' names after them.

    ``"LSSSS, RSSSS (letters: front_corner rear_corner front_toe middle_toe rear_toe)"``; ``"none"``
    for no modes.
    """
    from frcontrol.modes import scene_mode

    if not modes:
        return "none"
    names = payload["scene_contacts"]
    shown = ", ".join(scene_mode(mode, contacts, names) for mode in modes)
    return f"{shown} (letters: {' '.join(names)})"


def print_table(title: str, columns: Sequence[str], rows: Sequence[Sequence[str]]) -> None:
    """A text table at the console's width that never cuts a word (:func:`cli.text_table.table_lines`)."""
    for line in table_lines(title, columns, rows, console.width):
        console.print(line, markup=False, highlight=False, crop=False, soft_wrap=True)


def print_json(payload: dict[str, Any]) -> None:
    """Write a JSON document on stdout (NumPy values converted by :func:`frcontrol.jsonable.to_jsonable`)."""
    from frcontrol.jsonable import to_jsonable

    sys.stdout.write(json.dumps(to_jsonable(payload), indent=2) + "\n")


__all__ = [
    "answer",
    "Interrupted",
    "check_port",
    "live_viewer",
    "show_live",
    "write_motion",
    "fail",
    "note",
    "progress",
    "serve_until_stopped",
    "wait_until_stopped",
    "set_quiet",
    "tell",
    "handle_errors",
    "print_json",
    "print_table",
    "named_mode",
    "named_modes",
]
