"""The per-sample vibration path (float pairs: emulators/vibration.py ``*_ri``,
``sensed_tones``, and the ADXL335 chain's tones in emulators/analog/frontend.py) against the
complex reference functions: the same values to rounding, for any frequency, bandwidth,
averaging window and time."""

from __future__ import annotations

import math

import hypothesis.strategies as st
import numpy as np
import pytest
from hypothesis import given, settings

from emulators import vibration
from emulators.analog import AnalogFrontEnd
from emulators.analog.params import AnalogParams
from hil.plant.records import VibrationTone

REL = 1e-12  #: of the magnitude: a few ulps of rounding between the two formulations

omegas = st.floats(0.0, 2 * math.pi * 5000.0)
bandwidths = st.one_of(st.floats(0.5, 2000.0), st.sampled_from([0.0, -1.0, math.inf]))
windows = st.one_of(st.just(0.0), st.floats(1e-4, 0.02))
amplitudes = st.tuples(*[st.floats(-5.0, 5.0)] * 3)


def close(got: tuple[float, float], ref: complex) -> bool:
    return abs(complex(*got) - ref) <= REL * max(abs(ref), 1.0)


@settings(max_examples=200, deadline=None)
@given(w=omegas, fc=bandwidths, order=st.sampled_from([1, 2]))
def test_lowpass_pair_is_the_complex_lowpass(w: float, fc: float, order: int) -> None:
    assert close(vibration.lowpass_ri(w, fc, order), vibration.lowpass(w, fc, order))


def test_lowpass_pair_refuses_the_orders_the_reference_refuses() -> None:
    for fc in (30.0, math.inf):
        with pytest.raises(ValueError, match="order must be 1 or 2"):
            vibration.lowpass_ri(1.0, fc, 3)
        with pytest.raises(ValueError, match="order must be 1 or 2"):
            vibration.lowpass(1.0, fc, 3)


@settings(max_examples=200, deadline=None)
@given(w=omegas, window=windows)
def test_window_average_pair_is_the_complex_window_average(w: float, window: float) -> None:
    assert close(vibration.window_average_ri(w, window), vibration.window_average(w, window))


@settings(max_examples=100, deadline=None)
@given(tones=st.lists(st.tuples(omegas, st.floats(-10.0, 10.0), amplitudes, amplitudes), max_size=8),
       fc=bandwidths, order=st.sampled_from([1, 2]), window=windows, dt=st.floats(-0.01, 0.01))
def test_sensed_tones_is_the_sum_of_reference_tone_values(
    tones: list[tuple[float, float, tuple[float, float, float], tuple[float, float, float]]],
    fc: float, order: int, window: float, dt: float,
) -> None:
    ts = [VibrationTone(w, ph, re, im) for w, ph, re, im in tones]
    expect = np.zeros(3)
    for t in ts:
        h = vibration.lowpass(t.omega_radps, fc, order) * vibration.window_average(t.omega_radps, window)
        expect += vibration.tone_value(t, h, dt)
    got = vibration.sensed_tones(ts, fc, order, window, dt)
    np.testing.assert_allclose(got, expect, rtol=0, atol=1e-11 * max(1.0, len(ts)))


@settings(max_examples=60, deadline=None)
@given(tones=st.lists(st.tuples(st.floats(10.0, 2 * math.pi * 2000.0), st.floats(-10.0, 10.0), amplitudes,
                                amplitudes), min_size=1, max_size=6),
       dt_us=st.integers(0, 5000))
def test_adxl_channel_tones_are_the_complex_response(
    tones: list[tuple[float, float, tuple[float, float, float], tuple[float, float, float]]], dt_us: int,
) -> None:
    """Each accel channel's vibration volts: Re{(row . A) / ((1 + j w tau_s)(1 + j w tau_rc))
    e^(j phi)} summed over the tones, row = the channel's volts per m/s^2 in body axes."""
    fe = AnalogFrontEnd(AnalogParams(), np.random.default_rng(7))  # unit errors: every row entry counts
    ts = [VibrationTone(w, ph, re, im) for w, ph, re, im in tones]
    fe.set_vibration(0, ts)
    t_ns = dt_us * 1000
    for ch, sig in fe._wired:
        if sig == 0:
            continue
        row = fe._vib_V_per_mps2[sig - 1]
        tau_s, tau_rc = fe._tau_sensor[sig], fe._tau_rc[ch]
        expect = 0.0
        for t in ts:
            amp = complex(sum(r * a for r, a in zip(row, t.re, strict=True)),
                          sum(r * b for r, b in zip(row, t.im, strict=True)))
            h = 1.0 / (complex(1.0, t.omega_radps * tau_s) * complex(1.0, t.omega_radps * tau_rc))
            expect += (h * amp * complex(math.cos(t.phase_rad + t.omega_radps * t_ns * 1e-9),
                                         math.sin(t.phase_rad + t.omega_radps * t_ns * 1e-9))).real
        assert fe._vibration_V(ch, t_ns) == pytest.approx(expect, rel=1e-9, abs=1e-12)
