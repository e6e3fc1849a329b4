"""Plausibility of the ADC's converted readings: what a bit error in a data byte with good
acks (fault-adc-garbage's wire.bit_flips) turns into, and what gets through."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.drivers.analog import (
    G0_MPS2,
    AccelChainParams,
    AnalogChain,
    BaroChainParams,
)
from flightcode.estimation.plausibility import AdcPlausibility, PlausibilityParams

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
