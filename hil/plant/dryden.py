"""Dryden turbulence (MIL-F-8785C section 3.7, MIL-HDBK-1797 appendix A): linear velocities
and the spatial gradients that make moments, as one linear filter of white noise, sampled
exactly on a fixed sim-time grid.

Frame W ("wind axes"): x along the mean horizontal wind (downwind), y to its right, z down.
The turbulence is frozen in the air and carried past the vehicle at ``V`` (Taylor's
hypothesis), so a spatial derivative along x is ``-(1/V) d/dt``.

Spectra (one-sided PSD over omega in rad/s; the filters are driven by white noise with that
unit PSD, i.e. continuous intensity pi):

* ``u``: ``H_u = sigma_u sqrt(2 L_u / (pi V)) / (1 + (L_u/V) s)``
* ``v``: ``H_v = sigma_v sqrt(L_v / (pi V)) (1 + sqrt(3) (L_v/V) s) / (1 + (L_v/V) s)^2``
  (and ``w`` likewise with ``sigma_w, L_w``). MIL-F-8785C form with L_v = L_u.
* ``dw/dy`` (the spec's ``p_g``): ``sigma_w sqrt(0.8/V) (pi/(4b))^(1/6) / (L_w^(1/3) (1 + (4b/(pi V)) s))``,
  independent noise (b: span, here the rotor-to-rotor width).
* ``dw/dx`` (``q_g``): ``-(s/V) / (1 + (4b/(pi V)) s) * w_g``; ``dv/dx`` (``-r_g``):
  ``-(s/V) / (1 + (3b/(pi V)) s) * v_g``. The minus signs are the convected field's
  (MIL's + is for an aircraft flying forward through still turbulence).

Low-altitude intensities and scale lengths (MIL-F-8785C 3.7.2.3, h in ft, clamped to 10..1000
ft; below 10 ft the 10 ft values are used, as MATLAB's Dryden block does):
``sigma_w = 0.1 W20``, ``sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4``,
``L_w = h``, ``L_u = L_v = h / (0.177 + 0.000823 h)^1.2``; W20 is the mean wind at 20 ft.

State (8): ``u, v1, v2, w1, w2, dw/dy, dw/dx, dv/dx``; outputs (6):
``u, v, w`` (m/s) and ``dv/dx, dw/dx, dw/dy`` (1/s). Discretisation: Van Loan's method
(exact for a held-white-noise-free linear SDE); the initial state is drawn from the
stationary covariance, so statistics hold from the first sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

FT_M = 0.3048
#: MIL-F-8785C low-altitude model range (ft).
H_MIN_FT = 10.0
H_MAX_FT = 1000.0
N_STATES = 8
N_NOISE = 4


@dataclass(frozen=True)
class DrydenIntensity:
    """RMS gust velocities (m/s) and scale lengths (m) at one height."""

    sigma_u_mps: float
    sigma_v_mps: float
    sigma_w_mps: float
    L_u_m: float
    L_v_m: float
    L_w_m: float


def low_altitude_intensity(w20_mps: float, h_m: float) -> DrydenIntensity:
    """MIL-F-8785C low-altitude intensities and scale lengths for a 20 ft wind ``w20_mps``
    at height ``h_m`` above the ground (clamped to 10..1000 ft)."""
    h_ft = min(max(h_m / FT_M, H_MIN_FT), H_MAX_FT)
    k = 0.177 + 0.000823 * h_ft
    sigma_w = 0.1 * w20_mps
    sigma_uv = sigma_w / k**0.4
    l_uv_m = h_ft / k**1.2 * FT_M
    return DrydenIntensity(sigma_uv, sigma_uv, sigma_w, l_uv_m, l_uv_m, h_ft * FT_M)


def continuous_model(i: DrydenIntensity, v_mps: float, span_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C)`` of ``dx/dt = A x + B n``, ``y = C x`` with n white of intensity pi."""
    a = np.zeros((N_STATES, N_STATES))
    b = np.zeros((N_STATES, N_NOISE))
    c = np.zeros((6, N_STATES))
    # u: first order
    tu = i.L_u_m / v_mps
    a[0, 0] = -1.0 / tu
    b[0, 0] = i.sigma_u_mps * math.sqrt(2.0 * i.L_u_m / (math.pi * v_mps)) / tu
    c[0, 0] = 1.0

    def second_order(row: int, noise: int, sigma: float, length: float) -> tuple[np.ndarray, float]:
        # H = K (1 + z s) / (1 + T s)^2 = (K/T^2)(1 + z s) / (s^2 + 2 s / T + 1 / T^2)
        t = length / v_mps
        k = sigma * math.sqrt(length / (math.pi * v_mps))
        a[row, row + 1] = 1.0
        a[row + 1, row] = -1.0 / (t * t)
        a[row + 1, row + 1] = -2.0 / t
        b[row + 1, noise] = 1.0
        out = np.zeros(N_STATES)
        out[row] = k / (t * t)
        out[row + 1] = k / (t * t) * math.sqrt(3.0) * t
        return out, k / (t * t) * math.sqrt(3.0) * t

    cv, dv_gain = second_order(1, 1, i.sigma_v_mps, i.L_v_m)
    cw, dw_gain = second_order(3, 2, i.sigma_w_mps, i.L_w_m)
    c[1] = cv
    c[2] = cw
    # dw/dy (p_g): first order, its own noise
    tp = 4.0 * span_m / (math.pi * v_mps)
    kp = i.sigma_w_mps * math.sqrt(0.8 / v_mps) * (math.pi / (4.0 * span_m)) ** (1.0 / 6.0) / i.L_w_m ** (1.0 / 3.0)
    a[5, 5] = -1.0 / tp
    b[5, 3] = kp / tp
    c[5, 5] = 1.0
    # dw/dx = -(1/V) d/dt w, lagged by tq: x' = (-x - wdot / V) / tq, wdot = cw (A x + B n)
    tq = 4.0 * span_m / (math.pi * v_mps)
    a[6] += -(cw @ a) / (v_mps * tq)
    a[6, 6] += -1.0 / tq
    b[6, 2] = -dw_gain / (v_mps * tq)
    c[4, 6] = 1.0
    # dv/dx = -(1/V) d/dt v, lagged by tr
    tr = 3.0 * span_m / (math.pi * v_mps)
    a[7] += -(cv @ a) / (v_mps * tr)
    a[7, 7] += -1.0 / tr
    b[7, 1] = -dv_gain / (v_mps * tr)
    c[3, 7] = 1.0
    return a, b, c


def expm(m: np.ndarray) -> np.ndarray:
    """Matrix exponential by scaling and squaring with a Taylor series (set-up only)."""
    norm = float(np.max(np.sum(np.abs(m), axis=1)))
    s = max(0, int(math.ceil(math.log2(norm))) + 1) if norm > 0.0 else 0
    x = m / (2.0**s)
    out = np.eye(m.shape[0])
    term = np.eye(m.shape[0])
    for k in range(1, 20):
        term = term @ x / k
        out = out + term
    for _ in range(s):
        out = out @ out
    return out


def discretize(a: np.ndarray, b: np.ndarray, dt_s: float, q: float = math.pi) -> tuple[np.ndarray, np.ndarray]:
    """``(Phi, Qd)``: exact transition and process covariance over ``dt_s`` (Van Loan 1978)."""
    n = a.shape[0]
    m = np.zeros((2 * n, 2 * n))
    m[:n, :n] = -a
    m[:n, n:] = q * b @ b.T
    m[n:, n:] = a.T
    e = expm(m * dt_s)
    phi = e[n:, n:].T
    qd = phi @ e[:n, n:]
    return phi, 0.5 * (qd + qd.T)


def stationary_covariance(a: np.ndarray, b: np.ndarray, q: float = math.pi) -> np.ndarray:
    """``P`` with ``A P + P A^T + q B B^T = 0`` (Kronecker solve; set-up only)."""
    n = a.shape[0]
    eye = np.eye(n)
    lhs = np.kron(eye, a) + np.kron(a, eye)
    p = np.linalg.solve(lhs, -(q * b @ b.T).reshape(-1)).reshape(n, n)
    return 0.5 * (p + p.T)


def psd_sqrt(p: np.ndarray) -> np.ndarray:
    """A square root ``L`` with ``L L^T = p`` for a symmetric PSD matrix (negative rounding
    errors clipped)."""
    w, v = np.linalg.eigh(p)
    return v * np.sqrt(np.clip(w, 0.0, None))


class DrydenFilter:
    """The Dryden state advanced on a grid of ``dt_s`` with deviates from ``rng``.

    ``set_conditions(intensity, V, span)`` (re)builds the discrete model, keeping the state
    (an altitude change moves the scale lengths; the state carries over) and the white-noise
    sequence: grid step k is driven by the k-th 8 deviates of ``rng`` whatever the
    conditions did, so the same seed gives the same noise to two vehicles that fly
    differently (twin runs). ``step()`` advances to the next grid point; ``output()`` gives its
    6 outputs.
    """

    def __init__(self, rng: np.random.Generator, dt_s: float) -> None:
        self._rng = rng
        self._dt_s = dt_s
        self._x: np.ndarray | None = None
        self._phi = np.eye(N_STATES)
        self._l = np.zeros((N_STATES, N_STATES))
        self._c = np.zeros((6, N_STATES))
        #: unit normal deviates, one row per grid step, drawn in blocks; and the same rows
        #: shaped by the current noise gain (``_raw @ L^T``)
        self._raw = np.zeros((0, N_STATES))
        self._noise = np.zeros((0, N_STATES))
        self._next = 0
        self._cache: dict[tuple[float, float, float, float, float, float, float, float], tuple] = {}

    def set_conditions(self, i: DrydenIntensity, v_mps: float, span_m: float) -> None:
        key = (i.sigma_u_mps, i.sigma_v_mps, i.sigma_w_mps, i.L_u_m, i.L_v_m, i.L_w_m, v_mps, span_m)
        if key not in self._cache:
            a, b, c = continuous_model(i, v_mps, span_m)
            phi, qd = discretize(a, b, self._dt_s)
            p = stationary_covariance(a, b)
            self._cache[key] = (phi, psd_sqrt(qd), c, psd_sqrt(p))
        self._phi, self._l, self._c, p_sqrt = self._cache[key]
        if self._x is None:
            self._x = p_sqrt @ self._rng.standard_normal(N_STATES)
        # The deviates already drawn are kept and only re-shaped with the new gain: the k-th
        # grid step always uses the k-th row of the Generator's stream, whenever and however
        # often the conditions change. (Redrawing here made the series depend on the times
        # the vehicle's height crossed a band: twin runs with and without a payload got
        # different turbulence from its sag on, same seed.)
        self._noise = self._raw @ self._l.T

    def output(self) -> list[float]:
        """The 6 outputs at the current grid point."""
        assert self._x is not None
        out: list[float] = (self._c @ self._x).tolist()
        return out

    def step(self) -> None:
        """Advance one grid step."""
        if self._next >= len(self._noise):
            # deviates in blocks, shaped by the noise gain once per block (one matmul)
            self._raw = self._rng.standard_normal((256, N_STATES))
            self._noise = self._raw @ self._l.T
            self._next = 0
        assert self._x is not None  # set by reset()
        self._x = self._phi @ self._x + self._noise[self._next]
        self._next += 1
