"""ISA atmosphere against the standard table (docs/protocols.md 3; U.S. Standard Atmosphere 1976)."""

from __future__ import annotations

import pytest

from hil.plant import EnvironmentParams
from hil.plant.atmosphere import Atmosphere, isa_pressure_Pa, isa_temperature_K

from .support import hover_at, make_plant

# Standard-atmosphere table (U.S. Standard Atmosphere 1976; docs/protocols.md section 3 lists
# 0/1000/2000 m): height m -> pressure Pa.
ISA_TABLE = [(0.0, 101325.0), (1000.0, 89875.0), (2000.0, 79495.0), (5000.0, 54020.0)]


@pytest.mark.parametrize(("h_m", "p_Pa"), ISA_TABLE)
def test_isa_pressure_matches_the_standard_table(h_m: float, p_Pa: float) -> None:
    assert isa_pressure_Pa(h_m) == pytest.approx(p_Pa, rel=1e-3)


def test_isa_temperature_and_density() -> None:
    assert isa_temperature_K(0.0) == pytest.approx(288.15)
    assert isa_temperature_K(1000.0) == pytest.approx(281.65)
    atmo = Atmosphere(EnvironmentParams())
    assert atmo.density_kgpm3(0.0) == pytest.approx(1.2250, abs=1e-4)
    assert atmo.density_kgpm3(1000.0) == pytest.approx(1.1117, abs=1e-3)  # ISA table
    hot = Atmosphere(EnvironmentParams(temperature_offset_K=15.0))
    assert hot.temperature_K(0.0) == pytest.approx(303.15)
    assert hot.density_kgpm3(0.0) < atmo.density_kgpm3(0.0)


def test_field_elevation_and_qnh() -> None:
    high = Atmosphere(EnvironmentParams(field_elevation_m=1000.0))
    assert high.pressure_Pa(0.0) == pytest.approx(89875.0, rel=1e-3)
    assert high.pressure_Pa(1000.0) == pytest.approx(79495.0, rel=1e-3)
    low_qnh = Atmosphere(EnvironmentParams(qnh_Pa=100000.0))
    assert low_qnh.pressure_Pa(0.0) == pytest.approx(100000.0)
    # Near sea level dP/dh = -rho g = -12.0 Pa/m (docs/protocols.md 3).
    assert low_qnh.pressure_Pa(1.0) - low_qnh.pressure_Pa(0.0) == pytest.approx(-11.8, abs=0.2)


def test_plant_static_pressure_follows_altitude() -> None:
    plant = make_plant(environment=EnvironmentParams(field_elevation_m=1000.0, qnh_Pa=101325.0))
    p_ground = plant.sensors().p_static_Pa  # rotors stopped: no wash error
    assert p_ground == pytest.approx(89875.0, rel=1e-3)
    assert plant.sensors().air_T_C == pytest.approx(8.5, abs=0.01)
    hover_at(plant, 100.0)
    p_100 = plant.sensors().p_static_Pa
    assert p_ground - p_100 == pytest.approx(100.0 * 1.1117 * 9.80665, rel=0.01)
