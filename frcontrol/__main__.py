"""``python -m frcontrol``: the ``frc`` command line."""

from frcontrol.cli.app import main

main()
