"""The UART's transmitter (UM10139, chapters "UART0" and "UART1").

Transmitting: THR writes fill the 16-byte TX FIFO (a write to a full FIFO is lost and
counted); the shift register sends one frame at a time at the programmed rate while TER bit 7
is set; :meth:`Uart.take_tx` gives each byte with its start and end tick. LSR.THRE: TX FIFO
empty; TEMT: FIFO and shift register empty. The THRE interrupt follows the manual's start-up
rule: when the FIFO empties having held fewer than two characters since the last THRE event,
the interrupt waits one character time less the stop bits; it clears on a THR write or an IIR
read that reports it. Enabling it in IER with the FIFO empty raises it at once.
"""

from __future__ import annotations

from emulators.lpc2148.uart_regs import TxByte
from emulators.lpc2148.uart_state import UartState



def write_thr(u: UartState, value: int) -> None:
    u._thre_int, u._thre_int_at = False, None
    if len(u.tx) >= u._depth:
        u.counters["tx_fifo_overflows"] += 1
        return
    u.tx.append(value & 0xFF)
    if len(u.tx) > u._tx_peak:
        u._tx_peak = len(u.tx)
    if u._tsr_until is None:
        load_tsr(u, float(u.now))


def load_tsr(u: UartState, t: float) -> None:
    if not u.tx or not u.ter & 0x80:
        return
    value = u.tx.popleft()
    bit = u._bit
    fmt = u._fmt
    u._tsr_until = t + fmt.n_bits * bit
    u._sent.append(TxByte(t, u._tsr_until, value, bit, fmt))
    u.counters["tx_bytes"] += 1
    if not u.tx:  # the FIFO just emptied: a THRE event
        delay = 0.0 if u._tx_peak >= 2 else (fmt.n_bits - fmt.stop_bits) * bit
        u._thre_int_at = t + delay
        u._tx_peak = 0


def due_before(u: UartState, tick: int) -> float | None:
    """The earliest transmitter event at or before ``tick``."""
    tsr: float | None = u._tsr_until
    thre: float | None = u._thre_int_at
    if tsr is not None and tsr <= tick:
        return thre if thre is not None and thre < tsr else tsr
    if thre is not None and thre <= tick:
        return thre
    return None
