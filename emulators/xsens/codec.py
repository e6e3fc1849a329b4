"""Xbus framing: encode, strict decode, and a resynchronising stream parser.

Frame: ``FA BID MID LEN [LENH LENL] DATA CS``. LEN = 0xFF announces a 16-bit big-endian
extended length. The checksum makes the sum of every byte after the preamble (BID, MID,
LEN, the extended length bytes, DATA and CS) zero modulo 256 (docs/protocols.md §1.2; xspublic
``Xbus_insertChecksum`` includes the extended length bytes).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from emulators.xsens.defs import BID_MASTER, LEN_EXTENDED, MAX_STD_PAYLOAD, PREAMBLE

#: Largest payload the 16-bit extended length can announce.
MAX_EXT_PAYLOAD = 0xFFFF


class FrameError(ValueError):
    """A byte string is not exactly one valid Xbus frame (strict decoding only)."""


@dataclass(frozen=True)
class Frame:
    """One Xbus message. ``payload`` excludes header and checksum."""

    mid: int
    payload: bytes = b""
    bid: int = BID_MASTER


def checksum(body: bytes | bytearray | memoryview) -> int:
    """Checksum byte for ``body`` = every byte after the preamble, checksum excluded."""
    return -sum(body) & 0xFF


def encode_frame(mid: int, payload: bytes = b"", bid: int = BID_MASTER) -> bytes:
    """Bytes of one frame; payloads over 254 bytes use the extended length."""
    n = len(payload)
    if n > MAX_EXT_PAYLOAD:
        raise ValueError(f"payload of {n} bytes exceeds the Xbus maximum of {MAX_EXT_PAYLOAD}")
    if n <= MAX_STD_PAYLOAD:
        body = bytes((bid, mid, n)) + payload
    else:
        body = bytes((bid, mid, LEN_EXTENDED, n >> 8, n & 0xFF)) + payload
    return bytes((PREAMBLE,)) + body + bytes((checksum(body),))


def decode_frame(data: bytes) -> Frame:
    """Decode exactly one frame; raise :class:`FrameError` on any defect."""
    if len(data) < 5 or data[0] != PREAMBLE:
        raise FrameError("missing preamble or too short")
    if data[3] == LEN_EXTENDED:
        if len(data) < 7:
            raise FrameError("truncated extended length")
        n, header = (data[4] << 8) | data[5], 6
    else:
        n, header = data[3], 4
    if len(data) != header + n + 1:
        raise FrameError(f"length field says {n} payload bytes, frame has {len(data) - header - 1}")
    if sum(data[1:]) & 0xFF:
        raise FrameError("bad checksum")
    return Frame(data[2], bytes(data[header : header + n]), data[1])


@dataclass
class ParserStats:
    """What the parser saw; never reset."""

    frames_ok: int = 0
    checksum_errors: int = 0
    resync_bytes: int = 0  #: bytes discarded while looking for a frame
    oversize_frames: int = 0  #: length fields above the receive limit (treated as garbage)
    timeouts: int = 0  #: partial frames discarded after an inter-byte gap


@dataclass
class FrameParser:
    """Streaming Xbus parser that resynchronises after garbage.

    ``feed`` takes bytes in any fragmentation and returns the complete, valid frames. A
    frame with a bad checksum is dropped silently: only its preamble byte is discarded and
    the search restarts at the next byte, so a real frame hidden behind garbage is found.
    Lengths above ``max_payload`` are treated as garbage the same way. If ``timeout_ns``
    is positive, a partial frame older than that when new bytes arrive is discarded.
    """

    max_payload: int = 512
    timeout_ns: int = 0
    stats: ParserStats = field(default_factory=ParserStats)
    _buf: bytearray = field(default_factory=bytearray)
    _last_rx_ns: int | None = None

    def reset(self) -> None:
        """Forget a partial frame (power cycle, line change); counts it as resync bytes."""
        self.stats.resync_bytes += len(self._buf)
        self._buf.clear()

    @property
    def pending(self) -> int:
        """Bytes held while waiting for the rest of a frame."""
        return len(self._buf)

    def feed(self, data: bytes, t_ns: int = 0) -> list[Frame]:
        last = self._last_rx_ns
        if self._buf and self.timeout_ns > 0 and last is not None and t_ns - last > self.timeout_ns:
            self.stats.timeouts += 1
            self.reset()
        self._last_rx_ns = t_ns
        self._buf += data
        return self._extract()

    def _extract(self) -> list[Frame]:
        buf, stats = self._buf, self.stats
        frames: list[Frame] = []
        while True:
            start = buf.find(PREAMBLE)
            if start < 0:
                stats.resync_bytes += len(buf)
                buf.clear()
                return frames
            if start:
                stats.resync_bytes += start
                del buf[:start]
            if len(buf) < 4:
                return frames
            if buf[3] == LEN_EXTENDED:
                if len(buf) < 6:
                    return frames
                n, header = (buf[4] << 8) | buf[5], 6
            else:
                n, header = buf[3], 4
            if n > self.max_payload:
                stats.oversize_frames += 1
                stats.resync_bytes += 1
                del buf[:1]
                continue
            total = header + n + 1
            if len(buf) < total:
                return frames
            if sum(buf[1:total]) & 0xFF:
                stats.checksum_errors += 1
                stats.resync_bytes += 1
                del buf[:1]
                continue
            frames.append(Frame(buf[2], bytes(buf[header : header + n]), buf[1]))
            stats.frames_ok += 1
            del buf[:total]
