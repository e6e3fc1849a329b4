"""Xbus framing (XSENS MTi): frame encoder and a resynchronising stream parser.

Sans-I/O: bytes in, messages out; no port, no clock. Wire facts (docs/protocols.md 1.2;
MT0101P/MT0605P, xspublic ``xbus.h``): frame ``FA FF MID LEN [LENEXT_H LENEXT_L] DATA CS``;
LEN 0xFF marks a 16-bit extended length; every byte after 0xFA (including the extended
length) plus CS sums to 0 mod 256; multi-byte fields are big-endian. The measurement
payloads are decoded by :mod:`flightcode.drivers.mtdata`.

The parser never raises on peer garbage: it skips to the next ``FA FF``, drops frames whose
checksum fails (the device does the same) and counts both in ``counters``.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from enum import IntEnum, unique

PREAMBLE = 0xFA
BID_MASTER = 0xFF
EXTENDED_LEN = 0xFF
#: Largest payload xspublic accepts in an extended-length frame.
MAX_EXTENDED_PAYLOAD = 8185


@unique
class Mid(IntEnum):
    """Message identifiers used by the flight code (acks are MID + 1)."""

    REQ_DID = 0x00
    DEVICE_ID = 0x01
    SET_PERIOD = 0x04
    SET_PERIOD_ACK = 0x05
    GOTO_MEASUREMENT = 0x10
    GOTO_MEASUREMENT_ACK = 0x11
    REQ_FW_REV = 0x12
    FIRMWARE_REV = 0x13
    REQ_PRODUCT_CODE = 0x1C
    PRODUCT_CODE = 0x1D
    GOTO_CONFIG = 0x30
    GOTO_CONFIG_ACK = 0x31
    MT_DATA = 0x32
    MT_DATA2 = 0x36
    WAKE_UP = 0x3E
    ERROR = 0x42
    SET_OUTPUT_CONFIGURATION = 0xC0
    SET_OUTPUT_CONFIGURATION_ACK = 0xC1
    SET_OUTPUT_MODE = 0xD0
    SET_OUTPUT_MODE_ACK = 0xD1
    SET_OUTPUT_SETTINGS = 0xD2
    SET_OUTPUT_SETTINGS_ACK = 0xD3

def encode_frame(mid: int, payload: bytes = b"") -> bytes:
    """One Xbus frame to the master BID; extended length is used above 254 payload bytes."""
    n = len(payload)
    if n < EXTENDED_LEN:
        head = bytes((BID_MASTER, mid, n))
    elif n <= MAX_EXTENDED_PAYLOAD:
        head = bytes((BID_MASTER, mid, EXTENDED_LEN, n >> 8, n & 0xFF))
    else:
        raise ValueError(f"Xbus payload of {n} bytes exceeds {MAX_EXTENDED_PAYLOAD}")
    body = head + payload
    return bytes((PREAMBLE,)) + body + bytes(((-sum(body)) & 0xFF,))


@dataclass(frozen=True)
class XbusMessage:
    """One checked frame: message id and payload."""

    mid: int
    payload: bytes


class XbusParser:
    """Streaming frame parser: feed any fragments, get whole checked messages.

    ``max_payload`` bounds the length field accepted (a corrupted header claiming a huge
    length would otherwise stall the stream); the driver lowers it to the configured
    sample size in measurement state. Counters: ``frames``, ``garbage_bytes``,
    ``checksum_errors``, ``bad_length``.
    """

    def __init__(self, max_payload: int = MAX_EXTENDED_PAYLOAD) -> None:
        self.max_payload = max_payload
        self.counters: Counter[str] = Counter()
        self._buf = bytearray()

    def bytes_needed(self, default: int) -> int:
        """Bytes still missing from the frame in progress, or ``default`` if none is started."""
        buf = self._buf
        if len(buf) < 4:
            return default - len(buf) if len(buf) else default
        n = buf[3]
        if n == EXTENDED_LEN:
            if len(buf) < 6:
                return 6 - len(buf)
            total = 7 + ((buf[4] << 8) | buf[5])
        else:
            total = 5 + n
        return max(1, total - len(buf))

    def _frame_at(self, i: int) -> tuple[int, int] | int:
        """Frame starting at ``buf[i]``: (header length, total length) if complete and valid,
        0 if more bytes are needed, -1 if it cannot be a frame (bad length or checksum)."""
        buf = self._buf
        avail = len(buf) - i
        if avail < 4:
            return 0
        n = buf[i + 3]
        head = 4
        if n == EXTENDED_LEN:
            if avail < 6:
                return 0
            n = (buf[i + 4] << 8) | buf[i + 5]
            head = 6
        if n > self.max_payload:
            return -1
        total = head + n + 1
        if avail < total:
            return 0
        if sum(memoryview(buf)[i + 1 : i + total]) & 0xFF:
            return -2
        return head, total

    def feed(self, data: bytes) -> list[XbusMessage]:
        """Add received bytes; return every complete, checksum-valid message in order.

        A header that claims more bytes than have arrived is not trusted blindly: if a
        complete, valid frame already sits behind it, the header was garbage and is skipped
        (otherwise a stray ``FA FF`` with a long length would swallow the stream).
        """
        buf = self._buf
        buf += data
        out: list[XbusMessage] = []
        start = 0
        while True:
            start = buf.find(b"\xfa\xff", start)
            if start < 0:
                # Keep a trailing 0xFA: it may be the first half of the next preamble.
                keep = 1 if buf and buf[-1] == PREAMBLE else 0
                self.counters["garbage_bytes"] += len(buf) - keep
                del buf[: len(buf) - keep]
                break
            if start:
                self.counters["garbage_bytes"] += start
                del buf[:start]
                start = 0
            found = self._frame_at(0)
            if found == 0:
                later = self._later_frame()
                if later is None:
                    break
                self.counters["garbage_bytes"] += later
                del buf[:later]
                continue
            if isinstance(found, int):
                self.counters["bad_length" if found == -1 else "checksum_errors"] += 1
                start = 1
                continue
            head, total = found
            out.append(XbusMessage(buf[2], bytes(buf[head : total - 1])))
            self.counters["frames"] += 1
            del buf[:total]
        return out

    def _later_frame(self) -> int | None:
        """Offset of the first complete, valid frame after position 0, if any."""
        buf = self._buf
        j = buf.find(b"\xfa\xff", 1)
        while j > 0:
            if isinstance(self._frame_at(j), tuple):
                return j
            j = buf.find(b"\xfa\xff", j + 1)
        return None
