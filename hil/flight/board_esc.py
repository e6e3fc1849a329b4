"""The four ESC inputs of a board run, read from the LPC2148's output pins.

The firmware's lpc2148 layer drives ESC 0 and 1 from PWM2 (P0.7) and PWM5 (P0.21) and ESC 2
and 3 from Timer1's match outputs MAT1.2 (P0.17) and MAT1.3 (P0.18), each edge of the latter
programmed by the Timer1 interrupt (firmware/hal/lpc2148/lpc2148.h). :class:`EscPins` turns
what the peripheral models report into what an ESC model takes: "from sim time t on the
input is w us" (``Esc.update``), and counts the pulses that came late or not at all.

* PWM channels: the model reports each width or period change (``Lpc2148.take_pwm``); the
  hardware makes every pulse, so a running PWM channel is never late.
* Match outputs: each edge is a level change at a PCLK tick (``Timer.take_match_outputs``).
  A pulse's width is known at its falling edge and applies from there. A rising edge more
  than ``LATE_US`` after one period since the previous one is a late pulse; whole periods
  without a rising edge are missed pulses (the handler that programs the next edge ran too
  late: its match value had already passed). With no rising edge for ``SILENT_PERIODS``
  periods, or the output stuck high that long, the ESC sees no pulses (0 us).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

#: ESC number -> (the peripheral, its channel) as the lpc2148 layer wires them
PWM_ESCS = {2: 0, 5: 1}  #: PWM channel -> ESC
MAT_ESCS = {2: 2, 3: 3}  #: Timer1 match channel -> ESC
N_ESCS = 4
#: a rising edge later than one period plus this after the previous one counts as late, us
LATE_US = 2.0
#: periods without a rising edge after which the ESC sees no pulses
SILENT_PERIODS = 2.0


@dataclass
class _MatTrain:
    rise_ns: int | None = None  #: the last rising edge
    high: bool = False
    width_us: float = 0.0  #: the last complete pulse


@dataclass
class EscPins:
    """ESC inputs from the pins; times are sim ns."""

    #: ESC -> (sim ns, width us) changes not yet given to the ESC models
    pending: list[list[tuple[int, float]]] = field(default_factory=lambda: [[] for _ in range(N_ESCS)])
    width_us: list[float] = field(default_factory=lambda: [0.0] * N_ESCS)  #: what each ESC sees now
    period_us: float = 2500.0  #: the PWM's period: the rate the match outputs must keep too
    pulses: list[int] = field(default_factory=lambda: [0] * N_ESCS)  #: match-output pulses seen
    late: int = 0
    missed: int = 0
    #: (sim ns, ESC, width us) of every change, taken by the run's recording each tick
    changes: list[tuple[int, int, float]] = field(default_factory=list)
    _mat: dict[int, _MatTrain] = field(default_factory=lambda: {esc: _MatTrain() for esc in MAT_ESCS.values()})
    _applied: list[float] = field(default_factory=lambda: [0.0] * N_ESCS)  #: given to the ESC models

    def _set(self, esc: int, t_ns: int, width_us: float) -> None:
        if width_us != self.width_us[esc]:
            self.width_us[esc] = width_us
            self.pending[esc].append((t_ns, width_us))
            self.changes.append((t_ns, esc, width_us))

    def pwm(self, t_ns: int, channel: int, pulse_us: float, period_us: float) -> None:
        """PWM ``channel`` gives ``pulse_us`` every ``period_us`` from ``t_ns`` on (0, 0: off)."""
        esc = PWM_ESCS.get(channel)
        if esc is None:
            return
        if period_us > 0:
            self.period_us = period_us
        self._set(esc, t_ns, pulse_us if period_us > 0 else 0.0)

    def match(self, t_ns: int, channel: int, level: bool) -> None:
        """Timer1's MAT1.``channel`` pin went to ``level`` at ``t_ns``."""
        esc = MAT_ESCS.get(channel)
        if esc is None:
            return
        train = self._mat[esc]
        if level and not train.high:
            if train.rise_ns is not None:
                gap_us = (t_ns - train.rise_ns) / 1e3
                whole = round(gap_us / self.period_us)
                if whole > 1:
                    self.missed += whole - 1
                elif gap_us > self.period_us + LATE_US:
                    self.late += 1
            train.rise_ns = t_ns
            self.pulses[esc] += 1
        elif not level and train.high and train.rise_ns is not None:
            train.width_us = (t_ns - train.rise_ns) / 1e3
            self._set(esc, t_ns, train.width_us)
        train.high = level

    @property
    def applied_us(self) -> tuple[float, ...]:
        """The widths the ESC models were last given (at the last :meth:`drive`)."""
        return tuple(self._applied)

    def rebase(self, delta_ns: int) -> None:
        """Sim time moved by ``delta_ns`` (the end of boot): the times kept move with it."""
        for train in self._mat.values():
            if train.rise_ns is not None:
                train.rise_ns += delta_ns
        self.pending = [[(t + delta_ns, w) for t, w in p] for p in self.pending]
        self.changes = [(t + delta_ns, esc, w) for t, esc, w in self.changes]

    def silence_until(self, t_ns: int) -> None:
        """A match output that has given no rising edge for ``SILENT_PERIODS`` periods by
        ``t_ns`` gives the ESC no pulses from the moment that many periods had passed."""
        limit_ns = round(SILENT_PERIODS * self.period_us * 1e3)
        for esc, train in self._mat.items():
            if train.rise_ns is not None and t_ns - train.rise_ns > limit_ns:
                self._set(esc, train.rise_ns + limit_ns, 0.0)

    def drive(self, t_ns: int, update: Callable[[int, int, float], float]) -> tuple[float, ...]:
        """Hand every ESC its changes up to ``t_ns`` (``update(esc, t_ns, width_us)`` ->
        throttle, an ``Esc.update``), in time order; returns the throttles at ``t_ns``.
        Changes after ``t_ns`` (the core may run a few cycles past a tick) wait."""
        self.silence_until(t_ns)
        out = []
        for esc in range(N_ESCS):
            changes = sorted(self.pending[esc], key=lambda c: c[0])
            for t, w in changes:
                if t > t_ns:
                    break
                if t < t_ns:
                    update(esc, t, w)
                self._applied[esc] = w
            self.pending[esc] = [c for c in changes if c[0] > t_ns]
            out.append(update(esc, t_ns, self._applied[esc]))
        return tuple(out)
