"""SPI0 of the LPC2148 in master mode (UM10139, chapter "SPI interface SPI0"; base 0xE002 0000).

Registers: S0SPCR (0x00: bit 2 BitEnable, 3 CPHA, 4 CPOL, 5 MSTR, 6 LSBF, 7 SPIE, 11:8 BITS
with BitEnable: 8-15 bits, 0 = 16), S0SPSR (0x04, read only: bit 3 ABRT, 4 MODF, 5 ROVR,
6 WCOL, 7 SPIF), S0SPDR (0x08), S0SPCCR (0x0C: PCLK ticks per SCK period, even and >= 8 in
master mode), S0SPINT (0x1C: bit 0, write 1 to clear).

A write to S0SPDR with no transfer running starts one: BITS clocks of S0SPCCR ticks each. The
byte is exchanged with the slave (:class:`SpiSlave`, e.g. the MCP3204 behind a chip select on
a GPIO pin) at the transfer's start, with its timing; at the end SPIF is set and S0SPDR reads
the slave's answer. A write while a transfer runs sets WCOL and is lost. SPIF and WCOL clear
when S0SPSR has been read with them set and S0SPDR is then accessed; MODF clears on a read of
S0SPSR then a write of S0SPCR. The interrupt flag S0SPINT sets when SPIE is on and SPIF or
WCOL sets; it is the interrupt line (VIC channel 10).

MODF: SSEL0 (P0.7 selected as SSEL0) driven low while master clears MSTR and sets MODF
(:meth:`Spi.set_ssel`). Not modelled: slave mode (a transfer with MSTR clear raises
NotModelled), the test registers, ROVR and ABRT (slave-mode flags).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum, unique
from typing import Protocol

from emulators.lpc2148.errors import NotModelled, RegisterAccessError
from emulators.lpc2148.regs import RegisterFile

SPI0_BASE = 0xE002_0000


@unique
class SpiReg(IntEnum):
    """Register offsets (UM10139 SPI register map table)."""

    SPCR = 0x00
    SPSR = 0x04
    SPDR = 0x08
    SPCCR = 0x0C
    SPINT = 0x1C


_BIT_ENABLE, _CPHA, _CPOL, _MSTR, _LSBF, _SPIE = 0x04, 0x08, 0x10, 0x20, 0x40, 0x80
_MODF, _WCOL, _SPIF = 0x10, 0x40, 0x80


@dataclass(frozen=True)
class SpiTransfer:
    """One transfer's framing: ``start`` and ``end`` time, ``sck_period`` (same unit: PCLK
    ticks from the model, CCLK cycles from the bus), ``bits``, SPI mode bits, bit order."""

    start: int
    end: int
    sck_period: int
    bits: int
    cpol: int
    cpha: int
    lsb_first: bool

    @property
    def mode(self) -> int:
        """SPI mode number, CPOL << 1 | CPHA."""
        return self.cpol << 1 | self.cpha


class SpiSlave(Protocol):
    """What sits on MOSI/MISO: takes the master's word, returns its own for the same clocks."""

    def __call__(self, mosi: int, transfer: SpiTransfer) -> int: ...


@dataclass(frozen=True)
class SpiExchange:
    """A finished transfer (for recording)."""

    transfer: SpiTransfer
    mosi: int
    miso: int


def _no_slave(mosi: int, transfer: SpiTransfer) -> int:
    return 0  # nothing drives MISO


class Spi(RegisterFile):
    """SPI0; time in PCLK ticks."""

    name = "SPI0"

    def __init__(self, base: int = SPI0_BASE) -> None:
        super().__init__(base)
        self.spcr = 0
        self.spsr = 0
        self.spccr = 0
        self.spint = 0
        self.data = 0
        self.slave: SpiSlave = _no_slave
        self._busy_until: int | None = None
        self._pending: tuple[SpiTransfer, int, int] | None = None
        self._status_seen = 0  #: SPSR bits a read saw, cleared by the next SPDR access
        self._modf_seen = False
        self._exchanges: list[SpiExchange] = []

    @property
    def bits(self) -> int:
        if not self.spcr & _BIT_ENABLE:
            return 8
        n = (self.spcr >> 8) & 0xF
        return n if n >= 8 else 16

    # -- time -----------------------------------------------------------------------------
    def advance_to(self, tick: int) -> None:
        if self._busy_until is not None and tick >= self._busy_until:
            assert self._pending is not None
            transfer, mosi, miso = self._pending
            self.data = miso
            self._busy_until = self._pending = None
            self._exchanges.append(SpiExchange(transfer, mosi, miso))
            self._flag(_SPIF)

    def next_event(self) -> int | None:
        return self._busy_until

    def next_irq_event(self) -> int | None:
        return self._busy_until if self.spcr & _SPIE else None

    @property
    def irq(self) -> bool:
        return bool(self.spint)

    def _flag(self, bits: int) -> None:
        self.spsr |= bits
        if self.spcr & _SPIE and bits & (_SPIF | _WCOL):
            self.spint = 1

    def take_exchanges(self) -> list[SpiExchange]:
        """Drain the finished transfers."""
        out, self._exchanges = self._exchanges, []
        return out

    # -- pins -----------------------------------------------------------------------------
    def set_ssel(self, level: bool, tick: int) -> None:
        """SSEL0's level, when P0.7 is selected as SSEL0: low in master mode is a mode fault."""
        self.advance_to(tick)
        if not level and self.spcr & _MSTR:
            self.spcr &= ~_MSTR
            self._flag(_MODF)

    # -- registers ------------------------------------------------------------------------
    def read(self, offset: int, tick: int) -> int:
        self.advance_to(tick)
        if offset == SpiReg.SPSR:
            self._status_seen = self.spsr & (_SPIF | _WCOL)
            self._modf_seen = bool(self.spsr & _MODF)
            return self.spsr
        if offset == SpiReg.SPDR:
            self._spdr_accessed()
            return self.data
        values: dict[int, int] = {SpiReg.SPCR: self.spcr, SpiReg.SPCCR: self.spccr, SpiReg.SPINT: self.spint}
        if offset in values:
            return values[offset]
        raise self.unmodelled(offset, "read")

    def _spdr_accessed(self) -> None:
        self.spsr &= ~self._status_seen
        self._status_seen = 0

    def write(self, offset: int, value: int, tick: int) -> None:
        self.advance_to(tick)
        self.rescheduled = True  # a transfer started, SPIE changed
        if offset == SpiReg.SPDR:
            self._spdr_accessed()
            self._start(value, tick)
        elif offset == SpiReg.SPCR:
            self.spcr = value & 0xFFC
            if self._modf_seen:
                self.spsr &= ~_MODF
                self._modf_seen = False
        elif offset == SpiReg.SPCCR:
            self.spccr = value & 0xFF
        elif offset == SpiReg.SPINT:
            self.spint &= ~value & 1
        elif offset == SpiReg.SPSR:
            raise self.read_only(offset, "S0SPSR")
        else:
            raise self.unmodelled(offset, "write")

    def _start(self, value: int, tick: int) -> None:
        if self._busy_until is not None:
            self._flag(_WCOL)
            return
        if not self.spcr & _MSTR:
            raise NotModelled(self.base + SpiReg.SPDR, "SPI0 slave mode (S0SPDR written with MSTR clear)")
        if self.spccr < 8 or self.spccr & 1:
            raise RegisterAccessError(self.base + SpiReg.SPCCR,
                                      f"S0SPCCR = {self.spccr}: master mode needs an even count >= 8")
        bits = self.bits
        mosi = value & ((1 << bits) - 1)
        transfer = SpiTransfer(tick, tick + bits * self.spccr, self.spccr, bits, int(bool(self.spcr & _CPOL)),
                               int(bool(self.spcr & _CPHA)), bool(self.spcr & _LSBF))
        miso = self.slave(mosi, transfer) & ((1 << bits) - 1)
        self._busy_until = transfer.end
        self._pending = (transfer, mosi, miso)
