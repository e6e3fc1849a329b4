"""Landing: the descent setpoint and the hover collective a touchdown is judged against.

A landing is flown as a descent at a fixed rate that does not stop at the estimated ground
level: the altitude estimate near the ground is only as good as the barometer in rotor wash
(it reads low, on the bench by up to 0.9 m) and the accelerometer's integral, so a setpoint
that stops at "0 m" can leave the vehicle hovering on its ground cushion a few decimetres up
(fault-rc-loss on the bench: 0.19 m, estimate -0.04 m), and a landing declared there drops
it. A setpoint that keeps going down flies it onto the ground whatever the estimate says
(the LQI tracks the ramp, lagging ~0.8 m behind it at 0.5 m/s); on the ground the altitude
loop's integrator then winds the collective down, and that is what the touchdown test in
:mod:`flightcode.modes` looks for: the vehicle standing still with a collective that could
not hold it in the air.

:class:`HoverThrottle` learns the collective that holds the vehicle in steady flight clear
of the ground (payload, battery, a wrong ``vehicle.m_kg`` all move it), so "could not hold
it" is judged against the vehicle as it is.
"""

from __future__ import annotations

import math


class LandingDescent:
    """Altitude setpoint of a landing: from where the vehicle is, down at ``rate_mps``, no floor.

    Args:
        rate_mps: descent rate, m/s (> 0).
    """

    def __init__(self, rate_mps: float) -> None:
        if not (math.isfinite(rate_mps) and rate_mps > 0.0):
            raise ValueError(f"rate_mps must be finite and > 0, got {rate_mps}")
        self.rate_mps = rate_mps
        #: Current setpoint, m (z up; goes below the take-off level until the landing is confirmed).
        self.z_m = 0.0
        #: True between :meth:`start` and :meth:`stop`.
        self.active = False

    def start(self, z_m: float) -> None:
        """Begin the descent at ``z_m`` (m): the lower of the last setpoint and the estimate."""
        self.z_m = z_m
        self.active = True

    def stop(self) -> None:
        self.active = False

    def step(self, dt_s: float) -> float:
        """Advance by ``dt_s`` (s) of sensor time; returns the setpoint, m."""
        self.z_m -= self.rate_mps * dt_s
        return self.z_m


#: Time constant of the low-pass on the measured vertical acceleration for the touchdown
#: test, s (the XSENS's; long enough to average vibration, short next to landed_s).
ACCEL_LP_TAU_S = 0.1

#: Steady flight for :meth:`HoverThrottle.steady`: |vz| below this, m/s...
STEADY_VZ_MPS = 0.3
#: ...and |vertical acceleration| below this, m/s^2.
STEADY_AZ_MPS2 = 0.5


class HoverThrottle:
    """Exponential average of the collective throttle over steady flight (unit throttle).

    Args:
        initial: the model's hover throttle ``sqrt(m g / F_max)``, used until flight teaches better.
        tau_s: averaging time constant, s of sensor time.
        lo, hi: the learnt value is kept within [lo, hi] (a sanity bound around the model).
    """

    def __init__(self, initial: float, tau_s: float = 2.0, lo: float = 0.0, hi: float = 1.0) -> None:
        if not (0.0 < initial < 1.0):
            raise ValueError(f"initial hover throttle must be in (0, 1), got {initial}")
        if not (math.isfinite(tau_s) and tau_s > 0.0):
            raise ValueError(f"tau_s must be finite and > 0, got {tau_s}")
        self.initial = initial
        self.tau_s = tau_s
        self.lo, self.hi = lo, hi
        #: The current estimate, unit throttle.
        self.collective = initial
        #: Sensor seconds of steady flight averaged so far.
        self.learnt_s = 0.0

    @staticmethod
    def steady(z_hat_m: float, vz_hat_mps: float, az_hat_mps2: float, clear_of_ground_m: float) -> bool:
        """True when the estimate says the vehicle holds its height above ``clear_of_ground_m``
        (m; ground effect below it lowers the collective a hover needs)."""
        return z_hat_m > clear_of_ground_m and abs(vz_hat_mps) < STEADY_VZ_MPS and abs(az_hat_mps2) < STEADY_AZ_MPS2

    def update(self, collective: float, dt_s: float) -> float:
        """Average one sample of steady flight (the caller decides what is steady); returns the estimate."""
        if math.isfinite(collective) and dt_s > 0.0:
            alpha = dt_s / (self.tau_s + dt_s)
            c = self.collective + alpha * (collective - self.collective)
            self.collective = min(max(c, self.lo), self.hi)
            self.learnt_s += dt_s
        return self.collective
