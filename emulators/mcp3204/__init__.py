"""MCP3204 12-bit 4-channel SPI ADC, modelled clock by clock (see device.py)."""

from emulators.mcp3204.defs import InputMode, SpiMode, fig61_decode, fig61_request
from emulators.mcp3204.device import Mcp3204, Mcp3204Conversion, Mcp3204ProtocolError, Sampler
from emulators.mcp3204.params import Mcp3204Params
from emulators.mcp3204.transfer import code_center_V, lsb_V, quantize

__all__ = [
    "InputMode",
    "Mcp3204",
    "Mcp3204Conversion",
    "Mcp3204Params",
    "Mcp3204ProtocolError",
    "Sampler",
    "SpiMode",
    "code_center_V",
    "fig61_decode",
    "fig61_request",
    "lsb_V",
    "quantize",
]
