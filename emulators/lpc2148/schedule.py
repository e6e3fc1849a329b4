"""When the LPC2148's peripherals act: the bus's time (the base of
:class:`~emulators.lpc2148.bus.Lpc2148Bus`).

Time passes lazily. Each APB model keeps its next event (``next_event()``, in its PCLK ticks);
the bus keeps each slot's in CCLK cycles and the earliest of them (``_due``). When time passes
only the models with something due are stepped; a model's register access brings that model
up to the access's tick. So between events a model changes nothing anyone could see, and its
running counters (a timer's TC) are brought up to date by a register read. The request lines
into the VIC are kept per model: updated when a model is accessed or has an event.

:meth:`Schedule.next_event_cycle` is the next cycle at which a model changes something on its
own (a polling read could see it); :meth:`Schedule.next_irq_cycle` the next cycle at which a
request line may change on its own, the only events a core running or asleep in idle has to
stop for (a UART's characters below the trigger level are not among them).
"""

from __future__ import annotations

from typing import Final

from emulators.lpc2148.regs import RegisterFile, VicChannel
from emulators.lpc2148.scb import SystemControl
from emulators.lpc2148.timebase import Timebase
from emulators.lpc2148.vic import Vic

_EINT_SHIFT: Final = int(VicChannel.EINT0)
_PLL_BIT: Final = 1 << int(VicChannel.PLL)
_SCB_BITS: Final = (0xF << _EINT_SHIFT) | _PLL_BIT
#: "nothing scheduled" (cycles)
NEVER: Final = 1 << 100
_NEVER: Final = NEVER


class ApbSlot:
    """An APB peripheral on the PCLK clock, gated by a PCONP bit."""

    __slots__ = ("model", "pconp", "channel", "bit", "offset", "frozen_at", "stale", "at", "irq_at")

    def __init__(self, model: RegisterFile, pconp: int, channel: int) -> None:
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



class Schedule:
    """The clock of the models in ``slots``, the system control block's PLL and the VIC's
    request lines, at CCLK cycle :attr:`cycle`."""

    def __init__(self, scb: SystemControl, vic: Vic, slots: list[ApbSlot]) -> None:
        self.scb = scb
        self.vic = vic
        self.time = Timebase(round(scb.cclk_hz(0)), scb.pclk_div)
        self.cycle = 0
        self._slots = slots
        #: the VIC's inputs as last set (bit n = channel n)
        self._sources = 0
        #: no model has an event before this cycle (exact after time passed; a read that does
        #: not report a change moved no event earlier, so it stays a lower bound)
        self._due = _NEVER
        #: set when an access or an input may have brought an event earlier (a write, a UART's
        #: RBR read, bytes on a line): a core running to :meth:`next_irq_cycle` asks again,
        #: and clears it
        self.schedule_changed = False

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

    def _refresh(self, slot: ApbSlot) -> None:
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

    def _rescheduled(self, slot: ApbSlot) -> None:
        """``slot``'s model may have an earlier event now (a write, bytes on its line)."""
        self.schedule_changed = True
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
    def _model_line(self, slot: ApbSlot) -> None:
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

