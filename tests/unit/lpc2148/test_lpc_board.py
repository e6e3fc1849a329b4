"""The system control block and the whole bus: the PLL feed sequence and lock, a real start-up
sequence run as register accesses, idle until a timer interrupt, the unmodelled-register
errors, and the pins (UART bytes only through selected pins, captures, PWM widths)."""

from __future__ import annotations

import pytest

from emulators.lpc2148 import Lpc2148, NotModelled, RegisterAccessError, ScbParams, UnmodelledRegister

SCB = 0xE01F_C000
PLLCON, PLLCFG, PLLSTAT, PLLFEED = SCB + 0x80, SCB + 0x84, SCB + 0x88, SCB + 0x8C
T0 = 0xE000_4000
VIC = 0xFFFF_F000


def feed(b: Lpc2148, cycle: int) -> None:
    b.write(PLLFEED, 0xAA, 4, cycle)
    b.write(PLLFEED, 0x55, 4, cycle + 1)


def test_reset_state() -> None:
    b = Lpc2148()
    assert b.read(SCB + 0xC4, 4, 0) == 0x0018_17BE  # PCONP
    assert b.read(SCB + 0x100, 4, 0) == 0  # VPBDIV: PCLK = CCLK / 4
    assert b.read(SCB + 0x004, 4, 0) == 7  # MAMTIM
    assert b.read(SCB + 0x180, 4, 0) == 1  # RSIR: power-on reset
    assert b.read(PLLSTAT, 4, 0) == 0
    assert b.cclk_hz == 12_000_000 and b.time.pclk_hz == 3e6


def test_pll_feed_must_be_aa_55_on_consecutive_apb_accesses() -> None:
    b = Lpc2148()
    b.write(PLLCFG, 0x24, 4, 0)
    b.write(PLLCON, 1, 4, 0)
    assert b.read(PLLSTAT, 4, 0) == 0  # not fed: nothing in effect
    b.write(PLLFEED, 0xAA, 4, 1)
    b.read(0xE000_4008, 4, 2)  # another APB access in between voids the feed
    b.write(PLLFEED, 0x55, 4, 3)
    assert b.read(PLLSTAT, 4, 4) == 0 and b.scb.pll0.counters["bad_feeds"] == 1
    b.write(PLLFEED, 0x55, 4, 5)
    b.write(PLLFEED, 0xAA, 4, 6)  # wrong order
    assert b.read(PLLSTAT, 4, 7) == 0
    feed(b, 10)
    assert b.read(PLLSTAT, 4, 12) == 0x124  # M-1 = 4, P = 2, PLLE


def test_pll_locks_after_the_lock_time_and_connects() -> None:
    b = Lpc2148(ScbParams(pll_lock_us=100.0))
    b.write(PLLCFG, 0x24, 4, 0)
    b.write(PLLCON, 1, 4, 0)
    feed(b, 0)
    lock = 1 + 1200  # 100 us at 12 MHz after the feed's second write
    assert b.next_event_cycle() == lock
    assert not b.read(PLLSTAT, 4, lock - 1) >> 10 & 1
    assert b.read(PLLSTAT, 4, lock) >> 10 & 1
    b.write(PLLCON, 3, 4, lock + 10)
    feed(b, lock + 11)
    assert b.cclk_hz == 60_000_000
    assert b.t_ns == (lock + 12) * 1000 // 12  # time up to the connect ran at 12 MHz


def test_pll_outside_the_cco_range_never_locks() -> None:
    b = Lpc2148()
    b.write(PLLCFG, 0x04, 4, 0)  # M = 5, P = 1: Fcco = 120 MHz, below 156 MHz
    b.write(PLLCON, 1, 4, 0)
    feed(b, 0)
    assert b.next_event_cycle() is None
    assert not b.read(PLLSTAT, 4, 1_000_000) >> 10 & 1


def startup(b: Lpc2148) -> int:
    """A typical LPC2148 start-up: MAM, PLL to 60 MHz, PCLK = CCLK, UART0 at 115200 8N1 on
    P0.0/P0.1, Timer0 interrupting at 400 Hz through VIC slot 0. Returns the cycle after it."""
    c = 0
    w = b.write
    w(SCB + 0x000, 0, 4, c)
    w(SCB + 0x004, 3, 4, c)
    w(SCB + 0x000, 2, 4, c)
    w(PLLCFG, 0x24, 4, c)
    w(PLLCON, 1, 4, c)
    feed(b, c)
    while not b.read(PLLSTAT, 4, c) & (1 << 10):
        c += 5
    w(PLLCON, 3, 4, c)
    feed(b, c)
    w(SCB + 0x100, 1, 4, c + 2)
    w(0xE002_C000, 0b0101, 4, c + 3)
    w(0xE000_C00C, 0x83, 1, c + 4)
    w(0xE000_C000, 33, 1, c + 4)  # 60 MHz / (16 x 33) = 113 636 bit/s
    w(0xE000_C00C, 0x03, 1, c + 4)
    w(0xE000_C008, 0x07, 1, c + 4)
    w(T0 + 0x18, 150_000 - 1, 4, c + 5)  # MR0: 2.5 ms at PCLK 60 MHz
    w(T0 + 0x14, 0b011, 4, c + 5)
    w(VIC + 0x100, 0x1234, 4, c + 6)
    w(VIC + 0x200, 0x20 | 4, 4, c + 6)
    w(VIC + 0x010, 1 << 4, 4, c + 6)
    w(T0 + 0x04, 1, 4, c + 7)
    return c + 7


def test_startup_then_idle_until_the_timer_interrupt() -> None:
    b = Lpc2148()
    start = startup(b)
    assert b.cclk_hz == 60_000_000 and b.time.pclk_hz == 60e6
    assert b.scb.mamcr == 2 and b.scb.mamtim == 3
    b.write(SCB + 0xC0, 1, 4, start + 1)  # PCON.IDL
    assert b.sleeping
    wake = b.next_event_cycle()
    assert wake == start + 149_999  # TC counts from 0 and reaches MR0 = 149 999 after as many ticks
    b.advance_to(wake - 1)
    assert b.sleeping and not b.irq_request
    b.advance_to(wake)
    assert b.irq_request and not b.sleeping
    assert b.read(VIC + 0x030, 4, wake + 20) == 0x1234  # the IRQ vector's LDR PC, [PC, #-0xFF0]
    b.write(T0, 1, 4, wake + 40)  # clear MR0's flag
    b.write(VIC + 0x030, 0, 4, wake + 41)
    assert not b.irq_request
    assert b.next_event_cycle() == wake + 150_000


def test_uart_bytes_flow_only_through_selected_pins() -> None:
    b = Lpc2148()
    start = startup(b)
    b.write(0xE002_C000, 0, 4, start)  # P0.0/P0.1 back to GPIO
    b.uart_line_in(0, b"abc", start + 10, 115200)
    b.write(0xE000_C000, 0x41, 1, start + 20)
    b.advance(100_000)
    assert b.read(0xE000_C014, 1, b.cycle) & 1 == 0
    assert b.take_uart_tx(0) == []
    assert b.counters["uart0_rx_pin_not_selected"] == 3 and b.counters["uart0_tx_pin_not_selected"] == 1
    b.write(0xE002_C000, 0b0101, 4, b.cycle)
    b.uart_line_in(0, b"abc", b.cycle, 115200)
    b.advance(100_000)
    assert bytes(b.read(0xE000_C000, 1, b.cycle) for _ in range(3)) == b"abc"  # 1.4 % apart: fine


def test_a_uart_at_the_wrong_baud_reads_garbage() -> None:
    b = Lpc2148()
    startup(b)
    b.uart_line_in(0, b"\x55\xaa\x33\xcc", b.cycle, 57600)
    b.advance(200_000)
    data = bytes(b.read(0xE000_C000, 1, b.cycle) for _ in range(len(b.uart0.rx)))
    assert data != b"\x55\xaa\x33\xcc"


def test_uart_tx_times_in_cycles() -> None:
    b = Lpc2148()
    start = startup(b)
    b.write(0xE000_C000, 0x41, 1, start + 100)
    b.advance(20_000)
    (tx,) = b.take_uart_tx(0)
    assert tx.value == 0x41 and tx.start_cycle == start + 100
    assert tx.end_cycle - tx.start_cycle == 10 * 16 * 33  # PCLK = CCLK
    assert tx.baud == pytest.approx(60e6 / (16 * 33))


def test_capture_through_a_pin() -> None:
    b = Lpc2148()
    start = startup(b)
    b.write(0xE002_C000, 0b0101 | (0b10 << 20), 4, start)  # P0.10 = CAP1.0
    b.write(0xE000_8028, 0b111, 4, start)  # CAP1.0 both edges, interrupt
    b.write(0xE000_8004, 1, 4, start)
    b.pin_edge(0, 10, True, start + 1000)
    assert b.read(0xE000_802C, 4, start + 1001) == 1000 and b.read(0xE000_8000, 4, start + 1001) == 0x10
    b.pin_edge(0, 11, True, start + 2000)  # P0.11 is a GPIO: no capture
    assert b.read(0xE000_802C, 4, start + 2001) == 1000 and b.gpio.level(0, 11)


def test_pwm_pulse_widths_for_the_escs() -> None:
    b = Lpc2148()
    start = startup(b)
    w = b.write
    w(0xE001_400C, 59, 4, start)  # PR: 1 us counts at 60 MHz
    w(0xE001_4018, 2499, 4, start)  # 400 Hz
    w(0xE001_401C, 1100, 4, start)
    w(0xE001_4014, 0b010, 4, start)
    w(0xE001_404C, 1 << 9, 4, start)
    w(0xE001_4004, 0b1001, 4, start)
    assert b.take_pwm() == []  # PWM1's pin not selected
    w(0xE002_C000, 0b0110, 4, start + 1)  # P0.0 = PWM1 (2), P0.1 = RXD0 (1)
    (pulse,) = b.take_pwm()
    assert (pulse.channel, pulse.pulse_us, pulse.period_us) == (1, 1100.0, 2500.0)
    w(0xE001_401C, 1500, 4, start + 2)
    w(0xE001_4050, 0b10, 4, start + 2)
    b.advance(150_000)
    (pulse,) = b.take_pwm()
    assert pulse.pulse_us == 1500.0 and pulse.cycle == start + 150_000


def test_unmodelled_and_misused_registers_raise_naming_the_address() -> None:
    b = Lpc2148()
    with pytest.raises(UnmodelledRegister, match="0xE001C000"):
        b.read(0xE001_C000, 4, 0)  # I2C0
    with pytest.raises(UnmodelledRegister, match="0xE000C024"):
        b.write(0xE000_C024, 0, 4, 0)  # a UART0 offset with no register
    with pytest.raises(UnmodelledRegister, match="0xE0300000"):
        b.read(0xE030_0000, 4, 0)
    with pytest.raises(RegisterAccessError, match="byte lane"):
        b.write(0xE002_8001, 1, 1, 0)
    assert b.read(0xE002_C001, 1, 0) == 0  # a byte read of lane 1
    b.write(SCB + 0xC4, 0, 4, 1)  # PCONP: everything off
    with pytest.raises(RegisterAccessError, match="powered off"):
        b.read(T0 + 0x08, 4, 2)
    with pytest.raises(NotModelled, match="power-down"):
        b.write(SCB + 0xC0, 2, 4, 3)
    with pytest.raises(NotModelled, match="fast GPIO"):
        b.write(SCB + 0x1A0, 1, 4, 3)


def test_a_timer_powered_off_resumes_where_it_stopped() -> None:
    b = Lpc2148()
    b.write(T0 + 0x04, 1, 4, 0)
    b.write(SCB + 0xC4, 0x0018_17BE & ~2, 4, 400)  # Timer0 off at PCLK tick 100
    b.write(SCB + 0xC4, 0x0018_17BE, 4, 4000)
    assert b.read(T0 + 0x08, 4, 4400) == 200


def test_external_interrupt_level_and_edge() -> None:
    b = Lpc2148()
    b.write(0xE002_C000, 0b11 << 2, 4, 0)  # P0.1 = EINT0
    b.write(VIC + 0x010, 1 << 14, 4, 0)
    b.pin_edge(0, 1, False, 10)  # low: active in level mode
    assert b.irq_request and b.read(SCB + 0x140, 4, 11) == 1
    b.write(SCB + 0x140, 1, 4, 12)  # still low: the flag stays
    assert b.read(SCB + 0x140, 4, 13) == 1
    b.pin_edge(0, 1, True, 20)
    b.write(SCB + 0x140, 1, 4, 21)
    assert b.read(SCB + 0x140, 4, 22) == 0 and not b.irq_request
    b.write(SCB + 0x148, 1, 4, 23)  # edge-sensitive, falling
    b.pin_edge(0, 1, False, 30)
    b.write(SCB + 0x140, 1, 4, 31)
    assert b.read(SCB + 0x140, 4, 32) == 0  # an edge's flag clears
