"""The Bus Pirate model's device events: mode changes, protocol errors, UART rate changes and
SPI transfers (times in sim ns)."""

from __future__ import annotations

from dataclasses import dataclass

from emulators.base import DeviceEvent


@dataclass(frozen=True)
class BusPirateModeChanged(DeviceEvent):
    mode: str


@dataclass(frozen=True)
class BusPirateProtocolError(DeviceEvent):
    """A command the firmware rejects or tolerates; ``byte`` is the offending byte."""

    what: str
    byte: int


@dataclass(frozen=True)
class BusPirateUartRate(DeviceEvent):
    """The PC-side UART changed its rate (terminal ``b`` menu, or back after a reset)."""

    baud_bps: int


@dataclass(frozen=True, init=False)
class BusPirateSpi(DeviceEvent):
    """One bulk transfer or write-then-read on the SPI pins."""

    mosi: bytes
    miso: bytes

    def __init__(self, t_ns: int, mosi: bytes, miso: bytes) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "mosi", mosi)
        object.__setattr__(self, "miso", miso)
