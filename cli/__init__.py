"""The ``frc`` command line: parse, call the library, render. No algorithms live here."""

import sys

INTERRUPTED_EXIT = 130
"""The exit code of a run stopped by SIGINT (128 + 2), as a shell reports it."""


def main() -> None:
    """Entry point of the ``frc`` and ``frcontrol`` console scripts.

    The command line is imported here, inside the entry point, so that a Ctrl-C while it loads
    (Typer, NumPy) ends like one during a command: one line on stderr and exit 130, no traceback.
    """
    try:
        from .app import main as run
    except KeyboardInterrupt:
        sys.stderr.write("frc: error: interrupted by SIGINT\n")
        raise SystemExit(INTERRUPTED_EXIT) from None
    run()


__all__ = ["INTERRUPTED_EXIT", "main"]
