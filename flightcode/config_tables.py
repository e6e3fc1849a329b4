"""The tables of the flight code's configuration file, one frozen dataclass each (units in the
field names, defaults = the paper's vehicle); docs/flightcode.md documents every key. Read
and checked by :mod:`flightcode.config`.

The dataclasses also carry ``__pydantic_config__ = {"extra": "forbid"}`` so the bench can
validate the same tables with pydantic; the flight code itself imports only the stdlib here.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from flightcode.drivers.analog import AccelChainParams, BaroChainParams
from flightcode.drivers.maestro import EscParams
from flightcode.drivers.ppm_capture import PpmParams
from flightcode.drivers.sbus import SbusParams
from flightcode.drivers.xsens import ImuParams
from flightcode.estimation.plausibility import PlausibilityParams
from flightcode.log import Level
from flightcode.modes import ModesParams


@dataclass(frozen=True)
class PortParams:
    """One serial port: device path and line rate (bit/s)."""

    __pydantic_config__ = {"extra": "forbid"}

    path: str
    baud: int


@dataclass(frozen=True)
class PortsParams:
    """``[ports.*]``: where each device is. ``telemetry`` may be omitted when disabled."""

    __pydantic_config__ = {"extra": "forbid"}

    imu: PortParams
    adc: PortParams
    rc: PortParams
    esc: PortParams
    telemetry: PortParams | None = None


@dataclass(frozen=True)
class AdcParams:
    """``[adc]``: the SPI bridge, the MCP3204 and its channel map; chains in sub-tables."""

    __pydantic_config__ = {"extra": "forbid"}

    bridge: Literal["buspirate"] = "buspirate"
    spi_speed_hz: int = 1_000_000
    vref_V: float = 5.0
    baro_channel: int = 0
    accel_channels: tuple[int, int, int] = (1, 2, 3)
    read_timeout_s: float = 0.02
    entry_attempts: int = 5
    reply_timeout_s: float = 0.2
    quiet_s: float = 0.03
    resync_interval_s: float = 0.25
    baro: BaroChainParams = field(default_factory=BaroChainParams)
    accel: AccelChainParams = field(default_factory=AccelChainParams)


@dataclass(frozen=True)
class RcParams:
    """``[rc]``: front-end, channel map and stick scaling."""

    __pydantic_config__ = {"extra": "forbid"}

    frontend: Literal["capture", "sbus"] = "capture"
    channel_roll: int = 1
    channel_pitch: int = 2
    channel_throttle: int = 3
    channel_yaw: int = 4
    center_us: float = 1500.0
    half_range_us: float = 500.0
    throttle_low_us: float = 1000.0
    throttle_range_us: float = 1000.0
    max_angle_deg: float = 30.0
    max_yaw_rate_dps: float = 90.0
    capture: PpmParams = field(default_factory=PpmParams)
    sbus: SbusParams = field(default_factory=SbusParams)


@dataclass(frozen=True)
class VehicleParams:
    """``[vehicle]``: geometry and thrust (paper's quad; F_max is the total of four motors)."""

    __pydantic_config__ = {"extra": "forbid"}

    frame: Literal["x", "plus"] = "x"
    arm_m: float = 0.25
    F_max_N: float = 20.6
    kq_over_kt_m: float = 0.016
    m_kg: float = 1.1
    #: the mixer's differential: "thrust" (exact inverse of F = F_max d^2) or "throttle"
    #: (linear in throttle, sized at hover: torque gain d / d_h); flightcode/control/mixer.py
    mixer: Literal["thrust", "throttle"] = "throttle"


@dataclass(frozen=True)
class AttitudeParams:
    """``[attitude]``: memory controller (roll and pitch) and the stick prefilter."""

    __pydantic_config__ = {"extra": "forbid"}

    law: Literal["generalised", "paper_literal"] = "generalised"
    omega1_radps: float = 2.0
    omega2_radps: float = 15.0
    k0_per_s: float = 2.0
    J_hat_kgm2: float = 0.015
    tau_ff_s: float = 0.020
    u_limit_Nm: float = 0.8
    prefilter_omega_radps: float = 8.0


@dataclass(frozen=True)
class YawParams:
    """``[yaw]``: PI yaw-rate controller."""

    __pydantic_config__ = {"extra": "forbid"}

    kp_Nm_per_radps: float = 0.15
    ki_Nm_per_rad: float = 0.15
    u_limit_Nm: float = 0.15


@dataclass(frozen=True)
class AltitudeParams:
    """``[altitude]``: model, LQI weights, stick range and take-off threshold."""

    __pydantic_config__ = {"extra": "forbid"}

    T1_s: float = 0.08
    q_int: float = 8.25e-3
    q_z: float = 0.0
    q_vz: float = 0.0
    q_az: float = 0.0
    r: float = 1.0
    alt_range_m: float = 10.0
    takeoff_alt_m: float = 0.5


@dataclass(frozen=True)
class KfParams:
    """``[kf]``: altitude Kalman filter noise and the accelerometer source."""

    __pydantic_config__ = {"extra": "forbid"}

    accel_source: Literal["adxl335", "xsens"] = "adxl335"
    q_a: float = 2.0
    q_d: float = 0.05
    q_b: float = 1e-6
    r_baro_m2: float = 0.33
    r_acc: float = 0.091
    r_rest_vz: float = 0.0025
    rest_after_s: float = 1.0
    ground_effect_alt_m: float = 1.0
    ground_effect_r_scale: float = 25.0
    baro_gate_chi2: float = 25.0
    baro_gate_timeout_s: float = 1.0


@dataclass(frozen=True)
class FailsafeParams:
    """``[failsafe]``: RC loss, descent and IMU watchdog."""

    __pydantic_config__ = {"extra": "forbid"}

    rc_loss_s: float = 0.5
    descend_mps: float = 0.5
    imu_timeout_s: float = 0.1


@dataclass(frozen=True)
class TelemetryParams:
    """``[telemetry]``: XBee API downlink."""

    __pydantic_config__ = {"extra": "forbid"}

    enable: bool = True
    ap_mode: Literal[1, 2] = 1
    dest16: int = 0x0000
    divider: int = 8
    request_status: bool = False
    max_out_waiting: int = 256


@dataclass(frozen=True)
class LogParams:
    """``[log]``: stderr log level and the period of the stats line (sensor time)."""

    __pydantic_config__ = {"extra": "forbid"}

    level: Literal["debug", "info", "warning", "error"] = "info"
    stats_period_s: float = 1.0


@dataclass(frozen=True)
class FlightConfig:
    """The whole file."""

    __pydantic_config__ = {"extra": "forbid"}

    ports: PortsParams
    imu: ImuParams = field(default_factory=ImuParams)
    adc: AdcParams = field(default_factory=AdcParams)
    rc: RcParams = field(default_factory=RcParams)
    esc: EscParams = field(default_factory=EscParams)
    vehicle: VehicleParams = field(default_factory=VehicleParams)
    attitude: AttitudeParams = field(default_factory=AttitudeParams)
    yaw: YawParams = field(default_factory=YawParams)
    altitude: AltitudeParams = field(default_factory=AltitudeParams)
    kf: KfParams = field(default_factory=KfParams)
    plausibility: PlausibilityParams = field(default_factory=PlausibilityParams)
    failsafe: FailsafeParams = field(default_factory=FailsafeParams)
    telemetry: TelemetryParams = field(default_factory=TelemetryParams)
    modes: ModesParams = field(default_factory=ModesParams)
    log: LogParams = field(default_factory=LogParams)

    @property
    def T_s(self) -> float:
        """Loop period = IMU sample period, s."""
        return 1.0 / self.imu.rate_hz

    @property
    def log_level(self) -> Level:
        return Level[self.log.level.upper()]
