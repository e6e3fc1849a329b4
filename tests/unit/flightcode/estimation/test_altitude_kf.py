"""Altitude Kalman filter (docs/controllers.md 3.5): discretisation, steady state vs control.dlqe, tracking
with a quantised barometer, disturbance and bias convergence, partial updates."""

from __future__ import annotations

import copy
import math

import control as ct
import numpy as np
import pytest
import scipy.linalg

from flightcode.control.lqi_altitude import AltitudeModel
from flightcode.estimation.altitude_kf import AltitudeKF

T = 0.0025


@pytest.fixture(scope="module")
def model() -> AltitudeModel:
    return AltitudeModel()


def test_discrete_matrices(model: AltitudeModel) -> None:
    kf = AltitudeKF(model)
    a, b = AltitudeKF.continuous_model(model)
    np.testing.assert_allclose(kf.kf.F, scipy.linalg.expm(a * T), atol=1e-15)
    # docs/controllers.md 3.3 (the [z, z', a] block and B).
    np.testing.assert_allclose(kf.kf.F[:3, :3], [[1, 0.0025, 3.0e-6], [0, 1, 2.461e-3], [0, 0, 0.96923]], atol=1e-5)
    np.testing.assert_allclose(kf.kf.B.ravel()[:3], [8.76e-7, 1.048e-3, 0.8341], rtol=1e-3)
    # Van Loan, independently: expm([[-A, G W G^T], [0, A^T]] T).
    w = np.diag([0.0, 0.0, 2.0, 0.05, 1e-6])
    m = np.block([[-a, w], [np.zeros((5, 5)), a.T]]) * T
    e = scipy.linalg.expm(m)
    q = e[5:, 5:].T @ e[:5, 5:]
    np.testing.assert_allclose(kf.kf.Q, q, rtol=1e-9, atol=1e-20)
    # First-order sanity: the a, d, b diagonal ~ PSD x T.
    assert kf.kf.Q[3, 3] == pytest.approx(0.05 * T) and kf.kf.Q[4, 4] == pytest.approx(1e-6 * T)
    np.testing.assert_array_equal(kf.kf.H, [[1, 0, 0, 0, 0], [0, 0, 1, 1, 1]])
    np.testing.assert_array_equal(kf.kf.R, np.diag([1.28, 0.091]))


def test_steady_state_covariance_matches_dlqe(model: AltitudeModel) -> None:
    kf = AltitudeKF(model)
    f = kf.kf
    _, p_ss, poles = ct.dlqe(f.F, np.eye(5), f.H, f.Q, f.R)
    assert np.max(np.abs(poles)) < 1.0
    # docs/controllers.md 3.4: steady-state prior std of the altitude 0.050 m.
    assert math.sqrt(p_ss[0, 0]) == pytest.approx(0.050, abs=1e-3)
    # The Riccati solution is a fixed point of filterpy's predict/update...
    f.P = np.array(p_ss)
    f.update(np.array([0.0, 0.0]))
    f.predict(u=0.0)
    np.testing.assert_allclose(f.P_prior, p_ss, rtol=1e-8, atol=1e-14)
    # ...and the filter converges to it from the reset covariance. The slowest mode is the
    # bias (pole 0.99983, a 15 s time constant): within 0.5 % after 60 s.
    kf.reset(0.0)
    for _ in range(24000):
        kf.update(0.0, 0.0)
        kf.predict(0.0)
    scale = np.sqrt(np.outer(np.diag(p_ss), np.diag(p_ss)))
    assert np.max(np.abs(kf.P - p_ss) / scale) < 5e-3  # kf.P after predict is the prior


def test_tracks_a_trajectory_with_quantised_baro_and_learns_disturbance_and_bias(model: AltitudeModel) -> None:
    """Truth: the linear model with a payload-like disturbance d = -0.6 m/s^2 (the throttle
    counters it), accelerometer bias 0.15 m/s^2, 0.3 m/s^2 vibration noise, and a barometer
    quantised at 2.26 m per ADC code dithered by 0.5 mV (0.93 m) of noise (docs/controllers.md 3.4)."""
    kf = AltitudeKF(model)
    rng = np.random.default_rng(11)
    f = kf.kf.F.tolist()
    b = kf.kf.B.ravel().tolist()
    d_true, b_true, lsb_m = -0.6, 0.15, 2.26
    u_hold = -d_true / model.k_over_m_mps2
    x = [3.0, 0.0, -d_true, d_true, b_true]  # hovering: thrust deviation cancels d
    kf.reset(0.0)  # starts 3 m off
    n = int(60.0 / T)
    z_err = np.empty(n)
    v_err = np.empty(n)
    a_err = np.empty(n)
    for k in range(n):
        t = k * T
        u = u_hold + 0.02 * math.cos(2 * math.pi * 0.3 * t) + 0.01 * math.cos(2 * math.pi * 1.1 * t)
        x = [sum(f[i][j] * x[j] for j in range(5)) + b[i] * u for i in range(5)]
        z_baro = lsb_m * round((x[0] + rng.normal(0.0, 0.93)) / lsb_m)
        a_up = x[2] + x[3] + x[4] + rng.normal(0.0, 0.3)
        kf.predict(u)
        kf.update(z_baro, a_up)
        z_err[k] = kf.z_m - x[0]
        v_err[k] = kf.vz_mps - x[1]
        a_err[k] = kf.az_mps2 - (x[2] + x[3])
    late = slice(int(20.0 / T), None)
    # docs/controllers.md 3.4: 0.054 m RMS with a dithered ADC; measured here 0.039 m (vz 0.021 m/s,
    # a + d 0.093 m/s^2; d -0.617, b 0.145 after 60 s).
    assert float(np.sqrt(np.mean(z_err[late] ** 2))) < 0.1
    assert float(np.sqrt(np.mean(v_err[late] ** 2))) < 0.06
    assert float(np.sqrt(np.mean(a_err[late] ** 2))) < 0.2  # steady-state std of a + d: 0.13
    assert abs(z_err[0]) > 1.0  # it really had to converge
    assert kf.disturbance_mps2 == pytest.approx(d_true, abs=0.1)
    assert kf.bias_mps2 == pytest.approx(b_true, abs=0.05)
    assert max(abs(v) for v in (x[0], x[1])) < 10.0  # the truth stayed a sane trajectory


def test_positive_throttle_deviation_accelerates_up(model: AltitudeModel) -> None:
    kf = AltitudeKF(model)
    for _ in range(200):
        kf.predict(0.05)
    assert kf.a_thrust_mps2 == pytest.approx(0.05 * model.k_over_m_mps2, rel=0.01)
    assert kf.vz_mps > 0.0 and kf.z_m > 0.0
    assert kf.az_mps2 == kf.a_thrust_mps2 + kf.disturbance_mps2


def test_in_place_filter_equals_filterpy(model: AltitudeModel) -> None:
    """The per-sample arithmetic against filterpy's KalmanFilter (Joseph-form update, joint
    2-D measurement, update_sequential for one) on the same design: random throttle and
    measurements, some missing, for 10 s."""
    kf = AltitudeKF(model, r_baro_m2=0.2)
    ref = copy.deepcopy(kf.kf)
    ref.x = np.zeros((5, 1))
    ref.P = kf.P
    rng = np.random.default_rng(5)
    for k in range(4000):
        u = float(rng.normal(0.0, 0.05))
        kf.predict(u)
        ref.predict(u=u)
        z = float(rng.normal(1.0, 0.5)) if k % 7 else None
        a = float(rng.normal(0.0, 0.3)) if k % 11 else None
        kf.update(z, a)
        if z is not None and a is not None:
            ref.update(np.array([z, a]))
        elif z is not None:
            ref.update_sequential(0, z)
        elif a is not None:
            ref.update_sequential(1, a)
        if k % 500 == 0:
            np.testing.assert_allclose(kf.x, ref.x.ravel(), rtol=1e-9, atol=1e-12)
            np.testing.assert_allclose(kf.P, ref.P, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(kf.x, ref.x.ravel(), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(kf.P, ref.P, rtol=1e-9, atol=1e-15)
    assert np.array_equal(kf.P, kf.P.T)


def test_at_rest_an_accelerometer_offset_becomes_bias_not_a_fall(model: AltitudeModel) -> None:
    """On the ground with a 0.53 g offset on the accelerometer (the bench's seed-1 ADXL335; the
    datasheet allows up to 1 g on Z): without the zero-velocity update the filter reads it as
    a fall and the estimate sinks (-0.6 m here, as on the bench with r_baro 1.28 m^2); with it,
    the offset goes into b and the estimate stays at the barometer's height."""
    offset = -5.2

    def sit(rest: bool) -> tuple[AltitudeKF, float]:
        rng = np.random.default_rng(3)
        kf = AltitudeKF(model)
        kf.reset(0.0, z_var_m2=0.45**2 / 400)  # the boot reference: 1 s of 0.45 m samples averaged
        worst = 0.0
        for _ in range(1600):  # four seconds disarmed
            kf.predict(0.0)
            kf.update(float(rng.normal(0.0, 0.45)), offset + float(rng.normal(0.0, 0.05)))
            if rest:
                kf.update_at_rest()
            worst = max(worst, abs(kf.z_m))
        return kf, worst

    kf, worst = sit(rest=False)
    assert worst > 0.4
    kf, worst = sit(rest=True)
    assert worst < 0.05 and abs(kf.vz_mps) < 0.01
    assert kf.bias_mps2 == pytest.approx(offset, abs=0.05) and abs(kf.disturbance_mps2) < 0.05


def test_sequential_partial_updates_equal_the_joint_update(model: AltitudeModel) -> None:
    kf = AltitudeKF(model)
    for k in range(50):
        kf.predict(0.01)
        kf.update(0.1 * k, 0.2)
    kf.predict(0.0)
    joint, seq = copy.deepcopy(kf), copy.deepcopy(kf)
    joint.update(1.3, -0.4)
    seq.update(1.3, None)
    seq.update(None, -0.4)
    np.testing.assert_allclose(seq.x, joint.x, rtol=1e-10, atol=1e-13)
    np.testing.assert_allclose(seq.P, joint.P, rtol=1e-10, atol=1e-15)


def test_missing_measurements(model: AltitudeModel) -> None:
    kf = AltitudeKF(model)
    for _ in range(4000):
        kf.predict(0.0)
        kf.update(2.0, 0.0)
    p_z = kf.P_diag[0]
    x = kf.x
    kf.update(None, None)
    np.testing.assert_array_equal(kf.x, x)
    for _ in range(400):  # one second without barometer: altitude uncertainty grows
        kf.predict(0.0)
        kf.update(None, 0.0)
    assert kf.P_diag[0] > 2 * p_z
    for _ in range(400):
        kf.predict(0.0)
        kf.update(2.0, None)
    assert kf.z_m == pytest.approx(2.0, abs=0.2)
    kf.update(math.nan, math.inf)
    assert kf.counters["nonfinite_baro"] == 1 and kf.counters["nonfinite_acc"] == 1
    kf.predict(math.nan)
    assert kf.counters["nonfinite_input"] == 1 and math.isfinite(kf.z_m)


def test_reset(model: AltitudeModel) -> None:
    kf = AltitudeKF(model, r_baro_m2=2.0)
    for _ in range(100):
        kf.predict(0.1)
        kf.update(5.0, 1.0)
    kf.reset(1.5)
    assert (kf.z_m, kf.vz_mps, kf.az_mps2, kf.bias_mps2) == (1.5, 0.0, 0.0, 0.0)
    assert kf.P_diag == (2.0, 0.01, 0.01, 1.0, 0.25)
    kf.reset(0.0, z_var_m2=0.001)
    assert kf.P_diag == (0.001, 0.01, 0.01, 1.0, 0.25)


def test_rejects_bad_noise(model: AltitudeModel) -> None:
    with pytest.raises(ValueError):
        AltitudeKF(model, r_baro_m2=0.0)
    with pytest.raises(ValueError):
        AltitudeKF(model, q_a=-1.0)


def test_loosened_height_is_re_anchored_by_the_barometer_at_rest(model: AltitudeModel) -> None:
    """After a hard landing the estimate can be 0.7 m off while its covariance says a few cm
    (the bench's mission run); at rest the zero-velocity update then freezes the error.
    Loosening the height first lets the barometer put it right within a second."""

    def settle(loosen: bool) -> float:
        rng = np.random.default_rng(8)
        kf = AltitudeKF(model, r_baro_m2=0.33)
        kf.reset(0.7, z_var_m2=0.0005)  # confidently wrong: the truth is 0 m
        if loosen:
            kf.loosen_height(0.33)
            assert kf.P[0, 0] == 0.33 and not kf.P[0, 1:].any() and not kf.P[1:, 0].any()
            assert np.all(np.linalg.eigvalsh(kf.P) >= 0.0)
        for _ in range(400):
            kf.predict(0.0)
            kf.update(float(rng.normal(0.0, 0.44)), float(rng.normal(0.0, 0.05)))
            kf.update_at_rest()
        return abs(kf.z_m)

    assert settle(loosen=False) > 0.3  # measured 0.43 m after 1 s
    assert settle(loosen=True) < 0.05  # measured 0.01 m


def test_moved_to_a_height_found_elsewhere_the_filter_flies_on_from_there(model: AltitudeModel) -> None:
    """The barometer-motion check's re-anchor (flightcode/estimation/baro_motion.py): height,
    velocity and the disturbance the filter bent to fit a blocked barometer are set, the
    covariance stays valid, and on the accelerometer alone the filter holds the new state."""
    kf = AltitudeKF(model, r_baro_m2=0.33)
    kf.reset(2.0)
    for _ in range(400):  # a filter that has fitted a barometer stuck at 2 m
        kf.predict(0.05)
        kf.update(2.0, 0.0)
    assert abs(kf.disturbance_mps2) > 0.1  # it made the thrust's climb a disturbance
    kf.move_to(4.0, 0.5, 0.25, 0.04)
    assert (kf.z_m, kf.vz_mps, kf.disturbance_mps2) == (4.0, 0.5, 0.0)
    P = kf.P
    assert (P[0, 0], P[1, 1], P[3, 3]) == (0.25, 0.04, 1.0)
    assert not P[[0, 1, 3]][:, [2, 4]].any() and not P[0, 1] and not P[0, 3] and not P[1, 3]
    assert np.allclose(P, P.T) and np.all(np.linalg.eigvalsh(P) >= 0.0)
    for _ in range(200):  # 0.5 s level, on the accelerometer: the climb rate carries the height
        kf.predict(0.0)
        kf.update(None, 0.0)
    assert abs(kf.z_m - (4.0 + 0.5 * 0.5)) < 0.05 and abs(kf.vz_mps - 0.5) < 0.05


# -- barometer innovation gate ------------------------------------------------------------------
def _hovering(model: AltitudeModel, gate: float = 25.0, timeout_s: float = 1.0, seconds: float = 10.0,
              seed: int = 2) -> tuple[AltitudeKF, np.random.Generator]:
    """A filter settled on a vehicle holding 2 m (baro noise 0.44 m, accelerometer 0.3 m/s^2)."""
    rng = np.random.default_rng(seed)
    kf = AltitudeKF(model, r_baro_m2=0.33, baro_gate_chi2=gate, baro_gate_timeout_s=timeout_s)
    kf.reset(2.0, z_var_m2=0.001)
    for _ in range(int(seconds / T)):
        kf.predict(0.0)
        kf.update(2.0 + float(rng.normal(0.0, 0.44)), float(rng.normal(0.0, 0.3)))
    return kf, rng


def test_gate_rejects_a_baro_spike_that_the_ungated_filter_follows(model: AltitudeModel) -> None:
    """fault-baro-spike: +150 Pa for 0.2 s reads 12.5 m low. Fused, it drags the estimate
    (and so the altitude loop) metres away; gated, every spike reading is refused and counted."""

    def worst_error(gate: float) -> tuple[float, AltitudeKF]:
        kf, rng = _hovering(model, gate)
        worst = 0.0
        for k in range(int(3.0 / T)):
            spike = -12.5 if k < 80 else 0.0
            kf.predict(0.0)
            kf.update(2.0 + spike + float(rng.normal(0.0, 0.44)), float(rng.normal(0.0, 0.3)))
            worst = max(worst, abs(kf.z_m - 2.0))
        return worst, kf

    ungated, kf = worst_error(math.inf)
    assert ungated > 1.0 and kf.counters["baro_rejected"] == 0  # measured 2.76 m
    gated, kf = worst_error(25.0)
    assert gated < 0.15  # measured 0.05 m (the noise)
    assert kf.counters["baro_rejected"] == 80 and kf.counters["baro_reanchored"] == 0
    assert kf.baro_reject_run == 0  # readings accepted again after the spike


def test_gate_lets_gaussian_noise_and_a_climb_through(model: AltitudeModel) -> None:
    # 60 s of 0.44 m baro noise at hover and a 1 m/s climb with a consistent accelerometer:
    # a 5-sigma gate refuses nothing (one false rejection per ~1.7 million readings).
    kf, rng = _hovering(model, seconds=60.0)
    assert kf.counters["baro_rejected"] == 0
    z, vz = 2.0, 0.0
    for k in range(int(8.0 / T)):
        a = 1.0 if k < 400 else (-1.0 if 2400 <= k < 2800 else 0.0)  # to 1 m/s, 5 s, back to 0
        vz += a * T
        z += vz * T
        kf.predict(a / model.k_over_m_mps2)
        kf.update(z + float(rng.normal(0.0, 0.44)), a + float(rng.normal(0.0, 0.3)))
    assert kf.counters["baro_rejected"] == 0
    assert kf.z_m == pytest.approx(z, abs=0.3)


def test_gate_decision_is_the_chi_square_test(model: AltitudeModel) -> None:
    """One reading: refused exactly when innovation^2 > chi2 (P_zz + R); a refused reading
    leaves state and covariance untouched."""
    kf, _ = _hovering(model, seconds=2.0)
    kf.predict(0.0)
    s = kf.P[0, 0] + kf.r_baro_m2
    for factor, fused in ((0.99, True), (1.01, False)):
        trial = copy.deepcopy(kf)
        x, p = trial.x, trial.P
        innovation = factor * math.sqrt(25.0 * s)
        assert trial.update(trial.z_m - innovation, None) is fused
        if fused:
            assert trial.z_m < x[0]
        else:
            np.testing.assert_array_equal(trial.x, x)
            np.testing.assert_array_equal(trial.P, p)
            assert trial.counters["baro_rejected"] == 1
    assert kf.update(None, 0.0) is True  # no reading: nothing refused


def test_a_lasting_disagreement_re_anchors_the_height_to_the_baro(model: AltitudeModel) -> None:
    """A baro offset that stays (weather, a blocked port, or the estimate was the wrong one)
    is refused for baro_gate_timeout_s, then believed: the height jumps to it at once."""
    kf, rng = _hovering(model, timeout_s=0.5)
    for k in range(int(1.0 / T)):
        kf.predict(0.0)
        kf.update(-8.0 + float(rng.normal(0.0, 0.44)), float(rng.normal(0.0, 0.3)))
        if k == 198:
            assert kf.z_m == pytest.approx(2.0, abs=0.1) and kf.baro_reject_run == 199
        if k == 199:  # the 200th refusal in a row (0.5 s): re-anchored on this reading
            assert kf.counters["baro_reanchored"] == 1 and kf.baro_reject_run == 0
            assert kf.z_m == pytest.approx(-8.0, abs=1.0)
    assert kf.counters["baro_rejected"] == 200 and kf.counters["baro_reanchored"] == 1
    assert kf.z_m == pytest.approx(-8.0, abs=0.2)
    assert np.all(np.linalg.eigvalsh(kf.P) >= 0.0)


def test_gate_parameters_are_checked(model: AltitudeModel) -> None:
    with pytest.raises(ValueError):
        AltitudeKF(model, baro_gate_chi2=0.0)
    with pytest.raises(ValueError):
        AltitudeKF(model, baro_gate_timeout_s=-1.0)
    assert AltitudeKF(model).baro_gate_chi2 == math.inf  # the paper's filter: no gate unless asked
