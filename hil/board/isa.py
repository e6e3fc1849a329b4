"""ARM7TDMI instruction timings (ARM DDI 0210C, chapter 6 "Instruction Cycle Timings", the
instruction speed summary), per instruction word of the ARMv4T ARM and Thumb instruction sets.

S, N and I are the sequential, non-sequential and internal cycles of the TRM. With the
LPC2148's single-cycle SRAM each is one CCLK cycle; the flash's wait states come on top
(hil/board/mam.py). The costs here are for an instruction that executes (condition passed),
with multipliers at m = 1 and a PC write counted with its pipeline refill:

| class | cycles |
|---|---|
| data processing | 1S; +1I with a register-specified shift; +1S+1N when it writes the PC |
| MRS, MSR | 1S |
| LDR, LDRB, LDRH, LDRSB, LDRSH | 1S+1N+1I; +1S+1N when it loads the PC |
| STR, STRB, STRH | 2N |
| LDM (n registers) | nS+1N+1I; +1S+1N when the PC is loaded |
| STM (n registers) | (n-1)S+2N |
| SWP | 1S+2N+1I |
| B, BL, BX, SWI | 2S+1N |
| MUL | 1S+mI; MLA and MULL 1S+(m+1)I; MLAL 1S+(m+2)I |
| condition false | 1S |

m (the multiplier array cycles) is 1 to 4 by the multiplier operand's significant bytes (Rs; for
Thumb MUL, Rd): MUL, MLA, SMULL and SMLAL end early when the top 24/16/8 bits are all zeros or
all ones, UMULL and UMLAL only when they are all zeros (ARM DDI 0029E, 4.7.3 and 4.8.3). A
Thumb BL is two instructions on this core (prefix 1S, suffix 2S+1N).

The classes come from the raw encodings (ARM DDI 0029E, figures 4-1 and 5-1), which fix every
bit the timing depends on (a register-specified shift, a PC destination, the register list);
capstone (hil/board/blocks.py) splits a block into instructions and names them for listings.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

PC = 15
LR = 14
SP = 13
ALWAYS = 14  #: the AL condition
ALL_REGS = frozenset(range(16))
#: what an instruction that changes mode may write: the banked registers (FIQ banks r8-r14)
BANKED = frozenset(range(8, 15))


class Kind(Enum):
    DATA = "data processing"
    PSR = "MRS/MSR"
    LOAD = "load"
    STORE = "store"
    LOAD_MULTIPLE = "load multiple"
    STORE_MULTIPLE = "store multiple"
    SWAP = "swap"
    BRANCH = "branch"
    SWI = "software interrupt"
    MULTIPLY = "multiply"
    UNDEFINED = "undefined"


@dataclass(frozen=True)
class Timing:
    """One instruction's timing facts.

    ``s``, ``n``, ``i``: its cycles when it executes (m = 1, a PC write with its refill);
    ``cond``: its condition (``ALWAYS``, or a Thumb conditional branch's); ``writes_pc``: it may
    transfer control (it ends a basic block); ``mul_reg``/``mul_unsigned``: the multiplier
    operand whose size adds m - 1 internal cycles; ``writes``, ``writes_flags``: what it may
    change (conservative), for placing the data-dependent evaluations; ``literal``: the address
    of a PC-relative data read (a literal pool in flash); ``target``: a direct branch's target;
    ``fetches``: instructions the core fetches for it (2 for a Thumb BL pair)."""

    kind: Kind
    size: int
    s: int
    n: int
    i: int
    cond: int = ALWAYS
    writes_pc: bool = False
    mul_reg: int | None = None
    mul_unsigned: bool = False
    writes: frozenset[int] = frozenset()
    writes_flags: bool = False
    literal: int | None = None
    target: int | None = None
    fetches: int = 1

    @property
    def cycles(self) -> int:
        return self.s + self.n + self.i


def _bits(word: int, hi: int, lo: int) -> int:
    return (word >> lo) & ((1 << (hi - lo + 1)) - 1)


def _sext(value: int, bits: int) -> int:
    return value - (1 << bits) if value >> (bits - 1) & 1 else value


def _regs(mask: int) -> frozenset[int]:
    return frozenset(r for r in range(16) if mask >> r & 1)


def _undefined(size: int) -> Timing:
    return Timing(Kind.UNDEFINED, size, 0, 0, 0)


# -- ARM state ---------------------------------------------------------------------------------

def arm(word: int, address: int) -> Timing:
    """The timing of the ARM instruction ``word`` at ``address``."""
    cond = word >> 28
    if cond == 0xF:  # NV: unpredictable on ARMv4T
        return _undefined(4)
    if word & 0x0FFF_FFF0 == 0x012F_FF10:  # BX
        return Timing(Kind.BRANCH, 4, 2, 1, 0, cond, writes_pc=True, writes=frozenset({PC}))
    op = _bits(word, 27, 25)
    if op in (0, 1):
        return _arm_data_space(word, address, cond, op)
    if op in (2, 3):
        if op == 3 and word & 0x10:
            return _undefined(4)
        return _arm_single_transfer(word, address, cond, op)
    if op == 4:
        return _arm_block_transfer(word, cond)
    if op == 5:
        link = bool(word >> 24 & 1)
        target = (address + 8 + 4 * _sext(word & 0xFF_FFFF, 24)) & 0xFFFF_FFFF
        writes = frozenset({PC, LR}) if link else frozenset({PC})
        return Timing(Kind.BRANCH, 4, 2, 1, 0, cond, writes_pc=True, writes=writes, target=target)
    if op == 7 and word >> 24 & 1:
        return Timing(Kind.SWI, 4, 2, 1, 0, cond, writes_pc=True, writes=ALL_REGS, writes_flags=True)
    return _undefined(4)  # coprocessor instructions: the LPC2148 has no coprocessor


def _arm_data_space(word: int, address: int, cond: int, op: int) -> Timing:
    if op == 0 and word & 0x90 == 0x90:
        return _arm_extension_space(word, address, cond)
    if word & 0x0FBF_0FFF == 0x010F_0000:  # MRS
        return Timing(Kind.PSR, 4, 1, 0, 0, cond, writes=frozenset({_bits(word, 15, 12)}))
    if word & 0x0DB0_F000 == 0x0120_F000:  # MSR
        spsr = bool(word >> 22 & 1)
        flags = not spsr and bool(word >> 19 & 1)
        control = not spsr and bool(word >> 16 & 1)  # a mode change banks r8-r14
        return Timing(Kind.PSR, 4, 1, 0, 0, cond, writes=BANKED if control else frozenset(),
                      writes_flags=flags or control)
    opcode = _bits(word, 24, 21)
    set_flags = bool(word >> 20 & 1)
    rd = _bits(word, 15, 12)
    compare = 8 <= opcode <= 11
    if compare and not set_flags:
        return _undefined(4)
    reg_shift = op == 0 and bool(word & 0x10)
    i = 1 if reg_shift else 0
    if rd == PC and not compare:
        # MOVS pc, lr / SUBS pc, lr, #4: an exception return restores the CPSR (mode, flags)
        writes = ALL_REGS if set_flags else frozenset({PC})
        return Timing(Kind.DATA, 4, 2, 1, i, cond, writes_pc=True, writes=writes, writes_flags=set_flags)
    return Timing(Kind.DATA, 4, 1, 0, i, cond, writes=frozenset() if compare else frozenset({rd}),
                  writes_flags=set_flags)


def _arm_extension_space(word: int, address: int, cond: int) -> Timing:
    """Multiplies, SWP and the halfword/signed transfers (bits 7 and 4 set)."""
    set_flags = bool(word >> 20 & 1)
    rs = _bits(word, 11, 8)
    if word & 0x0FC0_00F0 == 0x0000_0090:  # MUL, MLA
        accumulate = word >> 21 & 1
        return Timing(Kind.MULTIPLY, 4, 1, 0, 1 + accumulate, cond, mul_reg=rs,
                      writes=frozenset({_bits(word, 19, 16)}), writes_flags=set_flags)
    if word & 0x0F80_00F0 == 0x0080_0090:  # UMULL, UMLAL, SMULL, SMLAL
        accumulate = word >> 21 & 1
        signed = bool(word >> 22 & 1)
        return Timing(Kind.MULTIPLY, 4, 1, 0, 2 + accumulate, cond, mul_reg=rs, mul_unsigned=not signed,
                      writes=frozenset({_bits(word, 19, 16), _bits(word, 15, 12)}), writes_flags=set_flags)
    if word & 0x0FB0_0FF0 == 0x0100_0090:  # SWP, SWPB
        return Timing(Kind.SWAP, 4, 1, 2, 1, cond, writes=frozenset({_bits(word, 15, 12)}))
    if word & 0x60 == 0:
        return _undefined(4)
    load = bool(word >> 20 & 1)
    pre, up, writeback = bool(word >> 24 & 1), bool(word >> 23 & 1), bool(word >> 21 & 1)
    rn, rd = _bits(word, 19, 16), _bits(word, 15, 12)
    literal = None
    if rn == PC and word >> 22 & 1 and pre and not writeback:
        offset = (_bits(word, 11, 8) << 4) | (word & 0xF)
        literal = address + 8 + (offset if up else -offset)
    return _transfer(load, rd, rn, pre, writeback, cond, literal)


def _arm_single_transfer(word: int, address: int, cond: int, op: int) -> Timing:
    load = bool(word >> 20 & 1)
    pre, up, writeback = bool(word >> 24 & 1), bool(word >> 23 & 1), bool(word >> 21 & 1)
    rn, rd = _bits(word, 19, 16), _bits(word, 15, 12)
    literal = None
    if op == 2 and rn == PC and pre and not writeback:
        offset = word & 0xFFF
        literal = address + 8 + (offset if up else -offset)
    return _transfer(load, rd, rn, pre, writeback, cond, literal)


def _transfer(load: bool, rd: int, rn: int, pre: bool, writeback: bool, cond: int, literal: int | None,
              size: int = 4) -> Timing:
    based = frozenset({rn}) if writeback or not pre else frozenset()
    if not load:
        return Timing(Kind.STORE, size, 0, 2, 0, cond, writes=based)
    if rd == PC:
        return Timing(Kind.LOAD, size, 2, 2, 1, cond, writes_pc=True, writes=based | {PC}, literal=literal)
    return Timing(Kind.LOAD, size, 1, 1, 1, cond, writes=based | {rd}, literal=literal)


def _arm_block_transfer(word: int, cond: int) -> Timing:
    load = bool(word >> 20 & 1)
    regs = _regs(word & 0xFFFF)
    n = len(regs) or 16  # an empty list is unpredictable; the bus sees 16 transfers
    rn = _bits(word, 19, 16)
    base = frozenset({rn}) if word >> 21 & 1 else frozenset()
    user_bank = bool(word >> 22 & 1)
    if not load:
        return Timing(Kind.STORE_MULTIPLE, 4, n - 1, 2, 0, cond, writes=base)
    return _load_multiple(4, regs, n, base, cond, restores_cpsr=user_bank and PC in regs)


def _load_multiple(size: int, regs: frozenset[int], n: int, base: frozenset[int], cond: int,
                   restores_cpsr: bool = False) -> Timing:
    if PC in regs:
        writes = ALL_REGS if restores_cpsr else regs | base
        return Timing(Kind.LOAD_MULTIPLE, size, n + 1, 2, 1, cond, writes_pc=True, writes=writes,
                      writes_flags=restores_cpsr)
    return Timing(Kind.LOAD_MULTIPLE, size, n, 1, 1, cond, writes=regs | base)


# -- Thumb state -------------------------------------------------------------------------------

def thumb(half: int, address: int, next_half: int | None = None) -> Timing:
    """The timing of the Thumb instruction ``half`` at ``address``; a BL prefix followed by its
    suffix (``next_half``) is one 4-byte pair, as capstone and Unicorn take it."""
    top5 = half >> 11
    if top5 <= 0b00011 or top5 >> 2 == 0b001:  # formats 1-3: shifts, add/sub, immediates
        rd = _bits(half, 10, 8) if top5 >> 2 == 0b001 else half & 7
        compare = top5 >> 2 == 0b001 and _bits(half, 12, 11) == 1
        return Timing(Kind.DATA, 2, 1, 0, 0, writes=frozenset() if compare else frozenset({rd}), writes_flags=True)
    if top5 == 0b01000:
        return _thumb_alu_hi(half)
    if top5 == 0b01001:  # LDR rd, [pc, #imm]
        literal = ((address + 4) & ~3) + 4 * (half & 0xFF)
        return _transfer(True, _bits(half, 10, 8), PC, True, False, ALWAYS, literal, size=2)
    if top5 >> 1 == 0b0101:  # formats 7/8: register offset
        if half >> 9 & 1:  # format 8: STRH (H=0, S=0) is the only store
            load = _bits(half, 11, 10) != 0
        else:
            load = bool(half >> 11 & 1)
        return _transfer(load, half & 7, 0, True, False, ALWAYS, None, size=2)
    if top5 >> 2 == 0b011 or top5 >> 1 == 0b1000:  # formats 9/10: immediate offset
        return _transfer(bool(half >> 11 & 1), half & 7, 0, True, False, ALWAYS, None, size=2)
    if top5 >> 1 == 0b1001:  # format 11: SP-relative
        return _transfer(bool(half >> 11 & 1), _bits(half, 10, 8), SP, True, False, ALWAYS, None, size=2)
    if top5 >> 1 == 0b1010:  # format 12: ADD rd, pc/sp, #imm
        return Timing(Kind.DATA, 2, 1, 0, 0, writes=frozenset({_bits(half, 10, 8)}))
    if half & 0xFF00 == 0xB000:  # format 13: ADD sp, #imm
        return Timing(Kind.DATA, 2, 1, 0, 0, writes=frozenset({SP}))
    if half & 0xF600 == 0xB400:  # format 14: PUSH/POP
        extra = half >> 8 & 1
        if half >> 11 & 1:
            regs = _regs(half & 0xFF) | ({PC} if extra else set())
            return _load_multiple(2, regs, len(regs), frozenset({SP}), ALWAYS)
        n = bin(half & 0xFF).count("1") + extra
        return Timing(Kind.STORE_MULTIPLE, 2, max(n - 1, 0), 2, 0, writes=frozenset({SP}))
    if top5 >> 1 == 0b1100:  # format 15: LDMIA/STMIA rb!
        rb = _bits(half, 10, 8)
        regs = _regs(half & 0xFF)
        n = len(regs) or 16
        if half >> 11 & 1:
            return _load_multiple(2, regs, n, frozenset({rb}), ALWAYS)
        return Timing(Kind.STORE_MULTIPLE, 2, n - 1, 2, 0, writes=frozenset({rb}))
    if top5 >> 1 == 0b1101:  # format 16/17: conditional branch, SWI
        cond = _bits(half, 11, 8)
        if cond == 0xF:
            return Timing(Kind.SWI, 2, 2, 1, 0, writes_pc=True, writes=ALL_REGS, writes_flags=True)
        if cond == 0xE:
            return _undefined(2)
        target = (address + 4 + 2 * _sext(half & 0xFF, 8)) & 0xFFFF_FFFF
        return Timing(Kind.BRANCH, 2, 2, 1, 0, cond, writes_pc=True, writes=frozenset({PC}), target=target)
    if top5 == 0b11100:  # format 18: B
        target = (address + 4 + 2 * _sext(half & 0x7FF, 11)) & 0xFFFF_FFFF
        return Timing(Kind.BRANCH, 2, 2, 1, 0, writes_pc=True, writes=frozenset({PC}), target=target)
    if top5 == 0b11110:  # format 19: BL prefix (LR = PC + offset high)
        if next_half is not None and next_half >> 11 == 0b11111:
            offset = (_sext(half & 0x7FF, 11) << 12) | ((next_half & 0x7FF) << 1)
            target = (address + 4 + offset) & 0xFFFF_FFFF
            return Timing(Kind.BRANCH, 4, 3, 1, 0, writes_pc=True, writes=frozenset({PC, LR}), target=target,
                          fetches=2)
        return Timing(Kind.DATA, 2, 1, 0, 0, writes=frozenset({LR}))
    if top5 == 0b11111:  # BL suffix alone
        return Timing(Kind.BRANCH, 2, 2, 1, 0, writes_pc=True, writes=frozenset({PC, LR}))
    return _undefined(2)


def _thumb_alu_hi(half: int) -> Timing:
    if not half >> 10 & 1:  # format 4: ALU operations
        op = _bits(half, 9, 6)
        rd = half & 7
        writes = frozenset() if op in (8, 10, 11) else frozenset({rd})
        if op == 13:  # MUL rd, rs: MULS rd, rs, rd on this core, the multiplier operand is rd
            return Timing(Kind.MULTIPLY, 2, 1, 0, 1, mul_reg=rd, writes=writes, writes_flags=True)
        i = 1 if op in (2, 3, 4, 7) else 0  # shifts by a register
        return Timing(Kind.DATA, 2, 1, 0, i, writes=writes, writes_flags=True)
    op = _bits(half, 9, 8)  # format 5: hi register operations, BX
    rd = (half >> 4 & 8) | (half & 7)
    if op == 3:
        return Timing(Kind.BRANCH, 2, 2, 1, 0, writes_pc=True, writes=frozenset({PC}))
    if op == 1:
        return Timing(Kind.DATA, 2, 1, 0, 0, writes_flags=True)
    if rd == PC:
        return Timing(Kind.DATA, 2, 2, 1, 0, writes_pc=True, writes=frozenset({PC}))
    return Timing(Kind.DATA, 2, 1, 0, 0, writes=frozenset({rd}))
