"""XBee API frame codec (802.15.4 firmware): ``7E len_hi len_lo frame-data checksum``.

checksum = 0xFF - (sum of frame-data bytes & 0xFF). In escaped mode (AP=2) every 0x7E,
0x7D, 0x11, 0x13 after the start delimiter is sent as ``7D, byte ^ 0x20``; length and
checksum are computed on the unescaped data. Multi-byte fields are big-endian.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum, IntEnum, auto, unique


@unique
class FrameType(IntEnum):
    """802.15.4 API identifiers."""

    TX_REQUEST_64 = 0x00
    TX_REQUEST_16 = 0x01
    AT_COMMAND = 0x08
    AT_COMMAND_QUEUE = 0x09
    REMOTE_AT_COMMAND = 0x17
    RX_64 = 0x80
    RX_16 = 0x81
    AT_RESPONSE = 0x88
    TX_STATUS = 0x89
    MODEM_STATUS = 0x8A
    REMOTE_AT_RESPONSE = 0x97


@unique
class Special(IntEnum):
    """Bytes with a meaning on the wire."""

    START = 0x7E
    ESCAPE = 0x7D
    XON = 0x11
    XOFF = 0x13


ESCAPED = frozenset((Special.START, Special.ESCAPE, Special.XON, Special.XOFF))


@unique
class TxStatus(IntEnum):
    """Delivery status in a 0x89 frame."""

    SUCCESS = 0
    NO_ACK = 1
    CCA_FAILURE = 2
    PURGED = 3


@unique
class AtStatus(IntEnum):
    """Status in a 0x88 frame."""

    OK = 0
    ERROR = 1
    INVALID_COMMAND = 2
    INVALID_PARAMETER = 3
    REMOTE_FAILED = 4  # remote AT only: the request did not reach the remote module


@unique
class ModemStatus(IntEnum):
    """Status in a 0x8A frame."""

    HARDWARE_RESET = 0
    WATCHDOG_RESET = 1
    ASSOCIATED = 2
    DISASSOCIATED = 3


@unique
class TxOption(IntEnum):
    """Bits of the TX request options byte."""

    DISABLE_ACK = 0x01
    BROADCAST_PAN = 0x04


@unique
class RxOption(IntEnum):
    """Bits of the RX options byte."""

    ADDRESS_BROADCAST = 0x02
    PAN_BROADCAST = 0x04


BROADCAST_16 = 0xFFFF
BROADCAST_64 = 0x000000000000FFFF


def checksum(frame_data: bytes) -> int:
    """0xFF minus the low byte of the sum of the frame data."""
    return 0xFF - (sum(frame_data) & 0xFF)


def escape(data: bytes) -> bytes:
    """Escape every special byte of ``data`` (everything after the start delimiter)."""
    out = bytearray()
    for b in data:
        if b in ESCAPED:
            out += bytes((Special.ESCAPE, b ^ 0x20))
        else:
            out.append(b)
    return bytes(out)


def encode_frame(frame_data: bytes, escaped: bool = False) -> bytes:
    """A complete API frame around ``frame_data`` (type byte first)."""
    if not 0 < len(frame_data) <= 0xFFFF:
        raise ValueError("frame data must be 1..65535 bytes")
    body = len(frame_data).to_bytes(2, "big") + frame_data + bytes((checksum(frame_data),))
    return bytes((Special.START,)) + (escape(body) if escaped else body)


class _P(Enum):
    START = auto()
    LEN_HI = auto()
    LEN_LO = auto()
    DATA = auto()
    CHECKSUM = auto()


@dataclass
class ParserCounters:
    """What the parser saw."""

    frames: int = 0
    bad_checksum: int = 0
    bad_length: int = 0
    skipped_bytes: int = 0
    restarts: int = 0  # an unescaped 0x7E cut a frame short (escaped mode)


class ApiParser:
    """Streaming API frame parser; ``feed`` returns the frame data of complete good frames.

    Unescaped mode is length-driven (0x7E inside a frame is data). In escaped mode a raw
    0x7E always starts a new frame. Frames with a bad checksum are dropped (the module
    does not answer them); lengths of 0 or above ``max_length`` resynchronise.
    """

    def __init__(self, escaped: bool = False, max_length: int = 256, *, fast_path: bool = True) -> None:
        self.escaped = escaped
        self.max_length = max_length
        #: a frame's data bytes taken as slices (same frames and counters as byte by byte,
        #: which ``fast_path=False`` keeps as the reference)
        self.fast_path = fast_path
        self.counters = ParserCounters()
        self._state = _P.START
        self._esc_next = False
        self._len = 0
        self._data = bytearray()

    def feed(self, data: bytes) -> list[bytes]:
        """Consume ``data``; return the frame data (type first) of each good frame."""
        frames: list[bytes] = []
        i, n = 0, len(data)
        while i < n:
            if self.fast_path and self._state is _P.DATA and not self._esc_next:
                chunk = data[i : i + self._len - len(self._data)]
                if self.escaped:  # up to the first byte that is not plain data
                    for special in (Special.START, Special.ESCAPE):
                        cut = chunk.find(special)
                        if cut >= 0:
                            chunk = chunk[:cut]
                if chunk:
                    i += len(chunk)
                    self._data += chunk
                    if len(self._data) == self._len:
                        self._state = _P.CHECKSUM
                    continue
            raw = data[i]
            i += 1
            if self._state is _P.START:
                if raw == Special.START:
                    self._begin()
                else:
                    self.counters.skipped_bytes += 1
                continue
            if self.escaped:
                if raw == Special.START:
                    self.counters.restarts += 1
                    self._begin()
                    continue
                if self._esc_next:
                    raw ^= 0x20
                    self._esc_next = False
                elif raw == Special.ESCAPE:
                    self._esc_next = True
                    continue
            frame = self._byte(raw)
            if frame is not None:
                frames.append(frame)
        return frames

    def _begin(self) -> None:
        self._state = _P.LEN_HI
        self._esc_next = False
        self._data.clear()

    def _byte(self, b: int) -> bytes | None:
        if self._state is _P.LEN_HI:
            self._len = b << 8
            self._state = _P.LEN_LO
        elif self._state is _P.LEN_LO:
            self._len |= b
            if not 0 < self._len <= self.max_length:
                self.counters.bad_length += 1
                self._state = _P.START
            else:
                self._state = _P.DATA
        elif self._state is _P.DATA:
            self._data.append(b)
            if len(self._data) == self._len:
                self._state = _P.CHECKSUM
        elif self._state is _P.CHECKSUM:
            self._state = _P.START
            if b != checksum(bytes(self._data)):
                self.counters.bad_checksum += 1
                return None
            self.counters.frames += 1
            return bytes(self._data)
        return None


# -- frame-data builders (type byte first) ---------------------------------------------------
def tx16(frame_id: int, dest16: int, data: bytes, options: int = 0) -> bytes:
    """TX request, 16-bit destination."""
    return bytes((FrameType.TX_REQUEST_16, frame_id)) + dest16.to_bytes(2, "big") + bytes((options,)) + data


def tx64(frame_id: int, dest64: int, data: bytes, options: int = 0) -> bytes:
    """TX request, 64-bit destination."""
    return bytes((FrameType.TX_REQUEST_64, frame_id)) + dest64.to_bytes(8, "big") + bytes((options,)) + data


def rx16(src16: int, rssi_dbm: float, data: bytes, options: int = 0) -> bytes:
    """RX packet, 16-bit source; RSSI byte is -dBm."""
    return bytes((FrameType.RX_16,)) + src16.to_bytes(2, "big") + bytes((_rssi(rssi_dbm), options)) + data


def rx64(src64: int, rssi_dbm: float, data: bytes, options: int = 0) -> bytes:
    """RX packet, 64-bit source."""
    return bytes((FrameType.RX_64,)) + src64.to_bytes(8, "big") + bytes((_rssi(rssi_dbm), options)) + data


def at_command(frame_id: int, command: str, parameter: bytes = b"", queue: bool = False) -> bytes:
    """AT command (0x08) or AT command queue (0x09)."""
    kind = FrameType.AT_COMMAND_QUEUE if queue else FrameType.AT_COMMAND
    return bytes((kind, frame_id)) + command.encode("ascii") + parameter


def at_response(frame_id: int, command: bytes, status: int, value: bytes = b"") -> bytes:
    """AT command response (0x88)."""
    return bytes((FrameType.AT_RESPONSE, frame_id)) + command + bytes((status,)) + value


def remote_at_command(frame_id: int, dest64: int, dest16: int, command: str, parameter: bytes = b"",
                      options: int = 0x02) -> bytes:
    """Remote AT command request (0x17); options bit1 = apply changes."""
    return (bytes((FrameType.REMOTE_AT_COMMAND, frame_id)) + dest64.to_bytes(8, "big") + dest16.to_bytes(2, "big")
            + bytes((options,)) + command.encode("ascii") + parameter)


def remote_at_response(frame_id: int, src64: int, src16: int, command: bytes, status: int,
                       value: bytes = b"") -> bytes:
    """Remote AT command response (0x97)."""
    return (bytes((FrameType.REMOTE_AT_RESPONSE, frame_id)) + src64.to_bytes(8, "big") + src16.to_bytes(2, "big")
            + command + bytes((status,)) + value)


def tx_status(frame_id: int, status: int) -> bytes:
    """TX status (0x89)."""
    return bytes((FrameType.TX_STATUS, frame_id, status))


def modem_status(status: int) -> bytes:
    """Modem status (0x8A)."""
    return bytes((FrameType.MODEM_STATUS, status))


def _rssi(rssi_dbm: float) -> int:
    return min(0xFF, max(0, int(round(-rssi_dbm))))
