"""The LPC2148's ARM7TDMI-S on Unicorn (ARMv4T), timed in CCLK cycles (docs/board.md).

Memory: 512 KB of flash at 0 (read-only to the program), 32 KB of SRAM at 0x4000_0000, the APB
peripherals at 0xE000_0000-0xE01F_FFFF and the VIC at 0xFFFF_F000 through the peripheral bus
(hil/board/mmio.py). Anything else is unmapped: an access there stops the run with
:class:`~hil.board.errors.CoreFault` naming the address.

:meth:`Core.run_until` runs the program to a cycle in slices: each slice ends at the first
basic block boundary at or after the next peripheral event, where the run loop lets the bus
catch up, takes an interrupt the VIC asserts (the ARM exception entry, written between slices:
Unicorn has no interrupt controller), or, while the core sleeps (PCON.IDL) or spins in a
branch to itself, skips to the next event. Cycles come from the C cycle counter
(hil/board/native.py): the ARM7TDMI TRM's timings per translated block, the MAM's flash waits,
the APB's accesses.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from enum import IntEnum

from unicorn import (UC_ARCH_ARM, UC_HOOK_INTR, UC_HOOK_MEM_INVALID, UC_MODE_ARM, UC_PROT_ALL, UC_PROT_EXEC,
                     UC_PROT_READ, Uc, UcError)
from unicorn import arm_const as A

from hil.board.blocks import Block, DecodeError, decode_block
from hil.board.elf import FirmwareImage
from hil.board.errors import CoreFault, FirmwareError
from hil.board.mmio import MmioBridge, PeripheralBus
from hil.board.native import CycleCounter, uclib
from hil.board.poll import is_poll_loop
from hil.board.semihost import ARM_SWI, THUMB_SWI, Semihost

FLASH_BASE, FLASH_SIZE = 0x0000_0000, 512 * 1024
SRAM_BASE, SRAM_SIZE = 0x4000_0000, 32 * 1024
UNTIL = 0xFFFF_FFF0  # never an instruction address: slices end through the cycle counter
EXCP_SWI = 2  # QEMU's exception number Unicorn hands UC_HOOK_INTR for an SWI


class Stop(IntEnum):
    """Why a slice ended (cyclehook.c's STOP_*)."""

    NONE = 0
    DEADLINE = 1
    REQUEST = 2
    RETRANSLATE = 3
    UNMASKED = 4
    SELF_LOOP = 5
    MISS_FAILED = 6


class Mode(IntEnum):
    """CPSR mode bits."""

    USR = 0x10
    FIQ = 0x11
    IRQ = 0x12
    SVC = 0x13
    ABT = 0x17
    UND = 0x1B
    SYS = 0x1F


CPSR_I, CPSR_F, CPSR_T = 0x80, 0x40, 0x20
VECTOR_SWI, VECTOR_IRQ, VECTOR_FIQ = 0x08, 0x18, 0x1C

#: on_interrupt(kind "irq"/"fiq", the cycle the request was seen, the cycle of the entry)
InterruptObserver = Callable[[str, int, int], None]


class Core:
    """One emulated ARM7TDMI-S with its flash, SRAM and peripheral bus."""

    def __init__(self, bus: PeripheralBus, semihost: Semihost | None = None,
                 on_interrupt: InterruptObserver | None = None) -> None:
        self.bus = bus
        self.semihost = semihost if semihost is not None else Semihost()
        self.on_interrupt = on_interrupt
        uc = Uc(UC_ARCH_ARM, UC_MODE_ARM)
        uc.ctl_set_cpu_model(A.UC_CPU_ARM_TI925T)  # ARMv4T: ARM and Thumb, no v5 instructions
        uc.mem_map(FLASH_BASE, FLASH_SIZE, UC_PROT_READ | UC_PROT_EXEC)
        uc.mem_map(SRAM_BASE, SRAM_SIZE, UC_PROT_ALL)
        self.uc = uc
        self._uch = uc._uch
        self._fault: BaseException | None = None
        self._stale: list[tuple[int, int]] = []
        self._by_insn: dict[int, set[tuple[int, int]]] = {}
        self.blocks: dict[tuple[int, int], Block] = {}
        self.counter = CycleCounter(uc, self._miss)
        self.mmio = MmioBridge(uc, self.counter, bus)
        self.mmio.is_poll_loop = self._is_poll_loop
        self._poll_loops: dict[tuple[int, int], bool] = {}
        self._hooks = [uc.hook_add(UC_HOOK_INTR, self._intr), uc.hook_add(UC_HOOK_MEM_INVALID, self._invalid)]
        self._reg = ctypes.c_uint32(0)
        self._reg_ref = ctypes.byref(self._reg)
        self.idle_cycles = 0  #: asleep in PCON idle
        self.spin_cycles = 0  #: skipped passes of a branch to itself
        self.poll_cycles = 0  #: skipped passes of a polling loop
        self.slices = 0
        self.retranslations = 0
        self.interrupts = {"irq": 0, "fiq": 0, "swi": 0}
        self._irq_seen_at: int | None = None
        self._slice_event: int | None = None
        #: stopped for a debugger (hil/board/debug.py): a run returns at once, short of its target
        self.halted = False
        self.reset()

    # -- state ------------------------------------------------------------------------------------
    @property
    def cycles(self) -> int:
        """CCLK cycles since reset."""
        return int(self.counter.state.cycles)

    def reg(self, regid: int) -> int:
        uclib.uc_reg_read(self._uch, regid, self._reg_ref)
        return self._reg.value

    def set_reg(self, regid: int, value: int) -> None:
        self._reg.value = value & 0xFFFF_FFFF
        uclib.uc_reg_write(self._uch, regid, self._reg_ref)

    @property
    def pc(self) -> int:
        return self.reg(A.UC_ARM_REG_PC)

    @property
    def cpsr(self) -> int:
        return self.reg(A.UC_ARM_REG_CPSR)

    def read_memory(self, address: int, size: int) -> bytes:
        return bytes(self.uc.mem_read(address, size))

    def read_u32(self, address: int) -> int:
        return int.from_bytes(self.read_memory(address, 4), "little")

    # -- program --------------------------------------------------------------------------------
    def load(self, image: FirmwareImage) -> None:
        """Place the image's segments in flash and SRAM, then reset."""
        for seg in image.segments:
            end = seg.address + len(seg.data)
            inside = [(b, s) for b, s in ((FLASH_BASE, FLASH_SIZE), (SRAM_BASE, SRAM_SIZE))
                      if b <= seg.address and end <= b + s]
            if not inside:
                raise FirmwareError(f"{image.path}: a segment at {seg.address:#010x}-{end:#010x} is outside the "
                                    f"LPC2148's flash (512 KB at 0) and SRAM (32 KB at 0x40000000)")
            self.uc.mem_write(seg.address, seg.data)
        self.reset()

    def load_code(self, address: int, code: bytes) -> None:
        """Place raw code (tests)."""
        self.uc.mem_write(address, code)

    def reset(self, pc: int = 0) -> None:
        """The reset state: supervisor mode, IRQ and FIQ masked, ARM state, at ``pc``."""
        self.set_reg(A.UC_ARM_REG_CPSR, Mode.SVC | CPSR_I | CPSR_F)
        self.set_reg(A.UC_ARM_REG_PC, pc)
        self.counter.state.next_nonseq = 1

    # -- running --------------------------------------------------------------------------------
    def run_until(self, target: int) -> None:
        """Run the program until its cycle count reaches ``target`` (it may pass it by the
        rest of a basic block), or until a debugger halts it (``halted``)."""
        self._run(target, UNTIL)

    def run_to(self, address: int, limit: int) -> int:
        """Run until the core is about to execute ``address`` (ARM or Thumb); returns the cycle
        count then. :class:`CoreFault` if ``limit`` cycles pass first."""
        self.uc.ctl_flush_tb()  # a block translated before may run through the address
        self._run(limit, address & ~1)
        if self.pc != address & ~1:
            raise CoreFault(f"did not reach {address:#010x} within {limit} cycles", self.pc)
        return self.cycles

    def _run(self, target: int, stop_pc: int) -> None:
        s = self.counter.state
        bus = self.bus
        while s.cycles < target and not self.halted:
            if self.pc == stop_pc:
                break
            bus.advance_to(s.cycles)
            if self._interrupt():
                continue
            nxt = bus.next_irq_cycle()  # only an interrupt changes what the core does next
            bus.schedule_changed = False
            until = target if nxt is None or nxt > target else nxt
            if bus.sleeping:
                self.idle_cycles += until - s.cycles
                s.cycles = until
                continue
            s.deadline = until
            self.mmio.slice_limit = target
            self._slice(stop_pc)
            # a slice that ended on a peripheral event: an interrupt it raises was requested then
            self._slice_event = int(s.deadline) if s.stop_reason == Stop.DEADLINE and s.deadline < target else None
        bus.advance_to(s.cycles)  # the peripherals at the core's cycle: what they sent by then can be taken

    def _slice(self, stop_pc: int) -> None:
        s = self.counter.state
        pc = self.pc | (1 if self.cpsr & CPSR_T else 0)
        s.stop_reason = Stop.NONE
        err = uclib.uc_emu_start(self._uch, pc, stop_pc, 0, 0)
        self.slices += 1
        self.counter.settle(self.pc)
        fault = self._fault or self.mmio.fault
        if fault is not None:
            self._fault = self.mmio.fault = None
            raise fault
        if err:
            raise CoreFault(f"the core stopped: {UcError(err)}", self.pc)
        reason = s.stop_reason
        if reason == Stop.RETRANSLATE:
            self.retranslations += 1
            for begin, end in self._stale:
                self.uc.ctl_remove_cache(begin, end)
            self._stale.clear()
        elif reason == Stop.SELF_LOOP:
            self._spin()
        elif reason == Stop.REQUEST and self.mmio.poll_found:
            self._skip_polls()
        elif reason == Stop.MISS_FAILED:
            raise CoreFault(f"no cycle facts for the block at {s.miss_addr:#010x}", s.miss_addr)

    def _spin(self) -> None:
        """A branch to itself: its iterations up to the next event cost nothing to emulate."""
        s = self.counter.state
        nxt = self.bus.next_irq_cycle()
        until = s.deadline if nxt is None else min(nxt, s.deadline)
        period = max(int(s.last_cost), 1)
        n = -(-(until - int(s.cycles)) // period)
        if n > 0:
            s.cycles += n * period
            self.spin_cycles += n * period

    def _skip_polls(self) -> None:
        """A polling loop: its passes up to the next event give the same results."""
        s, watch, bus = self.counter.state, self.mmio.poll_watch, self.bus
        self.mmio.poll_found = False
        if bus.sleeping or bus.irq_request or bus.fiq_request:
            watch.reset()
            return
        nxt = bus.next_event_cycle()
        until = s.deadline if nxt is None else min(nxt, s.deadline)
        period = max(watch.period, 1)
        n = -(-(until - int(s.cycles)) // period)
        if n > 0:
            s.cycles += n * period
            self.poll_cycles += n * period
        watch.reset()

    def _is_poll_loop(self, address: int, size: int) -> bool:
        key = (address, size)
        found = self._poll_loops.get(key)
        if found is None:
            block = self.blocks.get(key)
            found = block is not None and is_poll_loop(block, self.read_memory(address, size))
            self._poll_loops[key] = found
        return found

    def _interrupt(self) -> bool:
        """Take an interrupt the VIC asserts and the CPSR allows; else watch for the CPSR
        allowing it."""
        bus, s = self.bus, self.counter.state
        irq, fiq = bus.irq_request, bus.fiq_request
        self.mmio.irq_seen, self.mmio.fiq_seen = irq, fiq
        if self.mmio.request_ended:  # every request seen ended at an access since the last look
            self.mmio.request_ended = False
            self._irq_seen_at = None
        if not (irq or fiq):
            s.irq_watch = 0
            self._irq_seen_at = None
            return False
        if self._irq_seen_at is None:
            self._irq_seen_at = self._slice_event if self._slice_event is not None else int(s.cycles)
        cpsr = self.cpsr
        if fiq and not cpsr & CPSR_F:
            self._enter("fiq", Mode.FIQ, CPSR_I | CPSR_F, VECTOR_FIQ)
            return True
        if irq and not cpsr & CPSR_I:
            self._enter("irq", Mode.IRQ, CPSR_I, VECTOR_IRQ)
            return True
        s.irq_watch = (CPSR_F if fiq else 0) | (CPSR_I if irq else 0)
        return False

    def _enter(self, kind: str, mode: Mode, mask: int, vector: int) -> None:
        memmap = getattr(self.bus.scb, "memmap", 1)
        if memmap != 1:
            raise CoreFault(f"an exception with MEMMAP = {memmap}: only user flash vectors (MEMMAP = 1) are modelled",
                            self.pc)
        requested = self._irq_seen_at if self._irq_seen_at is not None else self.cycles
        entry = self.cycles
        self.counter.enter_exception(mode, mask, vector, 4)
        self.counter.state.irq_watch = 0
        self._irq_seen_at = None
        self.interrupts[kind] += 1
        if self.on_interrupt is not None:
            self.on_interrupt(kind, requested, entry)

    # -- callbacks from inside the emulation ----------------------------------------------------
    def _miss(self, address: int, size: int) -> int:
        try:
            thumb = bool(self.cpsr & CPSR_T)
            code = self.read_memory(address, size)
            counter = self.counter
            block = decode_block(code, address, thumb, counter.probed)
            new = [it for it in block.probes() if it.address not in counter.probed]
            for it in new:
                counter.add_probe(it)
            counter.insert(block)
            self.blocks[(address, size)] = block
            for it in block.items:
                self._by_insn.setdefault(it.address, set()).add((address, size))
            if not new:
                return 0
            self._stale.append((address, address + size))
            for it in new:  # blocks decoded before, with this item at their start or end
                for key in self._by_insn.get(it.address, set()) - {(address, size)}:
                    other = decode_block(self.read_memory(*key), key[0], thumb, counter.probed)
                    counter.insert(other)
                    self.blocks[key] = other
                    self._stale.append((key[0], key[0] + key[1]))
            return 1
        except DecodeError as e:
            self._fault = CoreFault(str(e), address)
        except BaseException as e:  # noqa: BLE001 - handed to the run loop, never lost in ctypes
            self._fault = e
        return 2

    def _intr(self, uc: Uc, intno: int, _user: object) -> None:
        try:
            pc = self.pc
            if intno != EXCP_SWI:
                raise CoreFault(f"exception {intno} (only SWI reaches the board's interrupt hook)", pc)
            self.counter.settle(pc)
            thumb = bool(self.cpsr & CPSR_T)
            number = (self.read_u32(pc - 2) & 0xFF) if thumb else (self.read_u32(pc - 4) & 0xFF_FFFF)
            if number == (THUMB_SWI if thumb else ARM_SWI):
                r0 = self.semihost.serve(self.reg(A.UC_ARM_REG_R0), self.reg(A.UC_ARM_REG_R1), self.read_memory,
                                         pc)
                self.set_reg(A.UC_ARM_REG_R0, r0)
                if self.semihost.exit_reason is not None:
                    self.counter.state.stop_request = 1
                return
            self.interrupts["swi"] += 1
            self.counter.enter_exception(Mode.SVC, CPSR_I, VECTOR_SWI, 0)
        except BaseException as e:  # noqa: BLE001
            self._fault = e
            self.counter.state.stop_request = 1

    def _invalid(self, uc: Uc, access: int, address: int, size: int, value: int, _user: object) -> bool:
        what = "write to flash" if address < FLASH_SIZE else "access to unmapped memory"
        self._fault = CoreFault(f"{size}-byte {what} at {address:#010x} (the LPC2148 has flash at 0, SRAM at "
                                f"0x40000000, peripherals at 0xE0000000 and 0xFFFFF000)", self.pc)
        return False
