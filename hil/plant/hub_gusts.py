"""The wind at each rotor hub relative to the wind at the CG, in body axes: the gust
differences that act on each rotor (rotor drag, flapping) and so make moments, from the
wind's NED gradient and the attitude.
"""

from __future__ import annotations

from collections.abc import Sequence

from hil.plant.wind import ZERO_GRADIENT, Mat3Flat

Vec3 = tuple[float, float, float]
#: No gradient: every hub has the CG's wind (3 zeros per hub).
NO_GUST_OFFSETS = (0.0,) * 12


def gust_offsets_B(gradient_N: Mat3Flat, x: Sequence[float], hubs_B_m: tuple[Vec3, ...]) -> tuple[float, ...]:
    """Wind at each hub minus wind at the CG, body axes (12 floats, m/s, 3 per hub), from the
    wind's NED gradient ``gradient_N`` (d(wind_N)/d(p_N), 1/s, row-major) and the attitude
    in the state ``x`` (``q_NB`` at x[6:10]): ``R^T G_N R r_i`` (held over the tick).
    ``hubs_B_m``: each hub's position from the CG, body FRD (m)."""
    g = gradient_N
    if g is ZERO_GRADIENT:
        return NO_GUST_OFFSETS
    qw, qx, qy, qz = x[6], x[7], x[8], x[9]
    r00 = 1.0 - 2.0 * (qy * qy + qz * qz)
    r01 = 2.0 * (qx * qy - qw * qz)
    r02 = 2.0 * (qx * qz + qw * qy)
    r10 = 2.0 * (qx * qy + qw * qz)
    r11 = 1.0 - 2.0 * (qx * qx + qz * qz)
    r12 = 2.0 * (qy * qz - qw * qx)
    r20 = 2.0 * (qx * qz - qw * qy)
    r21 = 2.0 * (qy * qz + qw * qx)
    r22 = 1.0 - 2.0 * (qx * qx + qy * qy)
    g00, g01, g02, g10, g11, g12, g20, g21, g22 = g
    # A = G R, then M = R^T A (body-axes gradient), unrolled: this runs every tick
    a00 = g00 * r00 + g01 * r10 + g02 * r20
    a01 = g00 * r01 + g01 * r11 + g02 * r21
    a02 = g00 * r02 + g01 * r12 + g02 * r22
    a10 = g10 * r00 + g11 * r10 + g12 * r20
    a11 = g10 * r01 + g11 * r11 + g12 * r21
    a12 = g10 * r02 + g11 * r12 + g12 * r22
    a20 = g20 * r00 + g21 * r10 + g22 * r20
    a21 = g20 * r01 + g21 * r11 + g22 * r21
    a22 = g20 * r02 + g21 * r12 + g22 * r22
    m00 = r00 * a00 + r10 * a10 + r20 * a20
    m01 = r00 * a01 + r10 * a11 + r20 * a21
    m02 = r00 * a02 + r10 * a12 + r20 * a22
    m10 = r01 * a00 + r11 * a10 + r21 * a20
    m11 = r01 * a01 + r11 * a11 + r21 * a21
    m12 = r01 * a02 + r11 * a12 + r21 * a22
    m20 = r02 * a00 + r12 * a10 + r22 * a20
    m21 = r02 * a01 + r12 * a11 + r22 * a21
    m22 = r02 * a02 + r12 * a12 + r22 * a22
    out: list[float] = []
    for hx, hy, hz in hubs_B_m:
        out += (
            m00 * hx + m01 * hy + m02 * hz,
            m10 * hx + m11 * hy + m12 * hz,
            m20 * hx + m21 * hy + m22 * hz,
        )
    return tuple(out)
