"""The Bus Pirate's I/O pins as raw bitbang mode sees them (binIO.c binBBpinset/dirset).

Five pins (CS, MISO, CLK, MOSI, AUX) with a direction (1 = input) and an output latch,
plus the power supplies and pull-ups. CS, CLK and MOSI go to the MCP3204; MISO reads its
DOUT. A pin set as input floats unless pulled up: the part then sees no edge on it.
"""

from __future__ import annotations

from emulators.buspirate.defs import PIN_MASK, Pin
from emulators.mcp3204 import Mcp3204


class Pins:
    """Pin state shared by bitbang and SPI mode (power and pull-ups are the same switches)."""

    def __init__(self, target_pullups: bool) -> None:
        self.target_pullups = target_pullups
        self.reset()

    def reset(self) -> None:
        """binReset(): all pins inputs, latches low, power and pull-ups off."""
        self.direction = PIN_MASK
        self.latch = 0
        self.power = False
        self.pullups = False
        self.aux = 0

    @property
    def pulled_up(self) -> bool:
        return self.pullups or self.target_pullups

    def set_direction(self, byte: int, adc: Mcp3204, t_ns: int) -> int:
        """010xxxxx: set directions; returns the pin read."""
        self.direction = byte & PIN_MASK
        self._drive(adc, t_ns)
        return (byte & ~PIN_MASK & 0xFF) | self.read(adc)

    def set_levels(self, byte: int, adc: Mcp3204, t_ns: int) -> int:
        """1xxxxxxx: power, pull-ups and output latches; returns the pin read."""
        self.power = bool(byte & Pin.POWER)
        self.pullups = bool(byte & Pin.PULLUP)
        self.latch = byte & PIN_MASK
        self._drive(adc, t_ns)
        return (byte & ~PIN_MASK & 0xFF) | self.read(adc)

    def level(self, pin: Pin) -> int | None:
        """Level the Bus Pirate puts on ``pin``; None if it floats."""
        if not self.direction & pin:
            return 1 if self.latch & pin else 0
        return 1 if self.pulled_up else None

    def read(self, adc: Mcp3204) -> int:
        """The low five bits of a pin read."""
        value = 0
        for pin in (Pin.CS, Pin.MISO, Pin.CLK, Pin.MOSI, Pin.AUX):
            if pin is Pin.MISO and self.direction & pin:
                dout = adc.dout
                level = (1 if self.pullups or adc.dout_pulled_up else 0) if dout is None else dout
            else:
                level = self.level(pin) or 0
            value |= pin if level else 0
        return value

    def _drive(self, adc: Mcp3204, t_ns: int) -> None:
        cs, sck, din = self.level(Pin.CS), self.level(Pin.CLK), self.level(Pin.MOSI)
        adc.set_pins(  # a floating pin keeps its last level: the part sees no edge
            t_ns,
            cs=(0 if adc.cs_low else 1) if cs is None else cs,
            sck=adc.sck if sck is None else sck,
            din=adc.din if din is None else din,
        )
