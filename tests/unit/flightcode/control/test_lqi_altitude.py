"""LQI altitude controller: gains against docs/controllers.md 3.2/3.3, the 5 m step, anti-windup."""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pydantic
import pytest

from flightcode.control.lqi_altitude import G_MPS2, AltitudeModel, LqiAltitude

T = 0.0025


def test_model_numbers_match_paper_section_3_1() -> None:
    m = AltitudeModel()
    assert m.d_h == pytest.approx(0.724, abs=5e-4)
    assert m.k_N == pytest.approx(29.8, abs=0.05)
    assert m.k_over_m_mps2 == pytest.approx(27.1, abs=0.05)
    a, b, c = m.state_space()
    assert b[2, 0] == pytest.approx(338.9, abs=0.2)
    num, den = ct.tfdata(ct.ss2tf(a, b, c, 0))
    # k/((1 + T1 s) m s^2) = 338.9 / (s^3 + 12.5 s^2)
    np.testing.assert_allclose(np.ravel(num[0][0]), [0.0, 0.0, 338.8], atol=0.2)
    np.testing.assert_allclose(np.ravel(den[0][0]), [1.0, 12.5, 0.0, 0.0], atol=1e-9)


def test_model_rejects_a_vehicle_that_cannot_hover_and_validates_from_toml() -> None:
    with pytest.raises(ValueError):
        AltitudeModel(m_kg=2.2)
    adapter = pydantic.TypeAdapter(AltitudeModel)
    assert adapter.validate_python({"m_kg": 1.4}).m_kg == 1.4
    with pytest.raises(pydantic.ValidationError):
        adapter.validate_python({"mass_kg": 1.4})


def test_gains_and_poles_match_paper_section_3_2() -> None:
    lqi = LqiAltitude(AltitudeModel())
    np.testing.assert_allclose(lqi.F1, [0.1415, 0.1103, 0.00796], rtol=2e-3)
    assert lqi.F2 == pytest.approx(-0.0908, rel=2e-3)
    expected = sorted([-12.50, -1.353, -0.673 - 1.169j, -0.673 + 1.169j], key=lambda p: (p.real, p.imag))
    np.testing.assert_allclose(lqi.poles, expected, atol=2e-3)
    assert lqi.K.shape == (1, 4)


def test_lqr_integral_action_cross_check() -> None:
    # python-control's built-in LQI integrates +C x (the opposite sign of the paper's x_r).
    model = AltitudeModel()
    a, b, c = model.state_space()
    k, _, _ = ct.lqr(ct.ss(a, b, np.eye(3), 0), np.diag([0, 0, 0, 8.25e-3]), 1.0, integral_action=c)
    lqi = LqiAltitude(model)
    np.testing.assert_allclose(np.ravel(k)[:3], lqi.F1, rtol=1e-6)
    assert np.ravel(k)[3] == pytest.approx(-lqi.F2, rel=1e-6)


def test_dlqr_with_Ts_scaling_agrees_within_half_a_percent() -> None:
    # docs/controllers.md 3.3: dlqr on the ZOH augmented system with (Q T, R T) -> F_d within 0.3 %.
    model = AltitudeModel()
    a, b, c = model.state_space()
    d = ct.c2d(ct.ss(a, b, c, 0), T, method="zoh")
    ad, bd = np.asarray(d.A), np.asarray(d.B)
    np.testing.assert_allclose(ad, [[1, 0.0025, 3.0e-6], [0, 1, 2.461e-3], [0, 0, 0.96923]], atol=1e-5)
    np.testing.assert_allclose(bd.ravel(), [8.76e-7, 1.048e-3, 0.8341], rtol=1e-3)
    a_aug = np.block([[ad, np.zeros((3, 1))], [-T * c, np.ones((1, 1))]])
    b_aug = np.vstack([bd, [[0.0]]])
    kd, _, _ = ct.dlqr(a_aug, b_aug, np.diag([0, 0, 0, 8.25e-3]) * T, np.array([[1.0]]) * T)
    lqi = LqiAltitude(model)
    np.testing.assert_allclose(np.ravel(kd), [0.14129, 0.11008, 0.00795, -0.09053], rtol=2e-3)
    np.testing.assert_allclose(np.ravel(kd), np.ravel(lqi.K), rtol=5e-3)


def test_linear_5_m_step_of_the_continuous_design() -> None:
    model = AltitudeModel()
    lqi = LqiAltitude(model)
    a, b, c = model.state_space()
    a_aug = np.block([[a, np.zeros((3, 1))], [-c, np.zeros((1, 1))]])
    b_aug = np.vstack([b, [[0.0]]])
    a_cl = a_aug - b_aug @ lqi.K
    sys = ct.ss(a_cl, np.array([[0.0], [0.0], [0.0], [5.0]]), np.array([[1.0, 0, 0, 0]]), 0)
    info = ct.step_info(sys, T=np.linspace(0, 20, 8001), SettlingTimeThreshold=0.02)
    # docs/controllers.md 3.2: rise 1.70 s, 2 % settling 5.00 s, overshoot 0.41 m (8.2 %).
    assert info["Overshoot"] == pytest.approx(8.2, abs=0.2)
    assert info["Peak"] - 5.0 == pytest.approx(0.41, abs=0.01)
    assert info["SettlingTime"] == pytest.approx(5.0, abs=0.1)
    assert info["RiseTime"] == pytest.approx(1.70, abs=0.03)


def _sim_step(lqi: LqiAltitude, model: AltitudeModel, z_ref: float, seconds: float, nonlinear: bool = False) -> dict[str, np.ndarray]:
    """Run update() at 400 Hz on the plant with full-state feedback.

    Linear: the ZOH model of docs/controllers.md 3.1. Nonlinear: thrust F_max d^2 with lag T1, gravity.
    """
    n = int(round(seconds / T))
    z = np.empty(n)
    thr = np.empty(n)
    if not nonlinear:
        a, b, c = model.state_space()
        d = ct.c2d(ct.ss(a, b, c, 0), T)
        ad, bd = np.asarray(d.A).tolist(), np.asarray(d.B).ravel().tolist()
        x = [0.0, 0.0, 0.0]
        for k in range(n):
            thr[k] = lqi.update(z_ref, x[0], x[1], x[2], True)
            u = thr[k] - model.d_h
            x = [sum(ad[i][j] * x[j] for j in range(3)) + bd[i] * u for i in range(3)]
            z[k] = x[0]
    else:
        zz, vz, f = 0.0, 0.0, model.m_kg * G_MPS2
        sub = 10
        h = T / sub
        for k in range(n):
            az = f / model.m_kg - G_MPS2
            thr[k] = lqi.update(z_ref, zz, vz, az, True)
            f_cmd = model.F_max_N * thr[k] ** 2
            for _ in range(sub):
                az = f / model.m_kg - G_MPS2
                zz, vz = zz + h * vz, vz + h * az
                f += h * (f_cmd - f) / model.T1_s
            z[k] = zz
    return {"z": z, "throttle": thr}


def _settling_time(z: np.ndarray, target: float, band: float) -> float:
    outside = np.nonzero(np.abs(z - target) > band)[0]
    return (outside[-1] + 1) * T if outside.size else 0.0


def test_discrete_update_reproduces_the_5_m_step() -> None:
    model = AltitudeModel()
    lqi = LqiAltitude(model)
    r = _sim_step(lqi, model, 5.0, 12.0)
    # docs/controllers.md 3.3: emulating the continuous F at 400 Hz: overshoot 0.412 m, settling 5.00 s.
    assert r["z"].max() - 5.0 == pytest.approx(0.41, abs=0.02)
    assert _settling_time(r["z"], 5.0, 0.1) == pytest.approx(5.0, abs=0.15)
    assert np.all((r["throttle"] >= 0.0) & (r["throttle"] <= 1.0))
    # docs/controllers.md 3.2: peak throttle deviation +0.106.
    assert r["throttle"].max() - model.d_h == pytest.approx(0.106, abs=0.01)


def test_nonlinear_thrust_step_stays_close() -> None:
    # docs/controllers.md 3.5 case B (full state, nonlinear plant): overshoot 0.44 m, settle +-0.25 m 4.65 s.
    model = AltitudeModel()
    r = _sim_step(LqiAltitude(model), model, 5.0, 12.0, nonlinear=True)
    assert r["z"].max() - 5.0 == pytest.approx(0.44, abs=0.05)
    assert _settling_time(r["z"], 5.0, 0.25) == pytest.approx(4.65, abs=0.3)


def test_conditional_integration_stops_windup_while_saturated() -> None:
    model = AltitudeModel()
    lqi = LqiAltitude(model)
    # Vehicle held on the ground (estimates stay 0) while the reference is 50 m up: the output
    # saturates at full throttle after 25 ticks, and from then on the integrator must not grow.
    outs = []
    for _ in range(400):
        outs.append(lqi.update(50.0, 0.0, 0.0, 0.0, True))
        if outs[-1] < 1.0:
            x_r_at_saturation = lqi.integrator_m_s
    assert outs[-1] == 1.0 and outs.count(1.0) > 350
    assert lqi.integrator_m_s == x_r_at_saturation == pytest.approx(25 * T * 50.0)
    assert lqi.last_u == pytest.approx(1.0 - model.d_h)
    # An error in the other direction unwinds (integrates) even while saturated high.
    before = lqi.integrator_m_s
    assert lqi.update(-1.0, 0.0, -50.0, 0.0, True) == 1.0
    assert lqi.integrator_m_s == pytest.approx(before - T * 1.0)


def test_without_anti_windup_the_integrator_would_grow() -> None:
    # A sanity check of the test above: in the linear range the integrator integrates.
    lqi = LqiAltitude(AltitudeModel())
    lqi.update(0.5, 0.0, 0.0, 0.0, True)
    assert lqi.integrator_m_s == pytest.approx(T * 0.5)


def test_saturated_low_output_and_negative_error_freezes_integrator() -> None:
    lqi = LqiAltitude(AltitudeModel())
    out = lqi.update(0.0, 50.0, 0.0, 0.0, True)
    assert out == 0.0 and lqi.integrator_m_s == 0.0


def test_inactive_resets_the_integrator_and_returns_zero() -> None:
    lqi = LqiAltitude(AltitudeModel())
    for _ in range(100):
        lqi.update(1.0, 0.0, 0.0, 0.0, True)
    assert lqi.integrator_m_s > 0.0
    assert lqi.update(1.0, 0.0, 0.0, 0.0, False) == 0.0
    assert lqi.integrator_m_s == 0.0 and lqi.last_u == 0.0
    # Active again from rest at the reference: hover throttle exactly.
    assert lqi.update(0.0, 0.0, 0.0, 0.0, True) == pytest.approx(AltitudeModel().d_h)


def test_non_finite_estimate_holds_output() -> None:
    lqi = LqiAltitude(AltitudeModel())
    d = lqi.update(1.0, 0.0, 0.0, 0.0, True)
    assert lqi.update(1.0, math.nan, 0.0, 0.0, True) == d
    assert lqi.counters["nonfinite_input"] == 1


def test_bad_construction_is_rejected() -> None:
    with pytest.raises(ValueError):
        LqiAltitude(AltitudeModel(), q_int=0.0)
    with pytest.raises(ValueError):
        LqiAltitude(AltitudeModel(), u_min=0.1)


def _damped_step(lqi: LqiAltitude, model: AltitudeModel, c_N_per_mps: float) -> tuple[float, float, np.ndarray]:
    """(overshoot m, settling s into +-0.25 m, closed-loop poles) of a linear 5 m step on the
    design model plus a vertical damping force -c z' (full state feedback, z'' measured)."""
    a, b, _ = model.state_space()
    a = a.copy()
    a[1, 1] = -c_N_per_mps / model.m_kg  # z'' = a_thrust - (c/m) z'
    k = lqi.K.ravel()
    # u = -(k0 z + k1 z' + k2 z'') - k3 x_r with z'' = a_thrust - (c/m) z'
    u_row = np.array([-k[0], -k[1] + k[2] * c_N_per_mps / model.m_kg, -k[2], -k[3]])
    a_cl = np.zeros((4, 4))
    a_cl[:3, :3] = a
    a_cl[3, 0] = -1.0
    a_cl[:3, :] += b @ u_row[None, :]
    sys = ct.ss(a_cl, np.array([[0.0], [0.0], [0.0], [5.0]]), np.array([[1.0, 0, 0, 0]]), 0)
    t, y = ct.step_response(sys, np.linspace(0.0, 30.0, 12001))
    outside = np.nonzero(np.abs(y - 5.0) > 0.25)[0]
    return float(np.max(y) - 5.0), float(t[outside[-1] + 1]), np.linalg.eigvals(a_cl)


def test_rig_weights_give_the_5_s_step_on_a_plant_with_rotor_inflow_damping() -> None:
    """Issue 13: the bench's plant damps vertical motion (rotor inflow drag k_z omega per
    rotor plus body drag, 1.5 N/(m/s)); the paper's model k/((1 + T1 s) m s^2) does not. With
    the docs/controllers.md 3.2 weights the loop slows and overshoots (settling past 6 s; 6-11 s on the
    bench); the weights the rig flies (rigs/paper-quad.toml [flight.overrides.altitude])
    restore about 5 s and 0.5 m. Damping from the rig's own plant parameters."""
    import tomllib
    from pathlib import Path

    rig = tomllib.loads((Path(__file__).parents[4] / "rigs" / "paper-quad.toml").read_text())
    aero, rotors = rig["plant"]["aero"], rig["plant"]["rotors"]
    model = AltitudeModel()
    omega_hover_radps = rotors["omega_max_radps"] * math.sqrt(model.m_kg * G_MPS2 / (4.0 * rotors["thrust_max_N"]))
    c = 4.0 * aero["rotor_drag_vertical_N_per_mps_per_radps"] * omega_hover_radps + aero["linear_drag_B_N_per_mps"][2]
    assert c == pytest.approx(1.51, abs=0.01)

    overshoot, settling, _ = _damped_step(LqiAltitude(model), model, 0.0)
    assert (overshoot, settling) == (pytest.approx(0.41, abs=0.01), pytest.approx(4.5, abs=0.05))
    overshoot, settling, poles = _damped_step(LqiAltitude(model), model, c)
    assert overshoot > 0.7 and settling > 6.0
    assert max(p.real for p in poles) == pytest.approx(-0.45, abs=0.01)

    weights = rig["flight"]["overrides"]["altitude"]
    overshoot, settling, _ = _damped_step(LqiAltitude(model, **weights), model, c)
    assert 0.4 <= overshoot <= 0.65 and settling <= 5.0
