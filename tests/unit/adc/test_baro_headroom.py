"""The default rig's barometer stage keeps every MPX5100AP unit off the ADC rails on the ground.

The x16 stage's window is only 6.9 kPa wide and the sensor's unit error alone is +-2.5 kPa
(datasheet, 0-85 C). With the field at 4.0 V on the pin about 1 unit in 5 read code 4095 at
rest, the flight code never fixed its altitude reference, and hover seeds 9, 15, 16 and 20 of a
20-seed campaign never took off. docs/analog-chain.md section 4.
"""

from __future__ import annotations

import dataclasses

import pytest

from emulators.analog import AnalogFrontEnd
from emulators.mcp3204 import quantize
from hil.flight.devices import spawn_rngs
from hil.plant.atmosphere import isa_pressure_Pa
from hil.config.rig import load_rig

REST = (0.0, 0.0, -9.80665)
#: Climb the stage must still read above the field for the worst unit, m (the scenarios fly
#: to about 7 m).
CLIMB_M = 50.0
T_FIELD_C = 15.0  # inside 0-85 C: the datasheet band, multiplier 1


def ground_code(unit_error_kPa: float | None, *, seed: int = 0, h_m: float = 0.0) -> int:
    """CH0's code for the default rig's field at height ``h_m``, electrical noise off."""
    rig = load_rig()
    a = rig.analog
    baro = dataclasses.replace(a.baro, noise_V_rms=0.0, unit_error_kPa=unit_error_kPa)
    ch0 = dataclasses.replace(a.conditioning[0], noise_V_rms=0.0)
    params = dataclasses.replace(a, baro=baro, conditioning=(ch0, *a.conditioning[1:]))
    atm = rig.plant.environment
    p_Pa = isa_pressure_Pa(atm.field_elevation_m + h_m, atm.qnh_Pa)
    fe = AnalogFrontEnd(params, spawn_rngs(seed)["analog"])
    fe.update(0, p_Pa, REST, T_FIELD_C)
    return quantize(fe.volts(0, 0), 5.0)


@pytest.mark.parametrize("unit_error_kPa", [-2.5, 0.0, 2.5])
def test_every_unit_in_the_datasheet_band_reads_inside_the_rails(unit_error_kPa: float) -> None:
    assert 0 < ground_code(unit_error_kPa) < 4095
    assert 0 < ground_code(unit_error_kPa, h_m=CLIMB_M) < 4095


def test_the_field_sits_mid_scale() -> None:
    assert abs(ground_code(0.0) - 2048) <= 1


@pytest.mark.parametrize("seed", [9, 15, 16, 20])
def test_the_units_that_pinned_the_rail_now_read_inside(seed: int) -> None:
    """The campaign seeds whose drawn unit read 4095 with the old 4.0 V field."""
    code = ground_code(None, seed=seed)
    assert 0 < code < 4095
