"""Memory held by what a callable builds, measured with tracemalloc (not a timed assertion)."""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


def traced(build: Callable[[], T]) -> tuple[T, int]:
    """``(build(), bytes traced while it ran and still held at its end)``."""
    tracemalloc.start()
    try:
        built = build()
        size, _ = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return built, size
