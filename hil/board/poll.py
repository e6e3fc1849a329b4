"""Polling loops the run loop can skip (docs/board.md, "Idle").

A firmware that waits on a status bit (``while (!(S0SPSR & SPIF));``, a flag an interrupt
sets) runs one basic block over and over; nothing it computes changes until a peripheral event
does. Emulating each pass costs a peripheral access in Python; the run loop instead skips the
passes up to the next event and counts their cycles as busy (the core was running them).

A block qualifies when it can only repeat itself with the same results:

- it ends with a conditional branch back to its own first instruction;
- it holds only loads (no writeback), data-processing instructions and that branch: no store,
  no multiply, no PSR access;
- it reads nothing it wrote on an earlier pass: every register (and the flags) it uses was
  either set earlier in the same pass or is never written by the block.

:class:`PollWatch` then confirms it at run time: three passes in a row, with nothing else run
between them, whose peripheral reads (address and value) are the same. RAM cannot change
while the loop runs alone (no DMA; interrupts come at events, where the skip ends).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from hil.board import isa
from hil.board.blocks import Block

PASSES = 3  #: identical passes before a skip


def _arm_reads(word: int) -> frozenset[int] | None:
    """Registers an allowed ARM instruction reads (None: not allowed in a polling loop)."""
    op = (word >> 25) & 7
    regs: set[int] = set()
    if op in (0, 1):
        if op == 0 and word & 0x90 == 0x90:  # multiplies, swaps, halfword transfers
            if word & 0x60 == 0 or word & 0x0120_0000 != 0x0100_0000 or not word >> 20 & 1:
                return None  # only LDRH/LDRSB/LDRSH with pre-index, no writeback
            regs.add((word >> 16) & 0xF)
            if not word >> 22 & 1:
                regs.add(word & 0xF)
            return frozenset(regs)
        if word & 0x0D90_0000 == 0x0100_0000:  # MRS, MSR and the rest of the compare space without S
            return None
        opcode = (word >> 21) & 0xF
        if opcode not in (13, 15):  # MOV, MVN have no first operand
            regs.add((word >> 16) & 0xF)
        if op == 0:
            regs.add(word & 0xF)
            if word & 0x10:
                regs.add((word >> 8) & 0xF)
        return frozenset(regs)
    if op in (2, 3):
        if not word >> 20 & 1 or word & 0x0120_0000 != 0x0100_0000:
            return None  # loads only, pre-indexed, no writeback
        regs.add((word >> 16) & 0xF)
        if op == 3:
            regs.add(word & 0xF)
        return frozenset(regs)
    return None


def _thumb_reads(half: int) -> frozenset[int] | None:
    top5 = half >> 11
    if top5 <= 0b00011:  # shifts, add/sub
        regs = {(half >> 3) & 7}
        if top5 == 0b00011 and not half >> 10 & 1:
            regs.add((half >> 6) & 7)
        return frozenset(regs)
    if top5 >> 2 == 0b001:  # immediate ops: MOV writes only
        return frozenset() if (half >> 11) & 3 == 0 else frozenset({(half >> 8) & 7})
    if top5 == 0b01000 and not half >> 10 & 1:  # ALU ops (not MUL)
        if (half >> 6) & 0xF == 13:
            return None
        return frozenset({half & 7, (half >> 3) & 7})
    if top5 == 0b01001:  # LDR pc-relative
        return frozenset()
    if top5 >> 1 == 0b0101:  # register offset: loads only
        load = (half >> 10) & 3 != 0 if half >> 9 & 1 else bool(half >> 11 & 1)
        return frozenset({(half >> 3) & 7, (half >> 6) & 7}) if load else None
    if top5 >> 2 == 0b011 or top5 >> 1 == 0b1000:  # immediate offset: loads only
        return frozenset({(half >> 3) & 7}) if half >> 11 & 1 else None
    return None


def is_poll_loop(block: Block, code: bytes) -> bool:
    """True if ``block`` (its bytes ``code``) can only repeat itself with the same results."""
    *body, (last_addr, last, _) = block.instructions
    if last.kind is not isa.Kind.BRANCH or last.cond == isa.ALWAYS or last.target != block.address:
        return False
    written = frozenset().union(*(t.writes for _, t, _ in body))
    flags_written = any(t.writes_flags for _, t, _ in body)
    defined: set[int] = set()
    flags_defined = False
    for address, t, _ in body:
        offset = address - block.address
        if block.thumb:
            reads = _thumb_reads(int.from_bytes(code[offset:offset + 2], "little"))
        else:
            reads = _arm_reads(int.from_bytes(code[offset:offset + 4], "little"))
        if reads is None or t.writes_pc or isa.PC in reads:
            return False
        if any(r in written and r not in defined for r in reads):
            return False
        if t.cond != isa.ALWAYS and flags_written and not flags_defined:
            return False
        defined |= t.writes
        flags_defined |= t.writes_flags
    return flags_defined or not flags_written


@dataclass
class PollWatch:
    """Peripheral reads, pass by pass, of the block that made them."""

    block: int = -1
    blocks: int = -1
    reads: list[tuple[int, int]] = field(default_factory=list)
    previous: list[tuple[int, int]] | None = None
    same: int = 0
    starts: list[int] = field(default_factory=list)

    def reset(self) -> None:
        self.block = -1
        self.previous = None
        self.same = 0
        self.reads = []
        self.starts = []

    def read(self, blocks: int, block: int, block_start: int, address: int, value: int) -> bool:
        """A read at ``address`` gave ``value`` in the block at ``block`` (entry number
        ``blocks``); True once the same reads came ``PASSES`` passes in a row."""
        if block == self.block and blocks == self.blocks:
            self.reads.append((address, value))
            return False
        if block == self.block and blocks == self.blocks + 1:
            self.same = self.same + 1 if self.reads == self.previous else 0
            self.previous = self.reads
        else:
            self.block, self.previous, self.same, self.starts = block, None, 0, []
        self.blocks = blocks
        self.reads = [(address, value)]
        self.starts = (self.starts + [block_start])[-2:]
        return self.same >= PASSES - 1

    @property
    def period(self) -> int:
        """Cycles of one pass (the last two passes' starts)."""
        return self.starts[1] - self.starts[0]
