"""PPM-to-SBUS converter front-end: decodes the receiver's PPM like a converter MCU and
sends SBUS frames at a fixed period.

SBUS frame (ArduPilot ``AP_RCProtocol_SBUS.cpp``, docs/protocols.md 5.2)::

    0F | 22 bytes: 16 channels x 11 bits, LSB first | flags | end (00 for SBUS1)
    flags: bit0 ch17, bit1 ch18, bit2 frame lost, bit3 failsafe

Scaling (ArduPilot): pwm_us = raw * 0.625 + 875, so raw = (pwm_us - 875) / 0.625.
On a pty parity and inversion do not exist; only byte content and frame timing matter.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from enum import IntEnum, IntFlag, unique

from emulators.base import DeviceEvent
from emulators.rc.oneway import OneWayDevice
from emulators.rc.params import SbusParams
from emulators.rc.ppm import PpmEdge

NS_PER_US = 1_000


@unique
class SbusWire(IntEnum):
    """Wire constants of an SBUS frame."""

    HEADER = 0x0F
    FRAME_LEN = 25
    N_CHANNELS = 16
    CHANNEL_BITS = 11
    RAW_MAX = 0x7FF


@unique
class SbusFlag(IntFlag):
    """Bits of the flags byte (byte 23)."""

    CH17 = 0x01
    CH18 = 0x02
    FRAME_LOST = 0x04
    FAILSAFE = 0x08


@dataclass(frozen=True)
class SbusFrame:
    """A decoded SBUS frame: 16 raw 11-bit channels and the flags."""

    channels_raw: tuple[int, ...]
    ch17: bool = False
    ch18: bool = False
    frame_lost: bool = False
    failsafe: bool = False
    end_byte: int = 0x00


def pwm_to_raw(pulse_us: float) -> int:
    """ArduPilot's inverse scaling, rounded and clamped to 11 bits."""
    return min(SbusWire.RAW_MAX, max(0, int(round((pulse_us - 875.0) / 0.625))))


def raw_to_pwm(raw: int) -> float:
    """ArduPilot's scaling: raw 11-bit value -> pulse width in us."""
    return raw * 0.625 + 875.0


def pack_sbus(frame: SbusFrame) -> bytes:
    """The 25 wire bytes of ``frame``."""
    if len(frame.channels_raw) != SbusWire.N_CHANNELS:
        raise ValueError("SBUS carries 16 channels")
    bits = 0
    for i, raw in enumerate(frame.channels_raw):
        if not 0 <= raw <= SbusWire.RAW_MAX:
            raise ValueError(f"channel {i + 1} raw value {raw} out of 11 bits")
        bits |= raw << (SbusWire.CHANNEL_BITS * i)
    flags = ((SbusFlag.CH17 if frame.ch17 else 0) | (SbusFlag.CH18 if frame.ch18 else 0)
             | (SbusFlag.FRAME_LOST if frame.frame_lost else 0) | (SbusFlag.FAILSAFE if frame.failsafe else 0))
    return bytes((SbusWire.HEADER,)) + bits.to_bytes(22, "little") + bytes((int(flags), frame.end_byte))


def unpack_sbus(data: bytes) -> SbusFrame | None:
    """Decode 25 bytes; None if the length or header is wrong."""
    if len(data) != SbusWire.FRAME_LEN or data[0] != SbusWire.HEADER:
        return None
    bits = int.from_bytes(data[1:23], "little")
    channels = tuple((bits >> (SbusWire.CHANNEL_BITS * i)) & SbusWire.RAW_MAX for i in range(SbusWire.N_CHANNELS))
    flags = data[23]
    return SbusFrame(channels, bool(flags & SbusFlag.CH17), bool(flags & SbusFlag.CH18),
                     bool(flags & SbusFlag.FRAME_LOST), bool(flags & SbusFlag.FAILSAFE), data[24])


@dataclass(frozen=True, init=False)
class PpmDecoded(DeviceEvent):
    """The converter decoded a PPM frame ending at ``t_ns`` with these widths (us)."""

    pulses_us: tuple[int, ...]

    def __init__(self, t_ns: int, pulses_us: tuple[int, ...]) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "pulses_us", pulses_us)


class PpmDecoder:
    """ArduPilot-style PPM-sum decoder (``AP_RCProtocol_PPMSum``), polarity independent.

    Consecutive half-periods are summed in pairs; a pair >= ``sync_min_us`` ends a frame,
    which is accepted with >= ``min_channels`` channels; a pair outside
    (``min_us``, ``max_us``) loses sync until the next sync gap.
    """

    MAX_CHANNELS = 16

    def __init__(self, sync_min_us: int, min_us: int, max_us: int, min_channels: int) -> None:
        self.sync_min_ns = sync_min_us * NS_PER_US
        self.min_ns = min_us * NS_PER_US
        self.max_ns = max_us * NS_PER_US
        self.min_channels = min_channels
        self._last_edge_ns: int | None = None
        self._half_ns: int | None = None
        self._channels: list[int] | None = None  # None = not synchronised
        self.frames_ok = 0
        self.frames_bad = 0

    def edge(self, t_ns: int) -> tuple[int, ...] | None:
        """Feed one edge; returns the channel widths (us) when it completes a good frame."""
        if self._last_edge_ns is None:
            self._last_edge_ns = t_ns
            return None
        width = t_ns - self._last_edge_ns
        self._last_edge_ns = t_ns
        if self._half_ns is None:
            self._half_ns = width
            return None
        pulse = self._half_ns + width
        self._half_ns = None
        if pulse >= self.sync_min_ns:
            done = self._channels
            self._channels = []
            if done is not None and len(done) >= self.min_channels:
                self.frames_ok += 1
                return tuple((w + NS_PER_US // 2) // NS_PER_US for w in done)
            if done:
                self.frames_bad += 1
            return None
        if self._channels is not None and self.min_ns < pulse < self.max_ns:
            self._channels.append(pulse)
            if len(self._channels) >= self.MAX_CHANNELS:
                self.frames_ok += 1
                done, self._channels = self._channels, None
                return tuple((w + NS_PER_US // 2) // NS_PER_US for w in done)
            return None
        if self._channels:
            self.frames_bad += 1
        self._channels = None
        return None


class SbusConverter(OneWayDevice):
    """A PPM-to-SBUS converter on the ``rc`` port.

    The bench feeds PPM edges (:meth:`feed_edges`) and calls :meth:`advance`; a frame is
    sent every ``frame_period_us`` carrying the last good PPM frame. Frame lost is flagged
    when the last good PPM frame is older than ``frame_lost_after_us``; failsafe (with
    frame lost) after ``failsafe_after_us`` without PPM, and from power-up until the first
    good frame. Channel values are held through loss, as converters do.
    """

    name = "rc"

    def __init__(self, params: SbusParams) -> None:
        super().__init__()
        self.params = params
        self.baud_bps = params.baud
        self.decoder = PpmDecoder(params.ppm_sync_min_us, params.ppm_min_us, params.ppm_max_us,
                                  params.ppm_min_channels)
        self._edges: deque[PpmEdge] = deque()
        self._next_frame_ns = params.phase_us * NS_PER_US
        self._period_ns = params.frame_period_us * NS_PER_US
        self._pulses_us: tuple[int, ...] = ()
        self._last_good_ns: int | None = None
        self._last_fed_ns = -1

    def feed_edges(self, edges: Iterable[PpmEdge]) -> None:
        """Queue PPM edges (non-decreasing times); they are decoded as sim time passes."""
        for e in edges:
            if e.t_ns < self._last_fed_ns:
                self.counters["edges_out_of_order"] += 1
                continue
            self._last_fed_ns = e.t_ns
            self._edges.append(e)

    def _decode_until(self, t_ns: int) -> None:
        while self._edges and self._edges[0].t_ns <= t_ns:
            e = self._edges.popleft()
            pulses = self.decoder.edge(e.t_ns)
            if pulses is not None:
                self._pulses_us = pulses
                self._last_good_ns = e.t_ns
                self.counters["ppm_frames_ok"] += 1
                self._event(PpmDecoded(e.t_ns, pulses))

    def current_frame(self, t_ns: int) -> SbusFrame:
        """The frame the converter would send at ``t_ns`` (edges up to then decoded)."""
        p = self.params
        pulses = self._pulses_us
        channels = tuple(pwm_to_raw(pulses[i] if i < len(pulses) else p.default_us)
                         for i in range(SbusWire.N_CHANNELS))
        if self._last_good_ns is None:  # no good frame yet
            failsafe = lost = True
        else:
            age_ns = t_ns - self._last_good_ns
            failsafe = age_ns >= p.failsafe_after_us * NS_PER_US
            lost = failsafe or age_ns > p.frame_lost_after_us * NS_PER_US
        return SbusFrame(channels, frame_lost=lost, failsafe=failsafe, end_byte=p.end_byte)

    def advance(self, t_ns: int) -> None:
        """Decode edges and send the frames due up to ``t_ns``."""
        while self._next_frame_ns <= t_ns:
            t_frame = self._next_frame_ns
            self._decode_until(t_frame)
            frame = self.current_frame(t_frame)
            self._send(pack_sbus(frame))
            self.counters["frames"] += 1
            self.counters["frames_lost_flag"] += frame.frame_lost
            self.counters["frames_failsafe"] += frame.failsafe
            self._next_frame_ns += self._period_ns
        self._decode_until(t_ns)


def pulses_from_frame(frame: SbusFrame, n: int = 8) -> tuple[float, ...]:
    """First ``n`` channels of ``frame`` in us (ArduPilot scaling)."""
    return tuple(raw_to_pwm(r) for r in frame.channels_raw[:n])


def raw_channels(pulses_us: Sequence[float]) -> tuple[int, ...]:
    """Raw values of up to 16 widths, padded with the raw value of 1500 us."""
    vals = [pwm_to_raw(p) for p in pulses_us[: SbusWire.N_CHANNELS]]
    return tuple(vals + [pwm_to_raw(1500)] * (SbusWire.N_CHANNELS - len(vals)))
