"""Telemetry downlink payload (format version 1) and the loop's compute-time window.

One payload per telemetry frame (50 Hz: every 8th 400 Hz sample), carried in an XBee TX16
frame. 90 bytes, little-endian, fixed layout; docs/telemetry.md documents it byte by byte
(the bench decodes it from that page, independently of this module). A new layout gets a
new ``version`` byte; decoders must check it first.

Compute time is ``time.perf_counter_ns`` around a loop iteration minus its blocking exchanges
(IMU wait, ADC transaction); the frame carries the last, maximum and mean over the samples
completed since the previous frame.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from enum import IntFlag, unique

VERSION = 1
_LAYOUT = struct.Struct("<BBHIH10f4H4f8H")
#: Payload length in bytes (<= 100, the 802.15.4 RF payload limit).
PAYLOAD_LEN = _LAYOUT.size
_U16_MAX = 0xFFFF


@unique
class TelemetryFlags(IntFlag):
    """Bits of the ``flags`` field."""

    RC_VALID = 0x0001  # a good RC frame within failsafe.rc_loss_s
    ADC_VALID = 0x0002  # this sample's ADC read succeeded
    MIXER_SATURATED = 0x0004  # the mixer clipped this sample
    BARO_REF_READY = 0x0008  # the boot pressure reference is fixed
    ACCEL_FROM_XSENS = 0x0010  # vertical acceleration from the XSENS (configured, or the ADXL335's offset moved)
    PAPER_LITERAL_LAW = 0x0020  # attitude.law = "paper_literal"
    IMU_SAMPLES_SKIPPED = 0x0040  # the loop fell behind and skipped samples in this window
    BARO_MOTION_REFUSED = 0x0080  # the barometer's motion disagrees with the accelerometers': not fused


@dataclass(frozen=True)
class TelemetryRecord:
    """Everything one frame carries (units in the names; frames: body FRD, world NED, z up).

    ``t_ns`` is sensor time since the first sample; ``mode`` the numeric mode (see
    :class:`flightcode.modes.Mode`); counters are totals since boot (sent modulo 65536).
    """

    seq: int
    t_ns: int
    mode: int
    flags: int
    euler_rad: tuple[float, float, float]
    z_hat_m: float
    vz_hat_mps: float
    z_baro_m: float
    roll_ref_rad: float
    pitch_ref_rad: float
    yaw_rate_ref_radps: float
    z_ref_m: float
    pulses_us: tuple[float, float, float, float]
    collective: float
    tau_applied_Nm: tuple[float, float, float]
    compute_last_us: float
    compute_max_us: float
    compute_mean_us: float
    imu_gap_samples: int
    imu_skipped_samples: int
    adc_failed_reads: int
    rc_errors: int
    telemetry_dropped: int


def _u16(value: float) -> int:
    """Non-negative count or duration to u16: NaN -> 0, saturating at 65535."""
    if not math.isfinite(value) or value <= 0:
        return 0
    return min(_U16_MAX, int(round(value)))


def encode(rec: TelemetryRecord) -> bytes:
    """The version-1 payload of ``rec`` (PAYLOAD_LEN bytes)."""
    return _LAYOUT.pack(
        VERSION,
        rec.mode,
        rec.seq & 0xFFFF,
        (rec.t_ns // 100_000) & 0xFFFFFFFF,
        rec.flags & 0xFFFF,
        *rec.euler_rad,
        rec.z_hat_m,
        rec.vz_hat_mps,
        rec.z_baro_m,
        rec.roll_ref_rad,
        rec.pitch_ref_rad,
        rec.yaw_rate_ref_radps,
        rec.z_ref_m,
        *(min(_U16_MAX, max(0, int(round(p * 4.0)))) for p in rec.pulses_us),
        rec.collective,
        *rec.tau_applied_Nm,
        _u16(rec.compute_last_us),
        _u16(rec.compute_max_us),
        _u16(rec.compute_mean_us),
        rec.imu_gap_samples & 0xFFFF,
        rec.imu_skipped_samples & 0xFFFF,
        rec.adc_failed_reads & 0xFFFF,
        rec.rc_errors & 0xFFFF,
        rec.telemetry_dropped & 0xFFFF,
    )


class ComputeWindow:
    """Compute-time statistics over the samples since the last :meth:`take`, in ns."""

    def __init__(self) -> None:
        self.last_ns = 0
        self._max_ns = 0
        self._sum_ns = 0
        self._n = 0

    def add(self, compute_ns: int) -> None:
        self.last_ns = compute_ns
        if compute_ns > self._max_ns:
            self._max_ns = compute_ns
        self._sum_ns += compute_ns
        self._n += 1

    def take(self) -> tuple[float, float, float]:
        """(last, max, mean) in us over the window; starts a new window."""
        mean = self._sum_ns / self._n if self._n else 0.0
        out = (self.last_ns / 1000.0, self._max_ns / 1000.0, mean / 1000.0)
        self._max_ns = self._sum_ns = self._n = 0
        return out
