"""The generated headers, one section each: (file name, render(cfg, source) -> text).

A section is a module of this package with ``FILENAME`` and ``render``. Add a module for
another layer's parameters (drivers, modes) and list it here; each writes its own header into
the output directory, so the layers' headers stay apart.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from flightcode.config import FlightConfig

from . import design


@dataclass(frozen=True)
class Section:
    filename: str
    render: Callable[[FlightConfig, str], str]


SECTIONS: tuple[Section, ...] = (
    Section(design.FILENAME, design.render),
)
