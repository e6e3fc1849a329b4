"""IMU (XSENS) sensor faults: bias, drift, scale, noise increase, freeze, saturation.

The motion handed to the device is transformed (hil/faults/env.py ImuMotion) in the order
freeze -> scale -> bias/drift -> extra noise -> range clip, so the device's own error model
and range clipping (status-word clip flags) still act on top. Frames: sensor frame S (FRD),
rad/s and m/s^2 like ``MtiDevice.set_motion``.
"""

from __future__ import annotations

import math
from typing import Any, Literal, TypeVar

from pydantic import Field

from hil.faults.base import NS_PER_S, Fault, FaultParams, Layer, NoParams, Refused, Vec3
from hil.faults.env import Quat

ZERO3: Vec3 = (0.0, 0.0, 0.0)

# Order of the IMU motion transforms.
STAGE_FREEZE, STAGE_SCALE, STAGE_BIAS, STAGE_NOISE, STAGE_CLIP = range(5)


def add3(a: Vec3, b: Vec3, k: float = 1.0) -> Vec3:
    """a + k b."""
    return (a[0] + k * b[0], a[1] + k * b[1], a[2] + k * b[2])


def _vec(x: float | Vec3) -> Vec3:
    return (float(x), float(x), float(x)) if isinstance(x, (int, float)) else (float(x[0]), float(x[1]), float(x[2]))


def refuse_if_zero(key: str, *values: float | Vec3) -> None:
    """Refuse a fault whose every value (scalar or vector) is zero: it would change nothing."""
    if all(v == 0.0 or v == ZERO3 for v in values):
        raise Refused(key, "all zero: the fault would change nothing")


P = TypeVar("P", bound=FaultParams)


class _ImuFault(Fault[P]):
    """Base of the IMU motion faults."""

    layer = Layer.SENSOR
    stage = STAGE_BIAS

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "imu"

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.imu_motion.add(self)
        return self.params.model_dump()

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.imu_motion.remove(self)
        return {"imu": "true motion"}

    def transform(self, t_ns: int, q: Quat, w: Vec3, f: Vec3) -> tuple[Quat, Vec3, Vec3]:
        raise NotImplementedError


class ImuBiasParams(FaultParams):
    gyro_bias_S_radps: Vec3 = Field(default=ZERO3, description="rate-of-turn bias, sensor axes, rad/s")
    acc_bias_S_mps2: Vec3 = Field(default=ZERO3, description="acceleration bias, sensor axes, m/s^2")


class ImuBias(_ImuFault[ImuBiasParams]):
    """Constant bias on the XSENS rate of turn and/or acceleration."""

    kind = "imu.bias"
    Params = ImuBiasParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        refuse_if_zero("gyro_bias_S_radps", params.gyro_bias_S_radps, params.acc_bias_S_mps2)

    def transform(self, t_ns: int, q: Quat, w: Vec3, f: Vec3) -> tuple[Quat, Vec3, Vec3]:
        p = self.params
        return q, add3(w, p.gyro_bias_S_radps), add3(f, p.acc_bias_S_mps2)


class ImuDriftParams(FaultParams):
    gyro_drift_S_radps_per_s: Vec3 = Field(default=ZERO3, description="rate-of-turn bias growth, sensor axes, rad/s per s")
    acc_drift_S_mps2_per_s: Vec3 = Field(default=ZERO3, description="acceleration bias growth, sensor axes, m/s^2 per s")


class ImuDrift(_ImuFault[ImuDriftParams]):
    """A bias growing linearly from zero at t_s (thermal drift)."""

    kind = "imu.drift"
    Params = ImuDriftParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        refuse_if_zero("gyro_drift_S_radps_per_s", params.gyro_drift_S_radps_per_s, params.acc_drift_S_mps2_per_s)

    def transform(self, t_ns: int, q: Quat, w: Vec3, f: Vec3) -> tuple[Quat, Vec3, Vec3]:
        dt_s = max(0, t_ns - self.t_start_ns) / NS_PER_S
        p = self.params
        return q, add3(w, p.gyro_drift_S_radps_per_s, dt_s), add3(f, p.acc_drift_S_mps2_per_s, dt_s)


class ImuScaleParams(FaultParams):
    gyro_scale: float | Vec3 = Field(default=1.0, description="rate-of-turn scale factor (one or per axis)")
    acc_scale: float | Vec3 = Field(default=1.0, description="acceleration scale factor (one or per axis)")


class ImuScale(_ImuFault[ImuScaleParams]):
    """Scale-factor error on the rate of turn and/or acceleration."""

    kind = "imu.scale"
    Params = ImuScaleParams
    stage = STAGE_SCALE

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        if _vec(params.gyro_scale) == (1.0, 1.0, 1.0) and _vec(params.acc_scale) == (1.0, 1.0, 1.0):
            raise Refused("gyro_scale", "both scales are 1: the fault would change nothing")

    def transform(self, t_ns: int, q: Quat, w: Vec3, f: Vec3) -> tuple[Quat, Vec3, Vec3]:
        g, a = _vec(self.params.gyro_scale), _vec(self.params.acc_scale)
        return q, (w[0] * g[0], w[1] * g[1], w[2] * g[2]), (f[0] * a[0], f[1] * a[1], f[2] * a[2])


class ImuNoiseParams(FaultParams):
    noise_factor: float = Field(gt=1.0, le=1000.0, description="white noise rms becomes this many times the device's")
    signals: Literal["gyro", "acc", "both"] = Field(default="both", description="which outputs get noisier")


class ImuNoise(_ImuFault[ImuNoiseParams]):
    """More white noise on the rate of turn and/or acceleration (vibration, failing sensor).

    Independent noise of rms sigma * sqrt(k^2 - 1) is added, so the total is k times the
    device's own per-sample sigma (rig [imu] noise density * sqrt(sample rate)).
    """

    kind = "imu.noise"
    Params = ImuNoiseParams
    stage = STAGE_NOISE

    @classmethod
    def _sigmas(cls, params: Any, rig: Any) -> tuple[float, float]:
        imu = rig.imu
        root = math.sqrt(imu.sample_rate_hz)
        extra = math.sqrt(params.noise_factor**2 - 1.0)
        g = imu.gyro_noise_radps_per_rthz * root * extra if params.signals != "acc" else 0.0
        a = imu.acc_noise_mps2_per_rthz * root * extra if params.signals != "gyro" else 0.0
        return g, a

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        if cls._sigmas(params, rig) == (0.0, 0.0):
            raise Refused("noise_factor", "the rig's [imu] noise density is 0 for these signals: nothing to multiply")

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.sigma_radps, self.sigma_mps2 = self._sigmas(self.params, self.env.devices.rig)
        out = super().apply(t_ns)
        return out | {"extra_gyro_radps_rms": self.sigma_radps, "extra_acc_mps2_rms": self.sigma_mps2}

    def transform(self, t_ns: int, q: Quat, w: Vec3, f: Vec3) -> tuple[Quat, Vec3, Vec3]:
        n = self.rng.standard_normal(6)
        sg, sa = self.sigma_radps, self.sigma_mps2
        return (
            q,
            (w[0] + sg * n[0], w[1] + sg * n[1], w[2] + sg * n[2]),
            (f[0] + sa * n[3], f[1] + sa * n[4], f[2] + sa * n[5]),
        )


class ImuFreeze(_ImuFault[NoParams]):
    """The IMU's sensing is stuck: orientation, rates and acceleration hold the values of t_s.

    The device keeps streaming (counters, time stamps) and its own noise stays on top.
    """

    kind = "imu.freeze"
    Params = NoParams
    stage = STAGE_FREEZE

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.held: tuple[Quat, Vec3, Vec3] | None = None
        return super().apply(t_ns)

    def transform(self, t_ns: int, q: Quat, w: Vec3, f: Vec3) -> tuple[Quat, Vec3, Vec3]:
        if self.held is None:
            self.held = (q, w, f)
        return self.held


class ImuSaturationParams(FaultParams):
    gyro_range_radps: float | None = Field(default=None, gt=0.0, description="rate of turn clips at +- this, rad/s")
    acc_range_mps2: float | None = Field(default=None, gt=0.0, description="acceleration clips at +- this, m/s^2")


class ImuSaturation(_ImuFault[ImuSaturationParams]):
    """The IMU saturates at a smaller range (wrong range setting, damaged sensor): each axis
    clips at +- the given range. The device's clip flags only report its own ranges."""

    kind = "imu.saturation"
    Params = ImuSaturationParams
    stage = STAGE_CLIP

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        if params.gyro_range_radps is None and params.acc_range_mps2 is None:
            raise Refused("gyro_range_radps", "give gyro_range_radps and/or acc_range_mps2")
        if params.gyro_range_radps is not None and params.gyro_range_radps >= rig.imu.gyro_range_radps:
            raise Refused("gyro_range_radps", f"not below the device's range {rig.imu.gyro_range_radps:g} rad/s")
        if params.acc_range_mps2 is not None and params.acc_range_mps2 >= rig.imu.acc_range_mps2:
            raise Refused("acc_range_mps2", f"not below the device's range {rig.imu.acc_range_mps2:g} m/s^2")

    def transform(self, t_ns: int, q: Quat, w: Vec3, f: Vec3) -> tuple[Quat, Vec3, Vec3]:
        g, a = self.params.gyro_range_radps, self.params.acc_range_mps2
        if g is not None:
            w = (min(g, max(-g, w[0])), min(g, max(-g, w[1])), min(g, max(-g, w[2])))
        if a is not None:
            f = (min(a, max(-a, f[0])), min(a, max(-a, f[1])), min(a, max(-a, f[2])))
        return q, w, f


FAULTS: tuple[type[Fault[Any]], ...] = (ImuBias, ImuDrift, ImuScale, ImuNoise, ImuFreeze, ImuSaturation)
