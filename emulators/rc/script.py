"""Stick scripts: what the pilot's hands do on the transmitter, as a function of sim time.

A :class:`StickScript` is built from a list of segments (frozen dataclasses, so a scenario
TOML table validates straight into them):

* :class:`Setpoint` - a channel goes to ``pulse_us`` at ``t_s``, linearly over ``ramp_s``
  (starting from wherever the channel is at ``t_s``, even in the middle of another ramp);
* :class:`Sine` - a sine added to the channel (or around ``offset_us``), faded in and out
  with a raised cosine over ``fade_s`` so the sticks never jump;
* :class:`Macro` - the "arm" / "disarm" gestures of the flight code's conventions;
* :class:`Loss` - a window with no RC signal at all (the receiver stops pulsing).

Channel numbering is the transmitter's, 1..8: ch1 roll, ch2 pitch, ch3 throttle, ch4 yaw,
ch5 mode switch, ch6-8 aux. Centre 1500 us, throttle low 1000 us.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from enum import Enum, IntEnum, unique

NS_PER_S = 1_000_000_000


@unique
class Channel(IntEnum):
    """Transmitter channel numbers (1-based) shared with the flight code."""

    ROLL = 1
    PITCH = 2
    THROTTLE = 3
    YAW = 4
    MODE = 5
    AUX1 = 6
    AUX2 = 7
    AUX3 = 8


N_SCRIPT_CHANNELS = 8
CENTRE_US = 1500
THROTTLE_LOW_US = 1000
#: Stick positions at power-up: centred, throttle low, switches low.
DEFAULT_INITIAL_US: tuple[int, ...] = (1500, 1500, 1000, 1500, 1000, 1000, 1000, 1000)

# Gesture conventions (the flight code's arming state machine is written from these).
ARM_THROTTLE_MAX_US = 1050
ARM_YAW_MIN_US = 1900
DISARM_YAW_MAX_US = 1100
GESTURE_HOLD_S = 1.0


def _check_channel(channel: int) -> None:
    if not 1 <= channel <= N_SCRIPT_CHANNELS:
        raise ValueError(f"channel must be 1..{N_SCRIPT_CHANNELS}, got {channel}")


def _to_ns(t_s: float) -> int:
    return int(round(t_s * NS_PER_S))


@dataclass(frozen=True)
class Setpoint:
    """Channel ``channel`` (1..8) goes to ``pulse_us`` starting at ``t_s`` (s), linearly over ``ramp_s`` (s)."""

    __pydantic_config__ = {"extra": "forbid"}

    t_s: float
    channel: int
    pulse_us: float
    ramp_s: float = 0.0

    def __post_init__(self) -> None:
        _check_channel(self.channel)
        if self.ramp_s < 0 or self.t_s < 0:
            raise ValueError("t_s and ramp_s must be >= 0")


@dataclass(frozen=True)
class Sine:
    """A sine of ``amplitude_us`` at ``freq_hz`` on ``channel`` from ``t_s`` for ``duration_s``.

    With ``offset_us`` None the sine is added to the channel's setpoint track; otherwise it
    oscillates around ``offset_us`` (replacing the track while it runs). The amplitude is
    faded in over the first ``fade_s`` and out over the last ``fade_s`` (raised cosine),
    clipped to half the duration for short sines.
    """

    __pydantic_config__ = {"extra": "forbid"}

    t_s: float
    channel: int
    amplitude_us: float
    freq_hz: float
    duration_s: float
    offset_us: float | None = None
    fade_s: float = 2.0

    def __post_init__(self) -> None:
        _check_channel(self.channel)
        if self.duration_s <= 0 or self.freq_hz <= 0 or self.fade_s < 0 or self.t_s < 0:
            raise ValueError("duration_s and freq_hz must be > 0, fade_s and t_s >= 0")

    def value_us(self, t_s: float) -> float:
        """The sine's contribution at absolute time ``t_s`` (0 outside its window)."""
        tau = t_s - self.t_s
        if tau < 0 or tau >= self.duration_s:
            return 0.0
        fade = min(self.fade_s, self.duration_s / 2)
        w = 1.0
        if fade > 0:
            edge = min(tau, self.duration_s - tau)
            if edge < fade:
                w = 0.5 * (1.0 - math.cos(math.pi * edge / fade))
        return self.amplitude_us * w * math.sin(2.0 * math.pi * self.freq_hz * tau)


@unique
class MacroName(str, Enum):
    """Named stick gestures."""

    ARM = "arm"
    DISARM = "disarm"


@dataclass(frozen=True)
class Macro:
    """A named gesture starting at ``t_s``: throttle low and yaw full right ("arm") or full
    left ("disarm") held for ``hold_s`` (> the 1 s the flight code needs), then yaw back to
    centre. Throttle stays low afterwards."""

    __pydantic_config__ = {"extra": "forbid"}

    t_s: float
    name: str
    hold_s: float = 1.5

    def __post_init__(self) -> None:
        MacroName(self.name)  # raises ValueError for unknown names
        if self.hold_s <= GESTURE_HOLD_S:
            raise ValueError(f"hold_s must exceed the {GESTURE_HOLD_S} s the gesture needs")

    def expand(self) -> tuple[Setpoint, ...]:
        """The setpoints this gesture stands for."""
        yaw_us = 2000 if MacroName(self.name) is MacroName.ARM else 1000
        return (
            Setpoint(self.t_s, Channel.THROTTLE, THROTTLE_LOW_US),
            Setpoint(self.t_s, Channel.YAW, yaw_us),
            Setpoint(self.t_s + self.hold_s, Channel.YAW, CENTRE_US),
        )


@dataclass(frozen=True)
class Loss:
    """No RC signal from ``t_s`` for ``duration_s`` (both s)."""

    __pydantic_config__ = {"extra": "forbid"}

    t_s: float
    duration_s: float

    def __post_init__(self) -> None:
        if self.duration_s <= 0 or self.t_s < 0:
            raise ValueError("duration_s must be > 0 and t_s >= 0")


Segment = Setpoint | Sine | Macro | Loss


class _Track:
    """Piecewise-linear setpoint track of one channel: breakpoints (t_ns, value_us)."""

    def __init__(self, initial_us: float) -> None:
        self.t_ns: list[int] = [0]
        self.v_us: list[float] = [float(initial_us)]

    def value(self, t_ns: int) -> float:
        i = bisect_right(self.t_ns, t_ns) - 1
        if i < 0:
            return self.v_us[0]
        if i + 1 >= len(self.t_ns):
            return self.v_us[i]
        t0, t1 = self.t_ns[i], self.t_ns[i + 1]
        v0, v1 = self.v_us[i], self.v_us[i + 1]
        return v0 + (v1 - v0) * (t_ns - t0) / (t1 - t0)

    def add(self, sp: Setpoint) -> None:
        t0 = _to_ns(sp.t_s)
        v0 = self.value(t0)
        # A new setpoint cuts whatever ramp was in progress.
        keep = bisect_right(self.t_ns, t0)
        del self.t_ns[keep:], self.v_us[keep:]
        self.t_ns.append(t0)
        self.v_us.append(v0)
        self.t_ns.append(t0 + _to_ns(sp.ramp_s))
        self.v_us.append(float(sp.pulse_us))


class StickScript:
    """The eight transmitter channels as functions of sim time.

    ``segments`` may come in any order; setpoints on one channel apply in time order (ties
    in list order). Widths are rounded to whole microseconds and clamped to
    ``[min_us, max_us]`` (the transmitter's end points).
    """

    def __init__(
        self,
        segments: Iterable[Segment] = (),
        *,
        initial_us: Sequence[float] = DEFAULT_INITIAL_US,
        min_us: int = 1000,
        max_us: int = 2000,
    ) -> None:
        if len(initial_us) != N_SCRIPT_CHANNELS:
            raise ValueError(f"initial_us needs {N_SCRIPT_CHANNELS} values")
        self.min_us = min_us
        self.max_us = max_us
        self.segments: tuple[Segment, ...] = tuple(segments)
        setpoints: list[Setpoint] = []
        self._sines: list[list[Sine]] = [[] for _ in range(N_SCRIPT_CHANNELS)]
        self._losses: list[tuple[int, int]] = []
        for seg in self.segments:
            if isinstance(seg, Setpoint):
                setpoints.append(seg)
            elif isinstance(seg, Macro):
                setpoints.extend(seg.expand())
            elif isinstance(seg, Sine):
                self._sines[seg.channel - 1].append(seg)
            elif isinstance(seg, Loss):
                start = _to_ns(seg.t_s)
                self._losses.append((start, start + _to_ns(seg.duration_s)))
            else:
                raise TypeError(f"unknown segment {seg!r}")
        self._tracks = [_Track(v) for v in initial_us]
        for sp in sorted(setpoints, key=lambda s: s.t_s):  # stable: ties keep list order
            self._tracks[sp.channel - 1].add(sp)
        self._losses.sort()

    def value_us(self, channel: int, t_ns: int) -> float:
        """Unrounded, unclamped stick value of ``channel`` (1..8) at ``t_ns``, in us."""
        ch = channel - 1
        base = self._tracks[ch].value(t_ns)
        t_s = t_ns / NS_PER_S
        for sine in self._sines[ch]:
            contrib = sine.value_us(t_s)
            if sine.offset_us is not None and sine.t_s <= t_s < sine.t_s + sine.duration_s:
                base = sine.offset_us
            base += contrib
        return base

    def pulses_us(self, t_ns: int) -> tuple[int, ...]:
        """The 8 channel widths at ``t_ns`` in us, rounded and clamped."""
        return tuple(
            min(self.max_us, max(self.min_us, int(round(self.value_us(ch, t_ns)))))
            for ch in range(1, N_SCRIPT_CHANNELS + 1)
        )

    def signal_present(self, t_ns: int) -> bool:
        """False inside a :class:`Loss` window."""
        for start, end in self._losses:
            if start > t_ns:
                break
            if t_ns < end:
                return False
        return True
