"""Altitude model and LQI altitude controller (Wang/Ma/Sun Eqs. 4.4-4.14, docs/controllers.md 3.1-3.3).

Model (z up, m): thrust F = F_max d^2 linearised at the hover throttle d_h = sqrt(m g / F_max),
gain k = dF/dd = 2 F_max d_h (N per unit throttle), first-order thrust lag T1:

    x = [z, z', z'']    A = [[0,1,0],[0,0,1],[0,0,-1/T1]]    B = [0, 0, k/(m T1)]^T    y = z

with the input u = d - d_h (throttle deviation; it absorbs m g, Eq. 4.3). LQI augments the
integral x_r' = r - z (the sign of the paper's matrix in Eq. 4.6) and solves the continuous
Riccati equation (``flightcode.control.design.lqr``, python-control's ``lqr`` computation): u = -F1 x - F2 x_r. The defaults Q = diag(0, 0, 0,
8.25e-3), R = 1 give F1 = [0.1415, 0.1103, 0.00796], F2 = -0.0908 and a 5 m step with 0.41 m
overshoot settling (2 %) in 5.0 s (docs/controllers.md 3.2). The continuous gains are emulated at 400 Hz
(x_r integrated by forward Euler); docs/controllers.md 3.3 shows the discrete design differs by < 0.3 %.

The model has no vertical damping, and the weights are the design's only free knob (the paper
gives neither Q nor R). On a vehicle whose rotors damp climbs and descents (inflow drag: the
bench's plant has 1.5 N/(m/s), a pole at -1.4 rad/s next to the loop's 1.3 rad/s) the default
weights give a slower, less damped loop: poles -0.45 +- 0.76j, 0.73 m overshoot and 6.4 s to
settle into +-0.25 m (linear). Weighting the integral more and the height a little, q_int =
0.04 and q_z = 0.003, gives 0.58 m and 4.7 s there (the bench's rig flies these:
rigs/paper-quad.toml [flight.overrides.altitude]; docs/flightcode.md "Retuning the altitude
LQI").
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass

import numpy as np

from flightcode.control.design import lqr

#: Standard gravity, m/s^2.
G_MPS2 = 9.80665


@dataclass(frozen=True)
class AltitudeModel:
    """Vertical dynamics of the vehicle. Defaults: the paper's quad (docs/controllers.md 3.1).

    Fields:
        m_kg: take-off mass, kg.
        F_max_N: total thrust of the four motors at full throttle, N ((1.1 + 1.0) kg x g).
        T1_s: thrust lag time constant seen by the altitude loop, s.
    """

    __pydantic_config__ = {"extra": "forbid"}

    m_kg: float = 1.1
    F_max_N: float = 20.6
    T1_s: float = 0.08

    def __post_init__(self) -> None:
        for name in ("m_kg", "F_max_N", "T1_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"AltitudeModel.{name} must be finite and > 0, got {value}")
        if self.m_kg * G_MPS2 >= self.F_max_N:
            raise ValueError(
                f"AltitudeModel: m g = {self.m_kg * G_MPS2:.2f} N >= F_max_N = {self.F_max_N} N, cannot hover"
            )

    @property
    def d_h(self) -> float:
        """Hover throttle sqrt(m g / F_max), unit throttle (0.724 for the paper's quad)."""
        return math.sqrt(self.m_kg * G_MPS2 / self.F_max_N)

    @property
    def k_N(self) -> float:
        """Linear thrust gain 2 F_max d_h, N per unit throttle (29.8 for the paper's quad)."""
        return 2.0 * self.F_max_N * self.d_h

    @property
    def k_over_m_mps2(self) -> float:
        """Steady vertical acceleration per unit throttle deviation, m/s^2 (27.1)."""
        return self.k_N / self.m_kg

    def state_space(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(A (3,3), B (3,1), C (1,3)) of x = [z m, z' m/s, z'' m/s^2], u = d - d_h, y = z."""
        a = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0 / self.T1_s]])
        b = np.array([[0.0], [0.0], [self.k_over_m_mps2 / self.T1_s]])
        c = np.array([[1.0, 0.0, 0.0]])
        return a, b, c


class LqiAltitude:
    """LQI altitude controller; gains from the continuous LQR (``design.lqr``) at construction.

    Args:
        model: vertical model (gains depend on m, F_max, T1).
        q_int: weight on the integral state x_r (1/(m s)^2).
        q_z, q_vz, q_az: weights on z, z', z''.
        r: weight on u (unit throttle^-2).
        T_s: loop period, s.
        u_min, u_max: limits of the throttle deviation; default -d_h and 1 - d_h, i.e. the
            collective throttle stays in [0, 1].

    Attributes:
        F1: state gains [per m, s/m, s^2/m] (numpy (3,)), F2: integral gain (1/(m s)),
        K: (1, 4) full LQI gain, poles: continuous closed-loop poles (rad/s, complex (4,)).
    """

    def __init__(
        self,
        model: AltitudeModel,
        q_int: float = 8.25e-3,
        q_z: float = 0.0,
        q_vz: float = 0.0,
        q_az: float = 0.0,
        r: float = 1.0,
        T_s: float = 0.0025,
        u_min: float | None = None,
        u_max: float | None = None,
    ) -> None:
        if not (math.isfinite(T_s) and T_s > 0.0):
            raise ValueError(f"T_s must be finite and > 0, got {T_s}")
        if not (math.isfinite(r) and r > 0.0):
            raise ValueError(f"r must be finite and > 0, got {r}")
        weights = (q_z, q_vz, q_az, q_int)
        if not all(math.isfinite(q) and q >= 0.0 for q in weights) or q_int <= 0.0:
            raise ValueError(f"weights must be >= 0 and q_int > 0, got {weights}")
        self.model = model
        self.T_s = float(T_s)
        self.d_h = model.d_h
        self.u_min = -self.d_h if u_min is None else float(u_min)
        self.u_max = 1.0 - self.d_h if u_max is None else float(u_max)
        if not self.u_min < 0.0 < self.u_max:
            raise ValueError(f"need u_min < 0 < u_max, got [{self.u_min}, {self.u_max}]")

        a, b, c = model.state_space()
        a_aug = np.block([[a, np.zeros((3, 1))], [-c, np.zeros((1, 1))]])
        b_aug = np.vstack([b, np.zeros((1, 1))])
        k, _, poles = lqr(a_aug, b_aug, np.diag(weights), np.array([[float(r)]]))
        self.K: np.ndarray = np.asarray(k, dtype=float)
        self.F1: np.ndarray = self.K[0, :3].copy()
        self.F2: float = float(self.K[0, 3])
        self.poles: np.ndarray = np.asarray(sorted(np.asarray(poles), key=lambda p: (p.real, p.imag)))

        self._f_z, self._f_vz, self._f_az = self.F1.tolist()
        self._f_r = self.F2
        #: Non-finite inputs seen; the controller holds its output on them.
        self.counters: Counter[str] = Counter()
        self._x_r = 0.0
        self.last_u = 0.0

    @property
    def integrator_m_s(self) -> float:
        """Integral state x_r = integral of (z_ref - z_hat), m s."""
        return self._x_r

    def reset(self) -> None:
        """Clear the integrator and the last output."""
        self._x_r = 0.0
        self.last_u = 0.0

    def update(self, z_ref_m: float, z_hat_m: float, vz_hat_mps: float, az_hat_mps2: float, active: bool) -> float:
        """Collective throttle in [0, 1] = d_h + u (z up; estimates from the altitude KF).

        ``self.last_u`` is the applied deviation u (for :meth:`AltitudeKF.predict`). While not
        active the integrator is reset, ``last_u`` is 0 and 0.0 is returned: the mode logic
        decides what the motors do on the ground.

        Anti-windup by conditional integration: x_r is not integrated on a tick whose output
        saturates in the direction the error would push it.
        """
        if not active:
            self._x_r = 0.0
            self.last_u = 0.0
            return 0.0
        err = z_ref_m - z_hat_m
        u = -(self._f_z * z_hat_m + self._f_vz * vz_hat_mps + self._f_az * az_hat_mps2) - self._f_r * self._x_r
        if not (math.isfinite(u) and math.isfinite(err)):
            self.counters["nonfinite_input"] += 1
            return self.d_h + self.last_u
        # Effect of this tick's integration on u has the sign of -F2 * err.
        push = -self._f_r * err
        if u > self.u_max:
            u = self.u_max
            integrate = push < 0.0
        elif u < self.u_min:
            u = self.u_min
            integrate = push > 0.0
        else:
            integrate = True
        if integrate:
            self._x_r += self.T_s * err
        d = self.d_h + u
        d = 1.0 if d > 1.0 else 0.0 if d < 0.0 else d
        self.last_u = d - self.d_h
        return d
