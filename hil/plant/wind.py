"""Wind in NED: mean + turbulence + steps and gusts, all in sim time.

Theory of operation. With ``dryden`` on, the turbulence is the Dryden model of dryden.py:
velocities and the spatial gradients (rotational gusts) in wind axes, turned into NED by the
mean wind's heading, advanced exactly on the ``update_period_ns`` grid; the intensities and
scale lengths follow the vehicle's height (``at(t_ns, h_m)``), re-evaluated when the height
leaves a 5 % band. ``gradient_N`` is the NED Jacobian d(wind)/d(position) at the last grid
point (1/s, row = wind component): the plant turns it into per-rotor gust differences.

Otherwise the turbulence is three independent first-order Gauss-Markov
(Ornstein-Uhlenbeck) processes, one per NED axis, with RMS ``sigma_i`` and correlation
time ``tau_i = L_i / V`` (Dryden's longitudinal spectrum, Taylor's frozen turbulence blown
past the vehicle at the mean wind speed V). They are advanced exactly,
``x <- a x + sigma sqrt(1 - a^2) n`` with ``a = exp(-dt / tau)``, on a fixed sim-time grid of
``update_period_ns`` counted from ``t0_ns``, and held between grid points. Because the grid
does not depend on how often ``at()`` is called, the same seed gives the same series
whatever the caller's step sizes. Normal deviates are drawn from the injected Generator in
blocks (cheaper than per-sample calls).

Steps and gusts are deterministic profiles added on top: ``add_step`` (constant from a
start time, optionally until an end time) and ``add_gust`` (step or 1-cosine over a
duration). Each returns a handle for ``remove``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil.plant.dryden import DrydenFilter, low_altitude_intensity
from hil.plant.params_environment import GustParams, GustShape, WindParams

Vec3 = tuple[float, float, float]

#: Normal deviates drawn per block (3 per grid point).
_BLOCK = 1024
#: The Dryden filter is rebuilt when the height leaves a band this wide (log ratio).
_HEIGHT_BAND = math.log(1.05)
Mat3Flat = tuple[float, float, float, float, float, float, float, float, float]
ZERO_GRADIENT: Mat3Flat = (0.0,) * 9  # type: ignore[assignment]


@dataclass(frozen=True)
class _Profile:
    start_t_ns: int
    end_t_ns: int | None
    peak_N_mps: Vec3
    shape: GustShape


class WindModel:
    """The wind field at the vehicle (uniform in space), NED, m/s."""

    def __init__(self, params: WindParams, rng: np.random.Generator, *, t0_ns: int = 0) -> None:
        self.params = params
        self._rng = rng
        self._mean: Vec3 = params.mean_N_mps
        self._sigma: Vec3 = params.turbulence_sigma_N_mps
        self._period_ns = params.update_period_ns
        self._turbulent = any(s > 0.0 for s in self._sigma)
        v_mean = max(math.hypot(self._mean[0], self._mean[1]), params.turbulence_min_speed_mps)
        dt_s = self._period_ns * 1e-9
        a = [math.exp(-dt_s * v_mean / length) for length in params.turbulence_length_m]
        self._a = tuple(a)
        self._b = tuple(s * math.sqrt(1.0 - ai * ai) for s, ai in zip(self._sigma, a, strict=True))
        self._normals: list[list[float]] = []
        self._next_normal = 0
        self._grid_t_ns = t0_ns
        self._turb: list[float] = [0.0, 0.0, 0.0]
        if self._turbulent:
            # Start in the stationary distribution so statistics hold from t0.
            n = self._draw()
            self._turb = [s * ni for s, ni in zip(self._sigma, n, strict=True)]
        self._dryden: DrydenFilter | None = None
        self._gradient_N: Mat3Flat = ZERO_GRADIENT
        if params.dryden:
            self._setup_dryden(v_mean, dt_s)
        self._profiles: dict[int, _Profile] = {}
        self._next_handle = 1
        for gust in params.gusts:
            self.add_gust(gust.peak_N_mps, gust.start_t_ns, gust.duration_ns, gust.shape)

    # -- Dryden ----------------------------------------------------------------------------
    def _setup_dryden(self, v_mean: float, dt_s: float) -> None:
        p = self.params
        m = self._mean
        self._w20 = math.hypot(m[0], m[1]) if p.dryden_w20_mps is None else p.dryden_w20_mps
        self._v_conv = v_mean
        heading = math.atan2(m[1], m[0]) if (m[0] or m[1]) else 0.0
        self._cos_h, self._sin_h = math.cos(heading), math.sin(heading)
        self._dryden = DrydenFilter(self._rng, dt_s)
        self._band = -1_000_000
        self._set_height(0.0)
        self._turb = self._dryden_outputs()

    def _set_height(self, h_m: float) -> None:
        assert self._dryden is not None
        band = int(math.floor(math.log(max(h_m, 0.1)) / _HEIGHT_BAND))
        if band == self._band:
            return
        self._band = band
        h_band_m = math.exp((band + 0.5) * _HEIGHT_BAND)
        self._dryden.set_conditions(
            low_altitude_intensity(self._w20, h_band_m), self._v_conv, self.params.dryden_span_m
        )

    def _dryden_outputs(self) -> list[float]:
        assert self._dryden is not None
        u, v, w, dv_dx, dw_dx, dw_dy = self._dryden.output()
        c, s = self._cos_h, self._sin_h
        if self.params.dryden_gradients:
            # G_N = R_NW G_W R_NW^T with G_W[v][x] = dv/dx, G_W[w][x] = dw/dx, G_W[w][y] = dw/dy
            # and R_NW a rotation about down by the heading.
            gvx = dv_dx
            self._gradient_N = (
                -s * c * gvx, -s * s * gvx, 0.0,
                c * c * gvx, c * s * gvx, 0.0,
                c * dw_dx - s * dw_dy, s * dw_dx + c * dw_dy, 0.0,
            )  # fmt: skip
        return [c * u - s * v, s * u + c * v, w]

    @property
    def gradient_N(self) -> Mat3Flat:
        """d(wind_N)/d(p_N) at the last grid point, row-major (1/s); zero without Dryden gradients."""
        return self._gradient_N

    # -- turbulence ------------------------------------------------------------------------
    def _draw(self) -> list[float]:
        if self._next_normal >= len(self._normals):
            self._normals = self._rng.standard_normal((_BLOCK, 3)).tolist()
            self._next_normal = 0
        n = self._normals[self._next_normal]
        self._next_normal += 1
        return n

    def _advance(self, t_ns: int) -> None:
        if self._dryden is not None:
            stepped = False
            while self._grid_t_ns + self._period_ns <= t_ns:
                self._dryden.step()
                self._grid_t_ns += self._period_ns
                stepped = True
            if stepped:
                self._turb = self._dryden_outputs()
            return
        if not self._turbulent:
            return
        a0, a1, a2 = self._a
        b0, b1, b2 = self._b
        x0, x1, x2 = self._turb
        while self._grid_t_ns + self._period_ns <= t_ns:
            n0, n1, n2 = self._draw()
            x0 = a0 * x0 + b0 * n0
            x1 = a1 * x1 + b1 * n1
            x2 = a2 * x2 + b2 * n2
            self._grid_t_ns += self._period_ns
        self._turb = [x0, x1, x2]

    @property
    def turbulence_N_mps(self) -> Vec3:
        """The turbulent part at the last grid point reached."""
        return (self._turb[0], self._turb[1], self._turb[2])

    # -- profiles --------------------------------------------------------------------------
    def add_step(self, wind_N_mps: Vec3, start_t_ns: int, until_t_ns: int | None = None) -> int:
        """Add a constant wind from ``start_t_ns`` (until ``until_t_ns``, exclusive, if given)."""
        if until_t_ns is not None and until_t_ns <= start_t_ns:
            raise ValueError("until_t_ns must be after start_t_ns")
        return self._add(_Profile(start_t_ns, until_t_ns, _vec3(wind_N_mps), GustShape.STEP))

    def add_gust(
        self,
        peak_N_mps: Vec3,
        start_t_ns: int,
        duration_ns: int,
        shape: GustShape = GustShape.ONE_MINUS_COSINE,
    ) -> int:
        """Add a gust of ``shape`` over [start, start + duration) (see GustShape)."""
        GustParams(_vec3(peak_N_mps), start_t_ns, duration_ns, shape)  # validates
        return self._add(_Profile(start_t_ns, start_t_ns + duration_ns, _vec3(peak_N_mps), GustShape(shape)))

    def remove(self, handle: int) -> None:
        """Remove a step or gust; an unknown handle raises KeyError (our misuse)."""
        del self._profiles[handle]

    def _add(self, profile: _Profile) -> int:
        handle = self._next_handle
        self._next_handle += 1
        self._profiles[handle] = profile
        return handle

    def profiles_N_mps(self, t_ns: int) -> Vec3:
        """Sum of the deterministic steps and gusts at ``t_ns``."""
        wx = wy = wz = 0.0
        for p in self._profiles.values():
            if t_ns < p.start_t_ns or (p.end_t_ns is not None and t_ns >= p.end_t_ns):
                continue
            if p.shape is GustShape.STEP:
                k = 1.0
            else:
                assert p.end_t_ns is not None
                k = 0.5 * (1.0 - math.cos(2.0 * math.pi * (t_ns - p.start_t_ns) / (p.end_t_ns - p.start_t_ns)))
            wx += k * p.peak_N_mps[0]
            wy += k * p.peak_N_mps[1]
            wz += k * p.peak_N_mps[2]
        return (wx, wy, wz)

    # -- total -----------------------------------------------------------------------------
    def at(self, t_ns: int, h_m: float | None = None) -> Vec3:
        """Total wind (NED, m/s) at ``t_ns``. Call with non-decreasing times. ``h_m``: the
        vehicle's height above the ground (m), for the Dryden scale lengths."""
        if h_m is not None and self._dryden is not None:
            self._set_height(h_m)
        self._advance(t_ns)
        px, py, pz = self.profiles_N_mps(t_ns) if self._profiles else (0.0, 0.0, 0.0)
        m = self._mean
        t = self._turb
        return (m[0] + t[0] + px, m[1] + t[1] + py, m[2] + t[2] + pz)


def _vec3(v: tuple[float, ...] | list[float]) -> Vec3:
    if len(v) != 3 or not all(math.isfinite(float(x)) for x in v):
        raise ValueError(f"need 3 finite components, got {v!r}")
    return (float(v[0]), float(v[1]), float(v[2]))
