"""Pickling of frozen records that may be compiled (mypyc).

A compiled frozen dataclass has no ``__dict__``, and the default reduction would restore it
through its frozen ``__setattr__``; such records pickle by field and are rebuilt through
``__init__`` instead. They cross processes: to the recorder's child, and from campaign
workers back to the campaign."""

from __future__ import annotations

from dataclasses import fields
from typing import Any


def by_fields(record: Any) -> tuple[type, tuple[object, ...]]:
    """``__reduce__`` of a dataclass whose fields are all ``__init__`` arguments."""
    return type(record), tuple(getattr(record, f.name) for f in fields(record))
