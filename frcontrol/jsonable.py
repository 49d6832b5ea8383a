"""Plain JSON values from results: what every ``to_dict()`` returns.

:func:`to_jsonable` turns NumPy arrays and scalars into lists, floats, ints and bools, recursively;
:func:`finite_or_none` maps an infinite or undefined float to ``None`` (JSON ``null``), for the
fields where infinity means "no bound" or "undefined". A non-finite number anywhere else is a bug,
and :func:`to_jsonable` refuses it rather than write ``NaN`` (which is not JSON).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import FrcontrolError

__all__ = ["finite_or_none", "to_jsonable"]


def finite_or_none(x: float | None) -> float | None:
    """A finite float, or None (JSON null) for an infinite, undefined or absent one."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def to_jsonable(value: Any) -> Any:
    """Convert NumPy arrays and scalars to plain JSON types; refuse NaN and infinities.

    Raises:
        FrcontrolError: a non-finite number reached the output (a bug: it names the value).
    """
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        x = float(value)
        if not math.isfinite(x):
            raise FrcontrolError(f"internal error: a non-finite number ({x}) reached the output")
        return x
    return value
