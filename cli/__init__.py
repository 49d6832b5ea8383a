"""The ``frc`` command line: parse, call the library, render. No algorithms live here."""

__all__: list[str] = []  # the command modules are imported by frcontrol.cli.app
