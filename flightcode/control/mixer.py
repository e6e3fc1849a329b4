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

Differential (``differential``):

* ``"thrust"``: torques are mixed in thrust and the throttles are the exact inverse of
  F = F_max d^2, so a commanded N m is applied at any collective;
* ``"throttle"``: the differential is linear in throttle around the collective, sized at the
  design hover throttle d_h, as the PWM mixers of the paper's era were
  (d_i = d_c + dd_i). Then pairs (d_c + dd)^2 - (d_c - dd)^2 = 4 d_c dd: the torque applied
  per N m commanded is d_c / d_h. A payload that moves hover up the thrust curve raises the
  torque gain with the thrust it needs (docs/controllers.md 2.7's payload model: x1.128 for +300 g).
  Implemented as the request scaled by d_c / d_h before the thrust-space mix: the first-order
  part, exact on one axis. A PWM mixer's dd^2 terms are left out: < 0.2 % of hover thrust on
  the collective, and cross-couplings when axes combine (11 mN m at 0.19 N m of pitch with
  0.02 N m of yaw at d = 0.5; flight torques are a fifth of that).

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


@unique
class Differential(Enum):
    """How roll, pitch and yaw torques become per-motor throttle (module docstring)."""

    THRUST = "thrust"  #: exact inverse of F = F_max d^2: torque gain 1
    THROTTLE = "throttle"  #: linear in throttle, sized at hover: torque gain d_c / d_h


@dataclass(frozen=True)
class MixResult:
    """Output of one mix.

    throttle: four motor throttles d_i in [0, 1] (Maestro channel i; pulse_us = 1000 + 1000 d).
    applied_tau_Nm: (roll, pitch, yaw) torque the clipped thrusts produce, N m, FRD.
    saturated: True if the request was altered (yaw cut, collective shifted or roll/pitch scaled).
    applied_collective_throttle: the collective the thrusts produce, sqrt(sum F / (4 F_max_motor)).
    applied_command_Nm: the applied torque in the controllers' units: ``applied_tau_Nm``
        divided by the torque gain (the same numbers for the ``"thrust"`` differential).
    """

    throttle: tuple[float, float, float, float]
    applied_tau_Nm: tuple[float, float, float]
    saturated: bool
    applied_collective_throttle: float = 0.0
    applied_command_Nm: tuple[float, float, float] = (0.0, 0.0, 0.0)


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
        differential: :class:`Differential` or its value, ``"thrust"`` or ``"throttle"``.
        hover_throttle: d_h, unit throttle, the ``"throttle"`` differential's design point.
    """

    def __init__(
        self,
        frame: str = "x",
        arm_m: float = 0.25,
        F_max_motor_N: float = 5.15,
        kq_over_kt_m: float = 0.016,
        differential: Differential | str = Differential.THRUST,
        hover_throttle: float = 0.5,
    ) -> None:
        try:
            self.differential = Differential(differential)
        except ValueError:
            raise ValueError(f"differential must be 'thrust' or 'throttle', got {differential!r}") from None
        if not (0.0 < hover_throttle < 1.0):
            raise ValueError(f"hover_throttle must be in (0, 1), got {hover_throttle}")
        #: 1 / d_h for the throttle differential; None mixes in thrust.
        self._per_hover: float | None = 1.0 / hover_throttle if self.differential is Differential.THROTTLE else None
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
        gain = 1.0 if self._per_hover is None else d_c * self._per_hover
        rx, ry, rz = tx, ty, tz  # the request, for the controllers when nothing can be applied
        if gain != 1.0:
            tx, ty, tz = tx * gain, ty * gain, tz * gain
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
        applied = (ny[0] * f0 + ny[1] * f1 + ny[2] * f2 + ny[3] * f3,
                   px[0] * f0 + px[1] * f1 + px[2] * f2 + px[3] * f3,
                   sz[0] * f0 + sz[1] * f1 + sz[2] * f2 + sz[3] * f3)
        # in the controllers' units
        if gain == 1.0:
            command = applied
        elif gain > 0.0:
            command = (applied[0] / gain, applied[1] / gain, applied[2] / gain)
        else:  # no differential at zero collective: the request is what the firmware holds
            command = (rx, ry, rz)
        return MixResult(
            (sqrt(f0 * inv), sqrt(f1 * inv), sqrt(f2 * inv), sqrt(f3 * inv)),
            applied,
            saturated,
            sqrt((f0 + f1 + f2 + f3) * 0.25 * inv),
            command,
        )
