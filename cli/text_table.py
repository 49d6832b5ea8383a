"""Plain text tables that never cut a word: columns wrap at spaces, or rows become lines.

Rich's tables fold or ellipsise a word when the console is narrow; these lay the columns out from
their longest words, so every word printed is whole at any width (80 columns included).
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence

COLUMN_GAP = 2
"""[characters] Spaces between two columns."""


def _wrap(text: str, width: int) -> list[str]:
    return textwrap.wrap(text, width, break_long_words=False, break_on_hyphens=False) or [""]


def _longest_word(text: str) -> int:
    return max((len(word) for word in text.split()), default=0)


def column_widths(columns: Sequence[str], rows: Sequence[Sequence[str]], width: int) -> list[int] | None:
    """Each column's width within ``width`` characters, or None when the longest words do not fit.

    A column gets its widest cell when everything fits; otherwise each starts at its longest word
    and the room left goes, a character at a time, to the columns that still wrap.
    """
    cells = [[column, *(row[i] for row in rows)] for i, column in enumerate(columns)]
    least = [max(_longest_word(cell) for cell in column) for column in cells]
    most = [max(len(cell) for cell in column) for column in cells]
    room = width - COLUMN_GAP * (len(columns) - 1)
    if sum(most) <= room:
        return most
    if sum(least) > room:
        return None
    widths = list(least)
    while sum(widths) < room:
        grown = False
        for i in range(len(widths)):
            if widths[i] < most[i] and sum(widths) < room:
                widths[i] += 1
                grown = True
        if not grown:
            break
    return widths


def table_lines(title: str, columns: Sequence[str], rows: Sequence[Sequence[str]], width: int) -> list[str]:
    """The table as text lines at most ``width`` wide (a longer word only if one alone is longer).

    Too narrow for the columns' longest words, each row is printed as ``first cell: column: value;
    ...`` wrapped at spaces (the first column's heading said once, after the title).
    """
    widths = column_widths(columns, rows, width)
    if widths is None:
        lines = textwrap.wrap(f"{title}, by {columns[0]}:", width, break_long_words=False,
                              break_on_hyphens=False)
        for row in rows:
            text = f"{row[0]}: " + "; ".join(f"{column}: {value}"
                                             for column, value in zip(columns[1:], row[1:], strict=True))
            lines += textwrap.wrap(text, width, initial_indent="  ", subsequent_indent="    ",
                                   break_long_words=False, break_on_hyphens=False)
        return lines
    total = sum(widths) + COLUMN_GAP * (len(widths) - 1)
    lines = [title.center(total).rstrip()]
    for index, row in enumerate([list(columns), *[list(r) for r in rows]]):
        wrapped = [_wrap(cell, w) for cell, w in zip(row, widths, strict=True)]
        for k in range(max(len(w) for w in wrapped)):
            parts = [(w[k] if k < len(w) else "").ljust(widths[i]) for i, w in enumerate(wrapped)]
            lines.append((" " * COLUMN_GAP).join(parts).rstrip())
        if index == 0:
            lines.append("-" * total)
    return lines


__all__ = [
    "COLUMN_GAP",
    "column_widths",
    "table_lines",
]
