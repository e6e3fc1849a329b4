"""Memory-based (time-delay-estimation) roll/pitch controller of Wang/Ma/Sun, per axis.

Law (docs/controllers.md 2.1, Eq. 3.24 corrected, with the generalised weights)::

    e   = phi - phi*                       (rad; phi = measured Euler angle)
    s   = e' + k0 e                        (rad/s; e' from the gyro Euler rate, never d/dt phi)
    eta = phi*'' + tau_ff phi*''' - k0 e'  (rad/s^2; eta = 0 for the Eq. 3.25 form)
    u_k = sat( u_{k-1} + J (w1 s_k + w2 s_{k-1}) + J (eta_k - eta_{k-1}) )    (N m)

On the Euler error model this closes the loop as
``s_{k+1} - (p1 + p2) s_k + p1 p2 s_{k-1} = T (f_k - f_{k-1})`` with
``w1 = (p1 + p2 - 2)/T`` and ``w2 = (1 - p1 p2)/T``. The paper's literal weights
(w1 = -2/T, w2 = 1/T, p1 = p2 = 0, deadbeat) are unstable at 400 Hz with any motor lag or one
sample of delay (docs/controllers.md 2.4); they stay selectable (:meth:`MemoryGains.paper_literal`) only so
the bench can show that its control-activity criterion catches the resulting chatter.

Anti-windup is the paper's: the accumulator holds the torque actually applied (after the
torque limit here and after mixer clipping through :meth:`MemoryAttitudeController.set_applied`).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass

from flightcode.control.reference import RefState


def weights_from_poles(omega1_radps: float, omega2_radps: float, T_s: float) -> tuple[float, float]:
    """Generalised memory weights (w1, w2) in 1/s for s-poles p_i = exp(-omega_i T_s)."""
    p1 = math.exp(-omega1_radps * T_s)
    p2 = math.exp(-omega2_radps * T_s)
    return (p1 + p2 - 2.0) / T_s, (1.0 - p1 * p2) / T_s


# docs/controllers.md 2.6: (omega1, omega2) = (2, 15) rad/s at 400 Hz -> w1 = -16.717, w2 = +16.644 1/s.
_W1_REC, _W2_REC = weights_from_poles(2.0, 15.0, 0.0025)


@dataclass(frozen=True)
class MemoryGains:
    """Gains of one attitude axis. Defaults: the recommended 400 Hz set of docs/controllers.md 2.6.

    Fields:
        T_s: loop period, s.
        k0_per_s: sliding-surface slope k0 (error decay rate once s = 0), 1/s.
        J_hat_kgm2: inertia estimate J_hat = J_xx / (d tau / d u); with u in N m, kg m^2.
        w1_per_s, w2_per_s: memory weights, 1/s (see :func:`weights_from_poles`).
        tau_ff_s: actuator-lag lead in eta (identified motor time constant), s.
        u_limit_Nm: symmetric torque limit, N m.
        use_eta: True = Eq. 3.24 (eta feed-forward), False = Eq. 3.25 (eta merged into f).
    """

    __pydantic_config__ = {"extra": "forbid"}

    T_s: float = 0.0025
    k0_per_s: float = 2.0
    J_hat_kgm2: float = 0.015
    w1_per_s: float = _W1_REC
    w2_per_s: float = _W2_REC
    tau_ff_s: float = 0.035
    u_limit_Nm: float = 0.8
    use_eta: bool = True

    def __post_init__(self) -> None:
        for name in ("T_s", "J_hat_kgm2", "u_limit_Nm"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"MemoryGains.{name} must be finite and > 0, got {value}")
        for name in ("k0_per_s", "w1_per_s", "w2_per_s", "tau_ff_s"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"MemoryGains.{name} must be finite")

    @classmethod
    def from_poles(
        cls,
        T_s: float = 0.0025,
        omega1_radps: float = 2.0,
        omega2_radps: float = 15.0,
        k0_per_s: float = 2.0,
        J_hat_kgm2: float = 0.015,
        tau_ff_s: float = 0.035,
        u_limit_Nm: float = 0.8,
    ) -> MemoryGains:
        """Generalised law with s-poles exp(-omega_i T_s) and the eta feed-forward + lead."""
        w1, w2 = weights_from_poles(omega1_radps, omega2_radps, T_s)
        return cls(T_s, k0_per_s, J_hat_kgm2, w1, w2, tau_ff_s, u_limit_Nm, True)

    @classmethod
    def paper_literal(
        cls,
        T_s: float = 0.0025,
        k0_per_s: float = 1.0,
        J_hat_kgm2: float = 0.015,
        u_limit_Nm: float = 0.8,
    ) -> MemoryGains:
        """The paper's deadbeat weights w1 = -2/T, w2 = 1/T, Eq. 3.25 (no eta, no lead).

        For demonstrations only: with any actuator lag or sample delay this chatters at the
        torque limit (docs/controllers.md 2.4).
        """
        return cls(T_s, k0_per_s, J_hat_kgm2, -2.0 / T_s, 1.0 / T_s, 0.0, u_limit_Nm, False)

    @property
    def poles(self) -> tuple[complex, complex]:
        """The two s-loop poles (p1, p2) implied by w1, w2: roots of z^2 - (2+T w1) z + 1 - T w2."""
        b = 2.0 + self.T_s * self.w1_per_s
        c = 1.0 - self.T_s * self.w2_per_s
        root = complex(b * b - 4.0 * c) ** 0.5
        return ((b + root) / 2.0, (b - root) / 2.0)

    def pid_equivalent(self) -> tuple[float, float, float]:
        """(K_p N m/rad, K_i N m/(rad s), K_d N m s/rad) of the equivalent PID on e (u = -PID).

        From u = -J w2 s + (J (w1 + w2)/T) integral(s) with s = e' + k0 e (docs/controllers.md 2.1/2.6).
        """
        j, t, k0 = self.J_hat_kgm2, self.T_s, self.k0_per_s
        w1, w2 = self.w1_per_s, self.w2_per_s
        return (j * (w2 * k0 - (w1 + w2) / t), -j * (w1 + w2) * k0 / t, j * w2)


class MemoryAttitudeController:
    """One roll or pitch axis of the memory controller (incremental u-form, Eq. 3.24).

    Call :meth:`update` once per loop tick; when the mixer had to clip, pass the torque it
    actually produced to :meth:`set_applied` before the next tick.
    """

    def __init__(self, gains: MemoryGains) -> None:
        self.gains = gains
        self._T = gains.T_s
        self._k0 = gains.k0_per_s
        self._J = gains.J_hat_kgm2
        self._w1 = gains.w1_per_s
        self._w2 = gains.w2_per_s
        self._tau = gains.tau_ff_s
        self._lim = gains.u_limit_Nm
        self._use_eta = gains.use_eta
        #: Non-finite inputs seen (driver faults); the controller holds its output on them.
        self.counters: Counter[str] = Counter()
        self._u_prev = 0.0
        self._s_prev = 0.0
        self._eta_prev = 0.0
        self._s = 0.0
        self._primed = False

    def reset(self) -> None:
        """Forget the memory: the next active update starts with u_{k-1} = 0, s_{k-1} = s_k."""
        self._u_prev = 0.0
        self._s_prev = 0.0
        self._eta_prev = 0.0
        self._s = 0.0
        self._primed = False

    @property
    def s_radps(self) -> float:
        """Sliding variable s = e' + k0 e of the last update, rad/s."""
        return self._s

    @property
    def u_prev_Nm(self) -> float:
        """The stored u_{k-1} (requested, or the applied value given to set_applied), N m."""
        return self._u_prev

    def update(self, ref: RefState, angle_rad: float, rate_radps: float, active: bool) -> float:
        """Torque request in N m about this body axis (FRD), limited to +-u_limit_Nm.

        Args:
            ref: reference angle and derivatives from :class:`~flightcode.control.reference.Prefilter3`.
            angle_rad: measured Euler angle (roll or pitch).
            rate_radps: measured Euler-angle rate from the gyro (phi' = p + (q sin phi +
                r cos phi) tan theta for roll; theta' = q cos phi - r sin phi for pitch).
            active: False while disarmed, landed or at idle throttle: the accumulator is not
                updated (u_{k-1} = 0, s_{k-1} = s, eta_{k-1} = eta) and 0.0 is returned.
        """
        k0 = self._k0
        ed = rate_radps - ref.rate_radps
        s = ed + k0 * (angle_rad - ref.angle_rad)
        if self._use_eta:
            eta = ref.acc_radps2 + self._tau * ref.jerk_radps3 - k0 * ed
        else:
            eta = 0.0
        if not (math.isfinite(s) and math.isfinite(eta)):
            # A NaN must never enter the accumulator; hold the last output instead.
            self.counters["nonfinite_input"] += 1
            return self._u_prev if active else 0.0
        self._s = s
        if not active or not self._primed:
            self._s_prev = s
            self._eta_prev = eta
            self._primed = True
            if not active:
                self._u_prev = 0.0
                return 0.0
        j = self._J
        u = self._u_prev + j * (self._w1 * s + self._w2 * self._s_prev) + j * (eta - self._eta_prev)
        lim = self._lim
        if u > lim:
            u = lim
        elif u < -lim:
            u = -lim
        self._u_prev = u
        self._s_prev = s
        self._eta_prev = eta
        return u

    def set_applied(self, torque_Nm: float) -> None:
        """Store the torque actually applied (after mixer clipping) as u_{k-1}, N m."""
        if not math.isfinite(torque_Nm):
            self.counters["nonfinite_applied"] += 1
            return
        lim = self._lim
        self._u_prev = lim if torque_Nm > lim else -lim if torque_Nm < -lim else float(torque_Nm)
