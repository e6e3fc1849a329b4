"""Scalar quaternion and rotation helpers on plain float tuples (no numpy: docs/performance.md).

Convention: ``q = (w, x, y, z)``, Hamilton product, ``q_AB`` rotates vectors expressed in
frame B into frame A: ``v_A = q_AB * v_B * conj(q_AB) = R(q_AB) v_B``. Euler angles are
ZYX (yaw about z, then pitch about the new y, then roll about the new x), returned and
taken as ``(roll, pitch, yaw)`` in radians, so ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
"""

from __future__ import annotations

import math

Quat = tuple[float, float, float, float]
Vec3 = tuple[float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]

IDENTITY: Quat = (1.0, 0.0, 0.0, 0.0)


def mul(a: Quat, b: Quat) -> Quat:
    """Hamilton product ``a * b`` (apply ``b`` first, then ``a``: q_AC = q_AB * q_BC)."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def conj(q: Quat) -> Quat:
    """Conjugate, the inverse of a unit quaternion (q_BA from q_AB)."""
    return (q[0], -q[1], -q[2], -q[3])


def normalized(q: Quat) -> Quat:
    """``q / |q|``; raises ValueError for a zero or non-finite quaternion (our misuse)."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if not (n > 0.0 and math.isfinite(n)):
        raise ValueError(f"cannot normalise quaternion {q}")
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def to_matrix(q: Quat) -> Mat3:
    """Rotation matrix R(q) (rows), for a unit quaternion."""
    w, x, y, z = q
    return (
        (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)),
        (2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)),
        (2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)),
    )


def rotate(q: Quat, v: Vec3) -> Vec3:
    """``R(q) v``: a vector in frame B expressed in frame A, for q = q_AB."""
    r = to_matrix(q)
    return (
        r[0][0] * v[0] + r[0][1] * v[1] + r[0][2] * v[2],
        r[1][0] * v[0] + r[1][1] * v[1] + r[1][2] * v[2],
        r[2][0] * v[0] + r[2][1] * v[1] + r[2][2] * v[2],
    )


def rotate_inv(q: Quat, v: Vec3) -> Vec3:
    """``R(q)^T v``: a vector in frame A expressed in frame B, for q = q_AB."""
    r = to_matrix(q)
    return (
        r[0][0] * v[0] + r[1][0] * v[1] + r[2][0] * v[2],
        r[0][1] * v[0] + r[1][1] * v[1] + r[2][1] * v[2],
        r[0][2] * v[0] + r[1][2] * v[1] + r[2][2] * v[2],
    )


def from_euler(roll_rad: float, pitch_rad: float, yaw_rad: float) -> Quat:
    """Quaternion of ``Rz(yaw) Ry(pitch) Rx(roll)`` (ZYX Euler)."""
    cr, sr = math.cos(0.5 * roll_rad), math.sin(0.5 * roll_rad)
    cp, sp = math.cos(0.5 * pitch_rad), math.sin(0.5 * pitch_rad)
    cy, sy = math.cos(0.5 * yaw_rad), math.sin(0.5 * yaw_rad)
    return (
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    )


def to_euler(q: Quat) -> Vec3:
    """ZYX Euler ``(roll, pitch, yaw)`` in radians of a unit quaternion.

    Pitch is in [-pi/2, pi/2] (clamped at gimbal lock), roll and yaw in (-pi, pi].
    """
    w, x, y, z = q
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    s = 2.0 * (w * y - z * x)
    pitch = math.asin(1.0 if s > 1.0 else -1.0 if s < -1.0 else s)
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return (roll, pitch, yaw)


def yaw_only(q: Quat) -> Quat:
    """The level attitude with the same heading (ZYX yaw) as ``q``."""
    yaw = to_euler(q)[2]
    return (math.cos(0.5 * yaw), 0.0, 0.0, math.sin(0.5 * yaw))


def cross(a: Vec3, b: Vec3) -> Vec3:
    """``a x b``."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
