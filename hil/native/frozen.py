"""Pickling of frozen records that may be compiled (mypyc).

A compiled frozen dataclass has no ``__dict__``, and the default reduction would restore it
through its frozen ``__setattr__``; such records pickle by field and are rebuilt through
``__init__`` instead. They cross processes: to the recorder's child, and from campaign
workers back to the campaign."""

from __future__ import annotations

import functools
from dataclasses import fields
from typing import Any


@functools.cache
def _field_names(cls: type) -> tuple[str, ...]:
    """Cached: ``dataclasses.fields`` is interpreted and rebuilds its tuple on every call, and
    the recorder pickles a plant state a few times a tick."""
    return tuple(f.name for f in fields(cls))


def by_fields(record: Any) -> tuple[type, tuple[object, ...]]:
    """``__reduce__`` of a dataclass whose fields are all ``__init__`` arguments."""
    cls: type = type(record)
    return cls, tuple([getattr(record, name) for name in _field_names(cls)])
