"""StickScript: setpoints with ramps, sines with fades, macros, loss windows."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from emulators.rc.script import (
    ARM_THROTTLE_MAX_US,
    ARM_YAW_MIN_US,
    DISARM_YAW_MAX_US,
    GESTURE_HOLD_S,
    Loss,
    Macro,
    Setpoint,
    Sine,
    StickScript,
)

S = 1_000_000_000


def test_defaults_centred_throttle_low() -> None:
    assert StickScript().pulses_us(0) == (1500, 1500, 1000, 1500, 1000, 1000, 1000, 1000)


def test_step_and_ramp() -> None:
    s = StickScript([Setpoint(1.0, 3, 1400), Setpoint(2.0, 3, 1800, ramp_s=2.0)])
    assert s.pulses_us(int(0.999 * S))[2] == 1000
    assert s.pulses_us(1 * S)[2] == 1400
    assert s.pulses_us(2 * S)[2] == 1400
    assert s.pulses_us(3 * S)[2] == 1600  # half-way up the ramp
    assert s.pulses_us(4 * S)[2] == 1800
    assert s.pulses_us(100 * S)[2] == 1800


def test_setpoint_interrupting_ramp_starts_from_current_value() -> None:
    s = StickScript([Setpoint(0.0, 1, 2000, ramp_s=2.0), Setpoint(1.0, 1, 1000, ramp_s=1.0)])
    assert s.pulses_us(1 * S)[0] == 1750  # 1500 -> 2000 half done
    assert s.pulses_us(int(1.5 * S))[0] == 1375
    assert s.pulses_us(2 * S)[0] == 1000


def test_clamped_to_end_points() -> None:
    s = StickScript([Setpoint(0.0, 2, 2600)])
    assert s.pulses_us(0)[1] == 2000


def test_sine_fades_in_and_out() -> None:
    sine = Sine(1.0, 1, amplitude_us=100, freq_hz=1.0, duration_s=10.0, fade_s=2.0)
    s = StickScript([sine])
    # Before, at the start and after: centred.
    assert s.value_us(1, int(0.5 * S)) == 1500
    assert s.value_us(1, 1 * S) == pytest.approx(1500)
    assert s.value_us(1, 12 * S) == 1500
    # Raised-cosine envelope 0.25 s into the 2 s fade: 0.5 * (1 - cos(pi * 0.25 / 2)).
    env = 0.5 * (1 - math.cos(math.pi * 0.25 / 2.0))
    assert s.value_us(1, int(1.25 * S)) == pytest.approx(1500 + 100 * env)  # sin = +1
    assert s.value_us(1, int(4.25 * S)) == pytest.approx(1600)  # past the fade: full amplitude
    assert s.value_us(1, int(10.75 * S)) == pytest.approx(1500 - 100 * env)  # fading out, sin = -1


@given(st.floats(min_value=0.0, max_value=12.0))
@settings(max_examples=200, deadline=None)
def test_sine_never_steps(t_s: float) -> None:
    sine = Sine(1.0, 4, amplitude_us=300, freq_hz=0.5, duration_s=8.0, fade_s=2.0)
    s = StickScript([sine])
    dt = 1e-4
    a = s.value_us(4, int(t_s * S))
    b = s.value_us(4, int((t_s + dt) * S))
    # Max slope of an unfaded sine: 2*pi*f*A us/s; the fade adds at most pi/(2*fade)*A.
    assert abs(b - a) <= (2 * 3.1416 * 0.5 * 300 + 3.1416 / 4 * 300) * dt * 1.01 + 1e-6


def test_sine_with_offset_replaces_track() -> None:
    s = StickScript([Sine(0.0, 3, amplitude_us=50, freq_hz=1.0, duration_s=4.0, offset_us=1300, fade_s=0.0)])
    assert s.value_us(3, int(0.25 * S)) == pytest.approx(1350)
    assert s.value_us(3, 5 * S) == 1000


def test_arm_macro_satisfies_gesture_then_recentres() -> None:
    s = StickScript([Setpoint(0.0, 3, 1300), Macro(2.0, "arm")])
    held = [s.pulses_us(int((2.0 + k * 0.01) * S)) for k in range(int(GESTURE_HOLD_S / 0.01) + 1)]
    assert all(p[2] <= ARM_THROTTLE_MAX_US and p[3] >= ARM_YAW_MIN_US for p in held)
    after = s.pulses_us(4 * S)
    assert after[3] == 1500 and after[2] == 1000


def test_disarm_macro() -> None:
    s = StickScript([Macro(0.5, "disarm", hold_s=1.2)])
    p = s.pulses_us(int(1.6 * S))
    assert p[2] <= ARM_THROTTLE_MAX_US and p[3] <= DISARM_YAW_MAX_US
    assert s.pulses_us(int(1.8 * S))[3] == 1500


def test_bad_segments_rejected() -> None:
    with pytest.raises(ValueError):
        Setpoint(0.0, 9, 1500)
    with pytest.raises(ValueError):
        Macro(0.0, "flip")
    with pytest.raises(ValueError):
        Macro(0.0, "arm", hold_s=0.5)
    with pytest.raises(ValueError):
        Loss(1.0, 0.0)


def test_loss_windows() -> None:
    s = StickScript([Loss(1.0, 0.5), Loss(3.0, 1.0)])
    assert s.signal_present(int(0.99 * S))
    assert not s.signal_present(1 * S)
    assert not s.signal_present(int(1.49 * S))
    assert s.signal_present(int(1.5 * S))
    assert not s.signal_present(int(3.5 * S))
    assert s.signal_present(4 * S)
