"""Which implementation decides the certified modes of :func:`frcontrol.mode_batch.decide_modes`.

Two implementations give the same answers (to round-off, see :data:`CERTIFIED_ROUND_OFF_BAND`):

- ``"compiled"``: :mod:`frcontrol._kernel`, a small C extension built by ``pip install .``; per
  mode it assembles ``A`` from the contact row table, equilibrates it by powers of two, solves by
  LU with partial pivoting, applies the :data:`~frcontrol.mode_batch.CERTIFIED_MARGIN` bound and
  decides the inequality rows at ``u``, all in one call (NumPy's per-call overhead is what limits
  the NumPy path on small problems).
- ``"numpy"``: the reference, the NumPy code of :mod:`frcontrol.mode_batch`.

The environment variable ``FRC_KERNEL`` chooses (``numpy`` or ``compiled``); unset or empty, the
compiled kernel when it is built, else NumPy. An unknown value, or ``compiled`` where the extension
was not built, raises :class:`~frcontrol.errors.KernelError`. An extension built from another
``_kernel.c`` than the one beside it (an editable install not rebuilt after a change) is not used:
a ``RuntimeWarning`` says so and NumPy runs (:func:`stale_reason`). Modes the bound does not certify go
to the batched SVD in NumPy on either path. The same switch chooses how the LP door
(:mod:`frcontrol.solvers`) checks an answer: ``lp_check`` of the extension, or NumPy's
:func:`~frcontrol.solvers.primal_residual` and residual tolerance (equal to round-off).
"""

from __future__ import annotations

import hashlib
import os
import warnings
from pathlib import Path
from types import ModuleType

from .errors import KernelError, StaleKernelWarning

KERNEL_VARIABLE = "FRC_KERNEL"
"""The environment variable that chooses the kernel."""

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


def kernel_choice() -> str:
    """The kernel in force: ``FRC_KERNEL``, or by default the compiled one when it is built.

    Unset, with a stale extension (:func:`stale_reason`), it warns (:class:`StaleKernelWarning`).

    Raises:
        KernelError: ``FRC_KERNEL`` names no kernel, or asks for the compiled one where it was not
            built or is stale.
    """
    value = os.environ.get(KERNEL_VARIABLE, "")
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


__all__ = ["CERTIFIED_ROUND_OFF_BAND", "compiled", "kernel_choice", "KERNEL_VARIABLE", "KERNELS", "NOT_BUILT",
           "stale_reason", "unavailable"]
