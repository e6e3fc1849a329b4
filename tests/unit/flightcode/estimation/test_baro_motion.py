"""The barometer checked against the accelerometers' motion (flightcode/estimation/baro_motion.py):
a blocked static port in a climb is seen, a barometer that moves with the vehicle never is,
and the estimator's gate keeps the outliers (a spike, a level shift) to itself."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.estimation.baro_motion import BaroMotionCheck

DT_S = 0.0025
#: one barometric reading's noise through the x16 stage, m (docs/analog-chain.md)
BARO_NOISE_M = 0.44


def climb_profile(t_s: np.ndarray, t0_s: float, height_m: float, duration_s: float) -> tuple[np.ndarray, ...]:
    """A smooth climb of ``height_m`` starting at ``t0_s`` over ``duration_s`` (1 - cos
    acceleration): (height m, vertical velocity m/s, vertical acceleration m/s^2)."""
    tau = np.clip((t_s - t0_s) / duration_s, 0.0, 1.0)
    z = height_m * (tau - np.sin(2 * np.pi * tau) / (2 * np.pi))
    inside = (t_s >= t0_s) & (t_s <= t0_s + duration_s)
    v = np.where(inside, height_m / duration_s * (1 - np.cos(2 * np.pi * tau)), 0.0)
    a = np.where(inside, height_m / duration_s ** 2 * 2 * np.pi * np.sin(2 * np.pi * tau), 0.0)
    return z, v, a


def fly(check: BaroMotionCheck, z: np.ndarray, v: np.ndarray, a: np.ndarray, baro: np.ndarray,
        judging: np.ndarray | None = None, rejected: np.ndarray | None = None) -> tuple[list[int], np.ndarray]:
    """Feed every sample (the estimate is the truth here): the samples at which a refusal
    started, and the refusal flag of every sample."""
    starts = []
    was = False
    trace = []
    for i in range(len(z)):
        refused = check.add(DT_S, float(baro[i]), float(a[i]), float(z[i]), float(v[i]),
                            True if judging is None else bool(judging[i]))
        if rejected is not None and rejected[i]:
            check.reading_rejected()
        if refused and not was:
            starts.append(i)
        was = refused
        trace.append(refused)
    return starts, np.array(trace)


def times(duration_s: float) -> np.ndarray:
    return np.arange(round(duration_s / DT_S)) * DT_S


def test_a_barometer_that_moves_with_the_vehicle_is_believed() -> None:
    t = times(12.0)
    z, v, a = climb_profile(t, 3.0, 5.0, 2.5)
    rng = np.random.default_rng(1)
    check = BaroMotionCheck()
    assert fly(check, 2.0 + z, v, a, 2.0 + z + rng.normal(0.0, BARO_NOISE_M, t.size))[0] == []
    assert check.counters["windows"] > 30 and 0.0 < check.worst_m < 0.6


def test_a_blocked_port_in_a_climb_is_refused_and_the_estimate_moved_to_the_inertial_height() -> None:
    t = times(10.0)
    z, v, a = climb_profile(t, 3.0, 2.0, 1.5)
    rng = np.random.default_rng(2)
    baro = 2.0 + rng.normal(0.0, BARO_NOISE_M, t.size)  # the trapped air: the noise goes on
    # the estimate as a filter fusing the held reading has it: it does not see the climb,
    # until it is moved to the inertial height (then it flies on the accelerometer: the truth)
    check = BaroMotionCheck()
    starts = []
    for i in range(t.size):
        est, vz = (2.0, 0.0) if not starts else (2.0 + z[i], v[i])
        if check.add(DT_S, float(baro[i]), float(a[i]), est, vz, True) and not starts:
            starts.append(i)
            target = check.take_reanchor()
    assert len(starts) == 1
    t_seen = t[starts[0]]
    # seen once the vehicle has left the trapped level by the tolerance (and a block more)
    first_over = t[np.argmax(z > check.max_m)]
    assert first_over <= t_seen <= first_over + 0.6
    assert target is not None
    # the inertial height from the window's start (where the estimate was still right)
    assert abs(target[0] - (2.0 + z[starts[0]])) < 0.2 and abs(target[1] - v[starts[0]]) < 0.2
    assert check.take_reanchor() is None  # once
    assert check.refusing  # still refused while it stays blocked at a level the vehicle left


def test_a_spike_or_a_level_shift_is_left_to_the_estimators_gate() -> None:
    t = times(8.0)
    zeros = np.zeros(t.size)
    rng = np.random.default_rng(3)
    baro = 2.0 + rng.normal(0.0, BARO_NOISE_M, t.size)
    spike = (t >= 3.0) & (t < 3.2)
    shift = t >= 5.0
    baro = baro + np.where(spike, 12.0, 0.0) + np.where(shift, -8.0, 0.0)
    # the gate refuses the spike and the first second of the shift, then re-anchors
    rejected = spike | ((t >= 5.0) & (t < 6.0))
    est = np.where(t >= 6.0, -6.0, 2.0)
    check = BaroMotionCheck()
    assert fly(check, est, zeros, zeros, baro, rejected=rejected)[0] == []
    # without the gate's word the same readings are a disagreement
    assert fly(BaroMotionCheck(), est, zeros, zeros, baro)[0] != []


def test_taken_back_when_the_port_clears_not_while_it_stays_blocked_away_from_the_vehicle() -> None:
    t = times(14.0)
    z, v, a = climb_profile(t, 4.0, 2.0, 1.5)
    rng = np.random.default_rng(4)
    noise = rng.normal(0.0, BARO_NOISE_M, t.size)
    blocked = (t >= 1.0) & (t < 9.0)
    baro = np.where(blocked, 2.0, 2.0 + z) + noise
    check = BaroMotionCheck()
    starts, refused = fly(check, 2.0 + z, v, a, baro)
    assert len(starts) == 1
    # still refused at 8.9 s: 2 m off, motionless (a hover proves nothing about a blocked port)
    assert refused[round(8.9 / DT_S)]
    # taken back once a whole window after the port cleared agrees, level and motion
    back = t[np.argmax(~refused & (t > 9.0))]
    assert 9.0 + 1.5 <= back <= 9.0 + 1.5 + 0.5
    assert check.counters["taken_back"] == 1


def test_not_judged_on_the_ground_or_across_a_gap() -> None:
    t = times(12.0)
    z, v, a = climb_profile(t, 4.0, 3.0, 1.0)
    baro = np.full(t.size, 2.0)  # blocked
    # the samples of the climb are not judged (ground effect, touchdown): nothing is seen
    check = BaroMotionCheck()
    judging = (t < 3.9) | (t > 5.2)
    assert fly(check, 2.0 + z, v, a, baro, judging=judging)[0] == []
    # nor in the first window after judging starts (the estimator's velocity is not trusted yet)
    check = BaroMotionCheck()
    assert fly(check, 2.0 + z, v, a, baro, judging=t > 3.0)[0] == []
    # readings missing for more than half a block in the middle of the climb: the window restarts
    check = BaroMotionCheck()
    baro_gap = np.where((t > 4.3) & (t < 4.75), math.nan, baro)
    assert fly(check, 2.0 + z, v, a, baro_gap)[0] == []
    # on the ground the barometer is the only height reference: a refusal ends
    check = BaroMotionCheck()
    assert fly(check, 2.0 + z, v, a, baro)[0] != [] and check.refusing
    check.on_ground()
    assert not check.refusing and check.take_reanchor() is None


def test_a_missing_acceleration_holds_the_last_one() -> None:
    t = times(9.0)
    z, v, a = climb_profile(t, 4.0, 4.0, 2.0)
    a_missing = np.where(np.arange(t.size) % 7 == 0, math.nan, a)  # refused ADXL readings
    check = BaroMotionCheck()
    assert fly(check, 2.0 + z, v, a_missing, 2.0 + z)[0] == [] and check.worst_m < 0.05


@pytest.mark.parametrize(("window_s", "block_s", "max_m"), [
    (0.25, 0.25, 1.5), (1.5, 0.0, 1.5), (1.5, 0.25, 0.0), (math.inf, 0.25, 1.5), (1.5, 0.25, math.nan)])
def test_bad_settings_are_refused(window_s: float, block_s: float, max_m: float) -> None:
    with pytest.raises(ValueError):
        BaroMotionCheck(window_s, block_s, max_m)


@settings(max_examples=40, deadline=None)
@given(height_m=st.floats(-6.0, 6.0), duration_s=st.floats(0.8, 4.0), t0_s=st.floats(0.5, 4.0),
       v_err_mps=st.floats(-0.3, 0.3), bias_mps2=st.floats(-0.05, 0.05), seed=st.integers(0, 2**16))
def test_property_no_refusal_of_a_barometer_that_measures_the_height(
        height_m: float, duration_s: float, t0_s: float, v_err_mps: float, bias_mps2: float, seed: int) -> None:
    """Any smooth climb or descent, with the error budget of the module docstring: the
    estimator's velocity off by up to 0.3 m/s, an accelerometer bias of up to 0.05 m/s^2,
    the barometer's own noise."""
    t = times(t0_s + duration_s + 3.0)
    z, v, a = climb_profile(t, t0_s, height_m, duration_s)
    rng = np.random.default_rng(seed)
    check = BaroMotionCheck()
    assert fly(check, z, v + v_err_mps, a + bias_mps2, z + rng.normal(0.0, BARO_NOISE_M, t.size))[0] == []


@settings(max_examples=40, deadline=None)
@given(height_m=st.floats(2.0, 6.0), sign=st.sampled_from([-1.0, 1.0]), duration_s=st.floats(0.5, 1.2),
       seed=st.integers(0, 2**16))
def test_property_a_blocked_port_is_seen_in_any_climb_or_descent_of_2_m_within_a_window(
        height_m: float, sign: float, duration_s: float, seed: int) -> None:
    """The worst case for the check: the estimator has fused the blocked reading all along
    (it never saw the vehicle move), so only a window that starts before the climb knows the
    vehicle's velocity; a climb of 2 m within one window (1.5 s) is seen."""
    t = times(duration_s + 7.0)
    z, v, a = climb_profile(t, 4.0, sign * height_m, duration_s)
    rng = np.random.default_rng(seed)
    check = BaroMotionCheck()
    est = np.zeros(t.size)  # a filter that fused the blocked reading
    assert fly(check, est, np.zeros(t.size), a, rng.normal(0.0, BARO_NOISE_M, t.size))[0] != []



def test_a_gap_while_refused_restarts_the_window_before_anything_is_judged() -> None:
    """After a gap (readings missing: an ADC resync) only a whole window is judged again: a
    port still blocked, with the vehicle descending through the trapped level, is not taken
    back on the few blocks since the gap (their short windows see too little motion)."""
    t = times(14.0)
    z, v, a = climb_profile(t, 4.0, 4.0, 1.5)  # 2 -> 6 m: the port is seen
    descent = (t >= 8.0) & (t < 11.0)  # then down at 1.2 m/s through the trapped 2-3.5 m
    z = z - 1.2 * np.clip(t - 8.0, 0.0, 3.0)
    v = v - np.where(descent, 1.2, 0.0)
    a = a + np.where(np.abs(t - 8.0) < DT_S / 2, -1.2 / DT_S, 0.0) + np.where(np.abs(t - 11.0) < DT_S / 2,
                                                                               1.2 / DT_S, 0.0)
    rng = np.random.default_rng(5)
    baro = 2.0 + rng.normal(0.0, BARO_NOISE_M, t.size)  # blocked at 2 m all along
    baro = np.where((t > 10.0) & (t < 10.3), math.nan, baro)
    starts, refused = fly(BaroMotionCheck(), 2.0 + z, v, a, baro)
    assert len(starts) == 1 and t[starts[0]] < 6.0
    assert refused[t > 10.3][: round(1.2 / DT_S)].all()  # one window after the gap: still refused
