"""SBUS receiver (as from a PPM-to-SBUS converter): frame parser and RC input.

Frame (docs/protocols.md 5.2; ArduPilot AP_RCProtocol_SBUS.cpp), line 100000 bit/s 8E2
(inverted on the wire; a pty carries the bytes only):

=====  ===============================================================
byte   content
=====  ===============================================================
0      0x0F header
1-22   16 channels x 11 bits, packed LSB first
23     flags: bit0 digital ch17, bit1 ch18, bit2 frame lost, bit3 failsafe
24     end byte: 0x00 (SBUS1) or 0x04/0x14/0x24/0x34 (SBUS2 slots)
=====  ===============================================================

There is no checksum: a frame is accepted when the header, the end byte and the unused flag
bits fit; otherwise the parser slides one byte and tries again (counted). Scaling is
ArduPilot's ``pulse_us = raw * 0.625 + 875`` (raw 200..1800 -> 1000..2000 us). A frame with
the failsafe bit is dropped (the receiver has lost the link: the loop's RC-loss timer keeps
running); the frame-lost bit alone is only counted, as in ArduPilot.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

from flightcode.drivers.base import SerialLike, read_waiting
from flightcode.drivers.ppm_capture import RcFrame

HEADER = 0x0F
FRAME_LEN = 25
END_BYTES = frozenset((0x00, 0x04, 0x14, 0x24, 0x34))
FLAG_CH17 = 0x01
FLAG_CH18 = 0x02
FLAG_FRAME_LOST = 0x04
FLAG_FAILSAFE = 0x08
N_CHANNELS = 16
#: SBUS line settings (8E2).
BAUD = 100_000


@dataclass(frozen=True)
class SbusParams:
    """``[rc.sbus]``: raw-to-microsecond scaling ``pulse_us = raw * scale_us + offset_us``."""

    __pydantic_config__ = {"extra": "forbid"}

    scale_us: float = 0.625
    offset_us: float = 875.0


@dataclass(frozen=True)
class SbusFrame:
    """One decoded frame: 16 raw 11-bit channel values and the flags byte."""

    raw: tuple[int, ...]
    flags: int


def encode_frame(raw: tuple[int, ...], flags: int = 0, end: int = 0x00) -> bytes:
    """The 25 wire bytes for 16 raw channel values (used by tests)."""
    bits = 0
    for i, value in enumerate(raw):
        bits |= (value & 0x7FF) << (11 * i)
    return bytes((HEADER,)) + bits.to_bytes(22, "little") + bytes((flags, end))


def decode_channels(payload: bytes) -> tuple[int, ...]:
    """16 raw channels from the 22 packed bytes."""
    bits = int.from_bytes(payload, "little")
    return tuple((bits >> (11 * i)) & 0x7FF for i in range(N_CHANNELS))


class SbusParser:
    """Streaming SBUS parser; counts slid bytes (``garbage_bytes``) and frames."""

    def __init__(self) -> None:
        self.counters: Counter[str] = Counter()
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[SbusFrame]:
        buf = self._buf
        buf += data
        out: list[SbusFrame] = []
        i, n = 0, len(buf)
        while n - i >= FRAME_LEN:
            if buf[i] != HEADER or buf[i + 24] not in END_BYTES or buf[i + 23] & 0xF0:
                self.counters["garbage_bytes"] += 1
                i += 1
                continue
            out.append(SbusFrame(decode_channels(bytes(buf[i + 1 : i + 23])), buf[i + 23]))
            self.counters["frames"] += 1
            i += FRAME_LEN
        del buf[:i]
        return out


class SbusRcInput:
    """SBUS on ``port`` (opened 100000 8E2 with read timeout 0: never blocks)."""

    name = "rc"

    def __init__(self, port: SerialLike, params: SbusParams) -> None:
        self.port = port
        self.params = params
        self.parser = SbusParser()
        self.counters: Counter[str] = Counter()
        #: The newest good frame (None until the first one).
        self.latest: RcFrame | None = None

    def poll(self, t_ns: int) -> RcFrame | None:
        """Read whatever arrived (non-blocking) and decode it; returns a new frame if any."""
        data = read_waiting(self.port)
        if not data:
            return None
        new = None
        scale, offset = self.params.scale_us, self.params.offset_us
        for frame in self.parser.feed(data):
            if frame.flags & FLAG_FRAME_LOST:
                self.counters["frame_lost_flags"] += 1
            if frame.flags & FLAG_FAILSAFE:
                self.counters["failsafe_frames"] += 1
                continue
            new = RcFrame(t_ns, tuple(raw * scale + offset for raw in frame.raw))
        if new is not None:
            self.counters["frames"] += 1
            self.latest = new
        return new
