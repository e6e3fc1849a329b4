"""The firmware's altitude Kalman filter against flightcode's AltitudeKF on the same inputs.

Tolerances (float32 against float64; measured on these sequences, then about five times that):

* a whole run (the C filter on its own from the start): every state within 1e-3 (m, m/s,
  m/s^2) over 100 000 samples (250 s); measured 1.9e-4 m, after the gate re-anchors the
  height to an 8 m level shift (P_zz loosened to 64 m^2 and brought back to 0.3 m^2 in one
  update leaves float32 1e-5 of relative error in the gains that follow), 4e-5 elsewhere. The
  covariance within 1e-3 of sqrt(P_ii P_jj); measured 1.9e-4.
* one step from the Python filter's state rounded to float32: every state within 1e-5
  relative plus 1e-6 x (1 + the readings' size), and the gate's verdict the same unless the Python test statistic is within 1e-4 of
  the threshold.

The inputs are float32 values, so both filters see the same numbers. The firmware keeps P
exactly symmetric (its upper triangle mirrored) where flightcode re-symmetrises every predict.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.config import FlightConfig
from flightcode.control.lqi_altitude import AltitudeModel
from flightcode.estimation.altitude_kf import AltitudeKF
from tests.unit.firmware import cfw

STATE_TOL = 1e-3
P_TOL = 1e-3


def f32(v: float) -> float:
    return float(np.float32(v))


def pair(lib: cfw.Lib, cfg: FlightConfig) -> tuple[AltitudeKF, cfw.CKalman]:
    kf = cfg.kf
    model = AltitudeModel(cfg.vehicle.m_kg, cfg.vehicle.F_max_N, cfg.altitude.T1_s)
    py = AltitudeKF(model, cfg.T_s, kf.q_a, kf.q_d, kf.q_b, kf.r_baro_m2, kf.r_acc, kf.r_rest_vz,
                    kf.baro_gate_chi2, kf.baro_gate_timeout_s)
    c = cfw.CKalman(lib, kf.r_baro_m2, kf.r_acc, kf.r_rest_vz, kf.baro_gate_chi2, kf.baro_gate_timeout_s, cfg.T_s)
    return py, c


def assert_close(py: AltitudeKF, c: cfw.CKalman, where: str) -> None:
    x, P, counters, run = c.read()
    err = np.abs(x - py.x)
    assert np.all(err <= STATE_TOL), f"{where}: state differs by {err} (C {x}, Python {py.x})"
    scale = np.sqrt(np.outer(np.diag(py.P), np.diag(py.P)))
    rel = np.max(np.abs(P - py.P) / scale)
    assert rel <= P_TOL, f"{where}: covariance differs by {rel} of sqrt(P_ii P_jj)"
    assert np.array_equal(P, P.T), f"{where}: the covariance is not exactly symmetric"
    assert run == py.baro_reject_run, where
    for name in ("baro_rejected", "baro_reanchored", "nonfinite_input", "nonfinite_baro", "nonfinite_acc"):
        assert counters[name] == py.counters[name], f"{where}: {name}"


def flight_profile(rng: np.random.Generator, n: int, T: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A vehicle's height, vertical acceleration and throttle deviation: hovers, climbs and
    descents of a few metres (a smooth random acceleration), a payload-like disturbance."""
    a = np.convolve(rng.normal(0.0, 4.0, n), np.ones(200) / 200.0, mode="same")
    v = np.cumsum(a) * T
    v -= np.convolve(v, np.ones(4000) / 4000.0, mode="same")  # no drift away: the height stays within metres
    z = np.cumsum(v) * T
    a = np.gradient(np.gradient(z, T), T)
    u = a / 27.1 + 0.02
    return z, a, u


def test_a_realistic_flight_with_outliers_gaps_ground_effect_and_rests(lib: cfw.Lib, rig_cfg: FlightConfig) -> None:
    py, c = pair(lib, rig_cfg)
    rng = np.random.default_rng(7)
    n, T = 100_000, rig_cfg.T_s
    z, a, u = flight_profile(rng, n, T)
    bias = 0.15
    for k in range(n):
        uk = f32(u[k])
        py.predict(uk)
        c.predict(uk)
        zb: float | None = f32(z[k] + rng.normal(0.0, 0.57))
        if rng.random() < 0.03:
            zb = None  # a lost ADC reply
        elif rng.random() < 0.002:
            zb = f32(z[k] + rng.choice([-1.0, 1.0]) * rng.uniform(5.0, 40.0))  # a bit error that passed
        ak: float | None = f32(a[k] + bias + rng.normal(0.0, 0.3)) if rng.random() > 0.02 else None
        scale = 25.0 if z[k] < 1.0 else 1.0  # the loop's ground-effect allowance
        if k % 20_000 == 5_000:  # a barometer level shift that outlasts the gate's timeout
            z[k:k + 600] += 8.0
        assert py.update(zb, ak, scale) == c.update(zb, ak, scale), f"sample {k}: gate verdict"
        if 30_000 <= k < 31_000:  # standing on the ground
            py.update_at_rest()
            c.update_at_rest()
        if k == 31_000:
            py.loosen_height(0.33)
            c.loosen_height(0.33)
        if k == 60_000:  # the barometer-motion check moved the estimate
            py.move_to(f32(z[k]), f32(0.2), 0.25, 0.04)
            c.move_to(f32(z[k]), f32(0.2), 0.25, 0.04)
        if k % 1000 == 0:
            assert_close(py, c, f"sample {k}")
    assert_close(py, c, "end")
    assert py.counters["baro_rejected"] > 100 and py.counters["baro_reanchored"] >= 2  # the gate worked


def test_random_inputs_including_non_finite_and_resets(lib: cfw.Lib, rig_cfg: FlightConfig) -> None:
    py, c = pair(lib, rig_cfg)
    rng = np.random.default_rng(3)
    for k in range(20_000):
        u = f32(rng.normal(0.0, 0.1)) if rng.random() > 0.001 else math.nan
        py.predict(u)
        c.predict(u)
        zb = f32(rng.normal(0.0, 2.0)) if rng.random() > 0.1 else (None if rng.random() > 0.01 else math.inf)
        ak = f32(rng.normal(0.0, 3.0)) if rng.random() > 0.1 else (None if rng.random() > 0.01 else math.nan)
        assert py.update(zb, ak) == c.update(zb, ak)
        if rng.random() < 0.0005:
            z0, var = f32(rng.normal(0.0, 5.0)), f32(rng.uniform(0.001, 1.0))
            py.reset(z0, var)
            c.reset(z0, var)
        if k % 500 == 0:
            assert_close(py, c, f"sample {k}")
    assert all(py.counters[k] > 0 for k in ("nonfinite_input", "nonfinite_baro", "nonfinite_acc"))


@settings(max_examples=100)
@given(seed=st.integers(0, 2**32 - 1), chi2=st.sampled_from([25.0, 9.0, 1.0]),
       z_baro=st.floats(-50.0, 50.0, width=32), a_up=st.floats(-30.0, 30.0, width=32),
       u=st.floats(-0.75, 0.25, width=32), r_scale=st.sampled_from([1.0, 25.0]))
def test_one_step_from_the_same_state(lib: cfw.Lib, rig_cfg: FlightConfig, seed: int, chi2: float, z_baro: float,
                                      a_up: float, u: float, r_scale: float) -> None:
    """From any covariance the filter reaches (a random walk of it), one predict and update
    give the same state, the same gate verdict (away from its threshold) and the same counters."""
    kf = rig_cfg.kf
    model = AltitudeModel(rig_cfg.vehicle.m_kg, rig_cfg.vehicle.F_max_N, rig_cfg.altitude.T1_s)
    py = AltitudeKF(model, rig_cfg.T_s, kf.q_a, kf.q_d, kf.q_b, kf.r_baro_m2, kf.r_acc, kf.r_rest_vz, chi2, 0.01)
    c = cfw.CKalman(lib, kf.r_baro_m2, kf.r_acc, kf.r_rest_vz, chi2, 0.01)
    rng = np.random.default_rng(seed)
    for _ in range(int(rng.integers(0, 60))):
        py.predict(f32(rng.normal(0, 0.05)))
        py.update(f32(rng.normal(0, 1.0)) if rng.random() < 0.7 else None, f32(rng.normal(0, 1.0)))
    # the Python state in float32, and Python's continued from that same float32 state
    x32, p32 = py.x.astype(np.float32), py.P.astype(np.float32)
    py._x[:] = x32
    py._P[:] = p32
    c.write(x32, p32, py.baro_reject_run)
    before = dict(py.counters)
    py.predict(u)
    c.predict(u)
    stat = (z_baro - py.z_m) ** 2 / (chi2 * (py.P[0, 0] + kf.r_baro_m2 * r_scale))
    fused_py, fused_c = py.update(z_baro, a_up, r_scale), c.update(z_baro, a_up, r_scale)
    if abs(stat - 1.0) < 1e-4:
        return  # on the gate's threshold: either verdict is float rounding
    assert fused_py == fused_c
    x, _, counters, run = c.read()
    # a float32 correction of up to 50 m rounds to a few 1e-6 of the terms it sums
    np.testing.assert_allclose(x, py.x, rtol=1e-5, atol=1e-6 * (1.0 + abs(z_baro) + abs(a_up)))
    assert run == py.baro_reject_run
    for name in ("baro_rejected", "baro_reanchored"):
        assert counters[name] == py.counters[name] - before.get(name, 0), name


@pytest.mark.parametrize("timeout_s, T_s, expected", [(1.0, 0.0025, 400), (0.0, 0.0025, 1), (0.001, 0.0025, 1),
                                                      (0.00625, 0.0025, 2), (0.01125, 0.0025, 4), (0.5, 0.01, 50)])
def test_gate_timeout_in_samples_rounds_as_python(lib: cfw.Lib, timeout_s: float, T_s: float, expected: int) -> None:
    assert max(1, round(timeout_s / T_s)) == expected  # 2.5 -> 2 and 4.5 -> 4: half to even
    assert lib.dll.altitude_kf_gate_max_rejects(round(timeout_s * 1e9), round(T_s * 1e9)) == expected
