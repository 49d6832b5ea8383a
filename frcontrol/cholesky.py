"""Cholesky factor and solves of a symmetric positive-definite matrix, by LAPACK directly.

``scipy.linalg.cho_factor`` and ``cho_solve`` call these same routines (``potrf``, ``potrs``) after
checks and conversions that cost more than the factorisation of a robot's small mass matrix; the
callers here hand over finite float64 arrays, so the answers are the same, number for number.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg


def cholesky_upper(matrix: np.ndarray) -> np.ndarray:
    """``scipy.linalg.cho_factor(matrix)``'s upper factor, by the same LAPACK call (``potrf``).

    Raises:
        numpy.linalg.LinAlgError: the matrix is not positive definite.
    """
    potrf = scipy.linalg.lapack.dpotrf if matrix.dtype == np.float64 else scipy.linalg.get_lapack_funcs(
        "potrf", (matrix,))
    factor, info = potrf(matrix, lower=False, clean=False, overwrite_a=False)
    if info != 0:
        raise np.linalg.LinAlgError(f"the matrix is not positive definite (potrf info {info})")
    return factor


def cholesky_solve(factor: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``scipy.linalg.cho_solve((factor, False), rhs)`` by the same LAPACK call (``potrs``).

    Raises:
        numpy.linalg.LinAlgError: LAPACK refused the arguments.
    """
    x, info = scipy.linalg.lapack.dpotrs(factor, rhs, lower=False, overwrite_b=False)
    if info != 0:
        raise np.linalg.LinAlgError(f"potrs failed (info {info})")
    return x


__all__ = ["cholesky_solve", "cholesky_upper"]
