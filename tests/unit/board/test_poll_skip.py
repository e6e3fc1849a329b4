"""Polling loops are skipped, not emulated, and the skip changes no cycle count."""

from __future__ import annotations

import pytest

from emulators.lpc2148 import Lpc2148
from hil.board.blocks import decode_block
from hil.board.poll import is_poll_loop
from tests.unit.board.armasm import assemble, core_with

SPI_WAIT = """
_start:
    ldr r2, =0xE0020000         @ SPI0
    mov r1, #254
    str r1, [r2, #0x0C]         @ S0SPCCR: the slowest clock, 254 PCLK a bit
    mov r1, #0x20
    str r1, [r2]                @ master
    ldr r0, =0x40001000
    mov r5, #3
next:
    mov r1, #0x55
    str r1, [r2, #8]            @ S0SPDR: a transfer of 8 x 254 PCLK
wait:
    ldr r3, [r2, #4]            @ S0SPSR until SPIF
    tst r3, #0x80
    beq wait
    ldr r3, [r2, #8]
    str r3, [r0], #4
    subs r5, r5, #1
    bne next
done:
    b done
"""


def run(skip: bool) -> tuple[int, int, int]:
    program = assemble(SPI_WAIT, base=0)
    bus = Lpc2148()
    bus.attach_spi_slave(lambda mosi, transfer: 0xA0 | (mosi & 0xF))
    core, _ = core_with(program, bus)
    if not skip:
        core.mmio.is_poll_loop = lambda address, size: False
    done = core.run_to(program.symbols["done"], 10_000_000)
    assert core.read_memory(0x4000_1000, 12) == bytes([0xA5, 0, 0, 0] * 3)
    return done, core.poll_cycles, core.mmio.apb_accesses


def test_skipping_a_polling_loop_keeps_every_cycle() -> None:
    emulated = run(skip=False)
    skipped = run(skip=True)
    assert skipped[0] == emulated[0]  # the loop ends at the same cycle
    assert skipped[1] > 0.9 * 3 * 8 * 254 * 4  # three transfers of 8 bits x 254 PCLK (PCLK = CCLK/4)
    assert skipped[2] < emulated[2] / 10  # and the status register was read a few times only


@pytest.mark.parametrize("source, expected", [
    ("wait:\n    ldr r3, [r2, #4]\n    tst r3, #0x80\n    beq wait\n", True),
    ("wait:\n    ldr r3, [r2, #4]\n    and r3, r3, #0x80\n    cmp r3, #0\n    beq wait\n", True),
    ("wait:\n    ldr r3, [r2, #4]\n    subs r4, r4, #1\n    tst r3, #0x80\n    beq wait\n", False),  # a counter
    ("wait:\n    ldr r3, [r2], #4\n    tst r3, #0x80\n    beq wait\n", False),  # the address moves
    ("wait:\n    ldr r3, [r2, #4]\n    str r3, [r4]\n    tst r3, #0x80\n    beq wait\n", False),  # a store
    ("wait:\n    ldr r3, [r2, #4]\n    tst r3, #0x80\n    beq 1f\n1:\n", False),  # not back to its start
    ("wait:\n    tst r3, #0x80\n    ldr r3, [r2, #4]\n    beq wait\n", False),  # the flags of the last pass
])
def test_what_counts_as_a_polling_loop(source: str, expected: bool) -> None:
    program = assemble("_start:\n" + source + "    b .\n")
    start = program.symbols["wait"]
    core, _ = core_with(program)
    words = source.count("\n    ")
    code = core.read_memory(start, 4 * words)
    assert is_poll_loop(decode_block(code, start, False), code) is expected
