"""The viewer's and the figures' errors.

Each carries the data that explains it as attributes, set in one place (:class:`VizError`), and a
message built from them.
"""

from __future__ import annotations

from pathlib import Path

from frcontrol.errors import FrcontrolError

__all__ = ["OutputFileError", "PortInUse", "ViewerServerError", "VizError"]


class VizError(FrcontrolError):
    """Base class of the errors raised while drawing, writing or serving a picture.

    Args:
        message: the one line shown to the user.
        **data: the error's data, kept as attributes of the same names.
    """

    def __init__(self, message: str, **data: object) -> None:
        for name, value in data.items():
            setattr(self, name, value)
        super().__init__(message)


class PortInUse(VizError):
    """The port asked for the meshcat server is already taken on this machine.

    Attributes:
        host: the interface the server would listen on.
        port: the port asked for.
    """

    host: str
    port: int

    def __init__(self, host: str, port: int) -> None:
        super().__init__(f"port {port} on {host} is already in use: choose another port, or give none "
                         "to let meshcat take the first free one from 7000", host=host, port=int(port))


class ViewerServerError(VizError):
    """The meshcat server could not be started (or stopped answering).

    Attributes:
        reason: what went wrong.
    """

    reason: str

    def __init__(self, reason: str) -> None:
        super().__init__(f"meshcat server: {reason}", reason=reason)


class OutputFileError(VizError):
    """A picture or page could not be written where asked.

    Attributes:
        path: the file asked for.
        reason: what went wrong.
    """

    path: str
    reason: str

    def __init__(self, path: str | Path, reason: str) -> None:
        super().__init__(f"cannot write {path}: {reason}", path=str(path), reason=reason)
