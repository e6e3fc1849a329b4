"""The C cycle counter (cyclehook.c) from Python: its structures, its tables, and its hooks on a
Unicorn engine.

The library is built by the package's install (setup.py, ``hil.board._cyclehook``), like the
clock shim. It calls Unicorn through function pointers filled in here from the ``unicorn``
package's own library, so it links against nothing.
"""

from __future__ import annotations

import ctypes
import importlib.util
from collections.abc import Callable
from pathlib import Path

from unicorn import UC_HOOK_BLOCK, UC_HOOK_CODE, Uc
from unicorn import arm_const as A
from unicorn.unicorn_py3 import unicorn as _ucmod

from hil.board.blocks import Block, Item

uclib = _ucmod.uclib

TABLE_BITS = 16  #: block table slots (65536), open addressing
ITEM_POOL = 1 << 16
LINE_POOL = 1 << 17
NO_REG = 0xFF
NO_LINE = 0xFFFF_FFFF

MissFn = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_uint32, ctypes.c_uint32)


class ItemT(ctypes.Structure):
    _fields_ = [("cond", ctypes.c_uint8), ("mul_reg", ctypes.c_uint8), ("mul_unsigned", ctypes.c_uint8),
                ("when", ctypes.c_uint8), ("false_delta", ctypes.c_int32)]


class BlockT(ctypes.Structure):
    _fields_ = [("addr", ctypes.c_uint32), ("size", ctypes.c_uint32), ("cost", ctypes.c_uint32),
                ("taken_extra", ctypes.c_uint32), ("fall", ctypes.c_uint32), ("n_instr", ctypes.c_uint32),
                ("flags", ctypes.c_uint32), ("item_first", ctypes.c_uint32), ("n_start", ctypes.c_uint16),
                ("n_end", ctypes.c_uint16), ("first_line", ctypes.c_uint32), ("last_line", ctypes.c_uint32),
                ("cross_first", ctypes.c_uint32), ("n_cross", ctypes.c_uint32), ("lit_first", ctypes.c_uint32),
                ("n_lit", ctypes.c_uint32), ("tail_cycles", ctypes.c_uint32), ("total_cycles", ctypes.c_uint32)]


class StateT(ctypes.Structure):
    _fields_ = [
        ("cycles", ctypes.c_uint64), ("block_start", ctypes.c_uint64), ("deadline", ctypes.c_uint64),
        ("blocks", ctypes.c_uint64), ("instructions", ctypes.c_uint64),
        ("evals_start", ctypes.c_uint64), ("evals_end", ctypes.c_uint64), ("evals_probe", ctypes.c_uint64),
        ("stop_reason", ctypes.c_uint32), ("stop_request", ctypes.c_uint32), ("irq_watch", ctypes.c_uint32),
        ("next_nonseq", ctypes.c_uint32), ("last_cost", ctypes.c_uint32),
        ("miss_addr", ctypes.c_uint32), ("miss_size", ctypes.c_uint32),
        ("cur_addr", ctypes.c_uint32), ("cur_size", ctypes.c_uint32),
        ("prev", ctypes.c_void_p), ("last", ctypes.c_void_p),
        ("mam_mode", ctypes.c_uint32), ("mam_cycles", ctypes.c_uint32),
        ("cur_line", ctypes.c_uint32), ("btb_line", ctypes.c_uint32), ("data_line", ctypes.c_uint32),
        ("carried", ctypes.c_uint32),
        ("table", ctypes.POINTER(BlockT)), ("mask", ctypes.c_uint32),
        ("items", ctypes.POINTER(ItemT)), ("cross", ctypes.POINTER(ctypes.c_uint32)),
        ("lits", ctypes.POINTER(ctypes.c_uint32)),
        ("uc", ctypes.c_void_p), ("reg_read", ctypes.c_void_p), ("reg_write", ctypes.c_void_p),
        ("emu_stop", ctypes.c_void_p), ("miss", MissFn),
        ("regid", ctypes.c_int32 * 16), ("cpsr_id", ctypes.c_int32), ("spsr_id", ctypes.c_int32),
    ]


class ProbeT(ctypes.Structure):
    _fields_ = [("state", ctypes.POINTER(StateT)), ("item", ItemT)]


REG_IDS = [A.UC_ARM_REG_R0 + r for r in range(13)] + [A.UC_ARM_REG_SP, A.UC_ARM_REG_LR, A.UC_ARM_REG_PC]


class HookLibraryMissing(RuntimeError):
    """The C cycle counter was not built."""


def library_path() -> Path:
    spec = importlib.util.find_spec("hil.board._cyclehook")
    if spec is None or spec.origin is None or not Path(spec.origin).is_file():
        raise HookLibraryMissing("the board's cycle counter (hil.board._cyclehook) was not built: "
                                 "reinstall the package (pip install -e .)")
    return Path(spec.origin)


_LIB: ctypes.CDLL | None = None


def library() -> ctypes.CDLL:
    global _LIB
    if _LIB is None:
        lib = ctypes.CDLL(str(library_path()))
        lib.cyc_settle.argtypes = [ctypes.POINTER(StateT), ctypes.c_uint32]
        lib.cyc_settle.restype = None
        lib.cyc_enter_exception.argtypes = [ctypes.POINTER(StateT)] + [ctypes.c_uint32] * 4
        lib.cyc_enter_exception.restype = None
        _LIB = lib
    return _LIB


def _fn_address(fn: "ctypes._FuncPointer") -> int:  # a C function of a loaded library
    return ctypes.cast(fn, ctypes.c_void_p).value or 0


class CycleCounter:
    """The C state, its tables and hooks, bound to one Unicorn engine.

    ``miss(address, size) -> Block | None`` is called for a block the table does not have; it
    returns the decoded block (inserted here) or None when the run must stop."""

    def __init__(self, uc: Uc, miss: Callable[[int, int], int]) -> None:
        self.uc = uc
        self.lib = library()
        self.table = (BlockT * (1 << TABLE_BITS))()
        self.items = (ItemT * ITEM_POOL)()
        self.cross = (ctypes.c_uint32 * LINE_POOL)()
        self.lits = (ctypes.c_uint32 * LINE_POOL)()
        self.n_blocks = self.n_items = self.n_cross = self.n_lits = 0
        self._miss = MissFn(miss)  # kept alive as long as the engine
        s = StateT()
        s.deadline = 0
        s.mam_mode, s.mam_cycles = 0, 1
        s.cur_line = s.btb_line = s.data_line = NO_LINE
        s.table = ctypes.cast(self.table, ctypes.POINTER(BlockT))
        s.mask = (1 << TABLE_BITS) - 1
        s.items = ctypes.cast(self.items, ctypes.POINTER(ItemT))
        s.cross = ctypes.cast(self.cross, ctypes.POINTER(ctypes.c_uint32))
        s.lits = ctypes.cast(self.lits, ctypes.POINTER(ctypes.c_uint32))
        s.uc = uc._uch.value
        s.reg_read = _fn_address(uclib.uc_reg_read)
        s.reg_write = _fn_address(uclib.uc_reg_write)
        s.emu_stop = _fn_address(uclib.uc_emu_stop)
        s.miss = self._miss
        for r, rid in enumerate(REG_IDS):
            s.regid[r] = rid
        s.cpsr_id, s.spsr_id = A.UC_ARM_REG_CPSR, A.UC_ARM_REG_SPSR
        self.state = s
        self.state_ptr = ctypes.pointer(s)
        self._probes: dict[int, tuple[ProbeT, object]] = {}
        self._hook(UC_HOOK_BLOCK, self.lib.cyc_block_hook, ctypes.addressof(s), 1, 0)

    def _hook(self, kind: int, fn: "ctypes._FuncPointer", user: int, begin: int, end: int) -> int:
        handle = _ucmod.uc_hook_h()
        err = uclib.uc_hook_add(self.uc._uch, ctypes.byref(handle), kind, _fn_address(fn), user, begin, end)
        if err:
            raise RuntimeError(f"uc_hook_add failed: error {err}")
        return handle.value

    # -- the table ------------------------------------------------------------------------------
    def insert(self, block: Block) -> None:
        """Store ``block`` (replacing an entry with the same address and size)."""
        if self.n_blocks >= (3 << TABLE_BITS) // 4:
            raise RuntimeError("the board's block table is full (more than 49152 distinct blocks)")
        starts, ends = block.start_items(), block.end_items()
        if self.n_items + len(starts) + len(ends) > ITEM_POOL or self.n_cross + len(block.line_cycles) > LINE_POOL \
                or self.n_lits + len(block.literal_lines) > LINE_POOL:
            raise RuntimeError("the board's cycle tables are full")
        first = self.n_items
        for it in starts + ends:
            slot = self.items[self.n_items]
            _fill_item(slot, it)
            self.n_items += 1
        cross_first = self.n_cross
        for c in block.line_cycles:
            self.cross[self.n_cross] = c
            self.n_cross += 1
        lit_first = self.n_lits
        for line in block.literal_lines:
            self.lits[self.n_lits] = line
            self.n_lits += 1
        slot_index = self._slot(block.address, block.size)
        e = self.table[slot_index]
        if e.size == 0:
            self.n_blocks += 1
        e.addr, e.size, e.cost, e.taken_extra, e.fall = block.address, block.size, block.cost, block.taken_extra, block.fall
        e.n_instr, e.flags, e.item_first, e.n_start, e.n_end = block.fetches, block.flags, first, len(starts), len(ends)
        e.first_line, e.last_line = block.first_line, block.last_line
        e.cross_first, e.n_cross = cross_first, len(block.line_cycles)
        e.lit_first, e.n_lit = lit_first, len(block.literal_lines)
        e.tail_cycles, e.total_cycles = block.tail_cycles, block.cost

    def _slot(self, address: int, size: int) -> int:
        mask = (1 << TABLE_BITS) - 1
        h = ((address >> 1) * 2654435761) & 0xFFFF_FFFF & mask
        while True:
            e = self.table[h]
            if e.size == 0 or (e.addr == address and e.size == size):
                return h
            h = (h + 1) & mask

    def add_probe(self, item: Item) -> None:
        """A code hook on ``item.address`` that evaluates it each time it runs."""
        if item.address in self._probes:
            return
        probe = ProbeT()
        probe.state = self.state_ptr
        _fill_item(probe.item, item)
        handle = self._hook(UC_HOOK_CODE, self.lib.cyc_probe_hook, ctypes.addressof(probe), item.address, item.address)
        self._probes[item.address] = (probe, handle)

    @property
    def probed(self) -> frozenset[int]:
        return frozenset(self._probes)

    # -- calls ----------------------------------------------------------------------------------
    def settle(self, next_pc: int) -> None:
        self.lib.cyc_settle(self.state_ptr, next_pc)

    def enter_exception(self, mode: int, mask: int, vector: int, lr_offset: int) -> None:
        self.lib.cyc_enter_exception(self.state_ptr, mode, mask, vector, lr_offset)


def _fill_item(slot: ItemT, item: Item) -> None:
    slot.cond = item.cond
    slot.mul_reg = NO_REG if item.mul_reg is None else item.mul_reg
    slot.mul_unsigned = int(item.mul_unsigned)
    slot.when = int(item.when)
    slot.false_delta = item.false_delta
