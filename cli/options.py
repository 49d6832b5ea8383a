"""Options shared by several commands, defined once so that names and meanings agree everywhere."""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from frcontrol.errors import InputError, reason_from_exception
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


# ------------------------------------------------------------------------------ checked option values
# A bad option value is a usage error (exit 2, one line naming the option and what it accepts),
# raised while the command line is parsed, before any work: typer.BadParameter from the callbacks
# below. A value that is well formed but does not fit the scene (an unknown coordinate in --input,
# an unknown --set path) is bad input, exit 1, found when the scene is read.


class NumberRange:
    """An option's callback: the value (or each value of a repeated option) is a finite number in range.

    ``low``/``high`` are inclusive bounds, ``above`` an exclusive lower bound (``--dt`` > 0); any
    may be None. ``unit`` is shown in the message ("[s]").
    """

    def __init__(self, low: float | None = None, high: float | None = None, *, above: float | None = None,
                 unit: str = "") -> None:
        self.low, self.high, self.above, self.unit = low, high, above, unit

    def expected(self) -> str:
        """What the option accepts, in words: "a finite number > 0 [s]"."""
        bounds = [f"> {self.above:g}" if self.above is not None else "",
                  f">= {self.low:g}" if self.low is not None else "",
                  f"<= {self.high:g}" if self.high is not None else ""]
        text = " and ".join(b for b in bounds if b)
        return f"a finite number{' ' + text if text else ''}{' ' + self.unit if self.unit else ''}"

    def check(self, value: Any) -> Any:
        """The option's callback (Typer calls it with the parsed value)."""
        for number in value if isinstance(value, list | tuple) else [value]:
            if number is None:
                continue
            if (not math.isfinite(number) or (self.above is not None and not number > self.above)
                    or (self.low is not None and number < self.low)
                    or (self.high is not None and number > self.high)):
                raise typer.BadParameter(f"expected {self.expected()}, got {number!r}")
        return value


def in_range(low: float | None = None, high: float | None = None, *, above: float | None = None,
             unit: str = "") -> Callable[[Any], Any]:
    """The callback of a numeric option: :class:`NumberRange` ``(low, high, above, unit)``'s check."""
    return NumberRange(low, high, above=above, unit=unit).check


def worded_once(err: Any) -> None:
    """Reword a bad option value's usage error in place: one option name, the option's range.

    The option is named once, by its long name ("'--duration'", not "'--duration' / '-T'"), and a
    value that is not a number is answered with the option's range ("expected a finite number > 0
    [s], got 'abc'"), not the parser's words.
    """
    param = getattr(err, "param", None)
    if param is None or getattr(err, "param_hint", None) is not None:
        return
    names = [name for name in param.opts if name.startswith("--")] or list(param.opts)
    err.param_hint = f"'{names[0]}'"
    parsing = err.__cause__
    info = getattr(getattr(param, "type_descriptor", None), "parameter_info", None)
    limits = getattr(getattr(info, "callback", None), "__self__", None)
    if isinstance(limits, NumberRange) and hasattr(parsing, "errors") and parsing.errors():
        first = parsing.errors()[0]
        expected = limits.expected()
        if str(first.get("type", "")).startswith("int"):
            expected = expected.replace("a finite number", "a whole number")
        err.message = f"expected {expected}, got {first.get('input')!r}"
    elif err.message.startswith("Value error, "):  # a choice's check: its own words, without the parser's
        err.message = err.message.removeprefix("Value error, ").rstrip(".")


def usage_error(option: str, message: str) -> typer.BadParameter:
    """The exit-2 error to raise for a bad value of ``option`` found inside a command."""
    return typer.BadParameter(message, param_hint=f"'{option}'")


def grammar(parse: Callable[[list[str]], Any]) -> Callable[[Any], Any]:
    """A repeated option's callback: ``parse`` reads its values (an InputError: a bad value)."""

    def check(value: list[str] | None) -> list[str] | None:
        try:
            parse(value or [])
        except InputError as err:  # the option is named once, by the usage error
            raise typer.BadParameter(re.sub(r"^--[a-z-]+:? ", "", str(err))) from None
        return value

    return check

SetOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--set", metavar="PATH=VALUE", callback=grammar(lambda texts: scene_overrides(texts)),
        help="Override a scene field without editing the file, e.g. --set contacts.tip.mu=0.5, "
             "--set state.q=[0,0.45,2.0], --set gravity=3.7, --set model.stiffness=1e6 (VALUE is "
             "TOML; repeatable). Checked exactly like the file: an unknown path names the nearest one.",
    ),
]


InputOpt = Annotated[
    list[str] | None,
    typer.Option("--input", "-i", metavar="NAME=VALUE", callback=grammar(lambda pairs: parse_inputs(pairs)),
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


def check_output_path(option: str, path: Path, check_format: Callable[[Path], None] | None = None) -> None:
    """Refuse, before any work, an output file ``option`` cannot write: create and remove a probe file.

    An existing file is opened for appending (nothing is written to it); a new one is created and
    removed. ``check_format`` refuses a suffix the command does not write (an InputError).

    Raises:
        typer.BadParameter: the path is a directory, its folder does not exist, the probe fails
            (read-only, /proc, permission denied), or its format is refused; the message names the
            option and the path as given.
    """
    shown = repr(str(path))
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise usage_error(option, f"{shown}: cannot write: it is a directory, expected a file name")
    if not folder.is_dir():
        raise usage_error(option, f"{shown}: cannot write: the folder {str(folder)!r} does not exist")
    if check_format is not None:
        try:
            check_format(path)
        except InputError as err:
            raise usage_error(option, str(err).removeprefix(f"{option} ")) from None
    try:
        if path.exists():
            with open(path, "ab"):  # appending nothing: the file is left as it is
                pass
        else:
            with open(path, "xb"):
                pass
            os.remove(path)
    except OSError as err:
        raise usage_error(option, f"{shown}: cannot write: {reason_from_exception(err)}") from None


def check_image_suffix(path: Path) -> None:
    """Refuse a ``--plot`` file whose suffix is no image format matplotlib writes.

    Raises:
        InputError: another suffix.
    """
    from matplotlib.backend_bases import FigureCanvasBase

    formats = FigureCanvasBase.get_supported_filetypes()
    if path.suffix.lower().lstrip(".") not in formats:
        raise InputError(f"{str(path)!r}: the suffix must name an image format "
                         f"({', '.join('.' + f for f in sorted(formats))})")


def check_out_suffix(out: Path | None) -> None:
    """Refuse an ``--out`` trajectory file that is neither ``.npz`` nor ``.csv``.

    Raises:
        InputError: another suffix.
    """
    from frcontrol.simulation import TRAJECTORY_FORMATS

    if out is not None and out.suffix.lower() not in TRAJECTORY_FORMATS:
        raise InputError(f"--out {str(out)!r}: the suffix must be one of {', '.join(TRAJECTORY_FORMATS)}")


def output_path(option: str, check_format: Callable[[Path], None] | None = None) -> Callable[[Any], Any]:
    """The callback of an output file option: :func:`check_output_path` when it is given."""

    def check(path: Path | None) -> Path | None:
        if path is not None:
            check_output_path(option, path, check_format)
        return path

    return check


OutOpt = Annotated[
    Path | None,
    typer.Option("--out", metavar="FILE", callback=output_path("--out", check_out_suffix),
                 help="Export the trajectory: FILE.npz (arrays times, q, v, inputs, forces, modes) or "
                      "FILE.csv (a row per sample)."),
]


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
        typer.Option("--plot", metavar="FILE", callback=output_path("--plot", check_image_suffix),
                     help=f"Write a figure: {what} (PNG, or PDF/SVG... by the file's suffix)."),
    ]


def html_option(what: str) -> Any:
    """The ``--html FILE`` option of a command, ``what`` saying what its page shows."""
    return Annotated[
        Path | None,
        typer.Option("--html", metavar="FILE", callback=output_path("--html"),
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
        typer.Option("--margin", callback=in_range(low=0.0, unit="[N m]"),
                     help=f"Distance [N m] kept between {what} and every input where another contact mode "
                          "also holds."),
    ]


def duration_option(what: str) -> Any:
    """The ``--duration``/``-T`` option of a command that simulates: ``what`` the simulated time is."""
    return Annotated[
        float,
        typer.Option("--duration", "-T", callback=in_range(low=0.0, unit="[s]"), help=what),
    ]


MaxTimeAliasOpt = Annotated[
    float | None,
    typer.Option("--max-time", hidden=True, callback=in_range(low=0.0, unit="[s]"),
                 help="The former name of --duration, kept so that scripts keep working."),
]
"""``--max-time``: the planners' former name of ``--duration``, hidden from ``--help``."""


def duration_given(duration: float, max_time: float | None) -> float:
    """The simulated time asked for: ``--duration``, or its former name ``--max-time`` when given."""
    return duration if max_time is None else max_time


StepOpt = Annotated[
    float, typer.Option("--dt", callback=in_range(above=0.0, unit="[s]"),
                        help="Time step [s] of the simulation."),
]
"""A planner's simulation time step."""

ReplanOpt = Annotated[
    int, typer.Option("--replan-every", callback=in_range(low=1), help="Steps between two plans."),
]
"""Steps of a planner's closed loop between two plans."""

PortOpt = Annotated[
    int | None,
    typer.Option("--port", callback=in_range(low=1, high=65535),
                 help="Port of the --view server (default: the first free port from 7000)."),
]

JsonOpt = Annotated[bool, typer.Option("--json", help="Print machine-readable JSON on stdout.")]


__all__ = [
    "InputOpt",
    "JsonOpt",
    "MaxTimeAliasOpt",
    "NumberRange",
    "in_range",
    "OutOpt",
    "PortOpt",
    "QuietOpt",
    "ReplanOpt",
    "SceneArg",
    "SetOpt",
    "StepOpt",
    "check_image_suffix",
    "check_out_suffix",
    "check_output_path",
    "duration_given",
    "duration_option",
    "grammar",
    "html_option",
    "margin_option",
    "output_path",
    "usage_error",
    "worded_once",
    "load_scene_with_overrides",
    "parse_inputs",
    "plot_option",
    "scene_argument",
    "scene_overrides",
    "view_option",
]
