"""Linear pieces of the analog chain: first-order stages, filtered noise, the gain stage.

Inputs are held constant between updates (zero-order hold), so first-order stages and
two cascaded first-order stages are advanced with their exact solutions. Noise that passes
a first-order stage is an Ornstein-Uhlenbeck process, also advanced exactly.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from emulators.analog.params import ConditioningParams


class NormalSource(Protocol):
    """Anything that hands out standard normals one at a time (a numpy Generator does)."""

    def standard_normal(self) -> float: ...

LN9 = math.log(9.0)  #: 10-90 % rise time = tau * ln 9 for a first-order stage


def tau_from_rise_s(rise_s: float) -> float:
    return rise_s / LN9


def tau_from_cutoff_s(f_Hz: float) -> float:
    """Time constant of a first-order low-pass with -3 dB at ``f_Hz`` (0 -> no stage)."""
    return 0.0 if f_Hz <= 0.0 else 1.0 / (2.0 * math.pi * f_Hz)


def first_order(x0: float, u: float, tau_s: float, dt_s: float) -> float:
    """State of dx/dt = (u - x) / tau after ``dt_s`` with ``u`` held (tau 0: x = u)."""
    if tau_s <= 0.0:
        return u
    return u + (x0 - u) * math.exp(-dt_s / tau_s)


def two_stage(x1_0: float, x2_0: float, u: float, tau1_s: float, tau2_s: float, dt_s: float) -> float:
    """Output of stage 2 fed by stage 1 (both first order) after ``dt_s`` with ``u`` held.

    e1 = x1 - u, e2 = x2 - u: e2(t) = e2(0) e^{-t/tau2} + e1(0) tau1/(tau1-tau2)
    (e^{-t/tau1} - e^{-t/tau2}); the equal-tau limit is e1(0) (t/tau) e^{-t/tau}.
    """
    if tau2_s <= 0.0:
        return first_order(x1_0, u, tau1_s, dt_s)
    e1, e2 = x1_0 - u, x2_0 - u
    if tau1_s <= 0.0:
        return u + e2 * math.exp(-dt_s / tau2_s)
    a2 = math.exp(-dt_s / tau2_s)
    if abs(tau1_s - tau2_s) < 1e-12 * max(tau1_s, tau2_s):
        cross = e1 * (dt_s / tau2_s) * a2
    else:
        cross = e1 * tau1_s / (tau1_s - tau2_s) * (math.exp(-dt_s / tau1_s) - a2)
    return u + e2 * a2 + cross


class TwoStageStep:
    """:func:`two_stage` for one fixed step ``dt_s``: the exponentials computed once.

    ``apply`` performs the same floating-point operations in the same order as
    :func:`two_stage` (so it returns the same bits), minus the ``exp`` calls.
    """

    __slots__ = ("_a1", "_a2", "_d", "_den", "_kind", "_q", "_tau1")

    def __init__(self, tau1_s: float, tau2_s: float, dt_s: float) -> None:
        self._tau1 = tau1_s
        self._a1 = self._a2 = self._q = self._den = self._d = 0.0
        if tau2_s <= 0.0:  # first_order(x1, u, tau1)
            self._kind = 1 if tau1_s > 0.0 else 0
            if tau1_s > 0.0:
                self._a1 = math.exp(-dt_s / tau1_s)
        elif tau1_s <= 0.0:
            self._kind, self._a2 = 2, math.exp(-dt_s / tau2_s)
        else:
            self._a2 = math.exp(-dt_s / tau2_s)
            if abs(tau1_s - tau2_s) < 1e-12 * max(tau1_s, tau2_s):
                self._kind, self._q = 3, dt_s / tau2_s
            else:
                self._kind, self._den = 4, tau1_s - tau2_s
                self._d = math.exp(-dt_s / tau1_s) - self._a2

    def apply(self, x1_0: float, x2_0: float, u: float) -> float:
        kind = self._kind
        if kind == 4:
            a2 = self._a2
            return u + (x2_0 - u) * a2 + (x1_0 - u) * self._tau1 / self._den * self._d
        if kind == 3:
            a2 = self._a2
            return u + (x2_0 - u) * a2 + (x1_0 - u) * self._q * a2
        if kind == 2:
            return u + (x2_0 - u) * self._a2
        if kind == 1:
            return u + (x1_0 - u) * self._a1
        return u


class NormalStream:
    """Standard normals from ``rng``, drawn ``block`` at a time.

    ``Generator.standard_normal(n)`` yields exactly the values of ``n`` successive
    ``standard_normal()`` calls (one ziggurat draw per value; tests/unit/adc/
    test_fastpath_equivalence.py checks it), so the consumers of a stream see the very
    sequence single draws would give them, at a fraction of the cost. Valid only while
    nothing else draws from ``rng``: the stream runs up to ``block - 1`` values ahead.
    """

    __slots__ = ("_block", "_buf", "_i", "_rng")

    def __init__(self, rng: np.random.Generator, block: int = 64) -> None:
        self._rng = rng
        self._block = block
        self._buf: list[float] = []
        self._i = 0

    def standard_normal(self) -> float:
        i = self._i
        if i >= len(self._buf):
            self._buf = self._rng.standard_normal(self._block).tolist()
            i = 0
        self._i = i + 1
        return self._buf[i]


class OuNoise:
    """First-order low-passed white noise: stationary ``sigma``, correlation time ``tau_s``.

    Advanced exactly: x <- a x + sqrt(1 - a^2) sigma w, a = exp(-dt / tau). With tau 0 each
    new instant is an independent draw. The first value is drawn from the stationary law.
    """

    def __init__(self, sigma: float, tau_s: float, rng: NormalSource) -> None:
        self.sigma = sigma
        self.tau_s = tau_s
        self._rng = rng
        self._x: float | None = None
        self._t_ns = 0

    def at(self, t_ns: int, scale: float = 1.0) -> float:
        """The noise value at ``t_ns`` (times ``scale``); an earlier or equal time reuses it."""
        if self.sigma <= 0.0:
            return 0.0
        if self._x is None:
            self._x = float(self._rng.standard_normal()) * self.sigma
            self._t_ns = t_ns
        elif t_ns > self._t_ns:
            dt_s = (t_ns - self._t_ns) * 1e-9
            a = math.exp(-dt_s / self.tau_s) if self.tau_s > 0.0 else 0.0
            self._x = a * self._x + math.sqrt(1.0 - a * a) * self.sigma * float(self._rng.standard_normal())
            self._t_ns = t_ns
        return self._x * scale


def filtered_noise(sigma: float, tau_sensor_s: float, tau_rc_s: float) -> tuple[float, float]:
    """(sigma, tau) of sensor noise (OU with ``tau_sensor_s``) after a first-order RC.

    Var out / Var in = tau1 / (tau1 + tau2) for two cascaded first-order stages driven by
    white noise; the correlation time is approximated by tau1 + tau2.
    """
    if tau_rc_s <= 0.0 or tau_sensor_s + tau_rc_s <= 0.0:
        return sigma, tau_sensor_s
    return sigma * math.sqrt(tau_sensor_s / (tau_sensor_s + tau_rc_s)), tau_sensor_s + tau_rc_s


def amplify(v_sensor_V: float, cond: ConditioningParams) -> float:
    """The gain stage: reference + gain * (v - offset), clipped to the amplifier's rails."""
    v = cond.reference_V + cond.gain * (v_sensor_V - cond.offset_V)
    return min(max(v, cond.rail_low_V), cond.rail_high_V)


def unamplify(v_pin_V: float, cond: ConditioningParams) -> float:
    """Inverse of :func:`amplify` inside the rails."""
    return cond.offset_V + (v_pin_V - cond.reference_V) / cond.gain
