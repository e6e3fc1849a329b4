"""Timer/Counter0 and Timer/Counter1 of the LPC2148 (UM10139, chapter "Timer/Counter0 and
Timer/Counter1"; Timer0 at 0xE000 4000, Timer1 at 0xE000 8000).

Registers: IR (write 1 to clear: bits 0-3 MR0-3, bits 4-7 CR0-3), TCR (bit 0 counter enable,
bit 1 counter reset: TC and PC held at 0 while set), TC, PR, PC, MCR, MR0-3, CCR (per capture
channel n bits 3n rising edge, 3n+1 falling edge, 3n+2 interrupt), CR0-3 (read only), EMR
(bits 0-3 the external match outputs EM0-3, bits 4-11 EMC0-3: 1 clear, 2 set, 3 toggle on the
channel's match), CTCR (mode 0, timer mode, only).

Captures: :meth:`Timer.set_capture_input` gives the level of CAPn.x (the bus routes pins whose
PINSEL function is CAPn.x); an edge selected in CCR loads TC into CRx and, with the interrupt
bit, sets the IR bit. The match outputs EM0-3 change on matches as EMR says; their changes are
kept for the bench (:meth:`Timer.take_match_outputs`).

Not modelled: counter mode (CTCR bits 1:0 != 0 raises NotModelled); the capture input's
synchronisation delay (the model loads TC of the edge's tick).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum, unique
from typing import Final

from emulators.lpc2148.counter import MatchCounter, MatchHandler
from emulators.lpc2148.errors import NotModelled
from emulators.lpc2148.regs import MASK32, RegisterFile

TIMER0_BASE = 0xE000_4000
TIMER1_BASE = 0xE000_8000
N_CHANNELS = 4


@unique
class TimerReg(IntEnum):
    """Register offsets (UM10139 timer register map table)."""

    IR = 0x00
    TCR = 0x04
    TC = 0x08
    PR = 0x0C
    PC = 0x10
    MCR = 0x14
    MR0 = 0x18  #: .. MR3 0x24
    CCR = 0x28
    CR0 = 0x2C  #: .. CR3 0x38, read only
    EMR = 0x3C
    CTCR = 0x70


@dataclass(frozen=True)
class MatchOutput:
    """External match output EMn of the timer changed to ``level`` at PCLK ``tick``."""

    tick: int
    channel: int
    level: bool


@dataclass(frozen=True)
class Capture:
    """CRn loaded with ``value`` at PCLK ``tick`` (an edge on CAPx.n)."""

    tick: int
    channel: int
    value: int


_IR: Final = int(TimerReg.IR)
_TCR: Final = int(TimerReg.TCR)
_TC: Final = int(TimerReg.TC)
_PR: Final = int(TimerReg.PR)
_PC: Final = int(TimerReg.PC)
_MCR: Final = int(TimerReg.MCR)
_MR0: Final = int(TimerReg.MR0)
_CCR: Final = int(TimerReg.CCR)
_CR0: Final = int(TimerReg.CR0)
_EMR: Final = int(TimerReg.EMR)
_CTCR: Final = int(TimerReg.CTCR)


class Timer(RegisterFile):
    """One 32-bit timer with four match and four capture channels; time in PCLK ticks."""

    def __init__(self, base: int, name: str) -> None:
        super().__init__(base)
        self.name = name
        self.counter = MatchCounter(N_CHANNELS)
        self.ir = 0
        self.ccr = 0
        self.cr = [0] * N_CHANNELS
        self.emr = 0
        self.ctcr = 0
        self._cap_level = [False] * N_CHANNELS
        self._match_outputs: list[MatchOutput] = []
        self._captures: list[Capture] = []
        self._on_match_cb: MatchHandler = self._on_match

    # -- time -----------------------------------------------------------------------------
    def advance_to(self, tick: int) -> None:
        self.counter.advance_to(tick, self._on_match_cb)

    def next_event(self) -> int | None:
        return self.counter.next_effect_tick()

    def next_irq_event(self) -> int | None:
        """The tick of the next match that sets an IR bit (the line can rise only then)."""
        return self.counter.next_interrupt_tick()

    @property
    def irq(self) -> bool:
        return self.ir != 0

    def _on_match(self, mask: int, tick: int) -> None:
        interrupt = self.counter.interrupt_mask
        self.ir |= mask & interrupt
        emr = self.emr
        if not emr >> 4:
            return  # no external match action
        for c in range(N_CHANNELS):
            if not mask >> c & 1:
                continue
            action = (emr >> (4 + 2 * c)) & 3
            if action == 0:
                continue
            old = bool(emr >> c & 1)
            new = False if action == 1 else True if action == 2 else not old
            emr = (emr & ~(1 << c)) | (int(new) << c)
            if new != old:
                self._match_outputs.append(MatchOutput(tick, c, new))
        self.emr = emr

    def _update_extra(self) -> None:
        extra = 0
        for c in range(N_CHANNELS):
            if (self.emr >> (4 + 2 * c)) & 3:
                extra |= 1 << c
        self.counter.extra = extra

    # -- pins -----------------------------------------------------------------------------
    def set_capture_input(self, channel: int, level: bool, tick: int) -> None:
        """CAPx.``channel`` is at ``level`` from ``tick`` on (an edge if it changed)."""
        self.advance_to(tick)
        old = self._cap_level[channel]
        self._cap_level[channel] = level
        if old == level:
            return
        bits = (self.ccr >> (3 * channel)) & 7
        if (level and bits & 1) or (not level and bits & 2):
            self.cr[channel] = self.counter.tc
            self._captures.append(Capture(tick, channel, self.counter.tc))
            if bits & 4:
                self.ir |= 1 << (4 + channel)

    def take_match_outputs(self) -> list[MatchOutput]:
        """Drain the external match output changes."""
        out, self._match_outputs = self._match_outputs, []
        return out

    def take_captures(self) -> list[Capture]:
        """Drain the captures made since the last call."""
        out, self._captures = self._captures, []
        return out

    # -- registers ------------------------------------------------------------------------
    def read(self, offset: int, tick: int) -> int:
        k = self.counter
        k.advance_to(tick, self._on_match_cb)
        if offset == _TC:
            return k.tc
        if offset == _IR:
            return self.ir
        if _MR0 <= offset < _MR0 + 4 * N_CHANNELS:
            return k.mr[(offset - _MR0) >> 2]
        if _CR0 <= offset < _CR0 + 4 * N_CHANNELS:
            return self.cr[(offset - _CR0) >> 2]
        if offset == _TCR:
            return int(k.enabled) | int(k.held_in_reset) << 1
        if offset == _PR:
            return k.pr
        if offset == _PC:
            return k.pc
        if offset == _MCR:
            return k.mcr
        if offset == _CCR:
            return self.ccr
        if offset == _EMR:
            return self.emr
        if offset == _CTCR:
            return self.ctcr
        raise self.unmodelled(offset, "read")

    def write(self, offset: int, value: int, tick: int) -> None:
        k = self.counter
        k.advance_to(tick, self._on_match_cb)
        value &= MASK32
        if offset == _IR:
            self.ir &= ~value  # write 1 to clear
            return
        if _MR0 <= offset < _MR0 + 4 * N_CHANNELS:
            k.mr[(offset - _MR0) >> 2] = value
        elif _CR0 <= offset < _CR0 + 4 * N_CHANNELS:
            raise self.read_only(offset, f"CR{(offset - _CR0) >> 2}")
        elif offset == _TCR:
            k.enabled = bool(value & 1)
            k.held_in_reset = bool(value & 2)
            if k.held_in_reset:
                k.tc = k.pc = 0
        elif offset == _TC:
            k.tc = value
        elif offset == _PR:
            k.pr = value
        elif offset == _PC:
            k.pc = value
        elif offset == _MCR:
            k.mcr = value & 0xFFF
        elif offset == _CCR:
            self.ccr = value & 0xFFF
            return
        elif offset == _EMR:
            self.emr = value & 0xFFF
            self._update_extra()
        elif offset == _CTCR:
            if value & 3:
                raise NotModelled(self.base + offset, f"{self.name} counter mode (CTCR = 0x{value:X})")
            self.ctcr = value & 0xF
            return
        else:
            raise self.unmodelled(offset, "write")
        k.changed()
        self.rescheduled = True
