"""The system control block of the LPC2148 (UM10139 Rev. 4, chapter 4 "System control", and
the MAM chapter; base 0xE01F C000): PLLs, MAM, APB (VPB) divider, power control, external
interrupts, memory map, reset source.

Registers: MAMCR 0x000 (bits 1:0: 0 off, 1 partly, 2 fully on), MAMTIM 0x004 (bits 2:0 flash
fetch cycles, reset 7; changing it while the MAM is on is counted, the manual says to turn the
MAM off first), MEMMAP 0x040, PLL0 0x080-0x08C and PLL1 0x0A0-0x0AC (pll.py), PCON 0x0C0
(bit 0 IDL, 1 PD, 2-4 brown-out bits), PCONP 0x0C4 (reset 0x0018 17BE), VPBDIV 0x100 (bits 1:0:
0 PCLK = CCLK/4 at reset, 1 CCLK, 2 CCLK/2, 3 reserved: ignored), EXTINT 0x140 (write 1 to
clear), INTWAKE 0x144, EXTMODE 0x148 (1 edge), EXTPOLAR 0x14C (1 high/rising), RSIR 0x180
(reset: POR; write 1 to clear), SCS 0x1A0.

Idle: writing PCON.IDL stops the core until an interrupt (the bus wakes it when the VIC asserts
nIRQ or nFIQ and clears IDL); peripherals run on. Time: CCLK cycles.

Not modelled (NotModelled): power-down (PCON.PD), fast GPIO (SCS bits 0-1), the PLL interrupt
other than PLOCK as a level on VIC channel 12, brown-out.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum, unique
from typing import Final

from emulators.lpc2148.errors import NotModelled
from emulators.lpc2148.pll import Pll
from emulators.lpc2148.regs import RegisterFile

SCB_BASE = 0xE01F_C000
PCONP_RESET = 0x0018_17BE
VPBDIV_DIVIDERS = {0: 4, 1: 1, 2: 2}


@unique
class ScbReg(IntEnum):
    """Register offsets from 0xE01F C000."""

    MAMCR = 0x000
    MAMTIM = 0x004
    MEMMAP = 0x040
    PLL0CON = 0x080
    PLL0CFG = 0x084
    PLL0STAT = 0x088
    PLL0FEED = 0x08C
    PLL1CON = 0x0A0
    PLL1CFG = 0x0A4
    PLL1STAT = 0x0A8
    PLL1FEED = 0x0AC
    PCON = 0x0C0
    PCONP = 0x0C4
    VPBDIV = 0x100
    EXTINT = 0x140
    INTWAKE = 0x144
    EXTMODE = 0x148
    EXTPOLAR = 0x14C
    RSIR = 0x180
    SCS = 0x1A0


_MAMCR: Final = int(ScbReg.MAMCR)
_MAMTIM: Final = int(ScbReg.MAMTIM)
_MEMMAP: Final = int(ScbReg.MEMMAP)
_PLL0CON: Final = int(ScbReg.PLL0CON)
_PLL0CFG: Final = int(ScbReg.PLL0CFG)
_PLL0STAT: Final = int(ScbReg.PLL0STAT)
_PLL0FEED: Final = int(ScbReg.PLL0FEED)
_PLL1CON: Final = int(ScbReg.PLL1CON)
_PLL1CFG: Final = int(ScbReg.PLL1CFG)
_PLL1STAT: Final = int(ScbReg.PLL1STAT)
_PLL1FEED: Final = int(ScbReg.PLL1FEED)
_PCON: Final = int(ScbReg.PCON)
_PCONP: Final = int(ScbReg.PCONP)
_VPBDIV: Final = int(ScbReg.VPBDIV)
_EXTINT: Final = int(ScbReg.EXTINT)
_INTWAKE: Final = int(ScbReg.INTWAKE)
_EXTMODE: Final = int(ScbReg.EXTMODE)
_EXTPOLAR: Final = int(ScbReg.EXTPOLAR)
_RSIR: Final = int(ScbReg.RSIR)
_SCS: Final = int(ScbReg.SCS)


@unique
class Pconp(IntEnum):
    """PCONP bits of the modelled peripherals."""

    TIM0 = 1
    TIM1 = 2
    UART0 = 3
    UART1 = 4
    PWM0 = 5
    SPI0 = 8


@dataclass(frozen=True)
class ScbParams:
    """The board around the part: crystal, PLL lock time, MEMMAP as the boot loader leaves it
    (1: user flash, when it starts a valid user program)."""

    fosc_hz: float = 12e6
    pll_lock_us: float = 100.0
    memmap_at_reset: int = 1


class SystemControl:
    """The SCB registers; the bus calls :meth:`read`/:meth:`write` with the CCLK cycle and its
    APB access count (for the PLL feed)."""

    name = "SCB"

    def __init__(self, params: ScbParams = ScbParams(), base: int = SCB_BASE) -> None:
        self.base = base
        self.params = params
        self.pll0 = Pll(params.fosc_hz, params.pll_lock_us)
        self.pll1 = Pll(params.fosc_hz, params.pll_lock_us)
        self.mamcr = 0
        self.mamtim = 7
        self.memmap = params.memmap_at_reset
        self.pcon = 0
        self.pconp = PCONP_RESET
        self.vpbdiv = 0
        self.extint = self.intwake = self.extmode = self.extpolar = 0
        self.rsir = 0x01
        self.scs = 0
        self._eint_level = [True] * 4
        self.counters: dict[str, int] = {"mamtim_changed_while_on": 0}

    # -- what the bus and the core read -----------------------------------------------------
    def cclk_hz(self, cycle: int) -> float:
        return self.pll0.output_hz(cycle)

    @property
    def pclk_div(self) -> int:
        return VPBDIV_DIVIDERS[self.vpbdiv]

    @property
    def sleeping(self) -> bool:
        """PCON.IDL: the core waits for an interrupt."""
        return bool(self.pcon & 1)

    def wake(self) -> None:
        self.pcon &= ~1

    def powered(self, bit: int) -> bool:
        return bool(self.pconp >> bit & 1)

    def next_event(self) -> int | None:
        return self.pll0.lock_at

    def pll_irq(self, cycle: int) -> bool:
        return self.pll0.locked(cycle)

    # -- external interrupts ----------------------------------------------------------------
    def set_eint(self, n: int, level: bool) -> None:
        """EINT``n``'s pin (selected as EINTn) is at ``level``."""
        old, self._eint_level[n] = self._eint_level[n], level
        high_active = bool(self.extpolar >> n & 1)
        if self.extmode >> n & 1:
            if old != level and level == high_active:
                self.extint |= 1 << n
        elif level == high_active:
            self.extint |= 1 << n

    def eint_lines(self) -> int:
        """EXTINT bits 0-3, the request lines of VIC channels 14-17."""
        return self.extint & 0xF

    # -- registers ------------------------------------------------------------------------
    def read(self, offset: int, cycle: int) -> int:
        if offset == _PCON:
            return self.pcon
        if offset == _PLL0STAT:
            return self.pll0.stat(cycle)
        if offset == _PLL1STAT:
            return self.pll1.stat(cycle)
        values: dict[int, int] = {
            _MAMCR: self.mamcr, _MAMTIM: self.mamtim, _MEMMAP: self.memmap,
            _PLL0CON: self.pll0.con_written, _PLL0CFG: self.pll0.cfg_written,
            _PLL1CON: self.pll1.con_written, _PLL1CFG: self.pll1.cfg_written,
            _PCONP: self.pconp, _VPBDIV: self.vpbdiv, _EXTINT: self.extint,
            _INTWAKE: self.intwake, _EXTMODE: self.extmode, _EXTPOLAR: self.extpolar,
            _RSIR: self.rsir, _SCS: self.scs,
        }
        if offset in values:
            return values[offset]
        if offset in (_PLL0FEED, _PLL1FEED):
            raise RegisterFile(self.base).write_only(offset, "PLLFEED")
        raise RegisterFile(self.base).unmodelled(offset, "read")

    def write(self, offset: int, value: int, cycle: int, apb_seq: int = 0) -> None:
        value &= 0xFFFF_FFFF
        here = self.base + offset
        if offset == _PCON:
            if value & 2:
                raise NotModelled(here, "power-down mode (PCON.PD)")
            self.pcon = value & 0x1F
        elif offset in (ScbReg.PLL0FEED, ScbReg.PLL1FEED):
            pll = self.pll0 if offset == ScbReg.PLL0FEED else self.pll1
            pll.feed(value & 0xFF, apb_seq, cycle, self.cclk_hz(cycle))
        elif offset in (ScbReg.PLL0CON, ScbReg.PLL1CON):
            (self.pll0 if offset == ScbReg.PLL0CON else self.pll1).con_written = value & 3
        elif offset in (ScbReg.PLL0CFG, ScbReg.PLL1CFG):
            (self.pll0 if offset == ScbReg.PLL0CFG else self.pll1).cfg_written = value & 0x7F
        elif offset == ScbReg.MAMCR:
            self.mamcr = value & 3
        elif offset == ScbReg.MAMTIM:
            if self.mamcr and (value & 7) != self.mamtim:
                self.counters["mamtim_changed_while_on"] += 1
            self.mamtim = value & 7
        elif offset == ScbReg.MEMMAP:
            self.memmap = value & 3
        elif offset == ScbReg.PCONP:
            self.pconp = value
        elif offset == ScbReg.VPBDIV:
            if value & 3 != 3:  # 3 is reserved: the previous setting stays
                self.vpbdiv = value & 3
        elif offset == ScbReg.EXTINT:
            self.extint &= ~value & 0xF
            for n in range(4):  # a level-sensitive input still active sets its flag again
                if not self.extmode >> n & 1 and self._eint_level[n] == bool(self.extpolar >> n & 1):
                    self.extint |= 1 << n
        elif offset == ScbReg.INTWAKE:
            self.intwake = value & 0xC00F
        elif offset == ScbReg.EXTMODE:
            self.extmode = value & 0xF
        elif offset == ScbReg.EXTPOLAR:
            self.extpolar = value & 0xF
        elif offset == ScbReg.RSIR:
            self.rsir &= ~value & 0xF
        elif offset == ScbReg.SCS:
            if value & 3:
                raise NotModelled(here, "fast GPIO (SCS GPIO0M/GPIO1M)")
            self.scs = value
        elif offset == ScbReg.PLL0STAT or offset == ScbReg.PLL1STAT:
            raise RegisterFile(self.base).read_only(offset, "PLLSTAT")
        else:
            raise RegisterFile(self.base).unmodelled(offset, "write")
