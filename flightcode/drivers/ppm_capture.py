"""PPM receiver through a 16-bit 1 MHz timer-capture front-end: record parser and PPM decoder.

Capture record (the project's fixed format, one per PPM edge, 6 bytes):

====  =====================================================================
byte  content
====  =====================================================================
0     0xA5 sync
1     sequence number u8 (increments per record, wraps)
2     flags: bit0 pin level after the edge (1 high), bit1 a capture was lost
      before this one (overrun), other bits 0
3-4   timer-capture value u16 little-endian, 1 us per count (wraps at 65536 us)
5     CRC-8 over bytes 1..4: polynomial 0x07, init 0x00, no reflection, no final xor
====  =====================================================================

Decoder rules (docs/protocols.md 5.1; ArduPilot AP_RCProtocol_PPMSum, Betaflight rx_pwm.c): a
channel is the time between consecutive edges of the same direction (separator + gap), so
either pulse polarity works; an interval >= 2700 us is the sync gap that ends a frame; valid
channel pulses lie strictly between 700 and 2300 us; anything else (or a lost edge, an
overrun flag, a sequence gap, a CRC failure) drops the frame being assembled and waits for
the next sync. A channel count is accepted ("locked") after ``lock_frames`` consecutive
frames of the same count (Betaflight: 25); frames with another count are dropped and counted
until a new count has been stable that long.

Loss is judged by the loop on sensor time (no frame for ``failsafe.rc_loss_s``); records that
arrive after more than ``stale_ms`` of silence also restart the decoder, since a 16-bit
capture difference across a long silence is aliased.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Literal

from flightcode.drivers.base import SerialLike, read_waiting

SYNC = 0xA5
RECORD_LEN = 6
FLAG_LEVEL = 0x01
FLAG_OVERRUN = 0x02


def _crc8_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table.append(crc)
    return tuple(table)


_CRC8 = _crc8_table()


def crc8(data: bytes) -> int:
    """CRC-8, poly 0x07, init 0, no reflection, no xor-out ("CRC-8/SMBUS"; check("123456789") = 0xF4)."""
    crc = 0
    for b in data:
        crc = _CRC8[crc ^ b]
    return crc


@dataclass(frozen=True)
class CaptureRecord:
    """One edge: sequence number, level after the edge (0/1), overrun flag, capture time (us, u16)."""

    seq: int
    level: int
    overrun: bool
    t_us: int


def encode_record(seq: int, level: int, overrun: bool, t_us: int) -> bytes:
    """The 6 wire bytes of a record (what the front-end sends; used by tests)."""
    body = bytes((seq & 0xFF, (level & 1) | (FLAG_OVERRUN if overrun else 0), t_us & 0xFF, (t_us >> 8) & 0xFF))
    return bytes((SYNC,)) + body + bytes((crc8(body),))


class CaptureParser:
    """Streaming record parser: resyncs on 0xA5 with a valid CRC; counts what it drops."""

    def __init__(self) -> None:
        self.counters: Counter[str] = Counter()
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[CaptureRecord]:
        buf = self._buf
        buf += data
        out: list[CaptureRecord] = []
        i = 0
        n = len(buf)
        while n - i >= RECORD_LEN:
            if buf[i] != SYNC:
                self.counters["garbage_bytes"] += 1
                i += 1
                continue
            flags = buf[i + 2]
            if _crc8_of(buf, i + 1) != buf[i + 5]:
                self.counters["crc_errors"] += 1
                i += 1
                continue
            if flags & 0xFC:  # reserved bits set: not a record after all
                self.counters["bad_flags"] += 1
                i += 1
                continue
            out.append(CaptureRecord(buf[i + 1], flags & FLAG_LEVEL, bool(flags & FLAG_OVERRUN),
                                     buf[i + 3] | (buf[i + 4] << 8)))
            i += RECORD_LEN
        del buf[:i]
        return out


def _crc8_of(buf: bytearray, start: int) -> int:
    table = _CRC8
    crc = table[buf[start]]
    crc = table[crc ^ buf[start + 1]]
    crc = table[crc ^ buf[start + 2]]
    return table[crc ^ buf[start + 3]]


@dataclass(frozen=True)
class PpmParams:
    """``[rc.capture]``: PPM decoding rules.

    Fields:
        sync_min_us: an interval at least this long is the frame sync, us.
        pulse_min_us, pulse_max_us: a channel interval must lie strictly between these, us.
        min_channels, max_channels: accepted frame sizes.
        lock_frames: consecutive frames of one channel count before that count is accepted.
        edge: which edges time the channels ("falling" or "rising"; both work for either
            polarity, see the module docstring).
        stale_ms: silence after which the decoder restarts (< 65.5 ms timer wrap), ms.
    """

    __pydantic_config__ = {"extra": "forbid"}

    sync_min_us: int = 2700
    pulse_min_us: int = 700
    pulse_max_us: int = 2300
    min_channels: int = 5
    max_channels: int = 16
    lock_frames: int = 25
    edge: Literal["falling", "rising"] = "falling"
    stale_ms: float = 50.0


class PpmDecoder:
    """Edges -> locked PPM frames (tuples of channel widths in us)."""

    def __init__(self, params: PpmParams) -> None:
        self.params = params
        self.counters: Counter[str] = Counter()
        self._level = 1 if params.edge == "rising" else 0
        self._last_level: int | None = None
        self._last_t: int | None = None
        self._last_seq: int | None = None
        self._synced = False
        self._channels: list[int] = []
        self._candidate = 0
        self._stable = 0
        #: The accepted channel count (None until locked).
        self.locked_channels: int | None = None

    def desync(self) -> None:
        """Forget the frame being assembled and the edge history (not the lock)."""
        self._synced = False
        self._channels = []
        self._last_t = None
        self._last_level = None
        self._last_seq = None

    def record(self, rec: CaptureRecord) -> tuple[int, ...] | None:
        """Process one edge; returns a frame when a frame with the locked count completes."""
        if self._last_seq is not None and rec.seq != (self._last_seq + 1) & 0xFF:
            self.counters["sequence_gaps"] += 1
            self.desync()
        if rec.overrun:
            self.counters["overruns"] += 1
            self.desync()
        if self._last_level is not None and rec.level == self._last_level:
            self.counters["missing_edges"] += 1
            self.desync()
        self._last_seq = rec.seq
        self._last_level = rec.level
        if rec.level != self._level:
            return None
        if self._last_t is None:
            self._last_t = rec.t_us
            return None
        width = (rec.t_us - self._last_t) & 0xFFFF
        self._last_t = rec.t_us
        p = self.params
        if width >= p.sync_min_us:
            frame = self._channels if self._synced else None
            self._synced = True
            self._channels = []
            if frame is not None:
                return self._complete(frame)
            return None
        if p.pulse_min_us < width < p.pulse_max_us:
            if self._synced:
                self._channels.append(width)
                if len(self._channels) > p.max_channels:
                    self.counters["too_many_channels"] += 1
                    self._synced = False
            return None
        self.counters["bad_pulses"] += 1
        self._synced = False
        self._channels = []
        return None

    def _complete(self, channels: list[int]) -> tuple[int, ...] | None:
        n = len(channels)
        if n < self.params.min_channels:
            self.counters["short_frames"] += 1
            return None
        if n == self._candidate:
            self._stable += 1
        else:
            self._candidate, self._stable = n, 1
        if n != self.locked_channels:
            if self._stable >= self.params.lock_frames:
                self.locked_channels = n
                self.counters["locks"] += 1
            else:
                self.counters["unlocked_frames"] += 1
                return None
        self.counters["frames"] += 1
        return tuple(channels)


@dataclass(frozen=True)
class RcFrame:
    """A decoded RC frame: sensor time of the tick that completed it, channel pulses in us."""

    t_ns: int
    channels_us: tuple[float, ...]


class CaptureRcInput:
    """The capture front-end on ``port`` (opened with read timeout 0: never blocks)."""

    name = "rc"

    def __init__(self, port: SerialLike, params: PpmParams) -> None:
        self.port = port
        self.parser = CaptureParser()
        self.decoder = PpmDecoder(params)
        self._stale_ns = int(params.stale_ms * 1e6)
        self._last_rx_ns: int | None = None
        #: The newest good frame (None until the first one).
        self.latest: RcFrame | None = None

    @property
    def counters(self) -> Counter[str]:
        return self.parser.counters + self.decoder.counters

    def poll(self, t_ns: int) -> RcFrame | None:
        """Read whatever arrived (non-blocking) and decode it; returns a new frame if any."""
        data = read_waiting(self.port)
        if not data:
            return None
        if self._last_rx_ns is not None and t_ns - self._last_rx_ns > self._stale_ns:
            self.decoder.desync()
            self.decoder.counters["stale_restarts"] += 1
        self._last_rx_ns = t_ns
        new = None
        for rec in self.parser.feed(data):
            frame = self.decoder.record(rec)
            if frame is not None:
                new = RcFrame(t_ns, tuple(float(w) for w in frame))
        if new is not None:
            self.latest = new
        return new
