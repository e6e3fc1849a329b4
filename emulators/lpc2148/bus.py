"""The LPC2148's peripheral bus: addresses to models, one clock for all of them, interrupt lines
into the VIC, and the idle state.

Memory map (UM10139 Rev. 4, chapter 2 "Memory addressing"; APB peripherals in 16 KB slots):
Timer0 0xE000 4000, Timer1 0xE000 8000, UART0 0xE000 C000, UART1 0xE001 0000, PWM 0xE001 4000,
SPI0 0xE002 0000, GPIO 0xE002 8000, PINSEL 0xE002 C000, system control 0xE01F C000, VIC
0xFFFF F000. Any other address in 0xE000 0000-0xE01F FFFF or 0xFFFF F000-0xFFFF FFFF (I2C, ADC,
SSP, RTC, WDT, USB, DAC...) raises UnmodelledRegister.

Accesses: :meth:`Lpc2148Bus.read` / :meth:`Lpc2148Bus.write` take the full address, the width
in bytes (1, 2, 4) and the CCLK cycle; the bus first lets time pass to that cycle. A byte or
halfword access at a register's address reads the low bits / writes the value zero-extended
(exact for the 8- and 16-bit registers: UART, SPI, PLL, PCON, VPBDIV...); a sub-word read at a
byte lane above 0 returns that lane; a sub-word write there raises RegisterAccessError. An
access to a peripheral powered off in PCONP raises RegisterAccessError; its clock stops while
it is off.

Time: the core counts CCLK cycles; the APB models count PCLK ticks (CCLK / VPBDIV); the bus
keeps both and nanoseconds (:mod:`~emulators.lpc2148.timebase`), following PLL connects and
VPBDIV writes. :meth:`Lpc2148Bus.next_event_cycle` is the next cycle at which a model changes
something on its own, so a core with nothing to run (idle, or in a wait loop) can skip there.
"""

from __future__ import annotations

from dataclasses import dataclass

from emulators.lpc2148.errors import RegisterAccessError, UnmodelledRegister
from emulators.lpc2148.gpio import GPIO_BASE, Gpio
from emulators.lpc2148.pinsel import PINSEL_BASE, PinSelect
from emulators.lpc2148.pwm import PWM_BASE, Pwm
from emulators.lpc2148.regs import RegisterFile, VicChannel
from emulators.lpc2148.scb import SCB_BASE, Pconp, ScbParams, SystemControl, ScbReg
from emulators.lpc2148.spi import SPI0_BASE, Spi, SpiSlave, SpiTransfer
from emulators.lpc2148.timebase import Timebase
from emulators.lpc2148.timer import TIMER0_BASE, TIMER1_BASE, Timer
from emulators.lpc2148.uart import UART0_BASE, UART1_BASE, Uart
from emulators.lpc2148.vic import VIC_BASE, Vic

APB_SLOT = 0x4000
_APB_SPACE = (0xE000_0000, 0xE020_0000)
_WIDTH_MASK = {1: 0xFF, 2: 0xFFFF, 4: 0xFFFF_FFFF}


@dataclass
class _Apb:
    """An APB peripheral on the PCLK clock, gated by a PCONP bit."""

    model: Timer | Uart | Pwm | Spi
    pconp: int
    channel: int
    offset: int = 0  #: PCLK ticks it missed while powered off
    frozen_at: int | None = None


class Lpc2148Bus:
    """Every modelled peripheral of one LPC2148, at CCLK cycle :attr:`cycle`."""

    def __init__(self, params: ScbParams = ScbParams()) -> None:
        self.scb = SystemControl(params)
        self.vic = Vic()
        self.timer0 = Timer(TIMER0_BASE, "TIMER0")
        self.timer1 = Timer(TIMER1_BASE, "TIMER1")
        self.uart0 = Uart(UART0_BASE, "UART0")
        self.uart1 = Uart(UART1_BASE, "UART1", modem=True)
        self.pwm = Pwm()
        self.spi0 = Spi()
        self.pinsel = PinSelect()
        self.gpio = Gpio(self.pinsel)
        self.time = Timebase(round(self.scb.cclk_hz(0)), self.scb.pclk_div)
        self.cycle = 0
        self.apb_accesses = 0
        self.apb: dict[int, _Apb] = {
            TIMER0_BASE: _Apb(self.timer0, Pconp.TIM0, VicChannel.TIMER0),
            TIMER1_BASE: _Apb(self.timer1, Pconp.TIM1, VicChannel.TIMER1),
            UART0_BASE: _Apb(self.uart0, Pconp.UART0, VicChannel.UART0),
            UART1_BASE: _Apb(self.uart1, Pconp.UART1, VicChannel.UART1),
            PWM_BASE: _Apb(self.pwm, Pconp.PWM0, VicChannel.PWM0),
            SPI0_BASE: _Apb(self.spi0, Pconp.SPI0, VicChannel.SPI0),
        }
        self._plain: dict[int, Gpio | PinSelect] = {GPIO_BASE: self.gpio, PINSEL_BASE: self.pinsel}

    # -- what the core reads ----------------------------------------------------------------
    @property
    def irq_request(self) -> bool:
        """nIRQ asserted by the VIC."""
        return self.vic.irq_request

    @property
    def fiq_request(self) -> bool:
        """nFIQ asserted by the VIC."""
        return self.vic.fiq_request

    @property
    def sleeping(self) -> bool:
        """PCON.IDL: the core waits for an interrupt (cleared when one is requested)."""
        return self.scb.sleeping

    @property
    def cclk_hz(self) -> int:
        return self.time.cclk_hz

    @property
    def t_ns(self) -> int:
        """Nanoseconds since reset at the current cycle."""
        return self.time.ns_at(self.cycle)

    # -- time -------------------------------------------------------------------------------
    def advance(self, cycles: int) -> None:
        """Let ``cycles`` CCLK cycles pass."""
        self.advance_to(self.cycle + cycles)

    def advance_to(self, cycle: int) -> None:
        """Let time pass up to CCLK ``cycle`` (never backwards)."""
        if cycle <= self.cycle:
            return
        lock = self.scb.next_event()
        if lock is not None and self.cycle < lock <= cycle:  # the PLL may connect at lock
            self._advance_models(lock)
            self.cycle = lock
            self._clocks_changed()
        self._advance_models(cycle)
        self.cycle = cycle
        self._update_lines()

    def _advance_models(self, cycle: int) -> None:
        pclk = self.time.pclk_at(cycle)
        for slot in self.apb.values():
            if slot.frozen_at is None:
                slot.model.advance_to(pclk - slot.offset)

    def next_event_cycle(self) -> int | None:
        """The next cycle (> :attr:`cycle`) at which a model changes something on its own."""
        times = []
        for slot in self.apb.values():
            if slot.frozen_at is None:
                tick = slot.model.next_event()
                if tick is not None:
                    times.append(self.time.cycle_of_pclk(tick + slot.offset))
        lock = self.scb.next_event()
        if lock is not None and lock > self.cycle:
            times.append(lock)
        return max(min(times), self.cycle + 1) if times else None

    def _clocks_changed(self) -> None:
        self.time.set_cclk_hz(self.cycle, round(self.scb.cclk_hz(self.cycle)))
        self.time.set_pclk_div(self.cycle, self.scb.pclk_div)

    def _update_lines(self) -> None:
        sources = self.scb.eint_lines() << VicChannel.EINT0
        if self.scb.pll_irq(self.cycle):
            sources |= 1 << VicChannel.PLL
        for slot in self.apb.values():
            if slot.model.irq:
                sources |= 1 << slot.channel
        self.vic.set_sources(sources)
        if self.scb.sleeping and (self.vic.irq_request or self.vic.fiq_request):
            self.scb.wake()

    def model_tick(self, model: RegisterFile) -> int:
        """The model's own clock now (PCLK ticks less those it spent powered off)."""
        slot = self.apb[model.base]
        return self.time.pclk_at(self.cycle) - slot.offset

    def cycle_of(self, model: RegisterFile, tick: float) -> int:
        """The CCLK cycle of a tick of ``model``'s clock."""
        return self.time.cycle_of_pclk(tick + self.apb[model.base].offset)

    # -- register access --------------------------------------------------------------------
    def read(self, address: int, width: int, cycle: int) -> int:
        """The ``width``-byte value at ``address`` at CCLK ``cycle``."""
        self.advance_to(cycle)
        lane = address & 3
        value = self._access(address - lane, None)
        self._update_lines()
        return (value >> (8 * lane)) & _WIDTH_MASK[width]

    def write(self, address: int, value: int, width: int, cycle: int) -> None:
        """Write ``value`` (``width`` bytes) to ``address`` at CCLK ``cycle``."""
        self.advance_to(cycle)
        if address & 3:
            raise RegisterAccessError(address, f"{width}-byte write at byte lane {address & 3} is not modelled")
        self._access(address, value & _WIDTH_MASK[width])
        self._update_lines()

    def _access(self, address: int, value: int | None) -> int:
        if address >= VIC_BASE:
            return self._rw(self.vic, address - VIC_BASE, value, 0)
        if not _APB_SPACE[0] <= address < _APB_SPACE[1]:
            raise UnmodelledRegister(address, "read" if value is None else "write", "outside the peripheral space")
        self.apb_accesses += 1
        base = address & ~(APB_SLOT - 1)
        offset = address - base
        if base == SCB_BASE:
            return self._scb(offset, value)
        if base in self._plain:
            return self._rw(self._plain[base], offset, value, self.cycle)
        slot = self.apb.get(base)
        if slot is None:
            raise UnmodelledRegister(address, "read" if value is None else "write", "no model at this APB slot")
        if slot.frozen_at is not None:
            raise RegisterAccessError(address, f"{slot.model.name} is powered off (PCONP bit {slot.pconp})")
        return self._rw(slot.model, offset, value, self.time.pclk_at(self.cycle) - slot.offset)

    @staticmethod
    def _rw(model: Vic | Gpio | PinSelect | Timer | Uart | Pwm | Spi, offset: int, value: int | None,
            tick: int) -> int:
        if value is None:
            return model.read(offset, tick)
        model.write(offset, value, tick)
        return 0

    def _scb(self, offset: int, value: int | None) -> int:
        if value is None:
            return self.scb.read(offset, self.cycle)
        pconp_before = self.scb.pconp
        self.scb.write(offset, value, self.cycle, self.apb_accesses)
        if offset == ScbReg.PCONP:
            self._power(pconp_before)
        self._clocks_changed()
        return 0

    def _power(self, before: int) -> None:
        pclk = self.time.pclk_at(self.cycle)
        for slot in self.apb.values():
            on = self.scb.powered(slot.pconp)
            if not on and slot.frozen_at is None:
                slot.frozen_at = pclk
            elif on and slot.frozen_at is not None:
                slot.offset += pclk - slot.frozen_at
                slot.frozen_at = None

    # -- wiring -----------------------------------------------------------------------------
    def attach_spi_slave(self, slave: SpiSlave) -> None:
        """``slave(mosi, transfer)`` answers SPI0's transfers; ``transfer`` in CCLK cycles."""
        def in_cycles(mosi: int, transfer: SpiTransfer) -> int:
            tr = transfer
            start, end = self.cycle_of(self.spi0, tr.start), self.cycle_of(self.spi0, tr.end)
            return slave(mosi, SpiTransfer(start, end, tr.sck_period * self.time.pclk_div, tr.bits, tr.cpol,
                                           tr.cpha, tr.lsb_first))
        self.spi0.slave = in_cycles
