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

Transmitting: :mod:`~emulators.lpc2148.uart_tx`.

Not modelled (NotModelled when selected): auto-baud (ACR start bit), UART1's loopback and
auto flow control (MCR bits 4, 6, 7); UART1's modem inputs read inactive (MSR 0), so there is
no modem status interrupt; LCR's break control does not hold the TX line low.
"""

from __future__ import annotations

import math
from collections import deque

from emulators.lpc2148.errors import NotModelled
from emulators.lpc2148 import uart_horizon, uart_tx
from emulators.lpc2148.line import FORMAT_8N1, FrameFormat, LineFrame, level_table
from emulators.lpc2148.uart_state import UartState

# the register map and records live in uart_regs; re-exported here (tests, the bus)
from emulators.lpc2148.uart_regs import (  # noqa: F401
    UART0_BASE, UART1_BASE, FIFO_DEPTH, TRIGGER_LEVELS, CTI_CHARACTERS, UartReg, Iir, Lsr, _ERRORS,
    TxByte, _RBR, _IER, _IIR, _LCR, _MCR, _LSR, _MSR, _SCR, _ACR, _FDR, _TER, _IIR_RLS, _IIR_RDA,
    _IIR_CTI, _IIR_THRE, _IIR_NONE, _DR, _OE, _PE, _FE, _BI, _THRE, _TEMT, _RXFE, _ERROR_BITS, _INF,
)

class Uart(UartState):
    """One UART; time in PCLK ticks. ``modem``: UART1's MCR and MSR exist."""

    @property
    def bit_ticks(self) -> float:
        """PCLK ticks per bit at the programmed divisor."""
        return self._bit

    @property
    def fmt(self) -> FrameFormat:
        return self._fmt

    @property
    def depth(self) -> int:
        return self._depth

    @property
    def trigger(self) -> int:
        return self._trigger

    def _char_ticks(self) -> float:
        return self._n_bits * self._bit

    # -- the device's side ------------------------------------------------------------------
    def line_in(self, data: bytes, tick: float, bit_ticks: float, fmt: FrameFormat = FORMAT_8N1) -> None:
        """A device sends ``data`` from ``tick`` on at ``bit_ticks`` PCLK ticks a bit, each
        frame after the previous one (its transmitter paces them back to back)."""
        self.advance_to(math.floor(tick))
        start = max(tick, self.line.line_free)
        levels = level_table(fmt)
        push = self.line.push
        for value in data:
            frame = LineFrame(start, bit_ticks, levels[value], value, fmt)
            push(frame)
            start = frame.end
        self._changed()

    def take_tx(self) -> list[TxByte]:
        """Drain the bytes sent since the last call."""
        out, self._sent = self._sent, []
        return out

    # -- time -----------------------------------------------------------------------------
    def advance_to(self, tick: int) -> None:
        if tick <= self.now:
            return  # everything due by then has been done
        work = self._work_at
        if work < 0:
            work = self._work()
        if tick < work:  # no character or transmitter event by then: only the time-out may pass
            if self._ne_valid and self._ne is not None and tick >= self._ne:
                self._ne_valid = self._nie_valid = False
            self.now = tick
            return
        self._changed()
        while True:
            due = uart_tx.due_before(self, tick)
            if due is None:
                break
            self._step(due)
        self._take_rx(tick)
        self.now = max(self.now, tick)

    def _step(self, t: float) -> None:
        self._take_rx(t)
        if self._thre_int_at is not None and self._thre_int_at <= t:
            self._thre_int, self._thre_int_at = True, None
        if self._tsr_until is not None and self._tsr_until <= t:
            self._tsr_until = None
            uart_tx.load_tsr(self, t)

    def next_event(self) -> int | None:
        if self._ne_valid:
            return self._ne
        best = self._work_at
        if best < 0:
            best = self._work()
        if self.rx and self.ier & 1 and not self._cti_active(self.now):
            cti = self._last_rx_activity + self._cti_ticks
            if cti < best:
                best = cti
        self._ne = None if best == _INF else math.ceil(best)
        self._ne_valid = True
        return self._ne

    def next_irq_event(self) -> int | None:
        """The tick at or before which the interrupt line may next change without a register
        access (None: not before one). Characters that change nothing (below the trigger
        level, no time-out between them) are not events: a burst's bytes are taken at once."""
        if not self._nie_valid:
            self._nie = uart_horizon.irq_horizon(self)
            self._nie_valid = True
        return self._nie

    # -- receiver -------------------------------------------------------------------------
    def _take_rx(self, t: float) -> None:
        if not self.line.frames:
            return
        chars = self.line.take_raw(t, self._bit, self._fmt)
        if not chars:
            return
        rx = self.rx
        depth = self._depth
        mask = self._data_mask
        overruns = errors_seen = 0
        for value, fe, pe, brk, done in chars:
            if len(rx) >= depth:
                self.lsr_errors |= _OE
                overruns += 1
                continue
            errors = (_FE if fe else 0) | (_PE if pe else 0) | (_BI if brk else 0)
            if errors:
                errors_seen += 1
                self._rx_errs += 1
            rx.append((value & mask, errors))
            self._last_rx_activity = done
            if not self._top_shown:
                self.lsr_errors |= rx[0][1]
                self._top_shown = True
        counters = self.counters
        counters["rx_chars"] += len(chars)
        if overruns:
            counters["rx_overruns"] += overruns
        if errors_seen:
            counters["rx_errors"] += errors_seen

    def _show_top(self) -> None:
        if self.rx and not self._top_shown:
            self.lsr_errors |= self.rx[0][1]
            self._top_shown = True

    def _read_rbr(self) -> int:
        if not self.rx:
            return 0  # RBR with no data: the last value is undefined; the model reads 0
        value, err = self.rx.popleft()
        if err:
            self._rx_errs -= 1
        self._top_shown = False
        self._last_rx_activity = float(self.now)
        self.rescheduled = True  # a new time-out from now: an event that may come before the others
        self._show_top()
        return value

    # -- transmitter ----------------------------------------------------------------------
    # -- interrupts -----------------------------------------------------------------------
    def _pending(self) -> Iir:
        return Iir(self._pending_code())

    @property
    def irq(self) -> bool:
        return self._pending_code() != _IIR_NONE

    def lsr(self) -> int:
        """LSR's value (without the read's side effects)."""
        value = self.lsr_errors & _ERROR_BITS
        if self.rx:
            value |= _DR
        if not self.tx:
            value |= _THRE
            if self._tsr_until is None:
                value |= _TEMT
        if self._rx_errs:
            value |= _RXFE
        return value

    # -- registers ------------------------------------------------------------------------
    def read(self, offset: int, tick: int) -> int:
        self.advance_to(tick)
        dlab = self.lcr & 0x80
        if offset == _LSR:
            value = self.lsr()
            if self.lsr_errors:
                self.lsr_errors = 0
                self._ne_valid = self._nie_valid = False
                self.rescheduled = True  # RLS ends: the line may rise again sooner
            return value
        if offset == _RBR:
            if dlab:
                return self.dll
            self._ne_valid = self._nie_valid = False
            return self._read_rbr()
        if offset == _IIR:
            pending = self._pending_code()
            if pending == _IIR_THRE:
                self._thre_int = False
                self._ne_valid = self._nie_valid = False
                self.rescheduled = True  # THRE ends: the line may rise again sooner
            return pending | (0xC0 if self.fcr & 1 else 0)
        if offset == _IER:
            return self.dlm if dlab else self.ier
        if self.modem and offset == _MSR:
            return 0
        if offset == _LCR:
            return self.lcr
        if offset == _SCR:
            return self.scr
        if offset == _ACR:
            return self.acr
        if offset == _FDR:
            return self.fdr
        if offset == _TER:
            return self.ter
        if self.modem and offset == _MCR:
            return self.mcr
        raise self.unmodelled(offset, "read")

    def write(self, offset: int, value: int, tick: int) -> None:
        self.advance_to(tick)
        self._changed()
        self.rescheduled = True
        value &= 0xFFFF_FFFF
        dlab = self.lcr & 0x80
        if offset == _RBR:
            if dlab:
                self.dll = value & 0xFF
                self._rates()
            else:
                uart_tx.write_thr(self, value)
        elif offset == _IER:
            if dlab:
                self.dlm = value & 0xFF
                self._rates()
            else:
                if value & 2 and not self.ier & 2 and not self.tx:
                    self._thre_int = True
                self.ier = value & (0x38F if self.modem else 0x307)
        elif offset == _IIR:
            self._write_fcr(value)
        elif offset == _LCR:
            self.lcr = value & 0xFF
            self._rates()
        elif offset == _SCR:
            self.scr = value & 0xFF
        elif offset == _ACR:
            if value & 1:
                raise NotModelled(self.base + offset, f"{self.name} auto-baud")
            self.acr = value & 0x307
        elif offset == _FDR:
            self.fdr = value & 0xFF
            self._rates()
        elif offset == _TER:
            self.ter = value & 0x80
            if self.ter and self._tsr_until is None:
                uart_tx.load_tsr(self, float(self.now))
        elif self.modem and offset == _MCR:
            if value & 0xD0:
                raise NotModelled(self.base + offset, f"{self.name} loopback or auto flow control")
            self.mcr = value & 0xFF
        elif offset in (_LSR, _MSR) and (offset == _LSR or self.modem):
            raise self.read_only(offset, UartReg(offset).name)
        else:
            raise self.unmodelled(offset, "write")

    def _write_fcr(self, value: int) -> None:
        if (value ^ self.fcr) & 1:  # switching the FIFOs on or off empties them
            self.rx.clear()
            self._rx_errs = 0
            self.tx.clear()
        if value & 2:
            self.rx.clear()
            self._rx_errs = 0
            self._top_shown = False
        if value & 4:
            self.tx.clear()
        self.fcr = value & 0xC1  # the reset bits clear themselves
        self._fifo_setup()
