"""Contract: the flight code's own converter (used here only as an oracle) inverts the
emulated chain of the default rig to within one code, as docs/analog-chain.md promises, over
the window but its outer 0.05 V (``rail_margin_V``: 41 codes, 70 Pa), which it refuses."""

from __future__ import annotations

import hypothesis.strategies as st
import numpy as np
from hypothesis import given, settings

from emulators.analog import AnalogFrontEnd
from emulators.analog.params import G0_MPS2
from emulators.mcp3204 import quantize
from flightcode.drivers.analog import AccelChainParams, AnalogChain, BaroChainParams
from tests.unit.adc.test_analog import quiet

PARAMS = quiet()
FLIGHT = AnalogChain(5.0, BaroChainParams(), AccelChainParams())
PA_PER_CODE = 5.0 / 4096 / 16 / 0.045 * 1000
MPS2_PER_CODE = 5.0 / 4096 / 0.33 * G0_MPS2


@settings(deadline=None, max_examples=100)
@given(
    st.floats(97_930.0, 104_720.0),  # the window 97 853.6-104 796.4 Pa less 70 Pa a side
    st.lists(st.floats(-2.5 * G0_MPS2, 2.5 * G0_MPS2), min_size=3, max_size=3),
)
def test_flight_code_recovers_the_plant_values(p_Pa: float, f_B: list[float]) -> None:
    fe = AnalogFrontEnd(PARAMS, np.random.default_rng(0))
    fe.update(0, p_Pa, f_B, 25.0)
    codes = [quantize(fe.volts(ch, 0), 5.0) for ch in range(4)]
    p_back = FLIGHT.baro_pressure_Pa(codes[0])
    assert p_back is not None and abs(p_back - p_Pa) <= PA_PER_CODE
    f_back = np.array(FLIGHT.accel_B_mps2(*codes[1:]))
    assert np.all(np.abs(f_back - np.array(f_B)) <= MPS2_PER_CODE)


@settings(deadline=None, max_examples=50)
@given(st.one_of(st.floats(90_000.0, 97_915.0), st.floats(104_735.0, 110_000.0)))
def test_flight_code_refuses_pressures_at_the_rails(p_Pa: float) -> None:
    fe = AnalogFrontEnd(PARAMS, np.random.default_rng(0))
    fe.update(0, p_Pa, [0.0, 0.0, -G0_MPS2], 25.0)
    assert FLIGHT.baro_pressure_Pa(quantize(fe.volts(0, 0), 5.0)) is None
