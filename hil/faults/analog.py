"""Analog sensor faults: barometer and ADXL335 bias, drift, scale, noise, freeze, saturation,
a blocked static port, the baro ground effect. (The ADC's own faults, inputs and reference,
are hil/faults/adc.py.)

They use the analog front-end's hooks (``set_baro_fault``, ``set_accel_fault``, combined by
composers.BaroComposer / AccelComposer). Accelerometer vectors are in body axes (FRD),
m/s^2, as the front-end takes them.
"""

from __future__ import annotations

import math
from typing import Any

from pydantic import Field

from emulators.analog.frontend import AccelFault, BaroFault
from hil.faults.base import NS_PER_S, Fault, FaultParams, Layer, NoParams, Refused, Vec3
from hil.faults.imu import ZERO3, P, add3, refuse_if_zero


# -- barometer (MPX5100AP through the analog front-end) ---------------------------------------------
def _needs(rig: Any, signals: tuple[str, ...], what: str) -> None:
    if not any(s in rig.analog.channel_map for s in signals):
        raise Refused("kind", f"no ADC channel of this rig is wired to the {what} ([analog] channel_map)")


class _BaroFault(Fault[P]):
    layer = Layer.SENSOR

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        _needs(rig, ("baro",), "barometer")

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "baro"

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.baro.add(self, t_ns)
        return {"baro": _baro_dict(self.env.devices.analog.baro_fault)}

    def update(self, t_ns: int) -> None:
        self.env.baro.push(t_ns)

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.baro.remove(self, t_ns)
        return {"baro": _baro_dict(self.env.devices.analog.baro_fault)}

    def baro_terms(self, t_ns: int) -> BaroFault:
        raise NotImplementedError


def _baro_dict(b: BaroFault) -> dict[str, Any]:
    return {"bias_Pa": b.bias_Pa, "scale": b.scale, "noise_factor": b.noise_factor, "frozen": b.frozen,
            "port_blocked": b.port_blocked}


class BaroBiasParams(FaultParams):
    bias_Pa: float = Field(description="pressure offset, Pa (+12 Pa reads about 1 m lower)")


class BaroBias(_BaroFault[BaroBiasParams]):
    """Constant pressure offset on the barometer."""

    kind = "baro.bias"
    Params = BaroBiasParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        super().check(params, rig)
        refuse_if_zero("bias_Pa", params.bias_Pa)

    def baro_terms(self, t_ns: int) -> BaroFault:
        return BaroFault(bias_Pa=self.params.bias_Pa)


class BaroDriftParams(FaultParams):
    drift_Pa_per_s: float = Field(description="pressure offset growth from t_s, Pa/s")


class BaroDrift(_BaroFault[BaroDriftParams]):
    """A pressure offset growing linearly from zero at t_s (thermal drift, weather)."""

    kind = "baro.drift"
    Params = BaroDriftParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        super().check(params, rig)
        refuse_if_zero("drift_Pa_per_s", params.drift_Pa_per_s)

    def baro_terms(self, t_ns: int) -> BaroFault:
        return BaroFault(bias_Pa=self.params.drift_Pa_per_s * max(0, t_ns - self.t_start_ns) / NS_PER_S)


class BaroScaleParams(FaultParams):
    scale: float = Field(gt=0.0, le=2.0, description="sensed pressure = true pressure x scale")


class BaroScale(_BaroFault[BaroScaleParams]):
    """Scale error of the barometer's pressure reading."""

    kind = "baro.scale"
    Params = BaroScaleParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        super().check(params, rig)
        if params.scale == 1.0:
            raise Refused("scale", "1 would change nothing")

    def baro_terms(self, t_ns: int) -> BaroFault:
        return BaroFault(scale=self.params.scale)


class NoiseFactorParams(FaultParams):
    noise_factor: float = Field(gt=1.0, le=1000.0, description="the sensor's noise rms becomes this many times larger")


class BaroNoise(_BaroFault[NoiseFactorParams]):
    """More barometer noise (turbulence at the port, failing sensor)."""

    kind = "baro.noise"
    Params = NoiseFactorParams

    def baro_terms(self, t_ns: int) -> BaroFault:
        return BaroFault(noise_factor=self.params.noise_factor)


class BaroFreeze(_BaroFault[NoParams]):
    """The barometer output is stuck at its value at t_s."""

    kind = "baro.freeze"
    Params = NoParams

    def baro_terms(self, t_ns: int) -> BaroFault:
        return BaroFault(frozen=True)


class BaroPortBlocked(_BaroFault[NoParams]):
    """The static port is blocked (water, an insect, tape left on after washing): the sensor
    sees the air trapped at t_s whatever the vehicle does, and its own output noise goes on.

    Unlike baro.freeze the reading is not a flat line, so a flight code's flat-line test
    passes it; only the barometer's disagreement with the vehicle's motion shows it. The
    analog front-end holds the port's pressure; the sensor's own errors (the other baro.*
    kinds) still show on top.
    """

    kind = "baro.port_blocked"
    Params = NoParams

    def baro_terms(self, t_ns: int) -> BaroFault:
        return BaroFault(port_blocked=True)


class BaroGroundEffectParams(FaultParams):
    error_at_ground_Pa: float = Field(
        default=40.0, description="extra static-pressure error on the ground, Pa (rotor wash raises it)"
    )
    decay_height_m: float = Field(default=0.5, gt=0.0, description="the error falls as exp(-h / decay_height_m)")


class BaroGroundEffect(_BaroFault[BaroGroundEffectParams]):
    """Extra pressure error near the ground: error_at_ground_Pa * exp(-h / decay_height_m),
    h the vehicle's height above the field (on top of the plant's own rotor-wash model)."""

    kind = "baro.ground_effect"
    Params = BaroGroundEffectParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        super().check(params, rig)
        refuse_if_zero("error_at_ground_Pa", params.error_at_ground_Pa)

    def baro_terms(self, t_ns: int) -> BaroFault:
        h = max(0.0, self.env.devices.plant.state.h_m)
        p = self.params
        return BaroFault(bias_Pa=p.error_at_ground_Pa * math.exp(-h / p.decay_height_m))


# -- accelerometer (ADXL335 through the analog front-end) -------------------------------------------
class _AccelFault(Fault[P]):
    layer = Layer.SENSOR

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        _needs(rig, ("accel_x", "accel_y", "accel_z"), "accelerometer")

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "accel"

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.accel.add(self, t_ns)
        return {"accel": _accel_dict(self.env.devices.analog.accel_fault)}

    def update(self, t_ns: int) -> None:
        self.env.accel.push(t_ns)

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.accel.remove(self, t_ns)
        return {"accel": _accel_dict(self.env.devices.analog.accel_fault)}

    def accel_terms(self, t_ns: int) -> AccelFault:
        raise NotImplementedError


def _accel_dict(a: AccelFault) -> dict[str, Any]:
    return {
        "bias_B_mps2": list(a.bias_mps2), "scale": a.scale, "noise_factor": a.noise_factor,
        "frozen": a.frozen, "saturate": a.saturate,
    }


class AccelBiasParams(FaultParams):
    bias_B_mps2: Vec3 = Field(description="specific-force offset, body axes FRD, m/s^2")


class AccelBias(_AccelFault[AccelBiasParams]):
    """Constant offset on the ADXL335 reading."""

    kind = "accel.bias"
    Params = AccelBiasParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        super().check(params, rig)
        refuse_if_zero("bias_B_mps2", params.bias_B_mps2)

    def accel_terms(self, t_ns: int) -> AccelFault:
        return AccelFault(bias_mps2=self.params.bias_B_mps2)


class AccelDriftParams(FaultParams):
    drift_B_mps2_per_s: Vec3 = Field(description="offset growth from t_s, body axes FRD, m/s^2 per s")


class AccelDrift(_AccelFault[AccelDriftParams]):
    """An ADXL335 offset growing linearly from zero at t_s."""

    kind = "accel.drift"
    Params = AccelDriftParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        super().check(params, rig)
        refuse_if_zero("drift_B_mps2_per_s", params.drift_B_mps2_per_s)

    def accel_terms(self, t_ns: int) -> AccelFault:
        dt_s = max(0, t_ns - self.t_start_ns) / NS_PER_S
        return AccelFault(bias_mps2=add3(ZERO3, self.params.drift_B_mps2_per_s, dt_s))


class AccelScaleParams(FaultParams):
    scale: float = Field(gt=0.0, le=4.0, description="sensed specific force = true x scale (all axes)")


class AccelScale(_AccelFault[AccelScaleParams]):
    """Sensitivity error of the ADXL335 (all axes)."""

    kind = "accel.scale"
    Params = AccelScaleParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        super().check(params, rig)
        if params.scale == 1.0:
            raise Refused("scale", "1 would change nothing")

    def accel_terms(self, t_ns: int) -> AccelFault:
        return AccelFault(scale=self.params.scale)


class AccelNoise(_AccelFault[NoiseFactorParams]):
    """More ADXL335 noise (vibration, a loose board)."""

    kind = "accel.noise"
    Params = NoiseFactorParams

    def accel_terms(self, t_ns: int) -> AccelFault:
        return AccelFault(noise_factor=self.params.noise_factor)


class AccelFreeze(_AccelFault[NoParams]):
    """The ADXL335 outputs are stuck at their values at t_s."""

    kind = "accel.freeze"
    Params = NoParams

    def accel_terms(self, t_ns: int) -> AccelFault:
        return AccelFault(frozen=True)


class AccelSaturation(_AccelFault[NoParams]):
    """Every ADXL335 axis pinned to its output rail (the side its reading is on), as under
    a shock beyond its +-3 g range."""

    kind = "accel.saturation"
    Params = NoParams

    def accel_terms(self, t_ns: int) -> AccelFault:
        return AccelFault(saturate=True)


FAULTS: tuple[type[Fault[Any]], ...] = (
    BaroBias, BaroDrift, BaroScale, BaroNoise, BaroFreeze, BaroPortBlocked, BaroGroundEffect,
    AccelBias, AccelDrift, AccelScale, AccelNoise, AccelFreeze, AccelSaturation,
)
