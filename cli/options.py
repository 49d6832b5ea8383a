"""Options shared by several commands, defined once so that names and meanings agree everywhere."""

from __future__ import annotations

from typing import Annotated, Any

import typer

from frcontrol.errors import InputError
from frcontrol.scene_schema import parse_override

SetOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--set", metavar="PATH=VALUE",
        help="Override a scene field without editing the file, e.g. --set contacts.tip.mu=0.5, "
             "--set state.q=[0,0.45,2.0], --set gravity=3.7, --set model.stiffness=1e6 (VALUE is "
             "TOML; repeatable). Checked exactly like the file: an unknown path names the nearest one.",
    ),
]


QuietOpt = Annotated[
    bool,
    typer.Option("--quiet", "-q", help="Print only the answer: no progress display and no notes such as "
                 "'wrote FILE' (errors and the simulation's validity warnings still go to stderr)."),
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


__all__ = ["QuietOpt", "SetOpt", "scene_overrides"]
