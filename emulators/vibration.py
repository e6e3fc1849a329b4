"""Vibration tones through a sensor's frequency response, evaluated at its sample instants.

Input (physics in): tones, each a sinusoid per axis of known angular frequency and phase,

    v(t) = Re{(re + j im) e^(j phi)},   phi = phase_rad + omega_radps (t - t_ref)

(the plant's ``VibrationTone``; any object with those four attributes will do). A linear
time-invariant sensor stage H(s) answers a sinusoid, once its transient has died out, with
the same sinusoid scaled by |H(j omega)| and shifted by arg H(j omega). So the output of a
sensor is the sum of ``Re{H(j omega) (re + j im) e^(j phi(t))}`` over the tones, exactly,
with no integration at a high rate; evaluated at the instant the sensor is sampled it is
what a real sampled sensor reads, aliasing included (a 97 Hz tone sampled at 50 Hz shows up
at 3 Hz, as it would on the vehicle). Quasi-steady: the rotor speed changes over tens of
ms, slower than the filters settle (3.2 ms for the ADXL335's 50 Hz pole).

Responses (all H(0) = 1):

* :func:`first_order`: a single pole at the -3 dB frequency (an RC: the ADXL335's output
  filter, 32 kOhm with its external capacitor);
* :func:`butterworth2`: two poles, -3 dB at the given frequency;
* :func:`window_average`: the mean over the preceding window T (integrate and dump, as a
  strapdown-integrating IMU's per-sample output): (1 - e^(-j omega T)) / (j omega T).

The complex functions above are the reference. The devices evaluate the same responses
per sample with the ``*_ri`` functions and :func:`sensed_tones`, which carry a complex number
as a (real, imaginary) pair of floats: compiled (setup.py), a float pair is native
arithmetic while a ``complex`` is a boxed object and a closure an allocation per call
(tests/unit/vibration/test_float_pairs.py holds the two to the same values).

Pure functions of their arguments; no I/O, no clock.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Iterable, Sequence
from typing import Protocol

Vec3 = tuple[float, float, float]
ZERO3: Vec3 = (0.0, 0.0, 0.0)


class Tone(Protocol):
    """A sinusoid per axis: see the module docstring (units and axes are the caller's)."""

    @property
    def omega_radps(self) -> float: ...
    @property
    def phase_rad(self) -> float: ...
    @property
    def re(self) -> Sequence[float]: ...
    @property
    def im(self) -> Sequence[float]: ...


def first_order(omega_radps: float, f3db_Hz: float) -> complex:
    """H(j omega) = 1 / (1 + j omega / omega_c) of a single pole at ``f3db_Hz`` (<= 0 or
    infinite: no filter, 1)."""
    if not (0.0 < f3db_Hz < math.inf):
        return 1.0 + 0.0j
    return 1.0 / complex(1.0, omega_radps / (2.0 * math.pi * f3db_Hz))


def butterworth2(omega_radps: float, f3db_Hz: float) -> complex:
    """H(j omega) = 1 / (1 - x^2 + j sqrt(2) x), x = omega / omega_c: second-order
    Butterworth, -3 dB at ``f3db_Hz`` (<= 0 or infinite: no filter, 1)."""
    if not (0.0 < f3db_Hz < math.inf):
        return 1.0 + 0.0j
    x = omega_radps / (2.0 * math.pi * f3db_Hz)
    return 1.0 / complex(1.0 - x * x, math.sqrt(2.0) * x)


def lowpass(omega_radps: float, f3db_Hz: float, order: int) -> complex:
    """:func:`first_order` (order 1) or :func:`butterworth2` (order 2)."""
    if order == 1:
        return first_order(omega_radps, f3db_Hz)
    if order == 2:
        return butterworth2(omega_radps, f3db_Hz)
    raise ValueError(f"order must be 1 or 2, got {order}")


def window_average(omega_radps: float, window_s: float) -> complex:
    """H(j omega) of the mean over the preceding ``window_s``: (1 - e^(-j w T)) / (j w T);
    zero at multiples of 1/T, |H| = |sinc(w T / 2)|, a delay of T/2."""
    x = omega_radps * window_s
    if abs(x) < 1e-9:
        return 1.0 + 0.0j
    return (1.0 - cmath.exp(-1j * x)) / (1j * x)


def tone_value(tone: Tone, h: complex, dt_s: float) -> Vec3:
    """One tone through response ``h`` (its H(j omega)) at ``dt_s`` after the tone's reference
    time: Re{h (re + j im) e^(j (phase + omega dt))}, per axis."""
    return tone_value_ri(tone, h.real, h.imag, dt_s)


def tone_value_ri(tone: Tone, hr: float, hi: float, dt_s: float) -> Vec3:
    """:func:`tone_value` with the response as ``hr + j hi``."""
    phi = tone.phase_rad + tone.omega_radps * dt_s
    c, s = math.cos(phi), math.sin(phi)
    re, im = tone.re, tone.im
    # Re{(hr + j hi)(a + j b)(c + j s)} with (a + j b) one axis' amplitude
    return (
        (hr * re[0] - hi * im[0]) * c - (hr * im[0] + hi * re[0]) * s,
        (hr * re[1] - hi * im[1]) * c - (hr * im[1] + hi * re[1]) * s,
        (hr * re[2] - hi * im[2]) * c - (hr * im[2] + hi * re[2]) * s,
    )


def lowpass_ri(omega_radps: float, f3db_Hz: float, order: int) -> tuple[float, float]:
    """:func:`lowpass` as (real, imaginary): 1 / (p + j q) with p + j q the denominator of
    :func:`first_order` (order 1) or :func:`butterworth2` (order 2)."""
    if order not in (1, 2):
        raise ValueError(f"order must be 1 or 2, got {order}")
    if not (0.0 < f3db_Hz < math.inf):
        return 1.0, 0.0
    x = omega_radps / (2.0 * math.pi * f3db_Hz)
    if order == 1:
        p, q = 1.0, x
    else:
        p, q = 1.0 - x * x, math.sqrt(2.0) * x
    n = p * p + q * q
    return p / n, -q / n


def window_average_ri(omega_radps: float, window_s: float) -> tuple[float, float]:
    """:func:`window_average` as (real, imaginary): (1 - e^(-j x)) / (j x) =
    sin(x) / x + j (cos(x) - 1) / x, x = omega T."""
    x = omega_radps * window_s
    if abs(x) < 1e-9:
        return 1.0, 0.0
    return math.sin(x) / x, (math.cos(x) - 1.0) / x


def sensed_tones(tones: Iterable[Tone], f3db_Hz: float, order: int, window_s: float, dt_s: float) -> Vec3:
    """Sum of ``tones`` through :func:`lowpass_ri` (``f3db_Hz``, ``order``) times
    :func:`window_average_ri` (``window_s``; 0: none) at ``dt_s`` after their reference
    time, per axis: what a sensor with that bandwidth and averaging reads."""
    x = y = z = 0.0
    for tone in tones:
        w = tone.omega_radps
        lr, li = lowpass_ri(w, f3db_Hz, order)
        ar, ai = window_average_ri(w, window_s)
        vx, vy, vz = tone_value_ri(tone, lr * ar - li * ai, lr * ai + li * ar, dt_s)
        x += vx
        y += vy
        z += vz
    return (x, y, z)
