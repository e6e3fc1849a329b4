"""ADXL335: specific force in body axes -> three output volts (static part).

ADI ADXL335 Rev. B: ratiometric, sensitivity 0.1 Vs per g and zero-g at Vs / 2 (with
per-unit tolerances), cross-axis +-1 %, output swing ~0.1 V to Vs - 0.2 V; the output
bandwidth is set by the external capacitors with the internal 32 kOhm, f = 1 / (2 pi R C);
rms noise = density x sqrt(pi / 2 x f) for that single pole. The accelerometer measures
specific force (at rest, flat, Z up: +1 g on Z).
"""

from __future__ import annotations

import math

import numpy as np

from emulators.analog.params import G0_MPS2, Adxl335Params

NDArray = np.ndarray


def mount_matrix(params: Adxl335Params) -> NDArray:
    """R_SB (3x3): sensor-axis vector = R_SB @ body-axis (FRD) vector."""
    return np.array(params.mount_R_SB, dtype=float)


def nominal_V(f_B_mps2: NDArray, params: Adxl335Params) -> NDArray:
    """Ideal part: Vs/2 + 0.1 Vs/g * (R_SB f_B) / g0, shape (3,), no clipping."""
    a_S_g = mount_matrix(params) @ np.asarray(f_B_mps2, dtype=float) / G0_MPS2
    vs = params.supply_V
    return vs / 2.0 + params.sensitivity_per_g * vs * a_S_g


def nominal_f_B_mps2(v_V: NDArray, params: Adxl335Params) -> NDArray:
    """Inverse of :func:`nominal_V` (what the flight code computes before calibration)."""
    vs = params.supply_V
    a_S_g = (np.asarray(v_V, dtype=float) - vs / 2.0) / (params.sensitivity_per_g * vs)
    return mount_matrix(params).T @ a_S_g * G0_MPS2


class Adxl335:
    """One sensor with this unit's tolerances drawn from ``rng``."""

    def __init__(self, params: Adxl335Params, rng: np.random.Generator) -> None:
        self.params = params
        vs = params.supply_V
        self.R_SB = mount_matrix(params)
        tol = params.sensitivity_tolerance
        #: This unit's sensitivity per axis, V/g.
        self.sensitivity_V_per_g = params.sensitivity_per_g * vs * (1.0 + rng.uniform(-tol, tol, 3))
        z_tol = np.array(params.zero_g_tolerance_V_at_3V) * vs / 3.0
        #: This unit's zero-g output offset from Vs/2 per axis at 25 C, V.
        self.zero_g_offset_V = rng.uniform(-1.0, 1.0, 3) * z_tol
        drift = np.array(params.zero_g_drift_mg_per_C)
        self.zero_g_drift_g_per_C = rng.uniform(-1.0, 1.0, 3) * drift * 1e-3
        c = params.cross_axis_fraction
        cross = rng.uniform(-c, c, (3, 3))
        np.fill_diagonal(cross, 0.0)
        #: Sensed acceleration = (I + cross) @ true acceleration, sensor axes.
        self.cross_axis = np.eye(3) + cross
        self.tau_s = tuple(1.0 / (2.0 * math.pi * params.f3db_Hz(i)) for i in range(3))
        density_V = np.array(params.noise_density_ug_per_rtHz_at_3V) * 1e-6 * params.sensitivity_per_g * 3.0
        #: Output noise per axis after the output RC, V rms (noise is constant in volts).
        self.noise_V_rms = tuple(
            float(density_V[i] * math.sqrt(math.pi / 2.0 * params.f3db_Hz(i))) for i in range(3)
        )
        # The per-axis terms of static_V as floats for static_V_floats.
        self._drift = tuple(self.zero_g_drift_g_per_C.tolist())
        self._offset = tuple(self.zero_g_offset_V.tolist())
        self._sens = tuple(self.sensitivity_V_per_g.tolist())

    @property
    def swing_V(self) -> tuple[float, float]:
        p = self.params
        return p.swing_low_V, p.supply_V - p.swing_high_below_supply_V

    def static_V(self, f_B_mps2: NDArray, T_C: float) -> NDArray:
        """Settled outputs (3,) for specific force ``f_B_mps2`` (body FRD) at ``T_C``."""
        vs = self.params.supply_V
        a_S_g = self.cross_axis @ (self.R_SB @ np.asarray(f_B_mps2, dtype=float)) / G0_MPS2
        a_S_g = a_S_g + self.zero_g_drift_g_per_C * (T_C - 25.0)
        v = vs / 2.0 + self.zero_g_offset_V + self.sensitivity_V_per_g * a_S_g
        lo, hi = self.swing_V
        return np.clip(v, lo, hi)

    def static_V_floats(self, f_B_mps2: tuple[float, float, float], T_C: float) -> list[float]:
        """:meth:`static_V` as three floats, bit for bit: the element-wise steps in Python
        floats (the same IEEE operations in the same order), the matrix products numpy's."""
        p = self.params
        a = (self.cross_axis @ (self.R_SB @ np.array(f_B_mps2, dtype=float))).tolist()
        dT = float(T_C) - 25.0
        half = p.supply_V / 2.0
        lo, hi = self.swing_V
        out = []
        for i in range(3):
            g = a[i] / G0_MPS2 + self._drift[i] * dT
            v = half + self._offset[i] + self._sens[i] * g
            out.append(min(max(v, lo), hi))  # np.clip(v, lo, hi); NaN stays NaN
        return out
