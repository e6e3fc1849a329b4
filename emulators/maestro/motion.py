"""Per-channel output position of the Maestro under speed and acceleration limits.

Units: positions and targets in quarter-microseconds (qus). The Maestro updates each
channel's position every ``update_period`` (10 ms):

* speed limit ``speed`` in qus per 10 ms (0 = unlimited);
* acceleration limit ``accel`` 0..255 in qus per 10 ms per 80 ms (0 = unlimited): the
  velocity grows by ``accel / 8`` qus/10 ms per 10 ms, and the channel decelerates so it
  stops on the target (a trapezoidal profile, close to Pololu's movement calculator).

A channel that is off (position 0) jumps straight to its first target, and a target of 0
turns it off at once: the Maestro cannot know where an unpowered servo is.
"""

from __future__ import annotations

import math

UNIT_PERIOD_NS = 10_000_000  # the 10 ms of the speed unit
ACCEL_PERIOD_NS = 80_000_000  # the 80 ms of the acceleration unit


class ServoChannel:
    """Target, position and velocity of one channel (qus, qus per update)."""

    def __init__(self, update_period_ns: int) -> None:
        self.update_period_ns = update_period_ns
        self.target_qus = 0
        self.position_qus = 0.0
        self.speed = 0
        self.accel = 0
        self._velocity = 0.0  # qus per update, >= 0, towards the target
        self._direction = 0.0

    @property
    def moving(self) -> bool:
        """True while the position has not reached the target."""
        return self.position_qus != self.target_qus

    def set_target(self, target_qus: int) -> None:
        """New target (already clamped); 0 = off."""
        self.target_qus = target_qus
        if target_qus == 0 or self.position_qus == 0 or (self.speed == 0 and self.accel == 0):
            self.position_qus = float(target_qus)
            self._velocity = 0.0

    def step(self) -> None:
        """One position update."""
        d = self.target_qus - self.position_qus
        if d == 0:
            self._velocity = 0.0
            return
        dist = abs(d)
        if math.copysign(1.0, d) != self._direction:  # target moved behind us: start over
            self._direction = math.copysign(1.0, d)
            self._velocity = 0.0
        k = self.update_period_ns / UNIT_PERIOD_NS
        v_max = self.speed * k if self.speed else math.inf
        if self.accel:
            a = self.accel * k * self.update_period_ns / ACCEL_PERIOD_NS
            v = min(self._velocity + a, v_max, max(a, math.sqrt(2.0 * a * dist)))
        else:
            v = v_max
        step = min(v, dist)
        self._velocity = step
        self.position_qus = float(self.target_qus) if step >= dist else self.position_qus + math.copysign(step, d)
