"""An asynchronous serial line as a receiver sees it: frames of bits sent at the sender's bit
time, sampled at the receiver's own bit time and format.

The sender (a device on the bench, or the LPC2148's transmitter) puts :class:`LineFrame`
records on the line: start time, bit time and the frame's bit levels (start 0, data LSB first,
optional parity, stop bits 1); between frames the line idles at 1. A receiver
(:class:`LineReceiver`) does what a 16550's does: on a falling edge it samples the middle of
the start bit (high there: a false start, it looks for the next edge), then the middle of each
of its own data, parity and stop bit times. A stop bit read as 0 is a framing error; all bits
0 a break. After the first stop bit's sample it looks for the next falling edge.

So a baud or format mismatch between the two ends gives what the hardware gives, bit for bit:
a small rate error still reads every byte, a larger one reads garbage with framing errors.
Times are floats in the receiver's clock ticks (PCLK for the LPC2148's UARTs).

Speed: a frame sent in the receiver's format at a rate close enough that every sample falls
in its own bit is taken whole (``LineReceiver(fast_path=False)`` samples every bit: the
reference it is tested against); :meth:`LineReceiver.clean_dones` lists when the next such
characters will be complete without taking them (for the UART's interrupt look-ahead).

Simplification: the receiver finds an edge at its exact time (a 16550 finds it within 1/16 of
a bit, at its next 16x sample clock).
"""

from __future__ import annotations

import math
from collections import deque
from itertools import islice
from dataclasses import dataclass
from enum import IntEnum, unique
from typing import Final, NamedTuple


@unique
class Parity(IntEnum):
    """LCR bits 5:4 with bit 3 set; NONE when parity is off."""

    ODD = 0
    EVEN = 1
    MARK = 2  #: forced 1
    SPACE = 3  #: forced 0
    NONE = 4


@dataclass(frozen=True)
class FrameFormat:
    """Data bits (5-8), parity, stop bits (1 or 2)."""

    data_bits: int = 8
    parity: Parity = Parity.NONE
    stop_bits: int = 1

    @property
    def n_bits(self) -> int:
        """Bits in a frame: start, data, parity, stop."""
        return 1 + self.data_bits + (self.parity != Parity.NONE) + self.stop_bits


FORMAT_8N1 = FrameFormat()


def _format_of_lcr(lcr: int) -> FrameFormat:
    parity = Parity((lcr >> 4) & 3) if lcr & 0x08 else Parity.NONE
    fmt = FrameFormat(5 + (lcr & 3), parity, 2 if lcr & 0x04 else 1)
    return FORMAT_8N1 if fmt == FORMAT_8N1 else fmt


#: LCR bits 5:0 -> its format, one object each (8N1 is FORMAT_8N1 itself: frames sent in it
#: are recognised by identity)
_LCR_FORMATS: Final = tuple(_format_of_lcr(lcr) for lcr in range(64))


def format_from_lcr(lcr: int) -> FrameFormat:
    """The frame format of a 16550 line control register value."""
    return _LCR_FORMATS[lcr & 0x3F]


def _parity_bit(value: int, fmt: FrameFormat) -> int:
    ones = bin(value & ((1 << fmt.data_bits) - 1)).count("1")
    return {Parity.ODD: 1 - (ones & 1), Parity.EVEN: ones & 1, Parity.MARK: 1, Parity.SPACE: 0}[fmt.parity]


def frame_levels(value: int, fmt: FrameFormat) -> tuple[int, ...]:
    """The line levels of one frame carrying ``value``."""
    data = [(value >> i) & 1 for i in range(fmt.data_bits)]
    parity = [] if fmt.parity == Parity.NONE else [_parity_bit(value, fmt)]
    return (0, *data, *parity, *([1] * fmt.stop_bits))


_LEVEL_TABLES: dict[FrameFormat, tuple[tuple[int, ...], ...]] = {}


def level_table(fmt: FrameFormat) -> tuple[tuple[int, ...], ...]:
    """``frame_levels(v, fmt)`` for v in 0-255, computed once per format."""
    table = _LEVEL_TABLES.get(fmt)
    if table is None:
        table = _LEVEL_TABLES[fmt] = tuple(frame_levels(v, fmt) for v in range(256))
    return table


class LineFrame(NamedTuple):
    """One frame on the line: ``start`` time, ``bit_time`` (same unit), its bit ``levels``,
    and the ``value`` and ``fmt`` it was sent with (for the receiver's fast path)."""

    start: float
    bit_time: float
    levels: tuple[int, ...]
    value: int
    fmt: FrameFormat

    @property
    def end(self) -> float:
        return self.start + len(self.levels) * self.bit_time


class Received(NamedTuple):
    """A character the receiver assembled, complete at ``done`` (its first stop bit's sample)."""

    value: int
    framing_error: bool
    parity_error: bool
    break_: bool
    done: float


class LineReceiver:
    """The frames on one line and the receiver sampling them."""

    def __init__(self, *, fast_path: bool = True) -> None:
        #: False: sample every bit of every frame (the reference the fast path is tested against)
        self.fast_path = fast_path
        #: the frames not taken yet (a frame taken whole leaves at once; the others when the
        #: receiver has looked past their end)
        self.frames: deque[LineFrame] = deque()
        #: the receiver looks for a falling edge from this time on
        self.idle_from = float("-inf")
        self._last_end = float("-inf")
        #: the last clean-rate question and its answer: (rx bit, tx bit, bits, clean)
        self._clean_memo: tuple[float, float, int, bool] = (0.0, 0.0, 0, False)
        # clean_dones' answer for a receiver at (_dq_bit, _dq_fmt), kept as frames come and go:
        # the dones of the leading frames read whole, and whether they are all the frames
        self._dq: deque[float] = deque()
        self._dq_bit = -1.0
        self._dq_fmt: FrameFormat | None = None  #: None: not kept
        self._dq_full = False

    def push(self, frame: LineFrame) -> None:
        """Put a frame on the line (frames come in time order and do not overlap)."""
        self.frames.append(frame)
        self._last_end = frame.start + len(frame.levels) * frame.bit_time
        fmt = self._dq_fmt
        if fmt is not None and self._dq_full:
            dq = self._dq
            n = fmt.n_bits
            after = dq[-1] if dq else self.idle_from
            if self.fast_path and frame.start >= after and frame.levels[0] == 0 and len(frame.levels) == n \
                    and (frame.fmt is fmt or frame.fmt == fmt) and self._is_clean(self._dq_bit, frame.bit_time, n):
                dq.append(frame.start + (n - 0.5) * self._dq_bit)
            else:
                self._dq_full = False

    @property
    def line_free(self) -> float:
        """When the last frame on the line ends (-inf if none)."""
        return self._last_end if self._last_end > self.idle_from else float("-inf")

    def _whole(self, f: LineFrame, bit_time: float, fmt: FrameFormat, n: int) -> bool:
        """``f``, the first frame on the line, is read whole: its start bit is the next falling
        edge, it is in the receiver's format and every sample falls in its own bit."""
        if not self.fast_path or f.start < self.idle_from or f.levels[0] != 0 or len(f.levels) != n:
            return False
        if f.fmt is not fmt and f.fmt != fmt:
            return False
        return self._is_clean(bit_time, f.bit_time, n)

    def _is_clean(self, rx_bit: float, tx_bit: float, n: int) -> bool:
        memo = self._clean_memo
        if memo[0] == rx_bit and memo[1] == tx_bit and memo[2] == n:
            return memo[3]
        clean = _clean(rx_bit, tx_bit, n)
        self._clean_memo = (rx_bit, tx_bit, n, clean)
        return clean

    def take(self, now: float, bit_time: float, fmt: FrameFormat) -> list[Received]:
        """The characters complete by ``now`` for a receiver at ``bit_time`` and ``fmt``."""
        return [Received(*c) for c in self.take_raw(now, bit_time, fmt)]

    def take_raw(self, now: float, bit_time: float, fmt: FrameFormat) -> list[tuple[int, bool, bool, bool, float]]:
        """:meth:`take`'s characters as plain tuples (value, framing error, parity error,
        break, done)."""
        out: list[tuple[int, bool, bool, bool, float]] = []
        frames = self.frames
        n = fmt.n_bits
        mask = (1 << fmt.data_bits) - 1
        to_stop = (n - 0.5) * bit_time
        kept = self._dq_fmt is fmt and self._dq_bit == bit_time
        while frames:
            f = frames[0]
            if self._whole(f, bit_time, fmt, n):
                done = f.start + to_stop
                if done > now:
                    break
                out.append((f.value & mask, False, False, False, done))
                self.idle_from = done
                frames.popleft()  # no falling edge after its last sample: nothing more to read in it
                if kept and self._dq:
                    self._dq.popleft()  # the first of the kept dones was this frame's
                else:
                    kept = False
                continue
            kept = False
            char, resume = self._next(bit_time, fmt)
            if char is None or char.done > now:
                break
            out.append((char.value, char.framing_error, char.parity_error, char.break_, char.done))
            self.idle_from = resume
            self._drop_before(resume)
        if self._drop_before(self.idle_from):
            kept = False
        if not kept:
            self._dq_fmt = None
        return out

    def peek_done(self, bit_time: float, fmt: FrameFormat) -> float | None:
        """When the next character will be complete, None if the line has none coming."""
        if self.frames:
            f = self.frames[0]
            n = fmt.n_bits
            if self._whole(f, bit_time, fmt, n):
                return f.start + (n - 0.5) * bit_time
        char, _ = self._next(bit_time, fmt)
        return None if char is None else char.done

    def clean_dones(self, bit_time: float, fmt: FrameFormat, limit: int) -> tuple[list[float], bool]:
        """When the next characters will be complete, up to ``limit`` of them, as long as each
        is a frame read whole (so it carries no error); and whether that covers every
        character on the line. Kept between calls for the same receiver (identical ``fmt``)."""
        frames = self.frames
        if not frames or limit <= 0:
            return [], not frames
        if self._dq_fmt is not fmt or self._dq_bit != bit_time:
            self._keep_dones(bit_time, fmt)
        dq = self._dq
        if len(dq) >= limit:
            return list(islice(dq, limit)), limit == len(frames)
        return list(dq), self._dq_full

    def _keep_dones(self, bit_time: float, fmt: FrameFormat) -> None:
        """The dones of the leading frames read whole by a receiver at ``bit_time``, ``fmt``."""
        dq: deque[float] = deque()
        self._dq, self._dq_bit, self._dq_fmt, self._dq_full = dq, bit_time, fmt, False
        frames = self.frames
        n = fmt.n_bits
        to_stop = (n - 0.5) * bit_time
        if frames and not self._whole(frames[0], bit_time, fmt, n):
            return
        previous = self.idle_from
        checked_bit = -1.0
        checked_fmt: FrameFormat | None = None
        for f in frames:  # each frame starts after the previous one's last sample: each is read whole alike
            if f.start < previous or f.levels[0] != 0 or len(f.levels) != n:
                return
            if f.bit_time != checked_bit or f.fmt is not checked_fmt:  # a burst's frames share both
                if (f.fmt is not fmt and f.fmt != fmt) or not self._is_clean(bit_time, f.bit_time, n):
                    return
                checked_bit, checked_fmt = f.bit_time, f.fmt
            previous = f.start + to_stop
            dq.append(previous)
        self._dq_full = True

    def _drop_before(self, t: float) -> bool:
        """Drop the frames that end by ``t``; whether there were any."""
        frames = self.frames
        dropped = False
        while frames and frames[0].start + len(frames[0].levels) * frames[0].bit_time <= t:
            frames.popleft()
            dropped = True
        return dropped

    def _edge_at_or_after(self, t: float) -> tuple[int, int] | None:
        """(frame index, bit index) of the first falling edge at time >= ``t``."""
        for i, f in enumerate(self.frames):
            if f.end <= t:
                continue
            levels = f.levels
            # the bits starting before t cannot hold the edge: begin at the first one at or after t
            k0 = 0 if t <= f.start else max(0, math.ceil((t - f.start) / f.bit_time) - 1)
            for k in range(k0, len(levels)):
                if levels[k] == 0 and (k == 0 or levels[k - 1] == 1) and f.start + k * f.bit_time >= t:
                    return i, k
        return None

    def _level(self, i: int, pos: float) -> int:
        """The line level ``pos`` after frame ``i``'s start."""
        f = self.frames[i]
        k = int(pos / f.bit_time)
        if k < len(f.levels):
            return f.levels[k]
        t = f.start + pos
        for j in range(i + 1, len(self.frames)):
            g = self.frames[j]
            if g.start > t:
                return 1
            if t < g.end:
                return g.levels[int((t - g.start) / g.bit_time)]
        return 1

    def _next(self, bit_time: float, fmt: FrameFormat) -> tuple[Received | None, float]:
        t = self.idle_from
        n = fmt.n_bits
        while True:
            edge = self._edge_at_or_after(t)
            if edge is None:
                return None, t
            i, k = edge
            f = self.frames[i]
            base = k * f.bit_time  # the edge, from the frame's start
            done = f.start + base + (n - 0.5) * bit_time
            if self.fast_path and k == 0 and f.fmt == fmt and len(f.levels) == n and _clean(bit_time, f.bit_time, n):
                return Received(f.value & ((1 << fmt.data_bits) - 1), False, False, False, done), done
            levels = [self._level(i, base + (j + 0.5) * bit_time) for j in range(n)]
            if levels[0]:
                t = f.start + base + 0.5 * bit_time  # a false start
                continue
            return _decode(levels, fmt, done), done


def _clean(rx_bit: float, tx_bit: float, n_bits: int) -> bool:
    """Every sample of a frame falls in its own bit (the rates are close enough)."""
    return all(int((j + 0.5) * rx_bit / tx_bit) == j for j in range(n_bits))


def _decode(levels: list[int], fmt: FrameFormat, done: float) -> Received:
    data = levels[1:1 + fmt.data_bits]
    value = sum(b << j for j, b in enumerate(data))
    parity_error = False
    if fmt.parity != Parity.NONE:
        parity_error = levels[1 + fmt.data_bits] != _parity_bit(value, fmt)
    stop = levels[n_stop := 1 + fmt.data_bits + (fmt.parity != Parity.NONE)]
    break_ = not any(levels[: n_stop + 1])
    return Received(value, stop == 0, parity_error, break_, done)
