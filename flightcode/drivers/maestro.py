"""Pololu Maestro servo controller driving the four ESCs: compact Set Multiple Targets.

Command (Maestro User's Guide 0J40 5.e; docs/protocols.md 6.2)::

    0x9F, n, first_channel, (target & 0x7F, (target >> 7) & 0x7F) x n

with targets in quarter-microseconds (1500 us -> 6000 -> ``70 2E``). One command carries all
four motors, so each loop sample costs exactly one write (the bench's lockstep barrier).
The port is opened with ``write_timeout=0``: the write never blocks the loop; a short write
is counted (the Maestro resynchronises on the next command byte, which has its MSB set).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum, unique

from flightcode.drivers.base import SerialLike


@unique
class MaestroCmd(IntEnum):
    """Compact-protocol command bytes used here."""

    SET_TARGET = 0x84  # ch, lo, hi
    SET_MULTIPLE_TARGETS = 0x9F  # n, first ch, (lo, hi) x n


def quarter_us(pulse_us: float) -> int:
    """Pulse width in us -> Maestro target in quarter-us (rounded)."""
    return int(round(pulse_us * 4.0))


def set_multiple_targets(first_channel: int, targets_qus: Sequence[int]) -> bytes:
    """Compact Set Multiple Targets for consecutive channels from ``first_channel``."""
    out = bytearray((MaestroCmd.SET_MULTIPLE_TARGETS, len(targets_qus), first_channel))
    for target in targets_qus:
        if not 0 <= target < 1 << 14:
            raise ValueError(f"Maestro target {target} out of 14-bit range")
        out += bytes((target & 0x7F, (target >> 7) & 0x7F))
    return bytes(out)


@dataclass(frozen=True)
class EscParams:
    """``[esc]``: pulse range and wiring.

    Fields:
        min_us: pulse at throttle 0 and while disarmed (the ESCs' arming level), us.
        max_us: pulse at throttle 1, us.
        idle_us: pulse while armed on the ground (motors turning slowly), us.
        first_channel: Maestro channel of motor 0; motors 0..3 use consecutive channels.
    """

    __pydantic_config__ = {"extra": "forbid"}

    min_us: float = 1000.0
    max_us: float = 2000.0
    idle_us: float = 1100.0
    first_channel: int = 0


class MaestroEsc:
    """The four ESC pulses through a Maestro on ``port`` (opened with write_timeout=0)."""

    name = "esc"
    N_MOTORS = 4

    def __init__(self, port: SerialLike, params: EscParams) -> None:
        self.port = port
        self.params = params
        self.counters: Counter[str] = Counter()
        #: The pulses of the last command written, us.
        self.last_pulses_us: tuple[float, ...] = (params.min_us,) * self.N_MOTORS

    def pulses_from_throttle(self, throttle: Sequence[float]) -> tuple[float, ...]:
        """Throttle in [0, 1] per motor -> pulse width in us (min_us + span * throttle)."""
        lo, span = self.params.min_us, self.params.max_us - self.params.min_us
        return tuple(lo + span * min(1.0, max(0.0, d)) for d in throttle)

    def write_pulses_us(self, pulses_us: Sequence[float]) -> None:
        """One Set Multiple Targets with ``pulses_us`` clamped to [min_us, max_us]."""
        lo, hi = self.params.min_us, self.params.max_us
        clamped = tuple(min(hi, max(lo, p)) for p in pulses_us)
        frame = set_multiple_targets(self.params.first_channel, [quarter_us(p) for p in clamped])
        written = self.port.write(frame)
        if written is not None and written < len(frame):
            self.counters["short_writes"] += 1
        self.counters["commands"] += 1
        self.last_pulses_us = clamped

    def write_minimum(self) -> None:
        """All motors to the minimum pulse (disarmed / safe state)."""
        self.write_pulses_us((self.params.min_us,) * self.N_MOTORS)
