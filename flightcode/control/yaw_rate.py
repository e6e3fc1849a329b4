"""PI yaw-rate controller (the paper controls roll/pitch angles; yaw is held by rate).

    e = r* - r                       (rad/s; r = yaw Euler rate from the gyro, positive nose right)
    u = sat(kp e + i)                (N m about the FRD z axis)
    i <- i + ki T e                  (conditional integration: frozen while u saturates in the
                                      direction of e)

Default gains (our choice, not the paper's): J_zz of the 1.1 kg, 0.25 m-arm quad is about
0.026 kg m^2 (motors 0.019, arms/ESCs 0.003, rest 0.004), so kp = 0.15 N m s/rad gives a
crossover near kp/J_zz = 6 rad/s, well inside a 35 ms motor lag; ki/kp = 1 rad/s places the
integral zero a decade lower. The limit 0.15 N m is about what four motors at hover can give
with kQ/kT = 0.016 m (4 x 0.016 m x 2.45 N). The mixer cuts yaw first when it must; pass the
torque it really applied to :meth:`YawRateController.set_applied` so the integrator unwinds.
"""

from __future__ import annotations

import math
from collections import Counter


class YawRateController:
    """PI yaw-rate loop with conditional-integration and applied-torque anti-windup.

    Args:
        kp_Nm_per_radps: proportional gain, N m per rad/s of rate error.
        ki_Nm_per_rad: integral gain, N m per rad of integrated rate error.
        u_limit_Nm: symmetric yaw-torque limit, N m (the integrator is bounded by it too).
        T_s: loop period, s.
    """

    def __init__(
        self,
        kp_Nm_per_radps: float = 0.15,
        ki_Nm_per_rad: float = 0.15,
        u_limit_Nm: float = 0.15,
        T_s: float = 0.0025,
    ) -> None:
        for name, value in (("kp_Nm_per_radps", kp_Nm_per_radps), ("ki_Nm_per_rad", ki_Nm_per_rad)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        for name, value in (("u_limit_Nm", u_limit_Nm), ("T_s", T_s)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        self.kp_Nm_per_radps = float(kp_Nm_per_radps)
        self.ki_Nm_per_rad = float(ki_Nm_per_rad)
        self.u_limit_Nm = float(u_limit_Nm)
        self.T_s = float(T_s)
        self._ki_T = self.ki_Nm_per_rad * self.T_s
        #: Non-finite inputs seen; the controller holds its output on them.
        self.counters: Counter[str] = Counter()
        self._i = 0.0
        self._u_req = 0.0

    def reset(self) -> None:
        """Clear the integrator."""
        self._i = 0.0
        self._u_req = 0.0

    @property
    def integrator_Nm(self) -> float:
        """Integral term, N m."""
        return self._i

    def update(self, rate_ref_radps: float, rate_meas_radps: float, active: bool) -> float:
        """Yaw torque request in N m (FRD z, positive nose right); 0 and integrator reset if not active."""
        if not active:
            self._i = 0.0
            self._u_req = 0.0
            return 0.0
        e = rate_ref_radps - rate_meas_radps
        if not math.isfinite(e):
            self.counters["nonfinite_input"] += 1
            return self._u_req
        lim = self.u_limit_Nm
        u = self.kp_Nm_per_radps * e + self._i
        if u >= lim:
            u = lim
            windup = e > 0.0
        elif u <= -lim:
            u = -lim
            windup = e < 0.0
        else:
            windup = False
        if not windup:
            i = self._i + self._ki_T * e
            self._i = lim if i > lim else -lim if i < -lim else i
        self._u_req = u
        return u

    def set_applied(self, torque_Nm: float) -> None:
        """Tell the loop the yaw torque the mixer really produced (N m).

        If the mixer cut the request, the integrator is moved back by the shortfall, but never
        past zero: the integral never grows or changes sign because of the clipping.
        """
        if not math.isfinite(torque_Nm):
            self.counters["nonfinite_applied"] += 1
            return
        shortfall = self._u_req - torque_Nm
        # Only unwind: shrink |i| toward zero when the clip opposes the integral's sign.
        if self._i != 0.0 and shortfall != 0.0 and (self._i > 0.0) == (shortfall > 0.0):
            i = self._i - shortfall
            self._i = max(i, 0.0) if self._i > 0.0 else min(i, 0.0)
        self._u_req = float(torque_Nm)
