"""Altitude Kalman filter: barometer + vertical accelerometer + thrust model (research/paper.md 3.5).

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

Discretisation at T_s: F, B by ``control.c2d`` (ZOH on u); Q by Van Loan from the white-noise
PSDs (q_a, q_d, q_b) with ``filterpy.common.van_loan_discretization``. The filter itself is
``filterpy.kalman.KalmanFilter``; a tick with only one measurement uses its sequential update
(filterpy >= 2.0).
"""

from __future__ import annotations

import math
from collections import Counter

import control as ct
import numpy as np
from filterpy.common import van_loan_discretization
from filterpy.kalman import KalmanFilter

from flightcode.control.lqi_altitude import AltitudeModel

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
        r_baro_m2: barometric altitude noise variance, m^2 (0.5 mV + ADC quantisation).
        r_acc: vertical acceleration noise variance, (m/s^2)^2 (vibration + ADXL noise + LSB).
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
    ) -> None:
        if not (math.isfinite(T_s) and T_s > 0.0):
            raise ValueError(f"T_s must be finite and > 0, got {T_s}")
        for name, value in (("q_a", q_a), ("q_d", q_d), ("q_b", q_b)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        for name, value in (("r_baro_m2", r_baro_m2), ("r_acc", r_acc)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        self.model = model
        self.T_s = float(T_s)
        a_c, b_c = self.continuous_model(model)
        h = np.array([[1.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 1.0, 1.0]])
        sysd = ct.c2d(ct.ss(a_c, b_c, h, np.zeros((2, 1))), self.T_s, method="zoh")
        g = np.diag([0.0, 0.0, math.sqrt(q_a), math.sqrt(q_d), math.sqrt(q_b)])
        _, q_d_matrix = van_loan_discretization(a_c, g, self.T_s)

        kf = KalmanFilter(dim_x=5, dim_z=2, dim_u=1)
        kf.F = np.asarray(sysd.A, dtype=float)
        kf.B = np.asarray(sysd.B, dtype=float)
        kf.H = h
        # Symmetrise: Van Loan's product is symmetric only to rounding.
        kf.Q = 0.5 * (q_d_matrix + q_d_matrix.T)
        kf.R = np.diag([float(r_baro_m2), float(r_acc)])
        self.kf = kf
        self._p0 = np.diag([float(r_baro_m2)] + [float(v) for v in P0_DIAG_REST[1:]])
        #: Non-finite inputs seen (treated as missing measurements / zero input).
        self.counters: Counter[str] = Counter()
        self.reset(0.0)

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

    def reset(self, z0_m: float) -> None:
        """Restart at altitude ``z0_m`` (m, up), at rest, with the initial covariance P0."""
        self.kf.x = np.array([[float(z0_m)], [0.0], [0.0], [0.0], [0.0]])
        self.kf.P = self._p0.copy()

    def predict(self, u_throttle_dev: float) -> None:
        """Propagate one tick with the applied throttle deviation u = d - d_h (unit throttle)."""
        if not math.isfinite(u_throttle_dev):
            self.counters["nonfinite_input"] += 1
            u_throttle_dev = 0.0
        self.kf.predict(u=u_throttle_dev)

    def update(self, z_baro_m: float | None, a_up_mps2: float | None) -> None:
        """Correct with this tick's measurements; ``None`` (or non-finite) means missing.

        Args:
            z_baro_m: barometric altitude, m, up positive.
            a_up_mps2: vertical acceleration from the accelerometer, m/s^2, up positive.
        """
        if z_baro_m is not None and not math.isfinite(z_baro_m):
            self.counters["nonfinite_baro"] += 1
            z_baro_m = None
        if a_up_mps2 is not None and not math.isfinite(a_up_mps2):
            self.counters["nonfinite_acc"] += 1
            a_up_mps2 = None
        if z_baro_m is not None and a_up_mps2 is not None:
            self.kf.update(np.array([z_baro_m, a_up_mps2]))
        elif z_baro_m is not None:
            self.kf.update_sequential(0, z_baro_m)
        elif a_up_mps2 is not None:
            self.kf.update_sequential(1, a_up_mps2)

    @property
    def z_m(self) -> float:
        """Estimated altitude, m (up)."""
        return float(self.kf.x[0, 0])

    @property
    def vz_mps(self) -> float:
        """Estimated vertical velocity, m/s (up)."""
        return float(self.kf.x[1, 0])

    @property
    def az_mps2(self) -> float:
        """Estimated vertical acceleration a + d, m/s^2 (up)."""
        return float(self.kf.x[2, 0] + self.kf.x[3, 0])

    @property
    def a_thrust_mps2(self) -> float:
        """Thrust-deviation acceleration state a, m/s^2."""
        return float(self.kf.x[2, 0])

    @property
    def disturbance_mps2(self) -> float:
        """Disturbance acceleration state d, m/s^2."""
        return float(self.kf.x[3, 0])

    @property
    def bias_mps2(self) -> float:
        """Accelerometer bias state b, m/s^2."""
        return float(self.kf.x[4, 0])

    @property
    def P(self) -> np.ndarray:
        """Posterior covariance (5, 5) in the state units above (a copy)."""
        return np.array(self.kf.P)

    @property
    def P_diag(self) -> tuple[float, float, float, float, float]:
        """Diagonal of the covariance: variances of [z, z', a, d, b]."""
        p = self.kf.P
        return (float(p[0, 0]), float(p[1, 1]), float(p[2, 2]), float(p[3, 3]), float(p[4, 4]))
