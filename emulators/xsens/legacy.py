"""Legacy MTData (0x32): layout from SetOutputMode / SetOutputSettings, encoder and decoder.

Payload order (MT0100P p. 29, docs/protocols.md §1.8): temperature, calibrated (acc, gyr, mag
unless disabled by settings bits 4..6), orientation (quaternion 4 / Euler 3 / matrix 9),
status byte, sample counter (u16). Scalars are float32 or signed fixed 12.20 (settings
bits 9..8). The rotation matrix goes out column by column (a, b, c = first column), as in
the Xsens "Orientation output specifications" article.

The emulated MTi has no auxiliary inputs, GPS, position/velocity (MTi-G) or raw 16-bit
inertial output; settings or modes asking for them are refused with Error 0x21.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass

from emulators.xsens.defs import (
    ErrorCode,
    LegacyFormat,
    LegacyMode,
    LegacyOrientation,
    LegacySettingsBit,
    LegacyTimestamp,
    Precision,
)
from emulators.xsens.frames import Quat, Vec3, quat_to_euler_deg, quat_to_matrix
from emulators.xsens.mtdata2 import decode_values, encode_values

_SUPPORTED_MODE = LegacyMode.TEMPERATURE | LegacyMode.CALIBRATED | LegacyMode.ORIENTATION | LegacyMode.STATUS
_ORIENT_SCALARS = {LegacyOrientation.QUATERNION: 4, LegacyOrientation.EULER: 3, LegacyOrientation.MATRIX: 9}


def timestamp_of(settings: int) -> int:
    return settings & 0x3


def orientation_of(settings: int) -> int:
    return (settings >> 2) & 0x3


def format_of(settings: int) -> int:
    return (settings >> 8) & 0x3


def is_ned(settings: int) -> bool:
    return bool(settings & LegacySettingsBit.NED)


def validate(mode: int, settings: int) -> ErrorCode | None:
    """None if the emulated legacy MTi can output this mode/settings pair, else the error."""
    if mode & ~_SUPPORTED_MODE & 0xFFFF:
        return ErrorCode.INVALID_PARAM
    if timestamp_of(settings) not in (LegacyTimestamp.NONE, LegacyTimestamp.SAMPLE_COUNTER):
        return ErrorCode.INVALID_PARAM
    if orientation_of(settings) not in _ORIENT_SCALARS:
        return ErrorCode.INVALID_PARAM
    if format_of(settings) not in (LegacyFormat.FLOAT32, LegacyFormat.FP1220):
        return ErrorCode.INVALID_PARAM
    return None


def _calibrated_parts(settings: int) -> tuple[bool, bool, bool]:
    return (not settings & LegacySettingsBit.NO_ACC, not settings & LegacySettingsBit.NO_GYR,
            not settings & LegacySettingsBit.NO_MAG)


def mtdata_length(mode: int, settings: int) -> int:
    """MTData payload length in bytes for a valid mode/settings pair."""
    n = 0
    if mode & LegacyMode.TEMPERATURE:
        n += 1
    if mode & LegacyMode.CALIBRATED:
        n += 3 * sum(_calibrated_parts(settings))
    if mode & LegacyMode.ORIENTATION:
        n += _ORIENT_SCALARS[LegacyOrientation(orientation_of(settings))]
    length = 4 * n
    if mode & LegacyMode.STATUS:
        length += 1
    if timestamp_of(settings) == LegacyTimestamp.SAMPLE_COUNTER:
        length += 2
    return length


@dataclass(frozen=True)
class LegacySample:
    """One sample in the output frame (see frames.py): the device fills it, MTData carries it."""

    temperature_degC: float
    acc_mps2: Vec3
    rate_radps: Vec3
    mag_au: Vec3
    q: Quat
    status: int
    sample_counter: int


def _precision(settings: int) -> Precision:
    return Precision.FP1220 if format_of(settings) == LegacyFormat.FP1220 else Precision.FLOAT32


def orientation_values(q: Quat, settings: int) -> tuple[float, ...]:
    """Orientation scalars in the order MTData carries them."""
    kind = orientation_of(settings)
    if kind == LegacyOrientation.EULER:
        return quat_to_euler_deg(q)
    if kind == LegacyOrientation.MATRIX:
        rows = quat_to_matrix(q)
        return tuple(rows[r][c] for c in range(3) for r in range(3))
    return q


def encode(mode: int, settings: int, s: LegacySample) -> bytes:
    """MTData payload for a valid mode/settings pair."""
    values: list[float] = []
    if mode & LegacyMode.TEMPERATURE:
        values.append(s.temperature_degC)
    if mode & LegacyMode.CALIBRATED:
        for present, v in zip(_calibrated_parts(settings), (s.acc_mps2, s.rate_radps, s.mag_au), strict=True):
            if present:
                values.extend(v)
    if mode & LegacyMode.ORIENTATION:
        values.extend(orientation_values(s.q, settings))
    out = encode_values(values, _precision(settings))
    if mode & LegacyMode.STATUS:
        out += bytes((s.status & 0xFF,))
    if timestamp_of(settings) == LegacyTimestamp.SAMPLE_COUNTER:
        out += struct.pack(">H", s.sample_counter & 0xFFFF)
    return out


def decode(mode: int, settings: int, payload: bytes) -> dict[str, Sequence[float] | float | int]:
    """Split an MTData payload into named fields (the inverse of :func:`encode`)."""
    if len(payload) != mtdata_length(mode, settings):
        raise ValueError(f"MTData of {len(payload)} bytes, mode/settings say {mtdata_length(mode, settings)}")
    precision = _precision(settings)
    out: dict[str, Sequence[float] | float | int] = {}
    i = 0

    def take(n: int) -> tuple[float, ...]:
        nonlocal i
        vals = decode_values(payload[i : i + 4 * n], precision)
        i += 4 * n
        return vals

    if mode & LegacyMode.TEMPERATURE:
        out["temperature"] = take(1)[0]
    if mode & LegacyMode.CALIBRATED:
        for present, name in zip(_calibrated_parts(settings), ("acc", "gyr", "mag"), strict=True):
            if present:
                out[name] = take(3)
    if mode & LegacyMode.ORIENTATION:
        kind = LegacyOrientation(orientation_of(settings))
        out[kind.name.lower()] = take(_ORIENT_SCALARS[kind])
    if mode & LegacyMode.STATUS:
        out["status"] = payload[i]
        i += 1
    if timestamp_of(settings) == LegacyTimestamp.SAMPLE_COUNTER:
        out["sample_counter"] = int.from_bytes(payload[i : i + 2], "big")
    return out
