"""``python -m frcontrol``: the ``frc`` command line."""

from frcontrol.cli import main

main()
