"""Shared pieces of the command line: error handling, JSON output, the console."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
from functools import wraps
from typing import Any, ParamSpec, TypeVar

import numpy as np
import typer
from rich.console import Console

from frcontrol.errors import FrcontrolError

console = Console()
P = ParamSpec("P")
R = TypeVar("R")


def fail(message: str) -> typer.Exit:
    """Print one line on stderr and return the exit (code 1) to raise."""
    sys.stderr.write(f"frc: error: {message}\n")
    return typer.Exit(code=1)


def handle_errors(func: Callable[P, R]) -> Callable[P, R]:
    """Turn every FrcontrolError into one line on stderr and exit code 1 (never a traceback)."""

    @wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return func(*args, **kwargs)
        except FrcontrolError as err:
            raise fail(str(err)) from None

    return wrapper


def to_jsonable(value: Any) -> Any:
    """Convert numpy arrays and scalars to plain JSON types; refuse NaN and infinities."""
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


def print_json(payload: dict[str, Any]) -> None:
    """Write a JSON document on stdout."""
    sys.stdout.write(json.dumps(to_jsonable(payload), indent=2) + "\n")
