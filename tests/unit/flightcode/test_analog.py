"""ADC codes -> pressure, altitude and specific force, against an independent forward model."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.drivers.analog import (
    AccelChainParams,
    AccelRestOffset,
    AnalogChain,
    BaroChainParams,
    BaroReference,
    isa_altitude_m,
    parse_mount,
)

G = 9.80665


def baro_code(p_Pa: float, gain: float = 16.0, offset_V: float = 3.928375, ref_V: float = 0.0) -> int:
    """MPX5100AP (Vs 5 V) -> offset/gain stage -> MCP3204 (Vref 5 V), floor quantiser."""
    v = 5.0 * (0.009 * p_Pa / 1000.0 - 0.095)
    v_adc = gain * (v - offset_V) + ref_V
    return min(4095, max(0, math.floor(4096 * v_adc / 5.0)))


def accel_code(a_mps2: float) -> int:
    """ADXL335 at 3.3 V, 330 mV/g around 1.65 V, into the 5 V MCP3204."""
    v = 3.3 / 2 + 0.1 * 3.3 * a_mps2 / G
    return math.floor(4096 * v / 5.0)


def isa_pressure_Pa(h_m: float) -> float:
    """docs/protocols.md 3: P(h) = 101325 (1 - 2.25577e-5 h)^5.25588."""
    return 101325.0 * (1.0 - 2.25577e-5 * h_m) ** 5.25588


def test_documented_sea_level_code_without_the_gain_stage() -> None:
    # docs/protocols.md 3 table: 101.325 kPa -> 4.085 V -> code 3346 with no conditioning stage.
    assert baro_code(101325.0, gain=1.0, offset_V=0.0) == 3346
    chain = AnalogChain(5.0, BaroChainParams(gain=1.0, offset_V=0.0), AccelChainParams())
    p = chain.baro_pressure_Pa(3346)
    assert p == pytest.approx(101325.0, abs=27.1)  # one LSB = 27.1 Pa (docs/controllers.md 3.4)


@settings(max_examples=80, deadline=None)
@given(p_Pa=st.floats(98_000.0, 104_600.0))
def test_pressure_inverse_within_one_lsb(p_Pa: float) -> None:
    chain = AnalogChain(5.0, BaroChainParams(), AccelChainParams())
    lsb_Pa = 5.0 / 4096 / 16 / (5.0 * 0.009) * 1000  # 1.7 Pa
    assert chain.baro_pressure_Pa(baro_code(p_Pa)) == pytest.approx(p_Pa, abs=lsb_Pa / 2 + 1e-6)


def test_rails_are_out_of_range() -> None:
    chain = AnalogChain(5.0, BaroChainParams(), AccelChainParams())
    assert chain.baro_pressure_Pa(0) is None and chain.baro_pressure_Pa(4095) is None
    assert baro_code(90_000.0) == 0  # a field at ~1 km is outside the default window


def test_codes_near_a_rail_are_no_pressure() -> None:
    """An open input floats to a rail with noise, a saturated stage sits there: within
    ``rail_margin_V`` (0.05 V = 41 codes) of either rail a code is refused, not a reading
    80-500 m from the field (scenario fault-baro-wire)."""
    chain = AnalogChain(5.0, BaroChainParams(), AccelChainParams())
    margin = math.ceil(0.05 / (5.0 / 4096))
    assert margin == 41
    for code in (1, 7, margin, 4095 - margin, 4094):
        assert chain.baro_pressure_Pa(code) is None, code
    assert chain.baro_pressure_Pa(margin + 1) is not None
    assert chain.baro_pressure_Pa(4094 - margin) is not None
    exact = AnalogChain(5.0, BaroChainParams(rail_margin_V=0.0), AccelChainParams())
    assert exact.baro_pressure_Pa(0) is None and exact.baro_pressure_Pa(4095) is None
    assert exact.baro_pressure_Pa(1) is not None and exact.baro_pressure_Pa(4094) is not None


def test_isa_altitude_matches_the_documented_table() -> None:
    # docs/protocols.md 3: 0 m 101.325 kPa, 500 m 95.461, 1000 m 89.875, 2000 m 79.495
    for h, p_kPa in ((0, 101.325), (500, 95.461), (1000, 89.875), (2000, 79.495)):
        assert isa_altitude_m(p_kPa * 1000) == pytest.approx(h, abs=1.0)


def test_relative_altitude_from_the_boot_reference() -> None:
    ref = BaroReference(average_ns=100_000_000)
    p0 = isa_pressure_Pa(50.0)
    for k in range(41):  # 0..100 ms of sensor time
        ready = ref.add(p0 + (3.0 if k % 2 else -3.0), k * 2_500_000)
    assert ready and ref.p_ref_Pa == pytest.approx(p0, abs=0.2)
    assert ref.altitude_m(isa_pressure_Pa(55.0)) == pytest.approx(5.0, abs=0.05)
    assert ref.altitude_m(p0) == pytest.approx(0.0, abs=0.02)


def test_reference_not_ready_before_the_averaging_time() -> None:
    ref = BaroReference(average_ns=1_000_000_000)
    assert not ref.add(100_000.0, 0)
    assert not ref.add(100_000.0, 999_999_999)
    assert ref.add(100_000.0, 1_000_000_000)


def test_default_field_sits_at_mid_scale() -> None:
    # The bench's default rig puts a sea-level field at 2.5 V on the ADC pin.
    assert baro_code(101_325.0) == math.floor(4096 * 2.5 / 5.0)


def test_accel_level_at_rest_and_scaling() -> None:
    chain = AnalogChain(5.0, BaroChainParams(), AccelChainParams(mount_B=("+X", "+Y", "+Z")))
    f = chain.accel_B_mps2(accel_code(0.0), accel_code(0.0), accel_code(-G))
    assert f == pytest.approx((0.0, 0.0, -G), abs=0.036)  # 3.70 mg = 0.036 m/s^2 per LSB (docs/controllers.md 3.4)
    f = chain.accel_B_mps2(accel_code(2 * G), accel_code(-1.5 * G), accel_code(0.0))
    assert f == pytest.approx((2 * G, -1.5 * G, 0.0), abs=0.036)


def test_mounting_map() -> None:
    # Default: sensor X forward, Y left, Z up (reads +1 g at rest): body y = -Y, body z = -Z.
    chain = AnalogChain(5.0, BaroChainParams(), AccelChainParams())
    f = chain.accel_B_mps2(accel_code(1.0), accel_code(2.0), accel_code(G))
    assert f == pytest.approx((1.0, -2.0, -G), abs=0.036)
    chain = AnalogChain(5.0, BaroChainParams(), AccelChainParams(mount_B=("-Y", "+Z", "+X")))
    f = chain.accel_B_mps2(accel_code(1.0), accel_code(2.0), accel_code(3.0))
    assert f == pytest.approx((-2.0, 3.0, 1.0), abs=0.036)


@pytest.mark.parametrize("bad", [("+X", "+X", "+Z"), ("X", "+Y", "+Z"), ("+Q", "+Y", "+Z")])
def test_bad_mounting_is_rejected(bad: tuple[str, str, str]) -> None:
    with pytest.raises(ValueError):
        parse_mount(bad)


def test_adc_bin_centre() -> None:
    chain = AnalogChain(5.0, BaroChainParams(), AccelChainParams())
    assert chain.volts(0) == pytest.approx(0.5 * 5 / 4096)
    assert chain.volts(4095) == pytest.approx(4095.5 * 5 / 4096)


def test_worked_examples_of_the_analog_chain_doc() -> None:
    # docs/analog-chain.md section 4 and 5 (default rig, nominal parts).
    chain = AnalogChain(5.0, BaroChainParams(), AccelChainParams())
    assert chain.baro_pressure_Pa(1266) == pytest.approx(100_000.0, abs=0.1)
    assert chain.baro_pressure_Pa(2048) == pytest.approx(101_325.8, abs=0.1)
    assert chain.accel_B_mps2(1351, 1351, 1622) == pytest.approx((0.0, 0.0, -G), abs=0.03)


@settings(max_examples=30, deadline=None)
@given(roll=st.floats(-0.2, 0.2), pitch=st.floats(-0.2, 0.2),
       offset=st.tuples(st.floats(-4.9, 4.9), st.floats(-4.9, 4.9), st.floats(-9.8, 9.8)))
def test_accel_rest_offset_is_learnt_on_a_tilted_ground(roll: float, pitch: float,
                                                        offset: tuple[float, float, float]) -> None:
    # At rest f_B = R_NB^T (0, 0, -g): independent rotation of the gravity vector.
    c, s = math.cos, math.sin
    f_rest = (G * s(pitch), -G * s(roll) * c(pitch), -G * c(roll) * c(pitch))
    cal = AccelRestOffset()
    for k in range(50):
        wobble = 0.01 * ((k % 5) - 2)  # zero-mean noise
        cal.add(tuple(f + o + wobble for f, o in zip(f_rest, offset)), roll, pitch)  # type: ignore[arg-type]
    assert cal.fix() == pytest.approx(offset, abs=1e-9)
    assert cal.correct(tuple(f + o for f, o in zip(f_rest, offset))) == pytest.approx(f_rest, abs=1e-9)  # type: ignore[arg-type]


def test_accel_rest_offset_rejects_an_unbelievable_part() -> None:
    cal = AccelRestOffset()
    cal.add((0.0, 0.0, +G), 0.0, 0.0)  # 2 g off: the board upside down, or a loose connector
    assert cal.fix() == (0.0, 0.0, 0.0) and cal.rejected
    assert AccelRestOffset().fix() == (0.0, 0.0, 0.0)  # nothing added: nothing to remove
