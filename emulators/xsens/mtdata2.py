"""MTData2 (0x36) payload: packets of ``XDI (u16) | size (u8) | data``, big-endian.

Floating outputs are encoded in the precision selected by the XDI's low two bits
(docs/protocols.md §1.9): float32, float64, signed fixed 12.20 (i32 = round(v * 2^20)) and
signed fixed 16.32 (6 bytes: u32 fraction then i16 integer part; value =
(int16 * 2^32 + uint32) / 2^32, xspublic ``XsMessage_getDataFP1632``). Fixed-point
values saturate at their range ends instead of wrapping.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Sequence

from emulators.xsens.defs import XDI_PRECISION_MASK, Precision

_F32 = struct.Struct(">f")
_F64 = struct.Struct(">d")
_I32 = struct.Struct(">i")
_FP1632 = struct.Struct(">Ih")

BYTES_PER_SCALAR: dict[Precision, int] = {
    Precision.FLOAT32: 4,
    Precision.FP1220: 4,
    Precision.FP1632: 6,
    Precision.FLOAT64: 8,
}

_I32_MIN, _I32_MAX = -(1 << 31), (1 << 31) - 1
_I48_MIN, _I48_MAX = -(1 << 47), (1 << 47) - 1


def precision_of(xdi: int) -> Precision:
    """Precision selected by an XDI's low bits."""
    return Precision(xdi & XDI_PRECISION_MASK)


def _encode_scalar(v: float, precision: Precision) -> bytes:
    if precision is Precision.FLOAT32:
        return _F32.pack(v)
    if precision is Precision.FLOAT64:
        return _F64.pack(v)
    if precision is Precision.FP1220:
        return _I32.pack(min(max(round(v * (1 << 20)), _I32_MIN), _I32_MAX))
    raw = min(max(round(v * (1 << 32)), _I48_MIN), _I48_MAX)
    return _FP1632.pack(raw & 0xFFFF_FFFF, raw >> 32)


_F32_N = [struct.Struct(f">{n}f") for n in range(10)]


def encode_values(values: Sequence[float], precision: Precision) -> bytes:
    """Scalars in ``precision``, concatenated."""
    if precision is Precision.FLOAT32:
        n = len(values)
        return (_F32_N[n] if n < 10 else struct.Struct(f">{n}f")).pack(*values)
    if precision is Precision.FLOAT64:
        return struct.pack(f">{len(values)}d", *values)
    return b"".join(_encode_scalar(v, precision) for v in values)


def decode_values(data: bytes, precision: Precision) -> tuple[float, ...]:
    """Inverse of :func:`encode_values`; ``len(data)`` must be a multiple of the scalar size."""
    size = BYTES_PER_SCALAR[precision]
    if len(data) % size:
        raise ValueError(f"{len(data)} bytes is not a whole number of {precision.name} scalars")
    n = len(data) // size
    if precision is Precision.FLOAT32:
        return struct.unpack(f">{n}f", data)
    if precision is Precision.FLOAT64:
        return struct.unpack(f">{n}d", data)
    if precision is Precision.FP1220:
        return tuple(v / (1 << 20) for v in struct.unpack(f">{n}i", data))
    out = []
    for i in range(n):
        frac, whole = _FP1632.unpack_from(data, i * 6)
        out.append((whole * (1 << 32) + frac) / (1 << 32))
    return tuple(out)


def pack_packets(packets: Iterable[tuple[int, bytes]]) -> bytes:
    """MTData2 payload from ``(xdi, data)`` packets (each data at most 255 bytes)."""
    out = bytearray()
    for xdi, data in packets:
        if len(data) > 255:
            raise ValueError(f"MTData2 packet {xdi:#06x} of {len(data)} bytes exceeds 255")
        out += xdi.to_bytes(2, "big")
        out.append(len(data))
        out += data
    return bytes(out)


def unpack_packets(payload: bytes) -> list[tuple[int, bytes]]:
    """Split an MTData2 payload into ``(xdi, data)``; raise ValueError if truncated."""
    packets, i = [], 0
    while i < len(payload):
        if i + 3 > len(payload):
            raise ValueError(f"truncated MTData2 packet header at offset {i}")
        xdi, size = int.from_bytes(payload[i : i + 2], "big"), payload[i + 2]
        if i + 3 + size > len(payload):
            raise ValueError(f"MTData2 packet {xdi:#06x} claims {size} bytes past the payload end")
        packets.append((xdi, bytes(payload[i + 3 : i + 3 + size])))
        i += 3 + size
    return packets
