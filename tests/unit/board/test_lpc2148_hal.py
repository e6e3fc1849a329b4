"""The firmware's lpc2148 hardware layer and startup code on the emulated board, wired to the
peripheral models at their pins: a probe program (fw_hal_probe.c) on the layer, and the flight
firmware's own ARM build reaching main."""

from __future__ import annotations

from pathlib import Path

import pytest

from emulators.lpc2148 import Lpc2148
from hil.board.core import SRAM_BASE, SRAM_SIZE, Core
from hil.board.elf import load_elf
from hil.board.stacks import stack_use
from tests.unit.board.armfw import build_firmware, build_on_hal

PROBE = Path(__file__).with_name("fw_hal_probe.c")
STACK_PAINT = 0xDEAD_BEEF
MS = 60_000  # cycles at 60 MHz


def boot(elf: Path) -> tuple[Core, Lpc2148, object]:
    image = load_elf(elf)
    bus = Lpc2148()
    core = Core(bus)
    core.uc.mem_write(SRAM_BASE, b"\xA5" * SRAM_SIZE)  # power-on garbage: .bss must be zeroed by startup
    core.load(image)
    core.reset(image.entry)
    return core, bus, image


def test_startup_reaches_main_with_the_clocks_memory_and_stacks_set() -> None:
    core, bus, image = boot(build_on_hal(PROBE))
    at_main = core.run_to(image.symbol("main"), 2_000_000)
    assert bus.cclk_hz == 60_000_000  # PLL0: 12 MHz x 5
    assert (bus.scb.mamcr, bus.scb.mamtim, bus.scb.pclk_div) == (2, 3, 1)
    assert at_main < 50_000  # the PLL's 100 us lock at 12 MHz, then the copies and the paint
    bss, bss_end = image.symbol("__bss_start"), image.symbol("__bss_end")
    assert core.read_memory(bss, bss_end - bss) == bytes(bss_end - bss)
    data, data_end = image.symbol("__data_start"), image.symbol("__data_end")
    load = image.symbol("__data_load")
    assert core.read_memory(data, data_end - data) == core.read_memory(load, data_end - data)
    bottom, top = image.symbol("__stack_bottom"), image.symbol("__stack_region_end")
    words = core.read_memory(bottom, top - bottom)
    assert all(int.from_bytes(words[i:i + 4], "little") == STACK_PAINT for i in range(0, len(words) - 64, 4))
    assert core.reg(12) == image.symbol("__svc_stack_top")  # UC_ARM_REG_SP in supervisor mode
    assert core.cpsr & 0xDF == 0xD3  # supervisor, IRQ and FIQ masked until hal_open


def test_the_layer_moves_bytes_spi_words_edges_and_pulses() -> None:
    core, bus, image = boot(build_on_hal(PROBE))
    spi: list[int] = []
    bus.attach_spi_slave(lambda mosi, transfer: (spi.append(mosi), mosi ^ 0xFF)[1])
    core.run_until(5 * MS)
    assert core.semihost.lines[:3] == ["main", "open", "spi 0 f9fffff9bfff"]
    assert spi == [0x06, 0x00, 0x00, 0x06, 0x40, 0x00]

    # the bench puts a device's bytes and edges on the pins at the core's current cycle
    imu = bytes(range(69))  # one MTData2-sized burst at 921600 baud: RDA at 8 bytes, then CTI
    bus.uart_line_in(0, imu, core.cycles, baud=921600)
    core.run_until(core.cycles + 2 * MS)
    bus.pin_edge(0, 10, True, core.cycles)
    core.run_until(core.cycles + 300 * 60)
    bus.pin_edge(0, 10, False, core.cycles)
    core.run_until(core.cycles + 10 * MS)
    echoed = [line for line in core.semihost.lines if line.startswith("echo ")]
    assert sum(int(line.split()[1]) for line in echoed) == 69
    core.run_until(core.cycles + 20 * MS)  # the echo leaves UART1 at 115200 baud: 6 ms
    assert bytes(tx.value for tx in bus.take_uart_tx(1)) == imu

    pulses = {p.channel: p.pulse_us for p in bus.take_pwm()}
    assert pulses == {2: pytest.approx(1000.0), 5: pytest.approx(1250.0)}
    outputs = bus.timer1.take_match_outputs()
    for channel, width_us in ((2, 1500), (3, 2000)):
        changes = [o for o in outputs if o.channel == channel]
        rises = [o.tick for o in changes if o.level]
        falls = [o.tick for o in changes if not o.level]
        assert len(rises) >= 10
        assert {f - r for r, f in zip(rises, falls)} == {width_us * 60}  # PCLK ticks
        assert {b - a for a, b in zip(rises, rises[1:])} == {2500 * 60}

    core.run_until(core.cycles + 200 * MS)
    edges = [line.split()[1:] for line in core.semihost.lines if line.startswith("edge ")]
    assert [(e[2], e[3]) for e in edges] == [("1", "0"), ("0", "0")]  # level after the edge, no overrun
    assert [int(e[1]) for e in edges] == [1, 2]
    assert (int(edges[1][0]) - int(edges[0][0])) % 65536 == pytest.approx(300, abs=1)  # 1 us per count
    assert core.semihost.lines[-1] == "done overruns 0"
    assert core.semihost.exit_reason == 0x2_0026
    assert core.idle_cycles > 0.8 * (core.cycles - core.spin_cycles)  # waiting in PCON idle, not spinning
    use = {u.mode: u for u in stack_use(image, core.read_memory)}
    assert {m: u.size_B for m, u in use.items()} == {"abt": 64, "und": 64, "fiq": 128, "irq": 1024, "svc": 5632}
    assert 256 < use["svc"].used_B < 5632 and 16 < use["irq"].used_B < 1024  # main's calls; the handlers
    assert use["fiq"].used_B == use["abt"].used_B == use["und"].used_B == 0
    core.uc.mem_write(image.symbol("__irq_stack_top") - 1024, b"\0\0\0\0")  # a write at the IRQ stack's end
    assert next(u for u in stack_use(image, core.read_memory) if u.mode == "irq").overflowed


def test_the_flight_firmware_reaches_main() -> None:
    core, bus, image = boot(build_firmware())
    assert core.run_to(image.symbol("main"), 2_000_000) < 50_000
    assert bus.cclk_hz == 60_000_000
