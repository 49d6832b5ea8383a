"""The kernel behind one seam: one backend object, NumPy's or the compiled extension's.

The hot loops of the analysis, the queries, the LCP and the simulation have two implementations
that give the same answers (to round-off, see :data:`CERTIFIED_ROUND_OFF_BAND`):

- ``"compiled"``: :mod:`frcontrol._kernel`, a small C extension built by ``pip install .``
  (plain C against the CPython API and the buffer protocol; NumPy's per-call overhead is what
  limits the NumPy code on small problems);
- ``"numpy"``: the reference, the NumPy twin of every compiled function, kept in the module that
  uses it.

A module registers each of its functions once, at import, with :func:`twin` (a name, the NumPy twin
and the compiled implementation, the same signature); it then calls ``backend().name(...)``, never
branching on the kernel. :func:`backend` returns the backend in force, :data:`NUMPY` or
:data:`COMPILED`, whose functions are plain attributes bound at registration (a call costs one
attribute lookup). A new compiled function plugs in there: write it in ``_kernel.c`` (its
arguments described by one table, parsed by ``parse``), its NumPy twin beside its caller, one
:func:`twin` line, and a cross-check in the tests (``tests/test_kernel.py`` checks that every
registered function is offered by both backends with one signature).

How the backend is chosen, the one place that says it: the environment variable ``FRC_KERNEL``
(``numpy`` or ``compiled``), read on every :func:`backend` call; unset or empty, the compiled
kernel when it is built, else NumPy. An unknown value, or ``compiled`` where the extension was not
built, raises :class:`~frcontrol.errors.KernelError`. An extension built from another ``_kernel.c``
than the one beside it (an editable install not rebuilt after a change) is not used: a
``RuntimeWarning`` says so once and NumPy runs (:func:`stale_reason`).

The LP door (:mod:`frcontrol.solvers`) does not import the kernel: its callers hand it the
backend's ``lp_check`` (:class:`~frcontrol.solvers.InequalityLPs`).
"""

from __future__ import annotations

import hashlib
import os
import warnings
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

from .errors import KernelError, StaleKernelWarning

KERNEL_VARIABLE = "FRC_KERNEL"
"""The environment variable that chooses the kernel."""

_VARIABLE_NAME = KERNEL_VARIABLE.encode()
"""``FRC_KERNEL`` as the compiled kernel's ``environment_value`` reads it (:func:`_variable_value`)."""

KERNELS = ("numpy", "compiled")
"""The kernels ``FRC_KERNEL`` may name."""

CERTIFIED_ROUND_OFF_BAND = 1e-6
"""Relative width of the band around the certification threshold (``bound * CERTIFIED_MARGIN *
tolerance = 1``) inside which the two kernels may decide a mode differently: their Frobenius
norms and LU solves sum in different orders, and ``||A_hat^-1||_F`` carries a relative error up to
about ``cond * eps``, some 1e-9 at the threshold's condition numbers (1e7); the band is wider.
Such a mode is certified by one kernel and sent to the SVD by the other, and both give the same
response: it is full rank outside the ill-conditioned band either way."""


NOT_BUILT = "the extension frcontrol._kernel was not built (reinstall with a C compiler: pip install .)"
"""Why the compiled kernel is unavailable, when it was not built."""


def stale_reason(module: ModuleType, source: Path) -> str | None:
    """Why ``module`` does not run ``source``, or None when it does (or no source is beside it).

    The build compiles the SHA-256 of ``frcontrol/_kernel.c`` into the extension
    (``SOURCE_SHA256``, setup.py). An editable install (``pip install -e .``) builds it in place
    and leaves the source beside it: when that source has changed since, the extension runs other
    code than the source says. Without a source beside it, there is nothing to compare.
    """
    if not source.is_file():
        return None
    built = getattr(module, "SOURCE_SHA256", "")
    if built == hashlib.sha256(source.read_bytes()).hexdigest():
        return None
    return (f"the extension frcontrol._kernel was built from another {source.name} than the one beside it "
            "(rebuild it: pip install -e .)")


def _load_compiled() -> tuple[ModuleType | None, str | None]:
    """The extension, or None and why not (not built, or built from another source)."""
    try:
        from . import _kernel
    except ImportError:
        return None, NOT_BUILT
    stale = stale_reason(_kernel, Path(__file__).with_name("_kernel.c"))
    return (None, stale) if stale is not None else (_kernel, None)


compiled, unavailable = _load_compiled()
"""The compiled extension :mod:`frcontrol._kernel`, or None where it was not built or is stale (its
source changed since it was built: :func:`stale_reason`); ``unavailable`` says which, else None."""


_stale_said = False
"""Whether this process was told that the extension is stale (:func:`kernel_choice` says it once)."""


def _variable_value() -> str:
    """``FRC_KERNEL``'s value, "" when unset.

    Read with C's ``getenv`` by the compiled kernel where it is in use (0.1 us against
    ``os.environ``'s 0.6 us per :func:`backend`), else from ``os.environ``.

    Both see every change made through ``os.environ`` (which calls ``putenv`` and ``unsetenv``); set
    the variable that way (``os.putenv`` or ``os.unsetenv`` alone leave ``os.environ`` behind).
    """
    if compiled is not None:
        return str(compiled.environment_value(_VARIABLE_NAME))
    return os.environ.get(KERNEL_VARIABLE, "")


def kernel_choice() -> str:
    """The kernel in force: ``FRC_KERNEL``, or by default the compiled one when it is built.

    Unset, with a stale extension (:func:`stale_reason`), it warns (:class:`StaleKernelWarning`).

    Raises:
        KernelError: ``FRC_KERNEL`` names no kernel, or asks for the compiled one where it was not
            built or is stale.
    """
    value = _variable_value()
    if not value:
        global _stale_said
        if compiled is None and unavailable != NOT_BUILT and not _stale_said:  # stale: say so, once
            _stale_said = True
            warnings.warn(f"{unavailable}; the NumPy kernel runs instead", StaleKernelWarning, stacklevel=2)
        return "compiled" if compiled is not None else "numpy"
    if value not in KERNELS:
        raise KernelError(f"{KERNEL_VARIABLE}={value!r} names no kernel; valid: {', '.join(KERNELS)}")
    if value == "compiled" and compiled is None:
        raise KernelError(f"{KERNEL_VARIABLE}=compiled, but {unavailable}")
    return value


class Backend:
    """One implementation of the kernel's functions: ``name`` is ``"numpy"`` or ``"compiled"``.

    Its functions are plain instance attributes, set once by :func:`twin`: calling one costs an
    attribute lookup and the call, no dispatch.
    """

    def __init__(self, name: str) -> None:
        self.name = name

    def __getattr__(self, function: str) -> Any:  # only for a name never registered
        if function.startswith("__"):  # a protocol Python probes for (copy, pickle): not a kernel function
            raise AttributeError(function)
        raise KernelError(f"the {self.name} kernel has no function {function!r}; registered: "
                          f"{', '.join(sorted(_REGISTERED)) or 'none'}")

    def __repr__(self) -> str:
        return f"<frcontrol kernel backend {self.name!r}>"


NUMPY = Backend("numpy")
"""The NumPy backend: the reference twins."""

COMPILED = Backend("compiled")
"""The compiled backend: :mod:`frcontrol._kernel` (its functions, or Python wrappers calling them)."""

_BACKENDS = {"numpy": NUMPY, "compiled": COMPILED}

_REGISTERED: dict[str, str] = {}
"""The registered functions' names, and the module each was registered from."""


def twin(name: str, numpy: Callable[..., Any], compiled: Callable[..., Any]) -> None:
    """Register the kernel's function ``name``: its NumPy twin and its compiled implementation.

    Both take the same arguments and give the same answers (to round-off); the cross-checks in the
    tests run each on both backends. Registering a name again from the same module (a reload)
    replaces it.

    Raises:
        KernelError: ``name`` is already registered from another module.
    """
    owner = getattr(numpy, "__module__", "?")
    if _REGISTERED.setdefault(name, owner) != owner:
        raise KernelError(f"the kernel's function {name!r} is registered twice: by {_REGISTERED[name]} "
                          f"and by {owner}")
    setattr(NUMPY, name, numpy)
    setattr(COMPILED, name, compiled)


def extension_function(name: str) -> Callable[..., Any]:
    """The extension's function ``name``, or one that raises :class:`~frcontrol.errors.KernelError`.

    Where the extension is not in use, the function says why (:func:`backend` never returns
    :data:`COMPILED` then).
    """
    if compiled is not None:
        return getattr(compiled, name)

    def not_built(*args: Any) -> Any:
        raise KernelError(f"the compiled kernel's {name} cannot run: {unavailable}")
    return not_built


def registered() -> dict[str, str]:
    """The registered functions' names, and the module each was registered from."""
    return dict(_REGISTERED)


def backend() -> Backend:
    """The backend in force (:func:`kernel_choice`): :data:`COMPILED` or :data:`NUMPY`.

    Raises:
        KernelError: as :func:`kernel_choice`.
    """
    if compiled is not None and not compiled.environment_value(_VARIABLE_NAME):
        return COMPILED
    return _BACKENDS[kernel_choice()]


__all__ = ["Backend", "backend", "CERTIFIED_ROUND_OFF_BAND", "COMPILED", "compiled", "extension_function",
           "kernel_choice", "KERNEL_VARIABLE", "KERNELS", "NOT_BUILT", "NUMPY", "registered", "stale_reason",
           "twin", "unavailable"]
