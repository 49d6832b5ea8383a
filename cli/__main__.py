"""``python -m frcontrol.cli``: the ``frc`` command line."""

from . import main

main()
