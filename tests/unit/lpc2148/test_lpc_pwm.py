"""PWM against UM10139's PWM chapter: the latch (new match values only at the next period and
only when latched), single- and double-edge widths, IR bit positions, outputs for the ESCs."""

from __future__ import annotations

from emulators.lpc2148 import Pwm
from emulators.lpc2148.pwm import PwmReg

MR = {0: 0x18, 1: 0x1C, 2: 0x20, 3: 0x24, 4: 0x40, 5: 0x44, 6: 0x48}


def running(pr: int = 0, mr0: int = 99, **mrs: int) -> Pwm:
    """A PWM in PWM mode: reset on MR0, channel 1-6 outputs enabled, the given match values latched."""
    p = Pwm()
    p.write(PwmReg.PR, pr, 0)
    p.write(MR[0], mr0, 0)
    for name, value in mrs.items():
        p.write(MR[int(name[2:])], value, 0)
    p.write(PwmReg.MCR, 0b010, 0)
    p.write(PwmReg.PCR, 0x7E00, 0)
    p.write(PwmReg.TCR, 0b1010, 0)  # PWM mode, held in reset
    p.write(PwmReg.TCR, 0b1001, 0)
    return p


def test_reset_values() -> None:
    p = Pwm()
    for reg in (PwmReg.IR, PwmReg.TCR, PwmReg.TC, PwmReg.PR, PwmReg.PC, PwmReg.MCR, PwmReg.PCR, PwmReg.LER,
                *MR.values()):
        assert p.read(reg, 0) == 0
    assert p.outputs() == {ch: (0, 0) for ch in range(1, 7)}


def test_match_writes_in_pwm_mode_wait_for_the_latch() -> None:
    p = running(mr0=99, mr1=30)  # written before PWM mode: in effect at once
    assert p.outputs()[1] == (30, 100)
    p.take_changes()
    p.write(MR[1], 60, 10)
    p.advance_to(1000)
    assert p.outputs()[1] == (30, 100)  # no LER bit: never takes effect
    p.write(PwmReg.LER, 0b10, 1005)
    assert p.read(PwmReg.LER, 1005) == 0b10
    p.advance_to(1099)  # TC reaches MR0 at tick 1099; the next period starts at 1100
    assert p.outputs()[1] == (60, 100)
    assert p.read(PwmReg.LER, 1099) == 0  # cleared by the transfer
    assert [(c.tick, c.channel, c.high_ticks) for c in p.take_changes()] == [(1100, 1, 60)]


def test_latch_transfers_only_the_latched_channels() -> None:
    p = running(mr0=99, mr1=10, mr2=20)
    p.write(MR[1], 11, 0)
    p.write(MR[2], 22, 0)
    p.write(PwmReg.LER, 0b100, 0)
    p.advance_to(200)
    assert p.outputs()[1] == (10, 100) and p.outputs()[2] == (22, 100)


def test_single_edge_limits() -> None:
    p = running(pr=2, mr0=9, mr1=0, mr2=4, mr3=9, mr4=10)
    out = p.outputs()
    assert out[1] == (0, 30)  # match value 0: low
    assert out[2] == (12, 30)  # 4 counts of 3 ticks
    assert out[3] == (27, 30)  # low only while TC = MR0
    assert out[4] == (30, 30)  # beyond the rate: high all the time


def test_double_edge_width() -> None:
    p = running(mr0=99, mr1=20, mr2=70, mr3=70)
    p.write(PwmReg.PCR, 0x7E00 | (1 << 2) | (1 << 3), 0)  # channels 2 and 3 double-edged
    out = p.outputs()
    assert out[2] == (50, 100)  # set at MR1 = 20, cleared at MR2 = 70
    assert out[3] == (0, 100)  # set and clear together: clear wins


def test_outputs_need_pwm_mode_enable_and_reset_on_mr0() -> None:
    p = running(mr0=99, mr1=30)
    p.write(PwmReg.PCR, 0, 0)
    assert p.outputs()[1] == (0, 0)
    p.write(PwmReg.PCR, 0x7E00, 0)
    p.write(PwmReg.TCR, 0b0001, 0)  # timer mode
    assert p.outputs()[1] == (0, 0)


def test_ir_bits_for_mr4_to_mr6_sit_at_8_to_10() -> None:
    p = running(mr0=99, mr4=10, mr6=20)
    p.write(PwmReg.MCR, 0b010 | (1 << 12) | (1 << 18), 0)
    p.advance_to(25)
    assert p.read(PwmReg.IR, 25) == (1 << 8) | (1 << 10) and p.irq
    p.write(PwmReg.IR, 1 << 8, 25)
    assert p.read(PwmReg.IR, 25) == 1 << 10


def test_next_event_is_the_latch() -> None:
    p = running(mr0=99, mr1=30)
    assert p.next_event() is None  # nothing to do: no interrupts, no latch pending
    p.write(MR[1], 50, 7)
    p.write(PwmReg.LER, 2, 7)
    assert p.next_event() == 99
