"""Options shared by several commands, defined once so that names and meanings agree everywhere."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from frcontrol.errors import InputError
from frcontrol.scene_schema import parse_override

if TYPE_CHECKING:  # the scene module loads when a command runs, not for --help
    from frcontrol.scene import Scene

def scene_argument(kind: str = "") -> Any:
    """The SCENE argument of a command; ``kind`` says what the scene must hold ("with [[disturbances]]")."""
    return Annotated[
        str, typer.Argument(metavar="SCENE", help=f"A scene file{' ' + kind if kind else ''}, or the name "
                            "of a shipped scene."),
    ]


SceneArg = scene_argument()

SetOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--set", metavar="PATH=VALUE",
        help="Override a scene field without editing the file, e.g. --set contacts.tip.mu=0.5, "
             "--set state.q=[0,0.45,2.0], --set gravity=3.7, --set model.stiffness=1e6 (VALUE is "
             "TOML; repeatable). Checked exactly like the file: an unknown path names the nearest one.",
    ),
]


InputOpt = Annotated[
    list[str] | None,
    typer.Option("--input", "-i", metavar="NAME=VALUE",
                 help="An input value NAME=VALUE (repeatable); inputs not named are 0."),
]


def parse_inputs(pairs: list[str] | None) -> dict[str, float]:
    """``["x=2.5", ...]`` -> ``{"x": 2.5}`` (the ``--input`` grammar of every command).

    Raises:
        InputError: a pair is not NAME=VALUE with a finite number, or a name repeats.
    """
    out: dict[str, float] = {}
    for pair in pairs or []:
        name, sep, value = pair.partition("=")
        name = name.strip()
        if not sep or not name:
            raise InputError(f"--input expects NAME=VALUE, got {pair!r}")
        try:
            number = float(value)
        except ValueError as err:
            raise InputError(f"--input {pair!r}: {value!r} is not a number") from err
        if not math.isfinite(number):
            raise InputError(f"--input {pair!r}: the value must be finite")
        if name in out:
            raise InputError(f"--input names {name!r} twice")
        out[name] = number
    return out


QuietOpt = Annotated[
    bool,
    typer.Option("--quiet", "-q", help="Print only the answer: no progress display and no notes such as "
                 "'wrote FILE' (errors and the simulation's validity warnings still go to stderr)."),
]


OutOpt = Annotated[
    Path | None,
    typer.Option("--out", metavar="FILE", help="Export the trajectory: FILE.npz (arrays times, q, v, "
                 "inputs, forces, modes) or FILE.csv (a row per sample)."),
]


def check_out_suffix(out: Path | None) -> None:
    """Refuse, before any work, an ``--out`` file that is neither ``.npz`` nor ``.csv``.

    Raises:
        InputError: another suffix.
    """
    from frcontrol.simulation import TRAJECTORY_FORMATS

    if out is not None and out.suffix.lower() not in TRAJECTORY_FORMATS:
        raise InputError(f"--out {str(out)!r}: the suffix must be one of {', '.join(TRAJECTORY_FORMATS)}")


def scene_overrides(assignments: list[str] | None) -> dict[str, Any]:
    """The ``--set`` assignments as ``{path: value}`` (the last one wins for a repeated path).

    Raises:
        InputError: an assignment without ``=`` or without a path.
    """
    out: dict[str, Any] = {}
    for assignment in assignments or []:
        try:
            path, value = parse_override(assignment)
        except ValueError as err:
            raise InputError(f"--set: {err}") from err
        out[path] = value
    return out


def load_scene_with_overrides(scene: str, assignments: list[str] | None) -> Scene:
    """The scene a command names (a file or a shipped scene's name), with its ``--set`` overrides.

    The scene module (and Pinocchio) loads here, when a command runs, not for ``--help``.

    Raises:
        SceneError: see :func:`frcontrol.scene.load_scene`.
        InputError: see :func:`scene_overrides`.
    """
    from frcontrol.scene import load_scene

    return load_scene(scene, overrides=scene_overrides(assignments))


def plot_option(what: str) -> Any:
    """The ``--plot FILE`` option of a command, ``what`` saying what its figure shows."""
    return Annotated[
        Path | None,
        typer.Option("--plot", metavar="FILE",
                     help=f"Write a figure: {what} (PNG, or PDF/SVG... by the file's suffix)."),
    ]


def html_option(what: str) -> Any:
    """The ``--html FILE`` option of a command, ``what`` saying what its page shows."""
    return Annotated[
        Path | None,
        typer.Option("--html", metavar="FILE",
                     help=f"Write a self-contained HTML page (meshcat, works offline) of {what}; an "
                          "animation has play/pause, a time slider, and the time and contact mode as text."),
    ]


def view_option(what: str) -> Any:
    """The ``--view`` option of a command, ``what`` saying what it serves."""
    return Annotated[
        bool,
        typer.Option("--view", help=f"Serve {what} on a local meshcat server and print its URL; serve "
                     "until Ctrl-C or SIGTERM, then shut the server down."),
    ]


def margin_option(what: str) -> Any:
    """A planner's ``--margin`` option: the distance [N m] kept between ``what`` and other modes' inputs."""
    return Annotated[
        float,
        typer.Option("--margin", min=0.0, help=f"Distance [N m] kept between {what} and every input "
                     "where another contact mode also holds."),
    ]


def max_time_option(what: str) -> Any:
    """A closed-loop planner's ``--max-time`` option, ``what`` saying what 0 keeps."""
    return Annotated[
        float,
        typer.Option("--max-time", "-T", min=0.0,
                     help=f"Longest simulated time [s] of the closed loop (0: {what}, no simulation)."),
    ]


StepOpt = Annotated[float, typer.Option("--dt", min=1e-6, help="Time step [s] of the simulation.")]
"""A planner's simulation time step."""

ReplanOpt = Annotated[int, typer.Option("--replan-every", min=1, help="Steps between two plans.")]
"""Steps of a planner's closed loop between two plans."""

PortOpt = Annotated[
    int | None,
    typer.Option("--port", min=1, max=65535,
                 help="Port of the --view server (default: the first free port from 7000)."),
]

JsonOpt = Annotated[bool, typer.Option("--json", help="Print machine-readable JSON on stdout.")]


__all__ = [
    "InputOpt",
    "JsonOpt",
    "OutOpt",
    "PortOpt",
    "QuietOpt",
    "SceneArg",
    "SetOpt",
    "check_out_suffix",
    "html_option",
    "load_scene_with_overrides",
    "parse_inputs",
    "plot_option",
    "scene_argument",
    "scene_overrides",
    "view_option",
]
