"""UART0 and UART1 of the LPC2148, 16550-style (UM10139, chapters "UART0" and "UART1"; UART0 at
0xE000 C000, UART1 at 0xE001 0000).

Registers: RBR/THR/DLL (0x00), IER/DLM (0x04; DLL/DLM while LCR bit 7, DLAB, is set), IIR
(read)/FCR (write) (0x08), LCR (0x0C), LSR (0x14, read only), SCR (0x1C), ACR (0x20), FDR
(0x28), TER (0x30); UART1 also MCR (0x10) and MSR (0x18).

Rates: a bit lasts 16 x DL x (1 + DIVADDVAL / MULVAL) PCLK ticks (DL = DLM:DLL, 0 read as 1;
FDR's fractional divider, reset 0x10: none). Bytes from a device arrive as frames on the line
at the device's own bit time (:meth:`Uart.line_in`, paced back to back like the device's
transmitter) and are sampled at the rate and format the firmware programmed
(:mod:`~emulators.lpc2148.line`): the firmware's baud matters, a mismatch garbles.

Receiving: a character enters the 16-byte RX FIFO at its first stop bit's sample; at a full
FIFO it is lost and LSR.OE set (the FIFO untouched). Per character, parity, framing and break
errors; they show in LSR (PE, FE, BI) when the character reaches RBR, and RXFE while an
erroneous character is in the FIFO. LSR reads clear OE, PE, FE and BI.
Interrupts (IIR priority): RLS (IER bit 2: OE, PE, FE or BI set), RDA (IER bit 0: FIFO at or
above the trigger level 1/4/8/14 of FCR bits 7:6), CTI (IER bit 0: characters in the FIFO and
no FIFO activity, a character in or an RBR read, for 4 character times, inside the manual's
3.5-4.5), THRE (IER bit 1). With FCR bit 0 clear the FIFOs are one byte deep.

Transmitting: THR writes fill the 16-byte TX FIFO (a write to a full FIFO is lost and
counted); the shift register sends one frame at a time at the programmed rate while TER bit 7
is set; :meth:`Uart.take_tx` gives each byte with its start and end tick. LSR.THRE: TX FIFO
empty; TEMT: FIFO and shift register empty. The THRE interrupt follows the manual's start-up
rule: when the FIFO empties having held fewer than two characters since the last THRE event,
the interrupt waits one character time less the stop bits; it clears on a THR write or an IIR
read that reports it. Enabling it in IER with the FIFO empty raises it at once.

Not modelled (NotModelled when selected): auto-baud (ACR start bit), UART1's loopback and
auto flow control (MCR bits 4, 6, 7); UART1's modem inputs read inactive (MSR 0), so there is
no modem status interrupt; LCR's break control does not hold the TX line low.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from enum import IntEnum, unique

from emulators.lpc2148.errors import NotModelled
from emulators.lpc2148.line import FORMAT_8N1, FrameFormat, LineFrame, LineReceiver, format_from_lcr, frame_levels
from emulators.lpc2148.regs import RegisterFile

UART0_BASE = 0xE000_C000
UART1_BASE = 0xE001_0000
FIFO_DEPTH = 16
TRIGGER_LEVELS = (1, 4, 8, 14)
#: character times without FIFO activity before the CTI interrupt
CTI_CHARACTERS = 4.0


@unique
class UartReg(IntEnum):
    """Register offsets (UM10139 UART register map tables)."""

    RBR_THR_DLL = 0x00
    IER_DLM = 0x04
    IIR_FCR = 0x08
    LCR = 0x0C
    MCR = 0x10  #: UART1 only
    LSR = 0x14
    MSR = 0x18  #: UART1 only
    SCR = 0x1C
    ACR = 0x20
    FDR = 0x28
    TER = 0x30


@unique
class Iir(IntEnum):
    """IIR values (bits 3:0) by priority."""

    RLS = 0x06
    RDA = 0x04
    CTI = 0x0C
    THRE = 0x02
    NONE = 0x01


class Lsr(IntEnum):
    DR = 0x01
    OE = 0x02
    PE = 0x04
    FE = 0x08
    BI = 0x10
    THRE = 0x20
    TEMT = 0x40
    RXFE = 0x80


_ERRORS = Lsr.OE | Lsr.PE | Lsr.FE | Lsr.BI


@dataclass(frozen=True)
class TxByte:
    """A byte the UART sent: on the line from PCLK tick ``start`` to ``end``."""

    start: float
    end: float
    value: int
    bit_ticks: float
    fmt: FrameFormat


class Uart(RegisterFile):
    """One UART; time in PCLK ticks. ``modem``: UART1's MCR and MSR exist."""

    def __init__(self, base: int, name: str, *, modem: bool = False) -> None:
        super().__init__(base)
        self.name = name
        self.modem = modem
        self.now = 0
        self.ier = self.lcr = self.scr = self.mcr = self.acr = 0
        self.fcr = 0
        self.dll, self.dlm, self.fdr, self.ter = 0x01, 0x00, 0x10, 0x80
        self.rx: deque[tuple[int, int]] = deque()  #: (value, LSR error bits)
        self.tx: deque[int] = deque()
        self.line = LineReceiver()
        self.lsr_errors = 0
        self._top_shown = False
        self._last_rx_activity = 0.0
        self._tsr_until: float | None = None
        self._thre_int = False
        self._thre_int_at: float | None = None
        self._tx_peak = 0
        self._sent: list[TxByte] = []
        self.counters: dict[str, int] = {"rx_chars": 0, "rx_overruns": 0, "rx_errors": 0, "tx_bytes": 0,
                                         "tx_fifo_overflows": 0}

    # -- rates ----------------------------------------------------------------------------
    @property
    def bit_ticks(self) -> float:
        """PCLK ticks per bit at the programmed divisor."""
        dl = (self.dlm << 8 | self.dll) or 1
        div_add, mul = self.fdr & 0xF, (self.fdr >> 4) & 0xF
        return 16.0 * dl * (1.0 + div_add / mul) if div_add and mul else 16.0 * dl

    @property
    def fmt(self) -> FrameFormat:
        return format_from_lcr(self.lcr)

    @property
    def depth(self) -> int:
        return FIFO_DEPTH if self.fcr & 1 else 1

    @property
    def trigger(self) -> int:
        return TRIGGER_LEVELS[self.fcr >> 6 & 3] if self.fcr & 1 else 1

    def _char_ticks(self) -> float:
        return self.fmt.n_bits * self.bit_ticks

    # -- the device's side ------------------------------------------------------------------
    def line_in(self, data: bytes, tick: float, bit_ticks: float, fmt: FrameFormat = FORMAT_8N1) -> None:
        """A device sends ``data`` from ``tick`` on at ``bit_ticks`` PCLK ticks a bit, each
        frame after the previous one (its transmitter paces them back to back)."""
        self.advance_to(math.floor(tick))
        start = max(tick, self.line.line_free)
        for value in data:
            frame = LineFrame(start, bit_ticks, frame_levels(value, fmt), value, fmt)
            self.line.push(frame)
            start = frame.end

    def take_tx(self) -> list[TxByte]:
        """Drain the bytes sent since the last call."""
        out, self._sent = self._sent, []
        return out

    # -- time -----------------------------------------------------------------------------
    def advance_to(self, tick: int) -> None:
        if tick <= self.now:
            return  # everything due by then has been done
        if self._tsr_until is None and self._thre_int_at is None and not self.line.frames:
            self.now = tick
            return
        while True:
            due = self._due_before(tick)
            if due is None:
                break
            self._step(due)
        for char in self.line.take(tick, self.bit_ticks, self.fmt):
            self._receive(char.value, char.framing_error, char.parity_error, char.break_, char.done)
        self.now = max(self.now, tick)

    def _due_before(self, tick: int) -> float | None:
        """The earliest transmitter event at or before ``tick``."""
        times = [t for t in (self._tsr_until, self._thre_int_at) if t is not None and t <= tick]
        return min(times) if times else None

    def _step(self, t: float) -> None:
        for char in self.line.take(t, self.bit_ticks, self.fmt):
            self._receive(char.value, char.framing_error, char.parity_error, char.break_, char.done)
        if self._thre_int_at is not None and self._thre_int_at <= t:
            self._thre_int, self._thre_int_at = True, None
        if self._tsr_until is not None and self._tsr_until <= t:
            self._tsr_until = None
            self._load_tsr(t)

    def next_event(self) -> int | None:
        times = [t for t in (self._tsr_until, self._thre_int_at) if t is not None]
        done = self.line.peek_done(self.bit_ticks, self.fmt)
        if done is not None:
            times.append(done)
        if self.rx and self.ier & 1 and not self._cti_active(self.now):
            times.append(self._last_rx_activity + CTI_CHARACTERS * self._char_ticks())
        return math.ceil(min(times)) if times else None

    # -- receiver -------------------------------------------------------------------------
    def _receive(self, value: int, fe: bool, pe: bool, brk: bool, t: float) -> None:
        self.counters["rx_chars"] += 1
        if len(self.rx) >= self.depth:
            self.lsr_errors |= Lsr.OE
            self.counters["rx_overruns"] += 1
            return
        errors = (Lsr.FE if fe else 0) | (Lsr.PE if pe else 0) | (Lsr.BI if brk else 0)
        if errors:
            self.counters["rx_errors"] += 1
        self.rx.append((value & ((1 << self.fmt.data_bits) - 1), errors))
        self._last_rx_activity = t
        self._show_top()

    def _show_top(self) -> None:
        if self.rx and not self._top_shown:
            self.lsr_errors |= self.rx[0][1]
            self._top_shown = True

    def _cti_active(self, now: float) -> bool:
        return bool(self.rx) and now >= self._last_rx_activity + CTI_CHARACTERS * self._char_ticks()

    def _read_rbr(self) -> int:
        if not self.rx:
            return 0  # RBR with no data: the last value is undefined; the model reads 0
        value, _ = self.rx.popleft()
        self._top_shown = False
        self._last_rx_activity = float(self.now)
        self._show_top()
        return value

    # -- transmitter ----------------------------------------------------------------------
    def _write_thr(self, value: int) -> None:
        self._thre_int, self._thre_int_at = False, None
        if len(self.tx) >= self.depth:
            self.counters["tx_fifo_overflows"] += 1
            return
        self.tx.append(value & 0xFF)
        self._tx_peak = max(self._tx_peak, len(self.tx))
        if self._tsr_until is None:
            self._load_tsr(float(self.now))

    def _load_tsr(self, t: float) -> None:
        if not self.tx or not self.ter & 0x80:
            return
        value = self.tx.popleft()
        bit = self.bit_ticks
        fmt = self.fmt
        self._tsr_until = t + fmt.n_bits * bit
        self._sent.append(TxByte(t, self._tsr_until, value, bit, fmt))
        self.counters["tx_bytes"] += 1
        if not self.tx:  # the FIFO just emptied: a THRE event
            delay = 0.0 if self._tx_peak >= 2 else (fmt.n_bits - fmt.stop_bits) * bit
            self._thre_int_at = t + delay
            self._tx_peak = 0

    # -- interrupts -----------------------------------------------------------------------
    def _pending(self) -> Iir:
        ier = self.ier
        if ier & 4 and self.lsr_errors & _ERRORS:
            return Iir.RLS
        if ier & 1 and self.rx:
            if len(self.rx) >= self.trigger:
                return Iir.RDA
            if self._cti_active(self.now):
                return Iir.CTI
        if ier & 2 and self._thre_int:
            return Iir.THRE
        return Iir.NONE

    @property
    def irq(self) -> bool:
        return self._pending() != Iir.NONE

    def lsr(self) -> int:
        """LSR's value (without the read's side effects)."""
        value = self.lsr_errors & _ERRORS
        if self.rx:
            value |= Lsr.DR
        if not self.tx:
            value |= Lsr.THRE
            if self._tsr_until is None:
                value |= Lsr.TEMT
        if any(err for _, err in self.rx):
            value |= Lsr.RXFE
        return value

    # -- registers ------------------------------------------------------------------------
    def read(self, offset: int, tick: int) -> int:
        self.advance_to(tick)
        dlab = self.lcr & 0x80
        if offset == UartReg.RBR_THR_DLL:
            return self.dll if dlab else self._read_rbr()
        if offset == UartReg.IER_DLM:
            return self.dlm if dlab else self.ier
        if offset == UartReg.IIR_FCR:
            pending = self._pending()
            if pending == Iir.THRE:
                self._thre_int = False
            return int(pending) | (0xC0 if self.fcr & 1 else 0)
        if offset == UartReg.LSR:
            value = self.lsr()
            self.lsr_errors = 0
            return value
        if self.modem and offset == UartReg.MSR:
            return 0
        values: dict[int, int] = {UartReg.LCR: self.lcr, UartReg.SCR: self.scr, UartReg.ACR: self.acr,
                                  UartReg.FDR: self.fdr, UartReg.TER: self.ter}
        if self.modem:
            values[UartReg.MCR] = self.mcr
        if offset in values:
            return values[offset]
        raise self.unmodelled(offset, "read")

    def write(self, offset: int, value: int, tick: int) -> None:
        self.advance_to(tick)
        value &= 0xFFFF_FFFF
        dlab = self.lcr & 0x80
        if offset == UartReg.RBR_THR_DLL:
            if dlab:
                self.dll = value & 0xFF
            else:
                self._write_thr(value)
        elif offset == UartReg.IER_DLM:
            if dlab:
                self.dlm = value & 0xFF
            else:
                if value & 2 and not self.ier & 2 and not self.tx:
                    self._thre_int = True
                self.ier = value & (0x38F if self.modem else 0x307)
        elif offset == UartReg.IIR_FCR:
            self._write_fcr(value)
        elif offset == UartReg.LCR:
            self.lcr = value & 0xFF
        elif offset == UartReg.SCR:
            self.scr = value & 0xFF
        elif offset == UartReg.ACR:
            if value & 1:
                raise NotModelled(self.base + offset, f"{self.name} auto-baud")
            self.acr = value & 0x307
        elif offset == UartReg.FDR:
            self.fdr = value & 0xFF
        elif offset == UartReg.TER:
            self.ter = value & 0x80
            if self.ter and self._tsr_until is None:
                self._load_tsr(float(self.now))
        elif self.modem and offset == UartReg.MCR:
            if value & 0xD0:
                raise NotModelled(self.base + offset, f"{self.name} loopback or auto flow control")
            self.mcr = value & 0xFF
        elif offset in (UartReg.LSR, UartReg.MSR) and (offset == UartReg.LSR or self.modem):
            raise self.read_only(offset, UartReg(offset).name)
        else:
            raise self.unmodelled(offset, "write")

    def _write_fcr(self, value: int) -> None:
        if (value ^ self.fcr) & 1:  # switching the FIFOs on or off empties them
            self.rx.clear()
            self.tx.clear()
        if value & 2:
            self.rx.clear()
            self._top_shown = False
        if value & 4:
            self.tx.clear()
        self.fcr = value & 0xC1  # the reset bits clear themselves
