"""The UART's state (:class:`UartState`, the base of :class:`emulators.lpc2148.uart.Uart`):
its registers, FIFOs, the transmitter's timing, the rates the registers give and the cached
look-ahead, with what every part of the model reads of it (the pending interrupt, the rates).
The transmitter (:mod:`~emulators.lpc2148.uart_tx`) and the interrupt look-ahead
(:mod:`~emulators.lpc2148.uart_horizon`) work on it, typed, without importing the model."""

from __future__ import annotations

from collections import deque

from emulators.lpc2148.line import FORMAT_8N1, LineReceiver, format_from_lcr
from emulators.lpc2148.regs import RegisterFile
from emulators.lpc2148.uart_regs import (
    _ERROR_BITS, _IIR_CTI, _IIR_NONE, _IIR_RDA, _IIR_RLS, _IIR_THRE, _INF, CTI_CHARACTERS, FIFO_DEPTH,
    TRIGGER_LEVELS, TxByte,
)


class UartState(RegisterFile):
    """One UART's state; time in PCLK ticks."""

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
        #: characters in the RX FIFO with an error (LSR.RXFE)
        self._rx_errs = 0
        # the divisor's, LCR's and FCR's consequences, recomputed when they are written
        self._bit = 16.0
        self._fmt = FORMAT_8N1
        self._n_bits = 10
        self._cti_ticks = 0.0
        self._data_mask = 0xFF
        self._depth = 1
        self._trigger = 1
        self._rates()
        self._fifo_setup()
        #: the earliest tick with something to process (a transmitter event, a character
        #: complete); -1: not known. Register reads do not move it: only writes and bytes in.
        self._work_at = -1.0
        # next_event() and next_irq_event(), kept until the state changes
        self._ne_valid = False
        self._ne: int | None = None
        self._nie_valid = False
        self._nie: int | None = None

    # -- rates ----------------------------------------------------------------------------
    def _rates(self) -> None:
        dl = (self.dlm << 8 | self.dll) or 1
        div_add, mul = self.fdr & 0xF, (self.fdr >> 4) & 0xF
        self._bit = 16.0 * dl * (1.0 + div_add / mul) if div_add and mul else 16.0 * dl
        self._fmt = format_from_lcr(self.lcr)
        self._n_bits = self._fmt.n_bits
        self._data_mask = (1 << self._fmt.data_bits) - 1
        self._cti_ticks = CTI_CHARACTERS * (self._n_bits * self._bit)

    def _fifo_setup(self) -> None:
        self._depth = FIFO_DEPTH if self.fcr & 1 else 1
        self._trigger = TRIGGER_LEVELS[self.fcr >> 6 & 3] if self.fcr & 1 else 1

    def _changed(self) -> None:
        self._ne_valid = self._nie_valid = False
        self._work_at = -1.0

    def _work(self) -> float:
        """:attr:`_work_at`, computed."""
        best = _INF
        if self._tsr_until is not None:
            best = self._tsr_until
        if self._thre_int_at is not None and self._thre_int_at < best:
            best = self._thre_int_at
        if self.line.frames:
            done = self.line.peek_done(self._bit, self._fmt)
            if done is not None and done < best:
                best = done
        self._work_at = best
        return best

    def _pending_code(self) -> int:
        ier = self.ier
        if ier & 4 and self.lsr_errors & _ERROR_BITS:
            return _IIR_RLS
        if ier & 1 and self.rx:
            if len(self.rx) >= self._trigger:
                return _IIR_RDA
            if self.now >= self._last_rx_activity + self._cti_ticks:
                return _IIR_CTI
        if ier & 2 and self._thre_int:
            return _IIR_THRE
        return _IIR_NONE

    def _cti_active(self, now: float) -> bool:
        return bool(self.rx) and now >= self._last_rx_activity + self._cti_ticks
