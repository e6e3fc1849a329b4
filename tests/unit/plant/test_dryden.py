"""Dryden turbulence: MIL-F-8785C intensities and spectra, exact discretisation, seeding,
frames, and the per-rotor gust differences that make moments."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hil.plant import PlantParams, WindParams
from hil.plant.dryden import (
    DrydenFilter,
    continuous_model,
    discretize,
    expm,
    low_altitude_intensity,
    stationary_covariance,
)
from hil.plant.hub_gusts import gust_offsets_B
from hil.plant.wind import WindModel
from tests.unit.plant.support import make_plant

DT_S = 0.0025


def test_low_altitude_intensities_follow_mil_f_8785c() -> None:
    # at 20 ft with W20 = 30 kt (moderate): sigma_w = 3 kt, sigma_u = sigma_w / (0.177 + 0.01646)^0.4
    i = low_altitude_intensity(15.4333, 20 * 0.3048)
    assert i.sigma_w_mps == pytest.approx(1.54333)
    assert i.sigma_u_mps == pytest.approx(1.54333 / (0.177 + 0.000823 * 20) ** 0.4)
    assert i.L_w_m == pytest.approx(20 * 0.3048)
    assert i.L_u_m == pytest.approx(20 / (0.177 + 0.000823 * 20) ** 1.2 * 0.3048)
    # below 10 ft the 10 ft values; above 1000 ft the 1000 ft values
    assert low_altitude_intensity(3.0, 0.5) == low_altitude_intensity(3.0, 10 * 0.3048)
    assert low_altitude_intensity(3.0, 2000.0) == low_altitude_intensity(3.0, 1000 * 0.3048)
    # scale length grows with height
    assert low_altitude_intensity(3.0, 50.0).L_w_m > low_altitude_intensity(3.0, 5.0).L_w_m


def test_expm_matches_a_known_exponential() -> None:
    a = np.array([[0.0, 1.0], [-4.0, 0.0]])  # harmonic oscillator, w = 2
    t = 0.7
    expected = np.array([[math.cos(2 * t), math.sin(2 * t) / 2], [-2 * math.sin(2 * t), math.cos(2 * t)]])
    np.testing.assert_allclose(expm(a * t), expected, atol=1e-12)


@pytest.mark.parametrize("v_mps", [1.0, 2.5, 10.0])
def test_stationary_output_rms_equals_the_spec(v_mps: float) -> None:
    """Variances of u, v, w are sigma^2 and of dw/dy the integral of the MIL p_g spectrum,
    whatever the speed; the discrete model keeps the stationary covariance."""
    i = low_altitude_intensity(4.0, 2.0)
    span = 0.66
    a, b, c = continuous_model(i, v_mps, span)
    p = stationary_covariance(a, b)
    var = np.diag(c @ p @ c.T)
    sp2 = i.sigma_w_mps**2 * 0.8 * math.pi**2 / (8 * span) * (math.pi / (4 * span)) ** (1 / 3) / i.L_w_m ** (2 / 3)
    np.testing.assert_allclose(np.sqrt(var[[0, 1, 2, 5]]), [i.sigma_u_mps, i.sigma_v_mps, i.sigma_w_mps, math.sqrt(sp2)], rtol=1e-9)
    phi, qd = discretize(a, b, DT_S)
    np.testing.assert_allclose(phi @ p @ phi.T + qd, p, rtol=1e-7, atol=1e-12)


def test_spectrum_of_w_matches_the_dryden_form() -> None:
    """The w filter's frequency response squared is sigma^2 L/(pi V) (1 + 3 (L w/V)^2) / (1 + (L w/V)^2)^2."""
    i = low_altitude_intensity(4.0, 2.0)
    v = 2.5
    a, b, c = continuous_model(i, v, 0.66)
    for w in (0.1, 1.0, 5.0, 30.0):
        h = c[2] @ np.linalg.solve(1j * w * np.eye(8) - a, b[:, 2])
        x = i.L_w_m * w / v
        expected = i.sigma_w_mps**2 * i.L_w_m / (math.pi * v) * (1 + 3 * x * x) / (1 + x * x) ** 2
        assert abs(h) ** 2 == pytest.approx(expected, rel=1e-9)


def test_gradient_along_the_wind_is_the_convected_time_derivative() -> None:
    """dw/dx = -(1/V) dw/dt, lagged by 4b/(pi V): its response to the w noise is
    -(jw/V)/(1 + jw 4b/(pi V)) times w's."""
    i = low_altitude_intensity(4.0, 2.0)
    v, span = 2.5, 0.66
    a, b, c = continuous_model(i, v, span)
    for w in (0.3, 3.0, 20.0):
        r = np.linalg.solve(1j * w * np.eye(8) - a, b[:, 2])
        expected = -(1j * w / v) / (1 + 1j * w * 4 * span / (math.pi * v)) * (c[2] @ r)
        assert c[4] @ r == pytest.approx(expected, rel=1e-9)


def test_sampled_series_has_the_right_rms() -> None:
    i = low_altitude_intensity(3.0, 2.0)
    f = DrydenFilter(np.random.default_rng(7), DT_S)
    f.set_conditions(i, 3.0, 0.66)
    out = np.empty((40_000, 6))
    for k in range(len(out)):
        f.step()
        out[k] = f.output()
    # w and dw/dy decorrelate in well under a second: 100 s of data gives a few % accuracy
    assert np.std(out[:, 2]) == pytest.approx(i.sigma_w_mps, rel=0.1)
    a, b, c = continuous_model(i, 3.0, 0.66)
    p = stationary_covariance(a, b)
    assert np.std(out[:, 5]) == pytest.approx(math.sqrt((c @ p @ c.T)[5, 5]), rel=0.1)


def _dryden_wind(seed: int, mean=(2.0, 1.5, 0.0), **kw) -> WindModel:
    return WindModel(WindParams(mean_N_mps=mean, dryden=True, **kw), np.random.default_rng(seed))


def test_same_seed_same_series_whatever_the_call_pattern() -> None:
    a, b = _dryden_wind(3), _dryden_wind(3)
    ta = [a.at(k * 2_500_000, 2.0) for k in range(400)]
    tb = []
    for k in range(0, 400, 4):  # called 4x less often: same values on its grid
        tb.append(b.at(k * 2_500_000, 2.0))
    assert tb == ta[::4]
    assert _dryden_wind(4).at(400 * 2_500_000, 2.0) != a.at(400 * 2_500_000, 2.0)


def test_rebuilding_the_filter_keeps_the_white_noise_sequence() -> None:
    """Grid step k is driven by the k-th row of deviates whatever set_conditions did: a
    rebuild with the same conditions (every step, mid-block) changes nothing, and one with
    other conditions only re-shapes the same deviates."""
    i = low_altitude_intensity(7.72, 2.0)
    a, b = DrydenFilter(np.random.default_rng(5), DT_S), DrydenFilter(np.random.default_rng(5), DT_S)
    a.set_conditions(i, 7.72, 0.66)
    b.set_conditions(i, 7.72, 0.66)
    out_a, out_b = [], []
    for _ in range(700):  # several 256-row blocks
        a.step()
        b.set_conditions(i, 7.72, 0.66)
        b.step()
        out_a.append(a.output())
        out_b.append(b.output())
    assert out_a == out_b
    # Other conditions in between: the deviates of each step are still the stream's own
    c = DrydenFilter(np.random.default_rng(5), DT_S)
    c.set_conditions(i, 7.72, 0.66)
    other = low_altitude_intensity(7.72, 30.0)
    c.set_conditions(other, 7.72, 0.66)
    for _ in range(100):
        c.step()
    c.set_conditions(i, 7.72, 0.66)
    rng = np.random.default_rng(5)
    rng.standard_normal(8)  # the initial state's draw
    raw = rng.standard_normal((256, 8))
    np.testing.assert_array_equal(c._noise, raw @ c._l.T)


def test_twin_plants_get_the_same_turbulence_whatever_their_heights() -> None:
    """Two vehicles, same seed: one takes a 300 g payload and sinks, crossing other 5 %
    height bands at other times (below the MIL model's 10 ft floor, so at the same
    intensities). The wind they fly in stays identical, sample for sample: a twin run with
    and without a payload compares the vehicles, not two turbulence draws. (Redrawing the
    noise block on every band change made the series part after the first difference.)"""
    params = replace(PlantParams(), wind=WindParams(mean_N_mps=(6.18, 4.63, 0.0), dryden=True))
    light, heavy = make_plant(params, seed=3), make_plant(params, seed=3)
    winds: list[list[tuple[float, float, float]]] = [[], []]
    heights: list[list[float]] = [[], []]
    for plant in (light, heavy):
        plant.set_kinematic_state((0.0, 0.0, -2.8), rotor_omega_radps=(607.0,) * 4)
    heavy.set_payload(0.3, (0.0, 0.02, 0.0))
    throttle = 607.0 / light.omega_max_radps
    for k in range(1, 401):  # 1 s: the heavy one sinks about 1.3 m
        for j, plant in enumerate((light, heavy)):
            plant.step(k * 2_500_000, [throttle] * 4)
            winds[j].append(plant.state.wind_N_mps)
            heights[j].append(plant.state.h_m)
    bands = [np.floor(np.log(np.array(h)) / math.log(1.05)) for h in heights]
    assert np.any(bands[0] != bands[1]) and min(heights[1]) > 0.5
    assert winds[0] == winds[1]


def test_wind_axes_follow_the_mean_wind_heading() -> None:
    """With the mean wind towards the east, the along-wind gradient dw/dx of wind axes is
    d(wind_D)/d(east) in NED, and dv/dx is d(wind_N)/d(east) with the sign of v's axis
    (wind-axis y points south then)."""
    east = _dryden_wind(5, mean=(0.0, 3.0, 0.0))
    north = _dryden_wind(5, mean=(3.0, 0.0, 0.0))
    for k in range(1, 50):
        east.at(k * 2_500_000, 2.0)
        north.at(k * 2_500_000, 2.0)
    ge, gn = east.gradient_N, north.gradient_N
    # same seed, same wind-axis series: the heading turns the gradient by 90 deg
    assert ge[8] == 0.0 and gn[8] == 0.0  # nothing varies with height (no d/dz terms)
    assert ge[7] == pytest.approx(gn[6])  # dw/d(east) with wind east == dw/d(north) with wind north
    assert ge[6] == pytest.approx(-gn[7])  # dw/dy: wind-axis y is south when the wind blows east
    assert ge[1] == pytest.approx(-gn[3])  # dv/dx: v is -north for an east wind, +east for a north wind
    tn, te = north.turbulence_N_mps, east.turbulence_N_mps
    assert te[1] == pytest.approx(tn[0]) and te[0] == pytest.approx(-tn[1]) and te[2] == pytest.approx(tn[2])


def test_turbulence_makes_moments_only_with_the_rotational_components() -> None:
    """A hovering vehicle in Dryden turbulence: with the gradients on, the rotors feel
    different gusts and the body gets roll and pitch accelerations; with them off (and no
    flapping or hub drag) a uniform gust only pushes the CG."""

    def alphas(p: PlantParams) -> np.ndarray:
        plant = make_plant(p, seed=11)
        om = 609.0
        plant.set_kinematic_state((0.0, 0.0, -2.0), rotor_omega_radps=(om,) * 4)
        out = []
        for k in range(1, 400):
            plant.set_kinematic_state((0.0, 0.0, -2.0), rotor_omega_radps=(om,) * 4)
            plant.step(k * 2_500_000, [om / plant.omega_max_radps] * 4)
            out.append(plant.accelerations()[1])
        return np.array(out)

    base = replace(PlantParams(), wind=WindParams(mean_N_mps=(2.0, 1.5, 0.0), dryden=True))
    with_gradients = alphas(base)
    assert np.std(with_gradients[:, 0]) > 0.05 and np.std(with_gradients[:, 1]) > 0.05  # rad/s^2
    uniform = replace(
        base,
        wind=replace(base.wind, dryden_gradients=False),
        aero=replace(
            base.aero,
            rotor_drag_N_per_mps_per_radps=0.0,
            rotor_drag_vertical_N_per_mps_per_radps=0.0,
            flapping_moment_Nm_per_mps_per_radps=0.0,
            centre_of_pressure_B_m=(0.0, 0.0, 0.0),
        ),
    )
    assert np.max(np.abs(alphas(uniform)[:, :2])) < 1e-9


def test_one_turbulence_model_at_a_time() -> None:
    with pytest.raises(ValueError, match="one turbulence model"):
        WindParams(dryden=True, turbulence_sigma_N_mps=(0.5, 0.5, 0.2))


def test_gust_differences_per_hub_are_the_gradient_in_body_axes() -> None:
    """Each hub's gust difference is R^T G_N R r_i for the tick's attitude (numpy oracle)."""
    from hil.plant import quat

    plant = make_plant(replace(PlantParams(), wind=WindParams(mean_N_mps=(3.0, -2.0, 0.0), dryden=True)), seed=2)
    for k in range(1, 40):
        plant.step(k * 2_500_000, (0.0,) * 4)
    q = quat.from_euler(0.3, -0.2, 1.1)
    plant.set_kinematic_state((0.0, 0.0, -5.0), q_NB=q)
    g = np.array(plant._wind.gradient_N).reshape(3, 3)
    assert np.any(g != 0.0)
    offsets = np.array(gust_offsets_B(plant._wind.gradient_N, plant._x, plant._hubs_B)).reshape(4, 3)
    r = np.array([[quat.rotate(q, (1.0, 0.0, 0.0)), quat.rotate(q, (0.0, 1.0, 0.0)), quat.rotate(q, (0.0, 0.0, 1.0))]])[0].T
    for hub, off in zip(plant._hubs_B, offsets, strict=True):
        np.testing.assert_allclose(off, r.T @ g @ r @ np.array(hub), atol=1e-12)
