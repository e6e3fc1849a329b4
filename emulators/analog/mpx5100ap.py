"""MPX5100AP: absolute pressure -> output volts (static part; dynamics in frontend.py).

NXP MPX5100 datasheet: Vout = Vs (0.009 P - 0.095) +- (pressure error x temperature
multiplier x 0.009 Vs), P in kPa; the error band is +-2.5 kPa over 0-85 C and the
multiplier (same family figure as MPX4115A) is 3 at -40 C and +125 C, 1 from 0 to 85 C,
linear in between. Response 1.0 ms (10-90 %).
"""

from __future__ import annotations

import numpy as np

from emulators.analog.conditioning import tau_from_rise_s
from emulators.analog.params import Mpx5100apParams


def temperature_multiplier(T_C: float) -> float:
    """Error-band multiplier: 3 at <= -40 C, 1 over 0..85 C, 3 at >= 125 C, linear between."""
    if T_C <= -40.0:
        return 3.0
    if T_C < 0.0:
        return 1.0 + 2.0 * (-T_C) / 40.0
    if T_C <= 85.0:
        return 1.0
    if T_C < 125.0:
        return 1.0 + 2.0 * (T_C - 85.0) / 40.0
    return 3.0


def nominal_V(p_Pa: float, params: Mpx5100apParams) -> float:
    """Datasheet transfer function without error or clipping."""
    return params.supply_V * (params.gain_per_kPa * p_Pa / 1000.0 + params.offset)


def nominal_Pa(v_V: float, params: Mpx5100apParams) -> float:
    """Inverse of :func:`nominal_V` (what the flight code computes)."""
    return (v_V / params.supply_V - params.offset) / params.gain_per_kPa * 1000.0


class Mpx5100ap:
    """One sensor: this unit's error draw, static output, response and noise figures."""

    def __init__(self, params: Mpx5100apParams, rng: np.random.Generator) -> None:
        self.params = params
        band = params.error_band_kPa
        #: This unit's pressure error inside 0..85 C, kPa.
        self.unit_error_kPa = (
            float(rng.uniform(-band, band)) if params.unit_error_kPa is None else params.unit_error_kPa
        )
        self.tau_s = tau_from_rise_s(params.response_time_s)

    def static_V(self, p_Pa: float, T_C: float) -> float:
        """Settled output for pressure ``p_Pa`` at temperature ``T_C``, clipped to the swing."""
        p = self.params
        err_kPa = self.unit_error_kPa * temperature_multiplier(T_C)
        v = nominal_V(p_Pa, p) + err_kPa * p.gain_per_kPa * p.supply_V
        return self.clip(v)

    def clip(self, v_V: float) -> float:
        p = self.params
        return min(max(v_V, p.swing_low_fraction * p.supply_V), p.swing_high_fraction * p.supply_V)

    @property
    def noise_V_rms(self) -> float:
        return self.params.noise_V_rms
