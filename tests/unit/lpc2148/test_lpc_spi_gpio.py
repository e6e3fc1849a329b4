"""SPI0, GPIO and the pin connect block against UM10139: SPI0's status flags and their clearing
sequences, the clock counter rule, the MCP3204 model on the bus with its chip select on a GPIO
pin; IOSET/IOCLR/IOPIN/IODIR; PINSEL functions and reserved values."""

from __future__ import annotations

import pytest

from emulators.lpc2148 import Gpio, Lpc2148, NotModelled, PinSelect, RegisterAccessError, Spi, SpiTransfer
from emulators.lpc2148.spi import SpiReg
from emulators.mcp3204 import Mcp3204, Mcp3204Params, fig61_decode, fig61_request, quantize

SPCR_MASTER = 0x20


def master(spccr: int = 8, spcr: int = SPCR_MASTER) -> Spi:
    s = Spi()
    s.write(SpiReg.SPCCR, spccr, 0)
    s.write(SpiReg.SPCR, spcr, 0)
    return s


def test_reset_values() -> None:
    s = Spi()
    assert [s.read(r, 0) for r in SpiReg] == [0, 0, 0, 0, 0]


def test_a_transfer_takes_eight_clocks_and_sets_spif() -> None:
    s = master(spccr=10, spcr=SPCR_MASTER | 0x80)
    seen: list[tuple[int, SpiTransfer]] = []
    s.slave = lambda mosi, transfer: seen.append((mosi, transfer)) or 0xA5
    s.write(SpiReg.SPDR, 0x3C, 100)
    assert seen[0][0] == 0x3C and (seen[0][1].start, seen[0][1].end) == (100, 180)
    assert s.next_event() == 180
    s.advance_to(179)
    assert s.read(SpiReg.SPSR, 179) == 0 and not s.irq
    s.advance_to(180)
    assert s.read(SpiReg.SPSR, 180) == 0x80 and s.irq and s.read(SpiReg.SPINT, 180) == 1
    assert s.read(SpiReg.SPDR, 180) == 0xA5
    assert s.read(SpiReg.SPSR, 180) == 0  # SPSR read with SPIF, then SPDR: cleared
    s.write(SpiReg.SPINT, 1, 180)
    assert not s.irq


def test_spif_stays_without_the_status_read() -> None:
    s = master()
    s.write(SpiReg.SPDR, 1, 0)
    s.advance_to(64)
    s.read(SpiReg.SPDR, 64)
    assert s.read(SpiReg.SPSR, 64) & 0x80


def test_write_during_a_transfer_is_a_collision() -> None:
    s = master()
    s.write(SpiReg.SPDR, 1, 0)
    s.write(SpiReg.SPDR, 2, 10)
    assert s.read(SpiReg.SPSR, 10) == 0x40
    s.advance_to(64)
    assert [x.mosi for x in s.take_exchanges()] == [1]


def test_clock_counter_rule_and_slave_mode() -> None:
    with pytest.raises(RegisterAccessError, match="0xE002000C"):
        master(spccr=7).write(SpiReg.SPDR, 0, 0)
    with pytest.raises(RegisterAccessError, match="even"):
        master(spccr=9).write(SpiReg.SPDR, 0, 0)
    with pytest.raises(NotModelled, match="slave"):
        master(spcr=0).write(SpiReg.SPDR, 0, 0)
    with pytest.raises(RegisterAccessError, match="0xE0020004"):
        master().write(SpiReg.SPSR, 0, 0)


def test_mode_fault_on_ssel_low() -> None:
    s = master()
    s.set_ssel(False, 5)
    assert s.read(SpiReg.SPSR, 5) & 0x10 and not s.read(SpiReg.SPCR, 5) & SPCR_MASTER
    s.write(SpiReg.SPCR, SPCR_MASTER, 5)  # SPSR read, then SPCR written: MODF cleared
    assert not s.read(SpiReg.SPSR, 5) & 0x10


def test_mcp3204_on_spi0_with_chip_select_on_p0_20() -> None:
    """The wiring the bench uses: GPIO P0.20 as CS, SPI0 mode 0,0, the MCP3204 model."""
    volts = [0.5, 2.5, 4.085, 1.0]
    adc = Mcp3204(Mcp3204Params(), lambda ch, t_ns: volts[ch])
    board = Lpc2148()
    board.watch_gpio(0, 20, lambda level, cycle: adc.deselect(cycle) if level else adc.select(cycle))
    board.attach_spi_slave(lambda mosi, tr: adc.exchange(bytes([mosi]), tr.start, tr.mode)[0])
    w = board.write
    w(0xE002C000, 0x1500, 4, 0)  # P0.4-6: SCK0, MISO0, MOSI0
    w(0xE0028008, 1 << 20, 4, 0)  # P0.20 output
    w(0xE0028004, 1 << 20, 4, 0)  # CS high
    w(0xE002000C, 8, 4, 0)  # SPCCR
    w(0xE0020000, SPCR_MASTER, 4, 0)
    cycle = 100
    w(0xE002800C, 1 << 20, 4, cycle)  # CS low
    rx = []
    for byte in fig61_request(2):
        w(0xE0020008, byte, 1, cycle)
        while not board.read(0xE0020004, 1, cycle) & 0x80:
            cycle += 4
        rx.append(board.read(0xE0020008, 1, cycle))
    w(0xE0028004, 1 << 20, 4, cycle)
    assert fig61_decode(bytes(rx)) == quantize(4.085, 5.0) == 3346
    assert cycle >= 100 + 3 * 8 * 8 * 4  # 8 clocks of 8 PCLK ticks of 4 cycles each, per byte
    assert [(c.pin, c.level) for c in board.gpio.take_changes()][-2:] == [(20, False), (20, True)]


def test_gpio_set_clear_pin_dir() -> None:
    g = Gpio(PinSelect())
    assert [g.read(o) for o in (0x00, 0x04, 0x08, 0x10, 0x14, 0x18)] == [0] * 6
    g.write(0x08, 0xF0)
    g.write(0x04, 0x30)
    g.write(0x0C, 0x10)
    assert g.read(0x04) == 0x20
    g.drive(0, 0, True)
    g.drive(0, 4, True)  # an output: the driven level does not show
    assert g.read(0x00) == 0x21
    g.write(0x00, 0xC0)  # IOPIN write sets the output register
    assert g.read(0x04) == 0xC0
    g.write(0x14, 0xFFFF_FFFF)
    assert g.read(0x14) == 0xFFFF_0000  # port 1 has P1.16-31 only
    with pytest.raises(RegisterAccessError, match="0xE002800C"):
        g.read(0x0C)


def test_gpio_watchers_only_for_gpio_function_pins() -> None:
    sel = PinSelect()
    g = Gpio(sel)
    calls: list[tuple[bool, int]] = []
    g.watchers[(0, 0)] = lambda level, cycle: calls.append((level, cycle))
    g.write(0x08, 1)
    g.write(0x04, 1, 7)
    sel.write(0x00, 1)  # P0.0 = TXD0
    g.write(0x0C, 1, 9)
    assert calls == [(True, 7)]


def test_pin_functions_and_reserved_values() -> None:
    sel = PinSelect()
    assert sel.function(0, 0) == "GPIO"
    sel.write(0x00, 0b0101)
    assert (sel.function(0, 0), sel.function(0, 1)) == ("TXD0", "RXD0")
    sel.write(0x04, 0b11 << 28)
    assert sel.function(0, 30) == "CAP0.0" and sel.selected("CAP0.0") == [30]
    with pytest.raises(RegisterAccessError, match="P0.0 function 3"):
        sel.write(0x00, 0b11)
    sel.write(0x14, 0x0C)
    assert sel.function(1, 20) == "TRACE" and sel.function(1, 27) == "DEBUG"
