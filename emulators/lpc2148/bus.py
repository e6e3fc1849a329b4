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
VPBDIV writes. When the models act (time passing lazily, the next events, the request lines
into the VIC): :mod:`~emulators.lpc2148.schedule`, the bus's base.
"""

from __future__ import annotations

from typing import Final

from emulators.lpc2148.errors import RegisterAccessError, UnmodelledRegister
from emulators.lpc2148.gpio import GPIO_BASE, Gpio
from emulators.lpc2148.pinsel import PINSEL_BASE, PinSelect
from emulators.lpc2148.pwm import PWM_BASE, Pwm
from emulators.lpc2148.regs import RegisterFile, VicChannel
from emulators.lpc2148.scb import SCB_BASE, Pconp, ScbParams, ScbReg, SystemControl
from emulators.lpc2148.spi import SPI0_BASE, Spi, SpiSlave, SpiTransfer
from emulators.lpc2148.schedule import ApbSlot, Schedule
from emulators.lpc2148.timer import TIMER0_BASE, TIMER1_BASE, Timer
from emulators.lpc2148.uart import Uart
from emulators.lpc2148.uart_regs import UART0_BASE, UART1_BASE
from emulators.lpc2148.vic import VIC_BASE, Vic

APB_SLOT = 0x4000
_SLOT_SHIFT: Final = 14
_APB_SPACE = (0xE000_0000, 0xE020_0000)
_APB_LOW: Final = 0xE000_0000
_APB_HIGH: Final = 0xE020_0000
_WIDTH_MASK = {1: 0xFF, 2: 0xFFFF, 4: 0xFFFF_FFFF}
_SCB_PAGE: Final = SCB_BASE >> _SLOT_SHIFT
_PCONP: Final = int(ScbReg.PCONP)


class Lpc2148Bus(Schedule):
    """Every modelled peripheral of one LPC2148, at CCLK cycle :attr:`cycle`."""

    def __init__(self, params: ScbParams = ScbParams()) -> None:
        scb = SystemControl(params)
        self.timer0 = Timer(TIMER0_BASE, "TIMER0")
        self.timer1 = Timer(TIMER1_BASE, "TIMER1")
        self.uart0 = Uart(UART0_BASE, "UART0")
        self.uart1 = Uart(UART1_BASE, "UART1", modem=True)
        self.pwm = Pwm()
        self.spi0 = Spi()
        self.pinsel = PinSelect()
        self.gpio = Gpio(self.pinsel)
        self.apb_accesses = 0
        self.apb: dict[int, ApbSlot] = {
            TIMER0_BASE: ApbSlot(self.timer0, Pconp.TIM0, VicChannel.TIMER0),
            TIMER1_BASE: ApbSlot(self.timer1, Pconp.TIM1, VicChannel.TIMER1),
            UART0_BASE: ApbSlot(self.uart0, Pconp.UART0, VicChannel.UART0),
            UART1_BASE: ApbSlot(self.uart1, Pconp.UART1, VicChannel.UART1),
            PWM_BASE: ApbSlot(self.pwm, Pconp.PWM0, VicChannel.PWM0),
            SPI0_BASE: ApbSlot(self.spi0, Pconp.SPI0, VicChannel.SPI0),
        }
        super().__init__(scb, Vic(), list(self.apb.values()))
        self._plain: dict[int, Gpio | PinSelect] = {GPIO_BASE: self.gpio, PINSEL_BASE: self.pinsel}
        self._pages: dict[int, ApbSlot] = {base >> _SLOT_SHIFT: slot for base, slot in self.apb.items()}
        self._plain_pages: dict[int, RegisterFile] = {base >> _SLOT_SHIFT: m for base, m in self._plain.items()}

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
        if cycle > self.cycle:
            if cycle < self._due:
                self.cycle = cycle
            else:
                self._catch_up(cycle)
        lane = address & 3
        address -= lane
        if address >= VIC_BASE:
            value = self.vic.read(address - VIC_BASE, 0)  # an acknowledge only lowers nIRQ
        else:
            if not _APB_LOW <= address < _APB_HIGH:
                raise UnmodelledRegister(address, "read", "outside the peripheral space")
            self.apb_accesses += 1
            page = address >> _SLOT_SHIFT
            slot = self._pages.get(page)
            if slot is not None:
                if slot.frozen_at is not None:
                    raise RegisterAccessError(address, f"{slot.model.name} is powered off (PCONP bit {slot.pconp})")
                model = slot.model
                value = model.read(address & (APB_SLOT - 1), self.time.pclk_at(self.cycle) - slot.offset)
                if model.rescheduled:  # the read changed what the model does next (else nothing)
                    model.rescheduled = False
                    self._model_line(slot)
                    self._rescheduled(slot)
            elif page == _SCB_PAGE:
                value = self.scb.read(address & (APB_SLOT - 1), self.cycle)
            else:
                plain = self._plain_pages.get(page)
                if plain is None:
                    raise UnmodelledRegister(address, "read", "no model at this APB slot")
                value = plain.read(address & (APB_SLOT - 1), self.cycle)
        return (value >> (8 * lane)) & _WIDTH_MASK[width]

    def write(self, address: int, value: int, width: int, cycle: int) -> None:
        """Write ``value`` (``width`` bytes) to ``address`` at CCLK ``cycle``."""
        if cycle > self.cycle:
            if cycle < self._due:
                self.cycle = cycle
            else:
                self._catch_up(cycle)
        if address & 3:
            raise RegisterAccessError(address, f"{width}-byte write at byte lane {address & 3} is not modelled")
        value &= _WIDTH_MASK[width]
        if address >= VIC_BASE:
            self.vic.write(address - VIC_BASE, value, 0)
            self._wake()
            return
        if not _APB_LOW <= address < _APB_HIGH:
            raise UnmodelledRegister(address, "write", "outside the peripheral space")
        self.apb_accesses += 1
        page = address >> _SLOT_SHIFT
        slot = self._pages.get(page)
        if slot is not None:
            if slot.frozen_at is not None:
                raise RegisterAccessError(address, f"{slot.model.name} is powered off (PCONP bit {slot.pconp})")
            model = slot.model
            model.write(address & (APB_SLOT - 1), value, self.time.pclk_at(self.cycle) - slot.offset)
            self._model_line(slot)
            if model.rescheduled:  # what the model does next changed (not by an IR clear)
                model.rescheduled = False
                self._rescheduled(slot)
        elif page == _SCB_PAGE:
            self._scb(address & (APB_SLOT - 1), value)
        else:
            plain = self._plain_pages.get(page)
            if plain is None:
                raise UnmodelledRegister(address, "write", "no model at this APB slot")
            plain.write(address & (APB_SLOT - 1), value, self.cycle)

    def _scb(self, offset: int, value: int) -> None:
        self.schedule_changed = True  # the PLL's lock, the clocks, a peripheral powered on
        pconp_before = self.scb.pconp
        self.scb.write(offset, value, self.cycle, self.apb_accesses)
        if offset == _PCONP:
            self._power(pconp_before)
        self._clocks_changed()
        self._scb_lines()
        lock = self.scb.pll0.lock_at
        if lock is not None and self.cycle < lock < self._due:
            self._due = lock
        self._wake()

    def _power(self, before: int) -> None:
        pclk = self.time.pclk_at(self.cycle)
        for slot in self._slots:
            on = self.scb.powered(slot.pconp)
            if not on and slot.frozen_at is None:
                slot.model.advance_to(pclk - slot.offset)  # its clock stops now: bring it up to now
                self._model_line(slot)
                slot.frozen_at = pclk
                slot.stale = True
            elif on and slot.frozen_at is not None:
                slot.offset += pclk - slot.frozen_at
                slot.frozen_at = None
                slot.stale = True
        self._due = self._next_due()

    # -- wiring -----------------------------------------------------------------------------
    def attach_spi_slave(self, slave: SpiSlave) -> None:
        """``slave(mosi, transfer)`` answers SPI0's transfers; ``transfer`` in CCLK cycles."""
        def in_cycles(mosi: int, transfer: SpiTransfer) -> int:
            tr = transfer
            start, end = self.cycle_of(self.spi0, tr.start), self.cycle_of(self.spi0, tr.end)
            return slave(mosi, SpiTransfer(start, end, tr.sck_period * self.time.pclk_div, tr.bits, tr.cpol,
                                           tr.cpha, tr.lsb_first))
        self.spi0.slave = in_cycles
