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
something on its own (a polling read could see it), so a core in a wait loop can skip there;
:meth:`Lpc2148Bus.next_irq_cycle` is the next cycle at which an interrupt line may change on
its own, the only events a core running or asleep in idle has to stop for (a UART's characters
below the trigger level are not among them).

Speed: time passes lazily. Each model keeps its next event; the bus keeps the earliest of them
and, when time passes, advances only the models with something due (a model's register access
brings that model up to the access's tick). So between events a model changes nothing anyone
could see, and its running counters (a timer's TC) are brought up to date by a register read.
The interrupt lines are updated when a model is accessed or has an event, not recomputed on
every access.
"""

from __future__ import annotations

from typing import Final

from emulators.lpc2148.errors import RegisterAccessError, UnmodelledRegister
from emulators.lpc2148.gpio import GPIO_BASE, Gpio
from emulators.lpc2148.pinsel import PINSEL_BASE, PinSelect
from emulators.lpc2148.pwm import PWM_BASE, Pwm
from emulators.lpc2148.regs import RegisterFile, VicChannel
from emulators.lpc2148.scb import SCB_BASE, Pconp, ScbParams, SystemControl, ScbReg
from emulators.lpc2148.spi import SPI0_BASE, Spi, SpiSlave, SpiTransfer
from emulators.lpc2148.timebase import Timebase
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
_EINT_SHIFT: Final = int(VicChannel.EINT0)
_PLL_BIT: Final = 1 << int(VicChannel.PLL)
_SCB_BITS: Final = (0xF << _EINT_SHIFT) | _PLL_BIT
#: "nothing scheduled" (cycles)
_NEVER: Final = 1 << 100


class _Apb:
    """An APB peripheral on the PCLK clock, gated by a PCONP bit."""

    __slots__ = ("model", "pconp", "channel", "bit", "offset", "frozen_at", "stale", "at", "irq_at")

    def __init__(self, model: Timer | Uart | Pwm | Spi, pconp: int, channel: int) -> None:
        self.model = model
        self.pconp = pconp
        self.channel = channel
        self.bit = 1 << channel  #: its request line in the VIC's inputs
        self.offset = 0  #: PCLK ticks it missed while powered off
        self.frozen_at: int | None = None
        #: the model was accessed or stepped since :attr:`at` and :attr:`irq_at` were computed
        self.stale = True
        #: the cycle of its next event, of its next interrupt-relevant event (_NEVER: none)
        self.at = _NEVER
        self.irq_at = _NEVER


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
        self._slots = list(self.apb.values())
        self._pages: dict[int, _Apb] = {base >> _SLOT_SHIFT: slot for base, slot in self.apb.items()}
        self._plain_pages: dict[int, Gpio | PinSelect] = {base >> _SLOT_SHIFT: m for base, m in self._plain.items()}
        #: the VIC's inputs as last set (bit n = channel n)
        self._sources = 0
        #: no model has an event before this cycle (exact after time passed; a read may have
        #: moved an event later, never earlier, so it stays a lower bound)
        self._due = _NEVER

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
        """Let time pass up to CCLK ``cycle`` (never backwards). Only the models with an event
        by then are stepped; the others catch up when accessed."""
        if cycle <= self.cycle:
            return
        if cycle < self._due:
            self.cycle = cycle
            return
        self._catch_up(cycle)

    def _catch_up(self, cycle: int) -> None:
        lock = self.scb.pll0.lock_at
        if lock is not None and self.cycle < lock <= cycle:  # the PLL may connect at lock
            self._run_due(lock)
            self.cycle = lock
            self._clocks_changed()
            self._scb_lines()
        self._run_due(cycle)
        self.cycle = cycle
        self._due = self._next_due()

    def _run_due(self, cycle: int) -> None:
        """Step the models with an event at or before ``cycle`` up to it."""
        pclk = self.time.pclk_at(cycle)
        for slot in self._slots:
            if slot.stale:
                self._refresh(slot)
            if slot.at <= cycle:  # the same as its tick <= pclk, for whole ticks
                slot.model.advance_to(pclk - slot.offset)
                slot.stale = True
                self._model_line(slot)

    def _refresh(self, slot: _Apb) -> None:
        """``slot``'s next events in cycles, from its model."""
        slot.stale = False
        if slot.frozen_at is not None:
            slot.at = slot.irq_at = _NEVER
            return
        tick = slot.model.next_event()
        slot.at = _NEVER if tick is None else self.time.cycle_of_pclk(tick + slot.offset)
        slot.irq_at = -1  # computed when asked (next_irq_cycle)

    def _next_due(self) -> int:
        """The earliest event of any model (and the PLL's lock), in cycles; _NEVER if none."""
        best = _NEVER
        for slot in self._slots:
            if slot.stale:
                self._refresh(slot)
            if slot.at < best:
                best = slot.at
        lock = self.scb.pll0.lock_at
        if lock is not None and self.cycle < lock < best:
            best = lock
        return best

    def next_event_cycle(self) -> int | None:
        """The next cycle (> :attr:`cycle`) at which a model changes something on its own."""
        best = self._due = self._next_due()
        return None if best == _NEVER else max(best, self.cycle + 1)

    def next_irq_cycle(self) -> int | None:
        """The next cycle (> :attr:`cycle`) at or before which an interrupt line may change on
        its own (or the clocks, at the PLL's lock); at most :meth:`next_event_cycle`'s events,
        without those no interrupt can follow (a character below the trigger level). None: no
        such change comes without an access or a pin."""
        best = _NEVER
        time = self.time
        for slot in self._slots:
            if slot.stale:
                self._refresh(slot)
            at = slot.irq_at
            if at < 0:
                tick = slot.model.next_irq_event() if slot.frozen_at is None else None
                at = slot.irq_at = _NEVER if tick is None else time.cycle_of_pclk(tick + slot.offset)
            if at < best:
                best = at
        lock = self.scb.pll0.lock_at
        if lock is not None and self.cycle < lock < best:
            best = lock
        return None if best == _NEVER else max(best, self.cycle + 1)

    def _rescheduled(self, slot: _Apb) -> None:
        """``slot``'s model may have an earlier event now (a write, bytes on its line)."""
        self._refresh(slot)
        if slot.at < self._due:
            self._due = slot.at

    def _clocks_changed(self) -> None:
        hz = round(self.scb.cclk_hz(self.cycle))
        div = self.scb.pclk_div
        time = self.time
        if hz != time.cclk_hz or div != time.pclk_div:
            time.set_cclk_hz(self.cycle, hz)
            time.set_pclk_div(self.cycle, div)
            for slot in self._slots:  # the events' cycles moved
                slot.stale = True
            self._due = self._next_due()

    # -- interrupt lines --------------------------------------------------------------------
    def _model_line(self, slot: _Apb) -> None:
        """``slot``'s request line into the VIC, after an access or an event."""
        sources = self._sources
        lines = sources | slot.bit if slot.model.irq else sources & ~slot.bit
        if lines != sources:
            self._sources = lines
            self.vic.set_sources(lines)
            self._wake()

    def _scb_lines(self) -> None:
        """EINT0-3 and the PLL's lock line."""
        lines = (self._sources & ~_SCB_BITS) | (self.scb.eint_lines() << _EINT_SHIFT)
        if self.scb.pll_irq(self.cycle):
            lines |= _PLL_BIT
        if lines != self._sources:
            self._sources = lines
            self.vic.set_sources(lines)
            self._wake()

    def _wake(self) -> None:
        if self.scb.pcon & 1 and (self.vic.irq_request or self.vic.fiq_request):
            self.scb.wake()

    def _update_lines(self) -> None:
        """Every request line from its model's state now."""
        sources = self.scb.eint_lines() << VicChannel.EINT0
        if self.scb.pll_irq(self.cycle):
            sources |= 1 << VicChannel.PLL
        for slot in self._slots:
            if slot.model.irq:
                sources |= slot.bit
        self._sources = sources
        self.vic.set_sources(sources)
        self._wake()

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
                slot.stale = True
                self._model_line(slot)
                if model.rescheduled:
                    model.rescheduled = False
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
            slot.model.write(address & (APB_SLOT - 1), value, self.time.pclk_at(self.cycle) - slot.offset)
            self._model_line(slot)
            self._rescheduled(slot)
        elif page == _SCB_PAGE:
            self._scb(address & (APB_SLOT - 1), value)
        else:
            plain = self._plain_pages.get(page)
            if plain is None:
                raise UnmodelledRegister(address, "write", "no model at this APB slot")
            plain.write(address & (APB_SLOT - 1), value, self.cycle)

    def _scb(self, offset: int, value: int) -> None:
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
