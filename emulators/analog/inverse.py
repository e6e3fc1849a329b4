"""Exact inverses of the nominal chain: ADC codes -> pressure and specific force.

These are the formulas docs/analog-chain.md gives the flight code (which cannot import
this module). Nominal means the datasheet transfer functions with the rig's conditioning;
this unit's errors (pressure error band, zero-g offsets, sensitivity spread, cross-axis)
are what the flight code calibrates away or the estimator absorbs.
"""

from __future__ import annotations

import numpy as np

from emulators.analog.adxl335 import nominal_f_B_mps2
from emulators.analog.adxl335 import nominal_V as accel_nominal_V
from emulators.analog.conditioning import amplify, unamplify
from emulators.analog.mpx5100ap import nominal_Pa
from emulators.analog.mpx5100ap import nominal_V as baro_nominal_V
from emulators.analog.params import AnalogParams, Signal
from emulators.mcp3204.transfer import code_center_V, quantize


def channel_of(params: AnalogParams, signal: Signal) -> int:
    """The ADC channel the rig wires ``signal`` to."""
    return params.channel_map.index(signal)


def pin_V_from_code(code: int, vref_V: float) -> float:
    """Middle of the code's bin: (code + 0.5) * VREF / 4096."""
    return code_center_V(code, vref_V)


def pressure_Pa_from_code(code: int, params: AnalogParams, vref_V: float = 5.0) -> float:
    """Barometer code -> static pressure, Pa."""
    cond = params.conditioning[channel_of(params, "baro")]
    v_sensor = unamplify(pin_V_from_code(code, vref_V), cond)
    return nominal_Pa(v_sensor, params.baro)


def f_B_mps2_from_codes(codes_xyz: tuple[int, int, int], params: AnalogParams, vref_V: float = 5.0) -> np.ndarray:
    """Accelerometer codes (sensor X, Y, Z channels) -> specific force in body axes, m/s^2."""
    v = []
    for axis, code in zip(("accel_x", "accel_y", "accel_z"), codes_xyz):
        cond = params.conditioning[channel_of(params, axis)]  # type: ignore[arg-type]
        v.append(unamplify(pin_V_from_code(code, vref_V), cond))
    return nominal_f_B_mps2(np.array(v), params.accel)


def code_from_pressure_Pa(p_Pa: float, params: AnalogParams, vref_V: float = 5.0) -> int:
    """Forward nominal chain (no errors, no noise) for checks and the doc's examples."""
    cond = params.conditioning[channel_of(params, "baro")]
    return quantize(amplify(baro_nominal_V(p_Pa, params.baro), cond), vref_V)


def codes_from_f_B_mps2(f_B_mps2: np.ndarray, params: AnalogParams, vref_V: float = 5.0) -> tuple[int, int, int]:
    """Forward nominal chain for the accelerometer channels (X, Y, Z)."""
    v = accel_nominal_V(np.asarray(f_B_mps2, dtype=float), params.accel)
    out = []
    for axis, vi in zip(("accel_x", "accel_y", "accel_z"), v):
        cond = params.conditioning[channel_of(params, axis)]  # type: ignore[arg-type]
        out.append(quantize(amplify(float(vi), cond), vref_V))
    return out[0], out[1], out[2]
