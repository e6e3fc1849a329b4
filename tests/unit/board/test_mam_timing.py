"""Flash timing through the MAM (UM10139 chapter 4) as the board models it (docs/board.md, "The
MAM"), computed by hand from its rules:

- MAMCR 0 (off): every instruction fetch and every flash data read takes MAMTIM cycles; a
  transfer refills the pipeline with two more fetches.
- MAMCR 1 (partly on): a fetch from a new 128-bit line after a transfer waits MAMTIM - 1; a
  sequential one into the next line waits MAMTIM less the cycles spent in the previous line;
  every flash data read takes MAMTIM.
- MAMCR 2 (fully on): as 1, but a transfer into the current line or the branch trail line
  does not wait, and a data read from the data buffer's line does not either.
"""

from __future__ import annotations

import pytest

from emulators.lpc2148 import Lpc2148
from tests.unit.board.armasm import assemble, core_with, cycles_between

SEQUENTIAL = """
_start:
    b a
.balign 16
a:
""" + "    add r0, r0, #1\n" * 8 + "b:\n    b b\n"

LOOP = """
_start:
    mov r1, #4
    b loop
.balign 16
loop:
    subs r1, r1, #1
    bne loop
b:
    b b
"""

LITERALS = """
_start:
    b a
.balign 16
a:
    ldr r0, lit1
    ldr r1, lit2
    ldr r2, lit3
b:
    b b
.balign 16
lit1: .word 1
lit2: .word 2
.balign 16
lit3: .word 3
"""


def mam_bus(mode: int, mamtim: int) -> Lpc2148:
    bus = Lpc2148()
    bus.scb.mamcr, bus.scb.mamtim = mode, mamtim
    return bus


def measure(source: str, mode: int, mamtim: int) -> int:
    program = assemble(source, base=0)
    core, bus = core_with(program, mam_bus(mode, mamtim))
    core.mmio.memory_timing_changed()
    a = core.run_to(program.symbols["a" if "a:" in source else "loop"], 100_000)
    return core.run_to(program.symbols["b"], 100_000) - a


@pytest.mark.parametrize("mode, mamtim, expected", [
    (0, 3, 8 + 2 * (8 + 2)),   # 8 fetches and the 2 of the branch's refill, each 2 cycles over
    (0, 1, 8),                 # MAMTIM = 1: flash as fast as SRAM
    (1, 3, 8 + 2),             # the branch target's line; the second line was prefetched in 4 cycles
    (2, 3, 8 + 2),             # the target line is in no buffer
    (2, 6, 8 + 5 + (6 - 4)),   # a slow flash: the second line's prefetch is 2 cycles short
    (1, 6, 8 + 5 + (6 - 4)),
])
def test_straight_line_code_from_flash(mode: int, mamtim: int, expected: int) -> None:
    assert measure(SEQUENTIAL, mode, mamtim) == expected


@pytest.mark.parametrize("mode, expected", [
    # 4 passes of subs (1S) + bne (taken 2S+1N three times, then 1S)
    (0, 14 + 2 * 4 * (2 + 2)),  # each pass: 2 fetches + 2 refill fetches at 3 cycles
    (1, 14 + 4 * 2),            # every transfer opens the line again
    (2, 14 + 2),                # only the first entry: afterwards the loop's line is the current one
])
def test_a_loop_in_one_line(mode: int, expected: int) -> None:
    assert measure(LOOP, mode, 3) == expected


@pytest.mark.parametrize("mode, expected", [
    (0, 9 + 2 * (3 + 2 + 3)),  # 3 LDR (1S+1N+1I); 3 fetches, 2 refill, 3 flash data reads
    (1, 9 + 2 + 3 * 2),        # the target line; every flash data read
    (2, 9 + 2 + 2 * 2),        # lit2 is in the data buffer after lit1
])
def test_literal_pool_reads(mode: int, expected: int) -> None:
    assert measure(LITERALS, mode, 3) == expected


def test_sram_code_ignores_the_mam() -> None:
    program = assemble(SEQUENTIAL)
    assert cycles_between(program, "a", "b", mam_bus(0, 7)) == 8


def test_the_firmware_sets_the_mam_through_its_registers() -> None:
    """MAMCR = 0, MAMTIM = 3, MAMCR = 2 as UM10139 asks, written by the program itself."""
    source = """
_start:
    ldr r0, =0xE01FC000
    mov r1, #0
    str r1, [r0]         @ MAMCR = 0
    mov r1, #3
    str r1, [r0, #4]     @ MAMTIM = 3
    mov r1, #2
    str r1, [r0]         @ MAMCR = 2
""" + LOOP.split("_start:\n", 1)[1]
    program = assemble(source, base=0)
    core, bus = core_with(program)
    assert (bus.scb.mamcr, bus.scb.mamtim) == (0, 7)
    a = core.run_to(program.symbols["loop"], 100_000)
    assert (bus.scb.mamcr, bus.scb.mamtim) == (2, 3)
    assert core.run_to(program.symbols["b"], 100_000) - a == 14 + 2
