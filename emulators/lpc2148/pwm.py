"""The LPC2148's PWM (UM10139, chapter "Pulse Width Modulator (PWM)"; base 0xE001 4000).

A timer block (:class:`~emulators.lpc2148.counter.MatchCounter`) with seven match registers:
MR0 sets the PWM rate (with MCR's reset on MR0, a period is MR0+1 counts of PR+1 PCLK ticks),
MR1-6 the edges. PWMPCR bits 2-6 (PWMSELn) make channel n double-edged (set by MR(n-1),
cleared by MRn) instead of single-edged (set at the period's start, cleared by MRn; a match
value of 0 keeps it low, one beyond MR0 keeps it high); bits 9-14 (PWMENA1-6) enable the
outputs. PWMIR: bits 0-3 MR0-3, bits 8-10 MR4-6, write 1 to clear. PWMTCR: bit 0 counter
enable, bit 1 counter reset, bit 3 PWM enable.

The latch (PWMLER): in PWM mode a write to MRn goes to a shadow register; it takes effect at
the start of the next period after the firmware set LER bit n (the transfer happens on the MR0
match; the LER bit then reads 0). Without the LER bit the new value never takes effect.
In timer mode (PWMTCR bit 3 clear) match writes take effect at once, and no output is driven.

Output for the ESC models: per channel the pulse width and the period, in PCLK ticks, as
:class:`PwmOutput` records when they change (:meth:`Pwm.take_changes`), and on demand
(:meth:`Pwm.outputs`).

Not modelled: the double-edge rule 3 of the manual (an old match value equal to the rate
reused once when match values change); a double-edged channel's width is taken as
(MRn - MR(n-1)) mod period with MRn == MR(n-1) giving 0 (clear wins).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum, unique

from emulators.lpc2148.counter import MatchCounter, MatchHandler
from emulators.lpc2148.regs import MASK32, RegisterFile

PWM_BASE = 0xE001_4000
N_MATCH = 7
CHANNELS = range(1, 7)
_MR_OFFSETS = (0x18, 0x1C, 0x20, 0x24, 0x40, 0x44, 0x48)


@unique
class PwmReg(IntEnum):
    """Register offsets (UM10139 PWM register map table)."""

    IR = 0x00
    TCR = 0x04
    TC = 0x08
    PR = 0x0C
    PC = 0x10
    MCR = 0x14
    PCR = 0x4C
    LER = 0x50


_TCR_ENABLE, _TCR_RESET, _TCR_PWM = 0x1, 0x2, 0x8


@dataclass(frozen=True)
class PwmOutput:
    """Channel ``channel`` (1-6) from PCLK ``tick`` on: high for ``high_ticks`` of every
    ``period_ticks`` (``high_ticks`` 0: no pulses; ``period_ticks`` 0: no PWM period)."""

    tick: int
    channel: int
    high_ticks: int
    period_ticks: int


def _ir_bit(channel: int) -> int:
    return 1 << (channel if channel < 4 else channel + 4)


class Pwm(RegisterFile):
    """The PWM block; time in PCLK ticks."""

    name = "PWM"

    def __init__(self, base: int = PWM_BASE) -> None:
        super().__init__(base)
        self.counter = MatchCounter(N_MATCH)
        self.ir = 0
        self.tcr = 0
        self.pcr = 0
        self.ler = 0
        self.shadow = [0] * N_MATCH
        self._last: dict[int, tuple[int, int]] = {c: (0, 0) for c in CHANNELS}
        self._changes: list[PwmOutput] = []
        self._on_match_cb: MatchHandler = self._on_match

    # -- time -----------------------------------------------------------------------------
    def advance_to(self, tick: int) -> None:
        self.counter.advance_to(tick, self._on_match_cb)

    def next_event(self) -> int | None:
        return self.counter.next_effect_tick()

    def next_irq_event(self) -> int | None:
        """The tick of the next match that sets an IR bit."""
        return self.counter.next_interrupt_tick()

    @property
    def irq(self) -> bool:
        return self.ir != 0

    @property
    def pwm_mode(self) -> bool:
        return bool(self.tcr & _TCR_PWM)

    def _on_match(self, mask: int, tick: int) -> None:
        interrupt = self.counter.interrupt_mask
        if mask & interrupt:
            for c in range(N_MATCH):
                if (mask & interrupt) >> c & 1:
                    self.ir |= _ir_bit(c)
        if mask & 1 and self.ler:
            for c in range(N_MATCH):
                if self.ler >> c & 1:
                    self.counter.mr[c] = self.shadow[c]
            self.ler = 0
            self.counter.extra = 0
            self._emit(tick + self.counter.pr + 1)  # the next period starts one count later

    # -- outputs --------------------------------------------------------------------------
    def outputs(self) -> dict[int, tuple[int, int]]:
        """Channel -> (high ticks, period ticks) with the match values in effect."""
        k = self.counter
        _, reset, _ = k.masks()
        count = k.pr + 1
        running = k.enabled and not k.held_in_reset and self.pwm_mode and bool(reset & 1)
        rate = k.mr[0]
        period = (rate + 1) * count
        out = {}
        for ch in CHANNELS:
            if not running or not self.pcr >> (8 + ch) & 1:
                out[ch] = (0, 0)
                continue
            fall = k.mr[ch]
            if ch >= 2 and self.pcr >> ch & 1:  # double edge: set by MR(n-1), cleared by MRn
                rise = k.mr[ch - 1]
                high = 0 if rise > rate or fall > rate else (fall - rise) % (rate + 1)
            else:
                high = 0 if fall == 0 else min(fall, rate + 1)
            out[ch] = (high * count, period)
        return out

    def _emit(self, tick: int) -> None:
        for ch, value in self.outputs().items():
            if value != self._last[ch]:
                self._last[ch] = value
                self._changes.append(PwmOutput(tick, ch, value[0], value[1]))

    def take_changes(self) -> list[PwmOutput]:
        """Drain the output changes (each from its tick on)."""
        out, self._changes = self._changes, []
        return out

    # -- registers ------------------------------------------------------------------------
    def read(self, offset: int, tick: int) -> int:
        self.counter.advance_to(tick, self._on_match_cb)
        k = self.counter
        if offset in _MR_OFFSETS:
            return k.mr[_MR_OFFSETS.index(offset)]
        values: dict[int, int] = {PwmReg.IR: self.ir, PwmReg.TCR: self._tcr_value(), PwmReg.TC: k.tc, PwmReg.PR: k.pr,
                  PwmReg.PC: k.pc, PwmReg.MCR: k.mcr, PwmReg.PCR: self.pcr, PwmReg.LER: self.ler}
        if offset in values:
            return values[offset]
        raise self.unmodelled(offset, "read")

    def _tcr_value(self) -> int:
        k = self.counter
        return (self.tcr & _TCR_PWM) | int(k.enabled) | int(k.held_in_reset) << 1

    def write(self, offset: int, value: int, tick: int) -> None:
        self.counter.advance_to(tick, self._on_match_cb)
        k = self.counter
        value &= MASK32
        if offset in _MR_OFFSETS:
            c = _MR_OFFSETS.index(offset)
            self.shadow[c] = value
            if not self.pwm_mode:
                k.mr[c] = value
        elif offset == PwmReg.IR:
            self.ir &= ~value
        elif offset == PwmReg.TCR:
            self.tcr = value & (_TCR_ENABLE | _TCR_RESET | _TCR_PWM)
            k.enabled = bool(value & _TCR_ENABLE)
            k.held_in_reset = bool(value & _TCR_RESET)
            if k.held_in_reset:
                k.tc = k.pc = 0
        elif offset == PwmReg.TC:
            k.tc = value
        elif offset == PwmReg.PR:
            k.pr = value
        elif offset == PwmReg.PC:
            k.pc = value
        elif offset == PwmReg.MCR:
            k.mcr = value & 0x1FFFFF
        elif offset == PwmReg.PCR:
            self.pcr = value & 0x7E7C
        elif offset == PwmReg.LER:
            self.ler = value & 0x7F
            k.extra = 1 if self.ler else 0  # the MR0 match must be stepped to latch
        else:
            raise self.unmodelled(offset, "write")
        k.changed()
        self.rescheduled = True
        self._emit(tick)
