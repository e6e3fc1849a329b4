"""Rotor imbalance vibration: rotating forces at the rotor speeds, as tones at the sensors.

Rotor ``i`` with static imbalance U_i = m_u r_u (kg m) and heavy-spot angle theta_i (from body
+x, in its direction of rotation; theta_i' = omega_i) pushes on its hub with

    F_i(t) = U_i omega_i^2 (cos theta_i, s_i sin theta_i, 0)       body FRD, rotor plane
           = Re{ U_i omega_i^2 (1, -j s_i, 0) e^(j theta_i) }

with s_i = +1 for a rotor turning clockwise seen from above (+x towards +y), -1 for
counter-clockwise. The airframe is a free rigid body at these frequencies (97-133 Hz, far
above any rigid-body mode), so a point r (from the CG) accelerates with

    a = F / m + alpha x r,   alpha = J^-1 (h_i x F)                  (h_i: hub from the CG)

and rotates with Omega = integral of alpha = Re{ alpha e^(j theta) / (j omega) } in steady
state. Both are linear in F with real coefficients, so each rotor gives, at each sensor, a
complex amplitude per axis (a *tone*): ``v(t) = Re{(re + j im) e^(j phi(t))}``. The sensors
apply their own frequency response to it (emulators/vibration.py), which is exact for a
sinusoid and so never aliases inside the model: the sampled value is the filtered sinusoid at
the sample instant, and aliases as a real sampled sensor's would.

The vibration is not fed back into the rigid-body dynamics: at 96 Hz a 0.31 N force moves the
vehicle by 0.8 um and tilts it by 3e-6 rad, and resolving it would need RK4 steps well below
the 1.25 ms sub-step. Centripetal terms (Omega^2 r) are second order and dropped.

Phases are integrated from the rotor speeds with the trapezoidal rule on every RK4 sub-step,
so they are continuous when the speed changes. Randomness (per-rotor magnitude spread,
initial phases) comes from the Generator passed in, 8 uniforms drawn at construction.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from hil.plant.params_vehicle import VibrationParams
from hil.plant.records import VibrationTone

Vec3 = tuple[float, float, float]
_TWO_PI = 2.0 * math.pi
_NO_TONES: tuple[VibrationTone, ...] = ()


def _cross(a: Sequence[float], b: Sequence[float]) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _matvec(m: Sequence[Sequence[float]], v: Sequence[float]) -> Vec3:
    return (
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    )


class _Coefficients:
    """Per rotor, per unit of U omega^2: the real (re) and imaginary (im) amplitude vectors of
    the specific force at the IMU (sensor frame S) and at the ADXL335 (body axes), and of the
    angular acceleration (sensor frame S), as tuples (re_x, re_y, re_z, im_x, im_y, im_z)."""

    __slots__ = ("f_imu", "f_acc", "alpha_imu")

    def __init__(self, f_imu: tuple[float, ...], f_acc: tuple[float, ...], alpha_imu: tuple[float, ...]) -> None:
        self.f_imu = f_imu
        self.f_acc = f_acc
        self.alpha_imu = alpha_imu


class RotorImbalance:
    """Heavy-spot phases of the four rotors and the vibration tones they make at the sensors.

    ``params``: VibrationParams; ``spin_cw_from_above``: per rotor, True if it turns clockwise
    seen from above; ``rng``: the vibration Generator (magnitude spread, initial phases).
    Call :meth:`set_geometry` before :meth:`tones` (and again after a mass change).
    """

    def __init__(self, params: VibrationParams, spin_cw_from_above: Sequence[bool], rng: np.random.Generator) -> None:
        self.params = params
        self._s = tuple(1.0 if cw else -1.0 for cw in spin_cw_from_above)
        draws = rng.uniform(0.0, 1.0, 8).tolist()  # always 8, so one option does not shift the other's draws
        spread = params.imbalance_spread
        #: This vehicle's imbalance per rotor, kg m.
        self.imbalance_kgm: tuple[float, ...] = tuple(
            u * (1.0 + spread * (2.0 * d - 1.0)) for u, d in zip(params.imbalance_kgm, draws[:4], strict=True)
        )
        start = params.phase_rad if params.phase_rad is not None else tuple(_TWO_PI * d for d in draws[4:])
        #: Heavy-spot angles now, rad in [0, 2 pi).
        self.phase_rad = [math.fmod(float(p), _TWO_PI) % _TWO_PI for p in start]
        self._coef: tuple[_Coefficients, ...] = ()

    def set_geometry(
        self,
        hubs_B_m: Sequence[Vec3],
        mass_kg: float,
        inverse_inertia_B: Sequence[Sequence[float]],
        imu_B_m: Vec3,
        acc_B_m: Vec3,
        R_SB: Sequence[Sequence[float]],
    ) -> None:
        """Precompute the linear maps force -> sensor motion. Positions are from the CG
        (body FRD, m); ``R_SB`` turns body axes into the IMU's sensor axes."""
        coef = []
        for h, s in zip(hubs_B_m, self._s, strict=True):
            parts: list[list[tuple[float, ...]]] = [[], [], []]
            # F = Re{(e_x - j s e_y) e^(j theta)}: re from e_x, im from -s e_y
            for unit in ((1.0, 0.0, 0.0), (0.0, -s, 0.0)):
                alpha = _matvec(inverse_inertia_B, _cross(h, unit))
                lin = (unit[0] / mass_kg, unit[1] / mass_kg, 0.0)
                ai, aa = _cross(alpha, imu_B_m), _cross(alpha, acc_B_m)
                f_imu = _matvec(R_SB, (lin[0] + ai[0], lin[1] + ai[1], lin[2] + ai[2]))
                f_acc = (lin[0] + aa[0], lin[1] + aa[1], lin[2] + aa[2])
                parts[0].append(f_imu)
                parts[1].append(f_acc)
                parts[2].append(_matvec(R_SB, alpha))
            coef.append(_Coefficients(*(tuple(p[0]) + tuple(p[1]) for p in parts)))  # type: ignore[arg-type]
        self._coef = tuple(coef)

    def advance(self, omega_before: Sequence[float], omega_after: Sequence[float], dt_s: float) -> None:
        """Integrate the phases over ``dt_s`` with the rotor speeds going from ``omega_before``
        to ``omega_after`` (rad/s; trapezoidal rule, exact for a linear change)."""
        ph = self.phase_rad
        half = 0.5 * dt_s
        for i in range(4):
            p = ph[i] + half * (omega_before[i] + omega_after[i])
            ph[i] = p - _TWO_PI if p >= _TWO_PI else p  # one wrap per sub-step at most (< 2 pi per 1.25 ms)

    def tones(
        self, omega_radps: Sequence[float]
    ) -> tuple[tuple[VibrationTone, ...], tuple[VibrationTone, ...], tuple[VibrationTone, ...]]:
        """``(f_imu_S, omega_imu_S, f_acc_B)``: one tone per spinning rotor at the current
        phases: specific force at the IMU (sensor frame, m/s^2), its angular rate (sensor
        frame, rad/s) and specific force at the ADXL335 (body axes, m/s^2)."""
        f_imu: list[VibrationTone] = []
        w_imu: list[VibrationTone] = []
        f_acc: list[VibrationTone] = []
        for c, u, w, ph in zip(self._coef, self.imbalance_kgm, omega_radps, self.phase_rad, strict=True):
            if w <= 0.0 or u == 0.0:
                continue
            k = u * w * w
            a, b, r = c.f_imu, c.f_acc, c.alpha_imu
            f_imu.append(VibrationTone(w, ph, (k * a[0], k * a[1], k * a[2]), (k * a[3], k * a[4], k * a[5])))
            f_acc.append(VibrationTone(w, ph, (k * b[0], k * b[1], k * b[2]), (k * b[3], k * b[4], k * b[5])))
            # Omega = Re{A e^(j theta) / (j omega)}: re = A_im / omega, im = -A_re / omega
            kw = u * w
            w_imu.append(VibrationTone(w, ph, (kw * r[3], kw * r[4], kw * r[5]), (-kw * r[0], -kw * r[1], -kw * r[2])))
        if not f_imu:
            return _NO_TONES, _NO_TONES, _NO_TONES
        return tuple(f_imu), tuple(w_imu), tuple(f_acc)
