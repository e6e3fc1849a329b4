"""Exceptions on the emulated core: IRQ and FIQ through the VIC (the ARM exception entry the run
loop writes between slices), masking, SWI, the semihosting console, idle, and the faults the
board stops on."""

from __future__ import annotations

import pytest

from emulators.lpc2148 import UnmodelledRegister
from hil.board.errors import CoreFault
from tests.unit.board.armasm import assemble, core_with

COUNT = 0x4000_0100  # the ISR's counter in SRAM

VECTORS = """
_start:
    b reset
    b .                         @ undefined
    b swi_handler               @ SWI
    b .                         @ prefetch abort
    b .                         @ data abort
    nop
    ldr pc, [pc, #-0xFF0]       @ IRQ: the VIC's vector address
    b fiq_handler               @ FIQ
reset:
    ldr r0, =0xE01FC000         @ the MAM fully on, 3-cycle flash (UM10139 4.9)
    mov r1, #3
    str r1, [r0, #4]
    mov r1, #2
    str r1, [r0]
    msr cpsr_c, #0xD1           @ FIQ mode, I and F set
    ldr sp, =0x40007F80
    mov r8, #0x88               @ FIQ's own r8
    msr cpsr_c, #0xD2           @ IRQ mode
    ldr sp, =0x40007F00
    msr cpsr_c, #0xD3           @ supervisor
    ldr sp, =0x40007000
    mov r8, #0x11               @ supervisor's r8
    ldr r0, =0xFFFFF000         @ VIC slot 0: Timer0 (channel 4) -> isr
    ldr r1, =isr
    str r1, [r0, #0x100]
    mov r1, #0x24
    str r1, [r0, #0x200]
    ldr r1, =SELECT
    str r1, [r0, #0x0C]         @ VICIntSelect
    mov r1, #0x10
    str r1, [r0, #0x10]         @ VICIntEnable: channel 4
    ldr r0, =0xE0004000         @ Timer0: interrupt and reset on MR0 = 999 PCLK
    ldr r1, =999
    str r1, [r0, #0x18]
    mov r1, #3
    str r1, [r0, #0x14]
    mov r1, #1
    str r1, [r0, #0x04]
"""

HANDLERS = """
isr:
    sub lr, lr, #4
    stmfd sp!, {r0-r3, lr}
    ldr r0, =0xE0004000
    mov r1, #1
    str r1, [r0]                @ T0IR: MR0 done
    ldr r2, =0x40000100
    ldr r3, [r2]
    add r3, r3, #1
    str r3, [r2]
    ldr r0, =0xFFFFF000
    mov r1, #0
    str r1, [r0, #0x30]         @ VICVectAddr: the ISR's end
    ldmfd sp!, {r0-r3, pc}^
fiq_handler:
    ldr r9, =0xE0004000
    mov r10, #1
    str r10, [r9]
    ldr r9, =0x40000100
    ldr r10, [r9]
    add r10, r10, #1
    str r10, [r9]
    add r8, r8, #1              @ the banked r8
    subs pc, lr, #4
swi_handler:
    ldr r2, =0x40000104
    str lr, [r2]
    mrs r3, spsr
    str r3, [r2, #4]
    movs pc, lr
"""

MAIN_SPIN = """
    msr cpsr_c, #0x13           @ interrupts on
main:
    ldr r2, =0x40000100
    ldr r3, [r2]
    cmp r3, #5
    blt main
done:
    b done
"""


def program(main: str = MAIN_SPIN, select: int = 0) -> object:
    return assemble(f".equ SELECT, {select}\n" + VECTORS + main + HANDLERS, base=0)


def test_irq_taken_and_returned_from() -> None:
    events: list[tuple[str, int, int]] = []
    prog = program()
    core, bus = core_with(prog)
    core.on_interrupt = lambda kind, requested, entry: events.append((kind, requested, entry))
    core.run_to(prog.symbols["done"], 200_000)
    assert core.read_u32(COUNT) == 5
    assert [e[0] for e in events] == ["irq"] * 5
    assert core.interrupts["irq"] == 5
    # Timer0 at PCLK = CCLK/4 (VPBDIV reset): a match every 1000 PCLK = 4000 cycles
    requests = [e[1] for e in events]
    assert [b - a for a, b in zip(requests, requests[1:])] == [4000] * 4
    # taken at the first block boundary after the request: within one pass of main's loop
    main_pass = core.blocks[next(k for k in core.blocks if k[0] == prog.symbols["main"])].cost + 2 + 2
    assert all(0 <= entry - requested <= main_pass for _, requested, entry in events)
    assert core.cpsr & 0x1F == 0x13 and not core.cpsr & 0x80  # back in supervisor, IRQs on


def test_fiq_banks_r8_to_r14() -> None:
    prog = program(select=0x10)  # channel 4 as FIQ
    core, _ = core_with(prog)
    core.run_to(prog.symbols["done"], 200_000)
    assert core.interrupts == {"irq": 0, "fiq": 5, "swi": 0}
    assert core.read_u32(COUNT) == 5
    assert core.reg(74) == 0x11  # UC_ARM_REG_R8 in supervisor mode: untouched by the handler


def test_a_masked_irq_is_taken_when_unmasked() -> None:
    main = """
    mov r4, #0
    ldr r5, =3000
wait:                           @ IRQs masked (reset state) while the timer fires
    add r4, r4, #1
    cmp r4, r5
    blt wait
    msr cpsr_c, #0x13           @ unmask: the pending IRQ is taken right after this block
after:
    ldr r2, =0x40000100
    ldr r3, [r2]
    b done
done:
    b done
"""
    prog = program(main)
    events: list[tuple[str, int, int]] = []
    core, _ = core_with(prog)
    core.on_interrupt = lambda kind, requested, entry: events.append((kind, requested, entry))
    core.run_to(prog.symbols["done"], 200_000)
    assert core.interrupts["irq"] == 1
    assert core.reg(69) == 1  # r3 (UC_ARM_REG_R3): the ISR ran before the count was read
    assert events[0][2] - events[0][1] > 4000  # it waited for the unmasking


def test_idle_skips_to_the_interrupt() -> None:
    main = """
    msr cpsr_c, #0x13
main:
    ldr r2, =0x40000100
    ldr r3, [r2]
    cmp r3, #5
    bge done
    ldr r0, =0xE01FC0C0
    mov r1, #1
    str r1, [r0]                @ PCON.IDL
    b main
done:
    b done
"""
    prog = program(main)
    core, bus = core_with(prog)
    end = core.run_to(prog.symbols["done"], 200_000)
    assert core.read_u32(COUNT) == 5
    assert core.interrupts["irq"] == 5
    assert 0.9 * end < core.idle_cycles < end  # the core slept most of the time
    assert core.slices < 100


def test_a_branch_to_itself_is_skipped_not_emulated() -> None:
    prog = program()
    core, _ = core_with(prog)
    core.run_until(2_000_000)
    assert core.pc in (prog.symbols["done"], prog.symbols["isr"])
    interrupts = core.interrupts["irq"]
    assert interrupts > 400  # the timer goes on every 4000 cycles
    assert core.spin_cycles > 0.9 * 2_000_000
    assert core.counter.state.blocks < 20 * interrupts


def test_swi_enters_supervisor_with_the_return_address() -> None:
    main = """
    msr cpsr_c, #0x10           @ user mode
    swi 0x42
after:
    b done
done:
    b done
"""
    prog = program(main)
    core, _ = core_with(prog)
    core.run_to(prog.symbols["done"], 100_000)
    assert core.read_u32(COUNT + 4) == prog.symbols["after"]  # LR_svc
    assert core.read_u32(COUNT + 8) & 0x1F == 0x10  # SPSR_svc: user mode
    assert core.cpsr & 0x1F == 0x10  # movs pc, lr restored user mode
    assert core.interrupts["swi"] == 1


def test_semihosting_console_lines() -> None:
    source = """
_start:
    ldr sp, =0x40007000
    mov r0, #4                  @ SYS_WRITE0
    adr r1, hello
    swi 0x123456
    mov r0, #3                  @ SYS_WRITEC
    adr r1, newline
    swi 0x123456
    adr r0, thumb + 1
    bx r0
.thumb
.thumb_func
thumb:
    movs r0, #4
    adr r1, bye
    swi 0xAB
    b .
.balign 4
bye: .asciz "bye from thumb\\n"
.arm
.balign 4
hello: .asciz "hello, board"
newline: .byte 10
"""
    prog = assemble(source, base=0)
    core, _ = core_with(prog)
    core.run_until(10_000)
    assert core.semihost.lines == ["hello, board", "bye from thumb"]


@pytest.mark.parametrize("body, message", [
    ("    ldr r0, =0x20000000\n    ldr r1, [r0]\n", "unmapped memory at 0x20000000"),
    ("    mov r0, #0x100\n    str r0, [r0]\n", "write to flash at 0x00000100"),
    ("    clz r0, r1\n", "undefined instruction"),
])
def test_faults_name_the_address(body: str, message: str) -> None:
    source = "_start:\n" + (".arch armv5te\n" if "clz" in body else "") + body + "    b .\n"
    prog = assemble(source, base=0)
    core, _ = core_with(prog)
    with pytest.raises(CoreFault, match=message):
        core.run_until(10_000)


def test_an_unmodelled_peripheral_register_stops_the_run() -> None:
    prog = assemble("_start:\n    ldr r0, =0xE0034000\n    ldr r1, [r0]\n    b .\n", base=0)  # ADC0
    core, _ = core_with(prog)
    with pytest.raises(UnmodelledRegister, match="E0034000"):
        core.run_until(10_000)


def test_run_to_stops_inside_a_block_that_already_ran() -> None:
    prog = assemble("""
_start:
    mov r0, #0
loop:
    add r0, r0, #1
mid:
    add r1, r1, #1
    cmp r0, #100
    bne loop
done:
    b done
""")
    core, _ = core_with(prog)
    core.run_until(50)  # the loop's block, translated through `mid`, has run
    core.run_to(prog.symbols["mid"], 10_000)
    assert core.pc == prog.symbols["mid"]
