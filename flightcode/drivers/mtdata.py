"""XSENS measurement payloads: MTData2 (mk4) and legacy MTData decoding, and the output
configuration the flight code asks for.

Sans-I/O. Wire facts (docs/protocols.md 1.8, 1.9; MT0100P, MT0605P, xspublic
``xsdataidentifier.h``):

* all fields big-endian; floats are IEEE-754 single unless the data identifier (MTData2) or
  the output settings (legacy MTData) select fixed point or double;
* MTData2 payload = packets of ``XDI(u16) size(u8) data``; XDI bits 3-2 the coordinate
  system, bits 1-0 the precision;
* legacy MTData = the items of SetOutputMode/SetOutputSettings in a fixed order.
"""

from __future__ import annotations

import math
import struct
from collections import Counter
from dataclasses import dataclass
from enum import IntEnum, unique

#: SampleTimeFine counts 10 kHz ticks (Xsens ROS driver SAMPLE_TIME_FINE_HZ).
SAMPLE_TIME_FINE_HZ = 10_000
#: Legacy SetPeriod unit: 1/115200 s.
LEGACY_PERIOD_CLOCK_HZ = 115_200


@unique
class Xdi(IntEnum):
    """MTData2 data identifiers with the coordinate/precision bits cleared (type = xdi & 0xFFF0)."""

    PACKET_COUNTER = 0x1020  # u16
    SAMPLE_TIME_FINE = 0x1060  # u32, 10 kHz ticks
    EULER_ANGLES = 0x2030  # roll, pitch, yaw, deg
    ACCELERATION = 0x4020  # specific force, m/s^2
    RATE_OF_TURN = 0x8020  # rad/s
    STATUS_WORD = 0xE020  # u32


@unique
class XdiCoord(IntEnum):
    """XDI bits 3-2: coordinate system of orientation/vector outputs."""

    ENU = 0x0
    NED = 0x4
    NWU = 0x8


@unique
class XdiPrecision(IntEnum):
    """XDI bits 1-0: number format (bytes per scalar in the comment)."""

    FLOAT32 = 0x0  # 4
    FP1220 = 0x1  # 4, signed 12.20 fixed point
    FP1632 = 0x2  # 6, u32 fraction then s16 integer part
    FLOAT64 = 0x3  # 8


@unique
class LegacyMode(IntEnum):
    """Legacy SetOutputMode bits (MT0100P p.27)."""

    TEMPERATURE = 0x0001
    CALIBRATED = 0x0002
    ORIENTATION = 0x0004
    AUXILIARY = 0x0008
    POSITION = 0x0010
    VELOCITY = 0x0020
    STATUS = 0x0800


@unique
class LegacySettings(IntEnum):
    """Legacy SetOutputSettings bits (MT0100P p.28)."""

    SAMPLE_COUNTER = 0x00000001
    ORIENT_EULER = 0x00000004
    ORIENT_MATRIX = 0x00000008
    DISABLE_ACC = 0x00000010
    DISABLE_GYR = 0x00000020
    DISABLE_MAG = 0x00000040
    FIXED_1220 = 0x00000100
    DISABLE_AIN1 = 0x00000400
    DISABLE_AIN2 = 0x00000800
    NED = 0x80000000

def mk4_output_configuration(rate_hz: int) -> tuple[tuple[int, int], ...]:
    """The (XDI with NED/float32 bits, frequency Hz) list the flight code sends to a mk4.

    Frequency 0xFFFF = "in every packet" (MT Manager capture, docs/protocols.md 1.9).
    """
    every = 0xFFFF
    return (
        (0x1020, every),  # PacketCounter
        (0x1060, every),  # SampleTimeFine
        (0x2034, rate_hz),  # EulerAngles, NED, float32
        (0x8024, rate_hz),  # RateOfTurn, NED (FRD body), float32
        (0x4024, rate_hz),  # Acceleration, NED (FRD body), float32
        (0xE020, every),  # StatusWord
    )


#: Legacy configuration: calibrated data + orientation; sample counter, Euler, NED.
LEGACY_OUTPUT_MODE = LegacyMode.CALIBRATED | LegacyMode.ORIENTATION
LEGACY_OUTPUT_SETTINGS = LegacySettings.SAMPLE_COUNTER | LegacySettings.ORIENT_EULER | LegacySettings.NED


def legacy_period(rate_hz: int) -> int:
    """SetPeriod value (units of 1/115200 s) for ``rate_hz``; 400 Hz -> 288."""
    return round(LEGACY_PERIOD_CLOCK_HZ / rate_hz)


def encode_output_configuration(entries: tuple[tuple[int, int], ...]) -> bytes:
    """SetOutputConfiguration payload: N x (XDI u16, frequency u16), big-endian."""
    return b"".join(struct.pack(">HH", xdi, freq) for xdi, freq in entries)

@dataclass(frozen=True)
class XsensData:
    """Decoded measurement, in the device's units and output frame (NED/FRD as configured).

    ``sample_time_fine`` is None for legacy MTData (which has only the u16 counter).
    Angles in degrees as on the wire; the driver converts them.
    """

    counter: int
    sample_time_fine: int | None
    euler_deg: tuple[float, float, float]
    rate_of_turn_radps: tuple[float, float, float]
    acceleration_mps2: tuple[float, float, float]
    status: int


def _scalars(data: bytes, precision: int, count: int) -> tuple[float, ...] | None:
    """Decode ``count`` scalars in the MTData2 ``precision``; None if the size is wrong."""
    if precision == XdiPrecision.FLOAT32:
        if len(data) != 4 * count:
            return None
        return struct.unpack(f">{count}f", data)
    if precision == XdiPrecision.FP1220:
        if len(data) != 4 * count:
            return None
        return tuple(v / 1048576.0 for v in struct.unpack(f">{count}i", data))
    if precision == XdiPrecision.FP1632:
        if len(data) != 6 * count:
            return None
        vals = []
        for i in range(count):
            frac, whole = struct.unpack_from(">Ih", data, 6 * i)
            vals.append((whole * 4294967296 + frac) / 4294967296.0)
        return tuple(vals)
    if len(data) != 8 * count:
        return None
    return struct.unpack(f">{count}d", data)


def _vec3(data: bytes, precision: int) -> tuple[float, float, float] | None:
    vals = _scalars(data, precision, 3)
    if vals is None or not all(math.isfinite(v) for v in vals):
        return None
    return (vals[0], vals[1], vals[2])


def mtdata2_packets(payload: bytes) -> list[tuple[int, bytes]] | None:
    """Split an MTData2 payload into (XDI, data) packets; None if a packet overruns the payload."""
    packets = []
    off, end = 0, len(payload)
    while off + 3 <= end:
        xdi, size = struct.unpack_from(">HB", payload, off)
        if off + 3 + size > end:
            return None
        packets.append((xdi, payload[off + 3 : off + 3 + size]))
        off += 3 + size
    return packets if off == end else None


#: The payload a mk4 sends for :func:`mk4_output_configuration`, items in that order: the
#: per-sample fast path decodes it with one unpack (anything else takes the general path).
_MK4_PAYLOAD = struct.Struct(">HBH" "HBI" "HB3f" "HB3f" "HB3f" "HBI")  # big-endian, no padding: 64 bytes
_MK4_HEADERS = ((0, 0x1020, 2), (3, 0x1060, 4), (6, 0x2034, 12), (11, 0x8024, 12), (16, 0x4024, 12),
                (21, 0xE020, 4))


def _decode_mk4_fast(payload: bytes) -> XsensData | None:
    """The flight code's own mk4 layout in one unpack; None if the payload is laid out otherwise."""
    if len(payload) != _MK4_PAYLOAD.size:
        return None
    v = _MK4_PAYLOAD.unpack(payload)
    for i, xdi, size in _MK4_HEADERS:
        if v[i] != xdi or v[i + 1] != size:
            return None
    if not math.isfinite(v[8] + v[9] + v[10] + v[13] + v[14] + v[15] + v[18] + v[19] + v[20]):
        return None  # the general path counts what is wrong
    return XsensData(v[2], v[5], (v[8], v[9], v[10]), (v[13], v[14], v[15]), (v[18], v[19], v[20]), v[23])


def decode_mtdata2(payload: bytes, counters: Counter[str]) -> XsensData | None:
    """Decode an MTData2 payload; None (counted) unless every item the loop needs is present.

    Needed: PacketCounter, SampleTimeFine, EulerAngles, RateOfTurn, Acceleration; StatusWord
    is optional (0 when absent). Unknown XDIs are skipped, malformed packets counted. The
    layout the flight code configures is decoded in one unpack (same result).
    """
    fast = _decode_mk4_fast(payload)
    if fast is not None:
        return fast
    packets = mtdata2_packets(payload)
    if packets is None:
        counters["mtdata2_truncated"] += 1
        return None
    counter = stf = None
    euler = gyr = acc = None
    status = 0
    for xdi, data in packets:
        kind, precision = xdi & 0xFFF0, xdi & 0x3
        if kind == Xdi.PACKET_COUNTER and len(data) == 2:
            counter = (data[0] << 8) | data[1]
        elif kind == Xdi.SAMPLE_TIME_FINE and len(data) == 4:
            stf = struct.unpack(">I", data)[0]
        elif kind == Xdi.EULER_ANGLES:
            euler = _vec3(data, precision)
        elif kind == Xdi.RATE_OF_TURN:
            gyr = _vec3(data, precision)
        elif kind == Xdi.ACCELERATION:
            acc = _vec3(data, precision)
        elif kind == Xdi.STATUS_WORD and len(data) == 4:
            status = struct.unpack(">I", data)[0]
    if counter is None or stf is None or euler is None or gyr is None or acc is None:
        counters["mtdata2_incomplete"] += 1
        return None
    return XsensData(counter, stf, euler, gyr, acc, status)


def legacy_mtdata_length(mode: int, settings: int) -> int:
    """MTData payload length for (mode, settings) with 4-byte scalars (float32 or 12.20)."""
    n = 0
    if mode & LegacyMode.TEMPERATURE:
        n += 4
    if mode & LegacyMode.CALIBRATED:
        for bit in (LegacySettings.DISABLE_ACC, LegacySettings.DISABLE_GYR, LegacySettings.DISABLE_MAG):
            n += 0 if settings & bit else 12
    if mode & LegacyMode.ORIENTATION:
        n += {0: 16, 1: 12, 2: 36}.get((settings >> 2) & 0x3, 16)
    if mode & LegacyMode.AUXILIARY:
        n += sum(0 if settings & bit else 2 for bit in (LegacySettings.DISABLE_AIN1, LegacySettings.DISABLE_AIN2))
    if mode & LegacyMode.POSITION:
        n += 12
    if mode & LegacyMode.VELOCITY:
        n += 12
    if mode & LegacyMode.STATUS:
        n += 1
    if settings & 0x3 == 1:
        n += 2
    return n


def decode_mtdata_legacy(payload: bytes, mode: int, settings: int, counters: Counter[str]) -> XsensData | None:
    """Decode a legacy MTData (0x32) payload laid out by ``mode``/``settings``.

    Order (MT0100P p.29 + MTi-G items): temperature, calibrated (acc, gyr, mag), orientation,
    auxiliary, position, velocity, status, sample counter. Requires calibrated acc and gyr,
    Euler orientation and the sample counter; anything else is counted and dropped.
    """
    if len(payload) != legacy_mtdata_length(mode, settings):
        counters["mtdata_bad_length"] += 1
        return None
    if not (mode & LegacyMode.CALIBRATED and mode & LegacyMode.ORIENTATION) or (settings >> 2) & 0x3 != 1:
        counters["mtdata_unsupported_layout"] += 1
        return None
    precision = XdiPrecision.FP1220 if settings & LegacySettings.FIXED_1220 else XdiPrecision.FLOAT32
    off = 4 if mode & LegacyMode.TEMPERATURE else 0
    acc = gyr = None
    if not settings & LegacySettings.DISABLE_ACC:
        acc = _vec3(payload[off : off + 12], precision)
        off += 12
    if not settings & LegacySettings.DISABLE_GYR:
        gyr = _vec3(payload[off : off + 12], precision)
        off += 12
    if not settings & LegacySettings.DISABLE_MAG:
        off += 12
    euler = _vec3(payload[off : off + 12], precision)
    status = payload[-3] if mode & LegacyMode.STATUS and settings & 0x3 == 1 else 0
    if settings & 0x3 != 1 or acc is None or gyr is None or euler is None:
        counters["mtdata_incomplete"] += 1
        return None
    counter = (payload[-2] << 8) | payload[-1]
    return XsensData(counter, None, euler, gyr, acc, status)
