"""A debugger's view of the emulated core: halting, breakpoints, a single step, registers and
memory, and the GDB remote protocol's commands over them (sans-I/O: packets in, replies out;
hil/flight/board_gdb.py carries them over TCP).

A breakpoint is a Unicorn code hook on its address that stops the core *before* the
instruction there runs; it costs no cycle until it stops the core. The cycle counter charges a
block when it enters it, so the rest of the stopped block is charged again when the core
resumes there (5 cycles a stop in tests/unit/board/test_debug.py's loop; docs/board.md).
Resuming from a breakpoint steps over it once. A halt also comes from a single step, from GDB's interrupt
(taken at the next tick), and at reset, where a debugger gets the core before its first
instruction.

Registers are GDB's ARM core set (feature ``org.gnu.gdb.arm.core``): r0-r12, sp, lr, pc and
cpsr, numbered 0-16 here as the target description says. Memory is the flash and the SRAM;
the peripherals are refused (a read of a FIFO or a status register would change the device).
"""

from __future__ import annotations

import signal
from enum import Enum

from unicorn import UC_HOOK_CODE, Uc, UcError
from unicorn import arm_const as A

from hil.board.core import FLASH_BASE, FLASH_SIZE, SRAM_BASE, SRAM_SIZE, Core

REGS = [getattr(A, f"UC_ARM_REG_R{i}") for i in range(13)] + [
    A.UC_ARM_REG_SP, A.UC_ARM_REG_LR, A.UC_ARM_REG_PC, A.UC_ARM_REG_CPSR]
_NAMES = [f"r{i}" for i in range(13)] + ["sp", "lr", "pc", "cpsr"]

_TYPES = {"sp": "data_ptr", "pc": "code_ptr"}
TARGET_XML = ("<?xml version=\"1.0\"?>\n<!DOCTYPE target SYSTEM \"gdb-target.dtd\">\n<target version=\"1.0\">\n"
              "<architecture>armv4t</architecture>\n<feature name=\"org.gnu.gdb.arm.core\">\n"
              + "".join(f"<reg name=\"{n}\" bitsize=\"32\" regnum=\"{i}\" type=\"{_TYPES.get(n, 'int')}\"/>\n"
                        for i, n in enumerate(_NAMES))
              + "</feature>\n</target>\n").encode()
PACKET_SIZE = 0x1000


class Resume(Enum):
    """What a command asks of the run after its reply."""

    STAY = "stay"  #: still halted: answer the next packet
    CONTINUE = "continue"
    STEP = "step"
    DETACH = "detach"  #: breakpoints gone, the core runs on, the session is over
    KILL = "kill"  #: the run ends


def _hex32(value: int) -> str:
    return (value & 0xFFFF_FFFF).to_bytes(4, "little").hex()


def _readable(address: int, length: int) -> bool:
    end = address + length
    return any(base <= address and end <= base + size for base, size in ((FLASH_BASE, FLASH_SIZE),
                                                                          (SRAM_BASE, SRAM_SIZE)))


class Debugger:
    """The core as GDB sees it. ``halted`` says whether it is stopped for the debugger;
    ``stop_signal`` is the signal of the last stop (SIGTRAP for a breakpoint or a step,
    SIGINT for an interrupt)."""

    def __init__(self, core: Core) -> None:
        self.core = core
        self.uc = core.uc
        self.breakpoints: dict[int, int] = {}  #: address -> hook handle
        self.stop_signal = int(signal.SIGTRAP)
        self._skip_at: int | None = None  #: the breakpoint the core resumes from: run it once
        self._step: int | None = None  #: the hook of a single step in progress
        self._step_from: int | None = None
        self.interrupt_requested = False
        self.stops = 0
        core.halted = True  # at reset: the debugger has the core before its first instruction

    # -- halting ------------------------------------------------------------------------------
    def _halt(self, signo: int) -> None:
        self.core.halted = True
        self.stop_signal = signo
        self.stops += 1
        self.uc.emu_stop()

    def _on_breakpoint(self, uc: Uc, address: int, size: int, _user: object) -> None:
        if self._skip_at == address:
            self._skip_at = None
            return
        self._skip_at = None
        if address in self.breakpoints:
            self._halt(int(signal.SIGTRAP))

    def _on_step(self, uc: Uc, address: int, size: int, _user: object) -> None:
        if self._step_from is not None and address == self._step_from:
            self._step_from = None  # the instruction to step: it runs
            return
        self._end_step()
        self._halt(int(signal.SIGTRAP))

    def _end_step(self) -> None:
        if self._step is not None:
            self.uc.hook_del(self._step)
            self._step = None
            self._step_from = None

    def take_interrupt(self) -> None:
        """GDB asked the running core to stop: halt it here (between ticks)."""
        if self.interrupt_requested and not self.core.halted:
            self.interrupt_requested = False
            self.core.halted = True
            self.stop_signal = int(signal.SIGINT)
            self.stops += 1

    def resume(self, how: Resume) -> None:
        """Let the core run (a continue, a step or a detach)."""
        pc = self.core.pc
        self._skip_at = pc if pc in self.breakpoints else None
        if how is Resume.STEP:
            self._step_from = pc
            self._step = self.uc.hook_add(UC_HOOK_CODE, self._on_step, begin=1, end=0)
            self.uc.ctl_flush_tb()  # blocks translated before carry no call to the new hook
        if how is Resume.DETACH:
            for address in list(self.breakpoints):
                self.remove_breakpoint(address)
        self.core.halted = False

    # -- breakpoints ----------------------------------------------------------------------------
    def add_breakpoint(self, address: int) -> None:
        address &= ~1
        if address in self.breakpoints:
            return
        self.breakpoints[address] = self.uc.hook_add(UC_HOOK_CODE, self._on_breakpoint, begin=address, end=address)
        self.uc.ctl_remove_cache(address, address + 4)  # a block translated before runs through it

    def remove_breakpoint(self, address: int) -> None:
        handle = self.breakpoints.pop(address & ~1, None)
        if handle is not None:
            self.uc.hook_del(handle)

    # -- registers and memory -------------------------------------------------------------------
    def registers(self) -> list[int]:
        return [self.core.reg(r) for r in REGS]

    def set_register(self, n: int, value: int) -> None:
        self.core.set_reg(REGS[n], value)

    def read(self, address: int, length: int) -> bytes | None:
        if length == 0 or not _readable(address, length):
            return None
        try:
            return self.core.read_memory(address, length)
        except UcError:
            return None

    def write(self, address: int, data: bytes) -> bool:
        """SRAM only: the flash takes the LPC2148's IAP, which a debugger's write is not."""
        if not data or not (SRAM_BASE <= address and address + len(data) <= SRAM_BASE + SRAM_SIZE):
            return False
        self.uc.mem_write(address, data)
        return True

    # -- the remote protocol ----------------------------------------------------------------------
    def stop_reply(self) -> bytes:
        return f"S{self.stop_signal:02x}".encode()

    def command(self, packet: bytes) -> tuple[bytes | None, Resume]:
        """One packet's reply (None: none now; a resume replies when the core halts again) and
        what the run does next."""
        try:
            return self._command(packet.decode("latin-1"))
        except (ValueError, IndexError):
            return b"E01", Resume.STAY

    def _command(self, p: str) -> tuple[bytes | None, Resume]:
        stay = Resume.STAY
        if p == "?":
            return self.stop_reply(), stay
        if p.startswith("qSupported"):
            return f"PacketSize={PACKET_SIZE:x};qXfer:features:read+".encode(), stay
        if p.startswith("qXfer:features:read:target.xml:"):
            offset, length = (int(x, 16) for x in p.rsplit(":", 1)[1].split(","))
            chunk = TARGET_XML[offset : offset + length]
            return (b"m" if offset + length < len(TARGET_XML) else b"l") + chunk, stay
        if p == "g":
            return "".join(_hex32(v) for v in self.registers()).encode(), stay
        if p.startswith("G"):
            raw = bytes.fromhex(p[1:])
            for n in range(min(len(raw) // 4, len(REGS))):
                self.set_register(n, int.from_bytes(raw[4 * n : 4 * n + 4], "little"))
            return b"OK", stay
        if p.startswith("p"):
            n = int(p[1:], 16)
            return (_hex32(self.registers()[n]).encode() if n < len(REGS) else b"E00"), stay
        if p.startswith("P"):
            n_text, value = p[1:].split("=")
            n = int(n_text, 16)
            if n >= len(REGS):
                return b"E00", stay
            self.set_register(n, int.from_bytes(bytes.fromhex(value), "little"))
            return b"OK", stay
        if p.startswith("m"):
            address, length = (int(x, 16) for x in p[1:].split(","))
            data = self.read(address, min(length, PACKET_SIZE // 2))
            return (data.hex().encode() if data is not None else b"E01"), stay
        if p.startswith("M"):
            where, hexdata = p[1:].split(":")
            address, length = (int(x, 16) for x in where.split(","))
            data = bytes.fromhex(hexdata)
            return (b"OK" if len(data) == length and self.write(address, data) else b"E01"), stay
        if p[:2] in ("Z0", "Z1", "z0", "z1"):
            address = int(p[3:].split(",")[0], 16)
            if p[0] == "Z":
                self.add_breakpoint(address)
            else:
                self.remove_breakpoint(address)
            return b"OK", stay
        if p in ("c", "s") or p[0] in "cs" and len(p) > 1:
            if len(p) > 1:
                self.core.set_reg(A.UC_ARM_REG_PC, int(p[1:], 16))
            return None, Resume.CONTINUE if p[0] == "c" else Resume.STEP
        if p == "D" or p.startswith("D;"):
            return b"OK", Resume.DETACH
        if p == "k" or p.startswith("vKill"):
            return (b"OK" if p.startswith("vKill") else None), Resume.KILL
        if p.startswith("H") or p.startswith("T") or p == "qSymbol::":
            return b"OK", stay
        if p == "qC":
            return b"QC1", stay
        if p == "qfThreadInfo":
            return b"m1", stay
        if p == "qsThreadInfo":
            return b"l", stay
        if p == "qAttached":
            return b"1", stay
        return b"", stay  # not supported: GDB falls back (vCont to c and s, X to M)
