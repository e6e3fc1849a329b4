"""Which protocol runs on each port, where its frames start and end, where the checksum is.

Wire faults that act on frames (bad checksum, truncated or duplicated frames) need the
frame boundaries of the byte stream. Device outputs are written in whole frames, so a
chunk is split from its first byte; bytes that do not form a complete frame (garbage, a
frame cut by the end of the chunk) are passed through untouched.

Frame formats (the emulators' codecs and docs):

* Xbus (XSENS): ``FA BID MID LEN [LENH LENL] DATA CS``, LEN = FF announces the 16-bit
  extended length; CS is the last byte (emulators/xsens/codec.py).
* RC capture record: ``A5 seq flags lo hi CRC-8``, 6 bytes (emulators/rc/capture.py).
* SBUS: ``0F`` + 22 channel bytes + flags + end byte, 25 bytes, no checksum.
* XBee API: ``7E LENH LENL DATA CS``; in escaped mode (AP=2) every byte after the
  delimiter may be escaped (``7D``, byte ^ 0x20), the checksum included.
* Pololu Maestro: one command per write; with CRC enabled its last byte is a CRC-7
  (7 bits: bit 7 set would make it a command byte).
* Bus Pirate binary SPI, Maestro replies, XBee transparent mode: no frames, no checksum;
  a chunk (one write) stands for a frame.
"""

from __future__ import annotations

from enum import Enum, unique
from typing import Any

import numpy as np

from emulators.xbee.frames import escape as xbee_escape

#: The ports of a run (the same list as hil/flight/run.py PORTS).
RIG_PORTS: tuple[str, ...] = ("imu", "adc", "rc", "esc", "telemetry", "ground")

XBUS_PREAMBLE = 0xFA
XBUS_LEN_EXTENDED = 0xFF
CAPTURE_SYNC = 0xA5
CAPTURE_LEN = 6
SBUS_HEADER = 0x0F
SBUS_LEN = 25
XBEE_START = 0x7E
XBEE_ESCAPE = 0x7D
XBEE_XOR = 0x20


@unique
class Direction(Enum):
    """Which way bytes travel, named from the bench: tx device -> flight code, rx back."""

    TX = "tx"
    RX = "rx"
    BOTH = "both"

    def covers(self, d: Direction) -> bool:
        return self is Direction.BOTH or self is d


@unique
class Protocol(Enum):
    """A port's byte protocol in one direction."""

    XBUS = "Xbus"
    CAPTURE = "RC capture records"
    SBUS = "SBUS"
    XBEE_API = "XBee API (AP=1)"
    XBEE_API_ESCAPED = "XBee escaped API (AP=2)"
    XBEE_TRANSPARENT = "XBee transparent mode (AP=0)"
    MAESTRO = "Pololu Maestro commands (CRC disabled)"
    MAESTRO_CRC = "Pololu Maestro commands with CRC-7"
    MAESTRO_REPLY = "Pololu Maestro replies"
    BUSPIRATE = "Bus Pirate binary SPI"
    NONE = "nothing (the client sends nothing on this port)"


#: Protocols whose frames carry a checksum the fault can corrupt.
WITH_CHECKSUM = frozenset(
    {Protocol.XBUS, Protocol.CAPTURE, Protocol.XBEE_API, Protocol.XBEE_API_ESCAPED, Protocol.MAESTRO_CRC}
)


def protocol_of(rig: Any, port: str, direction: Direction) -> Protocol:
    """The protocol the rig runs on ``port`` in ``direction`` (TX or RX)."""
    tx = direction is Direction.TX
    if port == "imu":
        return Protocol.XBUS
    if port in ("adc", "adc-spidriver"):
        return Protocol.BUSPIRATE
    if port == "rc":
        if not tx:
            return Protocol.NONE
        return Protocol.CAPTURE if rig.rc.frontend == "capture" else Protocol.SBUS
    if port == "esc":
        if tx:
            return Protocol.MAESTRO_REPLY
        return Protocol.MAESTRO_CRC if rig.esc.maestro.crc_enabled else Protocol.MAESTRO
    if port in ("telemetry", "ground"):
        params = rig.telemetry.vehicle if port == "telemetry" else rig.telemetry.ground
        return {0: Protocol.XBEE_TRANSPARENT, 1: Protocol.XBEE_API, 2: Protocol.XBEE_API_ESCAPED}[params.ap]
    raise KeyError(port)


# -- splitting ----------------------------------------------------------------------------------
Segment = tuple[bytes, bool]  #: (bytes, is a complete frame)


def split(protocol: Protocol, data: bytes) -> list[Segment]:
    """Cut ``data`` into frames and other bytes, in order; unframed protocols: one frame."""
    if protocol is Protocol.XBUS:
        return _scan(data, XBUS_PREAMBLE, _xbus_len)
    if protocol is Protocol.CAPTURE:
        return _scan(data, CAPTURE_SYNC, lambda d, i: CAPTURE_LEN)
    if protocol is Protocol.SBUS:
        return _scan(data, SBUS_HEADER, lambda d, i: SBUS_LEN)
    if protocol is Protocol.XBEE_API:
        return _scan(data, XBEE_START, _xbee_len)
    if protocol is Protocol.XBEE_API_ESCAPED:
        return _scan(data, XBEE_START, _xbee_escaped_len)
    return [(data, True)] if data else []


def _scan(data: bytes, start: int, length: Any) -> list[Segment]:
    """Frames beginning with ``start``; ``length(data, i)`` is the frame's length in bytes,
    or None when the chunk ends before the length is known."""
    out: list[Segment] = []
    i, n = 0, len(data)
    while i < n:
        if data[i] != start:
            j = data.find(bytes((start,)), i + 1)
            j = n if j < 0 else j
            out.append((data[i:j], False))
            i = j
            continue
        size = length(data, i)
        if size is None or i + size > n:
            out.append((data[i:], False))
            break
        out.append((data[i : i + size], True))
        i += size
    return out


def _xbus_len(data: bytes, i: int) -> int | None:
    if i + 4 > len(data):
        return None
    if data[i + 3] == XBUS_LEN_EXTENDED:
        if i + 6 > len(data):
            return None
        return 6 + ((data[i + 4] << 8) | data[i + 5]) + 1
    return 4 + data[i + 3] + 1


def _xbee_len(data: bytes, i: int) -> int | None:
    if i + 3 > len(data):
        return None
    return 3 + ((data[i + 1] << 8) | data[i + 2]) + 1


def _xbee_escaped_len(data: bytes, i: int) -> int | None:
    """Wire length of an escaped frame: walk until 2 + LEN + 1 unescaped bytes are seen."""
    raw = bytearray()
    j, n = i + 1, len(data)
    need: int | None = None
    while j < n:
        b = data[j]
        if b == XBEE_ESCAPE:
            if j + 1 >= n:
                return None
            b = data[j + 1] ^ XBEE_XOR
            j += 1
        raw.append(b)
        j += 1
        if need is None and len(raw) == 2:
            need = 2 + ((raw[0] << 8) | raw[1]) + 1
        if need is not None and len(raw) == need:
            return j - i
    return None


# -- corrupting ---------------------------------------------------------------------------------
def corrupt_checksum(protocol: Protocol, frame: bytes, rng: np.random.Generator) -> bytes:
    """``frame`` with its checksum changed to a wrong value (drawn from ``rng``)."""
    if protocol is Protocol.MAESTRO_CRC:
        return frame[:-1] + bytes((frame[-1] ^ int(rng.integers(1, 0x80)),))
    if protocol is Protocol.XBEE_API_ESCAPED:
        raw = bytearray()
        j = 1
        while j < len(frame):
            b = frame[j]
            if b == XBEE_ESCAPE and j + 1 < len(frame):
                j += 1
                b = frame[j] ^ XBEE_XOR
            raw.append(b)
            j += 1
        raw[-1] ^= int(rng.integers(1, 0x100))
        return bytes((XBEE_START,)) + xbee_escape(bytes(raw))
    return frame[:-1] + bytes((frame[-1] ^ int(rng.integers(1, 0x100)),))


def flip_last_byte(chunk: bytes, rng: np.random.Generator) -> bytes:
    """The generic checksum fault: the chunk's last byte xor a random non-zero value."""
    if not chunk:
        return chunk
    return chunk[:-1] + bytes((chunk[-1] ^ int(rng.integers(1, 0x100)),))
