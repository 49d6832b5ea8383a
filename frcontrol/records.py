"""Frozen records (dataclasses) with some fields changed, without ``dataclasses.replace``'s cost.

``dataclasses.replace`` reads every field by name and calls ``__init__``, which sets each one through
``object.__setattr__``: about ten microseconds for a scene or a contact problem, as much as the
rest of an atlas point's update. :func:`replaced` gives the same record by copying the fields'
values at once. It serves records whose ``__init__`` only stores its fields (no ``__post_init__``,
no init-only fields); what a record finds once and keeps (a ``functools.cached_property``) is
not copied: the new record finds it again from its own fields.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import fields
from functools import cache
from operator import itemgetter
from typing import Any, TypeVar

from .errors import InputError

Record = TypeVar("Record")


FieldReader = Callable[[dict[str, Any]], tuple[Any, ...]]
"""Reads a record's field values, in field order, from its ``__dict__``."""


@cache
def _field_names(cls: type) -> tuple[tuple[str, ...], frozenset[str], FieldReader]:
    """The names of ``cls``'s fields (as a tuple and a set) and a reader of their values, found once.

    Raises:
        InputError: ``cls`` has a ``__post_init__`` or init-only fields (use ``dataclasses.replace``).
    """
    if hasattr(cls, "__post_init__"):
        raise InputError(f"{cls.__name__} has a __post_init__: use dataclasses.replace")
    names = tuple(f.name for f in fields(cls))
    if any(not f.init for f in fields(cls)):
        raise InputError(f"{cls.__name__} has fields outside __init__: use dataclasses.replace")
    read = itemgetter(*names) if len(names) > 1 else (lambda state: tuple(state[name] for name in names))
    return names, frozenset(names), read


def replaced(record: Record, **changes: Any) -> Record:
    """``dataclasses.replace(record, **changes)`` for a record whose ``__init__`` only stores its fields.

    Raises:
        InputError: a change names no field of the record, or the record's class is not one
            :func:`replaced` serves (module docstring).
    """
    cls = type(record)
    names, known, read = _field_names(cls)  # type: ignore[arg-type]  # a class is hashable
    if not known.issuperset(changes):
        unknown = set(changes).difference(known)
        raise InputError(f"{cls.__name__} has no field {sorted(unknown)[0]!r}; "
                         f"its fields: {', '.join(names)}")
    new = object.__new__(cls)
    state = new.__dict__
    state.update(zip(names, read(record.__dict__), strict=True))
    state.update(changes)
    return new


__all__ = ["replaced"]
