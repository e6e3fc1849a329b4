"""The cycle model against the ARM7TDMI TRM (ARM DDI 0210C, "Instruction speed summary"; the
multiplier rules of ARM DDI 0029E 4.7.3 / 4.8.3), instruction class by class.

Each case is a short sequence in SRAM (single-cycle: S = N = I = 1 CCLK) between two labels;
the expected count is written as the TRM's S/N/I sum. The sequences are assembled with
arm-none-eabi-as (the firmware's toolchain).
"""

from __future__ import annotations

import pytest

from tests.unit.board.armasm import assemble, core_with, cycles_between

DATA = """
    mov r4, #0x40000000
    add r4, r4, #0x1000     @ a data area in SRAM
"""


def between(body: str, setup: str = "") -> int:
    program = assemble(f"_start:\n{DATA}{setup}\na:\n{body}\nb:\n    b b\n")
    return cycles_between(program, "a", "b")


def S(n: int = 1) -> int:  # noqa: N802 - the TRM's names
    return n


N = I = S


def test_data_processing_is_1s() -> None:
    assert between("    add r0, r0, #1\n" * 10) == 10 * S()


def test_register_specified_shift_adds_1i() -> None:
    body = "    add r0, r0, r1, lsl r2\n    mov r3, r1, ror r2\n    add r0, r0, r1, lsl #3\n"
    assert between(body, "    mov r2, #3\n") == 2 * (S() + I()) + S()


def test_ldr_is_1s_1n_1i_and_str_2n() -> None:
    body = "    ldr r1, [r4]\n    ldrb r2, [r4, #1]\n    ldrh r3, [r4, #2]\n    ldrsb r5, [r4, #3]\n" \
           "    str r1, [r4, #4]\n    strb r1, [r4, #8]\n    strh r1, [r4, #10]\n"
    assert between(body) == 4 * (S() + N() + I()) + 3 * (2 * N())


@pytest.mark.parametrize("n", [1, 2, 4, 8, 13])
def test_ldm_is_ns_1n_1i(n: int) -> None:
    regs = ",".join(f"r{r}" for r in range(n)) if n < 4 else f"r0-r{n - 1}" if n <= 4 else \
        "r0-r3," + ",".join(f"r{r}" for r in range(5, n + 1))
    assert between(f"    ldmia r4, {{{regs}}}\n") == S(n) + N() + I()


@pytest.mark.parametrize("n", [1, 2, 4, 8, 13])
def test_stm_is_n_minus_1_s_2n(n: int) -> None:
    regs = ",".join(f"r{r}" for r in range(n)) if n < 4 else f"r0-r{n - 1}" if n <= 4 else \
        "r0-r3," + ",".join(f"r{r}" for r in range(5, n + 1))
    assert between(f"    stmia r4, {{{regs}}}\n") == S(n - 1) + 2 * N()


def test_push_pop_with_the_pc_is_an_ldm_that_loads_the_pc() -> None:
    # bl f: 2S+1N; f: push {r4, lr}: (2-1)S+2N; pop {r4, pc}: 2S+1N+1I + 1S+1N; b b: 2S+1N
    body = "    bl f\n    b b\nf:\n    push {r4, lr}\n    pop {r4, pc}\n"
    assert between(body, "    mov sp, r4\n") == (2 * S() + N()) + (S() + 2 * N()) + (S(2) + N() + I() + S() + N()) \
        + (2 * S() + N())


def test_b_and_bl_are_2s_1n() -> None:
    body = "    b 1f\n1:\n    bl 2f\n2:\n    b 3f\n    nop\n3:\n"
    assert between(body) == 3 * (2 * S() + N())


def test_bx_to_thumb_and_back() -> None:
    # adr, mov: 1S each; bx r1: 2S+1N; Thumb adds: 1S; bx lr: 2S+1N; back at b b: 2S+1N
    body = "    adr r1, t + 1\n    mov lr, pc\n    bx r1\n    b b\n.thumb\n.thumb_func\nt:\n    adds r0, #7\n" \
           "    bx lr\n.arm\n"
    assert between(body) == S() + S() + (2 * S() + N()) + S() + (2 * S() + N()) + (2 * S() + N())  # then b b


@pytest.mark.parametrize("multiplier, m", [
    (0x12, 1), (0x1234, 2), (0x12_3456, 3), (0x1234_5678, 4),
    (0xFFFF_FFFE, 1), (0xFFFF_8000, 2), (0xFF80_0000, 3), (0x8000_0000, 4), (0, 1)])
def test_mul_terminates_early_by_the_multiplier_operand(multiplier: int, m: int) -> None:
    setup = f"    ldr r2, ={multiplier:#x}\n    mov r1, #3\n"
    assert between("    mul r0, r1, r2\n", setup) == S() + I(m)
    assert between("    mla r0, r1, r2, r3\n", setup) == S() + I(m + 1)


@pytest.mark.parametrize("multiplier, m_signed, m_unsigned", [
    (0x12, 1, 1), (0x1234, 2, 2), (0x12_3456, 3, 3), (0x1234_5678, 4, 4), (0xFFFF_FFFE, 1, 4),
    (0xFFFF_8000, 2, 4), (0xFF80_0000, 3, 4)])
def test_long_multiplies_unsigned_end_early_only_on_zeros(multiplier: int, m_signed: int, m_unsigned: int) -> None:
    setup = f"    ldr r2, ={multiplier:#x}\n    mov r1, #3\n"
    assert between("    umull r0, r3, r1, r2\n", setup) == S() + I(m_unsigned + 1)
    assert between("    smull r0, r3, r1, r2\n", setup) == S() + I(m_signed + 1)
    assert between("    umlal r0, r3, r1, r2\n", setup) == S() + I(m_unsigned + 2)
    assert between("    smlal r0, r3, r1, r2\n", setup) == S() + I(m_signed + 2)


@pytest.mark.parametrize("where", ["start", "end", "probe"])
@pytest.mark.parametrize("multiplier, m", [(0x7F, 1), (0x7FFF, 2), (0x7F_FFFF, 3), (0x7FFF_FFFF, 4)])
def test_each_way_of_reading_the_multiplier_gives_the_same_count(where: str, multiplier: int, m: int) -> None:
    """The operand read at the block's start (set by an earlier block), at its end (not written
    after the MUL) or by a probe (written just before and overwritten by the MUL itself)."""
    store = f"    ldr r5, ={multiplier:#x}\n    str r5, [r4, #16]\n    mov r1, #3\n"
    load = "    ldr r2, [r4, #16]\n"
    if where == "start":
        body, setup = "    mul r0, r1, r2\n", store + load
    elif where == "end":
        body, setup = load + "    mul r0, r1, r2\n", store
    else:
        body, setup = load + "    mul r2, r1, r2\n", store
    assert between(body, setup) == (S() + N() + I() if where != "start" else 0) + S() + I(m)


def test_a_probe_on_an_instruction_serves_every_block_that_holds_it() -> None:
    # the loop's MUL is reached as the middle of the first block and as the start of the loop's;
    # m follows r2 (1, then 2 once r2 > 0xFF) in both
    body = """
    mov r0, #0
    mov r2, #0xF0
    mov r1, #3
loop:
    add r2, r2, #0x10
    mul r2, r1, r2
    lsr r2, r2, #1
    subs r1, r1, #1
    bne loop
"""
    # r2: 0x100*3/2=0x180 (m=2), 0x190*2/2=0x190 (m=2), 0x1A0*1/2=0xD0 (m=2)
    per_iteration = S() + (S() + I(2)) + S() + S()  # add, mul, lsr, subs
    expected = 3 * S() + 3 * per_iteration + 2 * (2 * S() + N()) + S()  # bne taken twice, then falls through
    assert between(body) == expected


def test_condition_false_costs_1s() -> None:
    body = "    cmp r0, r0\n    ldrne r1, [r4]\n    strne r1, [r4]\n    mulne r0, r1, r2\n" \
           "    ldmiane r4, {r0-r3}\n    addne r0, r0, r1, lsl r2\n"
    assert between(body) == S() + 5 * S()


def test_condition_true_costs_the_instruction() -> None:
    body = "    cmp r0, r0\n    ldreq r1, [r4]\n    streq r1, [r4]\n    ldmiaeq r4, {r0-r3}\n"
    assert between(body) == S() + (S() + N() + I()) + 2 * N() + (S(4) + N() + I())


def test_conditional_branch_taken_and_not() -> None:
    taken = "    cmp r0, r0\n    beq 1f\n    nop\n1:\n"
    not_taken = "    cmp r0, r0\n    bne 1f\n    nop\n1:\n"
    assert between(taken) == S() + (2 * S() + N())
    assert between(not_taken) == S() + S() + S()


@pytest.mark.parametrize("body, expected", [
    ("    adr r5, 1f\n    mov pc, r5\n1:\n", S() + (S() + S() + N())),           # data processing to the PC
    ("    adr r5, 1f\n    str r5, [r4]\n    ldr pc, [r4]\n1:\n", S() + 2 * N() + (S() + N() + I() + S() + N())),
    ("    adr r5, 1f\n    add pc, r5, r0, lsl r0\n1:\n", S() + (S() + I() + S() + N())),  # with a register shift
])
def test_pc_writing_instructions_add_the_refill(body: str, expected: int) -> None:
    assert between(body, "    mov r0, #0\n") == expected


def test_swp_is_1s_2n_1i() -> None:
    assert between("    swp r0, r1, [r4]\n") == S() + 2 * N() + I()


def test_thumb_timings() -> None:
    # in Thumb: ALU 1S, shift by register 1S+1I, LDR 1S+1N+1I, STR 2N, MUL 1S+mI, PUSH/POP
    body = """
    adr r0, t + 1
    bx r0
.thumb
.thumb_func
t:
    movs r1, #200
    lsls r1, r1, r2
    ldr r3, [r4]
    str r3, [r4]
    movs r5, #3
    muls r5, r1
    push {r4, r5}
    pop {r4, r5}
    adr r0, back
    bx r0
.arm
back:
"""
    # r2 = 1: r1 = 400 = 0x190 -> m = 2 for muls r5, r1 (multiplier: r5's value 3 -> m = 1 on this core)
    expected = (S() + (2 * S() + N())          # adr, bx
                + S() + (S() + I()) + (S() + N() + I()) + 2 * N() + S() + (S() + I(1))
                + (S() + 2 * N()) + (S(2) + N() + I())
                + S() + (2 * S() + N()))        # adr, bx
    assert between(body, "    mov r2, #1\n    mov sp, r4\n") == expected


def test_thumb_bl_is_a_pair_of_instructions() -> None:
    body = """
    adr r0, t + 1
    bx r0
.thumb
.thumb_func
t:
    bl f
    adr r0, back
    bx r0
.thumb_func
f:
    bx lr
.arm
back:
"""
    bl_pair = S() + (2 * S() + N())  # prefix 1S, suffix 2S+1N
    expected = S() + (2 * S() + N()) + bl_pair + (2 * S() + N()) + S() + (2 * S() + N())
    assert between(body) == expected


@pytest.mark.parametrize("where, counter", [("start", "evals_start"), ("end", "evals_end"), ("probe", "evals_probe")])
def test_the_multiplier_is_read_where_the_block_allows(where: str, counter: str) -> None:
    store = "    ldr r5, =0x1234\n    str r5, [r4, #16]\n    mov r1, #3\n"
    load = "    ldr r2, [r4, #16]\n"
    body = {"start": "    mul r0, r1, r2\n", "end": load + "    mul r0, r1, r2\n", "probe": load + "    mul r2, r1, r2\n"}
    program = assemble(f"_start:\n{DATA}{store}{load if where == 'start' else ''}\na:\n{body[where]}\nb:\n    b b\n")
    core, _ = core_with(program)
    core.run_to(program.symbols["a"], 10_000)
    state = core.counter.state
    state.evals_start = state.evals_end = state.evals_probe = 0
    core.run_to(program.symbols["b"], 10_000)
    assert {c: getattr(state, c) for c in ("evals_start", "evals_end", "evals_probe")} == \
        {c: int(c == counter) for c in ("evals_start", "evals_end", "evals_probe")}
    assert core.retranslations == (1 if where == "probe" else 0)
