"""What the sensors feel of the vehicle: the noise-free inputs of the IMU, the ADXL335 and
the static port (``SensorTruth``) from the rigid-body state, where each sensor sits and how
the IMU is turned, the air at the port, and the rotor imbalance's vibration tones.
"""

from __future__ import annotations

import math

from hil.plant import ground, quat
from hil.plant.aero import BaroWash
from hil.plant.atmosphere import ZERO_C_K, Atmosphere
from hil.plant.params_vehicle import SensorMountParams
from hil.plant.records import SensorTruth, VibrationTone
from hil.plant.vibration import RotorImbalance

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Four = tuple[float, float, float, float]


def _specific_force_at(r_B_m: Vec3, cg_B_m: Vec3, f_cg_B: Vec3, alpha: Vec3, w: Vec3) -> Vec3:
    """Specific force (body axes, m/s^2) at ``r_B_m`` (body FRD from the body origin, m), from
    the CG's ``f_cg_B`` and the lever arm from the CG ``cg_B_m``: angular acceleration
    ``alpha`` (rad/s^2) and rate ``w`` (rad/s), both body axes."""
    c = cg_B_m
    r = (r_B_m[0] - c[0], r_B_m[1] - c[1], r_B_m[2] - c[2])
    a1 = quat.cross(alpha, r)
    a2 = quat.cross(w, quat.cross(w, r))
    return (f_cg_B[0] + a1[0] + a2[0], f_cg_B[1] + a1[1] + a2[1], f_cg_B[2] + a1[2] + a2[2])


class Sensing:
    """The sensors on one vehicle: ``mount`` (positions, the IMU's turn), the air they read
    (``atmo``, the rotor wash at the static port ``wash``), gravity (m/s^2), the landing-gear
    depth (m: the ground is that far below the body origin at rest) and the rotor-imbalance
    model (None: no vibration)."""

    def __init__(
        self,
        mount: SensorMountParams,
        atmo: Atmosphere,
        wash: BaroWash,
        gravity_mps2: float,
        gear_depth_m: float,
        vib: RotorImbalance | None,
    ) -> None:
        self.mount = mount
        #: The IMU's sensor frame S relative to the body: rotates S vectors into body axes.
        self.q_BS = quat.from_euler(*(math.radians(a) for a in mount.imu_rotation_BS_rpy_deg))
        self._atmo = atmo
        self._wash = wash
        self._g = gravity_mps2
        self._gear_m = gear_depth_m
        self._vib = vib

    def truth(
        self, t_ns: int, x: list[float], a_N: Vec3, alpha: Vec3, cg_B_m: Vec3, thrust_N: Four
    ) -> SensorTruth:
        """Noise-free sensor inputs at sim time ``t_ns`` (see SensorTruth) from the 17-state
        ``x`` (dynamics.py), the CG's acceleration ``a_N`` (NED, m/s^2) and the angular
        acceleration ``alpha`` (body, rad/s^2), the CG ``cg_B_m`` (body FRD from the body
        origin, m) and the four rotors' thrusts (N)."""
        m = self.mount
        q: Quat = (x[6], x[7], x[8], x[9])
        w: Vec3 = (x[10], x[11], x[12])
        f_cg_B = quat.rotate_inv(q, (a_N[0], a_N[1], a_N[2] - self._g))
        f_imu_B = _specific_force_at(m.imu_position_B_m, cg_B_m, f_cg_B, alpha, w)
        f_acc_B = _specific_force_at(m.accel_position_B_m, cg_B_m, f_cg_B, alpha, w)
        q_SB = quat.conj(self.q_BS)
        h = ground.origin_height_m(x, cg_B_m)
        port_above_ground = h + self._gear_m - quat.rotate(q, m.baro_position_B_m)[2]
        total_thrust = sum(thrust_N)
        vib_f_S: tuple[VibrationTone, ...] = ()
        vib_w_S: tuple[VibrationTone, ...] = ()
        vib_f_acc_B: tuple[VibrationTone, ...] = ()
        if self._vib is not None:
            vib_f_S, vib_w_S, vib_f_acc_B = self._vib.tones((x[13], x[14], x[15], x[16]))
        return SensorTruth(
            t_ns=t_ns,
            q_NS=quat.mul(q, self.q_BS),
            omega_S_radps=quat.rotate(q_SB, w),
            f_S_mps2=quat.rotate(q_SB, f_imu_B),
            f_acc_B_mps2=f_acc_B,
            p_static_Pa=self._atmo.pressure_Pa(port_above_ground) + self._wash.error_Pa(total_thrust, h),
            air_T_C=self._atmo.temperature_K(port_above_ground) - ZERO_C_K,
            vib_f_S=vib_f_S,
            vib_omega_S=vib_w_S,
            vib_f_acc_B=vib_f_acc_B,
        )
