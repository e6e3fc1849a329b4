"""Altitude Kalman filter: barometer + vertical accelerometer + thrust model (docs/controllers.md 3.5).

States (z up), continuous time::

    x = [z m, z' m/s, a m/s^2, d m/s^2, b m/s^2]
    z'  = z'
    z'' = a + d
    a'  = (-a + (k/m) u) / T1 + w_a        a: thrust-deviation acceleration, u = d_throttle - d_h
    d'  = w_d                              d: slow vertical disturbance (payload, ground effect)
    b'  = w_b                              b: accelerometer bias
    y   = [z_baro, a_up] = [z, a + d + b] + noise

``a_up`` is the vertical specific force minus g, i.e. the measured vertical acceleration, up
positive: a_up = -(R_NB f_B)_z - g with f_B the FRD specific force (the loop computes it tilt
compensated). The d state is needed: without it a constant throttle offset (payload) would be
mistaken for accelerometer bias.

Barometer outliers (a gust on the static port, a corrupted ADC code) are rejected by an
innovation gate: a reading whose squared innovation exceeds ``baro_gate_chi2`` times its
innovation variance S = P_zz + R (a chi-square test with one degree of freedom; 25 = 5 sigma,
a false rejection every ~1.7 million Gaussian readings) is not fused and is counted in
``counters["baro_rejected"]``. A disagreement that lasts ``baro_gate_timeout_s`` is not an
outlier any more (the estimate, not the barometer, is what went wrong, or the barometer
really moved): the height is then re-anchored to the reading (its variance loosened to the
squared innovation, so the update puts it there) and ``counters["baro_reanchored"]`` counts it.

On the ground (motors not under control) the vehicle is at rest: :meth:`update_at_rest`
adds a zero-velocity pseudo-measurement (z' = 0, variance ``r_rest_vz``), so an accelerometer
offset is learnt as bias b instead of being integrated into a fall (what made the estimate sink
to -0.5..-1.5 m while disarmed); the height itself is still the barometer's.

Discretisation at T_s: F, B by ZOH on u (``design.zoh``, what ``control.c2d`` computes); Q by Van Loan from the white-noise
PSDs (q_a, q_d, q_b) (``design.van_loan``, what ``filterpy.common.van_loan_discretization``
computes). :attr:`AltitudeKF.kf` holds the design (F, B, H, Q, R) in a
``filterpy.kalman.KalmanFilter``, built when first asked for: importing filterpy costs the
flight code about a second at start-up (design.py), and the flight needs only the fast
path. The per-sample arithmetic is the
same filter done in place on preallocated arrays: R is diagonal, so the measurements are
applied one scalar at a time (exactly the joint update), each a rank-one covariance update
without a matrix inverse; P is re-symmetrised every predict. That is about 3x cheaper than
filterpy's general predict/update (which allocates and inverts per call) and is tested
against it (tests/unit/flightcode/estimation/test_altitude_kf.py).
"""

from __future__ import annotations

import math
from collections import Counter
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from flightcode.control.design import van_loan, zoh
from flightcode.control.lqi_altitude import AltitudeModel

if TYPE_CHECKING:
    from filterpy.kalman import KalmanFilter

#: Initial variances [z m^2, z' (m/s)^2, a (m/s^2)^2, d (m/s^2)^2, b (m/s^2)^2] after reset:
#: z as uncertain as one baro reading (filled in from r_baro_m2), the vehicle at rest (small
#: z' and a), a payload / thrust mismatch of up to ~1 m/s^2 (d), an ADXL335 zero-g offset of
#: ~0.5 m/s^2 (b).
P0_DIAG_REST = (None, 0.01, 0.01, 1.0, 0.25)


class AltitudeKF:
    """400 Hz altitude estimator. Call :meth:`predict` then :meth:`update` once per tick.

    Args:
        model: vertical model (k/m and T1 drive the a state).
        T_s: tick period, s.
        q_a, q_d, q_b: continuous white-noise PSDs on a', d', b', (m/s^3)^2/Hz.
        r_baro_m2: barometric altitude noise variance, m^2 (default: the paper's chain without
            the x16 stage, 0.5 mV + quantisation; the flight config sets the vehicle's).
        r_acc: vertical acceleration noise variance, (m/s^2)^2 (vibration + ADXL noise + LSB;
            docs/controllers.md 3.5 budgets 0.3 m/s^2). Checked against the bench's rotor-imbalance
            vibration (docs/vibration.md): it adds 0.02-0.03 m/s^2 RMS at 96 Hz to the vertical
            acceleration, and the altitude-step estimate error stays 0.07-0.11 m (0.07-0.11
            without it), also at 30x the imbalance: unchanged.
        r_rest_vz: variance of the zero-velocity pseudo-measurement at rest, (m/s)^2.
        baro_gate_chi2: a barometer reading with innovation^2 > this x S is rejected (an
            outlier); ``math.inf`` (the default) fuses every reading.
        baro_gate_timeout_s: consecutive rejections lasting this long re-anchor the height to
            the barometer, s.
    """

    def __init__(
        self,
        model: AltitudeModel,
        T_s: float = 0.0025,
        q_a: float = 2.0,
        q_d: float = 0.05,
        q_b: float = 1e-6,
        r_baro_m2: float = 1.28,
        r_acc: float = 0.091,
        r_rest_vz: float = 0.0025,
        baro_gate_chi2: float = math.inf,
        baro_gate_timeout_s: float = 1.0,
    ) -> None:
        if not (math.isfinite(T_s) and T_s > 0.0):
            raise ValueError(f"T_s must be finite and > 0, got {T_s}")
        for name, value in (("q_a", q_a), ("q_d", q_d), ("q_b", q_b)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        for name, value in (("r_baro_m2", r_baro_m2), ("r_acc", r_acc), ("r_rest_vz", r_rest_vz)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        if not baro_gate_chi2 > 0.0:  # inf allowed: no gate
            raise ValueError(f"baro_gate_chi2 must be > 0, got {baro_gate_chi2}")
        if not (math.isfinite(baro_gate_timeout_s) and baro_gate_timeout_s >= 0.0):
            raise ValueError(f"baro_gate_timeout_s must be finite and >= 0, got {baro_gate_timeout_s}")
        self.model = model
        self.T_s = float(T_s)
        a_c, b_c = self.continuous_model(model)
        h = np.array([[1.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 1.0, 1.0]])
        a_d, b_d = zoh(a_c, b_c, self.T_s)
        g = np.diag([0.0, 0.0, math.sqrt(q_a), math.sqrt(q_d), math.sqrt(q_b)])
        _, q_d_matrix = van_loan(a_c, g, self.T_s)
        #: The design: F (5, 5), B (5, 1), H (2, 5), Q (5, 5), R (2, 2), for a T_s period
        #: (contiguous: the per-sample products read F and Q as they are).
        self.F = np.array(a_d, dtype=float)
        self.B = np.asarray(b_d, dtype=float)
        self.H = h
        # Symmetrise: Van Loan's product is symmetric only to rounding.
        self.Q = 0.5 * (q_d_matrix + q_d_matrix.T)
        self.R = np.diag([float(r_baro_m2), float(r_acc)])
        self.r_baro_m2 = float(r_baro_m2)
        self.r_acc = float(r_acc)
        self.r_rest_vz = float(r_rest_vz)
        self.baro_gate_chi2 = float(baro_gate_chi2)
        #: Consecutive rejected readings after which the height is re-anchored to the barometer.
        self.baro_gate_max_rejects = max(1, round(baro_gate_timeout_s / self.T_s))
        #: Barometer readings rejected in a row so far (0 after any accepted reading).
        self.baro_reject_run = 0
        self._p0 = np.diag([float(r_baro_m2)] + [float(v) for v in P0_DIAG_REST[1:]])
        # Per-sample working arrays (no allocation on the tick path).
        self._Ft = np.array(self.F.T)
        self._B = np.array(self.B[:, 0])
        self._x = np.zeros(5)
        self._x_next = np.zeros(5)
        self._v5 = np.zeros(5)
        self._ph = np.zeros(5)
        self._k = np.zeros(5)
        self._P = np.zeros((5, 5))
        self._m55 = np.zeros((5, 5))
        #: Non-finite inputs seen (treated as missing measurements / zero input), barometer
        #: readings rejected by the gate and re-anchors after a long rejection.
        self.counters: Counter[str] = Counter()
        self.reset(0.0)

    @cached_property
    def kf(self) -> KalmanFilter:
        """The design (F, B, H, Q, R) in filterpy's filter, the reference of the fast path
        (its own copies: stepping it leaves this filter alone)."""
        from filterpy.kalman import KalmanFilter

        kf = KalmanFilter(dim_x=5, dim_z=2, dim_u=1)
        kf.F, kf.B, kf.H, kf.Q, kf.R = (np.array(m) for m in (self.F, self.B, self.H, self.Q, self.R))
        return kf

    @staticmethod
    def continuous_model(model: AltitudeModel) -> tuple[np.ndarray, np.ndarray]:
        """(A (5,5), B (5,1)) of the continuous state model in the module docstring."""
        a = np.zeros((5, 5))
        a[0, 1] = 1.0
        a[1, 2] = 1.0
        a[1, 3] = 1.0
        a[2, 2] = -1.0 / model.T1_s
        b = np.zeros((5, 1))
        b[2, 0] = model.k_over_m_mps2 / model.T1_s
        return a, b

    def reset(self, z0_m: float, z_var_m2: float | None = None) -> None:
        """Restart at altitude ``z0_m`` (m, up), at rest, with the initial covariance P0.

        ``z_var_m2``: variance of ``z0_m`` (default one barometer reading's, ``r_baro_m2``;
        the loop passes the variance of its boot pressure average, which is much smaller).
        """
        self._x[:] = (float(z0_m), 0.0, 0.0, 0.0, 0.0)
        self._P[:] = self._p0
        self.baro_reject_run = 0
        if z_var_m2 is not None:
            self._P[0, 0] = float(z_var_m2)

    def predict(self, u_throttle_dev: float) -> None:
        """Propagate one tick with the applied throttle deviation u = d - d_h (unit throttle)."""
        if not math.isfinite(u_throttle_dev):
            self.counters["nonfinite_input"] += 1
            u_throttle_dev = 0.0
        x, xn, P, m = self._x, self._x_next, self._P, self._m55
        np.dot(self.F, x, out=xn)
        np.multiply(self._B, u_throttle_dev, out=self._v5)
        xn += self._v5
        self._x, self._x_next = xn, x
        np.dot(self.F, P, out=m)
        np.dot(m, self._Ft, out=P)
        P += self.Q
        np.add(P, P.T, out=m)  # re-symmetrise (the rank-one updates are symmetric only to rounding)
        np.multiply(m, 0.5, out=P)

    def _scalar_update(self, innovation: float, hph: float, r: float) -> None:
        """x += K innovation, P -= K (H P) for one scalar measurement; ``self._ph`` holds P H^T
        and ``hph`` is H P H^T."""
        ph, k, x = self._ph, self._k, self._x
        s = hph + r
        np.multiply(ph, 1.0 / s, out=k)
        np.multiply(k, innovation, out=self._v5)
        x += self._v5
        np.multiply(k[:, None], ph[None, :], out=self._m55)
        self._P -= self._m55

    def _update_baro(self, z_baro_m: float, r_m2: float) -> bool:
        """Gate and fuse one barometer reading; True if it was fused."""
        innovation = z_baro_m - float(self._x[0])
        p_zz = float(self._P[0, 0])
        if innovation * innovation > self.baro_gate_chi2 * (p_zz + r_m2):
            self.counters["baro_rejected"] += 1
            self.baro_reject_run += 1
            if self.baro_reject_run < self.baro_gate_max_rejects:
                return False
            # Disagreeing for the whole timeout: believe the barometer again, at once.
            self.counters["baro_reanchored"] += 1
            self.loosen_height(innovation * innovation)
        self.baro_reject_run = 0
        np.copyto(self._ph, self._P[:, 0])
        self._scalar_update(innovation, float(self._ph[0]), r_m2)
        return True

    def _update_acc(self, a_up_mps2: float) -> None:
        P, ph, x = self._P, self._ph, self._x
        np.add(P[:, 2], P[:, 3], out=ph)
        ph += P[:, 4]
        self._scalar_update(a_up_mps2 - float(x[2] + x[3] + x[4]), float(ph[2] + ph[3] + ph[4]), self.r_acc)

    def update(self, z_baro_m: float | None, a_up_mps2: float | None, baro_r_scale: float = 1.0) -> bool:
        """Correct with this tick's measurements; ``None`` (or non-finite) means missing.

        Args:
            z_baro_m: barometric altitude, m, up positive.
            a_up_mps2: vertical acceleration from the accelerometer, m/s^2, up positive.
            baro_r_scale: this reading's variance is ``r_baro_m2`` times this (> 1: trusted less).

        Returns:
            False if a barometer reading was given and rejected by the gate, else True.
        """
        fused = True
        if z_baro_m is not None:
            if math.isfinite(z_baro_m):
                fused = self._update_baro(z_baro_m, self.r_baro_m2 * baro_r_scale)
            else:
                self.counters["nonfinite_baro"] += 1
        if a_up_mps2 is not None:
            if math.isfinite(a_up_mps2):
                self._update_acc(a_up_mps2)
            else:
                self.counters["nonfinite_acc"] += 1
        return fused

    def loosen_height(self, z_var_m2: float) -> None:
        """Make the height as uncertain as ``z_var_m2`` (m^2) and uncorrelated with the other
        states (still a valid covariance), so the next barometer readings re-anchor it: for
        a vehicle that has just come to rest after a touchdown the accelerometer missed (a
        hard landing saturates it)."""
        self._reset_variance(0, z_var_m2)

    def _reset_variance(self, i: int, var: float) -> None:
        """State ``i``'s variance set to ``var``, uncorrelated with the others (P stays valid)."""
        P = self._P
        P[i, :] = 0.0
        P[:, i] = 0.0
        P[i, i] = float(var)

    def move_to(self, z_m: float, vz_mps: float, z_var_m2: float, vz_var_m2: float) -> None:
        """Put the height at ``z_m`` (m, up) and the vertical velocity at ``vz_mps`` (m/s),
        with these variances, for a height found elsewhere than in this filter (the inertial
        height of :mod:`flightcode.estimation.baro_motion`, when the barometer it had fused
        turns out not to have measured the vehicle). The disturbance d restarts at 0 with
        its initial variance: it is what the filter bent to reconcile the thrust and the
        accelerometer with that barometer; the accelerometer alone learns it again in a few
        tenths of a second. The three are uncorrelated with the rest after (a valid
        covariance)."""
        x = self._x
        x[0] = float(z_m)
        x[1] = float(vz_mps)
        x[3] = 0.0
        for i, var in ((0, z_var_m2), (1, vz_var_m2), (3, self._p0[3, 3])):
            self._reset_variance(i, var)
        self.baro_reject_run = 0

    def update_at_rest(self) -> None:
        """The vehicle stands on the ground: fuse z' = 0 (variance ``r_rest_vz``)."""
        np.copyto(self._ph, self._P[:, 1])
        self._scalar_update(-float(self._x[1]), float(self._ph[1]), self.r_rest_vz)

    @property
    def x(self) -> np.ndarray:
        """State [z m, z' m/s, a m/s^2, d m/s^2, b m/s^2] (a copy)."""
        return np.array(self._x)

    @property
    def z_m(self) -> float:
        """Estimated altitude, m (up)."""
        return float(self._x[0])

    @property
    def vz_mps(self) -> float:
        """Estimated vertical velocity, m/s (up)."""
        return float(self._x[1])

    @property
    def az_mps2(self) -> float:
        """Estimated vertical acceleration a + d, m/s^2 (up)."""
        return float(self._x[2] + self._x[3])

    @property
    def a_thrust_mps2(self) -> float:
        """Thrust-deviation acceleration state a, m/s^2."""
        return float(self._x[2])

    @property
    def disturbance_mps2(self) -> float:
        """Disturbance acceleration state d, m/s^2."""
        return float(self._x[3])

    @property
    def bias_mps2(self) -> float:
        """Accelerometer bias state b, m/s^2."""
        return float(self._x[4])

    @property
    def P(self) -> np.ndarray:
        """Covariance (5, 5) in the state units above (a copy; after predict: the prior)."""
        return np.array(self._P)

    @property
    def P_diag(self) -> tuple[float, float, float, float, float]:
        """Diagonal of the covariance: variances of [z, z', a, d, b]."""
        p = self._P
        return (float(p[0, 0]), float(p[1, 1]), float(p[2, 2]), float(p[3, 3]), float(p[4, 4]))
