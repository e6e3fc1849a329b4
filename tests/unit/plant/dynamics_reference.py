"""The equations of motion as they were written before the derivative was inlined
(hil/plant/dynamics.py): one helper per term, the rotors in a loop, RK4 over zipped lists.
Kept as the reference the inlined code must equal bit for bit (test_dynamics_exact.py)."""

from __future__ import annotations

from collections.abc import Sequence

from hil.plant.dynamics import Derivative, DynamicsConstants, Inputs, State, Vec3, Vec4
from hil.plant.quat import to_matrix


def rotor_hub_aero_B(
    sd: float, sz: float, sf: float, o_radps: float,
    rx_m: float, ry_m: float, rz_m: float,
    bx_mps: float, by_mps: float, bz_mps: float,
    wx_radps: float, wy_radps: float, wz_radps: float,
    gx_mps: float, gy_mps: float, gz_mps: float,
) -> tuple[float, float, float, float, float, float]:
    """One rotor's H-force (N) at its hub and the moment it adds about the CG (N m), body FRD.

    ``sd``, ``sz``, ``sf``: sigma times rotor drag in-plane, along the shaft, and flapping;
    ``o_radps``: rotor speed; ``r*_m``: hub relative to the CG; ``b*_mps``: the CG's
    air-relative velocity; ``w*_radps``: body rates; ``g*_mps``: the hub's gust minus the
    CG's. Returns (Hx, Hy, Hz, dMx, dMy, dMz); the caller adds them in that order, so the
    floating-point sums are those of the former inline code.
    """
    hvx = bx_mps + wy_radps * rz_m - wz_radps * ry_m - gx_mps
    hvy = by_mps + wz_radps * rx_m - wx_radps * rz_m - gy_mps
    hvz = bz_mps + wx_radps * ry_m - wy_radps * rx_m - gz_mps
    hx_, hy_, hz_ = -sd * o_radps * hvx, -sd * o_radps * hvy, -sz * o_radps * hvz
    return (
        hx_,
        hy_,
        hz_,
        ry_m * hz_ - rz_m * hy_ - sf * o_radps * hvy,
        rz_m * hx_ - rx_m * hz_ + sf * o_radps * hvx,
        rx_m * hy_ - ry_m * hx_,
    )


def body_drag_B(
    sig: float, bx_mps: float, by_mps: float, bz_mps: float, lin: Vec3, quad: Vec3, cp_m: Vec3,
) -> tuple[float, float, float, float, float, float]:
    """Parasitic drag (N) on the CG's air-relative velocity ``b*_mps`` (body FRD), linear
    plus quadratic per axis, scaled by the density ratio ``sig``, and its moment about the CG
    from the centre of pressure ``cp_m`` (N m). Returns (Fx, Fy, Fz, Mx, My, Mz)."""
    ex = -sig * (lin[0] + quad[0] * abs(bx_mps)) * bx_mps
    ey = -sig * (lin[1] + quad[1] * abs(by_mps)) * by_mps
    ez = -sig * (lin[2] + quad[2] * abs(bz_mps)) * bz_mps
    cpx, cpy, cpz = cp_m
    return ex, ey, ez, cpy * ez - cpz * ey, cpz * ex - cpx * ez, cpx * ey - cpy * ex


def add_rotors_aero_B(
    sd: float, sz: float, sf: float, hubs_m: tuple[Vec3, ...], o: Vec4,
    bx_mps: float, by_mps: float, bz_mps: float, wx_radps: float, wy_radps: float, wz_radps: float,
    u: Inputs, f_N: Vec3, m_Nm: Vec3,
) -> tuple[float, float, float, float, float, float]:
    """``f_N`` and ``m_Nm`` (body FRD, about the CG) plus the four rotors' H-forces and
    flapping moments (:func:`rotor_hub_aero_B`; ``sd``, ``sz``, ``sf`` as there), rotor 0
    first. ``hubs_m``: each hub relative to the CG; ``o``: rotor speeds (rad/s); ``b*_mps``:
    the CG's air-relative velocity; ``w*_radps``: body rates; ``u``: the inputs, whose last
    12 floats are the hubs' gusts. The sums are taken rotor by rotor in that order, as the
    equations of motion always have."""
    fx, fy, fz = f_N
    mx, my, mz = m_Nm
    g = 8
    for i in range(4):
        rx, ry, rz = hubs_m[i]
        hx_, hy_, hz_, dmx, dmy, dmz = rotor_hub_aero_B(
            sd, sz, sf, o[i], rx, ry, rz, bx_mps, by_mps, bz_mps, wx_radps, wy_radps, wz_radps,
            u[g], u[g + 1], u[g + 2],
        )
        g += 3
        fx += hx_
        fy += hy_
        fz += hz_
        mx += dmx
        my += dmy
        mz += dmz
    return fx, fy, fz, mx, my, mz


def make_derivative(k: DynamicsConstants) -> Derivative:
    """Build ``f(x, u) -> dx/dt`` (a 17-tuple) with the constants bound in."""
    g = k.gravity_mps2
    minv = 1.0 / k.mass_kg
    (jxx, jxy, jxz), (_, jyy, jyz), (_, _, jzz) = k.inertia_B_kgm2
    (ixx, ixy, ixz), (iyx, iyy, iyz), (izx, izy, izz) = k.inverse_inertia_B
    rx0, rx1, rx2, rx3 = k.rotor_x_m
    ry0, ry1, ry2, ry3 = k.rotor_y_m
    kt0, kt1, kt2, kt3 = k.k_T
    kq0, kq1, kq2, kq3 = k.k_Q_signed
    jr0, jr1, jr2, jr3 = k.j_rotor_signed
    tu = 1.0 / k.tau_up_s
    td = 1.0 / k.tau_down_s
    lin, quad, cp = k.linear_drag, k.quadratic_drag, k.cp_m
    kd, kz, kf = k.rotor_drag, k.rotor_drag_z, k.flapping
    rotor_aero = kd > 0.0 or kz > 0.0 or kf > 0.0
    hubs = tuple(zip(k.rotor_x_m, k.rotor_y_m, k.rotor_z_m, strict=True))
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
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = to_matrix((qw, qx, qy, qz))  # body -> NED
        # Air-relative velocity of the CG in body axes, then body drag at the centre of pressure.
        ux, uy, uz = vx - wn, vy - we, vz - wd
        bx = r00 * ux + r10 * uy + r20 * uz
        by = r01 * ux + r11 * uy + r21 * uz
        bz = r02 * ux + r12 * uy + r22 * uz
        ex, ey, ez, mx, my, mz = body_drag_B(sig, bx, by, bz, lin, quad, cp)
        fx, fy, fz = ex, ey, ez - (t0 + t1 + t2 + t3)
        if rotor_aero:
            fx, fy, fz, mx, my, mz = add_rotors_aero_B(
                sig * kd, sig * kz, sig * kf, hubs, (o0, o1, o2, o3), bx, by, bz, wx, wy, wz, u,
                (fx, fy, fz), (mx, my, mz))
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
    """One classical RK4 step of length ``h`` (s); renormalises the quaternion."""
    # zip without strict= (noqa B905): every vector is N_STATES long by construction, and
    # this is the hot path.
    hh = 0.5 * h
    k1 = f(x, u)
    k2 = f([a + hh * b for a, b in zip(x, k1)], u)  # noqa: B905
    k3 = f([a + hh * b for a, b in zip(x, k2)], u)  # noqa: B905
    k4 = f([a + h * b for a, b in zip(x, k3)], u)  # noqa: B905
    h6 = h / 6.0
    y = [a + h6 * (b + 2.0 * (c + d) + e) for a, b, c, d, e in zip(x, k1, k2, k3, k4)]  # noqa: B905
    qw, qx, qy, qz = y[6], y[7], y[8], y[9]
    n = (qw * qw + qx * qx + qy * qy + qz * qz) ** -0.5
    y[6], y[7], y[8], y[9] = qw * n, qx * n, qy * n, qz * n
    return y
