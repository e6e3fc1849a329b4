"""Third-order critically damped reference prefilter (stick command -> smooth reference).

The memory attitude controller needs the reference and its first three derivatives
(phi*, phi*', phi*'', phi*''') for the eta feed-forward with the actuator-lag lead
(docs/controllers.md 2.5 item 4). The stick command is passed through

    G(s) = omega^3 / (s + omega)^3

realised in phase-variable form x = [y, y', y''] and discretised exactly (zero-order hold on
the command) with ZOH (``design.zoh``, what ``control.c2d`` computes) at construction. The triple real pole gives a monotone step
response (no overshoot). The filter is unit-agnostic: angles in rad give rad, rad/s, rad/s^2,
rad/s^3; altitude in m gives m, m/s, m/s^2, m/s^3 (the field names say rad because the
attitude loop is the main user).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flightcode.control.design import zoh


@dataclass(frozen=True)
class RefState:
    """Reference sample: value, and its first three time derivatives (see module docstring)."""

    angle_rad: float
    rate_radps: float
    acc_radps2: float
    jerk_radps3: float


class Prefilter3:
    """Critically damped third-order prefilter omega^3/(s+omega)^3 at sample period ``T_s``.

    Args:
        omega_radps: pole (bandwidth) in rad/s; docs/controllers.md 2.5 recommends about 8 rad/s for
            the attitude sticks.
        T_s: sample period in s (0.0025 at 400 Hz).

    Per call cost is a handful of float multiplications (the 3x3 ZOH matrices are kept as
    Python floats, no numpy on the tick path).
    """

    def __init__(self, omega_radps: float = 8.0, T_s: float = 0.0025) -> None:
        if not (omega_radps > 0.0 and math.isfinite(omega_radps)):
            raise ValueError(f"omega_radps must be > 0, got {omega_radps}")
        if not (T_s > 0.0 and math.isfinite(T_s)):
            raise ValueError(f"T_s must be > 0, got {T_s}")
        self.omega_radps = float(omega_radps)
        self.T_s = float(T_s)
        w = self.omega_radps
        a = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-(w**3), -3.0 * w**2, -3.0 * w]])
        b = np.array([[0.0], [0.0], [w**3]])
        a_d, b_d = zoh(a, b, self.T_s)
        # Unrolled to plain floats: the tick path stays in scalar Python arithmetic.
        rows = np.asarray(a_d, dtype=float).tolist()
        (self._a00, self._a01, self._a02) = rows[0]
        (self._a10, self._a11, self._a12) = rows[1]
        (self._a20, self._a21, self._a22) = rows[2]
        self._b0, self._b1, self._b2 = np.asarray(b_d, dtype=float).ravel().tolist()
        self._w3 = w**3
        self._c1 = 3.0 * w**2
        self._c2 = 3.0 * w
        self._y = 0.0
        self._yd = 0.0
        self._ydd = 0.0
        self._cmd = 0.0

    def reset(self, value: float = 0.0) -> RefState:
        """Settle the filter at ``value`` (all derivatives zero); returns that state."""
        self._y = float(value)
        self._yd = 0.0
        self._ydd = 0.0
        self._cmd = self._y
        return RefState(self._y, 0.0, 0.0, 0.0)

    def update(self, cmd: float) -> RefState:
        """Advance one sample with the command ``cmd`` held over it; return the new reference.

        The jerk is the exact third derivative at the new sample for the held command. A
        non-finite command (a driver fault) is ignored: the last finite command is held, so
        the filter state never turns into NaN.
        """
        if not math.isfinite(cmd):
            cmd = self._cmd
        self._cmd = cmd
        y, yd, ydd = self._y, self._yd, self._ydd
        self._y = self._a00 * y + self._a01 * yd + self._a02 * ydd + self._b0 * cmd
        self._yd = self._a10 * y + self._a11 * yd + self._a12 * ydd + self._b1 * cmd
        self._ydd = self._a20 * y + self._a21 * yd + self._a22 * ydd + self._b2 * cmd
        jerk = self._w3 * (cmd - self._y) - self._c1 * self._yd - self._c2 * self._ydd
        return RefState(self._y, self._yd, self._ydd, jerk)
