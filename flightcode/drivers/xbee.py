"""XBee-PRO (802.15.4) telemetry downlink in API mode: TX16 frames out, incoming frames parsed.

API frame (Digi 802.15.4 manual; docs/protocols.md 8.2)::

    7E  len_hi len_lo  frame_data...  checksum       checksum = 0xFF - (sum(frame_data) & 0xFF)

TX request, 16-bit address (frame type 0x01): ``01 frame_id dest_hi dest_lo options payload``
(payload <= 100 bytes; options 0x01 = disable ACK). With ``AP=2`` every byte after the start
delimiter that is 0x7E, 0x7D, 0x11 or 0x13 is sent as ``7D, byte ^ 0x20``; length and
checksum are computed on the unescaped data.

The link never blocks the loop: before each write it checks ``out_waiting`` and drops the
frame (counted) if the previous ones have not left yet; the port has ``write_timeout=0``.
Bytes from the modem (TX status 0x89 when frame ids are used, modem status, anything else)
are read without blocking and parsed, so they never pile up in the input buffer.
"""

from __future__ import annotations

from collections import Counter
from enum import IntEnum, unique

from flightcode.drivers.base import SerialLike, read_waiting

START = 0x7E
ESCAPE = 0x7D
XOR = 0x20
NEEDS_ESCAPE = frozenset((0x7E, 0x7D, 0x11, 0x13))
MAX_RF_PAYLOAD = 100
#: Longest frame data accepted from the modem (RX64 with 100 bytes is 111; AT replies are short).
MAX_FRAME_DATA = 256


@unique
class ApiFrameType(IntEnum):
    """802.15.4 API identifiers the driver builds or recognises."""

    TX64 = 0x00
    TX16 = 0x01
    AT_COMMAND = 0x08
    RX64 = 0x80
    RX16 = 0x81
    AT_RESPONSE = 0x88
    TX_STATUS = 0x89
    MODEM_STATUS = 0x8A


@unique
class TxOption(IntEnum):
    """TX request option bits."""

    DISABLE_ACK = 0x01
    BROADCAST_PAN = 0x04


def tx16(frame_id: int, dest16: int, payload: bytes, options: int = 0) -> bytes:
    """Frame data of a TX16 request (without delimiter, length and checksum)."""
    if len(payload) > MAX_RF_PAYLOAD:
        raise ValueError(f"XBee 802.15.4 payload of {len(payload)} bytes (max {MAX_RF_PAYLOAD})")
    return bytes((ApiFrameType.TX16, frame_id & 0xFF, (dest16 >> 8) & 0xFF, dest16 & 0xFF, options)) + payload


def escape(data: bytes) -> bytes:
    """AP=2 escaping of the bytes after the start delimiter."""
    out = bytearray()
    for b in data:
        if b in NEEDS_ESCAPE:
            out += bytes((ESCAPE, b ^ XOR))
        else:
            out.append(b)
    return bytes(out)


def api_frame(frame_data: bytes, escaped: bool) -> bytes:
    """A complete API frame for ``frame_data`` (AP=1, or AP=2 when ``escaped``)."""
    n = len(frame_data)
    body = bytes((n >> 8, n & 0xFF)) + frame_data + bytes((0xFF - (sum(frame_data) & 0xFF),))
    return bytes((START,)) + (escape(body) if escaped else body)


class XbeeApiParser:
    """Streaming API-frame parser (AP=1 or AP=2); yields checked frame data."""

    def __init__(self, escaped: bool) -> None:
        self.escaped = escaped
        self.counters: Counter[str] = Counter()
        self._raw = bytearray()

    def _unescape(self) -> tuple[bytearray, bool]:
        """Unescaped bytes after the delimiter at raw[0], and whether a new 0x7E cut them short."""
        out = bytearray()
        raw, i, n = self._raw, 1, len(self._raw)
        while i < n:
            b = raw[i]
            if b == START:
                return out, True
            if b == ESCAPE:
                if i + 1 >= n:
                    break  # the escaped byte has not arrived yet
                out.append(raw[i + 1] ^ XOR)
                i += 2
            else:
                out.append(b)
                i += 1
        return out, False

    def feed(self, data: bytes) -> list[bytes]:
        raw = self._raw
        raw += data
        frames: list[bytes] = []
        while raw:
            start = raw.find(bytes((START,)))
            if start < 0:
                self.counters["garbage_bytes"] += len(raw)
                raw.clear()
                break
            if start:
                self.counters["garbage_bytes"] += start
                del raw[:start]
            body, interrupted = self._unescape() if self.escaped else (raw[1:], False)
            n = (body[0] << 8) | body[1] if len(body) >= 2 else MAX_RF_PAYLOAD
            if n > MAX_FRAME_DATA:  # no 802.15.4 frame is this long: a corrupted header
                self.counters["bad_length"] += 1
                del raw[:1]
                continue
            if len(body) < n + 3:
                if interrupted:  # a new 7E started before this frame was complete
                    self.counters["truncated_frames"] += 1
                    del raw[:1]
                    continue
                break
            frame = bytes(body[2 : 2 + n])
            if (sum(frame) + body[2 + n]) & 0xFF != 0xFF:
                self.counters["checksum_errors"] += 1
                del raw[:1]
                continue
            frames.append(frame)
            self.counters["frames"] += 1
            del raw[: self._raw_length(n + 3)]
        return frames

    def _raw_length(self, unescaped_len: int) -> int:
        """Raw bytes (delimiter included) that hold the first ``unescaped_len`` bytes of the body."""
        if not self.escaped:
            return 1 + unescaped_len
        raw, i, count = self._raw, 1, 0
        while count < unescaped_len:
            i += 2 if raw[i] == ESCAPE else 1
            count += 1
        return i


class XbeeTelemetryLink:
    """TX16 frames to ``dest16`` through the XBee on ``port`` (write_timeout=0, timeout=0).

    Args:
        escaped: True for AP=2, False for AP=1.
        dest16: 16-bit address of the ground station (0xFFFF broadcast).
        request_status: True: frame ids 1..255 in turn, so the modem answers a TX status per
            frame (counted by status); False: frame id 0, no status traffic.
        max_out_waiting: drop a frame when more than this many bytes are still unsent.
    """

    name = "telemetry"

    def __init__(self, port: SerialLike, *, escaped: bool, dest16: int, request_status: bool,
                 max_out_waiting: int) -> None:
        self.port = port
        self.escaped = escaped
        self.dest16 = dest16
        self.request_status = request_status
        self.max_out_waiting = max_out_waiting
        self.parser = XbeeApiParser(escaped)
        self.counters: Counter[str] = Counter()
        self._frame_id = 0

    def send(self, payload: bytes) -> bool:
        """Queue one TX16 frame if the link has room; False (counted) if it was dropped."""
        self.drain()
        if self.port.out_waiting > self.max_out_waiting:
            self.counters["dropped_busy"] += 1
            return False
        if self.request_status:
            self._frame_id = self._frame_id % 255 + 1
        frame = api_frame(tx16(self._frame_id, self.dest16, payload), self.escaped)
        written = self.port.write(frame)
        if written is not None and written < len(frame):
            self.counters["short_writes"] += 1
            return False
        self.counters["sent"] += 1
        return True

    def drain(self) -> None:
        """Read and parse whatever the modem sent (non-blocking)."""
        data = read_waiting(self.port)
        if not data:
            return
        for frame in self.parser.feed(data):
            if frame[0] == ApiFrameType.TX_STATUS and len(frame) >= 3:
                self.counters["tx_ok" if frame[2] == 0 else f"tx_status_{frame[2]}"] += 1
            else:
                self.counters[f"rx_frame_{frame[0]:02x}"] += 1
