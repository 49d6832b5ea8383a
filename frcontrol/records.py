"""Frozen records (dataclasses) with some fields changed, without ``dataclasses.replace``'s cost.

``dataclasses.replace`` reads every field by name and calls ``__init__``, which sets each one through
``object.__setattr__``: about ten microseconds for a scene or a contact problem, as much as the
rest of an atlas point's update. :func:`replaced` gives the same record by copying the fields'
values at once. It serves records whose ``__init__`` only stores its fields (no ``__post_init__``,
no init-only fields); what a record finds once and keeps (a ``functools.cached_property``) is
not copied: the new record finds it again from its own fields.
"""

from __future__ import annotations

from dataclasses import fields
from functools import cache
from typing import Any, TypeVar

from .errors import InputError

Record = TypeVar("Record")


@cache
def _field_names(cls: type) -> tuple[str, ...]:
    """The names of ``cls``'s fields, found once per class.

    Raises:
        InputError: ``cls`` has a ``__post_init__`` or init-only fields (use ``dataclasses.replace``).
    """
    if hasattr(cls, "__post_init__"):
        raise InputError(f"{cls.__name__} has a __post_init__: use dataclasses.replace")
    names = tuple(f.name for f in fields(cls))
    if any(not f.init for f in fields(cls)):
        raise InputError(f"{cls.__name__} has fields outside __init__: use dataclasses.replace")
    return names


def replaced(record: Record, **changes: Any) -> Record:
    """``dataclasses.replace(record, **changes)`` for a record whose ``__init__`` only stores its fields.

    Raises:
        InputError: a change names no field of the record, or the record's class is not one
            :func:`replaced` serves (module docstring).
    """
    cls = type(record)
    names = _field_names(cls)  # type: ignore[arg-type]  # a class is hashable
    unknown = set(changes).difference(names)
    if unknown:
        raise InputError(f"{cls.__name__} has no field {sorted(unknown)[0]!r}; "
                         f"its fields: {', '.join(names)}")
    state = record.__dict__
    values = {name: state[name] for name in names}
    values.update(changes)
    new = object.__new__(cls)
    new.__dict__.update(values)
    return new


__all__ = ["replaced"]
