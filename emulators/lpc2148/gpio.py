"""The LPC2148's legacy GPIO ports (UM10139 Rev. 4, chapter 8 "GPIO", §8.4; base 0xE002 8000).

Per port n (0 at offsets 0x00-0x0C, 1 at 0x10-0x1C): IOnPIN (read: the pins' levels; write:
the output register directly), IOnSET (write 1s set output bits; read: the output register),
IOnDIR (1 = output), IOnCLR (write 1s clear output bits; write only). Reset: all inputs,
output register 0. Port 1 has P1.16-P1.31 only; P0.24, P0.26 and P0.27 do not exist as GPIO.

A pin's level: its output register bit when it is a GPIO output, else what the outside drives
(:meth:`Gpio.drive`, set by the bus's pin events; 0 until driven). An output change on a pin
whose function is GPIO is reported to the watchers the bus registered (e.g. the MCP3204's chip
select) and kept for recording. GPIO has no clock: its ticks are the bus's CCLK cycles.

Not modelled: the fast GPIO registers at 0x3FFF C000 (selecting them in SCS raises
NotModelled in the system control block).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from emulators.lpc2148.pinsel import PinSelect
from emulators.lpc2148.regs import MASK32, RegisterFile

GPIO_BASE = 0xE002_8000
#: the bits that are GPIO pins on each port
PORT_PINS = (MASK32 & ~((1 << 24) | (1 << 26) | (1 << 27)), 0xFFFF_0000)

#: watcher(level, cycle)
PinWatcher = Callable[[bool, int], None]


@dataclass(frozen=True)
class PinChange:
    """GPIO output P``port``.``pin`` went to ``level`` at CCLK ``cycle``."""

    cycle: int
    port: int
    pin: int
    level: bool


class Gpio(RegisterFile):
    """IO0/IO1 PIN, SET, DIR, CLR."""

    name = "GPIO"

    def __init__(self, pinsel: PinSelect, base: int = GPIO_BASE) -> None:
        super().__init__(base)
        self.pinsel = pinsel
        self.dir = [0, 0]
        self.out = [0, 0]
        self.ext = [0, 0]
        self.watchers: dict[tuple[int, int], PinWatcher] = {}
        self._changes: list[PinChange] = []

    def level(self, port: int, pin: int) -> bool:
        """The level of P``port``.``pin``."""
        return bool(self.pins(port) >> pin & 1)

    def pins(self, port: int) -> int:
        """IOnPIN: output bits on outputs, driven levels on inputs."""
        d = self.dir[port]
        return ((self.out[port] & d) | (self.ext[port] & ~d)) & PORT_PINS[port]

    def drive(self, port: int, pin: int, level: bool) -> None:
        """The outside drives P``port``.``pin`` to ``level``."""
        self.ext[port] = (self.ext[port] & ~(1 << pin)) | (int(level) << pin)

    def take_changes(self) -> list[PinChange]:
        """Drain the GPIO output changes."""
        out, self._changes = self._changes, []
        return out

    def read(self, offset: int, tick: int = 0) -> int:
        port, reg = offset >> 4, offset & 0xF
        if port > 1:
            raise self.unmodelled(offset, "read")
        if reg == 0x0:
            return self.pins(port)
        if reg == 0x4:
            return self.out[port]
        if reg == 0x8:
            return self.dir[port]
        raise self.write_only(offset, f"IO{port}CLR")

    def write(self, offset: int, value: int, tick: int = 0) -> None:
        port, reg = offset >> 4, offset & 0xF
        if port > 1:
            raise self.unmodelled(offset, "write")
        before = self.pins(port)
        value &= PORT_PINS[port]
        if reg == 0x0:
            self.out[port] = value
        elif reg == 0x4:
            self.out[port] |= value
        elif reg == 0x8:
            self.dir[port] = value
        else:
            self.out[port] &= ~value
        changed = (before ^ self.pins(port)) & self.dir[port]
        pin = 0
        while changed:
            if changed & 1 and self.pinsel.function(port, pin) in ("GPIO", "GPO"):
                level = self.level(port, pin)
                self._changes.append(PinChange(tick, port, pin, level))
                watcher = self.watchers.get((port, pin))
                if watcher is not None:
                    watcher(level, tick)
            changed >>= 1
            pin += 1
