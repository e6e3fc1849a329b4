"""Vibration through the sensors' bandwidths (emulators/vibration.py and its use by the ADXL335
chain and the XSENS): amplitude |H| and phase arg H at a frequency, the ADXL335's documented
-3 dB point from its capacitor, the XSENS identities, and sampling that aliases like a real
sampled sensor."""

from __future__ import annotations

import dataclasses
import math

import hypothesis.strategies as st
import numpy as np
import pytest
from hypothesis import given, settings

from emulators import vibration
from emulators.analog import AnalogFrontEnd
from emulators.analog.params import G0_MPS2
from emulators.xsens.device import MtiDevice
from emulators.xsens.params import XsensParams
from hil.plant.records import VibrationTone
from tests.unit.adc.test_analog import quiet

TICK_NS = 2_500_000


def tone_x(freq_Hz: float, amp: float, phase: float = 0.0) -> VibrationTone:
    """amp cos(phase + w t) on body x."""
    return VibrationTone(2 * math.pi * freq_Hz, phase, (amp, 0.0, 0.0), (0.0, 0.0, 0.0))


def fit_sine(t_s: np.ndarray, v: np.ndarray, freq_Hz: float) -> tuple[float, float]:
    """Least-squares amplitude and phase (of cos) of ``v`` at ``freq_Hz`` (plus an offset)."""
    w = 2 * math.pi * freq_Hz
    a = np.column_stack([np.cos(w * t_s), np.sin(w * t_s), np.ones_like(t_s)])
    (c, s, _), *_ = np.linalg.lstsq(a, v, rcond=None)
    return float(math.hypot(c, s)), float(math.atan2(-s, c))


# -- the responses ---------------------------------------------------------------------------
def test_first_order_is_minus_3_db_and_minus_45_deg_at_its_corner() -> None:
    h = vibration.first_order(2 * math.pi * 50.0, 50.0)
    assert abs(h) == pytest.approx(1 / math.sqrt(2)) and math.degrees(np.angle(h)) == pytest.approx(-45.0)
    assert vibration.first_order(1e6, math.inf) == 1.0 and vibration.first_order(1e6, 0.0) == 1.0


def test_butterworth2_is_minus_3_db_and_minus_90_deg_at_its_corner() -> None:
    h = vibration.butterworth2(2 * math.pi * 30.0, 30.0)
    assert abs(h) == pytest.approx(1 / math.sqrt(2)) and math.degrees(np.angle(h)) == pytest.approx(-90.0)
    assert abs(vibration.butterworth2(2 * math.pi * 300.0, 30.0)) == pytest.approx(1e-2, rel=1e-3)  # -40 dB/dec
    with pytest.raises(ValueError):
        vibration.lowpass(1.0, 30.0, 3)


def test_window_average_is_the_mean_of_the_sinusoid_over_the_window() -> None:
    T, w = 2.5e-3, 2 * math.pi * 97.0
    h = vibration.window_average(w, T)
    t = np.linspace(-T, 0.0, 100_001)
    mean = np.trapezoid(np.exp(1j * w * t), t) / T  # mean of e^(j w t) over [-T, 0]
    assert h == pytest.approx(complex(mean), abs=1e-9)
    assert abs(vibration.window_average(2 * math.pi * 400.0, T)) == pytest.approx(0.0, abs=1e-12)  # a null at 1/T


@settings(max_examples=60, deadline=None)
@given(f=st.floats(1.0, 2000.0), fc=st.floats(1.0, 1000.0), order=st.sampled_from([1, 2]),
       dt=st.floats(-0.01, 0.01), phase=st.floats(-10.0, 10.0))
def test_property_tone_value_is_re_of_h_times_the_phasor(
    f: float, fc: float, order: int, dt: float, phase: float
) -> None:
    """For any tone and low-pass: |value| bounded by |H| |amplitude|, and the value equals
    Re{H A e^(j phi)} computed with complex numbers; |H| falls with frequency."""
    tone = VibrationTone(2 * math.pi * f, phase, (0.3, -0.1, 0.02), (0.05, 0.2, -0.07))
    h = vibration.lowpass(tone.omega_radps, fc, order)
    got = vibration.tone_value(tone, h, dt)
    amp = np.array(tone.re) + 1j * np.array(tone.im)
    expect = (h * amp * np.exp(1j * (phase + tone.omega_radps * dt))).real
    np.testing.assert_allclose(got, expect, atol=1e-12)
    assert all(abs(g) <= abs(h) * abs(a) + 1e-12 for g, a in zip(got, amp, strict=True))
    assert abs(vibration.lowpass(2 * tone.omega_radps, fc, order)) < abs(h)


# -- ADXL335 through the analog chain ------------------------------------------------------------
def adxl_chain(C_uF: float, **accel: object) -> AnalogFrontEnd:
    p = quiet()
    acc = dataclasses.replace(p.accel, filter_C_uF=(C_uF, C_uF, C_uF), **accel)
    return AnalogFrontEnd(dataclasses.replace(p, accel=acc), np.random.default_rng(0))


def sampled_x_volts(
    fe: AnalogFrontEnd, tone: VibrationTone, n: int = 4000, step_ns: int = 50_000
) -> tuple[np.ndarray, np.ndarray]:
    """Level at rest, the tone set at t = 0; CH1 (sensor X = body x) sampled every step_ns."""
    rest = (0.0, 0.0, -G0_MPS2)
    fe.update(0, 101_325.0, rest, 25.0)
    fe.set_vibration(0, (tone,))
    t = np.arange(n) * step_ns
    v = []
    for ti in t:
        fe.update(int(ti), 101_325.0, rest, 25.0)
        v.append(fe.volts(1, int(ti)))
    return t * 1e-9, np.array(v)


@pytest.mark.parametrize("C_uF", [0.1, 0.047, 0.22])
def test_adxl335_capacitor_sets_the_documented_minus_3_db_point(C_uF: float) -> None:
    """f-3dB = 1 / (2 pi 32 kOhm C) (ADXL335 Rev. B): a tone at that frequency reads 1/sqrt(2)
    of its amplitude (in volts: 0.1 Vs per g) and lags 45 deg."""
    f3db = 1.0 / (2 * math.pi * 32e3 * C_uF * 1e-6)
    fe = adxl_chain(C_uF)
    amp = 2.0  # m/s^2
    t, v = sampled_x_volts(fe, tone_x(f3db, amp, phase=0.3))
    got_amp, got_phase = fit_sine(t, v, f3db)
    v_per_mps2 = 0.1 * 3.3 / G0_MPS2
    assert got_amp == pytest.approx(amp * v_per_mps2 / math.sqrt(2), rel=1e-6)
    assert got_phase == pytest.approx(0.3 - math.pi / 4, abs=1e-6)


def test_adxl335_default_chain_at_hover_rotor_speed() -> None:
    """The rig's 0.1 uF (49.7 Hz) at 97 Hz: |H| = 0.456, -63 deg (docs/vibration.md)."""
    h = 1 / complex(1, 97.0 / (1 / (2 * math.pi * 32e3 * 0.1e-6)))
    assert abs(h) == pytest.approx(0.456, abs=1e-3) and math.degrees(np.angle(h)) == pytest.approx(-62.9, abs=0.1)
    fe = adxl_chain(0.1)
    t, v = sampled_x_volts(fe, tone_x(97.0, 1.0))
    assert fit_sine(t, v, 97.0)[0] == pytest.approx(abs(h) * 0.1 * 3.3 / G0_MPS2, rel=1e-6)


def test_adxl335_vibration_goes_through_the_channel_rc_too() -> None:
    p = quiet()
    cond = list(p.conditioning)
    cond[1] = dataclasses.replace(cond[1], rc_cutoff_Hz=100.0)
    with_rc = dataclasses.replace(p, conditioning=tuple(cond))  # type: ignore[arg-type]
    fe = AnalogFrontEnd(with_rc, np.random.default_rng(0))
    t, v = sampled_x_volts(fe, tone_x(97.0, 1.0))
    h = 1 / (complex(1, 97.0 / 49.736) * complex(1, 97.0 / 100.0))
    assert fit_sine(t, v, 97.0)[0] == pytest.approx(abs(h) * 0.1 * 3.3 / G0_MPS2, rel=1e-3)


def test_adxl335_faults_act_on_the_vibration() -> None:
    """Scale scales it; saturation pins the output (no vibration on the rail); freeze holds."""
    fe = adxl_chain(0.1)
    t, v = sampled_x_volts(fe, tone_x(97.0, 1.0))
    base = fit_sine(t, v, 97.0)[0]
    fe = adxl_chain(0.1)
    fe.set_accel_fault(scale=2.0)
    t, v = sampled_x_volts(fe, tone_x(97.0, 1.0))
    assert fit_sine(t, v, 97.0)[0] == pytest.approx(2 * base, rel=1e-6)
    fe = adxl_chain(0.1)
    fe.set_accel_fault(saturate=True)
    assert np.ptp(sampled_x_volts(fe, tone_x(97.0, 1.0))[1]) == 0.0
    fe = adxl_chain(0.1)
    fe.set_accel_fault(frozen=True)
    assert np.ptp(sampled_x_volts(fe, tone_x(97.0, 1.0))[1]) == 0.0


def test_adxl335_sampled_at_400_hz_aliases_like_the_real_part() -> None:
    """A 300 Hz tone sampled at 400 Hz reads as a 100 Hz tone of the 300 Hz amplitude."""
    fe = adxl_chain(0.1)
    t, v = sampled_x_volts(fe, tone_x(300.0, 1.0), n=4000, step_ns=TICK_NS)
    amp_alias, _ = fit_sine(t, v, 100.0)
    assert amp_alias == pytest.approx(abs(vibration.first_order(2 * math.pi * 300.0, 49.736)) * 0.1 * 3.3 / G0_MPS2,
                                      rel=1e-3)


# -- XSENS ----------------------------------------------------------------------------------
def test_xsens_identity_responses() -> None:
    """mk4 (MTi-300): 375 / 415 Hz and the mean over the output interval (2.5 ms at 400 Hz);
    legacy: 30 / 40 Hz, point samples."""
    w = 2 * math.pi * 97.0
    tone = VibrationTone(w, 0.0, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    mk4 = MtiDevice(XsensParams(output_configuration=((0x4020, 400), (0x8020, 400))), np.random.default_rng(0))
    factory = MtiDevice(XsensParams(), np.random.default_rng(0))  # 100 Hz messages: a 10 ms mean
    assert factory.vibration_S((tone,), (), 0.0)[0][0] == pytest.approx(
        (vibration.first_order(w, 375.0) * vibration.window_average(w, 10e-3)).real, abs=1e-12)
    legacy = MtiDevice(XsensParams(identity="legacy"), np.random.default_rng(0))
    assert XsensParams(identity="legacy").sensor_response().acc_bandwidth_Hz == 30.0
    for dev, h_acc, h_gyr in (
        (mk4, vibration.first_order(w, 375.0) * vibration.window_average(w, 2.5e-3),
         vibration.first_order(w, 415.0) * vibration.window_average(w, 2.5e-3)),
        (legacy, vibration.first_order(w, 30.0), vibration.first_order(w, 40.0)),
    ):
        for dt in (0.0, 1.1e-3):
            f, r = dev.vibration_S((tone,), (tone,), dt)
            assert f[0] == pytest.approx((h_acc * np.exp(1j * w * dt)).real, abs=1e-12)
            assert r[0] == pytest.approx((h_gyr * np.exp(1j * w * dt)).real, abs=1e-12)
    assert abs(vibration.first_order(w, 30.0)) == pytest.approx(0.295, abs=1e-3)


def test_xsens_bandwidth_overrides_and_errors() -> None:
    p = XsensParams(identity="legacy", acc_bandwidth_Hz=100.0, bandwidth_order=2, output_averaging=True)
    r = p.sensor_response()
    assert (r.acc_bandwidth_Hz, r.gyro_bandwidth_Hz, r.averaging) == (100.0, 40.0, True)
    for bad in ({"acc_bandwidth_Hz": 0.0}, {"gyro_bandwidth_Hz": math.inf}, {"bandwidth_order": 3}):
        with pytest.raises(ValueError):
            XsensParams(**bad)  # type: ignore[arg-type]


def test_xsens_samples_carry_the_filtered_tone_at_the_sample_instant() -> None:
    """Driven as hil/flight/devices.py drives it, the 400 Hz acceleration output of a legacy-bandwidth
    mk4 carries |H| of a 97 Hz tone (noise and biases off)."""
    p = XsensParams(output_configuration=((0x4020, 400),), acc_bandwidth_Hz=30.0, output_averaging=False,
                    acc_noise_mps2_per_rthz=0.0, acc_bias_sigma_mps2=0.0, gyro_noise_radps_per_rthz=0.0,
                    gyro_bias_sigma_radps=0.0, gyro_bias_rw_radps_per_rts=0.0, orientation_bias_rp_deg=0.0,
                    orientation_bias_yaw_deg=0.0, orientation_noise_deg=0.0)
    dev = MtiDevice(p, np.random.default_rng(0))
    tone = VibrationTone(2 * math.pi * 97.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))  # -sin on z
    acc = []
    for k in range(400):
        t = k * TICK_NS
        dv_f, _ = dev.vibration_S((tone,), (), t * 1e-9)  # the tone's reference is t = 0
        dev.set_motion((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, -9.80665 + dv_f[2]))
        dev.advance(t)
        dev.take_output()
        acc += [e.acc_mps2 for e in dev.take_events() if type(e).__name__ == "SampleSent"]
    z = np.array([a[2] for a in acc])  # output frame ENU-like: z up, so the sign flips
    amp, _ = fit_sine(np.arange(len(z)) * TICK_NS * 1e-9, z, 97.0)
    assert amp == pytest.approx(abs(vibration.first_order(2 * math.pi * 97.0, 30.0)), rel=1e-5)
