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
reference it is tested against).

Simplification: the receiver finds an edge at its exact time (a 16550 finds it within 1/16 of
a bit, at its next 16x sample clock).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from enum import IntEnum, unique
from typing import NamedTuple


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


def format_from_lcr(lcr: int) -> FrameFormat:
    """The frame format of a 16550 line control register value."""
    parity = Parity((lcr >> 4) & 3) if lcr & 0x08 else Parity.NONE
    return FrameFormat(5 + (lcr & 3), parity, 2 if lcr & 0x04 else 1)


def _parity_bit(value: int, fmt: FrameFormat) -> int:
    ones = bin(value & ((1 << fmt.data_bits) - 1)).count("1")
    return {Parity.ODD: 1 - (ones & 1), Parity.EVEN: ones & 1, Parity.MARK: 1, Parity.SPACE: 0}[fmt.parity]


def frame_levels(value: int, fmt: FrameFormat) -> tuple[int, ...]:
    """The line levels of one frame carrying ``value``."""
    data = [(value >> i) & 1 for i in range(fmt.data_bits)]
    parity = [] if fmt.parity == Parity.NONE else [_parity_bit(value, fmt)]
    return (0, *data, *parity, *([1] * fmt.stop_bits))


@dataclass(frozen=True)
class LineFrame:
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
        self.frames: deque[LineFrame] = deque()
        #: the receiver looks for a falling edge from this time on
        self.idle_from = float("-inf")

    def push(self, frame: LineFrame) -> None:
        """Put a frame on the line (frames come in time order and do not overlap)."""
        self.frames.append(frame)

    @property
    def line_free(self) -> float:
        """When the last frame on the line ends (-inf if none)."""
        return self.frames[-1].end if self.frames else float("-inf")

    def take(self, now: float, bit_time: float, fmt: FrameFormat) -> list[Received]:
        """The characters complete by ``now`` for a receiver at ``bit_time`` and ``fmt``."""
        out: list[Received] = []
        while True:
            char, resume = self._next(bit_time, fmt)
            if char is None or char.done > now:
                self._drop_before(self.idle_from)
                return out
            out.append(char)
            self.idle_from = resume
            self._drop_before(resume)

    def peek_done(self, bit_time: float, fmt: FrameFormat) -> float | None:
        """When the next character will be complete, None if the line has none coming."""
        char, _ = self._next(bit_time, fmt)
        return None if char is None else char.done

    def _drop_before(self, t: float) -> None:
        while self.frames and self.frames[0].end <= t:
            self.frames.popleft()

    def _edge_at_or_after(self, t: float) -> tuple[int, int] | None:
        """(frame index, bit index) of the first falling edge at time >= ``t``."""
        for i, f in enumerate(self.frames):
            if f.end <= t:
                continue
            for k, level in enumerate(f.levels):
                if level == 0 and (k == 0 or f.levels[k - 1] == 1) and f.start + k * f.bit_time >= t:
                    return i, k
        return None

    def _level(self, i: int, pos: float) -> int:
        """The line level ``pos`` after frame ``i``'s start."""
        f = self.frames[i]
        k = int(pos / f.bit_time)
        if k < len(f.levels):
            return f.levels[k]
        t = f.start + pos
        for g in list(self.frames)[i + 1:]:
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
