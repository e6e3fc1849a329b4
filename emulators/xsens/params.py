"""Parameters of the XSENS MTi emulator (rig table ``[imu]``).

Two identities: ``mk4`` (an MTi 100-series device speaking MTData2; by default the
MTi-300 AHRS whose identity is in the golden capture, Scottapotamas/xsens-mti docs/mtmanager_packets.md)
and ``legacy`` (a 2012-era MTi speaking MTData). Fields left at ``None`` take the
identity's default from :data:`IDENTITY_DEFAULTS`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from emulators.xsens.defs import BAUD_BPS_BY_CODE


class Identity(StrEnum):
    """Which device the emulator is."""

    MK4 = "mk4"
    LEGACY = "legacy"


class PowerUp(StrEnum):
    """State the constructor leaves the device in."""

    #: Measurement with the stored configuration, no WakeUp sent (clients do not expect
    #: one when they open the port; docs/protocols.md §1.3 recommendation).
    MEASUREMENT = "measurement"
    #: A real power-up: WakeUp, then the 500 ms WakeUpAck window.
    WAKEUP = "wakeup"


@dataclass(frozen=True)
class IdentityDefaults:
    """What a device of one identity reports and stores out of the box."""

    device_id: int
    product_code: str
    firmware_rev: tuple[int, ...]  #: (major, minor, rev) or + (build, svn rev) on mk4
    hardware_version: tuple[int, int]
    error_mode: int
    output_configuration: tuple[tuple[int, int], ...]  #: mk4 (XDI, Hz); empty for legacy
    legacy_output_mode: int
    legacy_output_settings: int


IDENTITY_DEFAULTS: dict[Identity, IdentityDefaults] = {
    # Identity of the MTi-300 in the golden capture (device id, product code, FW 1.8.2
    # build 37 rev 70964, hardware 2.0). Its Configuration reply shows the legacy fields
    # of an mk4 in MTData2 mode: output mode 0, settings 1. Factory output (mtidocs
    # "Miscellaneous"): 100 Hz quaternion with packet counter; SampleTimeFine and
    # StatusWord as in the capture's example 6.
    Identity.MK4: IdentityDefaults(
        device_id=0x037003F8,
        product_code="MTi-300-2A5G4",
        firmware_rev=(1, 8, 2, 37, 70964),
        hardware_version=(2, 0),
        error_mode=2,  # XDA treats mk4 devices as IncreasePacketCounterAndSendError
        output_configuration=((0x1020, 0xFFFF), (0x1060, 0xFFFF), (0x2010, 100), (0xE020, 0xFFFF)),
        legacy_output_mode=0x0000,
        legacy_output_settings=0x0000_0001,
    ),
    # A plausible 2012 MTi (3rd generation): device id in the 0x0050xxxx family of
    # docs/protocols.md §1.2, a 3-byte FW revision; factory output quaternion + sample counter
    # at 100 Hz (MT0100P p. 25), error mode 1 (ethz docstring).
    Identity.LEGACY: IdentityDefaults(
        device_id=0x00500A2B,
        product_code="MTi-28A53G35",
        firmware_rev=(2, 8, 1),
        hardware_version=(1, 6),
        error_mode=1,
        output_configuration=(),
        legacy_output_mode=0x0004,
        legacy_output_settings=0x0000_0001,
    ),
}

@dataclass(frozen=True)
class SensorResponse:
    """How the inertial sensors answer fast motion (used for the rotor vibration tones).

    ``acc_bandwidth_Hz``/``gyro_bandwidth_Hz``: -3 dB bandwidths; ``averaging``: whether an
    output is the mean over its output interval (strapdown integration, then dv/dt).
    """

    acc_bandwidth_Hz: float
    gyro_bandwidth_Hz: float
    averaging: bool


SENSOR_RESPONSE_DEFAULTS: dict[Identity, SensorResponse] = {
    # MTi-300 datasheet (Movella, May 2023): accelerometer 375 Hz, gyroscope 415 Hz (-3 dB).
    # MT0605P rev. E 4.9.3: "Calibrated data has been going through Strapdown Integration and
    # Inverse Strapdown Integration", i.e. dv / dt over the output interval: a mean.
    Identity.MK4: SensorResponse(375.0, 415.0, True),
    # 2012 MTi (MT0100P): accelerometer 30 Hz, rate gyroscope 40 Hz; MT0100P 4.5.2: the
    # calibrated data is "unprocessed ... no additional filtering", so a point sample.
    Identity.LEGACY: SensorResponse(30.0, 40.0, False),
}

#: Filter profiles of the golden MTi-300 (type, version, label).
MTI300_FILTER_PROFILES: tuple[tuple[int, int, str], ...] = (
    (39, 15, "general"),
    (40, 15, "high_mag_dep"),
    (41, 15, "dynamic"),
    (42, 15, "low_mag_dep"),
    (43, 15, "vru_general"),
)


@dataclass(frozen=True)
class XsensParams:
    """Emulated XSENS MTi. Units are in the names; frames: reference NED, sensor FRD.

    Line and protocol:
        identity: ``mk4`` or ``legacy``.
        device_id, product_code, firmware_rev, hardware_version: None = identity default.
        baud_bps: the device's line rate at power-up (8N1). 921600 so that the paper's
            400 Hz output fits the line (115200 carries only 11520 B/s).
        power_up: constructor state (see :class:`PowerUp`).
        power_on_offset_ns: device clock at sim time 0; SampleTimeFine =
            ((t_ns + offset) // 100_000) mod 2**32.
        wakeup_window_ns: WakeUpAck window after WakeUp (500 ms, mtidocs "States").
        wakeup_delay_ns: boot time from Reset/power-on to the WakeUp message.
        sample_rate_hz: internal sample grid; output rates must divide it (400 Hz = tick).
        output_configuration: mk4 stored (XDI, Hz) list; None = factory default.
        legacy_output_mode, legacy_output_settings: None = identity default.
        legacy_period: SetPeriod value, 1/115200 s (1152 = 100 Hz).
        legacy_skip_factor: SetOutputSkipFactor value.
        error_mode: 0..3 (SetErrorMode); None = identity default.
        tx_buffer_bytes: device transmit buffer; a data message that does not fit behind
            the bytes still on the line is an overrun (assumed size).
        rx_max_payload_bytes: longest message the device accepts; longer length fields
            are treated as garbage (assumed size).
        rx_timeout_ns: an incomplete message is discarded after this inter-byte gap
            (assumed; 0 disables).
        filter_profiles, filter_profile: ReqAvailableFilterProfiles list, current type.
        emts_size_bytes: size of the opaque eMTS blob (1320 B in the capture).

    Error model (seeded by the Generator given to the device):
        gyro_noise_radps_per_rthz, acc_noise_mps2_per_rthz: white-noise densities
            (MTi-300: 0.01 deg/s/sqrt(Hz), 60 ug/sqrt(Hz)); per-sample sigma = density *
            sqrt(sample_rate_hz).
        gyro_bias_sigma_radps, acc_bias_sigma_mps2: turn-on bias sigma, drawn at power-on.
        gyro_bias_rw_radps_per_rts: gyro bias random walk.
        orientation_bias_rp_deg, orientation_bias_yaw_deg: turn-on orientation error sigma
            (MTi-300 static accuracy 0.2 deg roll/pitch, 1 deg heading).
        orientation_noise_deg: white orientation noise per sample (sigma).
        acc_range_mps2, gyro_range_radps: saturation (clip bits in the status word).
        acc_bandwidth_Hz, gyro_bandwidth_Hz: -3 dB bandwidths of the accelerometers and
            gyroscopes; None = the identity's (:data:`SENSOR_RESPONSE_DEFAULTS`: mk4 375 /
            415 Hz, legacy 30 / 40 Hz). Applied to the rotor vibration tones
            (emulators/vibration.py); the rigid-body motion (< 10 Hz) passes unfiltered.
        bandwidth_order: 1 (single pole) or 2 (Butterworth) for those low-passes. The
            documents give only the -3 dB point; 1 is the choice that lets more through.
        output_averaging: outputs are the mean over the output interval (mk4 strapdown
            integration); None = the identity's (mk4 yes, legacy no).

    Environment seen by the other outputs:
        mag_field_N_au: Earth field in NED, normalised (1 = calibration field).
        temperature_degC, pressure_Pa: until :meth:`MtiDevice.set_ambient` is called.
        gravity_mps2: local gravity for FreeAcceleration.
    """

    __pydantic_config__ = {"extra": "forbid"}

    identity: Identity = Identity.MK4
    device_id: int | None = None
    product_code: str | None = None
    firmware_rev: tuple[int, ...] | None = None
    hardware_version: tuple[int, int] | None = None
    baud_bps: int = 921_600
    power_up: PowerUp = PowerUp.MEASUREMENT
    power_on_offset_ns: int = 0
    wakeup_window_ns: int = 500_000_000
    wakeup_delay_ns: int = 0
    sample_rate_hz: int = 400
    output_configuration: tuple[tuple[int, int], ...] | None = None
    legacy_output_mode: int | None = None
    legacy_output_settings: int | None = None
    legacy_period: int = 1152
    legacy_skip_factor: int = 0
    error_mode: int | None = None
    tx_buffer_bytes: int = 1024
    rx_max_payload_bytes: int = 512
    rx_timeout_ns: int = 10_000_000
    filter_profiles: tuple[tuple[int, int, str], ...] = MTI300_FILTER_PROFILES
    filter_profile: int = 39
    emts_size_bytes: int = 1320

    gyro_noise_radps_per_rthz: float = math.radians(0.01)
    acc_noise_mps2_per_rthz: float = 60e-6 * 9.80665
    gyro_bias_sigma_radps: float = math.radians(0.2)
    gyro_bias_rw_radps_per_rts: float = 2e-5
    acc_bias_sigma_mps2: float = 0.03
    orientation_bias_rp_deg: float = 0.2
    orientation_bias_yaw_deg: float = 1.0
    orientation_noise_deg: float = 0.05
    acc_range_mps2: float = 200.0
    gyro_range_radps: float = math.radians(450.0)
    acc_bandwidth_Hz: float | None = None
    gyro_bandwidth_Hz: float | None = None
    bandwidth_order: int = 1
    output_averaging: bool | None = None

    mag_field_N_au: tuple[float, float, float] = (0.5, 0.0, 0.866)
    temperature_degC: float = 35.0
    pressure_Pa: float = 101_325.0
    gravity_mps2: float = 9.80665

    def __post_init__(self) -> None:
        if self.sample_rate_hz <= 0 or 1_000_000_000 % self.sample_rate_hz:
            raise ValueError(f"sample_rate_hz={self.sample_rate_hz} must divide 1e9 ns")
        if self.baud_bps not in BAUD_BPS_BY_CODE.values():
            raise ValueError(f"baud_bps={self.baud_bps} is not an Xbus rate: {sorted(set(BAUD_BPS_BY_CODE.values()))}")
        for name in ("acc_bandwidth_Hz", "gyro_bandwidth_Hz"):
            bw = getattr(self, name)
            if bw is not None and not (math.isfinite(bw) and bw > 0.0):
                raise ValueError(f"{name}={bw} must be a finite frequency > 0 Hz (or left out: the identity's)")
        if self.bandwidth_order not in (1, 2):
            raise ValueError(f"bandwidth_order={self.bandwidth_order} must be 1 (single pole) or 2 (Butterworth)")

    @property
    def defaults(self) -> IdentityDefaults:
        return IDENTITY_DEFAULTS[Identity(self.identity)]

    def sensor_response(self) -> SensorResponse:
        """Bandwidths and averaging with the identity's defaults filled in."""
        d = SENSOR_RESPONSE_DEFAULTS[Identity(self.identity)]
        return SensorResponse(
            d.acc_bandwidth_Hz if self.acc_bandwidth_Hz is None else self.acc_bandwidth_Hz,
            d.gyro_bandwidth_Hz if self.gyro_bandwidth_Hz is None else self.gyro_bandwidth_Hz,
            d.averaging if self.output_averaging is None else self.output_averaging,
        )

    def resolved(self) -> ResolvedIdentity:
        """Concrete identity values (defaults filled in)."""
        d = self.defaults
        return ResolvedIdentity(
            device_id=d.device_id if self.device_id is None else self.device_id,
            product_code=d.product_code if self.product_code is None else self.product_code,
            firmware_rev=d.firmware_rev if self.firmware_rev is None else self.firmware_rev,
            hardware_version=d.hardware_version if self.hardware_version is None else self.hardware_version,
            error_mode=d.error_mode if self.error_mode is None else self.error_mode,
            output_configuration=(
                d.output_configuration if self.output_configuration is None else self.output_configuration
            ),
            legacy_output_mode=d.legacy_output_mode if self.legacy_output_mode is None else self.legacy_output_mode,
            legacy_output_settings=(
                d.legacy_output_settings if self.legacy_output_settings is None else self.legacy_output_settings
            ),
        )


@dataclass(frozen=True)
class ResolvedIdentity(IdentityDefaults):
    """:class:`IdentityDefaults` after applying the rig's overrides."""
