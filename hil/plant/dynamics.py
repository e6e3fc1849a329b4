"""The 17-state equations of motion and the fixed-step RK4, on plain floats.

Why it looks like this: numpy on a state this small is ~20x slower than scalar code
(docs/performance.md, The plant in scalar Python), so the derivative is hand-unrolled with every constant bound
as a closure variable (cheap to load), and ``rk4`` works on lists.

State ``x`` (list of 17 floats)::

    0-2   p_N      CG position, NED (m)
    3-5   v_N      CG velocity, NED (m/s)
    6-9   q_NB     attitude (w, x, y, z), body FRD -> NED
    10-12 w_B      body rates (rad/s)
    13-16 omega_i  rotor speeds (rad/s), i = rotor index

Inputs ``u`` (tuple of 20 floats), held over a step: four rotor speed commands (rad/s), the
wind at the CG (NED, m/s), the air density ratio sigma (ISA sea level = 1), then for each
rotor i the wind at its hub minus the wind at the CG, in body axes (m/s; 3 floats per
rotor, rotor 0 first): the spatial turbulence gradient across the airframe (wind.py).

Forces and moments (all at/about the CG):

* rotor i: thrust ``T_i = k_T f_i sigma g_e omega_i^2`` along -z_B at its hub; drag torque
  ``s_i k_Q f_i sigma omega_i^2`` and motor reaction ``s_i J_r d omega_i/dt`` about z_B
  (``s_i = +1`` counter-clockwise from above); rotor angular momentum
  ``-s_i J_r omega_i e_z`` enters the gyroscopic term.
* body (parasitic) drag on the CG's air-relative velocity in body axes, linear + quadratic
  per axis, acting at the centre of pressure ``r_cp`` (a moment ``r_cp x F`` about the CG).
* per rotor, from the air-relative velocity at its hub ``v_i = v_B + w x r_i - dw_i``
  (body motion, body rotation and the local gust; aero.py has the model and its sources):
  rotor drag (H-force) ``-sigma omega_i (k_d v_ix, k_d v_iy, k_z v_iz)`` at the hub, and
  the blade-flapping hub moment ``sigma k_f omega_i (-v_iy, v_ix, 0)`` (disk tilts away from
  the relative wind: nose up when moving forward).
* rotational damping per axis; all aerodynamic terms scale with sigma.
* ground effect ``g_e`` from the height of the level rotor plane (see aero.py).
* gravity ``+g`` along z_N.

Euler: ``J dw/dt = M - w x (J w + h_r)``; quaternion: ``dq/dt = q * (0, w) / 2``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]
State = list[float]
Inputs = tuple[float, ...]  # 20 floats, see the module docstring
Derivative = Callable[[Sequence[float], Inputs], tuple[float, ...]]

N_STATES = 17


@dataclass(frozen=True)
class DynamicsConstants:
    """Everything the derivative needs, in SI units, rotor quantities per rotor index."""

    gravity_mps2: float
    mass_kg: float
    inertia_B_kgm2: Mat3
    inverse_inertia_B: Mat3
    #: Hub x, y, z relative to the CG (body FRD, m).
    rotor_x_m: tuple[float, float, float, float]
    rotor_y_m: tuple[float, float, float, float]
    rotor_z_m: tuple[float, float, float, float]
    #: k_T * thrust factor (N/(rad/s)^2).
    k_T: tuple[float, float, float, float]
    #: spin sign * k_Q * thrust factor (N m/(rad/s)^2).
    k_Q_signed: tuple[float, float, float, float]
    #: spin sign * rotor inertia (kg m^2).
    j_rotor_signed: tuple[float, float, float, float]
    tau_up_s: float
    tau_down_s: float
    linear_drag: Vec3
    quadratic_drag: Vec3
    #: Rotor drag in the rotor plane / along the shaft, per rotor (N per m/s per rad/s).
    rotor_drag: float
    rotor_drag_z: float
    #: Blade-flapping hub moment per rotor (N m per m/s per rad/s).
    flapping: float
    #: Body centre of pressure relative to the CG (body FRD, m).
    cp_m: Vec3
    angular_drag: Vec3
    #: Rotor-plane height above ground is ``ge_z0_m - p_N[2]`` (level approximation).
    ge_z0_m: float
    ge_cutoff_m: float
    ge_gain: Callable[[float], float]


def make_derivative(k: DynamicsConstants) -> Derivative:
    """Build ``f(x, u) -> dx/dt`` (a 17-tuple) with the constants bound in.

    Every helper (rotation matrix, body drag, the four hubs' rotor drag and flapping) is
    written out inline: the calls and the tuples between them cost more than the arithmetic
    (docs/performance.md, The plant in scalar Python). The operations and their order are
    those of the equations in the module docstring term by term, so the results are the
    same floats bit for bit (tests/unit/plant/test_dynamics_exact.py keeps them so)."""
    g = k.gravity_mps2
    minv = 1.0 / k.mass_kg
    (jxx, jxy, jxz), (_, jyy, jyz), (_, _, jzz) = k.inertia_B_kgm2
    (ixx, ixy, ixz), (iyx, iyy, iyz), (izx, izy, izz) = k.inverse_inertia_B
    rx0, rx1, rx2, rx3 = k.rotor_x_m
    ry0, ry1, ry2, ry3 = k.rotor_y_m
    rz0, rz1, rz2, rz3 = k.rotor_z_m
    kt0, kt1, kt2, kt3 = k.k_T
    kq0, kq1, kq2, kq3 = k.k_Q_signed
    jr0, jr1, jr2, jr3 = k.j_rotor_signed
    tu = 1.0 / k.tau_up_s
    td = 1.0 / k.tau_down_s
    lin0, lin1, lin2 = k.linear_drag
    quad0, quad1, quad2 = k.quadratic_drag
    cpx, cpy, cpz = k.cp_m
    kd, kz, kf = k.rotor_drag, k.rotor_drag_z, k.flapping
    rotor_aero = kd > 0.0 or kz > 0.0 or kf > 0.0
    dax, day, daz = k.angular_drag
    ge_z0 = k.ge_z0_m
    ge_cut = k.ge_cutoff_m
    ge_gain = k.ge_gain

    def derivative(x: Sequence[float], u: Inputs) -> tuple[float, ...]:
        _, _, pz, vx, vy, vz, qw, qx, qy, qz, wx, wy, wz, o0, o1, o2, o3 = x
        c0, c1, c2, c3, wn, we, wd, sig = u[0], u[1], u[2], u[3], u[4], u[5], u[6], u[7]
        # Motor lag, separate time constants up/down.
        d0 = (c0 - o0) * (tu if c0 > o0 else td)
        d1 = (c1 - o1) * (tu if c1 > o1 else td)
        d2 = (c2 - o2) * (tu if c2 > o2 else td)
        d3 = (c3 - o3) * (tu if c3 > o3 else td)
        zr = ge_z0 - pz
        kk = sig * ge_gain(zr) if zr < ge_cut else sig
        t0 = kt0 * o0 * o0 * kk
        t1 = kt1 * o1 * o1 * kk
        t2 = kt2 * o2 * o2 * kk
        t3 = kt3 * o3 * o3 * kk
        # R(q) body -> NED (quat.to_matrix)
        r00 = 1.0 - 2.0 * (qy * qy + qz * qz)
        r01 = 2.0 * (qx * qy - qw * qz)
        r02 = 2.0 * (qx * qz + qw * qy)
        r10 = 2.0 * (qx * qy + qw * qz)
        r11 = 1.0 - 2.0 * (qx * qx + qz * qz)
        r12 = 2.0 * (qy * qz - qw * qx)
        r20 = 2.0 * (qx * qz - qw * qy)
        r21 = 2.0 * (qy * qz + qw * qx)
        r22 = 1.0 - 2.0 * (qx * qx + qy * qy)
        # Air-relative velocity of the CG in body axes, then body drag at the centre of
        # pressure: linear + quadratic per axis, scaled by sigma; its moment r_cp x F.
        ux, uy, uz = vx - wn, vy - we, vz - wd
        bx = r00 * ux + r10 * uy + r20 * uz
        by = r01 * ux + r11 * uy + r21 * uz
        bz = r02 * ux + r12 * uy + r22 * uz
        ex = -sig * (lin0 + quad0 * abs(bx)) * bx
        ey = -sig * (lin1 + quad1 * abs(by)) * by
        ez = -sig * (lin2 + quad2 * abs(bz)) * bz
        mx = cpy * ez - cpz * ey
        my = cpz * ex - cpx * ez
        mz = cpx * ey - cpy * ex
        fx, fy, fz = ex, ey, ez - (t0 + t1 + t2 + t3)
        if rotor_aero:
            # Per hub i: air velocity h = b + w x r_i - gust_i; H-force -sigma omega_i
            # (k_d hx, k_d hy, k_z hz) at the hub; flapping sigma k_f omega_i (-hy, hx, 0).
            nsd, nsz, sf = -(sig * kd), -(sig * kz), sig * kf
            hvx = bx + wy * rz0 - wz * ry0 - u[8]
            hvy = by + wz * rx0 - wx * rz0 - u[9]
            hvz = bz + wx * ry0 - wy * rx0 - u[10]
            a, b = nsd * o0, sf * o0
            hx, hy, hz = a * hvx, a * hvy, nsz * o0 * hvz
            fx += hx
            fy += hy
            fz += hz
            mx += ry0 * hz - rz0 * hy - b * hvy
            my += rz0 * hx - rx0 * hz + b * hvx
            mz += rx0 * hy - ry0 * hx
            hvx = bx + wy * rz1 - wz * ry1 - u[11]
            hvy = by + wz * rx1 - wx * rz1 - u[12]
            hvz = bz + wx * ry1 - wy * rx1 - u[13]
            a, b = nsd * o1, sf * o1
            hx, hy, hz = a * hvx, a * hvy, nsz * o1 * hvz
            fx += hx
            fy += hy
            fz += hz
            mx += ry1 * hz - rz1 * hy - b * hvy
            my += rz1 * hx - rx1 * hz + b * hvx
            mz += rx1 * hy - ry1 * hx
            hvx = bx + wy * rz2 - wz * ry2 - u[14]
            hvy = by + wz * rx2 - wx * rz2 - u[15]
            hvz = bz + wx * ry2 - wy * rx2 - u[16]
            a, b = nsd * o2, sf * o2
            hx, hy, hz = a * hvx, a * hvy, nsz * o2 * hvz
            fx += hx
            fy += hy
            fz += hz
            mx += ry2 * hz - rz2 * hy - b * hvy
            my += rz2 * hx - rx2 * hz + b * hvx
            mz += rx2 * hy - ry2 * hx
            hvx = bx + wy * rz3 - wz * ry3 - u[17]
            hvy = by + wz * rx3 - wx * rz3 - u[18]
            hvz = bz + wx * ry3 - wy * rx3 - u[19]
            a, b = nsd * o3, sf * o3
            hx, hy, hz = a * hvx, a * hvy, nsz * o3 * hvz
            fx += hx
            fy += hy
            fz += hz
            mx += ry3 * hz - rz3 * hy - b * hvy
            my += rz3 * hx - rx3 * hz + b * hvx
            mz += rx3 * hy - ry3 * hx
        ax = (r00 * fx + r01 * fy + r02 * fz) * minv
        ay = (r10 * fx + r11 * fy + r12 * fz) * minv
        az = (r20 * fx + r21 * fy + r22 * fz) * minv + g
        # Thrust and rotor moments about the CG.
        hr = jr0 * o0 + jr1 * o1 + jr2 * o2 + jr3 * o3
        mx += -(ry0 * t0 + ry1 * t1 + ry2 * t2 + ry3 * t3) - sig * dax * wx + wy * hr
        my += rx0 * t0 + rx1 * t1 + rx2 * t2 + rx3 * t3 - sig * day * wy - wx * hr
        mz += (
            sig * (kq0 * o0 * o0 + kq1 * o1 * o1 + kq2 * o2 * o2 + kq3 * o3 * o3)
            + jr0 * d0
            + jr1 * d1
            + jr2 * d2
            + jr3 * d3
            - sig * daz * wz
        )
        hx = jxx * wx + jxy * wy + jxz * wz
        hy = jxy * wx + jyy * wy + jyz * wz
        hz = jxz * wx + jyz * wy + jzz * wz
        mx -= wy * hz - wz * hy
        my -= wz * hx - wx * hz
        mz -= wx * hy - wy * hx
        return (
            vx,
            vy,
            vz,
            ax,
            ay,
            az,
            -0.5 * (qx * wx + qy * wy + qz * wz),
            0.5 * (qw * wx + qy * wz - qz * wy),
            0.5 * (qw * wy + qz * wx - qx * wz),
            0.5 * (qw * wz + qx * wy - qy * wx),
            ixx * mx + ixy * my + ixz * mz,
            iyx * mx + iyy * my + iyz * mz,
            izx * mx + izy * my + izz * mz,
            d0,
            d1,
            d2,
            d3,
        )

    return derivative


def rk4_step(f: Derivative, x: State, u: Inputs, h: float) -> State:
    """One classical RK4 step of length ``h`` (s); renormalises the quaternion.

    The stages' states are written out per element rather than zipped: the list building
    was a fifth of the step (same operations, same order, same floats)."""
    hh = 0.5 * h
    x0, x1, x2, x3, x4, x5, x6, x7, x8, x9, x10, x11, x12, x13, x14, x15, x16 = x
    k1 = f(x, u)
    a0, a1, a2, a3, a4, a5, a6, a7, a8, a9, a10, a11, a12, a13, a14, a15, a16 = k1
    k2 = f([x0 + hh * a0, x1 + hh * a1, x2 + hh * a2, x3 + hh * a3, x4 + hh * a4, x5 + hh * a5,
            x6 + hh * a6, x7 + hh * a7, x8 + hh * a8, x9 + hh * a9, x10 + hh * a10, x11 + hh * a11,
            x12 + hh * a12, x13 + hh * a13, x14 + hh * a14, x15 + hh * a15, x16 + hh * a16], u)
    b0, b1, b2, b3, b4, b5, b6, b7, b8, b9, b10, b11, b12, b13, b14, b15, b16 = k2
    k3 = f([x0 + hh * b0, x1 + hh * b1, x2 + hh * b2, x3 + hh * b3, x4 + hh * b4, x5 + hh * b5,
            x6 + hh * b6, x7 + hh * b7, x8 + hh * b8, x9 + hh * b9, x10 + hh * b10, x11 + hh * b11,
            x12 + hh * b12, x13 + hh * b13, x14 + hh * b14, x15 + hh * b15, x16 + hh * b16], u)
    c0, c1, c2, c3, c4, c5, c6, c7, c8, c9, c10, c11, c12, c13, c14, c15, c16 = k3
    k4 = f([x0 + h * c0, x1 + h * c1, x2 + h * c2, x3 + h * c3, x4 + h * c4, x5 + h * c5,
            x6 + h * c6, x7 + h * c7, x8 + h * c8, x9 + h * c9, x10 + h * c10, x11 + h * c11,
            x12 + h * c12, x13 + h * c13, x14 + h * c14, x15 + h * c15, x16 + h * c16], u)
    d0, d1, d2, d3, d4, d5, d6, d7, d8, d9, d10, d11, d12, d13, d14, d15, d16 = k4
    h6 = h / 6.0
    qw = x6 + h6 * (a6 + 2.0 * (b6 + c6) + d6)
    qx = x7 + h6 * (a7 + 2.0 * (b7 + c7) + d7)
    qy = x8 + h6 * (a8 + 2.0 * (b8 + c8) + d8)
    qz = x9 + h6 * (a9 + 2.0 * (b9 + c9) + d9)
    n = (qw * qw + qx * qx + qy * qy + qz * qz) ** -0.5
    return [x0 + h6 * (a0 + 2.0 * (b0 + c0) + d0), x1 + h6 * (a1 + 2.0 * (b1 + c1) + d1),
            x2 + h6 * (a2 + 2.0 * (b2 + c2) + d2), x3 + h6 * (a3 + 2.0 * (b3 + c3) + d3),
            x4 + h6 * (a4 + 2.0 * (b4 + c4) + d4), x5 + h6 * (a5 + 2.0 * (b5 + c5) + d5),
            qw * n, qx * n, qy * n, qz * n,
            x10 + h6 * (a10 + 2.0 * (b10 + c10) + d10), x11 + h6 * (a11 + 2.0 * (b11 + c11) + d11),
            x12 + h6 * (a12 + 2.0 * (b12 + c12) + d12), x13 + h6 * (a13 + 2.0 * (b13 + c13) + d13),
            x14 + h6 * (a14 + 2.0 * (b14 + c14) + d14), x15 + h6 * (a15 + 2.0 * (b15 + c15) + d15),
            x16 + h6 * (a16 + 2.0 * (b16 + c16) + d16)]
