"""Value plausibility of IMU samples: what the Xbus checksum cannot promise.

The Xbus checksum is one byte: about 1 in 256 frames corrupted on the wire still matches,
and a bit flipped in a float's exponent turns a 1 deg roll into 1e19 deg or a 0.1 rad/s rate
into 25 rad/s. One such sample fed to the attitude controllers' memories upsets the vehicle.
A sample is refused when a value is not finite, lies beyond what any MTi measures, or moves
further from the last accepted sample than the vehicle can in the time between them:

- Euler angles: |roll|, |yaw| <= 180 deg, |pitch| <= 90 deg; each angle moves at most
  ``MAX_RATE_RADPS`` x the time since the last accepted sample (+ 0.5 deg of noise);
- rates: |p|, |q|, |r| <= ``MAX_RATE_RADPS`` (2000 deg/s, beyond the full scale of the
  MTi gyroscopes); each changes at most ``MAX_ANGULAR_ACCEL_RADPS2`` x that time (+ 0.5 rad/s
  of noise and vibration);
- specific force: each axis <= ``MAX_SPECIFIC_FORCE_MPS2`` (200 m/s^2, about 20 g, beyond
  the full scale of the MTi accelerometers).

The bounds are the sensor's and the airframe's, not the flight's: a 1.1 kg quad-rotor's
torque limits (0.8 N m roll/pitch on a 0.01 kg m^2 inertia) give at most 80 rad/s^2, and
``MAX_ANGULAR_ACCEL_RADPS2`` allows more than ten times that.
"""

from __future__ import annotations

import math

_DEG = math.pi / 180.0
#: no MTi measures faster rotation (rad/s)
MAX_RATE_RADPS = 2000.0 * _DEG
#: more than ten times what the airframe's torque can produce (rad/s^2)
MAX_ANGULAR_ACCEL_RADPS2 = 1000.0
#: no MTi measures more specific force on one axis (m/s^2)
MAX_SPECIFIC_FORCE_MPS2 = 200.0
_ANGLE_NOISE_RAD = 0.5 * _DEG
_RATE_NOISE_RADPS = 0.5
_ANGLE_LIMITS_RAD = (math.pi, math.pi / 2.0, math.pi)


def _wrapped(a: float) -> float:
    """``a`` wrapped into [-pi, pi), rad."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def implausible(euler_rad: tuple[float, float, float], omega_B_radps: tuple[float, float, float],
                f_B_mps2: tuple[float, float, float],
                last: tuple[tuple[float, float, float], tuple[float, float, float]] | None, dt_s: float) -> str | None:
    """Why the sample cannot be true (a short reason), or None when it can.

    ``last`` is the last accepted sample's (euler_rad, omega_B_radps), None for the first;
    ``dt_s`` the time since it, s.
    """
    values = (*euler_rad, *omega_B_radps, *f_B_mps2)
    if not all(math.isfinite(v) for v in values):
        return "not finite"
    if any(abs(a) > lim for a, lim in zip(euler_rad, _ANGLE_LIMITS_RAD)):
        return "angle out of range"
    if any(abs(w) > MAX_RATE_RADPS for w in omega_B_radps):
        return "rate out of range"
    if any(abs(f) > MAX_SPECIFIC_FORCE_MPS2 for f in f_B_mps2):
        return "specific force out of range"
    if last is None:
        return None
    last_euler, last_omega = last
    max_turn = MAX_RATE_RADPS * dt_s + _ANGLE_NOISE_RAD
    if any(abs(_wrapped(a - b)) > max_turn for a, b in zip(euler_rad, last_euler)):
        return "angle jump"
    max_change = MAX_ANGULAR_ACCEL_RADPS2 * dt_s + _RATE_NOISE_RADPS
    if any(abs(w - v) > max_change for w, v in zip(omega_B_radps, last_omega)):
        return "rate jump"
    return None
