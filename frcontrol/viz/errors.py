"""The viewer's and the figures' errors."""

from __future__ import annotations

from pathlib import Path

from frcontrol.errors import FrcontrolError

__all__ = ["OutputFileError", "PortInUse", "ViewerServerError", "VizError"]


class VizError(FrcontrolError):
    """Base class of the errors raised while drawing, writing or serving a picture."""


class PortInUse(VizError):
    """The port asked for the meshcat server is already taken on this machine.

    Attributes:
        host: the interface the server would listen on.
        port: the port asked for.
    """

    def __init__(self, host: str, port: int) -> None:
        self.host = host
        self.port = int(port)
        super().__init__(
            f"port {port} on {host} is already in use: choose another port, or give none to let "
            "meshcat take the first free one from 7000"
        )


class ViewerServerError(VizError):
    """The meshcat server could not be started (or stopped answering)."""

    def __init__(self, reason: str) -> None:
        self.reason = reason
        super().__init__(f"meshcat server: {reason}")


class OutputFileError(VizError):
    """A picture or page could not be written where asked.

    Attributes:
        path: the file asked for.
        reason: what went wrong.
    """

    def __init__(self, path: str | Path, reason: str) -> None:
        self.path = str(path)
        self.reason = reason
        super().__init__(f"cannot write {self.path}: {reason}")
