"""The flight code's barometer noise setting (``[kf] r_baro_m2`` in
rigs/flightcode-paper-quad.toml) follows from the default rig's emulated chain, as its
comment derives it: one sample's noise sigma (m) and the lag-1 correlation rho the 100 Hz RC
puts between samples give the white-noise equivalent sigma^2 (1 + rho) / (1 - rho) of the
slow band the filter averages over seconds. Measured here on the emulated MPX5100AP, x16
stage and MCP3204 at rest, so a change of the chain that moves the figures fails this test
instead of leaving the comment and the setting behind."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from emulators.analog import AnalogFrontEnd
from emulators.analog.inverse import pressure_Pa_from_code
from emulators.mcp3204 import quantize
from hil.config import RIGS_DIR
from hil.config.rig import load_rig
from hil.flight.devices import spawn_rngs
from hil.plant.atmosphere import isa_pressure_Pa

TICK_NS = 2_500_000  # the 400 Hz loop reads CH0 once a sample
AT_REST = (0.0, 0.0, -9.80665)
H_M = 2.0  # a hover's height, m


def measured_noise(seed: int, n_samples: int = 20_000) -> tuple[float, float]:
    """(sigma of one CH0 reading in metres of altitude, lag-1 correlation) at a still 2 m."""
    rig = load_rig()
    env = rig.plant.environment
    p_Pa = isa_pressure_Pa(env.field_elevation_m + H_M, env.qnh_Pa)
    fe = AnalogFrontEnd(rig.analog, spawn_rngs(seed)["analog"])
    p_read_Pa = np.empty(n_samples)
    for k in range(n_samples):
        t_ns = k * TICK_NS
        fe.update(t_ns, p_Pa, AT_REST, 15.0)
        p_read_Pa[k] = pressure_Pa_from_code(quantize(fe.volts(0, t_ns + TICK_NS // 25), 5.0), rig.analog)
    c = p_read_Pa[n_samples // 10:]  # past the chain's start-up
    c = c - c.mean()
    rho = float((c[1:] * c[:-1]).mean() / c.var())
    pa_per_m = isa_pressure_Pa(env.field_elevation_m + H_M - 0.5, env.qnh_Pa) - isa_pressure_Pa(
        env.field_elevation_m + H_M + 0.5, env.qnh_Pa)
    return float(c.std()) / pa_per_m, rho


def flight_r_baro_m2() -> float:
    cfg = tomllib.loads((RIGS_DIR / "flightcode-paper-quad.toml").read_text())
    return float(cfg["kf"]["r_baro_m2"])


@pytest.mark.parametrize("seed", [1, 2])
def test_r_baro_is_the_chains_white_noise_equivalent(seed: int) -> None:
    sigma_m, rho = measured_noise(seed)
    assert 0.40 <= sigma_m <= 0.48  # the comment's 0.44 m a sample
    assert 0.24 <= rho <= 0.34  # and its 0.29
    equivalent_m2 = sigma_m**2 * (1.0 + rho) / (1.0 - rho)
    assert flight_r_baro_m2() == pytest.approx(equivalent_m2, rel=0.15)
