"""Excamera SPIDriver (the protocol of the PyPI ``spidriver`` client) with the MCP3204."""

from emulators.spidriver.defs import crc16_ccitt
from emulators.spidriver.device import SpiDriver, SpiDriverSpi
from emulators.spidriver.params import SpiDriverParams

__all__ = ["SpiDriver", "SpiDriverParams", "SpiDriverSpi", "crc16_ccitt"]
