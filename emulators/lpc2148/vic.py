"""The LPC2148's Vectored Interrupt Controller, an ARM PrimeCell PL190 (UM10139, chapter
"Vectored Interrupt Controller (VIC)"; register map at 0xFFFF F000).

32 request inputs (the LPC2148 wires 0-22, :class:`~emulators.lpc2148.regs.VicChannel`) are ORed
with VICSoftInt, then split by VICIntSelect into FIQ (1) and IRQ (0) and gated by VICIntEnable.
IRQs assigned to one of 16 vectored slots (VICVectCntl0-15: bit 5 enable, bits 4:0 channel;
slot 0 the highest priority) are vectored; the other enabled IRQs are non-vectored, below
every slot.

The priority hardware: reading VICVectAddr returns VICVectAddrN of the highest-priority active
vectored slot (or VICDefVectAddr for a non-vectored IRQ) and from then on masks that priority
and every lower one from nIRQ, until a write to VICVectAddr ends that interrupt (the PL190's
priority stack, so nested ISRs unwind in order). A read with nothing active returns
VICDefVectAddr and masks nothing. A write with nothing in service does nothing.

Outputs: :attr:`Vic.irq_request` and :attr:`Vic.fiq_request`, True while nIRQ / nFIQ are
asserted (low).

Not modelled: VICProtection's effect (the model does not know the CPU mode; the bit is stored),
the PL190's test registers.
"""

from __future__ import annotations

from enum import IntEnum, unique
from typing import Final

from emulators.lpc2148.regs import MASK32, RegisterFile

VIC_BASE = 0xFFFF_F000
N_SLOTS = 16
#: the priority level of the non-vectored IRQs (below slot 15)
NON_VECTORED = N_SLOTS
_NOTHING_IN_SERVICE = N_SLOTS + 1
_SLOT_ENABLE = 0x20
_SLOT_CHANNEL = 0x1F


@unique
class VicReg(IntEnum):
    """Register offsets (UM10139 VIC register map table)."""

    IRQ_STATUS = 0x000  #: RO
    FIQ_STATUS = 0x004  #: RO
    RAW_INTR = 0x008  #: RO
    INT_SELECT = 0x00C
    INT_ENABLE = 0x010
    INT_EN_CLR = 0x014  #: WO
    SOFT_INT = 0x018
    SOFT_INT_CLEAR = 0x01C  #: WO
    PROTECTION = 0x020
    VECT_ADDR = 0x030
    DEF_VECT_ADDR = 0x034
    VECT_ADDR0 = 0x100  #: .. 0x13C
    VECT_CNTL0 = 0x200  #: .. 0x23C


_VECT_ADDR: Final = int(VicReg.VECT_ADDR)
_VECT_ADDR0: Final = int(VicReg.VECT_ADDR0)
_VECT_CNTL0: Final = int(VicReg.VECT_CNTL0)
_IRQ_STATUS: Final = int(VicReg.IRQ_STATUS)
_FIQ_STATUS: Final = int(VicReg.FIQ_STATUS)
_RAW_INTR: Final = int(VicReg.RAW_INTR)
_INT_SELECT: Final = int(VicReg.INT_SELECT)
_INT_ENABLE: Final = int(VicReg.INT_ENABLE)
_INT_EN_CLR: Final = int(VicReg.INT_EN_CLR)
_SOFT_INT: Final = int(VicReg.SOFT_INT)
_SOFT_INT_CLEAR: Final = int(VicReg.SOFT_INT_CLEAR)
_PROTECTION: Final = int(VicReg.PROTECTION)
_DEF_VECT_ADDR: Final = int(VicReg.DEF_VECT_ADDR)


class Vic(RegisterFile):
    """The VIC. The bus sets the peripherals' request lines with :meth:`set_sources`.

    nIRQ and nFIQ are computed when an input or a register changes, not when they are read."""

    name = "VIC"

    def __init__(self, base: int = VIC_BASE) -> None:
        super().__init__(base)
        self.sources = 0  #: request lines from the peripherals, bit n = channel n
        self.int_select = 0
        self.int_enable = 0
        self.soft_int = 0
        self.protection = 0
        self.def_vect_addr = 0
        self.vect_addr = [0] * N_SLOTS
        self.vect_cntl = [0] * N_SLOTS
        #: priority levels in service, innermost last (slot number, or NON_VECTORED)
        self.in_service: list[int] = []
        #: channel -> its priority level (from vect_cntl)
        self._levels = [NON_VECTORED] * 32
        self._irq = False
        self._fiq = False

    # -- inputs ---------------------------------------------------------------------------
    def set_sources(self, mask: int) -> None:
        """The levels of the 32 request lines (bit n = channel n asserted)."""
        mask &= MASK32
        if mask != self.sources:
            self.sources = mask
            self._outputs()

    def _outputs(self) -> None:
        """nIRQ and nFIQ from the inputs and the registers."""
        active = (self.sources | self.soft_int) & self.int_enable
        self._fiq = active & self.int_select != 0
        irq = active & ~self.int_select & MASK32
        self._irq = irq != 0 and self._highest_of(irq) < self._current_level()

    # -- derived state --------------------------------------------------------------------
    @property
    def raw(self) -> int:
        """VICRawIntr: requests ORed with the software interrupts, before enabling."""
        return self.sources | self.soft_int

    @property
    def irq_status(self) -> int:
        return self.raw & self.int_enable & ~self.int_select & MASK32

    @property
    def fiq_status(self) -> int:
        return self.raw & self.int_enable & self.int_select

    def _level_of(self, channel: int) -> int:
        """The priority of ``channel``: its lowest enabled slot, else NON_VECTORED."""
        for slot, cntl in enumerate(self.vect_cntl):
            if cntl & _SLOT_ENABLE and cntl & _SLOT_CHANNEL == channel:
                return slot
        return NON_VECTORED

    def _current_level(self) -> int:
        return self.in_service[-1] if self.in_service else _NOTHING_IN_SERVICE

    def _highest_of(self, status: int) -> int:
        """The highest-priority (lowest) level among the channels in ``status``."""
        levels = self._levels
        best = _NOTHING_IN_SERVICE
        channel = 0
        while status:
            if status & 1 and levels[channel] < best:
                best = levels[channel]
            status >>= 1
            channel += 1
        return best

    def _highest_active(self) -> int:
        """The highest-priority (lowest) level among the active IRQs, _NOTHING_IN_SERVICE if none."""
        return self._highest_of(self.irq_status)

    @property
    def irq_request(self) -> bool:
        """nIRQ asserted: an active IRQ above the priority in service."""
        return self._irq

    @property
    def fiq_request(self) -> bool:
        """nFIQ asserted: an active FIQ (FIQs have no priority logic)."""
        return self._fiq

    # -- registers ------------------------------------------------------------------------
    def read(self, offset: int, tick: int = 0) -> int:
        if offset == _VECT_ADDR:
            return self._acknowledge()
        if _VECT_ADDR0 <= offset < _VECT_ADDR0 + 4 * N_SLOTS:
            return self.vect_addr[(offset - _VECT_ADDR0) >> 2]
        if _VECT_CNTL0 <= offset < _VECT_CNTL0 + 4 * N_SLOTS:
            return self.vect_cntl[(offset - _VECT_CNTL0) >> 2]
        if offset == _IRQ_STATUS:
            return self.irq_status
        if offset == _FIQ_STATUS:
            return self.fiq_status
        if offset == _RAW_INTR:
            return self.raw
        if offset == _INT_SELECT:
            return self.int_select
        if offset == _INT_ENABLE:
            return self.int_enable
        if offset == _SOFT_INT:
            return self.soft_int
        if offset == _PROTECTION:
            return self.protection
        if offset == _DEF_VECT_ADDR:
            return self.def_vect_addr
        if offset == _INT_EN_CLR:
            raise self.write_only(offset, "VICIntEnClr")
        if offset == _SOFT_INT_CLEAR:
            raise self.write_only(offset, "VICSoftIntClear")
        raise self.unmodelled(offset, "read")

    def write(self, offset: int, value: int, tick: int = 0) -> None:
        value &= MASK32
        if offset == _VECT_ADDR:
            if self.in_service:  # the ISR's end: lower priorities may interrupt again
                self.in_service.pop()
        elif _VECT_ADDR0 <= offset < _VECT_ADDR0 + 4 * N_SLOTS:
            self.vect_addr[(offset - _VECT_ADDR0) >> 2] = value
            return
        elif _VECT_CNTL0 <= offset < _VECT_CNTL0 + 4 * N_SLOTS:
            self.vect_cntl[(offset - _VECT_CNTL0) >> 2] = value & (_SLOT_ENABLE | _SLOT_CHANNEL)
            levels = [NON_VECTORED] * 32
            for slot in range(N_SLOTS - 1, -1, -1):  # the lowest enabled slot of a channel wins
                cntl = self.vect_cntl[slot]
                if cntl & _SLOT_ENABLE:
                    levels[cntl & _SLOT_CHANNEL] = slot
            self._levels = levels
        elif offset == _INT_SELECT:
            self.int_select = value
        elif offset == _INT_ENABLE:
            self.int_enable |= value  # writing 0s has no effect (VICIntEnClr clears)
        elif offset == _INT_EN_CLR:
            self.int_enable &= ~value
        elif offset == _SOFT_INT:
            self.soft_int |= value
        elif offset == _SOFT_INT_CLEAR:
            self.soft_int &= ~value
        elif offset == _PROTECTION:
            self.protection = value & 1
            return
        elif offset == _DEF_VECT_ADDR:
            self.def_vect_addr = value
            return
        elif offset in (_IRQ_STATUS, _FIQ_STATUS, _RAW_INTR):
            raise self.read_only(offset, VicReg(offset).name)
        else:
            raise self.unmodelled(offset, "write")
        self._outputs()

    def _acknowledge(self) -> int:
        """A read of VICVectAddr: the address of the interrupt now serviced, and its priority
        pushed so that only higher priorities assert nIRQ until the matching write."""
        level = self._highest_active()
        if level >= self._current_level():
            return self.def_vect_addr  # nothing above what is in service: no push
        self.in_service.append(level)
        self._outputs()
        return self.def_vect_addr if level == NON_VECTORED else self.vect_addr[level]
