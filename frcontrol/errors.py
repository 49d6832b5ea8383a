"""Errors raised by frcontrol.

Every failure caused by the user's input is a subclass of :class:`FrcontrolError` carrying the
data that explains it, so that the command line can print one clear line and a program can react
to the cause. Results that are legitimately negative (an empty domain, an infeasible LP, Lemke's
method ending on a ray) are *results*, not exceptions.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path


class FrcontrolError(Exception):
    """Base class of every error frcontrol raises on purpose."""


@lru_cache(maxsize=1)
def _shipped_root() -> Path:
    from importlib import resources

    return Path(str(resources.files("frcontrol.robots"))).resolve()


def shown_path(path: str | Path) -> str:
    """A file as messages name it: a shipped scene by its name, a shipped robot by its file name.

    So that no message discloses where frcontrol is installed (``rod_on_table``, ``rod.urdf``,
    not ``/.../site-packages/frcontrol/robots/scenes/rod_on_table.toml``); any other path as given.
    """
    text = str(path)
    try:
        where = Path(text).resolve().relative_to(_shipped_root())
    except (ValueError, OSError, RuntimeError):  # not shipped, or not a path (a NUL, a loop)
        return text
    if where.parent == Path("scenes") and where.suffix == ".toml":
        return where.stem
    return where.as_posix()


def reason_from_exception(err: BaseException) -> str:
    """One line saying why a file operation failed, without an errno dump.

    An ``OSError`` gives its ``strerror`` ("No such file or directory"); anything else its message.
    """
    if isinstance(err, OSError) and err.strerror:
        return err.strerror[0].lower() + err.strerror[1:]
    return str(err).splitlines()[0] if str(err) else type(err).__name__


class SceneError(FrcontrolError):
    """A scene file is missing, unreadable, malformed or physically invalid.

    Attributes:
        path: the scene file (or URDF) concerned.
        field: the offending field, dotted (``contacts[1].mu``), or ``""`` for the whole file.
        reason: what is wrong and what was expected.
    """

    def __init__(self, path: str, field: str, reason: str) -> None:
        self.path = str(path)
        self.field = field
        self.reason = reason
        shown = shown_path(self.path)
        where = f"{shown}: {field}: " if field else f"{shown}: "
        super().__init__(where + reason)


class RobotModelError(FrcontrolError):
    """A URDF could not be turned into a planar Pinocchio model."""

    def __init__(self, path: str, reason: str) -> None:
        self.path = str(path)
        self.reason = reason
        super().__init__(f"{shown_path(self.path)}: {reason}")


class FrameNotFound(FrcontrolError):
    """A link or frame name does not exist in the robot model."""

    def __init__(self, name: str, available: Sequence[str]) -> None:
        self.name = name
        self.available = list(available)
        super().__init__(f"unknown link {name!r}; the robot has: {', '.join(self.available)}")


class CoordinateNotFound(FrcontrolError):
    """A coordinate name does not exist (inputs, disturbances, command-line ``--input``)."""

    def __init__(self, name: str, available: Sequence[str]) -> None:
        self.name = name
        self.available = list(available)
        super().__init__(
            f"unknown coordinate {name!r}; the coordinates are: {', '.join(self.available)}"
        )


class InputError(FrcontrolError):
    """A value handed to a library function is malformed (shape, NaN, outside its limits)."""


class LimitExceeded(InputError):
    """A value asks for more work or memory than a documented cap allows.

    Attributes:
        field: the argument that asks for it (``duration``, ``stiffness``...).
        value: what was asked (in the cap's unit).
        limit: the cap.
    """

    def __init__(self, field: str, value: float, limit: float, message: str) -> None:
        self.field = field
        self.value = value
        self.limit = limit
        super().__init__(message)


class KernelError(FrcontrolError):
    """The compiled kernel cannot be used as asked.

    ``FRC_KERNEL`` names no kernel, the compiled kernel is asked for but not built, or a buffer
    handed to it has the wrong dtype, shape or memory layout.
    """


class StaleKernelWarning(UserWarning):
    """The compiled kernel was built from another ``_kernel.c`` than the one beside it.

    An editable install not rebuilt after a change to the C source: the NumPy kernel runs instead
    (:func:`frcontrol.kernel.stale_reason`); ``pip install -e .`` rebuilds it.
    """


class IllConditioned(FrcontrolError):
    """A matrix is too ill-conditioned to trust the answer at the stated tolerance."""

    def __init__(self, matrix_name: str, condition_number: float, tolerance: float) -> None:
        self.matrix_name = matrix_name
        self.condition_number = float(condition_number)
        self.tolerance = float(tolerance)
        super().__init__(
            f"{matrix_name} is ill-conditioned: condition number {condition_number:.3g} "
            f"exceeds 1/tolerance = {1.0 / tolerance:.3g}"
        )


class ImpactState(FrcontrolError):
    """A contact moves into its surface (v_n < 0): an impact, not an acceleration problem."""

    def __init__(self, contact: str, normal_velocity: float) -> None:
        self.contact = contact
        self.normal_velocity = float(normal_velocity)
        super().__init__(
            f"contact {contact!r} moves into its surface (v_n = {normal_velocity:.6g} m/s < 0): "
            "this is an impact, not an acceleration-level problem; resolve the impact first"
        )


class AtlasInterrupted(FrcontrolError):
    """An atlas stopped before its last chunk.

    A signal, a lost scheduler or a chunk that kills its workers; the chunks finished so far are
    kept when the run writes ``--out``.
    """


class ChunkTimeLimitExceeded(AtlasInterrupted):
    """An atlas chunk ran past the run's time limit per chunk; its worker was stopped."""


class SolverNotFound(FrcontrolError):
    """The requested LP/QP back-end is unknown or not installed."""

    def __init__(self, name: str, available: Sequence[str], source: str = "") -> None:
        self.name = name
        self.available = list(available)
        origin = f" (from {source})" if source else ""
        super().__init__(
            f"solver {name!r}{origin} is not available; installed back-ends: {', '.join(self.available)}"
        )


__all__ = [
    "StaleKernelWarning",
    "AtlasInterrupted",
    "ChunkTimeLimitExceeded",
    "CoordinateNotFound",
    "FrameNotFound",
    "FrcontrolError",
    "IllConditioned",
    "ImpactState",
    "InputError",
    "LimitExceeded",
    "reason_from_exception",
    "RobotModelError",
    "SceneError",
    "SolverNotFound",
    "shown_path",
]
