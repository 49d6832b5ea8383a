"""``python -m frcontrol.cli``: the ``frc`` command line."""

from .app import main

main()
