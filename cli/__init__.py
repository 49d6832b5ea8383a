"""The ``frc`` command line: parse, call the library, render. No algorithms live here."""
