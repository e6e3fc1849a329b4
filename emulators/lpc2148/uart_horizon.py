"""The UART's look-ahead: when its interrupt line may next change without a register access
(:meth:`emulators.lpc2148.uart.Uart.next_irq_event`), so the core can run a whole slice up to it.
Characters that change nothing (below the trigger level, no time-out between them) are not
events: a burst's bytes are taken at once."""

from __future__ import annotations

import math
from emulators.lpc2148.uart_regs import _IIR_CTI, _IIR_RDA, _IIR_RLS, _IIR_THRE, _INF
from emulators.lpc2148.uart_state import UartState



def irq_horizon(u: UartState) -> int | None:
    code: int = u._pending_code()
    if code == _IIR_RLS or code == _IIR_RDA or code == _IIR_THRE:
        return None  # asserted, and it stays so until the firmware reads or writes
    ier: int = u.ier
    best: float = _INF
    if ier & 2:  # THRE rises when the FIFO empties (at a load of the shift register)
        if u._thre_int_at is not None:
            best = u._thre_int_at
        elif u._tsr_until is not None and u.tx and u.ter & 0x80:
            t: float = u._tsr_until
            for _ in range(len(u.tx) - 1):
                t = t + u._n_bits * u._bit
            best = t
    if ier & 5:
        if code == _IIR_CTI:  # the time-out alone asserts it: the next character ends it
            if u.line.frames:
                done: float | None = u.line.peek_done(u._bit, u._fmt)
                if done is not None and done < best:
                    best = done
        else:
            rise = rx_rise(u)
            if rise < best:
                best = rise
    return None if best == _INF else math.ceil(best)


def rx_rise(u: UartState) -> float:
    """With the line low: when the receiver next raises it (RDA at the trigger level, the
    time-out, an overrun with RLS enabled), from the characters on the line."""
    ier: int = u.ier
    n: int = len(u.rx)
    last: float = u._last_rx_activity
    window: float = u._cti_ticks
    if not u.line.frames:
        return last + window if ier & 1 and n else _INF
    depth: int = u._depth
    trigger: int = u._trigger
    dones: list[float]
    complete: bool
    # with RDA enabled the trigger level comes within trigger - n characters; else an overrun
    # within depth - n + 1
    limit = (trigger - n if ier & 1 else depth - n + 1) + 1
    dones, complete = u.line.clean_dones(u._bit, u._fmt, limit if limit > 1 else 1)
    for done in dones:
        if ier & 1 and n:
            cti = last + window
            if done > math.ceil(cti):
                return cti  # the time-out comes before this character
        if n >= depth:
            if ier & 4:
                return done  # an overrun: OE, RLS
            continue
        n += 1
        last = done
        if ier & 1 and n >= trigger:
            return done
    if not complete:  # the next character is not read whole (it may be an error): stop at it
        nxt: float | None = u.line.peek_done(u._bit, u._fmt) if not dones else dones[-1]
        bound = _INF if nxt is None else nxt
        return min(bound, last + window) if ier & 1 and n else bound
    return last + window if ier & 1 and n else _INF
