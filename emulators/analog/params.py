"""Parameters of the analog front-end (rig TOML table ``[analog]`` and sub-tables).

Defaults are the paper's vehicle (docs/controllers.md §3.4, docs/protocols.md §3-4): an MPX5100AP
on 5 V behind a x16 offset-and-gain stage into CH0, an ADXL335 on 3.3 V into CH1-3, the
MCP3204's VREF on the 5 V rail.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

#: What an ADC input is wired to. "none" leaves the pin unconnected (it floats).
Signal = Literal["baro", "accel_x", "accel_y", "accel_z", "none"]

G0_MPS2 = 9.80665  #: standard gravity: 1 g in m/s^2
P_SEA_LEVEL_PA = 101_325.0


@dataclass(frozen=True)
class Mpx5100apParams:
    """NXP MPX5100AP absolute pressure sensor (datasheet Rev. 14).

    Vout = Vs * (gain_per_kPa * P_kPa + offset), ratiometric to Vs; the A part is rated
    15-115 kPa (0.2-4.7 V at Vs = 5 V) and its output clips at that swing. Error band
    +-2.5 kPa over 0-85 C (2.5 % VFSS), times the temperature multiplier outside it.
    """

    __pydantic_config__ = {"extra": "forbid"}

    supply_V: float = 5.0
    gain_per_kPa: float = 0.009  #: of Vs per kPa (45 mV/kPa at 5 V)
    offset: float = -0.095  #: of Vs at 0 kPa
    swing_low_fraction: float = 0.04  #: 0.2 V at 5 V (15 kPa)
    swing_high_fraction: float = 0.94  #: 4.7 V at 5 V (115 kPa)
    error_band_kPa: float = 2.5
    #: This unit's pressure error inside 0-85 C; None draws it uniformly within the band.
    unit_error_kPa: float | None = None
    response_time_s: float = 1.0e-3  #: 10-90 %; first-order tau = t / ln 9
    #: Output noise, V rms, correlated over the response time (not in the datasheet;
    #: docs/controllers.md §7 uses 0.5 mV as realistic, 0.1 and 1.2 mV as bounds).
    noise_V_rms: float = 0.5e-3


@dataclass(frozen=True)
class Adxl335Params:
    """ADI ADXL335 +-3 g accelerometer (Rev. B), ratiometric on its supply.

    Per axis: V = Vs/2 + zero-g offset + 0.1 Vs/g * a, clipped to the output swing, then
    the output RC (internal 32 kOhm with the external capacitor). Per-unit sensitivity,
    zero-g, zero-g drift and cross-axis terms are drawn from the rng within the tolerances
    (set a tolerance to 0 for an ideal part).
    """

    __pydantic_config__ = {"extra": "forbid"}

    supply_V: float = 3.3  #: docs/controllers.md §3.4 (3.6 V maximum, so not the 5 V rail)
    sensitivity_per_g: float = 0.1  #: of Vs per g: 300 mV/g at 3 V, 330 mV/g at 3.3 V
    sensitivity_tolerance: float = 0.10  #: 270-330 mV/g at 3 V
    #: Zero-g tolerance per axis in V at Vs = 3 V (X, Y 1.35-1.65 V; Z 1.2-1.8 V), ratiometric.
    zero_g_tolerance_V_at_3V: tuple[float, float, float] = (0.15, 0.15, 0.30)
    zero_g_drift_mg_per_C: tuple[float, float, float] = (1.0, 1.0, 2.0)  #: +- per unit, from 25 C
    cross_axis_fraction: float = 0.01  #: +-1 % per off-diagonal term
    #: Noise density per axis at Vs = 3 V (constant in volts: 45 uV/rtHz on X, Y).
    noise_density_ug_per_rtHz_at_3V: tuple[float, float, float] = (150.0, 150.0, 300.0)
    filter_R_ohm: float = 32_000.0
    #: CX, CY, CZ: 0.1 uF gives f-3dB = 1 / (2 pi 32 kOhm C) = 50 Hz (docs/controllers.md §3.4).
    filter_C_uF: tuple[float, float, float] = (0.1, 0.1, 0.1)
    swing_low_V: float = 0.1
    swing_high_below_supply_V: float = 0.2  #: high limit = Vs - 0.2 V
    #: Rotation from body axes (FRD) to sensor axes, rows = sensor X, Y, Z in body axes.
    #: Default: flat, component side up, X forward: sensor (x, y, z) = (x_B, -y_B, -z_B),
    #: so at rest sensor Z reads +1 g.
    mount_R_SB: tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]] = (
        (1.0, 0.0, 0.0),
        (0.0, -1.0, 0.0),
        (0.0, 0.0, -1.0),
    )

    def f3db_Hz(self, axis: int) -> float:
        return 1.0 / (2.0 * math.pi * self.filter_R_ohm * self.filter_C_uF[axis] * 1e-6)


@dataclass(frozen=True)
class ConditioningParams:
    """One ADC channel's signal conditioning, sensor -> ADC pin.

    V_pin = clip(reference_V + gain * (V_sensor - offset_V), rail_low_V, rail_high_V),
    low-passed by an RC with cutoff ``rc_cutoff_Hz`` (0: none), plus white electrical noise
    of ``noise_V_rms`` per sample.
    """

    __pydantic_config__ = {"extra": "forbid"}

    gain: float = 1.0
    offset_V: float = 0.0  #: subtracted from the sensor voltage before the gain
    reference_V: float = 0.0  #: added at the amplifier output
    rail_low_V: float = 0.0
    rail_high_V: float = 5.0
    rc_cutoff_Hz: float = 0.0
    noise_V_rms: float = 0.3e-3


def baro_offset_V_for_field(
    p_field_Pa: float, gain: float, pin_V: float = 2.5, baro: Mpx5100apParams = Mpx5100apParams()
) -> float:
    """The ``offset_V`` that puts field pressure ``p_field_Pa`` at ``pin_V`` on the ADC pin.

    With gain 16 the 5 V ADC range spans 0.3125 V of sensor output = 6.9 kPa, about 580 m
    near sea level: a fixed offset cannot cover fields from sea level to 2 km, so the rig
    picks it for its field. 2.5 V, mid-scale, leaves +-3.47 kPa (~290 m) either way: the
    MPX5100AP's unit error alone is +-2.5 kPa (datasheet), so a field level nearer a rail
    pins some units at a rail on the ground (4.0 V did, for about 1 unit in 5).
    """
    v_field = baro.supply_V * (baro.gain_per_kPa * p_field_Pa / 1000.0 + baro.offset)
    return v_field - pin_V / gain


#: The default rig's CH0 stage: x16, sea-level field at 2.5 V (mid-scale), 100 Hz anti-alias RC.
BARO_X16_SEA_LEVEL = ConditioningParams(
    gain=16.0, offset_V=baro_offset_V_for_field(P_SEA_LEVEL_PA, 16.0), rc_cutoff_Hz=100.0
)
UNITY = ConditioningParams()


@dataclass(frozen=True)
class AnalogParams:
    """The whole analog chain in front of the MCP3204's four inputs."""

    __pydantic_config__ = {"extra": "forbid"}

    baro: Mpx5100apParams = field(default_factory=Mpx5100apParams)
    accel: Adxl335Params = field(default_factory=Adxl335Params)
    channel_map: tuple[Signal, Signal, Signal, Signal] = ("baro", "accel_x", "accel_y", "accel_z")
    conditioning: tuple[ConditioningParams, ConditioningParams, ConditioningParams, ConditioningParams] = (
        BARO_X16_SEA_LEVEL,
        UNITY,
        UNITY,
        UNITY,
    )
    #: An open (floating) input drifts from its last value to this level with this time
    #: constant, with this much noise (fault model; leakage decides the rail on a real board).
    open_input_level_V: float = 0.0
    open_input_tau_s: float = 0.05
    open_input_noise_V_rms: float = 5e-3
