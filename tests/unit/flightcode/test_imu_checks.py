"""imu_checks: a sample that cannot be true is named; one the vehicle can produce never is."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from flightcode.drivers.imu_checks import MAX_RATE_RADPS, implausible

DT_S = 0.0025
LEVEL = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
angle = st.floats(-math.pi / 2, math.pi / 2)
rate = st.floats(-10.0, 10.0)


@given(roll=angle, pitch=st.floats(-1.5, 1.5), yaw=st.floats(-math.pi, math.pi), p=rate, q=rate, r=rate,
       turn=st.floats(-1.0, 1.0), accel=st.floats(-1.0, 1.0))
def test_a_motion_within_the_airframe_s_limits_is_plausible(roll, pitch, yaw, p, q, r, turn, accel) -> None:
    """Any attitude, a turn of up to MAX_RATE x dt and a rate change of up to 1000 rad/s^2 x dt."""
    last = ((roll, pitch, yaw), (p, q, r))
    step = turn * MAX_RATE_RADPS * DT_S
    yaw2 = (yaw + step + math.pi) % (2 * math.pi) - math.pi
    now = ((roll + step * 0.1, pitch, yaw2), (p + accel * 2.5, q, r))
    if abs(now[0][0]) <= math.pi:
        assert implausible(*now, (0.0, 0.0, -9.81), last, DT_S) is None


@given(bits=st.integers(3, 7))
def test_a_flipped_exponent_bit_in_a_rate_is_caught(bits: int) -> None:
    """0.1 rad/s with exponent bit ``bits`` set (x 2^8 .. x 2^128): a jump or out of range.
    Lower bits (x 4, x 16 of a slow rate) stay within what the airframe can do, and the
    controllers ride through one such sample."""
    w = 0.1 * 2.0 ** (2 ** bits)
    assert implausible((0.0, 0.0, 0.0), (w, 0.0, 0.0), (0.0, 0.0, -9.81), LEVEL, DT_S) is not None


def test_reasons() -> None:
    level = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, -9.81))
    assert implausible(*level, None, 0.0) is None
    assert implausible((0.0, 2.0, 0.0), (0, 0, 0), (0, 0, -9.81), None, 0.0) == "angle out of range"
    assert implausible((0.0, 0.0, 0.0), (0, 0, 0), (0, 0, 300.0), None, 0.0) == "specific force out of range"
    assert implausible((0.2, 0.0, 0.0), (0, 0, 0), (0, 0, -9.81), LEVEL, DT_S) == "angle jump"
    assert implausible((0.0, 0.0, 0.0), (0, 5.0, 0), (0, 0, -9.81), LEVEL, DT_S) == "rate jump"
    assert implausible((0.0, 0.0, 0.0), (float("inf"), 0, 0), (0, 0, -9.81), LEVEL, DT_S) == "not finite"
