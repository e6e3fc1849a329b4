"""The firmware's mixer and landing helpers against flightcode's.

Mixer tolerances (float32 against float64, both frames, both differentials, requests far
beyond what fits; measured on 20 000 random requests, then a margin): each motor's thrust
within 2e-5 N (measured 1.6e-6 N) and its throttle within 1e-5 where the thrust is above 1 %
of the maximum (5.2e-7; below 1 % sqrt magnifies a thrust's rounding: 1e-7 N is a throttle of
1.4e-4); the applied torques and the torques in the controllers' units within 1e-5 (4.8e-7);
the collective's square (the total thrust over 4 F_max) within 4e-6, 2e-5 N; the saturation
flag identical (no difference measured) unless the request's largest or smallest motor
thrust is within 1e-4 N of a bound (the fit tolerance is flightcode's 1e-9 N or 4 float32
ulps of the terms summed, whichever is larger). Landing: the descent within 1e-5 m over 60 s
(compensated summation; 7e-12 m, a plain float32 sum was 5 mm off), the hover collective
within 1e-6, the touchdown filter within 1e-6 m/s^2.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.control.landing import ACCEL_LP_TAU_S, HoverThrottle, LandingDescent
from flightcode.control.mixer import Mixer, _EPS_N
from tests.unit.firmware import cfw

FMAX = 20.6 / 4
D_H = math.sqrt(1.1 * 9.80665 / 20.6)


def f32(v: float) -> float:
    return float(np.float32(v))


def mixer_pair(lib: cfw.Lib, frame: str, differential: str) -> tuple[Mixer, cfw.CMixer]:
    c = cfw.CMixer(lib, frame, 0.25, f32(FMAX), 0.016, differential, f32(D_H))
    assert c.ok
    return Mixer(frame, 0.25, FMAX, 0.016, differential, D_H), c


@pytest.mark.parametrize("frame", ["x", "plus"])
def test_allocation_inverse(lib: cfw.Lib, frame: str) -> None:
    py, c = mixer_pair(lib, frame, "thrust")
    m, _ = c.read()
    inv = np.linalg.inv(py.allocation)
    np.testing.assert_allclose(m, inv[:, 1:].T, rtol=1e-6, atol=1e-6)


def near_bound(py: Mixer, collective: float, tau: tuple[float, float, float]) -> bool:
    """The request's motor thrusts (before any saturation handling) within 1e-4 N of a bound."""
    d_c = min(max(collective, 0.0), 1.0) if math.isfinite(collective) else 0.0
    gain = 1.0 if py._per_hover is None else d_c * py._per_hover
    t = [(v if math.isfinite(v) else 0.0) * gain for v in tau]
    f_c = FMAX * d_c * d_c
    thrust = [f_c + py._m_roll[i] * t[0] + py._m_pitch[i] * t[1] + py._m_yaw[i] * t[2] for i in range(4)]
    base = [f_c + py._m_roll[i] * t[0] + py._m_pitch[i] * t[1] for i in range(4)]
    return any(abs(f) < 1e-4 or abs(f - FMAX) < 1e-4 for f in (*thrust, *base))


def assert_mix_close(py: Mixer, c: cfw.CMixer, collective: float, tau: tuple[float, float, float]) -> cfw.CMix:
    mp, mc = py.mix(collective, tau), c.mix(collective, tau)
    fp, fc = FMAX * np.square(mp.throttle), FMAX * np.square(mc.throttle)
    assert np.abs(fc - fp).max() <= 2e-5, (collective, tau, mp, mc)
    big = fp > 0.01 * FMAX
    assert np.abs(np.array(mc.throttle) - mp.throttle)[big].max(initial=0.0) <= 1e-5
    np.testing.assert_allclose(mc.applied_tau_Nm, mp.applied_tau_Nm, atol=1e-5)
    np.testing.assert_allclose(mc.applied_command_Nm, mp.applied_command_Nm, atol=1e-5, rtol=1e-5)
    # the collective is sqrt of the total thrust: compared as thrust (near 0 sqrt magnifies)
    assert mc.applied_collective_throttle**2 == pytest.approx(mp.applied_collective_throttle**2, abs=4e-6)
    if mc.saturated != mp.saturated:
        assert near_bound(py, collective, tau), (collective, tau, mp, mc)
    return mc


@pytest.mark.parametrize("frame", ["x", "plus"])
@pytest.mark.parametrize("differential", ["thrust", "throttle"])
def test_mix_random_requests_with_saturation(lib: cfw.Lib, frame: str, differential: str) -> None:
    py, c = mixer_pair(lib, frame, differential)
    rng = np.random.default_rng(9)
    saturated = 0
    for _ in range(2000):
        collective = f32(rng.uniform(-0.2, 1.2))
        scale = rng.choice([0.05, 0.8])  # flight-sized requests, and ones far beyond what fits
        tau = (f32(rng.normal(0, scale)), f32(rng.normal(0, scale)), f32(rng.normal(0, scale / 5)))
        saturated += assert_mix_close(py, c, collective, tau).saturated
    assert 200 < saturated < 1800  # both branches exercised


@settings(max_examples=300)
@given(collective=st.floats(-0.5, 1.5, width=32).filter(lambda c: c == 0.0 or abs(c) >= 1e-30)
       | st.sampled_from([0.0, 1.0, math.nan, D_H]),
       tau=st.tuples(*(st.floats(-3.0, 3.0, width=32) | st.sampled_from([0.0, math.inf, math.nan]),) * 3),
       frame=st.sampled_from(["x", "plus"]), differential=st.sampled_from(["thrust", "throttle"]))
def test_mix_property(lib: cfw.Lib, collective: float, tau: tuple[float, float, float], frame: str,
                      differential: str) -> None:
    """Any request; collectives between 0 and 1e-30 (the LQI never gives them) are left out:
    below about 1e-36 the float32 torques underflow to 0 and the torque fed back to the
    controllers is 0 where flightcode's doubles still give the fraction that fits (found by
    this test at a collective of 1.4e-45)."""
    py, c = mixer_pair(lib, frame, differential)
    mc = assert_mix_close(py, c, collective, tau)
    assert all(0.0 <= d <= 1.0 for d in mc.throttle)
    counters = c.read()[1]
    assert counters == {k: py.counters[k] for k in counters}


def test_firmware_fit_tolerance_is_at_least_flightcodes() -> None:
    assert _EPS_N == 1e-9  # the firmware's MIXER_EPS_MIN_N


def test_mixer_refuses_bad_params(lib: cfw.Lib) -> None:
    assert not cfw.CMixer(lib, "x", 0.0, FMAX, 0.016, "thrust", D_H).ok
    assert not cfw.CMixer(lib, "x", 0.25, FMAX, 0.016, "throttle", 1.0).ok


# -- landing -----------------------------------------------------------------------------------------
def test_descent(lib: cfw.Lib) -> None:
    py, c = LandingDescent(0.5), cfw.CDescent(lib, 0.5)
    assert c.ok and not cfw.CDescent(lib, 0.0).ok
    py.start(2.0)
    c.start(2.0)
    for _ in range(24_000):  # 60 s: well past the ground
        zp, zc = py.step(0.0025), c.step(0.0025)
    assert zc == pytest.approx(zp, abs=1e-5) and zp == pytest.approx(-28.0)


def test_hover_collective_and_steady(lib: cfw.Lib) -> None:
    py, c = HoverThrottle(D_H), cfw.CHover(lib, f32(D_H))
    assert c.ok and not cfw.CHover(lib, 1.0).ok
    rng = np.random.default_rng(12)
    for k in range(20_000):
        col = f32(rng.uniform(0.6, 0.9)) if k % 1000 else (math.nan if k % 2000 else f32(1.7))
        dt = 0.0025 if k % 777 else 0.0
        assert c.update(col, dt) == pytest.approx(py.update(col, dt), abs=1e-6)
    assert c.learnt_s == pytest.approx(py.learnt_s, rel=1e-3)  # informational: a float32 sum of 2.5 ms steps
    for args in [(2.0, 0.1, 0.2, 1.0), (0.9, 0.1, 0.2, 1.0), (2.0, 0.3, 0.0, 1.0), (2.0, -0.29, -0.49, 1.0),
                 (2.0, 0.0, 0.5, 1.0), (1.0, 0.0, 0.0, 1.0)]:
        assert c.steady(*args) == HoverThrottle.steady(*args), args


def test_touchdown_filter(lib: cfw.Lib) -> None:
    c = cfw.CTouchdown(lib)
    lp = 0.0
    rng = np.random.default_rng(13)
    for k in range(10_000):
        a = f32(rng.normal(0.0, 3.0)) if k % 500 else math.nan
        dt = 0.0025 * (1 + (k % 100 == 0))
        if math.isfinite(a):  # flightcode/loop.py's own line
            lp += dt / (ACCEL_LP_TAU_S + dt) * (a - lp)
        assert c.update(a, dt) == pytest.approx(lp, abs=1e-6)
