"""``frc schema`` and ``frc validate``: the scene format, and checking files against it."""

from __future__ import annotations

import json
import sys
from typing import Annotated

import typer

from frcontrol.errors import SceneError
from frcontrol.scene_schema import SCENE_SCHEMA

from .common import handle_errors, note, print_json, set_quiet
from .options import JsonOpt, QuietOpt


@handle_errors
def schema_command(
    json_output: Annotated[bool, typer.Option("--json", help="Accepted for uniformity: the schema is JSON.")]
    = False,
    quiet: QuietOpt = False,
) -> None:
    """Print the scene format as a JSON Schema (draft 2020-12).

    \b
    Example:
      frc schema --json
    """
    set_quiet(quiet)
    sys.stdout.write(json.dumps(SCENE_SCHEMA, indent=2) + "\n")


@handle_errors
def validate_command(
    files: Annotated[list[str], typer.Argument(metavar="FILE",
                                               help="Scene files, or names of shipped scenes.")],
    json_output: JsonOpt = False,
    quiet: QuietOpt = False,
) -> None:
    """Check scene files: exit 0 when all are valid, else 1 with one line per problem on stderr.

    \b
    Examples:
      frc validate rod_on_table rhex_flip
      frc validate snake_climb --json
    """
    set_quiet(quiet)
    from frcontrol.scene import resolve_scene_path, scene_problems

    reports = []
    for name in files:
        problems = scene_problems(name)
        try:
            shown = str(resolve_scene_path(name))
        except SceneError:  # a missing file: one of its problems, already listed
            shown = name
        reports.append({"file": shown, "valid": not problems,
                        "problems": [{"field": p.field, "reason": p.reason} for p in problems]})
        for p in problems:
            where = f"{shown}: {p.field}: " if p.field else f"{shown}: "
            sys.stderr.write(f"frc: error: {where}{p.reason}\n")
    if json_output:
        print_json({"valid": all(r["valid"] for r in reports), "files": reports})
    else:
        for r in reports:
            if r["valid"]:
                note(f"{r['file']}: valid")
    if not all(r["valid"] for r in reports):
        raise typer.Exit(code=1)


__all__ = ["schema_command", "validate_command"]
