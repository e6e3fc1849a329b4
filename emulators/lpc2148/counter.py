"""The prescaled 32-bit counter with match registers that Timer0/1 and the PWM share
(UM10139, chapters "Timer/Counter0 and Timer/Counter1" and "Pulse Width Modulator (PWM)").

Per PCLK tick the prescale counter PC counts up; on the tick after PC has reached PR it
returns to 0 and the timer counter TC advances, so TC advances every PR+1 ticks. A match
happens on the tick at which TC becomes equal to a match register MRn. Per channel the match
control bits (MCR, 3 bits a channel) say: interrupt (bit 0), reset (bit 1: at the end of the
count at MRn, TC goes to 0 instead of MRn+1, giving the match value a full count), stop
(bit 2: the counters stop with TC at MRn and the counter enable bit is cleared).

Time is stepped from match to match, not tick by tick, so a long idle stretch costs one loop
iteration per match that matters. Up to the next match of a channel with MCR bits or in
:attr:`MatchCounter.extra` PC and TC are plain arithmetic (a register read costs no
stepping). :meth:`MatchCounter.ticks_to_effect` and :meth:`MatchCounter.ticks_to_interrupt`
look ahead on a copy for the core's skip-to-next-event; both are kept until the counter's
state changes (the owner calls :meth:`MatchCounter.changed` after writing its registers).

Simplification: the manual's timing figures raise the interrupt flag one PCLK after TC reaches
the match value; the model raises it on the tick TC reaches it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Final

from emulators.lpc2148.regs import MASK32

_WRAP: Final = 1 << 32
#: a look-ahead horizon no firmware reaches (ticks)
_FOREVER: Final = 1 << 80
#: "no match ahead" for the arithmetic horizon (absolute ticks)
_NEVER: Final = 1 << 90
#: a cached look-ahead not computed yet
_UNKNOWN: Final = -1

#: on_match(channel mask, tick of the match)
MatchHandler = Callable[[int, int], None]


def _no_handler(mask: int, tick: int) -> None:
    pass


class MatchCounter:
    """PC, TC, PR, MRs and MCR of one timer block; the owner reacts to matches.

    The owner writes the registers (:attr:`tc`, :attr:`pc`, :attr:`pr`, :attr:`mr`,
    :attr:`mcr`, :attr:`enabled`, :attr:`held_in_reset`, :attr:`extra`) directly and then calls
    :meth:`changed`."""

    __slots__ = ("n_match", "tc", "pc", "pr", "mr", "mcr", "enabled", "held_in_reset", "extra", "tick",
                 "_interrupt", "_reset", "_stop", "_masks_mcr", "_stop_at", "_reset_next", "_effect_at", "_irq_at")

    def __init__(self, n_match: int) -> None:
        self.n_match = n_match
        self.tc = 0
        self.pc = 0
        self.pr = 0
        self.mr = [0] * n_match
        self.mcr = 0
        self.enabled = False
        self.held_in_reset = False
        #: channels whose matches matter to the owner besides MCR (external match, PWM latch)
        self.extra = 0
        #: the tick the state above belongs to
        self.tick = 0
        self._interrupt = self._reset = self._stop = 0
        self._masks_mcr = 0  #: the MCR value the three masks above are of
        #: the absolute tick of the next match of a channel with MCR bits or in extra (_NEVER: none)
        self._stop_at = _NEVER
        #: the next count of TC is a reset (TC sits on a reset channel's match value)
        self._reset_next = False
        #: ticks_to_effect / ticks_to_interrupt as absolute ticks (None: never; _UNKNOWN: not computed)
        self._effect_at: int | None = _UNKNOWN
        self._irq_at: int | None = _UNKNOWN

    def changed(self) -> None:
        """The registers were written: recompute what depends on them."""
        self._interrupt, self._reset, self._stop = self.masks()
        self._masks_mcr = self.mcr
        self._effect_at = self._irq_at = _UNKNOWN
        self._horizon()

    def masks(self) -> tuple[int, int, int]:
        """(interrupt, reset, stop) channel masks from MCR."""
        interrupt = reset = stop = 0
        for c in range(self.n_match):
            bits = (self.mcr >> (3 * c)) & 7
            if bits & 1:
                interrupt |= 1 << c
            if bits & 2:
                reset |= 1 << c
            if bits & 4:
                stop |= 1 << c
        return interrupt, reset, stop

    def _masks(self) -> tuple[int, int, int]:
        if self._masks_mcr != self.mcr:
            return self.masks()
        return self._interrupt, self._reset, self._stop

    @property
    def interrupt_mask(self) -> int:
        """The channels with MCR's interrupt bit."""
        return self._masks()[0]

    @property
    def running(self) -> bool:
        return self.enabled and not self.held_in_reset

    def _horizon(self) -> None:
        """The next match of a channel that needs stepping (MCR bits or extra), absolute; and
        when it is the next effect or interrupt, the look-aheads too (no copy to step)."""
        self._stop_at = _NEVER
        self._reset_next = False
        if not (self.enabled and not self.held_in_reset):
            return
        interrupt, reset, stop = self._masks()
        effect = interrupt | stop | self.extra
        relevant = effect | reset
        if not relevant:
            self._effect_at = self._irq_at = None  # nothing ever matches
            return
        mr = self.mr
        tc = self.tc
        self._reset_next = self._hits(reset, tc) != 0
        first = ((self.pr - self.pc) & MASK32) + 1  # ticks to TC's next count
        value = 0 if self._reset_next else (tc + 1) & MASK32  # TC after it
        period = self.pr + 1
        best = _NEVER
        hit = 0
        for c in range(self.n_match):
            if relevant >> c & 1:
                t = first + ((mr[c] - value) & MASK32) * period
                if t < best:
                    best, hit = t, 1 << c
                elif t == best:
                    hit |= 1 << c
        self._stop_at = self.tick + best
        # the first match to step is the first of all: if it has an effect, it is the next one
        if hit & effect:
            self._effect_at = self._stop_at
        if hit & interrupt:
            self._irq_at = self._stop_at
        elif hit & stop:
            self._irq_at = None  # the counter stops before any interrupt

    def advance_to(self, tick: int, on_match: MatchHandler = _no_handler) -> None:
        """Let the counter run to ``tick``, calling ``on_match(mask, tick)`` at each match of
        a channel with MCR bits or in :attr:`extra` (stop and reset are handled here)."""
        n = tick - self.tick
        if n <= 0:
            return
        if tick < self._stop_at:  # no match to step: PC and TC by arithmetic
            self.tick = tick
            if not (self.enabled and not self.held_in_reset):
                return
            first = ((self.pr - self.pc) & MASK32) + 1
            if n < first:
                self.pc = (self.pc + n) & MASK32
                return
            counts, self.pc = divmod(n - first, self.pr + 1)
            self.tc = ((0 if self._reset_next else self.tc + 1) + counts) & MASK32
            self._reset_next = False  # a reset value is a match: never reached by arithmetic
            return
        start = self.tick
        self.tick = tick
        if self.running:
            self._run(n, start, on_match, probe=False)
            self._effect_at = self._irq_at = _UNKNOWN
        self._horizon()

    def ticks_to_effect(self) -> int | None:
        """Ticks from now to the next match with an effect beyond a reset (interrupt, stop,
        or a channel in :attr:`extra`); None if the counter never gets there."""
        at = self._effect_at
        if at == _UNKNOWN:
            at = None
            if self.running:
                interrupt, _, stop = self._masks()
                ahead = self._run(_FOREVER, 0, _no_handler, probe=True, effect=interrupt | stop | self.extra)
                at = None if ahead is None else self.tick + ahead
            self._effect_at = at
        return None if at is None else at - self.tick

    def ticks_to_interrupt(self) -> int | None:
        """Ticks from now to the next match that sets an interrupt flag (MCR bit 0); None if
        the counter never gets there (or stops first)."""
        at = self._irq_at
        if at == _UNKNOWN:
            at = None
            if self.running:
                interrupt = self._masks()[0]
                ahead = self._run(_FOREVER, 0, _no_handler, probe=True, effect=interrupt)
                at = None if ahead is None else self.tick + ahead
            self._irq_at = at
        return None if at is None else at - self.tick

    def next_effect_tick(self) -> int | None:
        """The tick of :meth:`ticks_to_effect` (a model's next event); None: never."""
        ahead = self.ticks_to_effect()
        return None if ahead is None else self.tick + ahead

    def next_interrupt_tick(self) -> int | None:
        """The tick of :meth:`ticks_to_interrupt` (a model's IRQ line can rise only then)."""
        ahead = self.ticks_to_interrupt()
        return None if ahead is None else self.tick + ahead

    def clone(self) -> MatchCounter:
        """An independent copy of the counter's state."""
        sim = MatchCounter(self.n_match)
        sim.tc, sim.pc, sim.pr, sim.mr, sim.mcr = self.tc, self.pc, self.pr, list(self.mr), self.mcr
        sim.enabled, sim.held_in_reset, sim.extra, sim.tick = self.enabled, self.held_in_reset, self.extra, self.tick
        return sim

    def _run(self, n: int, start: int, on_match: MatchHandler, probe: bool, effect: int = 0) -> int | None:
        """Step ``n`` ticks from match to match. ``probe``: stop at the first match in
        ``effect`` and return its tick from now (None: none comes, or a stop comes first),
        leaving the counter as it was."""
        interrupt, reset, stop = self._interrupt, self._reset, self._stop
        if self._masks_mcr != self.mcr:
            interrupt, reset, stop = self.masks()
        if probe:
            if not effect:
                return None
            relevant = effect | reset | stop
        else:
            relevant = interrupt | stop | self.extra | reset
        n_match = self.n_match
        rel = [c for c in range(n_match) if relevant >> c & 1]
        res = [c for c in range(n_match) if reset >> c & 1]
        mr = self.mr  # read live: a handler may change it (the PWM's latch)
        pr = self.pr
        period = pr + 1
        tc, pc = self.tc, self.pc
        t = 0
        resets = 0
        while True:
            to_inc = ((pr - pc) & MASK32) + 1
            if n - t < to_inc:
                if not probe:
                    self.tc, self.pc = tc, (pc + (n - t)) & MASK32
                return None
            t += to_inc
            pc = 0
            at_reset = False
            for c in res:
                if mr[c] == tc:
                    at_reset = True
                    break
            if at_reset:
                tc = 0
                resets += 1
            else:
                tc = (tc + 1) & MASK32
            hit = 0
            for c in rel:
                if mr[c] == tc:
                    hit |= 1 << c
            if hit:
                if probe:
                    if hit & effect:
                        return t
                    if hit & stop:
                        return None  # the counter stops before any match in effect
                else:
                    self.tc, self.pc = tc, pc
                    on_match(hit, start + t)
                    if hit & stop:
                        self.enabled = False
                        return None
            if probe and resets >= 2:
                return None  # one whole reset cycle without an effect: none ever comes
            at_reset = False
            for c in res:
                if mr[c] == tc:
                    at_reset = True
                    break
            if at_reset:
                continue  # the next count is a reset: take it singly
            d = _WRAP
            for c in rel:
                gap = ((mr[c] - tc) & MASK32) or _WRAP
                if gap < d:
                    d = gap
            skip = min(d - 1, (n - t) // period)
            if skip > 0:
                tc = (tc + skip) & MASK32
                t += skip * period

    def _at(self, mask: int, tc: int) -> bool:
        return self._hits(mask, tc) != 0

    def _hits(self, mask: int, tc: int) -> int:
        hit = 0
        if mask:
            for c in range(self.n_match):
                if mask >> c & 1 and self.mr[c] == tc:
                    hit |= 1 << c
        return hit
