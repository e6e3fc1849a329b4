"""A basic block's cycle facts, computed once when Unicorn first runs it (docs/board.md, "The
cycle model").

Unicorn reports each translated block as (address, size). :func:`decode_block` splits its bytes
into instructions with capstone, takes each one's timing from :mod:`hil.board.isa`, and returns:

- the static cost: every instruction executed, multipliers at m = 1; a final conditional
  transfer counted not taken, with what taking it adds;
- the data-dependent items: an instruction whose condition may fail (when failing changes its
  cost) or whose multiplier operand sets m. Each is evaluated where its inputs are known: at
  the block's start when no earlier instruction of the block may write them, at its end when
  no later one (nor itself) may, else by a probe on that instruction;
- the MAM facts: the 128-bit flash lines the block's fetches run through, the cycles spent in
  each, the lines of its PC-relative flash data reads (hil/board/mam.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import capstone  # type: ignore[import-untyped]

from hil.board import isa

FLASH_END = 0x0008_0000  #: 512 KB of on-chip flash from address 0
LINE_SHIFT = 4  #: the MAM's 128-bit lines


class When(IntEnum):
    """Where a data-dependent item is evaluated (cyclehook.c's AT_*)."""

    START = 0
    END = 1
    PROBE = 2


class BlockFlag(IntEnum):
    XFER = 1
    COND_XFER = 2
    SELF_LOOP = 4
    FLASH = 8


@dataclass(frozen=True)
class Item:
    """A data-dependent cost at ``address``: ``false_delta`` cycles when condition ``cond``
    fails; m - 1 internal cycles from register ``mul_reg``'s value."""

    address: int
    cond: int
    mul_reg: int | None
    mul_unsigned: bool
    false_delta: int
    when: When


@dataclass(frozen=True)
class Block:
    """One translated block's facts (the C side's block_t, items and pools)."""

    address: int
    size: int
    thumb: bool
    instructions: tuple[tuple[int, isa.Timing, str], ...]  #: (address, timing, disassembly)
    cost: int
    taken_extra: int
    flags: int
    items: tuple[Item, ...]
    fetches: int
    first_line: int
    last_line: int
    line_cycles: tuple[int, ...]  #: cycles spent in each line the block leaves (in order)
    tail_cycles: int
    literal_lines: tuple[int, ...]

    @property
    def fall(self) -> int:
        return self.address + self.size

    def start_items(self) -> list[Item]:
        return [it for it in self.items if it.when is When.START]

    def end_items(self) -> list[Item]:
        return [it for it in self.items if it.when is When.END]

    def probes(self) -> list[Item]:
        return [it for it in self.items if it.when is When.PROBE]

    def listing(self) -> str:
        return "\n".join(f"  {a:08x}  {t.cycles:2d}  {text}" for a, t, text in self.instructions)


class DecodeError(Exception):
    """A block that cannot be a real one (an undefined instruction, a transfer not at the end)."""


_ARM = capstone.Cs(capstone.CS_ARCH_ARM, capstone.CS_MODE_ARM)
_THUMB = capstone.Cs(capstone.CS_ARCH_ARM, capstone.CS_MODE_THUMB)


def split(code: bytes, address: int, thumb: bool) -> list[tuple[int, int, str]]:
    """(address, size, text) of each instruction in ``code``; capstone's ARMv7 decoder reads
    every ARMv4T encoding; what it rejects is listed as a 4- or 2-byte ``.word``/``.short``."""
    md = _THUMB if thumb else _ARM
    out: list[tuple[int, int, str]] = []
    offset = 0
    while offset < len(code):
        got = next(md.disasm_lite(code[offset:], address + offset, 1), None)
        if got is None:
            width = 2 if thumb else 4
            value = int.from_bytes(code[offset:offset + width], "little")
            out.append((address + offset, width, f".{'short' if thumb else 'word'} {value:#x}"))
            offset += width
            continue
        a, size, mnemonic, op_str = got
        out.append((a, size, f"{mnemonic} {op_str}".strip()))
        offset += size
    return out


def _timing(code: bytes, offset: int, address: int, size: int, thumb: bool) -> isa.Timing:
    if not thumb:
        return isa.arm(int.from_bytes(code[offset:offset + 4], "little"), address)
    half = int.from_bytes(code[offset:offset + 2], "little")
    following = int.from_bytes(code[offset + 2:offset + 4], "little") if size == 4 else None
    return isa.thumb(half, address, following)


def decode_block(code: bytes, address: int, thumb: bool, probed: frozenset[int] = frozenset()) -> Block:
    """The facts of the block of ``code`` at ``address``; ``probed``: instruction addresses that
    already have a probe (an item there is always evaluated by it)."""
    insns = []
    for a, size, text in split(code, address, thumb):
        t = _timing(code, a - address, a, size, thumb)
        if t.kind is isa.Kind.UNDEFINED:
            raise DecodeError(f"undefined instruction at {a:#010x} ({text}) on an ARM7TDMI")
        if t.size != size:
            raise DecodeError(f"instruction at {a:#010x} ({text}): capstone took {size} bytes, the core {t.size}")
        insns.append((a, t, text))
    for a, t, text in insns[:-1]:
        if t.writes_pc:
            raise DecodeError(f"a transfer inside a translated block at {a:#010x} ({text})")
    last_addr, last, _ = insns[-1]
    flags = BlockFlag.FLASH if address < FLASH_END else 0
    taken_extra = 0
    costs = [t.cycles for _, t, _ in insns]
    if last.writes_pc:
        if last.cond == isa.ALWAYS:
            flags |= BlockFlag.XFER
            if last.target == last_addr and len(insns) == 1 and last.kind is isa.Kind.BRANCH and isa.LR not in last.writes:
                flags |= BlockFlag.SELF_LOOP
        else:
            flags |= BlockFlag.COND_XFER
            taken_extra = last.cycles - 1
            costs[-1] = 1
    items = _items(insns, probed)
    lines, tail, first_line, last_line = _lines(insns, costs)
    literals = tuple(t.literal >> LINE_SHIFT for _, t, _ in insns
                     if t.literal is not None and 0 <= t.literal < FLASH_END)
    return Block(address, sum(t.size for _, t, _ in insns), thumb, tuple(insns), sum(costs), taken_extra, int(flags),
                 tuple(items), sum(t.fetches for _, t, _ in insns), first_line, last_line, tuple(lines), tail,
                 literals)


def _items(insns: list[tuple[int, isa.Timing, str]], probed: frozenset[int]) -> list[Item]:
    items = []
    last = len(insns) - 1
    for j, (a, t, _) in enumerate(insns):
        conditional = t.cond != isa.ALWAYS and not (j == last and t.writes_pc)
        false_delta = 1 - t.cycles if conditional else 0
        if false_delta == 0 and t.mul_reg is None:
            continue  # a condition-false data operation costs 1S like an executed one
        cond = t.cond if false_delta else isa.ALWAYS
        items.append(Item(a, cond, t.mul_reg, t.mul_unsigned, false_delta, _where(insns, j, cond, t.mul_reg, probed)))
    return items


def _where(insns: list[tuple[int, isa.Timing, str]], j: int, cond: int, reg: int | None,
           probed: frozenset[int]) -> When:
    if insns[j][0] in probed:
        return When.PROBE

    def clean(part: list[tuple[int, isa.Timing, str]]) -> bool:
        return all(not (cond != isa.ALWAYS and t.writes_flags) and not (reg is not None and reg in t.writes)
                   for _, t, _ in part)

    if clean(insns[:j]):
        return When.START
    if clean(insns[j:]):
        return When.END
    return When.PROBE


def _lines(insns: list[tuple[int, isa.Timing, str]], costs: list[int]) -> tuple[list[int], int, int, int]:
    """Cycles spent in each 128-bit line the block leaves, the cycles in its last line, its
    first and last lines. An instruction's cycles count in the line of its (first) fetch."""
    first_line = insns[0][0] >> LINE_SHIFT
    line, spent, left = first_line, 0, []
    for (a, t, _), cost in zip(insns, costs):
        here = a >> LINE_SHIFT
        if here != line:
            left.append(spent)
            line, spent = here, 0
        spent += cost
        end_line = (a + t.size - 1) >> LINE_SHIFT  # a Thumb BL pair across a line boundary
        if end_line != line:
            left.append(spent)
            line, spent = end_line, 0
    return left, spent, first_line, line
