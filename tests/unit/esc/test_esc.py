"""ESC model: frame latching, arming and signal-loss timing in sim time, faults."""

from __future__ import annotations

import numpy as np
import pytest

from emulators.esc import Esc, EscArmed, EscDesync, EscDisarmed, EscParams

MS = 1_000_000
TICK = 2_500_000


def run(esc: Esc, pulse_at, t_end_ns: int, step_ns: int = TICK) -> list[tuple[int, float]]:
    """Drive ``esc`` each ``step_ns`` with ``pulse_at(t_ns)``; returns (t_ns, throttle)."""
    out = []
    for t in range(0, t_end_ns + 1, step_ns):
        out.append((t, esc.update(t, pulse_at(t))))
    return out


def first_armed_ns(esc: Esc) -> int | None:
    for e in esc.take_events():
        if isinstance(e, EscArmed):
            return e.t_ns
    return None


def test_arms_after_low_signal_for_arm_time() -> None:
    esc = Esc(EscParams(pwm_rate_hz=400.0, arm_time_s=0.5))
    run(esc, lambda t: 1000.0, 600 * MS)
    assert esc.armed
    # Frames every 2.5 ms from t = 0; armed on the first frame >= 0.5 s after the first low one.
    assert first_armed_ns(esc) == 500 * MS


def test_high_signal_at_power_up_does_not_arm() -> None:
    esc = Esc(EscParams())
    run(esc, lambda t: 1500.0 if t < 2_000 * MS else 1000.0, 2_400 * MS)
    assert not esc.armed and esc.throttle == 0.0
    run_from = [esc.update(t, 1000.0) for t in range(2_400 * MS, 2_600 * MS, TICK)]
    assert esc.armed and run_from[-1] == 0.0
    # 333 Hz frames: the first low frame is the first boundary after 2 s (2003.0 ms), armed
    # on the first boundary 0.5 s after it.
    period = round(1e9 / 333.0)
    first_low = -(-2_000 * MS // period) * period
    if first_low == 2_000 * MS:
        first_low += period
    assert first_armed_ns(esc) == -(-(first_low + 500 * MS) // period) * period


def test_throttle_mapping_after_arming() -> None:
    esc = Esc(EscParams(deadband_us=30.0))
    run(esc, lambda t: 1000.0, 600 * MS)
    t = 600 * MS
    for width, want in [(1000.0, 0.0), (1030.0, 0.0), (1515.0, 0.5), (2000.0, 1.0), (2100.0, 1.0)]:
        t += 10 * MS
        assert esc.update(t, width) == pytest.approx(want) or esc.update(t + 4 * MS, width) == pytest.approx(want)
        t += 4 * MS


def test_new_width_seen_only_at_frame_boundaries() -> None:
    esc = Esc(EscParams(pwm_rate_hz=50.0))  # 20 ms frames
    run(esc, lambda t: 1000.0, 600 * MS, step_ns=20 * MS)
    assert esc.armed
    assert esc.update(601 * MS, 2000.0) == 0.0  # last boundary was 600 ms
    assert esc.update(619 * MS, 2000.0) == 0.0
    assert esc.update(620 * MS, 2000.0) == 1.0
    # A command that arrives and is replaced between two boundaries is never seen.
    esc.update(625 * MS, 1000.0)
    esc.update(630 * MS, 2000.0)
    assert esc.update(640 * MS, 2000.0) == 1.0 and esc.latched_us == 2000.0
    # Boundaries passed between calls use the width that was on the pin then.
    esc.update(641 * MS, 1500.0)
    assert esc.update(699 * MS, 1000.0) == pytest.approx((1500.0 - 1030.0) / 970.0)
    assert esc.latched_us == 1500.0
    assert esc.update(700 * MS, 1000.0) == 0.0 and esc.latched_us == 1000.0


def test_signal_loss_holds_then_stops_and_needs_rearm() -> None:
    p = EscParams(pwm_rate_hz=400.0, signal_timeout_s=0.25)
    esc = Esc(p)
    run(esc, lambda t: 1000.0, 600 * MS)
    esc.update(600 * MS, 1515.0)
    esc.update(700 * MS, 0.0)  # pulses stop (Maestro target 0) at 700 ms
    held = esc.update(947 * MS, 0.0)
    assert held == pytest.approx(0.5) and esc.armed
    assert esc.update(950 * MS, 0.0) == 0.0 and not esc.armed
    ev = [e for e in esc.take_events() if isinstance(e, EscDisarmed)]
    # Last valid frame at 697.5 ms; disarmed on the first frame >= 250 ms later.
    assert [e.t_ns for e in ev] == [947_500_000]
    # A high signal coming back does not drive the motor; a low one re-arms after 0.5 s.
    assert esc.update(1_000 * MS, 1515.0) == 0.0
    run_t = 1_000 * MS
    while run_t < 1_600 * MS:
        run_t += TICK
        esc.update(run_t, 1515.0)
    assert not esc.armed
    for k in range(1, 300):
        esc.update(run_t + k * TICK, 1000.0)
    assert esc.armed


def test_out_of_range_widths_count_as_no_signal() -> None:
    esc = Esc(EscParams())
    run(esc, lambda t: 500.0, 1_000 * MS)
    assert not esc.armed and esc.counters["invalid_frames"] > 300


def test_refuse_arm_fault() -> None:
    esc = Esc(EscParams())
    esc.set_refuse_arm(True)
    run(esc, lambda t: 1000.0, 2_000 * MS)
    assert not esc.armed
    esc.set_refuse_arm(False)
    for k in range(1, 200):
        esc.update(2_000 * MS + k * TICK, 1000.0)
    assert not esc.armed  # 0.4975 s of low signal since the fault cleared
    for k in range(200, 205):
        esc.update(2_000 * MS + k * TICK, 1000.0)
    assert esc.armed


def test_stuck_fault() -> None:
    esc = Esc(EscParams())
    run(esc, lambda t: 1000.0, 600 * MS)
    for k in range(1, 10):
        esc.update(600 * MS + k * TICK, 1515.0)
    esc.set_stuck(True)
    assert esc.update(700 * MS, 2000.0) == pytest.approx(0.5)
    esc.set_stuck(True, 0.2)
    assert esc.update(710 * MS, 2000.0) == pytest.approx(0.2)
    esc.set_stuck(False)
    assert esc.update(720 * MS, 2000.0) == 1.0


def test_desync_seeded_drops() -> None:
    def drops(seed: int) -> list[int]:
        esc = Esc(EscParams(pwm_rate_hz=400.0, desync_duration_s=0.1), np.random.default_rng(seed))
        run(esc, lambda t: 1000.0, 600 * MS)
        esc.set_desync(2.0)
        out = run(esc, lambda t: 1500.0, 10_000 * MS)
        zeros = sum(1 for t, th in out if t > 700 * MS and th == 0.0)
        starts = [e.t_ns for e in esc.take_events() if isinstance(e, EscDesync)]
        assert zeros >= 0.09 / 0.0025 * len(starts) * 0.9  # each drop lasts ~0.1 s
        return starts

    a, b, c = drops(1), drops(1), drops(2)
    assert a == b and a != c
    assert 8 <= len(a) <= 32  # ~2 Hz over ~9.4 s, minus time spent in drops


def test_params_validated() -> None:
    with pytest.raises(ValueError):
        EscParams(pwm_rate_hz=1000.0)
    with pytest.raises(ValueError):
        EscParams(min_us=1000.0, max_us=1100.0)
