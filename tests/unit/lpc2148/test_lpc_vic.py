"""VIC (PL190) against UM10139's VIC register descriptions: reset values, write-1-to-set/clear
registers, the vectored priority order and the VICVectAddr read/write sequencing."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from emulators.lpc2148 import RegisterAccessError, UnmodelledRegister, Vic
from emulators.lpc2148.vic import NON_VECTORED, VicReg

T0, T1, U0, U1 = 4, 5, 6, 7


def slot(vic: Vic, n: int, channel: int, address: int) -> None:
    vic.write(VicReg.VECT_CNTL0 + 4 * n, 0x20 | channel)
    vic.write(VicReg.VECT_ADDR0 + 4 * n, address)


def test_reset_values() -> None:
    vic = Vic()
    for reg in (VicReg.IRQ_STATUS, VicReg.FIQ_STATUS, VicReg.RAW_INTR, VicReg.INT_SELECT, VicReg.INT_ENABLE,
                VicReg.SOFT_INT, VicReg.PROTECTION, VicReg.DEF_VECT_ADDR):
        assert vic.read(reg) == 0
    assert all(vic.read(VicReg.VECT_CNTL0 + 4 * n) == 0 for n in range(16))
    assert not vic.irq_request and not vic.fiq_request
    assert vic.read(VicReg.VECT_ADDR) == 0  # nothing active: VICDefVectAddr


def test_enable_and_soft_registers_set_and_clear_by_ones() -> None:
    vic = Vic()
    vic.write(VicReg.INT_ENABLE, 1 << T0)
    vic.write(VicReg.INT_ENABLE, 1 << U0)  # zeros written do not clear
    assert vic.read(VicReg.INT_ENABLE) == (1 << T0) | (1 << U0)
    vic.write(VicReg.INT_EN_CLR, 1 << T0)
    assert vic.read(VicReg.INT_ENABLE) == 1 << U0
    vic.write(VicReg.SOFT_INT, 1 << T1)
    assert vic.read(VicReg.RAW_INTR) == 1 << T1
    vic.write(VicReg.SOFT_INT_CLEAR, 1 << T1)
    assert vic.read(VicReg.RAW_INTR) == 0


def test_status_split_by_int_select() -> None:
    vic = Vic()
    vic.set_sources((1 << T0) | (1 << U0) | (1 << U1))
    vic.write(VicReg.INT_ENABLE, (1 << T0) | (1 << U0))
    vic.write(VicReg.INT_SELECT, 1 << T0)
    assert vic.read(VicReg.RAW_INTR) == (1 << T0) | (1 << U0) | (1 << U1)
    assert vic.read(VicReg.FIQ_STATUS) == 1 << T0
    assert vic.read(VicReg.IRQ_STATUS) == 1 << U0
    assert vic.fiq_request and vic.irq_request


def test_vectaddr_returns_the_highest_slot_and_masks_lower_until_written() -> None:
    vic = Vic()
    slot(vic, 0, U0, 0x100)
    slot(vic, 1, T0, 0x200)
    vic.write(VicReg.INT_ENABLE, (1 << U0) | (1 << T0))
    vic.set_sources((1 << U0) | (1 << T0))
    assert vic.irq_request
    assert vic.read(VicReg.VECT_ADDR) == 0x100
    assert not vic.irq_request  # slot 1 is below slot 0 in service
    vic.set_sources(1 << T0)  # the ISR cleared the UART's request
    vic.write(VicReg.VECT_ADDR, 0)
    assert vic.irq_request
    assert vic.read(VicReg.VECT_ADDR) == 0x200
    vic.set_sources(0)
    vic.write(VicReg.VECT_ADDR, 0)
    assert vic.in_service == []


def test_a_higher_priority_nests_and_unwinds_in_order() -> None:
    vic = Vic()
    slot(vic, 1, U0, 0x100)
    slot(vic, 3, T0, 0x300)
    vic.write(VicReg.INT_ENABLE, (1 << U0) | (1 << T0))
    vic.set_sources(1 << T0)
    assert vic.read(VicReg.VECT_ADDR) == 0x300
    vic.set_sources((1 << T0) | (1 << U0))
    assert vic.irq_request  # slot 1 preempts slot 3
    assert vic.read(VicReg.VECT_ADDR) == 0x100
    assert vic.in_service == [3, 1]
    vic.set_sources(1 << T0)
    vic.write(VicReg.VECT_ADDR, 0)
    assert vic.in_service == [3] and not vic.irq_request
    vic.write(VicReg.VECT_ADDR, 0)
    assert vic.irq_request  # T0 still asserted: it interrupts again


def test_non_vectored_gets_the_default_address_below_every_slot() -> None:
    vic = Vic()
    vic.write(VicReg.DEF_VECT_ADDR, 0xD00)
    slot(vic, 15, U0, 0x150)
    vic.write(VicReg.INT_ENABLE, (1 << U0) | (1 << T1))
    vic.set_sources(1 << T1)
    assert vic.read(VicReg.VECT_ADDR) == 0xD00
    assert vic.in_service == [NON_VECTORED] and not vic.irq_request
    vic.set_sources((1 << T1) | (1 << U0))
    assert vic.irq_request and vic.read(VicReg.VECT_ADDR) == 0x150


def test_a_disabled_slot_makes_its_channel_non_vectored_and_lowest_slot_wins() -> None:
    vic = Vic()
    vic.write(VicReg.DEF_VECT_ADDR, 0xD00)
    slot(vic, 2, U0, 0x120)
    slot(vic, 5, U0, 0x150)  # same channel twice: the lower-numbered slot is used
    vic.write(VicReg.INT_ENABLE, 1 << U0)
    vic.set_sources(1 << U0)
    assert vic.read(VicReg.VECT_ADDR) == 0x120
    vic.write(VicReg.VECT_ADDR, 0)
    vic.write(VicReg.VECT_CNTL0 + 8, U0)  # slot 2 disabled
    vic.write(VicReg.VECT_CNTL0 + 20, U0)  # slot 5 disabled
    assert vic.read(VicReg.VECT_ADDR) == 0xD00


def test_fiq_ignores_the_priority_hardware() -> None:
    vic = Vic()
    slot(vic, 0, U0, 0x100)
    vic.write(VicReg.INT_ENABLE, (1 << U0) | (1 << T0))
    vic.write(VicReg.INT_SELECT, 1 << T0)
    vic.set_sources((1 << U0) | (1 << T0))
    vic.read(VicReg.VECT_ADDR)
    assert vic.fiq_request and not vic.irq_request


def test_wrong_accesses_raise_naming_the_address() -> None:
    vic = Vic()
    with pytest.raises(RegisterAccessError, match="0xFFFFF014"):
        vic.read(VicReg.INT_EN_CLR)
    with pytest.raises(RegisterAccessError, match="0xFFFFF01C"):
        vic.read(VicReg.SOFT_INT_CLEAR)
    with pytest.raises(RegisterAccessError, match="0xFFFFF000"):
        vic.write(VicReg.IRQ_STATUS, 1)
    with pytest.raises(UnmodelledRegister, match="0xFFFFF040"):
        vic.read(0x040)
    with pytest.raises(UnmodelledRegister, match="0xFFFFF300"):
        vic.write(0x300, 0)


@given(st.lists(st.tuples(st.sampled_from(["src", "ack", "end"]), st.integers(0, (1 << 8) - 1)), max_size=60))
def test_priority_stack_invariants(ops: list[tuple[str, int]]) -> None:
    """In service levels strictly rise in priority inward; nIRQ is asserted exactly when an
    enabled IRQ's level is above the innermost in service; an ack takes the highest active."""
    vic = Vic()
    for n, channel in enumerate((0, 2, 4, 6)):  # channels 0, 2, 4, 6 in slots 0-3; 1, 3, 5, 7 non-vectored
        slot(vic, n * 2 + 1, channel, 0x1000 + n)
    vic.write(VicReg.INT_ENABLE, 0xFF)
    for op, mask in ops:
        if op == "src":
            vic.set_sources(mask)
        elif op == "ack":
            before = list(vic.in_service)
            address = vic.read(VicReg.VECT_ADDR)
            if vic.in_service != before:
                level = vic.in_service[-1]
                active = [vic._level_of(c) for c in range(8) if vic.irq_status >> c & 1]
                assert level == min(active)
                assert address == (0 if level == NON_VECTORED else 0x1000 + (level - 1) // 2)
        else:
            vic.write(VicReg.VECT_ADDR, 0)
        stack = vic.in_service
        assert all(a > b for a, b in zip(stack, stack[1:], strict=False))
        top = stack[-1] if stack else 99
        levels = [vic._level_of(c) for c in range(8) if vic.irq_status >> c & 1]
        assert vic.irq_request == any(level < top for level in levels)
