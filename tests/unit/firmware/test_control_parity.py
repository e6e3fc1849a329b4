"""The firmware's prefilter, memory attitude, yaw-rate and LQI controllers against flightcode's.

Each controller gets the same float32 inputs in both languages: steps, random sequences that
drive it into its limits (anti-windup), inactive stretches, non-finite inputs. Tolerances
(float32 against float64; measured, then a margin):

* prefilter: the ZOH coefficients (closed form in float32 against scipy's expm) within 2e-6
  relative (measured 2.1e-7); the outputs within 2e-5 of each derivative's peak (5.6e-6);
* memory attitude: the weights within 1e-6 relative (3.8e-8); the torque within 2e-5 N m at
  every step of a 20 000-step open-loop run never re-synchronised, whose accumulator sums the
  float32 rounding (3.4e-7 N m generalised, 3.9e-6 N m with the paper's weights); a closed
  loop on a lagged roll axis within 1e-5 rad (5e-7);
* yaw rate: the torque and the integrator within 1e-6 N m (6e-8);
* LQI: the collective within 1e-5 (1.4e-6) and the integrator within 1e-4 m s (6.4e-6) over
  20 000 steps; a 5 m step flown on the linear model within 1e-4 m (2.4e-5).
Saturation flags, counters and the inactive outputs are identical.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.config import FlightConfig
from flightcode.control.lqi_altitude import AltitudeModel, LqiAltitude
from flightcode.control.memory_attitude import MemoryAttitudeController, MemoryGains
from flightcode.control.reference import Prefilter3, RefState
from flightcode.control.yaw_rate import YawRateController
from tests.unit.firmware import cfw


def f32(v: float) -> float:
    return float(np.float32(v))


def f32s(n: int, rng: np.random.Generator, scale: float) -> list[float]:
    return rng.normal(0.0, scale, n).astype(np.float32).tolist()


# -- prefilter -------------------------------------------------------------------------------------
@pytest.mark.parametrize("omega, T_s", [(8.0, 0.0025), (30.0, 0.0025), (2.0, 0.0025), (8.0, 0.01), (400.0, 0.0025)])
def test_prefilter_coefficients(lib: cfw.Lib, omega: float, T_s: float) -> None:
    py, c = Prefilter3(omega, T_s), cfw.CPrefilter(lib, omega, T_s)
    assert c.ok
    a, b = c.params()
    a_py = np.array([[py._a00, py._a01, py._a02], [py._a10, py._a11, py._a12], [py._a20, py._a21, py._a22]])
    b_py = np.array([py._b0, py._b1, py._b2])
    np.testing.assert_allclose(a, a_py, rtol=2e-6, atol=1e-12 * np.abs(a_py).max())
    np.testing.assert_allclose(b, b_py, rtol=2e-6)


@pytest.mark.parametrize("omega", [8.0, 30.0])
def test_prefilter_response(lib: cfw.Lib, omega: float) -> None:
    py, c = Prefilter3(omega, 0.0025), cfw.CPrefilter(lib, omega, 0.0025)
    rng = np.random.default_rng(2)
    cmds = [f32(v) for v in np.repeat(rng.uniform(-0.5, 0.5, 40), 250)]  # stick steps every 0.625 s
    cmds[1000] = math.nan  # a driver fault: the last command is held
    out_py = np.array([[r.angle_rad, r.rate_radps, r.acc_radps2, r.jerk_radps3] for r in map(py.update, cmds)])
    out_c = np.array([c.update(v) for v in cmds])
    peak = np.abs(out_py).max(axis=0)
    err = np.abs(out_c - out_py).max(axis=0) / peak
    assert np.all(err < 2e-5), err
    assert np.all(np.isfinite(out_c))
    assert c.reset(0.3) == (f32(0.3), 0.0, 0.0, 0.0)
    assert c.update(0.3)[0] == pytest.approx(0.3, rel=1e-6)  # settled: stays there


def test_prefilter_refuses_bad_params(lib: cfw.Lib) -> None:
    assert not cfw.CPrefilter(lib, 0.0, 0.0025).ok and not cfw.CPrefilter(lib, 8.0, -1.0).ok
    assert not cfw.CPrefilter(lib, math.inf, 0.0025).ok


# -- memory attitude -------------------------------------------------------------------------------
def memory_pair(lib: cfw.Lib, literal: bool, omega1: float = 5.0, omega2: float = 15.0, k0: float = 4.0,
                tau: float = 0.005, lim: float = 0.8) -> tuple[MemoryAttitudeController, cfw.CMemory]:
    if literal:
        gains = MemoryGains.paper_literal(0.0025, k0, 0.015, lim)
    else:
        gains = MemoryGains.from_poles(0.0025, omega1, omega2, k0, 0.015, tau, lim)
    c = cfw.CMemory(lib, literal, 0.0025, omega1, omega2, k0, 0.015, tau, lim)
    assert c.ok
    return MemoryAttitudeController(gains), c


@pytest.mark.parametrize("omega1, omega2", [(2.0, 15.0), (5.0, 15.0), (3.0, 25.0), (0.5, 100.0)])
def test_memory_weights(lib: cfw.Lib, omega1: float, omega2: float) -> None:
    py, c = memory_pair(lib, False, omega1, omega2)
    state, _ = c.read()
    np.testing.assert_allclose(state[4:6], [py.gains.w1_per_s, py.gains.w2_per_s], rtol=1e-6)
    py, c = memory_pair(lib, True)
    np.testing.assert_array_equal(c.read()[0][4:6], np.float32([-800.0, 400.0]))


@pytest.mark.parametrize("literal", [False, True])
def test_memory_open_loop_with_saturation_inactive_stretches_and_clipping(lib: cfw.Lib, literal: bool) -> None:
    py, c = memory_pair(lib, literal)
    rng = np.random.default_rng(4)
    n = 20_000
    refs = np.stack([f32s(n, rng, 0.3), f32s(n, rng, 1.0), f32s(n, rng, 10.0), f32s(n, rng, 200.0)], axis=1)
    angle, rate = f32s(n, rng, 0.2), f32s(n, rng, 1.0)
    active = np.ones(n, dtype=bool)
    for s in rng.integers(0, n - 300, 15):
        active[s:s + int(rng.integers(1, 300))] = False
    worst = 0.0
    for k in range(n):
        ref = tuple(refs[k].tolist())
        if k % 997 == 0:
            ref = (math.nan, *ref[1:])
        up = py.update(RefState(*ref), angle[k], rate[k], bool(active[k]))
        uc = c.update(ref, angle[k], rate[k], bool(active[k]))
        worst = max(worst, abs(up - uc))
        assert abs(up - uc) <= 2e-5, f"step {k}: {up} vs {uc}"
        if k % 7 == 0:  # the mixer clipped: the applied torque comes back
            applied = f32(up * rng.uniform(0.3, 1.0)) if k % 1001 else math.inf
            py.set_applied(applied)
            c.set_applied(applied)
        if k == 12_345:
            py.reset()
            c.reset()
    _, counters = c.read()
    assert counters == {k: py.counters[k] for k in counters} and counters["nonfinite_input"] > 0 and counters["nonfinite_applied"] > 0


@pytest.mark.parametrize("literal", [False, True])
def test_memory_closed_loop_on_a_lagged_axis(lib: cfw.Lib, literal: bool) -> None:
    """Each controller flies its own copy of a roll axis (J = 0.0153 kg m^2, 20 ms motor lag,
    one sample of delay, a gust torque): a +-10 deg reference tracked alike (the literal
    weights chatter at the limit in both)."""
    pf_py, pf_c = Prefilter3(8.0, 0.0025), cfw.CPrefilter(lib, 8.0, 0.0025)
    py, c = memory_pair(lib, literal)
    rng = np.random.default_rng(8)
    gust = np.convolve(rng.normal(0.0, 0.03, 8000), np.ones(50) / 50 * 7, mode="same")
    states = {"py": [0.0, 0.0, 0.0, 0.0], "c": [0.0, 0.0, 0.0, 0.0]}  # phi, phi', torque, the delayed command
    angles: dict[str, list[float]] = {"py": [], "c": []}
    for k in range(8000):
        cmd = f32(math.radians(10.0) * (1 if (k // 800) % 2 else -1))
        refs = {"py": pf_py.update(cmd), "c": pf_c.update(cmd)}
        for who, ctl in (("py", py), ("c", c)):
            phi, dphi, tau, u_delayed = states[who]
            ref = refs[who]
            u = ctl.update(ref, f32(phi), f32(dphi), True)  # type: ignore[arg-type]
            tau += (u_delayed - tau) * 0.0025 / 0.020
            dphi += (tau + gust[k]) / 0.0153 * 0.0025
            phi += dphi * 0.0025
            states[who] = [phi, dphi, tau, u]
            angles[who].append(phi)
    diff = np.abs(np.array(angles["c"]) - np.array(angles["py"]))
    assert diff.max() < 1e-5, diff.max()


# -- yaw rate --------------------------------------------------------------------------------------
@settings(max_examples=40)
@given(seed=st.integers(0, 2**32 - 1), kp=st.floats(0.0, 1.0), ki=st.floats(0.0, 1.0),
       lim=st.floats(0.01, 0.5))
def test_yaw_rate_random_with_saturation_and_clipping(lib: cfw.Lib, seed: int, kp: float, ki: float,
                                                      lim: float) -> None:
    py, c = YawRateController(kp, ki, lim, 0.0025), cfw.CYaw(lib, kp, ki, lim, 0.0025)
    assert c.ok
    rng = np.random.default_rng(seed)
    refs, meas = f32s(1000, rng, 1.5), f32s(1000, rng, 1.0)
    for k in range(1000):
        active = k % 400 > 20
        r = refs[k] if k % 333 else math.nan
        up, uc = py.update(r, meas[k], active), c.update(r, meas[k], active)
        assert abs(up - uc) <= 1e-6, f"step {k}"
        if k % 3 == 0:
            applied = f32(up * rng.uniform(-0.2, 1.0))
            py.set_applied(applied)
            c.set_applied(applied)
        i_c, _, _ = c.read()
        assert abs(i_c - py.integrator_Nm) <= 1e-6, f"step {k}: integrator"
    counters = c.read()[2]
    assert counters == {k: py.counters[k] for k in counters}


def test_yaw_rate_refuses_bad_params(lib: cfw.Lib) -> None:
    assert not cfw.CYaw(lib, -0.1, 0.1, 0.15, 0.0025).ok and not cfw.CYaw(lib, 0.1, 0.1, 0.0, 0.0025).ok


# -- LQI -------------------------------------------------------------------------------------------
def lqi_pair(lib: cfw.Lib, cfg: FlightConfig) -> tuple[LqiAltitude, cfw.CLqi]:
    v, alt = cfg.vehicle, cfg.altitude
    model = AltitudeModel(v.m_kg, v.F_max_N, alt.T1_s)
    py = LqiAltitude(model, alt.q_int, alt.q_z, alt.q_vz, alt.q_az, alt.r, cfg.T_s)
    c = cfw.CLqi(lib, cfg.T_s, v.m_kg, v.F_max_N)
    assert c.ok
    return py, c


def test_lqi_random_inputs_saturating_both_ways(lib: cfw.Lib, rig_cfg: FlightConfig) -> None:
    py, c = lqi_pair(lib, rig_cfg)
    rng = np.random.default_rng(6)
    n = 20_000
    z_ref = np.repeat(rng.uniform(0.0, 10.0, 40), n // 40).astype(np.float32).tolist()
    z, vz, az = f32s(n, rng, 3.0), f32s(n, rng, 1.0), f32s(n, rng, 2.0)
    saturated = 0
    for k in range(n):
        active = k % 4000 > 100
        zk = z[k] if k % 2011 else math.nan
        dp, dc = py.update(z_ref[k], zk, vz[k], az[k], active), c.update(z_ref[k], zk, vz[k], az[k], active)
        assert abs(dp - dc) <= 1e-5, f"step {k}"
        x_r, last_u, d_h, _ = c.read()
        assert abs(x_r - py.integrator_m_s) <= 1e-4 and abs(last_u - py.last_u) <= 1e-5, f"step {k}"
        saturated += dp in (0.0, 1.0)
    assert saturated > 1000  # the limits and the conditional integration were exercised
    assert c.read()[3] == py.counters["nonfinite_input"] > 0
    assert c.read()[2] == pytest.approx(py.d_h, rel=1e-7)


def test_lqi_step_response_tracks_flightcodes(lib: cfw.Lib, rig_cfg: FlightConfig) -> None:
    """A 5 m step on the linear model, each controller flying its own copy: the heights agree
    within 1e-4 m (the float32 gains and arithmetic)."""
    py, c = lqi_pair(lib, rig_cfg)
    model = py.model
    heights = {}
    for who, ctl in (("py", py), ("c", c)):
        z = vz = az = 0.0
        trace = []
        for k in range(8000):
            d = ctl.update(5.0, f32(z), f32(vz), f32(az), True)
            u = d - model.d_h
            az += (model.k_over_m_mps2 * u - az) / model.T1_s * 0.0025
            vz += az * 0.0025
            z += vz * 0.0025
            trace.append(z)
        heights[who] = np.array(trace)
    assert np.abs(heights["c"] - heights["py"]).max() < 1e-4
    assert heights["py"].max() > 5.2  # it overshoots (docs/controllers.md 3.2), so the integrator mattered
