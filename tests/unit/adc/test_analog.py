"""Analog front-end: sensor transfer functions, dynamics, noise, faults, the whole chain.

Reference values: NXP MPX5100 datasheet (Vout = Vs (0.009 P - 0.095); 0.2 / 4.7 V at 15 /
115 kPa, Vs = 5 V; error band 2.5 kPa x temperature multiplier; 1 ms response), ADI ADXL335
Rev. B (0.1 Vs per g, Vs/2 at 0 g, f = 1 / (2 pi 32k C), rms noise = density sqrt(pi/2 f)),
docs/protocols.md §3 table and docs/controllers.md §3.4.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib

import hypothesis.strategies as st
import numpy as np
import pytest
from hypothesis import given, settings

from emulators.analog import AnalogFrontEnd, AnalogParams, Adxl335Params, ConditioningParams, Mpx5100apParams
from emulators.analog.adxl335 import Adxl335
from emulators.analog.conditioning import OuNoise, amplify, first_order, two_stage, unamplify
from emulators.analog.inverse import (
    code_from_pressure_Pa,
    codes_from_f_B_mps2,
    f_B_mps2_from_codes,
    pressure_Pa_from_code,
)
from emulators.analog.mpx5100ap import Mpx5100ap, nominal_V, temperature_multiplier
from emulators.analog.params import G0_MPS2, baro_offset_V_for_field
from emulators.mcp3204 import Mcp3204, Mcp3204Params, fig61_decode, fig61_request, quantize
from hil.config import ConfigError, validate

REST = (0.0, 0.0, -G0_MPS2)
P0 = 101_325.0


def quiet(**kw: object) -> AnalogParams:
    """Default rig with no unit errors and no noise (the exact nominal chain)."""
    baro = Mpx5100apParams(unit_error_kPa=0.0, noise_V_rms=0.0)
    accel = Adxl335Params(
        sensitivity_tolerance=0.0,
        zero_g_tolerance_V_at_3V=(0.0, 0.0, 0.0),
        zero_g_drift_mg_per_C=(0.0, 0.0, 0.0),
        cross_axis_fraction=0.0,
        noise_density_ug_per_rtHz_at_3V=(0.0, 0.0, 0.0),
    )
    base = AnalogParams(baro=baro, accel=accel)
    cond = tuple(dataclasses.replace(c, noise_V_rms=0.0) for c in base.conditioning)
    return dataclasses.replace(base, conditioning=cond, **kw)  # type: ignore[arg-type]


def no_conditioning(p: AnalogParams) -> AnalogParams:
    cond = ConditioningParams(noise_V_rms=p.conditioning[1].noise_V_rms)
    return dataclasses.replace(p, conditioning=(cond, cond, cond, cond))


# -- MPX5100AP ------------------------------------------------------------------------------
def test_mpx5100ap_transfer_function_and_swing() -> None:
    p = Mpx5100apParams(unit_error_kPa=0.0)
    assert nominal_V(101_325.0, p) == pytest.approx(4.084625)
    assert nominal_V(15_000.0, p) == pytest.approx(0.2) and nominal_V(115_000.0, p) == pytest.approx(4.7)
    s = Mpx5100ap(p, np.random.default_rng(0))
    assert s.static_V(5_000.0, 25.0) == pytest.approx(0.2)
    assert s.static_V(130_000.0, 25.0) == pytest.approx(4.7)
    low = Mpx5100ap(dataclasses.replace(p, supply_V=4.75), np.random.default_rng(0))
    assert low.static_V(P0, 25.0) == pytest.approx(4.084625 * 4.75 / 5.0)  # ratiometric


def test_temperature_multiplier_and_error_band() -> None:
    table = {-60: 3, -40: 3, -20: 2, 0: 1, 50: 1, 85: 1, 105: 2, 125: 3, 150: 3}
    assert {t: temperature_multiplier(t) for t in table} == pytest.approx(table)
    errors = [Mpx5100ap(Mpx5100apParams(), np.random.default_rng(seed)).unit_error_kPa for seed in range(200)]
    assert max(map(abs, errors)) <= 2.5 and max(errors) > 2.0 and min(errors) < -2.0
    s = Mpx5100ap(Mpx5100apParams(unit_error_kPa=1.5), np.random.default_rng(0))
    assert s.static_V(P0, 25.0) - nominal_V(P0, s.params) == pytest.approx(1.5 * 0.045)
    assert s.static_V(P0, -40.0) - nominal_V(P0, s.params) == pytest.approx(3 * 1.5 * 0.045)


# -- ADXL335 ---------------------------------------------------------------------------------
def test_adxl335_ideal_transfer_orientation_and_saturation() -> None:
    a = Adxl335(quiet().accel, np.random.default_rng(0))
    assert a.static_V(np.array(REST), 25.0) == pytest.approx([1.65, 1.65, 1.98])  # Z up reads +1 g
    assert a.static_V(np.array([G0_MPS2, 0, 0]), 25.0) == pytest.approx([1.98, 1.65, 1.65])
    assert a.static_V(np.array([0, G0_MPS2, 0]), 25.0) == pytest.approx([1.65, 1.32, 1.65])  # sensor Y = -y_B
    assert a.static_V(np.array([30 * G0_MPS2, -30 * G0_MPS2, 0]), 25.0) == pytest.approx([3.1, 3.1, 1.65])
    assert a.static_V(np.array([-30 * G0_MPS2, 0, 0]), 25.0)[0] == pytest.approx(0.1)
    perm = dataclasses.replace(quiet().accel, mount_R_SB=((0, 1, 0), (-1, 0, 0), (0, 0, -1)))
    b = Adxl335(perm, np.random.default_rng(0))
    assert b.static_V(np.array([G0_MPS2, 0, 0]), 25.0) == pytest.approx([1.65, 1.32, 1.65])


def test_adxl335_unit_tolerances_within_datasheet() -> None:
    for seed in range(50):
        a = Adxl335(Adxl335Params(), np.random.default_rng(seed))
        assert np.all(np.abs(a.sensitivity_V_per_g / 0.33 - 1) <= 0.10)
        assert np.all(np.abs(a.zero_g_offset_V) <= np.array([0.165, 0.165, 0.33]) + 1e-12)
        off = a.cross_axis - np.eye(3)
        assert np.all(np.abs(off) <= 0.01) and np.all(np.diag(off) == 0)
    a = Adxl335(Adxl335Params(), np.random.default_rng(3))
    assert a.noise_V_rms[2] == pytest.approx(300e-6 * 0.3 * math.sqrt(math.pi / 2 / (2 * math.pi * 32e3 * 0.1e-6)))
    assert Adxl335Params().f3db_Hz(0) == pytest.approx(49.7, abs=0.1)


# -- dynamics --------------------------------------------------------------------------------
def test_first_and_two_stage_solutions_match_integration() -> None:
    assert first_order(0.0, 1.0, 1e-3, 1e-3) == pytest.approx(1 - math.exp(-1))
    for tau1, tau2 in ((0.5e-3, 1.6e-3), (1e-3, 1e-3), (2e-3, 0.3e-3)):
        x1 = x2 = 0.0
        h = 1e-7
        for _ in range(30_000):  # 3 ms of Euler with a small step
            x1, x2 = x1 + h * (1.0 - x1) / tau1, x2 + h * (x1 - x2) / tau2
        assert two_stage(0.0, 0.0, 1.0, tau1, tau2, 3e-3) == pytest.approx(x2, rel=1e-3)


def test_baro_step_response_is_one_ms_10_90() -> None:
    p = no_conditioning(quiet())
    fe = AnalogFrontEnd(p, np.random.default_rng(0))
    fe.update(0, 50_000.0, REST, 25.0)
    fe.update(0, 100_000.0, REST, 25.0)  # step at t = 0, held afterwards
    v0, v1 = nominal_V(50_000.0, p.baro), nominal_V(100_000.0, p.baro)
    frac = {t: (fe.volts(0, t) - v0) / (v1 - v0) for t in range(0, 3_000_000, 1000)}
    t10 = min(t for t, f in frac.items() if f >= 0.1)
    t90 = min(t for t, f in frac.items() if f >= 0.9)
    assert (t90 - t10) * 1e-9 == pytest.approx(1e-3, abs=2e-6)


def test_accel_rc_and_conditioning_rc_step_responses() -> None:
    p = quiet()
    fe = AnalogFrontEnd(p, np.random.default_rng(0))
    fe.update(0, P0, REST, 25.0)
    fe.update(0, P0, (G0_MPS2, 0.0, -G0_MPS2), 25.0)  # 1 g step on X
    tau_ns = round(32e3 * 0.1e-6 * 1e9)
    frac = (fe.volts(1, tau_ns) - 1.65) / 0.33
    assert frac == pytest.approx(1 - math.exp(-1), abs=1e-6)
    # updating in ticks gives the same as evaluating in between (exact discretisation)
    for k in range(1, 9):
        fe.update(k * 400_000, P0, (G0_MPS2, 0.0, -G0_MPS2), 25.0)
    assert fe.latched_V[1] == pytest.approx(1.65 + 0.33 * (1 - math.exp(-3.2e-3 / 3.2e-3)))


# -- noise -------------------------------------------------------------------------------------
def test_seeded_noise_is_reproducible_and_seed_dependent() -> None:
    def run(seed: int) -> list[float]:
        fe = AnalogFrontEnd(AnalogParams(), np.random.default_rng(seed))
        out = []
        for k in range(50):
            fe.update(k * 2_500_000, P0 - k, REST, 25.0)
            out += [fe.volts(ch, k * 2_500_000) for ch in range(4)]
        return out

    assert run(7) == run(7)
    assert run(7) != run(8)


def test_noise_levels() -> None:
    p = dataclasses.replace(quiet(), conditioning=(ConditioningParams(noise_V_rms=0.3e-3),) * 4)
    fe = AnalogFrontEnd(p, np.random.default_rng(1))
    fe.update(0, P0, REST, 25.0)
    e = np.array([fe.volts(0, 0) for _ in range(4000)])
    assert e.std() == pytest.approx(0.3e-3, rel=0.05)
    acc = dataclasses.replace(AnalogParams().accel, sensitivity_tolerance=0.0)
    fe2 = AnalogFrontEnd(dataclasses.replace(quiet(), accel=acc), np.random.default_rng(2))
    z = np.array([fe2.volts(3, k * 50_000_000) for k in range(3000)])  # 50 ms apart: independent
    assert z.std() == pytest.approx(fe2.accel.noise_V_rms[2], rel=0.06)
    same = {fe2.volts(3, 10**12) for _ in range(3)}
    assert len(same) == 1  # sensor noise of one instant is shared by its samples


def test_ou_noise_correlation() -> None:
    n = OuNoise(1.0, 1e-3, np.random.default_rng(0))
    xs = np.array([n.at(k * 100_000) for k in range(40_000)])  # 0.1 ms steps
    rho = np.corrcoef(xs[:-10], xs[10:])[0, 1]  # lag 1 ms
    assert rho == pytest.approx(math.exp(-1), abs=0.05)


def test_dither_without_conditioning_averages_below_one_lsb() -> None:
    p = no_conditioning(quiet())
    p = dataclasses.replace(p, conditioning=(ConditioningParams(noise_V_rms=0.6e-3),) * 4)
    fe = AnalogFrontEnd(p, np.random.default_rng(5))
    p_test = 101_000.0
    fe.update(0, p_test, REST, 25.0)
    v = nominal_V(p_test, p.baro)
    mean_code = np.mean([quantize(fe.volts(0, 0), 5.0) for _ in range(4000)])
    assert mean_code == pytest.approx(v * 4096 / 5.0 - 0.5, abs=0.05)  # floor: -0.5 LSB bias


# -- conditioning and the whole chain ---------------------------------------------------------
def test_amplifier_inverse_and_rails() -> None:
    c = ConditioningParams(gain=16.0, offset_V=3.8, reference_V=0.1)
    for v in (3.8, 3.9, 4.0):
        assert unamplify(amplify(v, c), c) == pytest.approx(v)
    assert amplify(5.0, c) == 5.0 and amplify(3.0, c) == 0.0


def test_default_rig_codes_and_table_value_without_conditioning() -> None:
    fe = AnalogFrontEnd(quiet(), np.random.default_rng(0))
    fe.update(0, P0, REST, 25.0)
    adc = Mcp3204(Mcp3204Params(), fe.volts)
    codes = []
    for ch in range(4):
        adc.select(0)
        codes.append(fig61_decode(adc.exchange(fig61_request(ch), 0)))
        adc.deselect(0)
    assert codes == [2048, 1351, 1351, 1622]  # 2.5 V, 1.65 V, 1.65 V, 1.98 V
    bare = AnalogFrontEnd(no_conditioning(quiet()), np.random.default_rng(0))
    bare.update(0, P0, REST, 25.0)
    assert quantize(bare.volts(0, 0), 5.0) == 3346  # docs/protocols.md §3: h = 0 m


def test_field_offset_helper() -> None:
    off = baro_offset_V_for_field(79_495.0, 16.0)  # a 2 km field
    cond = ConditioningParams(gain=16.0, offset_V=off)
    assert amplify(nominal_V(79_495.0, Mpx5100apParams()), cond) == pytest.approx(2.5)


@settings(deadline=None, max_examples=150)
@given(st.floats(min_value=97_900.0, max_value=104_700.0))
def test_inverse_pressure_within_one_lsb(p_Pa: float) -> None:
    params = quiet()
    lsb_Pa = 5.0 / 4096 / 16 / 0.045 * 1000  # 1.7 Pa at the x16 stage
    assert abs(pressure_Pa_from_code(code_from_pressure_Pa(p_Pa, params), params) - p_Pa) <= lsb_Pa
    bare = no_conditioning(params)
    assert abs(pressure_Pa_from_code(code_from_pressure_Pa(p_Pa, bare), bare) - p_Pa) <= 27.2


@settings(deadline=None, max_examples=150)
@given(st.lists(st.floats(-2.5 * G0_MPS2, 2.5 * G0_MPS2), min_size=3, max_size=3))
def test_inverse_accel_within_one_lsb(f: list[float]) -> None:
    params = quiet()
    back = f_B_mps2_from_codes(codes_from_f_B_mps2(np.array(f), params), params)
    lsb_mps2 = 5.0 / 4096 / 0.33 * G0_MPS2  # 3.7 mg
    assert np.all(np.abs(back - np.array(f)) <= lsb_mps2)


# -- faults ------------------------------------------------------------------------------------
def test_channel_stuck_and_open() -> None:
    p = dataclasses.replace(quiet(), open_input_noise_V_rms=0.0)
    fe = AnalogFrontEnd(p, np.random.default_rng(0))
    fe.update(0, P0, REST, 25.0)
    fe.set_channel_stuck(2, 4.5)
    assert fe.volts(2, 0) == 4.5
    fe.set_channel_stuck(2, None)
    assert fe.volts(2, 0) == pytest.approx(1.65)
    fe.set_channel_open(1, True)
    assert fe.volts(1, 1_000_000) == pytest.approx(1.65)  # starts from its last value
    assert fe.volts(1, 1_000_000 + 50_000_000) == pytest.approx(1.65 * math.exp(-1))
    fe.set_channel_open(1, False)
    assert fe.volts(1, 60_000_000) == pytest.approx(1.65)


def test_baro_fault_bias_scale_frozen_noise() -> None:
    p = no_conditioning(quiet())
    fe = AnalogFrontEnd(p, np.random.default_rng(0))
    fe.set_baro_fault(bias_Pa=-1000.0)
    fe.update(0, P0, REST, 25.0)
    assert fe.volts(0, 0) == pytest.approx(nominal_V(P0 - 1000.0, p.baro))
    fe.set_baro_fault(scale=0.5)
    fe.update(0, P0, REST, 25.0)
    assert fe.volts(0, 10**9) == pytest.approx(nominal_V(P0 * 0.5, p.baro))
    fe.set_baro_fault(frozen=True)
    held = fe.volts(0, 10**9)
    fe.update(2 * 10**9, 90_000.0, REST, 25.0)
    assert fe.volts(0, 2 * 10**9) == held
    fe.set_baro_fault()
    assert fe.volts(0, 2 * 10**9) == pytest.approx(nominal_V(90_000.0, p.baro))
    noisy = AnalogFrontEnd(no_conditioning(AnalogParams()), np.random.default_rng(0))
    noisy.update(0, P0, REST, 25.0)
    noisy.set_baro_fault(noise_factor=10.0)
    spread = np.std([noisy.volts(0, k * 10**7) for k in range(500)])
    assert spread > 4e-3  # 10 x 0.5 mV sensor noise


def test_accel_fault_bias_saturate_frozen() -> None:
    fe = AnalogFrontEnd(quiet(), np.random.default_rng(0))
    fe.set_accel_fault(bias_mps2=(G0_MPS2, 0.0, 0.0))
    fe.update(0, P0, REST, 25.0)
    assert fe.volts(1, 10**9) == pytest.approx(1.98)
    fe.set_accel_fault(saturate=True)
    fe.update(10**9, P0, (0.1, -0.1, -G0_MPS2), 25.0)
    assert [fe.volts(ch, 2 * 10**9) for ch in (1, 2, 3)] == pytest.approx([3.1, 3.1, 3.1])
    fe.set_accel_fault(frozen=True, scale=2.0)
    held = [fe.volts(ch, 2 * 10**9) for ch in (1, 2, 3)]
    fe.update(3 * 10**9, P0, (5.0, 5.0, 5.0), 25.0)
    assert [fe.volts(ch, 3 * 10**9) for ch in (1, 2, 3)] == held


def test_unconnected_input_floats() -> None:
    p = dataclasses.replace(quiet(), channel_map=("baro", "accel_x", "accel_y", "none"))
    fe = AnalogFrontEnd(p, np.random.default_rng(0))
    fe.update(0, P0, REST, 25.0)
    assert abs(fe.volts(3, 10**9)) < 0.05


# -- rig TOML -----------------------------------------------------------------------------------
RIG = """
[analog]
channel_map = ["baro", "accel_x", "accel_y", "accel_z"]
[analog.baro]
supply_V = 5.0
noise_V_rms = 0.0005
[analog.accel]
supply_V = 3.3
filter_C_uF = [0.1, 0.1, 0.1]
mount_R_SB = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]
[[analog.conditioning]]
gain = 16.0
offset_V = 3.928375
rc_cutoff_Hz = 100.0
[[analog.conditioning]]
[[analog.conditioning]]
[[analog.conditioning]]
"""


def test_rig_toml_validates_into_params_and_rejects_unknown_keys() -> None:
    table = tomllib.loads(RIG)["analog"]
    params = validate(AnalogParams, table, file="rig.toml", section="analog")
    assert params.conditioning[0].gain == 16.0 and params.conditioning[1] == ConditioningParams()
    assert params.conditioning[0].offset_V == pytest.approx(AnalogParams().conditioning[0].offset_V)
    with pytest.raises(ConfigError, match="gian"):
        validate(AnalogParams, {"conditioning": [{"gian": 2}] * 4}, file="rig.toml", section="analog")
