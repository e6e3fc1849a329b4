"""Motor mixer: collective throttle + body torques -> four motor throttles, with priorities.

Layout (shared flight-code convention; body FRD, motor i on Maestro channel i):

    X frame (default), arm a from the centre, l = a / sqrt(2):
        motor 0 front-right (+l, +l) CCW     motor 2 front-left (+l, -l) CW
        motor 1 rear-left   (-l, -l) CCW     motor 3 rear-right (-l, +l) CW
    plus frame:
        motor 0 right (0, +a) CCW   motor 1 left (0, -a) CCW   motor 2 front (+a, 0) CW   motor 3 back (-a, 0) CW

Thrust F_i = F_max_motor d_i^2 acts along -z_B at (x_i, y_i), so
tau_x = -sum y_i F_i (roll, right wing down), tau_y = sum x_i F_i (pitch, nose up) and a CCW
prop's reaction torque is +yaw (nose right): tau_z = (kQ/kT) sum spin_i F_i, spin = +1 CCW.

kQ/kT = 0.016 m is the shared convention for the APC 12x4.5 (static C_P/(2 pi C_T) x D gives
0.016-0.020 m); the plant uses the same number.

Saturation (all in thrust, per-motor bounds [0, F_max_motor]):

1. the full request fits: apply it;
2. otherwise reduce yaw (largest fraction of tau_z that fits at the requested collective with
   full roll/pitch);
3. if roll/pitch do not fit even without yaw, shift the collective just enough to fit them,
   scaling roll/pitch down only if their spread exceeds the thrust range, then give yaw the
   largest fraction that fits at that collective.

The collective may shift up or down (at zero collective a roll/pitch request lifts it): the
mode logic keeps the attitude loops inactive while landed, so a disarmed vehicle requests
zero torque and gets zero thrust. The applied torque is computed back from the final thrusts.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from enum import Enum, unique

import numpy as np


@unique
class Frame(Enum):
    """Motor layout."""

    X = "x"
    PLUS = "plus"


_FRAME_ALIASES = {"x": Frame.X, "plus": Frame.PLUS, "+": Frame.PLUS}
_EPS_N = 1e-9  # thrust tolerance for "fits", N


@dataclass(frozen=True)
class MixResult:
    """Output of one mix.

    throttle: four motor throttles d_i in [0, 1] (Maestro channel i; pulse_us = 1000 + 1000 d).
    applied_tau_Nm: (roll, pitch, yaw) torque the clipped thrusts produce, N m, FRD.
    saturated: True if the request was altered (yaw cut, collective shifted or roll/pitch scaled).
    applied_collective_throttle: the collective the thrusts produce, sqrt(sum F / (4 F_max_motor)).
    """

    throttle: tuple[float, float, float, float]
    applied_tau_Nm: tuple[float, float, float]
    saturated: bool
    applied_collective_throttle: float = 0.0


def motor_layout(frame: Frame, arm_m: float) -> tuple[tuple[float, float, int], ...]:
    """((x_m, y_m, spin), ...) for motors 0..3 in FRD; spin +1 = CCW seen from above."""
    if frame is Frame.X:
        l = arm_m / math.sqrt(2.0)
        return ((l, l, 1), (-l, -l, 1), (l, -l, -1), (-l, l, -1))
    return ((0.0, arm_m, 1), (0.0, -arm_m, 1), (arm_m, 0.0, -1), (-arm_m, 0.0, -1))


class Mixer:
    """Thrust-space mixer for the four motors.

    Args:
        frame: "x" (default) or "plus" ("+").
        arm_m: centre-to-motor distance, m.
        F_max_motor_N: thrust of one motor at full throttle, N (20.6 N / 4).
        kq_over_kt_m: reaction-torque to thrust ratio of a prop, m.
    """

    def __init__(
        self,
        frame: str = "x",
        arm_m: float = 0.25,
        F_max_motor_N: float = 5.15,
        kq_over_kt_m: float = 0.016,
    ) -> None:
        try:
            self.frame = _FRAME_ALIASES[frame.lower()] if isinstance(frame, str) else Frame(frame)
        except (KeyError, ValueError):
            raise ValueError(f"frame must be 'x' or 'plus', got {frame!r}") from None
        for name, value in (("arm_m", arm_m), ("F_max_motor_N", F_max_motor_N), ("kq_over_kt_m", kq_over_kt_m)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        self.arm_m = float(arm_m)
        self.F_max_motor_N = float(F_max_motor_N)
        self.kq_over_kt_m = float(kq_over_kt_m)
        self.layout = motor_layout(self.frame, self.arm_m)
        # Rows: [sum F, tau_x, tau_y, tau_z] = alloc @ F.
        alloc = np.array(
            [
                [1.0] * 4,
                [-y for _, y, _ in self.layout],
                [x for x, _, _ in self.layout],
                [self.kq_over_kt_m * s for _, _, s in self.layout],
            ]
        )
        self.allocation = alloc
        mix = np.linalg.inv(alloc)
        # Per-motor thrust per unit torque (columns 1..3 of the inverse), as floats.
        self._m_roll = mix[:, 1].tolist()
        self._m_pitch = mix[:, 2].tolist()
        self._m_yaw = mix[:, 3].tolist()
        self._ny = [-y for _, y, _ in self.layout]
        self._px = [x for x, _, _ in self.layout]
        self._sz = [self.kq_over_kt_m * s for _, _, s in self.layout]
        #: Non-finite inputs replaced by zero.
        self.counters: Counter[str] = Counter()

    def _yaw_fraction(self, base: list[float], yaw: list[float]) -> float:
        """Largest beta in [0, 1] with 0 <= base_i + beta yaw_i <= F_max for all i (base fits)."""
        fmax = self.F_max_motor_N
        beta = 1.0
        for b, y in zip(base, yaw):
            if y > 0.0:
                room = (fmax - b) / y
            elif y < 0.0:
                room = -b / y
            else:
                continue
            if room < beta:
                beta = room
        return beta if beta > 0.0 else 0.0

    def mix(self, collective_throttle: float, tau_Nm: tuple[float, float, float]) -> MixResult:
        """Throttles for a collective throttle in [0, 1] and a (roll, pitch, yaw) torque in N m (FRD)."""
        fmax = self.F_max_motor_N
        d_c = collective_throttle
        if not math.isfinite(d_c):
            self.counters["nonfinite_collective"] += 1
            d_c = 0.0
        d_c = 1.0 if d_c > 1.0 else 0.0 if d_c < 0.0 else d_c
        tx, ty, tz = tau_Nm
        if not (math.isfinite(tx) and math.isfinite(ty) and math.isfinite(tz)):
            self.counters["nonfinite_torque"] += 1
            tx = tx if math.isfinite(tx) else 0.0
            ty = ty if math.isfinite(ty) else 0.0
            tz = tz if math.isfinite(tz) else 0.0
        f_c = fmax * d_c * d_c  # collective per motor: 4 F_max d_c^2 / 4
        mr, mp, my = self._m_roll, self._m_pitch, self._m_yaw
        rp = [mr[0] * tx + mp[0] * ty, mr[1] * tx + mp[1] * ty, mr[2] * tx + mp[2] * ty, mr[3] * tx + mp[3] * ty]
        yw = [my[0] * tz, my[1] * tz, my[2] * tz, my[3] * tz]
        lo_ok, hi_ok = -_EPS_N, fmax + _EPS_N

        thrust = [f_c + rp[0] + yw[0], f_c + rp[1] + yw[1], f_c + rp[2] + yw[2], f_c + rp[3] + yw[3]]
        saturated = False
        if min(thrust) < lo_ok or max(thrust) > hi_ok:
            saturated = True
            base = [f_c + r for r in rp]
            if not all(lo_ok <= f <= hi_ok for f in base):
                # Roll/pitch alone do not fit: scale them if their spread is too wide, then
                # shift the collective the least that makes them fit.
                lo, hi = min(rp), max(rp)
                span = hi - lo
                if span > fmax:
                    alpha = fmax / span
                    rp = [alpha * r for r in rp]
                    lo, hi = alpha * lo, alpha * hi
                f_c = min(max(f_c, -lo), fmax - hi)
                base = [f_c + r for r in rp]
            beta = self._yaw_fraction(base, yw)
            thrust = [b + beta * y for b, y in zip(base, yw)]

        f0, f1, f2, f3 = (fmax if f > fmax else 0.0 if f < 0.0 else f for f in thrust)
        sqrt, inv = math.sqrt, 1.0 / fmax
        ny, px, sz = self._ny, self._px, self._sz
        return MixResult(
            (sqrt(f0 * inv), sqrt(f1 * inv), sqrt(f2 * inv), sqrt(f3 * inv)),
            (ny[0] * f0 + ny[1] * f1 + ny[2] * f2 + ny[3] * f3,
             px[0] * f0 + px[1] * f1 + px[2] * f2 + px[3] * f3,
             sz[0] * f0 + sz[1] * f1 + sz[2] * f2 + sz[3] * f3),
            saturated,
            sqrt((f0 + f1 + f2 + f3) * 0.25 * inv),
        )
