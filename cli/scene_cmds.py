"""``frc schema`` and ``frc validate``: the scene format, and checking files against it."""

from __future__ import annotations

import json
import sys
from typing import Annotated

import typer

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
    from frcontrol.answers import schema_answer

    sys.stdout.write(json.dumps(schema_answer().document, indent=2) + "\n")


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
    from frcontrol.answers import validation_answer, validation_problems

    document = validation_answer(files).document
    for _, line in validation_problems(document):
        sys.stderr.write(f"frc: error: {line}\n")
    if json_output:
        print_json(document)
    else:
        for r in document["files"]:
            if r["valid"]:
                note(f"{r['file']}: valid")
    if not document["valid"]:
        raise typer.Exit(code=1)


__all__ = ["schema_command", "validate_command"]
