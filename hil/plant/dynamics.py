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

from hil.plant.quat import to_matrix

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
