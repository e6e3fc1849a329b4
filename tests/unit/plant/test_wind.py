"""Wind: seeded, reproducible turbulence with the right statistics; steps and gusts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.plant import GustParams, GustShape, WindParams
from hil.plant.wind import WindModel

from .support import TICK_NS, hover_at, make_plant, run

TURB = WindParams(mean_N_mps=(3.0, 0.0, 0.0), turbulence_sigma_N_mps=(1.0, 0.8, 0.4))


def _series(seed: int, n: int, params: WindParams = TURB, every: int = 1) -> list[tuple[float, float, float]]:
    w = WindModel(params, np.random.default_rng(seed))
    return [w.at(k * every * TICK_NS) for k in range(n)]


def test_same_seed_same_series_different_seed_different() -> None:
    a, b, c = _series(7, 2000), _series(7, 2000), _series(8, 2000)
    assert a == b
    assert a != c
    assert len({round(x[0], 12) for x in a}) > 100  # it moves


def test_series_does_not_depend_on_how_often_it_is_sampled() -> None:
    every_tick = _series(3, 4000)
    every_4th = _series(3, 1000, every=4)
    assert every_4th == every_tick[::4]


def test_calm_by_default_and_no_random_draws() -> None:
    rng = np.random.default_rng(1)
    state = rng.bit_generator.state
    w = WindModel(WindParams(), rng)
    assert {w.at(k * TICK_NS) for k in range(100)} == {(0.0, 0.0, 0.0)}
    assert rng.bit_generator.state == state


def test_turbulence_statistics() -> None:
    # Short scale lengths (tau = L / 1 m/s = 50 ms) so 100 s hold ~1000 correlation times.
    params = WindParams(turbulence_sigma_N_mps=(1.0, 0.5, 0.25), turbulence_length_m=(0.05, 0.05, 0.05))
    x = np.array(_series(11, 40_000, params))
    np.testing.assert_allclose(x.mean(axis=0), 0.0, atol=0.1)
    np.testing.assert_allclose(x.std(axis=0), (1.0, 0.5, 0.25), rtol=0.08)
    # Lag-one autocorrelation of the exact first-order process: exp(-dt / tau).
    r1 = np.corrcoef(x[:-1, 0], x[1:, 0])[0, 1]
    assert r1 == pytest.approx(math.exp(-0.0025 / 0.05), abs=0.01)
    # Independent axes.
    assert abs(np.corrcoef(x[:, 0], x[:, 1])[0, 1]) < 0.1


def test_gust_profiles() -> None:
    w = WindModel(WindParams(), np.random.default_rng(1))
    s = 1_000_000_000
    h1 = w.add_gust((0.0, 4.0, 0.0), start_t_ns=2 * s, duration_ns=2 * s)
    assert w.at(s) == (0.0, 0.0, 0.0)
    assert w.at(2 * s)[1] == pytest.approx(0.0)
    assert w.at(2 * s + s // 2)[1] == pytest.approx(2.0)
    assert w.at(3 * s)[1] == pytest.approx(4.0)  # peak half-way
    assert w.at(4 * s) == (0.0, 0.0, 0.0)  # over
    h2 = w.add_step((1.0, 0.0, -0.5), start_t_ns=5 * s, until_t_ns=6 * s)
    assert w.at(5 * s) == (1.0, 0.0, -0.5)
    assert w.at(6 * s) == (0.0, 0.0, 0.0)
    w.remove(h1)
    w.remove(h2)
    with pytest.raises(KeyError):
        w.remove(h1)
    with pytest.raises(ValueError):
        w.add_step((1.0, 0.0, 0.0), start_t_ns=s, until_t_ns=s)


def test_scheduled_gusts_from_params() -> None:
    s = 1_000_000_000
    params = WindParams(
        mean_N_mps=(1.0, 0.0, 0.0),
        gusts=(GustParams((0.0, 0.0, -2.0), start_t_ns=s, duration_ns=s, shape=GustShape.STEP),),
    )
    w = WindModel(params, np.random.default_rng(1))
    assert w.at(0) == (1.0, 0.0, 0.0)
    assert w.at(s) == (1.0, 0.0, -2.0)
    assert w.at(2 * s) == (1.0, 0.0, 0.0)


def test_wind_pushes_a_hovering_vehicle_downwind() -> None:
    plant = make_plant()
    hover_at(plant, 20.0)
    handle = plant.add_wind((0.0, 5.0, 0.0))  # blowing towards east
    run(plant, 400, lambda p: [p.hover_throttle()] * 4)
    s = plant.state
    assert s.wind_N_mps == (0.0, 5.0, 0.0)
    assert s.v_N_mps[1] > 1.0 and s.p_N_m[1] > 0.5
    assert abs(s.v_N_mps[0]) < 1e-6
    plant.remove_wind(handle)
    run(plant, 1, [0.7] * 4)
    assert plant.state.wind_N_mps == (0.0, 0.0, 0.0)


def test_plant_wind_is_reproducible_per_seed() -> None:
    def trace(seed: int) -> list[tuple[float, float, float]]:
        plant = make_plant(seed=seed, wind=TURB)
        hover_at(plant, 20.0)
        out = []
        for _ in range(200):
            run(plant, 1, lambda p: [p.hover_throttle()] * 4)
            out.append(plant.state.p_N_m)
        return out

    assert trace(5) == trace(5)
    assert trace(5) != trace(6)
