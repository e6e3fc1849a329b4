"""XSENS MTi emulator (legacy MTi and mk4 MTi 100-series): Xbus, sans-I/O.

Bench-facing API: :class:`MtiDevice` with :class:`XsensParams`; events in
:mod:`emulators.xsens.events`; wire constants in :mod:`emulators.xsens.defs`.
"""

from emulators.xsens.device import MtiDevice
from emulators.xsens.events import (
    BaudChanged,
    CommandHandled,
    LineOverload,
    ProtocolError,
    SampleDropped,
    SampleSent,
    State,
    StateChanged,
)
from emulators.xsens.params import Identity, PowerUp, XsensParams

__all__ = [
    "BaudChanged",
    "CommandHandled",
    "Identity",
    "LineOverload",
    "MtiDevice",
    "PowerUp",
    "ProtocolError",
    "SampleDropped",
    "SampleSent",
    "State",
    "StateChanged",
    "XsensParams",
]
