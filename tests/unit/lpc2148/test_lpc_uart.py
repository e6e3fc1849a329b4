"""UART0/1 against UM10139's UART chapters: reset values, DLAB, IIR priorities (RLS, RDA, CTI,
THRE), LSR bits, the THRE start-up rule, paced TX; hypothesis properties of the RX FIFO:
bytes in == bytes out unless overrun, OE set exactly when a byte arrives at a full FIFO, RDA
exactly at the trigger level."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from emulators.lpc2148 import NotModelled, RegisterAccessError, Uart, UnmodelledRegister
from emulators.lpc2148.uart import Iir, Lsr, UartReg

BIT = 128.0  # DLL = 8: 16 x 8 PCLK ticks a bit
CHAR = 10 * BIT


def uart(fcr: int = 0x07, ier: int = 0) -> Uart:
    u = Uart(0xE000_C000, "UART0")
    u.write(UartReg.LCR, 0x83, 0)
    u.write(UartReg.RBR_THR_DLL, 8, 0)
    u.write(UartReg.IER_DLM, 0, 0)
    u.write(UartReg.LCR, 0x03, 0)
    u.write(UartReg.IIR_FCR, fcr, 0)
    u.write(UartReg.IER_DLM, ier, 0)
    return u


def test_reset_values() -> None:
    u = Uart(0xE000_C000, "UART0")
    assert u.read(UartReg.IIR_FCR, 0) == 0x01
    assert u.read(UartReg.LSR, 0) == 0x60
    assert u.read(UartReg.LCR, 0) == 0 and u.read(UartReg.IER_DLM, 0) == 0
    assert u.read(UartReg.FDR, 0) == 0x10 and u.read(UartReg.TER, 0) == 0x80
    u.write(UartReg.LCR, 0x80, 0)
    assert u.read(UartReg.RBR_THR_DLL, 0) == 1 and u.read(UartReg.IER_DLM, 0) == 0
    u.write(UartReg.SCR, 0x5A, 0)
    assert u.read(UartReg.SCR, 0) == 0x5A


def test_divisor_and_fractional_divider() -> None:
    u = uart()
    assert u.bit_ticks == 128.0  # 15 MHz PCLK / 128 = 117 188 bit/s for 115 200
    u.write(UartReg.FDR, (12 << 4) | 1, 0)  # x (1 + 1/12)
    assert u.bit_ticks == pytest.approx(16 * 8 * 13 / 12)


def test_bytes_arrive_at_the_stop_bit_and_raise_rda_at_the_trigger() -> None:
    u = uart(fcr=0x47, ier=1)  # trigger 4
    u.line_in(b"abcd", 0.0, BIT)
    assert u.next_event() == 9.5 * BIT
    u.advance_to(int(3 * CHAR + 9.5 * BIT) - 1)
    assert len(u.rx) == 3 and not u.irq
    u.advance_to(int(3 * CHAR + 9.5 * BIT))
    assert u.read(UartReg.IIR_FCR, u.now) == 0xC0 | Iir.RDA
    assert bytes(u.read(0, u.now) for _ in range(4)) == b"abcd"
    assert u.read(UartReg.IIR_FCR, u.now) == 0xC1


def test_character_timeout_after_four_character_times() -> None:
    u = uart(fcr=0x87, ier=1)  # trigger 8
    u.line_in(b"x", 0.0, BIT)
    arrived = int(9.5 * BIT)
    deadline = arrived + int(4 * CHAR)
    u.advance_to(arrived)
    assert u.next_event() == deadline
    u.advance_to(deadline - 1)
    assert u.read(UartReg.IIR_FCR, deadline - 1) & 0xF == Iir.NONE
    u.advance_to(deadline)
    assert u.read(UartReg.IIR_FCR, deadline) & 0xF == Iir.CTI
    assert u.read(0, deadline) == ord("x") and not u.irq


def test_rls_outranks_rda_and_clears_on_lsr_read() -> None:
    u = uart(fcr=0x07, ier=0x07)
    u.line_in(bytes(17), 0.0, BIT)  # one more than the FIFO holds: overrun
    u.advance_to(int(17 * CHAR))
    assert u.read(UartReg.IIR_FCR, u.now) & 0xF == Iir.RLS
    lsr = u.read(UartReg.LSR, u.now)
    assert lsr & Lsr.OE and lsr & Lsr.DR
    assert u.read(UartReg.IIR_FCR, u.now) & 0xF == Iir.RDA
    assert not u.read(UartReg.LSR, u.now) & Lsr.OE


def test_framing_errors_from_a_wrong_baud_show_with_their_character() -> None:
    u = uart(fcr=0x07, ier=0x04)
    u.line_in(b"\x55\xaa\x0f", 0.0, 2 * BIT)  # the device at half the programmed rate
    u.advance_to(100_000)
    assert u.counters["rx_errors"] > 0
    assert u.read(UartReg.LSR, u.now) & (Lsr.FE | Lsr.RXFE)


def test_thre_interrupt_start_up_rule() -> None:
    u = uart(ier=0)
    u.write(UartReg.IER_DLM, 2, 0)
    assert u.read(UartReg.IIR_FCR, 0) & 0xF == Iir.THRE  # enabled with the FIFO empty
    assert u.read(UartReg.IIR_FCR, 0) & 0xF == Iir.NONE  # the IIR read cleared it
    u.write(0, 0x41, 10)  # one character: straight to the shift register
    assert u.read(UartReg.LSR, 10) & Lsr.THRE and not u.read(UartReg.LSR, 10) & Lsr.TEMT
    assert not u.irq
    delayed = 10 + int(9 * BIT)  # one character time less the stop bit
    assert u.next_event() == delayed
    u.advance_to(delayed)
    assert u.irq
    u.write(0, 0x42, delayed)
    u.write(0, 0x43, delayed)  # two held at once: THRE as soon as the FIFO empties
    assert not u.irq
    u.advance_to(int(10 + 2 * CHAR) - 1)  # 0x43 goes to the shift register at 10 + 2 characters
    assert not u.irq
    u.advance_to(int(10 + 2 * CHAR))
    assert u.irq


def test_tx_bytes_leave_back_to_back_at_the_rate() -> None:
    u = uart()
    for b in b"hi!":
        u.write(0, b, 100)
    u.advance_to(100 + int(3 * CHAR))
    sent = u.take_tx()
    assert [(s.value, s.start, s.end) for s in sent] == [
        (ord("h"), 100.0, 100 + CHAR), (ord("i"), 100 + CHAR, 100 + 2 * CHAR), (ord("!"), 100 + 2 * CHAR, 100 + 3 * CHAR)]
    assert u.read(UartReg.LSR, u.now) & Lsr.TEMT


def test_ter_holds_transmission() -> None:
    u = uart()
    u.write(UartReg.TER, 0, 0)
    u.write(0, 0x41, 0)
    u.advance_to(10_000)
    assert u.take_tx() == []
    u.write(UartReg.TER, 0x80, 10_000)
    assert [s.value for s in u.take_tx()] == [0x41]


def test_wrong_accesses() -> None:
    u = uart()
    with pytest.raises(RegisterAccessError, match="0xE000C014"):
        u.write(UartReg.LSR, 0, 0)
    with pytest.raises(UnmodelledRegister, match="0xE000C010"):
        u.read(UartReg.MCR, 0)  # UART0 has no modem control register
    with pytest.raises(NotModelled, match="auto-baud"):
        u.write(UartReg.ACR, 1, 0)
    u1 = Uart(0xE001_0000, "UART1", modem=True)
    assert u1.read(UartReg.MSR, 0) == 0
    with pytest.raises(NotModelled, match="loopback"):
        u1.write(UartReg.MCR, 0x10, 0)


@settings(max_examples=150)
@given(gaps=st.lists(st.integers(0, 3000), min_size=1, max_size=50),
       reads=st.lists(st.tuples(st.integers(0, 60_000), st.integers(0, 20)), max_size=20),
       trigger=st.integers(0, 3))
def test_fifo_overrun_and_trigger_properties(gaps: list[int], reads: list[tuple[int, int]], trigger: int) -> None:
    """Bytes arrive at chosen times, the firmware drains at chosen times: every byte is read
    or lost to an overrun; OE is seen iff a byte arrived at a full FIFO since the last LSR
    read; RDA iff the FIFO holds at least the trigger level."""
    level = (1, 4, 8, 14)[trigger]
    u = uart(fcr=0x07 | (trigger << 6), ier=1)
    starts, t = [], 0
    for gap in gaps:
        t += gap
        starts.append(t)
        t += int(10 * BIT)
    # (time, order, kind, value): a frame's start, its arrival at the stop bit, a firmware read
    events = [(s0, 0, "start", i & 0xFF) for i, s0 in enumerate(starts)]
    events += [(int(s0 + 9.5 * BIT), 1, "arrive", i & 0xFF) for i, s0 in enumerate(starts)]
    events += [(r, 2, "read", n) for r, n in reads]
    fifo: list[int] = []
    got, lost, overrun = 0, 0, False
    for when, _, kind, x in sorted(events):
        if kind == "start":
            u.line_in(bytes([x]), float(when), BIT)
        elif kind == "arrive":
            if len(fifo) == 16:
                lost += 1
                overrun = True
            else:
                fifo.append(x)
        else:
            u.advance_to(when)
            assert [v for v, _ in u.rx] == fifo
            assert (u.read(UartReg.IIR_FCR, when) & 0xF == Iir.RDA) == (len(fifo) >= level)
            assert bool(u.read(UartReg.LSR, when) & Lsr.OE) == overrun
            overrun = False
            for _ in range(x):
                if fifo:
                    assert u.read(0, when) == fifo.pop(0)
                    got += 1
    u.advance_to(t + 100)
    got += len(u.rx)
    assert got + lost == len(starts)
    assert u.counters["rx_overruns"] == lost
