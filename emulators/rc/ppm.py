"""The PPM-sum pulse train of the RC receiver, generated edge by edge in sim time.

Frame layout (idle-high polarity; the other polarity swaps the levels)::

    |sep|  ch1 - sep  |sep|  ch2 - sep  | ... |sep|  chN - sep  |sep|   sync gap   |sep| ...
    ^ frame start      ^                             ^                             ^ next frame

A channel's value is the time between the starts of consecutive separators (what
ArduPilot and Betaflight measure, whatever the polarity). N channels take N+1 separators;
the frame lasts ``frame_us`` unless the channels would leave less than ``min_sync_us``
between the last separator and the next frame, in which case it is stretched.

Channel values are sampled from the :class:`StickScript` at each frame start. Faults act
on the train from the first frame that starts at or after the time they are injected.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from mypy_extensions import mypyc_attr

from emulators.rc.params import PpmParams
from emulators.rc.script import CENTRE_US

NS_PER_US = 1_000


class Sticks(Protocol):
    """What the generator reads: a :class:`~emulators.rc.script.StickScript`, or anything
    that answers the same two questions (the bench's RC-loss fault wraps the script)."""

    def signal_present(self, t_ns: int) -> bool: ...

    def pulses_us(self, t_ns: int) -> tuple[int, ...]: ...


@dataclass(frozen=True, init=False)
class PpmEdge:
    """One edge of the PPM line at sim time ``t_ns``; ``level`` is the pin level after it (True = high)."""

    t_ns: int
    level: bool

    def __init__(self, t_ns: int, level: bool) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "level", level)


@dataclass(frozen=True, init=False)
class PpmFrame:
    """One generated frame: start time, the channel widths it carries (us), and whether a glitch was inserted."""

    t_ns: int
    pulses_us: tuple[int, ...]
    glitch: bool = False

    def __init__(self, t_ns: int, pulses_us: tuple[int, ...], glitch: bool = False) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "pulses_us", pulses_us)
        object.__setattr__(self, "glitch", glitch)


@dataclass(frozen=True)
class _Glitch:
    t_ns: int
    width_us: int
    channel: int


@mypyc_attr(allow_interpreted_subclasses=True)
class PpmGenerator:
    """Edges of the receiver's PPM output for a given stick script.

    ``rng`` (a seeded ``numpy.random.Generator``) draws the edge jitter. Call
    :meth:`edges_until` with non-decreasing times to collect the edges due so far.
    """

    def __init__(self, params: PpmParams, rng: np.random.Generator, script: Sticks) -> None:
        self.params = params
        self.rng = rng
        self.script = script
        self._next_frame_ns = params.phase_us * NS_PER_US
        self._pending: deque[PpmEdge] = deque()
        self._frames: list[PpmFrame] = []
        self._n_channels = params.n_channels
        self._stuck: dict[int, int] = {}
        self._losses: list[tuple[int, int]] = []
        self._glitches: list[_Glitch] = []
        # Timed fault changes, applied at frame starts: (t_ns, seq, kind, args).
        self._changes: list[tuple[int, int, str, tuple[int, ...]]] = []
        self._seq = 0
        self._clip_ns = int(params.jitter_clip_us * NS_PER_US)
        self.level = params.idle_high
        self.counters: dict[str, int] = {"frames": 0, "frames_lost": 0, "glitches": 0}

    # -- fault hooks ---------------------------------------------------------------------
    def inject_loss(self, t_ns: int, duration_ns: int) -> None:
        """No pulses for frames starting in ``[t_ns, t_ns + duration_ns)``."""
        self._losses.append((t_ns, t_ns + duration_ns))

    def inject_glitch(self, t_ns: int, width_us: int = 20, channel: int = 3) -> None:
        """Insert one extra ``width_us`` pulse in the middle of ``channel`` (1-based) of the
        first frame starting at or after ``t_ns``; decoders see one channel split in two."""
        self._glitches.append(_Glitch(t_ns, width_us, channel))
        self._glitches.sort(key=lambda g: g.t_ns)

    def set_channel_count(self, t_ns: int, n_channels: int) -> None:
        """From the first frame at or after ``t_ns`` send ``n_channels`` channels (extra ones centred)."""
        if not 1 <= n_channels <= 16:
            raise ValueError("n_channels must be 1..16")
        self._schedule(t_ns, "count", (n_channels,))

    def set_stuck(self, t_ns: int, channel: int, pulse_us: int | None) -> None:
        """Channel ``channel`` (1-based) stuck at ``pulse_us`` from ``t_ns`` on; None releases it."""
        self._schedule(t_ns, "stuck", (channel, -1 if pulse_us is None else int(pulse_us)))

    def _schedule(self, t_ns: int, kind: str, args: tuple[int, ...]) -> None:
        self._seq += 1
        self._changes.append((t_ns, self._seq, kind, args))
        self._changes.sort()

    # -- generation ----------------------------------------------------------------------
    def edges_until(self, t_ns: int) -> list[PpmEdge]:
        """All edges with time <= ``t_ns`` not returned before, in time order."""
        while self._next_frame_ns - self._clip_ns <= t_ns:
            self._generate_frame()
        out: list[PpmEdge] = []
        pending = self._pending
        while pending and pending[0].t_ns <= t_ns:
            out.append(pending.popleft())
        if out:
            self.level = out[-1].level
        return out

    def take_frames(self) -> list[PpmFrame]:
        """Drain the records of the frames generated so far (for recording)."""
        frames, self._frames = self._frames, []
        return frames

    def _apply_changes(self, t0: int) -> None:
        while self._changes and self._changes[0][0] <= t0:
            _, _, kind, args = self._changes.pop(0)
            if kind == "count":
                self._n_channels = args[0]
            elif args[1] < 0:
                self._stuck.pop(args[0], None)
            else:
                self._stuck[args[0]] = args[1]

    def _queue_edges(self, t0: int, pulses: list[tuple[float, float]]) -> None:
        """Queue the two edges of each active pulse (start, stop in us from ``t0``), jittered.

        Python floats do the same IEEE operations numpy's element-wise arithmetic did (x1000,
        + clipped jitter, round half to even) at a fraction of the cost; the jitter is still
        one ``Generator.normal(size=n)`` call, so the draws are the same.
        """
        p = self.params
        t_rel_ns = [float(x) * NS_PER_US for pulse in pulses for x in pulse]
        if p.jitter_us_rms > 0:
            clip = self._clip_ns
            jitter = self.rng.normal(0.0, p.jitter_us_rms * NS_PER_US, size=len(t_rel_ns)).tolist()
            t_rel_ns = [t + min(max(j, -clip), clip) for t, j in zip(t_rel_ns, jitter, strict=True)]
        active, idle = not p.idle_high, p.idle_high
        pending = self._pending
        for i, t_rel in enumerate(t_rel_ns):
            pending.append(PpmEdge(max(0, t0 + round(t_rel)), idle if i & 1 else active))

    def _lost(self, t0: int) -> bool:
        if not self.script.signal_present(t0):
            return True
        return any(start <= t0 < end for start, end in self._losses)

    def _generate_frame(self) -> None:
        p = self.params
        t0 = self._next_frame_ns
        self._apply_changes(t0)
        sticks = self.script.pulses_us(t0)
        n = self._n_channels
        widths = [sticks[i] if i < len(sticks) else CENTRE_US for i in range(n)]
        for ch, value in self._stuck.items():
            if 1 <= ch <= n:
                widths[ch - 1] = value
        frame_ns = max(p.frame_us, sum(widths) + p.min_sync_us) * NS_PER_US
        self._next_frame_ns = t0 + frame_ns
        if self._lost(t0):
            self.counters["frames_lost"] += 1
            return
        glitch = None
        while self._glitches and self._glitches[0].t_ns <= t0:
            glitch = self._glitches.pop(0)
        # Active-pulse start/stop times (us from t0): N+1 separators.
        starts_us: list[float] = []
        acc = 0
        for w in widths:
            starts_us.append(acc)
            acc += w
        starts_us.append(acc)
        pulses = [(s, s + p.separator_us) for s in starts_us]
        if glitch is not None and 1 <= glitch.channel <= n:
            s = starts_us[glitch.channel - 1] + p.separator_us
            e = starts_us[glitch.channel]
            mid = (s + e) / 2
            if e - s > glitch.width_us + 2 * p.jitter_clip_us + 2:
                pulses.append((mid - glitch.width_us / 2, mid + glitch.width_us / 2))
                pulses.sort()
                self.counters["glitches"] += 1
        self._queue_edges(t0, pulses)
        self.counters["frames"] += 1
        self._frames.append(PpmFrame(t0, tuple(widths), glitch is not None))
