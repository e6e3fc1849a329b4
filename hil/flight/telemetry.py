"""The bench's own decoder of the flight code's telemetry downlink (docs/telemetry.md).

The bench plays the ground station: it reads the XBee API frames the flight code writes
to the vehicle's module (TX16 0x01 / TX64 0x00, escaped or not), and decodes the payload
(format version 1, 90 bytes, little-endian). It never imports the flight code: the format
is a documented wire contract, decoded here independently.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterator
from typing import Any

START = 0x7E
ESCAPE = 0x7D
TX64 = 0x00
TX16 = 0x01
_V1 = struct.Struct("<BBHIH10f4H4f8H")
RAD2DEG = 180.0 / math.pi
MODES = {0: "BOOT", 1: "DISARMED", 2: "ARMED", 3: "FLYING", 4: "FAILSAFE_RC", 5: "FAILSAFE_IMU"}


def decode_payload(payload: bytes) -> dict[str, Any] | None:
    """Version-1 payload -> a flat dict with units in the keys; None if not version 1."""
    if len(payload) != _V1.size or payload[0] != 1:
        return None
    v = _V1.unpack(payload)
    (_, mode, seq, stf, flags) = v[:5]
    roll, pitch, yaw, z_hat, vz_hat, z_baro, roll_ref, pitch_ref, yaw_rate_ref, z_ref = v[5:15]
    pulses = [q / 4.0 for q in v[15:19]]
    collective, tau_r, tau_p, tau_y = v[19:23]
    c_last, c_max, c_mean, gaps, skipped, adc_fail, rc_err, tm_drop = v[23:31]
    return {
        "seq": seq,
        "t_s": stf / 10_000.0,
        "mode": mode,
        "mode_name": MODES.get(mode, str(mode)),
        "flags": flags,
        # the altitude filter's accelerometer (docs/telemetry.md flags bit 4): 1 the XSENS's
        "accel_from_xsens": 1.0 if flags & 0x0010 else 0.0,
        "roll_deg": roll * RAD2DEG,
        "pitch_deg": pitch * RAD2DEG,
        "yaw_deg": yaw * RAD2DEG,
        "alt_est_m": z_hat,
        "vz_est_mps": vz_hat,
        "alt_baro_m": z_baro,
        "roll_ref_deg": roll_ref * RAD2DEG,
        "pitch_ref_deg": pitch_ref * RAD2DEG,
        "yaw_rate_ref_degps": yaw_rate_ref * RAD2DEG,
        "alt_ref_m": z_ref,
        "pulses_us": pulses,
        "collective": collective,
        "tau_applied_Nm": [tau_r, tau_p, tau_y],
        "compute_last_us": c_last,
        "compute_max_us": c_max,
        "compute_mean_us": c_mean,
        "imu_gap_samples": gaps,
        "imu_skipped_samples": skipped,
        "adc_failed_reads": adc_fail,
        "rc_errors": rc_err,
        "telemetry_dropped": tm_drop,
    }


class TelemetryDecoder:
    """Streaming XBee API parser (AP=1 or AP=2) yielding decoded telemetry payloads."""

    def __init__(self) -> None:
        self._buf = bytearray()
        self.frames = 0
        self.bad_checksums = 0
        self.unknown_payloads = 0

    def feed(self, data: bytes) -> Iterator[dict[str, Any]]:
        self._buf += data
        buf = self._buf
        while True:
            start = buf.find(START)
            if start < 0:
                buf.clear()
                return
            if start:
                del buf[:start]
            frame, used = _unescape_frame(buf)
            if used == 0:
                return  # incomplete
            del buf[:used]
            if frame is None:
                self.bad_checksums += 1
                continue
            self.frames += 1
            kind = frame[0]
            if kind == TX16 and len(frame) >= 5:
                payload = bytes(frame[5:])
            elif kind == TX64 and len(frame) >= 11:
                payload = bytes(frame[11:])
            else:
                continue
            decoded = decode_payload(payload)
            if decoded is None:
                self.unknown_payloads += 1
                continue
            yield decoded


def _unescape_frame(buf: bytearray) -> tuple[bytes | None, int]:
    """Parse one frame at buf[0] == 0x7E. Returns (frame data or None if bad, bytes used);
    (None, 0) when more bytes are needed. Handles escaping transparently: an escaped
    stream never contains a raw 0x7D/0x7E inside a frame, an unescaped one rarely does,
    so 0x7D is treated as an escape only when the frame does not check out unescaped."""
    plain = _parse_plain(buf)
    if plain[1] and plain[0] is not None:
        return plain
    # Not a good unescaped frame: read it escaped, and wait while that reading needs more
    # bytes (an escaped frame that arrived up to a 0x7D near its end reads as a complete
    # bad frame unescaped; taking that verdict lost the frame).
    return _parse(buf, escaped=True)


def _parse_plain(buf: bytearray) -> tuple[bytes | None, int]:
    """``_parse(buf, escaped=False)`` with slices instead of a loop over the bytes (the
    telemetry link carries about 100 bytes a frame at 50 Hz); same results."""
    nxt = buf.find(START, 1)
    end = len(buf) if nxt < 0 else nxt  # bytes 1..end-1 hold no START
    if end >= 3:
        need = 2 + ((buf[1] << 8) | buf[2]) + 1  # length bytes, data, checksum
        if need > 2 + 0x200:
            return None, 1
        if end - 1 >= need:
            data = bytes(buf[3 : need])
            ok = (sum(data) + buf[need]) & 0xFF == 0xFF
            return (data if ok else None), 1 + need
    return (None, 0) if nxt < 0 else (None, nxt)


def _parse(buf: bytearray, *, escaped: bool) -> tuple[bytes | None, int]:
    """One frame at buf[0] == 0x7E, byte by byte (the reference for ``_parse_plain``)."""
    out = bytearray()
    i = 1
    n = len(buf)
    need = None
    while True:
        if i >= n:
            return None, 0
        b = buf[i]
        i += 1
        if escaped and b == ESCAPE:
            if i >= n:
                return None, 0
            b = buf[i] ^ 0x20
            i += 1
        elif b == START:
            return None, i - 1  # a new frame started: this one was truncated
        out.append(b)
        if need is None and len(out) == 2:
            need = 2 + ((out[0] << 8) | out[1]) + 1
            if need > 2 + 0x200:
                return None, 1
        if need is not None and len(out) == need:
            data = bytes(out[2:-1])
            ok = (sum(data) + out[-1]) & 0xFF == 0xFF
            return (data if ok else None), i
