"""Sensor error model: white noise, turn-on biases, gyro bias random walk, orientation error.

All errors live in the input frames (NED reference, FRD sensor frame S), before the
output-frame conversion, so every output frame sees the same physical error.

* Rate of turn: ``omega + b_g + n_g``; ``b_g`` drawn at power-on (sigma
  ``gyro_bias_sigma_radps``) and random-walking, ``b_g += sigma_rw * sqrt(dt) * N``;
  ``n_g`` white with per-sample sigma = density * sqrt(sample_rate_hz).
* Specific force: ``f + b_a + n_a`` (constant turn-on bias, white noise).
* Orientation: the onboard filter's error, bounded (it is corrected by gravity and the
  magnetic field), modelled as a turn-on Euler-angle offset plus white noise per sample,
  added to the true ZYX angles.

Random numbers are drawn in a fixed order (9 normals at power-on, then 12 per sample, taken
from blocks of 64 samples) from the Generator the device was given, so a run is
reproducible from its seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from emulators.xsens.frames import Quat, Vec3, euler_deg_to_quat, quat_to_euler_deg
from emulators.xsens.params import XsensParams


@dataclass(frozen=True, init=False)
class Measured:
    """One sample as the sensor measured it (input frames)."""

    q_NS: Quat
    omega_S_radps: Vec3
    f_S_mps2: Vec3

    def __init__(self, q_NS: Quat, omega_S_radps: Vec3, f_S_mps2: Vec3) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "q_NS", q_NS)
        object.__setattr__(self, "omega_S_radps", omega_S_radps)
        object.__setattr__(self, "f_S_mps2", f_S_mps2)


#: Samples' worth of normals drawn per Generator call.
_BLOCK_SAMPLES = 64


class ErrorModel:
    """Stateful error generator; ``power_on`` draws new turn-on errors."""

    def __init__(self, params: XsensParams, rng: np.random.Generator) -> None:
        self.p = params
        self.rng = rng
        root_rate = math.sqrt(params.sample_rate_hz)
        self._sig_g = params.gyro_noise_radps_per_rthz * root_rate
        self._sig_a = params.acc_noise_mps2_per_rthz * root_rate
        self.gyro_bias_S_radps: Vec3 = (0.0, 0.0, 0.0)
        self.acc_bias_S_mps2: Vec3 = (0.0, 0.0, 0.0)
        self.euler_offset_deg: Vec3 = (0.0, 0.0, 0.0)
        self._t_last_ns: int | None = None
        self._block: list[float] = []
        self._block_at = 0
        self.power_on()

    def power_on(self) -> None:
        p = self.p
        self._block, self._block_at = [], 0  # a new power-on starts a fresh block
        n = self.rng.standard_normal(9).tolist()
        self.gyro_bias_S_radps = (n[0] * p.gyro_bias_sigma_radps, n[1] * p.gyro_bias_sigma_radps,
                                  n[2] * p.gyro_bias_sigma_radps)
        self.acc_bias_S_mps2 = (n[3] * p.acc_bias_sigma_mps2, n[4] * p.acc_bias_sigma_mps2,
                                n[5] * p.acc_bias_sigma_mps2)
        self.euler_offset_deg = (n[6] * p.orientation_bias_rp_deg, n[7] * p.orientation_bias_rp_deg,
                                 n[8] * p.orientation_bias_yaw_deg)
        self._t_last_ns = None

    def _normals(self) -> list[float]:
        """The next 12 standard normals (drawn from the Generator in blocks: it is faster)."""
        if self._block_at >= len(self._block):
            self._block = self.rng.standard_normal(12 * _BLOCK_SAMPLES).tolist()
            self._block_at = 0
        i = self._block_at
        self._block_at += 12
        return self._block[i : i + 12]

    def measure(self, t_ns: int, q_NS: Quat, omega_S_radps: Vec3, f_S_mps2: Vec3) -> Measured:
        """Apply the errors to the true motion at sample time ``t_ns``."""
        p = self.p
        n = self._normals()
        dt_s = 0.0 if self._t_last_ns is None else max(t_ns - self._t_last_ns, 0) * 1e-9
        self._t_last_ns = t_ns
        rw = p.gyro_bias_rw_radps_per_rts * math.sqrt(dt_s)
        bg = self.gyro_bias_S_radps
        bg = (bg[0] + rw * n[0], bg[1] + rw * n[1], bg[2] + rw * n[2])
        self.gyro_bias_S_radps = bg
        sg, sa, ba = self._sig_g, self._sig_a, self.acc_bias_S_mps2
        omega = (omega_S_radps[0] + bg[0] + sg * n[3], omega_S_radps[1] + bg[1] + sg * n[4],
                 omega_S_radps[2] + bg[2] + sg * n[5])
        f = (f_S_mps2[0] + ba[0] + sa * n[6], f_S_mps2[1] + ba[1] + sa * n[7], f_S_mps2[2] + ba[2] + sa * n[8])
        off, so = self.euler_offset_deg, p.orientation_noise_deg
        if off == (0.0, 0.0, 0.0) and so == 0.0:
            return Measured(q_NS, omega, f)
        roll, pitch, yaw = quat_to_euler_deg(q_NS)
        q = euler_deg_to_quat(roll + off[0] + so * n[9], pitch + off[1] + so * n[10], yaw + off[2] + so * n[11])
        return Measured(q, omega, f)
