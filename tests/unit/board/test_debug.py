"""The debugger's view of the core (hil/board/debug.py): a breakpoint stops the core before its
instruction with the cycles of what ran, a resume steps over it, a step runs one instruction,
and a run with breakpoints ends at the cycle count and registers of the same run without."""

from __future__ import annotations

import signal

from hil.board.core import SRAM_BASE
from hil.board.debug import REGS, Debugger, Resume
from tests.unit.board.armasm import assemble, core_with

LOOP = """
_start:
    mov r0, #0
    mov r1, #0
again:
    add r0, r0, #1
mark:
    add r1, r1, r0
    cmp r0, #50
    bne again
done:
    b done
"""


def test_a_breakpoint_stops_before_its_instruction_and_costs_only_its_stops() -> None:
    program = assemble(LOOP)
    done, mark = program.symbols["done"], program.symbols["mark"]
    plain, _ = core_with(program)
    cycles_at_done = plain.run_to(done, 10_000)

    core, _ = core_with(program)
    dbg = Debugger(core)
    assert core.halted  # at reset, before the first instruction
    core.run_until(10_000)
    assert core.cycles == 0 and core.pc == program.symbols["_start"]
    dbg.add_breakpoint(mark)
    r0_at_stops = []
    for _ in range(100):
        dbg.resume(Resume.CONTINUE)
        core.run_until(10_000)
        if not core.halted:
            break
        assert core.pc == mark and dbg.stop_signal == signal.SIGTRAP
        reply = dbg.command(b"p0")[0]
        assert reply is not None
        r0_at_stops.append(int.from_bytes(bytes.fromhex(reply.decode()), "little"))
    assert r0_at_stops == list(range(1, 51))
    assert dbg.registers()[:2] == [plain.reg(r) for r in REGS[:2]]
    # Each stop re-fetches the rest of its block on the resume, as a chip leaving debug state
    # refills its pipeline: the add, the compare and the taken branch, 5 cycles a stop here.
    core2, _ = core_with(program)
    dbg2 = Debugger(core2)
    dbg2.add_breakpoint(mark)
    for _ in range(50):
        dbg2.resume(Resume.CONTINUE)
        core2.run_until(10_000)
    dbg2.remove_breakpoint(mark)
    dbg2.resume(Resume.CONTINUE)
    assert core2.run_to(done, 10_000) == cycles_at_done + 50 * 5


def test_a_breakpoint_that_never_stops_the_core_costs_nothing() -> None:
    program = assemble(LOOP)
    plain, _ = core_with(program)
    cycles_at_done = plain.run_to(program.symbols["done"], 10_000)
    core, _ = core_with(program)
    dbg = Debugger(core)
    dbg.add_breakpoint(program.symbols["done"] + 4)  # never reached
    dbg.resume(Resume.CONTINUE)
    assert core.run_to(program.symbols["done"], 10_000) == cycles_at_done and not core.halted


def test_a_step_runs_one_instruction() -> None:
    program = assemble(LOOP)
    core, _ = core_with(program)
    dbg = Debugger(core)
    start = program.symbols["_start"]
    for n in range(1, 4):
        assert dbg.command(b"s") == (None, Resume.STEP)
        dbg.resume(Resume.STEP)
        core.run_until(10_000)
        assert core.halted and core.pc == start + 4 * n
    dbg.resume(Resume.DETACH)
    core.run_until(10_000)
    assert not core.halted and core.pc == program.symbols["done"]


def test_memory_and_registers_through_the_protocol() -> None:
    program = assemble(LOOP)
    core, _ = core_with(program)
    dbg = Debugger(core)
    assert dbg.command(b"M40000400,4:78563412") == (b"OK", Resume.STAY)
    assert dbg.command(b"m40000400,4") == (b"78563412", Resume.STAY)
    assert dbg.command(b"m0,4") != (b"E01", Resume.STAY)  # flash reads
    assert dbg.command(b"M0,4:00000000") == (b"E01", Resume.STAY)  # flash is not written
    assert dbg.command(b"me0000000,4") == (b"E01", Resume.STAY)  # nor a peripheral read
    assert dbg.command(b"P3=efbeadde") == (b"OK", Resume.STAY)
    assert dbg.command(b"p3") == (b"efbeadde", Resume.STAY)
    g = dbg.command(b"g")[0]
    assert g is not None and len(g) == 17 * 8 and g[15 * 8 : 16 * 8] == program.symbols["_start"].to_bytes(4, "little").hex().encode()
    assert dbg.command(b"vMustReplyEmpty") == (b"", Resume.STAY)
    assert dbg.command(b"k") == (None, Resume.KILL)
    assert SRAM_BASE == 0x4000_0000
