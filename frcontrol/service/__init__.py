"""The planning service (``frc serve``): frcontrol's commands as JSON over HTTP for other programs.

``create_app(ServiceConfig(...))`` builds the FastAPI application (``pip install "frcontrol[serve]"``);
each endpoint answers with the matching command's ``--json`` document, built by the same library
calls (:mod:`frcontrol.answers`). The work runs in worker processes (:mod:`.pool`) with a time limit
per request; requests are strict pydantic models (:mod:`.models`); scenes come by a shipped name or
by content, never by a path (:mod:`.work`). ``POST /atlas`` runs ``frc atlas`` as a job on its own
local pool or a Dask cluster (:mod:`.atlas_job`). FastAPI loads only when this package is imported.
"""

from __future__ import annotations

from .api import API_VERSION, ENDPOINTS, ServiceConfig, create_app

__all__ = [
    "API_VERSION",
    "ENDPOINTS",
    "ServiceConfig",
    "create_app",
]
