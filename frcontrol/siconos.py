"""Siconos test-problem files: LCPs and 2-D frictional contact problems, as text ``.dat`` files.

The readers parse Siconos' NumericsMatrix text format (dense, or sparse blocks) and the
FrictionContact2D layout, checking every count and value; a malformed file raises an
:class:`~frcontrol.errors.InputError` naming the file, the line and what was expected. The
problems themselves live in :mod:`frcontrol.lcp`.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from frcontrol.errors import InputError
from frcontrol.lcp import FrictionContact2D

__all__ = ["read_siconos_fc2d", "read_siconos_lcp"]


class _Tokens:
    """Whitespace-separated tokens of a text file, each with its line number."""

    def __init__(self, path: Path) -> None:
        self.path = path
        try:
            text = path.read_text()
        except (OSError, UnicodeDecodeError) as exc:
            raise InputError(f"{path}: cannot read the file: {exc}") from exc
        lines = text.splitlines()
        self.items = [
            (token, number) for number, line in enumerate(lines, start=1) for token in line.split()
        ]
        self.position = 0
        self.last_line = max(1, len(lines))

    @property
    def line(self) -> int:
        """Line of the last token read (1 before any)."""
        return self.items[self.position - 1][1] if self.position else 1

    def error(self, line: int, message: str) -> InputError:
        return InputError(f"{self.path}, line {line}: {message}")

    def _next(self, what: str) -> tuple[str, int]:
        if self.position >= len(self.items):
            raise self.error(self.last_line, f"unexpected end of file, expected {what}")
        item = self.items[self.position]
        self.position += 1
        return item

    def integer(self, what: str, minimum: int = 0) -> int:
        token, line = self._next(what)
        try:
            value = int(token)
        except ValueError:
            raise self.error(line, f"expected {what} (an integer), found {token!r}") from None
        if value < minimum:
            raise self.error(line, f"{what} must be at least {minimum}, found {value}")
        return value

    def expect(self, value: int, what: str) -> None:
        token, line = self._next(what)
        if token != str(value):
            raise self.error(line, f"expected {what} = {value}, found {token!r}")

    def floats(self, count: int, what: str) -> np.ndarray:
        values = np.empty(count)
        for k in range(count):
            token, line = self._next(f"{what} (entry {k + 1} of {count})")
            try:
                values[k] = float(token)
            except ValueError:
                raise self.error(
                    line, f"expected {what} (entry {k + 1} of {count}), found {token!r}"
                ) from None
            if not math.isfinite(values[k]):
                raise self.error(line, f"{what} entry {k + 1} is not finite: {token!r}")
        return values


def _read_block_sizes(tokens: _Tokens, count: int, total: int, what: str) -> list[int]:
    """Cumulative block sizes (strictly increasing, ending at ``total``), prefixed with 0."""
    offsets = [0]
    for k in range(count):
        offsets.append(tokens.integer(f"{what} {k + 1}", minimum=offsets[-1] + 1))
    if offsets[-1] != total:
        raise tokens.error(tokens.line, f"{what} end at {offsets[-1]}, expected {total}")
    return offsets


def _read_sparse_block(tokens: _Tokens, rows: int, cols: int) -> np.ndarray:
    """Read a Siconos ``SparseBlockStructuredMatrix`` dump (storage 1) into a dense array.

    After the storage type and the sizes: the number of blocks ``nb`` (0: a zero matrix, nothing
    follows), the numbers of block rows and block columns, the cumulative block row sizes, the
    cumulative block column sizes, ``filled1`` (block rows + 1) and ``filled2`` (``nb``), the
    block-row pointers (CSR, ``filled1`` entries), the block-column index of each block
    (``filled2`` entries), then for each block in order its number followed by its entries,
    column-major.
    """
    matrix = np.zeros((rows, cols))
    blocks = tokens.integer("number of blocks")
    if blocks == 0:
        return matrix
    block_rows = tokens.integer("number of block rows", minimum=1)
    block_cols = tokens.integer("number of block columns", minimum=1)
    row_offsets = _read_block_sizes(tokens, block_rows, rows, "cumulative block row sizes")
    col_offsets = _read_block_sizes(tokens, block_cols, cols, "cumulative block column sizes")
    tokens.expect(block_rows + 1, "filled1 (number of block rows + 1)")
    tokens.expect(blocks, "filled2 (number of blocks)")
    row_start = [tokens.integer(f"block row pointer {k + 1}") for k in range(block_rows + 1)]
    col_index = [tokens.integer(f"block column index {k + 1}") for k in range(blocks)]
    if row_start[0] != 0 or row_start[-1] != blocks or row_start != sorted(row_start):
        raise tokens.error(
            tokens.line,
            f"block row pointers {row_start} are not non-decreasing from 0 to {blocks}",
        )
    if any(c >= block_cols for c in col_index):
        raise tokens.error(
            tokens.line,
            f"block column index out of range in {col_index} (block columns: {block_cols})",
        )
    for block_row in range(block_rows):
        r0, r1 = row_offsets[block_row], row_offsets[block_row + 1]
        for number in range(row_start[block_row], row_start[block_row + 1]):
            tokens.expect(number, "block number")
            c0, c1 = col_offsets[col_index[number]], col_offsets[col_index[number] + 1]
            values = tokens.floats((r1 - r0) * (c1 - c0), f"block {number}")
            matrix[r0:r1, c0:c1] = values.reshape(c1 - c0, r1 - r0).T  # column-major
    return matrix


def _read_numerics_matrix(tokens: _Tokens) -> np.ndarray:
    """Read a Siconos ``NumericsMatrix`` dump: storage type, sizes, dense or sparse-block data."""
    storage = tokens.integer("matrix storage type")
    storage_line = tokens.line
    rows = tokens.integer("matrix row count", minimum=1)
    cols = tokens.integer("matrix column count", minimum=1)
    if storage == 0:
        tokens.expect(rows, "dense matrix row count (repeated)")
        tokens.expect(cols, "dense matrix column count (repeated)")
        values = tokens.floats(rows * cols, "dense matrix")
        return values.reshape(cols, rows).T  # stored column-major
    if storage == 1:
        return _read_sparse_block(tokens, rows, cols)
    raise tokens.error(
        storage_line, f"unsupported matrix storage type {storage} (0 = dense, 1 = sparse block)"
    )


def read_siconos_lcp(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a Siconos LCP file: ``n``, the matrix (dense or sparse-block), then ``q``.

    Anything after the ``n`` entries of ``q`` (comments in some files) is ignored.

    Args:
        path: the ``.dat`` file.

    Returns:
        ``(M, q)`` as dense float arrays.

    Raises:
        InputError: if the file cannot be read or is malformed (naming the file and line).
    """
    tokens = _Tokens(Path(path))
    n = tokens.integer("problem size n", minimum=1)
    M = _read_numerics_matrix(tokens)
    if M.shape != (n, n):
        raise tokens.error(1, f"problem size {n} does not match matrix shape {M.shape}")
    q = tokens.floats(n, "vector q")
    return M, q


def read_siconos_fc2d(path: str | Path) -> FrictionContact2D:
    """Read a Siconos FrictionContactProblem file of dimension 2.

    Layout: dimension (2), number of contacts ``nc``, the ``2 nc x 2 nc`` matrix ``W`` (dense
    or sparse-block), ``q`` (``2 nc``), ``mu`` (``nc``); a trailing flag is ignored.

    Args:
        path: the ``.dat`` file.

    Returns:
        The problem.

    Raises:
        InputError: if the file cannot be read or is malformed (naming the file and line).
    """
    tokens = _Tokens(Path(path))
    tokens.expect(2, "problem dimension")
    nc = tokens.integer("number of contacts", minimum=1)
    W = _read_numerics_matrix(tokens)
    if W.shape != (2 * nc, 2 * nc):
        raise tokens.error(2, f"{nc} contacts need a {2 * nc} x {2 * nc} matrix, got {W.shape}")
    q = tokens.floats(2 * nc, "vector q")
    mu = tokens.floats(nc, "friction coefficients mu")
    if np.any(mu < 0):
        raise tokens.error(tokens.line, "negative friction coefficient")
    return FrictionContact2D(W=W, q=q, mu=mu, number_of_contacts=nc)
