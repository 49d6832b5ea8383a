"""The ``frc`` application: one Typer app, one module per command group."""

from __future__ import annotations

import sys
import warnings
from collections.abc import Sequence
from typing import Any

import typer
from typer._click.exceptions import ClickException, NoArgsIsHelpError, UsageError
from typer.core import TyperGroup
from typer.exceptions import Abort

from frcontrol.errors import KernelError, StaleKernelWarning
from frcontrol.kernel import kernel_choice

from . import (
    analyze_cmd,
    atlas_cmd,
    climb_cmd,
    flip_cmd,
    model_cmds,
    plan_cmd,
    scene_cmds,
    serve_cmd,
    simulate_cmd,
    standup_cmd,
    statics_cmd,
    view_cmd,
)
from .common import Interrupted, fail
from .options import worded_once


class FrcGroup(TyperGroup):
    """The ``frc`` command group: the one place where a run's end becomes an exit code.

    A usage error (an unknown option, a missing argument, a bad option value) is one line on
    stderr and exit 2; Ctrl-C is one line, ``frc: error: interrupted by SIGINT``, and exit 130.
    """

    def invoke(self, ctx: Any) -> Any:
        """Run the command; Ctrl-C (KeyboardInterrupt) wherever it lands becomes :class:`Interrupted`."""
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            raise Interrupted() from None

    def main(self, args: Sequence[str] | None = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True, **extra: Any) -> Any:
        """Parse and run; print any usage error or interruption as one line; exit with its code."""
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except NoArgsIsHelpError as err:  # bare `frc`: the help, as before
            err.show()
            code = err.exit_code
        except ClickException as err:
            worded_once(err)
            hint = f" (see '{err.ctx.command_path} -h')" if isinstance(err, UsageError) and err.ctx else ""
            message = " ".join(err.format_message().split())
            sys.stderr.write(f"frc: error: {message}{hint}\n")
            code = err.exit_code
        except (Abort, KeyboardInterrupt):
            sys.stderr.write("frc: error: interrupted by SIGINT\n")
            code = 130
        except Interrupted as err:
            sys.stderr.write(f"frc: error: {err}\n")
            code = err.exit_code
        else:
            if code == 130:  # Typer's own exit for a Ctrl-C while the command line is read: silent
                sys.stderr.write("frc: error: interrupted by SIGINT\n")
        if code in (130, 143):
            _exit_code_as_given()
        if not standalone_mode:
            return code
        sys.exit(code if isinstance(code, int) else 0)


def _exit_code_as_given() -> None:
    """Keep an interrupted run's exit code (130, 143) as it is, whatever ran when the signal came.

    CPython remembers a KeyboardInterrupt that ended code it ran for a C extension (Boost.Python's
    ``exec``, which Pinocchio calls) even when the command caught it, and ``python -m`` then ends
    the process by SIGINT instead of with the code it was given. SIGINT is blocked for the last
    moments of the run (the cleanup at exit): that self-signal stays pending, and the code stands.
    """
    import signal

    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})


app = typer.Typer(
    name="frc",
    cls=FrcGroup,
    help="frcontrol: contact modes, mode domains, ambiguity and planning for planar robots in contact.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
    rich_markup_mode=None,  # help texts say [s], [N m], [model]: literal text, not markup
)


def _version(value: bool) -> None:
    if value:
        from importlib.metadata import PackageNotFoundError, version

        try:
            typer.echo(f"frcontrol {version('frcontrol')}")
        except PackageNotFoundError:  # run from a source tree that is not installed
            typer.echo("frcontrol (not installed)")
        raise typer.Exit()


@app.callback()
def _root(
    show_version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                      help="Print the version and exit."),
) -> None:
    """frcontrol: contact modes, mode domains, ambiguity and planning for planar robots in contact."""
    # Floating-point warnings (overflow in a run that diverges) would add lines to stderr: the
    # library reports what they mean (a diverged status, a warning with its time and detail).
    warnings.filterwarnings("ignore", category=RuntimeWarning)
    try:  # FRC_KERNEL (frcontrol.kernel) is checked once, before any command runs
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", StaleKernelWarning)
            kernel_choice()
    except KernelError as err:
        raise fail(str(err)) from None
    for warning in caught:  # a stale compiled kernel: one line, and NumPy runs
        typer.echo(f"frc: warning: {warning.message}", err=True)
app.command("robots")(model_cmds.robots)
app.command("show")(model_cmds.show)
app.command("analyze")(analyze_cmd.analyze_command)
app.command("statics")(statics_cmd.statics_command)
app.command("view")(view_cmd.view_command)
app.command("simulate")(simulate_cmd.simulate_command)
app.command("flip")(flip_cmd.flip_command)
app.command("climb")(climb_cmd.climb_command)
app.command("standup")(standup_cmd.standup_command)
app.command("plan")(plan_cmd.plan_command)
app.command("atlas")(atlas_cmd.atlas_command)
app.command("schema")(scene_cmds.schema_command)
app.command("validate")(scene_cmds.validate_command)
app.command("serve")(serve_cmd.serve_command)


def main() -> None:
    """Entry point of the ``frc`` and ``frcontrol`` console scripts."""
    app()


__all__ = [
    "FrcGroup",
    "app",
    "main",
]
