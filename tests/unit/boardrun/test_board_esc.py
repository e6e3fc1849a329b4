"""The ESC inputs read from the LPC2148's pins (hil/flight/board_esc.py): PWM widths as the
model reports them, match-output pulses rebuilt from their edges, late and missed pulses, a
silent output, and the order the ESC models get them in."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from hil.flight.board_esc import LATE_US, SILENT_PERIODS, EscPins

US = 1000  # ns


def record(pins: EscPins, t_ns: int) -> list[tuple[int, int, float]]:
    """Drive the pins to ``t_ns`` with recording ESC models: (esc, t, width) as they were called."""
    calls: list[tuple[int, int, float]] = []
    pins.drive(t_ns, lambda esc, t, w: (calls.append((esc, t, w)), 0.5)[1])
    return calls


def mat_pulse(pins: EscPins, channel: int, rise_us: int, width_us: int) -> None:
    pins.match(rise_us * US, channel, True)
    pins.match((rise_us + width_us) * US, channel, False)


def test_pwm_widths_reach_escs_0_and_1_from_their_change() -> None:
    pins = EscPins()
    pins.pwm(100 * US, 2, 1000.0, 2500.0)
    pins.pwm(150 * US, 5, 1250.0, 2500.0)
    pins.pwm(160 * US, 3, 1900.0, 2500.0)  # PWM3 drives no ESC on this board
    calls = record(pins, 2500 * US)
    assert (0, 100 * US, 1000.0) in calls and (1, 150 * US, 1250.0) in calls
    assert pins.width_us == [1000.0, 1250.0, 0.0, 0.0]
    assert [c for c in calls if c[1] == 2500 * US] == [(0, 2500 * US, 1000.0), (1, 2500 * US, 1250.0),
                                                        (2, 2500 * US, 0.0), (3, 2500 * US, 0.0)]
    pins.pwm(3000 * US, 2, 0.0, 0.0)  # the channel switched off: no pulses
    assert pins.width_us[0] == 0.0


def test_a_match_output_pulse_applies_from_its_falling_edge() -> None:
    pins = EscPins()
    mat_pulse(pins, 2, 100, 1500)
    mat_pulse(pins, 3, 100, 1213)
    assert pins.width_us[2:] == [1500.0, 1213.0]
    calls = record(pins, 2500 * US)
    assert (2, 1600 * US, 1500.0) in calls and (3, 1313 * US, 1213.0) in calls
    assert pins.pulses[2:] == [1, 1] and pins.late == pins.missed == 0


def test_pulses_one_period_apart_are_on_time_later_ones_late_and_gaps_missed() -> None:
    pins = EscPins()
    for k in range(4):
        mat_pulse(pins, 2, 100 + 2500 * k, 1000)
    assert (pins.late, pins.missed) == (0, 0)
    mat_pulse(pins, 2, 100 + 2500 * 4 + round(LATE_US) + 1, 1000)  # a handler a few us late
    assert (pins.late, pins.missed) == (1, 0)
    mat_pulse(pins, 2, 100 + 2500 * 7 + 3, 1000)  # two periods without a pulse
    assert pins.missed == 2


def test_a_silent_output_gives_its_esc_no_pulses_after_the_silent_periods() -> None:
    pins = EscPins()
    mat_pulse(pins, 3, 100, 1200)
    limit_us = round(SILENT_PERIODS * 2500)
    assert record(pins, (100 + limit_us) * US)[-1] == (3, (100 + limit_us) * US, 1200.0)  # not yet
    calls = record(pins, (100 + limit_us + 2500) * US)
    assert (3, (100 + limit_us) * US, 0.0) in calls and pins.width_us[3] == 0.0


def test_a_change_after_the_tick_waits_for_the_next_one() -> None:
    pins = EscPins()
    pins.pwm(2500 * US + 40, 2, 1100.0, 2500.0)  # the core ran 40 ns past the tick
    assert record(pins, 2500 * US)[0] == (0, 2500 * US, 0.0)
    assert (0, 2500 * US + 40, 1100.0) in record(pins, 5000 * US)


def test_rebase_moves_what_is_kept_with_sim_time() -> None:
    pins = EscPins()
    mat_pulse(pins, 2, 100, 1000)
    pins.rebase(-10_000 * US)
    mat_pulse(pins, 2, 100 + 2500 - 10_000, 1000)
    assert (pins.late, pins.missed) == (0, 0)


@given(st.lists(st.tuples(st.integers(0, 3), st.integers(0, 10_000_000), st.floats(800.0, 2200.0)), max_size=40),
       st.lists(st.integers(1, 20_000_000), min_size=1, max_size=10))
def test_every_esc_sees_its_changes_in_time_order(changes: list[tuple[int, int, float]], ticks: list[int]) -> None:
    pins = EscPins()
    for esc, t, w in sorted(changes, key=lambda c: c[1]):
        pins._set(esc, t, w)
    seen: dict[int, list[int]] = {e: [] for e in range(4)}
    for t_tick in sorted(set(ticks)):
        pins.drive(t_tick, lambda esc, t, w: (seen[esc].append(t), 0.0)[1])
    for times in seen.values():
        assert times == sorted(times)


@pytest.mark.parametrize("channel", [0, 1])
def test_match_channels_without_an_esc_are_ignored(channel: int) -> None:
    pins = EscPins()
    mat_pulse(pins, channel, 100, 1000)
    assert pins.width_us == [0.0] * 4 and pins.changes == []
