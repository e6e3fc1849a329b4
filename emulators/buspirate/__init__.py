"""Bus Pirate v3 in binary mode (BBIO1/SPI1) with the MCP3204 on its SPI pins."""

from emulators.buspirate.defs import Mode
from emulators.buspirate.device import BusPirate
from emulators.buspirate.events import (
    BusPirateModeChanged,
    BusPirateProtocolError,
    BusPirateSpi,
    BusPirateUartRate,
)
from emulators.buspirate.params import BusPirateParams
from emulators.buspirate.terminal import Terminal

__all__ = [
    "BusPirate",
    "BusPirateModeChanged",
    "BusPirateParams",
    "BusPirateProtocolError",
    "BusPirateSpi",
    "BusPirateUartRate",
    "Mode",
    "Terminal",
]
