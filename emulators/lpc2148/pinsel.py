"""The pin connect block (UM10139 Rev. 4, chapter 6 "Pin connect block", tables of PINSEL0,
PINSEL1 and PINSEL2; base 0xE002 C000): which function each pin has.

PINSEL0 (0x00) holds 2 bits for each of P0.0-P0.15, PINSEL1 (0x04) for P0.16-P0.31; PINSEL2
(0x14) bit 2 makes P1.26-31 the debug port and bit 3 P1.16-25 the trace port. Reset: all GPIO
(PINSEL2 reset 0: no debugger on RTCK, no trace resistor on P1.20).

The bus asks :meth:`PinSelect.function` before it lets bytes, captures, PWM pulses or
external interrupts through a pin (a UART's bytes flow only while P0.0/P0.1 are TXD0/RXD0).
Selecting a reserved function is an error naming the pin.
"""

from __future__ import annotations

from emulators.lpc2148.errors import RegisterAccessError
from emulators.lpc2148.regs import RegisterFile

PINSEL_BASE = 0xE002_C000
_R = "reserved"

#: P0.n -> its functions for PINSEL values 0, 1, 2, 3 (UM10139 Rev. 4 §6.4.1, §6.4.2)
PORT0_FUNCTIONS: dict[int, tuple[str, str, str, str]] = {
    0: ("GPIO", "TXD0", "PWM1", _R),
    1: ("GPIO", "RXD0", "PWM3", "EINT0"),
    2: ("GPIO", "SCL0", "CAP0.0", _R),
    3: ("GPIO", "SDA0", "MAT0.0", "EINT1"),
    4: ("GPIO", "SCK0", "CAP0.1", "AD0.6"),
    5: ("GPIO", "MISO0", "MAT0.1", "AD0.7"),
    6: ("GPIO", "MOSI0", "CAP0.2", "AD1.0"),
    7: ("GPIO", "SSEL0", "PWM2", "EINT2"),
    8: ("GPIO", "TXD1", "PWM4", "AD1.1"),
    9: ("GPIO", "RXD1", "PWM6", "EINT3"),
    10: ("GPIO", "RTS1", "CAP1.0", "AD1.2"),
    11: ("GPIO", "CTS1", "CAP1.1", "SCL1"),
    12: ("GPIO", "DSR1", "MAT1.0", "AD1.3"),
    13: ("GPIO", "DTR1", "MAT1.1", "AD1.4"),
    14: ("GPIO", "DCD1", "EINT1", "SDA1"),
    15: ("GPIO", "RI1", "EINT2", "AD1.5"),
    16: ("GPIO", "EINT0", "MAT0.2", "CAP0.2"),
    17: ("GPIO", "CAP1.2", "SCK1", "MAT1.2"),
    18: ("GPIO", "CAP1.3", "MISO1", "MAT1.3"),
    19: ("GPIO", "MAT1.2", "MOSI1", "CAP1.2"),
    20: ("GPIO", "MAT1.3", "SSEL1", "EINT3"),
    21: ("GPIO", "PWM5", "AD1.6", "CAP1.3"),
    22: ("GPIO", "AD1.7", "CAP0.0", "MAT0.0"),
    23: ("GPIO", "VBUS", _R, _R),
    24: (_R, _R, _R, _R),
    25: ("GPIO", "AD0.4", "AOUT", _R),
    26: (_R, _R, _R, _R),
    27: (_R, _R, _R, _R),
    28: ("GPIO", "AD0.1", "CAP0.2", "MAT0.2"),
    29: ("GPIO", "AD0.2", "CAP0.3", "MAT0.3"),
    30: ("GPIO", "AD0.3", "EINT3", "CAP0.0"),
    31: ("GPO", "UP_LED", "CONNECT", _R),
}


_PINS_WITH: dict[str, tuple[int, ...]] = {}


def pins_with(function: str) -> list[int]:
    """The P0 pins that can carry ``function``."""
    pins = _PINS_WITH.get(function)
    if pins is None:
        pins = _PINS_WITH[function] = tuple(pin for pin, fns in PORT0_FUNCTIONS.items() if function in fns)
    return list(pins)


class PinSelect(RegisterFile):
    """PINSEL0/1/2."""

    name = "PINSEL"

    def __init__(self, base: int = PINSEL_BASE) -> None:
        super().__init__(base)
        self.pinsel = [0, 0]
        self.pinsel2 = 0

    def function(self, port: int, pin: int) -> str:
        """The function selected for P``port``.``pin``."""
        if port == 1:
            if 26 <= pin <= 31 and self.pinsel2 & 0x4:
                return "DEBUG"
            if 16 <= pin <= 25 and self.pinsel2 & 0x8:
                return "TRACE"
            return "GPIO" if 16 <= pin <= 31 else _R
        sel = (self.pinsel[pin >> 4] >> (2 * (pin & 15))) & 3
        return PORT0_FUNCTIONS[pin][sel]

    def selected(self, function: str) -> list[int]:
        """The P0 pins on which ``function`` is selected now."""
        pins = _PINS_WITH.get(function)
        if pins is None:
            pins = tuple(pins_with(function))
        return [pin for pin in pins if self.function(0, pin) == function]

    def read(self, offset: int, tick: int = 0) -> int:
        if offset in (0x00, 0x04):
            return self.pinsel[offset >> 2]
        if offset == 0x14:
            return self.pinsel2
        raise self.unmodelled(offset, "read")

    def write(self, offset: int, value: int, tick: int = 0) -> None:
        value &= 0xFFFF_FFFF
        if offset in (0x00, 0x04):
            first = 16 * (offset >> 2)
            for i in range(16):
                sel = (value >> (2 * i)) & 3
                if sel and PORT0_FUNCTIONS[first + i][sel] == _R:
                    raise RegisterAccessError(self.base + offset, f"P0.{first + i} function {sel} is reserved")
            self.pinsel[offset >> 2] = value
        elif offset == 0x14:
            self.pinsel2 = value & 0x0C
        else:
            raise self.unmodelled(offset, "write")
