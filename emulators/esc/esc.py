"""One ESC: servo pulse width in, throttle command (0..1) out for the plant's motor model.

The ESC samples its input only at PWM frame boundaries (``k / pwm_rate_hz`` in sim time,
power-up at sim time 0): a width change between boundaries is seen at the next one.
Arming follows SimonK/BLHeli practice: after power-up the motor is not driven until the
input has been low (<= min + deadband) for ``arm_time_s``; a high input at power-up just
waits. With no valid pulses the last throttle is held for ``signal_timeout_s``, then the
motor stops and the ESC disarms (it must see a low signal again to re-arm).

The motor's own lag is the plant's job (hil/plant); this model returns the commanded
throttle.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum, auto

import numpy as np

from emulators.base import DeviceEvent
from emulators.esc.params import EscParams

NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class EscArmed(DeviceEvent):
    """The ESC armed at ``t_ns``."""


@dataclass(frozen=True)
class EscDisarmed(DeviceEvent):
    """The ESC disarmed at ``t_ns`` (``reason``: "signal_lost")."""

    reason: str


@dataclass(frozen=True)
class EscDesync(DeviceEvent):
    """A desync thrust drop began at ``t_ns`` (fault)."""


class EscState(Enum):
    """Arming state."""

    DISARMED = auto()
    ARMED = auto()


class Esc:
    """One ESC.

    ``rng`` draws the desync fault's timing; a fresh ``default_rng(0)`` when omitted.
    Call :meth:`update` with non-decreasing ``t_ns``: it means "from ``t_ns`` on the input
    width is ``pulse_us``" (0.0 = no pulses) and returns the throttle in [0, 1].
    """

    def __init__(self, params: EscParams, rng: np.random.Generator | None = None) -> None:
        self.params = params
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.state = EscState.DISARMED
        self.throttle = 0.0
        self.latched_us = 0.0  #: width seen at the last frame boundary
        self.counters: dict[str, int] = {"frames": 0, "invalid_frames": 0, "arms": 0, "disarms": 0, "desyncs": 0}
        self._period_ns = int(round(NS_PER_S / params.pwm_rate_hz))
        self._next_frame_ns = 0
        self._t_ns = 0
        self._pin_us = 0.0
        self._low_since_ns: int | None = None
        self._last_valid_ns: int | None = None
        self._events: list[DeviceEvent] = []
        self._refuse_arm = False
        self._desync_rate_hz = 0.0
        self._desync_until_ns = -1
        self._stuck = False
        self._stuck_throttle = 0.0

    @property
    def armed(self) -> bool:
        """True while the ESC drives the motor."""
        return self.state is EscState.ARMED

    # -- fault hooks ---------------------------------------------------------------------
    def set_refuse_arm(self, active: bool) -> None:
        """While active the ESC never arms (e.g. a failed calibration)."""
        self._refuse_arm = active

    def set_desync(self, rate_hz: float) -> None:
        """Sporadic desyncs: thrust drops to 0 for ``desync_duration_s``, starting at
        ``rate_hz`` on average (Poisson, seeded); 0 switches the fault off."""
        self._desync_rate_hz = max(0.0, rate_hz)

    def set_stuck(self, active: bool, throttle: float | None = None) -> None:
        """Freeze the output at ``throttle`` (None: at its current value) while active."""
        self._stuck = active
        self._stuck_throttle = self.throttle if throttle is None else min(1.0, max(0.0, throttle))

    # -- input ---------------------------------------------------------------------------
    def update(self, t_ns: int, pulse_us: float) -> float:
        """The input is ``pulse_us`` from ``t_ns`` on; returns the throttle at ``t_ns``."""
        if t_ns < self._t_ns:
            self.counters["time_reversed"] = self.counters.get("time_reversed", 0) + 1
            return self.throttle
        while self._next_frame_ns <= t_ns:
            b = self._next_frame_ns
            self._frame(b, pulse_us if b == t_ns else self._pin_us)
            self._next_frame_ns += self._period_ns
        self._pin_us = pulse_us
        self._t_ns = t_ns
        return self.throttle

    def take_events(self) -> list[DeviceEvent]:
        """Drain arming/disarming/desync events."""
        events, self._events = self._events, []
        return events

    def _frame(self, t_ns: int, width_us: float) -> None:
        p = self.params
        self.counters["frames"] += 1
        if not p.valid_min_us <= width_us <= p.valid_max_us:
            self.counters["invalid_frames"] += 1
            self.latched_us = 0.0
            self._low_since_ns = None
            if (self.armed and self._last_valid_ns is not None
                    and t_ns - self._last_valid_ns >= p.signal_timeout_s * NS_PER_S):
                self.state = EscState.DISARMED
                self.throttle = 0.0
                self.counters["disarms"] += 1
                self._events.append(EscDisarmed(t_ns, "signal_lost"))
            self._apply_stuck()
            return
        self.latched_us = width_us
        self._last_valid_ns = t_ns
        low_limit = p.min_us + p.deadband_us
        if not self.armed:
            self.throttle = 0.0
            if self._refuse_arm or width_us > low_limit:
                self._low_since_ns = None
            else:
                if self._low_since_ns is None:
                    self._low_since_ns = t_ns
                if t_ns - self._low_since_ns >= p.arm_time_s * NS_PER_S:
                    self.state = EscState.ARMED
                    self.counters["arms"] += 1
                    self._events.append(EscArmed(t_ns))
            self._apply_stuck()
            return
        self.throttle = min(1.0, max(0.0, (width_us - low_limit) / (p.max_us - low_limit)))
        self._desync(t_ns)
        self._apply_stuck()

    def _desync(self, t_ns: int) -> None:
        if t_ns < self._desync_until_ns:
            self.throttle = 0.0
            return
        if self._desync_rate_hz > 0 and self.throttle > 0:
            if self.rng.random() < self._desync_rate_hz * self._period_ns / NS_PER_S:
                self._desync_until_ns = t_ns + int(self.params.desync_duration_s * NS_PER_S)
                self.throttle = 0.0
                self.counters["desyncs"] += 1
                self._events.append(EscDesync(t_ns))

    def _apply_stuck(self) -> None:
        if self._stuck:
            self.throttle = self._stuck_throttle
