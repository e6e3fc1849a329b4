"""Rotations and the device's output frames (scalar math: this runs 400 times a second).

Quaternions are ``(w, x, y, z)``, Hamilton convention; ``q_AB`` rotates vectors of frame B
into frame A: ``v_A = q_AB * v_B * conj(q_AB)``. Euler angles are ZYX (yaw, pitch, roll),
returned as ``(roll, pitch, yaw)``.

Input frames (set by the bench): reference NED; sensor frame S is FRD-like (x forward,
y right, z down). Output frames chosen by the XDI coordinate bits (legacy: settings bit 31):

* NED (0x4): orientation ``q_NS`` as given; vectors in S as given.
* ENU (0x0, the mk4 default): reference ENU and sensor frame S' = x forward, y left, z up:
  ``q_ES' = q_EN * q_NS * q_SS'`` with ``q_EN`` the 180 deg turn about (1, 1, 0)/sqrt(2)
  and ``q_SS'`` the 180 deg turn about x; vectors ``v_S' = (x, -y, -z)``.
* NWU (0x8, the legacy default): reference NWU (``q_WN`` = 180 deg about x), sensor frame
  S' as for ENU: ``q_WS' = q_WN * q_NS * q_SS'``; vectors ``v_S' = (x, -y, -z)``.

So a level sensor facing north reads yaw 0 in NED and NWU and yaw +90 deg in ENU, and its
specific force reads (0, 0, -g) with NED bits and (0, 0, +g) otherwise.
"""

from __future__ import annotations

import math

from emulators.xsens.defs import CoordSys

Quat = tuple[float, float, float, float]
Vec3 = tuple[float, float, float]

_H = math.sqrt(0.5)
Q_IDENTITY: Quat = (1.0, 0.0, 0.0, 0.0)
#: NED -> ENU reference change.
Q_EN: Quat = (0.0, _H, _H, 0.0)
#: NED -> NWU reference change.
Q_WN: Quat = (0.0, 1.0, 0.0, 0.0)
#: x-forward/y-left/z-up sensor frame S' -> FRD sensor frame S.
Q_SS: Quat = (0.0, 1.0, 0.0, 0.0)
_Q_REF: dict[CoordSys, Quat] = {CoordSys.ENU: Q_EN, CoordSys.NWU: Q_WN}
_RAD2DEG = 180.0 / math.pi


def quat_mul(a: Quat, b: Quat) -> Quat:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def quat_conj(q: Quat) -> Quat:
    return (q[0], -q[1], -q[2], -q[3])


def quat_normalize(q: Quat) -> Quat:
    """Unit quaternion with w >= 0 (the sign devices output); identity for a zero input."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if n == 0.0 or not math.isfinite(n):
        return Q_IDENTITY
    s = (1.0 if q[0] >= 0.0 else -1.0) / n
    # "+ 0.0" turns -0.0 into 0.0 so exact axes do not go out as 0x80000000
    return (q[0] * s + 0.0, q[1] * s + 0.0, q[2] * s + 0.0, q[3] * s + 0.0)


def rotate(q: Quat, v: Vec3) -> Vec3:
    """``R(q) v`` for a unit quaternion."""
    w, x, y, z = q
    vx, vy, vz = v
    # t = 2 (q_vec x v); v' = v + w t + q_vec x t
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (
        vx + w * tx + y * tz - z * ty,
        vy + w * ty + z * tx - x * tz,
        vz + w * tz + x * ty - y * tx,
    )


def rotate_inv(q: Quat, v: Vec3) -> Vec3:
    """``R(q)^T v``."""
    return rotate(quat_conj(q), v)


def quat_to_matrix(q: Quat) -> tuple[Vec3, Vec3, Vec3]:
    """Rows of the rotation matrix ``R(q)``."""
    w, x, y, z = q
    return (
        (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )


def quat_to_euler_deg(q: Quat) -> Vec3:
    """ZYX Euler angles ``(roll, pitch, yaw)`` in degrees; yaw and roll in (-180, 180]."""
    w, x, y, z = q
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    s = 2.0 * (w * y - z * x)
    pitch = math.asin(1.0 if s > 1.0 else -1.0 if s < -1.0 else s)
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return (roll * _RAD2DEG, pitch * _RAD2DEG, yaw * _RAD2DEG)


def euler_deg_to_quat(roll_deg: float, pitch_deg: float, yaw_deg: float) -> Quat:
    """Inverse of :func:`quat_to_euler_deg` (w >= 0)."""
    hr, hp, hy = (math.radians(a) * 0.5 for a in (roll_deg, pitch_deg, yaw_deg))
    cr, sr, cp, sp, cy, sy = math.cos(hr), math.sin(hr), math.cos(hp), math.sin(hp), math.cos(hy), math.sin(hy)
    return quat_normalize((
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ))


def orientation_in(q_NS: Quat, coord: CoordSys) -> Quat:
    """The sensor orientation expressed in the output frame selected by ``coord``."""
    if coord is CoordSys.NED:
        return quat_normalize(q_NS)
    return quat_normalize(quat_mul(quat_mul(_Q_REF[coord], q_NS), Q_SS))


def vector_in(v_S: Vec3, coord: CoordSys) -> Vec3:
    """A sensor-frame vector in the output sensor frame (FRD for NED, else x-fwd/y-left/z-up)."""
    if coord is CoordSys.NED:
        return v_S
    return (v_S[0], -v_S[1], -v_S[2])


def gravity_in(g_mps2: float, coord: CoordSys) -> Vec3:
    """Gravity acceleration in the output reference frame (down is +z only for NED)."""
    return (0.0, 0.0, g_mps2) if coord is CoordSys.NED else (0.0, 0.0, -g_mps2)


def delta_q(omega_radps: Vec3, dt_s: float) -> Quat:
    """Orientation increment over ``dt_s`` at constant body rate (strapdown DeltaQ)."""
    wx, wy, wz = omega_radps
    rate = math.sqrt(wx * wx + wy * wy + wz * wz)
    half = 0.5 * rate * dt_s
    if rate == 0.0:
        return Q_IDENTITY
    s = math.sin(half) / rate
    return (math.cos(half), wx * s, wy * s, wz * s)
