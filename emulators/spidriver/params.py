"""Parameters of the SPIDriver bridge (rig TOML table ``[adc.spidriver]``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal


@dataclass(frozen=True)
class SpiDriverParams:
    """An Excamera SPIDriver wired to the MCP3204.

    ``product`` "spidriver2" adds the mode field to the status line and accepts ``m``; the
    PyPI client's ``setmode`` only works against a "spidriver2" (docs/protocols.md §7.2).
    The status values (serial, USB voltage, current, temperature) are what the front panel
    would show; the uptime is counted from sim time 0 plus ``uptime_at_t0_s``.
    """

    __pydantic_config__ = {"extra": "forbid"}

    baud_bps: int = 460800  #: FT230X <-> EFM8 line rate the client opens
    product: Literal["spidriver1", "spidriver2"] = "spidriver2"
    serial: str = "DO01JUHT"  #: FTDI serial string, 8 characters
    uptime_at_t0_s: int = 5  #: seconds the unit has been powered when sim time is 0
    usb_voltage_V: float = 5.012
    current_mA: int = 2  #: drawn by the attached device (the MCP3204: ~0.4 mA, reads 0-2)
    temperature_C: float = 26.3
    spi_mode: int = 0  #: mode after power-up (the firmware configures mode 0)
