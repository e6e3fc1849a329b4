"""Plausibility of the ADC's converted readings: what a bit error in a data byte with good
acks (fault-adc-garbage's wire.bit_flips) turns into, and what gets through."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.drivers.analog import (
    G0_MPS2,
    AccelChainParams,
    AnalogChain,
    BaroChainParams,
)
from flightcode.estimation.plausibility import AdcPlausibility, FlatLine, PlausibilityParams

CHAIN = AnalogChain(5.0, BaroChainParams(), AccelChainParams())
#: The baro's code at a sea-level field (2.5 V on the pin with the default stage).
BARO_CODE = math.floor(4096 * 2.5 / 5.0)
#: The ADXL335's codes at rest, level (sensor X, Y at 0 g = 1.65 V, sensor Z at +1 g = 1.98 V).
ACCEL_CODES = (math.floor(4096 * 1.65 / 5.0), math.floor(4096 * 1.65 / 5.0), math.floor(4096 * 1.98 / 5.0))


def a_up(f_B: tuple[float, float, float]) -> float:
    """Vertical acceleration of a level vehicle, m/s^2 (up)."""
    return -f_B[2] - G0_MPS2


def test_baro_range_and_step() -> None:
    chk = AdcPlausibility(PlausibilityParams())
    assert chk.baro_Pa(101_325.0) == 101_325.0  # first reading: range only
    assert chk.baro_Pa(101_380.0) == 101_380.0  # +55 Pa: within the step
    assert chk.baro_Pa(101_450.0) is None  # +70 Pa: refused...
    assert chk.baro_Pa(101_455.0) == 101_455.0  # ...and the level it jumped to is the next reference
    assert chk.baro_Pa(120_000.0) is None  # beyond the MPX5100AP's 115 kPa
    assert chk.baro_Pa(101_455.0) == 101_455.0  # an out-of-range reading is no reference
    assert chk.baro_Pa(None) is None
    assert chk.baro_Pa(95_000.0) == 95_000.0  # after a missing reading: range only
    assert chk.baro_Pa(14_000.0) is None
    assert dict(chk.counters) == {"baro_step": 1, "baro_out_of_range": 2} and chk.refused == 3


def test_single_bit_errors_in_the_baro_code() -> None:
    """One code is 1.7 Pa (0.14 m): bits 6-11 move the pressure by 108 Pa (9 m) or more and
    are refused here, with the good reading after them (compared with the corrupted one);
    bits 0-5 (54 Pa at most) are left to the altitude filter's innovation gate. At mid-scale
    (2048) bit 11 gives code 0, a rail, which the analog chain itself refuses."""
    p_good = CHAIN.baro_pressure_Pa(BARO_CODE)
    assert p_good is not None and abs(p_good - 101_325.0) < 2.0
    for bit in range(12):
        chk = AdcPlausibility(PlausibilityParams())
        chk.baro_Pa(p_good)
        p_bad = CHAIN.baro_pressure_Pa(BARO_CODE ^ (1 << bit))
        if p_bad is None:  # mid-scale 2048 with its top bit flipped is the rail: the chain refuses it
            assert BARO_CODE ^ (1 << bit) == 0 and bit == 11
            continue
        refused = chk.baro_Pa(p_bad) is None
        assert refused is (bit >= 6), bit
        assert (chk.baro_Pa(p_good) is None) is refused


def test_accel_bit_errors_are_caught_by_range_or_by_the_xsens() -> None:
    """Sensor Z (body -z) at 1 g: the top bit puts the pin above the 3.3 V supply (beyond
    +-5 g: refused by range); bits 7-10 move the vertical acceleration by 4.6 m/s^2 or more,
    which the XSENS on the same airframe does not see (refused by agreement); bits 0-6
    (2.3 m/s^2 at most) pass, as does the good reading."""
    chk = AdcPlausibility(PlausibilityParams())
    good = CHAIN.accel_B_mps2(*ACCEL_CODES)
    assert chk.accel_in_range(good) and chk.accel_agrees(a_up(good), 0.0)
    for bit in range(12):
        codes = list(ACCEL_CODES)
        codes[2] ^= 1 << bit
        f = CHAIN.accel_B_mps2(*codes)
        in_range = chk.accel_in_range(f)
        assert in_range is (bit < 11), bit
        if in_range:
            assert chk.accel_agrees(a_up(f), 0.0) is (bit < 7), bit
    assert chk.counters == {"accel_out_of_range": 1, "accel_disagrees_xsens": 4}
    assert not chk.accel_in_range((0.0, math.nan, -9.8))


@settings(max_examples=60, deadline=None)
@given(start=st.floats(96_000.0, 103_000.0),
       steps=st.lists(st.floats(-59.9, 59.9), min_size=1, max_size=50),
       jump=st.floats(60.1, 5_000.0), sign=st.sampled_from([-1.0, 1.0]))
def test_believable_pressures_pass_and_any_larger_step_is_refused(start: float, steps: list[float], jump: float,
                                                                  sign: float) -> None:
    chk = AdcPlausibility(PlausibilityParams())
    p = start
    assert chk.baro_Pa(p) == p
    for d in steps:
        p += d
        assert chk.baro_Pa(p) == p
    assert chk.baro_Pa(p + sign * jump) is None
    assert chk.refused == 1


def test_limits_come_from_the_params() -> None:
    chk = AdcPlausibility(PlausibilityParams(baro_max_step_Pa=10.0, accel_max_g=2.0, accel_xsens_tolerance_mps2=0.5))
    chk.baro_Pa(100_000.0)
    assert chk.baro_Pa(100_011.0) is None
    assert not chk.accel_in_range((0.0, 0.0, -2.1 * G0_MPS2)) and chk.accel_in_range((0.0, 0.0, -1.9 * G0_MPS2))
    assert not chk.accel_agrees(0.6, 0.0) and chk.accel_agrees(0.4, 0.0)


# -- the barometer's flat-line test ---------------------------------------------------------------
@settings(max_examples=200, deadline=None)
@given(n=st.integers(2, 12), min_std=st.floats(0.1, 10.0),
       xs=st.lists(st.floats(90_000.0, 110_000.0), min_size=1, max_size=60),
       steps=st.lists(st.floats(-3.0, 3.0), min_size=1, max_size=60))
def test_flat_line_is_the_windows_standard_deviation(n: int, min_std: float, xs: list[float],
                                                     steps: list[float]) -> None:
    """Every verdict is numpy's population std of the last n values against min_std (not yet
    full: never flat), over levels of a whole pressure range and small wanderings."""
    values = [x + s for x in xs[:1] for s in steps] + xs  # a quiet stretch, then jumps
    det = FlatLine(n, min_std)
    for i, v in enumerate(values):
        flat = det.add(v)
        if i + 1 < n:
            assert flat is False
            continue
        std = float(np.std(values[i + 1 - n: i + 1]))
        if abs(std - min_std) > 1e-6 * (1.0 + min_std):  # away from the bound's rounding
            assert flat is (std < min_std), (i, std)
        assert det.flat is flat


def test_flat_line_window_needs_two_values() -> None:
    with pytest.raises(ValueError, match="at least 2"):
        FlatLine(1, 1.0)


def _baro_chk() -> AdcPlausibility:
    return AdcPlausibility(PlausibilityParams())


def test_a_live_barometer_is_never_a_flat_line() -> None:
    """5.3 Pa of noise per reading (the x16 chain), correlated from reading to reading as the
    sensor's output filter makes it (lag-1 0.29), at a hover and through a climb: 200000
    readings (8 min at 400 Hz), none refused."""
    rng = np.random.default_rng(1)
    chk, e, rho = _baro_chk(), 0.0, 0.29
    for k in range(200_000):
        e = rho * e + math.sqrt(1.0 - rho * rho) * 5.3 * rng.standard_normal()
        level = 100_000.0 - (12.0 * 2.0 * min(1.0, max(0.0, (k - 100_000) / 800.0)))  # a 2 m climb
        assert chk.baro_Pa(level + e) is not None or chk.counters["baro_step"], k
    assert chk.counters["baro_flat"] == 0


def test_a_stuck_barometer_is_refused_until_it_moves_again() -> None:
    """A held output leaves the pin's noise (0.3 code, 0.5 Pa) on the code: refused from the
    window's end on; live readings are taken again at once."""
    rng = np.random.default_rng(2)
    chk = _baro_chk()
    n = PlausibilityParams().baro_flat_readings
    live = [100_000.0 + 5.3 * rng.standard_normal() for _ in range(200)]
    stuck = [100_003.0 + 0.5 * rng.standard_normal() for _ in range(400)]
    assert all(chk.baro_Pa(p) is not None for p in live)
    taken = [chk.baro_Pa(p) is not None for p in stuck]
    assert all(taken[: n // 2]) and not any(taken[n:]) and chk.baro_flat
    assert chk.counters["baro_flat"] >= len(stuck) - n
    back = [chk.baro_Pa(100_024.0 + 5.3 * rng.standard_normal()) for _ in range(50)]  # 2 m higher, live
    assert all(p is not None for p in back[1:]) and not chk.baro_flat


def test_flat_line_test_off() -> None:
    chk = AdcPlausibility(PlausibilityParams(baro_flat_readings=0))
    assert all(chk.baro_Pa(100_000.0) == 100_000.0 for _ in range(500))
    assert chk.refused == 0 and not chk.baro_flat
