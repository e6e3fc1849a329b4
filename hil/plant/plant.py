"""The plant: the quad-rotor, its rotors, battery and environment, stepped in sim time.

Theory of operation. ``step(t_ns, throttle)`` integrates from the current sim time to
``t_ns`` with the four ESC throttles held. The interval is cut on the tick grid
(``tick_ns`` from ``t0_ns``); per tick the slow parts are updated once, explicitly: the wind
(on its own sim-time grid), the air density at the current height, and the battery
operating point from the rotors' shaft power, which sets ``omega_max`` and so the speed
commands ``throttle * omega_max``. The tick is then integrated with ``substeps`` fixed RK4
steps of the 17-state model (dynamics.py), with ground contact handled between sub-steps
(ground.py). The rotor-imbalance phases advance with every sub-step (vibration.py); the
vibration reaches the sensors as tones in ``sensors()``, not the rigid body. Nothing here
reads a clock or does I/O; the only randomness is the wind's and the vibration's
Generators, passed in.

Reference point: ``p_N_m``/``v_N_mps``/``h_m`` are of the body origin (hub centre), which is
the empty vehicle's CG; the integrator tracks the CG, which moves with a payload.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence

import numpy as np

from hil.plant import ground, quat
from hil.plant.aero import BaroWash, GroundEffect
from hil.plant.atmosphere import ZERO_C_K, Atmosphere
from hil.plant.battery import Battery
from hil.plant.dynamics import DynamicsConstants, Inputs, make_derivative, rk4_step
from hil.plant.params import GustShape, PlantParams
from hil.plant.records import PlantState, SensorTruth, VibrationTone
from hil.plant.rigid_body import MassProperties, base_mass_properties, with_payload
from hil.plant.rotors import lag_step, rotor_geometry
from hil.plant.vibration import RotorImbalance
from hil.plant.wind import ZERO_GRADIENT, WindModel

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Four = tuple[float, float, float, float]
_NO_GUST_OFFSETS = (0.0,) * 12

__all__ = ["Plant", "PlantState", "SensorTruth"]


class Plant:
    """6-DOF quad-rotor with rotor lag, battery, drag, ground effect, ground contact, wind.

    ``params``: PlantParams; ``rng``: the Generator for the wind turbulence; ``t0_ns``: the
    sim time of the initial state (at rest on the ground, level, heading
    ``params.initial_yaw_rad``, rotors stopped); ``vibration_rng``: the Generator of the
    rotor imbalances (None: a child spawned from ``rng``, which leaves ``rng``'s own draws
    unchanged).
    """

    def __init__(
        self,
        params: PlantParams,
        rng: np.random.Generator,
        *,
        t0_ns: int = 0,
        vibration_rng: np.random.Generator | None = None,
    ) -> None:
        self.params = params
        #: Events and oddities: ``throttle_clamped``/``throttle_nan`` (per value cleaned),
        #: ``liftoffs``, ``touchdowns``, ``battery_empty``/``battery_power_limited`` (per
        #: tick spent so).
        self.counters: Counter[str] = Counter()
        self._t0_ns = t0_ns
        self._t_ns = t0_ns
        self._atmo = Atmosphere(params.environment)
        self._wind = WindModel(params.wind, rng, t0_ns=t0_ns)
        self._battery = Battery(params.battery)
        self._geom = rotor_geometry(params.rotors)
        self._ge = GroundEffect(params.aero, params.rotors)
        self._wash = BaroWash(params.aero, params.rotors)
        self._g = params.environment.gravity_mps2
        self._gear_m = params.body.gear_depth_m
        self._base_mass = base_mass_properties(params.body)
        self._mass = self._base_mass
        self._factor = [1.0, 1.0, 1.0, 1.0]
        self._throttle: Four = (0.0, 0.0, 0.0, 0.0)
        self._wind_now: Vec3 = self._wind.at(t0_ns)
        self._sigma = self._atmo.density_ratio(self._gear_m)
        self._omega_max = self._omega_max_at(self._battery.voltage_V)
        self._u: Inputs = (0.0, 0.0, 0.0, 0.0, *self._wind_now, self._sigma, *_NO_GUST_OFFSETS)
        q0 = quat.from_euler(0.0, 0.0, params.initial_yaw_rad)
        self._x = [0.0] * 6 + list(q0) + [0.0] * 7
        self._on_ground = True
        ground.rest(self._x, self._mass.cg_B_m)
        self.last_touchdown: ground.Touchdown | None = None
        mount = params.sensors
        self._q_BS = quat.from_euler(*(math.radians(a) for a in mount.imu_rotation_BS_rpy_deg))
        self._vib: RotorImbalance | None = None
        if params.vibration.enabled:
            cw = tuple(not ccw for ccw in params.rotors.spin_ccw_from_above)
            vib_rng = rng.spawn(1)[0] if vibration_rng is None else vibration_rng
            self._vib = RotorImbalance(params.vibration, cw, vib_rng)
        self._state: PlantState | None = None
        self._rebuild()

    # -- set-up ----------------------------------------------------------------------------
    def _rebuild(self) -> None:
        """Recompute the derivative's constants after a mass or rotor change."""
        rp, ap = self.params.rotors, self.params.aero
        c = self._mass.cg_B_m
        cp = ap.centre_of_pressure_B_m
        pos = self._geom.position_B_m
        s = self._geom.spin_sign
        f = self._factor
        k = DynamicsConstants(
            gravity_mps2=self._g,
            mass_kg=self._mass.mass_kg,
            inertia_B_kgm2=self._mass.inertia_B_kgm2,
            inverse_inertia_B=self._mass.inverse_inertia,
            rotor_x_m=tuple(p[0] - c[0] for p in pos),  # type: ignore[arg-type]
            rotor_y_m=tuple(p[1] - c[1] for p in pos),  # type: ignore[arg-type]
            rotor_z_m=tuple(p[2] - c[2] for p in pos),  # type: ignore[arg-type]
            k_T=tuple(rp.k_T_N_per_radps2 * fi for fi in f),  # type: ignore[arg-type]
            k_Q_signed=tuple(si * rp.k_Q_Nm_per_radps2 * fi for si, fi in zip(s, f, strict=True)),  # type: ignore[arg-type]
            j_rotor_signed=tuple(si * rp.rotor_inertia_kgm2 for si in s),  # type: ignore[arg-type]
            tau_up_s=rp.tau_up_s,
            tau_down_s=rp.tau_down_s,
            linear_drag=ap.linear_drag_B_N_per_mps,
            quadratic_drag=ap.quadratic_drag_B_N_per_mps2,
            rotor_drag=ap.rotor_drag_N_per_mps_per_radps,
            rotor_drag_z=ap.rotor_drag_vertical_N_per_mps_per_radps,
            flapping=ap.flapping_moment_Nm_per_mps_per_radps,
            cp_m=(cp[0] - c[0], cp[1] - c[1], cp[2] - c[2]),
            angular_drag=ap.angular_drag_B_Nm_per_radps,
            ge_z0_m=c[2] + self._gear_m - rp.rotor_z_B_m,
            ge_cutoff_m=self._ge.cutoff_m,
            ge_gain=self._ge.gain,
        )
        self._k = k
        self._hubs_B = tuple(zip(k.rotor_x_m, k.rotor_y_m, k.rotor_z_m, strict=True))
        self._f = make_derivative(k)
        if self._vib is not None:
            m = self.params.sensors
            imu, acc = m.imu_position_B_m, m.accel_position_B_m
            self._vib.set_geometry(
                self._hubs_B,
                self._mass.mass_kg,
                self._mass.inverse_inertia,
                (imu[0] - c[0], imu[1] - c[1], imu[2] - c[2]),
                (acc[0] - c[0], acc[1] - c[1], acc[2] - c[2]),
                quat.to_matrix(quat.conj(self._q_BS)),
            )
        self._state = None

    def _omega_max_at(self, battery_V: float) -> float:
        rp = self.params.rotors
        return rp.omega_max_radps * max(battery_V, 0.0) / rp.omega_max_ref_V

    def _shaft_power_W(self, omegas: Sequence[float], sigma: float) -> float:
        k_q = self.params.rotors.k_Q_Nm_per_radps2 * sigma
        return sum(k_q * fi * w * w * w for fi, w in zip(self._factor, omegas, strict=True))

    # -- stepping --------------------------------------------------------------------------
    @property
    def t_ns(self) -> int:
        """Sim time of the current state (ns)."""
        return self._t_ns

    def step(self, t_ns: int, throttle: Sequence[float]) -> None:
        """Integrate to ``t_ns`` (>= current time) holding the 4 ESC throttles (0..1).

        Out-of-range throttles are clamped (NaN counts as 0) and counted.
        """
        if t_ns < self._t_ns:
            raise ValueError(f"sim time went backwards: {t_ns} < {self._t_ns}")
        self._throttle = self._clean(throttle)
        tick = self.params.tick_ns
        while self._t_ns < t_ns:
            t = self._t_ns
            t_end = min(t_ns, t + tick - (t - self._t0_ns) % tick)
            self._advance(t, t_end)
            self._t_ns = t_end
        self._state = None

    def _clean(self, throttle: Sequence[float]) -> Four:
        if len(throttle) != 4:
            raise ValueError(f"need 4 throttles, got {len(throttle)}")
        out = []
        for v in throttle:
            d = float(v)
            if math.isnan(d):
                self.counters["throttle_nan"] += 1
                d = 0.0
            elif d < 0.0 or d > 1.0:
                self.counters["throttle_clamped"] += 1
                d = 0.0 if d < 0.0 else 1.0
            out.append(d)
        return (out[0], out[1], out[2], out[3])

    def _advance(self, t_ns: int, t_end_ns: int) -> None:
        """One tick (or part of one): slow updates, then RK4 sub-steps."""
        p = self.params
        dt_ns = t_end_ns - t_ns
        n = -(-dt_ns * p.substeps // p.tick_ns)
        h_s = dt_ns * 1e-9 / n
        x = self._x
        cg = self._mass.cg_B_m
        h_m = ground.origin_height_m(x, cg)
        self._wind_now = self._wind.at(t_ns, h_m)
        self._sigma = sigma = self._atmo.density_ratio(h_m + self._gear_m)
        bat = self._battery
        bat.update(self._shaft_power_W(x[13:17], sigma), p.rotors.efficiency, dt_ns * 1e-9)
        if bat.power_limited:
            self.counters["battery_power_limited"] += 1
        if bat.soc <= 0.0:
            self.counters["battery_empty"] += 1
        self._omega_max = om = self._omega_max_at(bat.voltage_V)
        th = self._throttle
        wn, we, wd = self._wind_now
        offsets = self._gust_offsets_B(x)
        u: Inputs = (th[0] * om, th[1] * om, th[2] * om, th[3] * om, wn, we, wd, sigma, *offsets)
        self._u = u
        f = self._f
        vib = self._vib
        for k in range(n):
            if vib is not None:  # the imbalance phases follow the rotors, grounded or not
                w0 = (x[13], x[14], x[15], x[16])
            if self._on_ground:
                if f(x, u)[5] < 0.0:  # free-flight acceleration points up: lift off
                    self._on_ground = False
                    self.counters["liftoffs"] += 1
                else:
                    rp = p.rotors
                    for i in range(4):
                        x[13 + i] = lag_step(x[13 + i], u[i], h_s, rp.tau_up_s, rp.tau_down_s)
                    if vib is not None:
                        vib.advance(w0, (x[13], x[14], x[15], x[16]), h_s)
                    continue
            x = rk4_step(f, x, u, h_s)
            if vib is not None:
                vib.advance(w0, (x[13], x[14], x[15], x[16]), h_s)
            if ground.origin_height_m(x, cg) < 0.0:
                self.last_touchdown = ground.touchdown_record(x, t_ns + (k + 1) * dt_ns // n)
                self.counters["touchdowns"] += 1
                ground.rest(x, cg)
                self._on_ground = True
        self._x = x

    def _gust_offsets_B(self, x: Sequence[float]) -> tuple[float, ...]:
        """Wind at each hub minus wind at the CG, body axes (12 floats), from the wind's NED
        gradient and this tick's attitude: ``R^T G_N R r_i`` (held over the tick)."""
        g = self._wind.gradient_N
        if g is ZERO_GRADIENT:
            return _NO_GUST_OFFSETS
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
        for hx, hy, hz in self._hubs_B:
            out += (
                m00 * hx + m01 * hy + m02 * hz,
                m10 * hx + m11 * hy + m12 * hz,
                m20 * hx + m21 * hy + m22 * hz,
            )
        return tuple(out)

    # -- outputs ---------------------------------------------------------------------------
    def _thrusts(self) -> Four:
        x = self._x
        zr = self._k.ge_z0_m - x[2]
        kk = self._sigma * self._ge.gain(zr)
        kt = self._k.k_T
        return (
            kt[0] * x[13] ** 2 * kk,
            kt[1] * x[14] ** 2 * kk,
            kt[2] * x[15] ** 2 * kk,
            kt[3] * x[16] ** 2 * kk,
        )

    @property
    def state(self) -> PlantState:
        """Frozen truth snapshot at ``t_ns`` (cached until the next change)."""
        if self._state is not None:
            return self._state
        x = self._x
        c = self._mass.cg_B_m
        q: Quat = (x[6], x[7], x[8], x[9])
        w: Vec3 = (x[10], x[11], x[12])
        rc = quat.rotate(q, c)
        rv = quat.rotate(q, quat.cross(w, c))
        p_N = (x[0] - rc[0], x[1] - rc[1], x[2] - rc[2])
        bat = self._battery
        self._state = PlantState(
            t_ns=self._t_ns,
            p_N_m=p_N,
            v_N_mps=(x[3] - rv[0], x[4] - rv[1], x[5] - rv[2]),
            q_NB=q,
            omega_B_radps=w,
            euler_rpy_rad=quat.to_euler(q),
            rotor_omega_radps=(x[13], x[14], x[15], x[16]),
            thrust_N=self._thrusts(),
            battery_V=bat.voltage_V,
            battery_soc=bat.soc,
            battery_A=bat.current_A,
            on_ground=self._on_ground,
            wind_N_mps=self._wind_now,
            mass_kg=self._mass.mass_kg,
            h_m=0.0 - p_N[2],  # 0.0 - z, not -z: no -0.0 at rest
        )
        return self._state

    def accelerations(self) -> tuple[Vec3, Vec3]:
        """``(a_N_mps2, alpha_B_radps2)``: CG acceleration (NED) and angular acceleration
        (body) at the current state and held inputs; zero while resting on the ground."""
        if self._on_ground:
            return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        d = self._f(self._x, self._u)
        return (d[3], d[4], d[5]), (d[10], d[11], d[12])

    def _specific_force_at(self, r_B_m: Vec3, f_cg_B: Vec3, alpha: Vec3, w: Vec3) -> Vec3:
        c = self._mass.cg_B_m
        r = (r_B_m[0] - c[0], r_B_m[1] - c[1], r_B_m[2] - c[2])
        a1 = quat.cross(alpha, r)
        a2 = quat.cross(w, quat.cross(w, r))
        return (f_cg_B[0] + a1[0] + a2[0], f_cg_B[1] + a1[1] + a2[1], f_cg_B[2] + a1[2] + a2[2])

    def sensors(self) -> SensorTruth:
        """Noise-free sensor inputs at ``t_ns`` (see SensorTruth)."""
        x = self._x
        m = self.params.sensors
        q: Quat = (x[6], x[7], x[8], x[9])
        w: Vec3 = (x[10], x[11], x[12])
        a_N, alpha = self.accelerations()
        f_cg_B = quat.rotate_inv(q, (a_N[0], a_N[1], a_N[2] - self._g))
        f_imu_B = self._specific_force_at(m.imu_position_B_m, f_cg_B, alpha, w)
        f_acc_B = self._specific_force_at(m.accel_position_B_m, f_cg_B, alpha, w)
        q_SB = quat.conj(self._q_BS)
        h = ground.origin_height_m(x, self._mass.cg_B_m)
        port_above_ground = h + self._gear_m - quat.rotate(q, m.baro_position_B_m)[2]
        total_thrust = sum(self._thrusts())
        vib_f_S: tuple[VibrationTone, ...] = ()
        vib_w_S: tuple[VibrationTone, ...] = ()
        vib_f_acc_B: tuple[VibrationTone, ...] = ()
        if self._vib is not None:
            vib_f_S, vib_w_S, vib_f_acc_B = self._vib.tones((x[13], x[14], x[15], x[16]))
        return SensorTruth(
            t_ns=self._t_ns,
            q_NS=quat.mul(q, self._q_BS),
            omega_S_radps=quat.rotate(q_SB, w),
            f_S_mps2=quat.rotate(q_SB, f_imu_B),
            f_acc_B_mps2=f_acc_B,
            p_static_Pa=self._atmo.pressure_Pa(port_above_ground) + self._wash.error_Pa(total_thrust, h),
            air_T_C=self._atmo.temperature_K(port_above_ground) - ZERO_C_K,
            vib_f_S=vib_f_S,
            vib_omega_S=vib_w_S,
            vib_f_acc_B=vib_f_acc_B,
        )

    @property
    def rotor_imbalance(self) -> RotorImbalance | None:
        """The rotor-imbalance model (its phases and this vehicle's imbalances); None if off."""
        return self._vib

    @property
    def mass_properties(self) -> MassProperties:
        """Current mass, CG and inertia (with payload)."""
        return self._mass

    @property
    def omega_max_radps(self) -> float:
        """Full-throttle rotor speed (rad/s) at the battery voltage of the last tick."""
        return self._omega_max

    def hover_rotor_omega_radps(self) -> float:
        """Rotor speed (rad/s, all rotors equal) whose thrust balances the weight, level,
        at the current height (ground effect) and air density."""
        gain = self._ge.gain(self._k.ge_z0_m - self._x[2])
        k_sum = sum(self._k.k_T) * self._sigma * gain
        if k_sum <= 0.0:
            return math.inf
        return math.sqrt(self._mass.mass_kg * self._g / k_sum)

    def hover_throttle(self) -> float:
        """Equal throttle on all four ESCs that holds altitude (level) at the current mass,
        thrust factors, height, air density and battery charge (including the sag that the
        hover current itself causes). May exceed 1.0: the vehicle cannot hover then."""
        om = self.hover_rotor_omega_radps()
        if not math.isfinite(om):
            return math.inf
        power = self._shaft_power_W((om, om, om, om), self._sigma)
        volts, _, _ = self._battery.operating_point(power, self.params.rotors.efficiency)
        return om / self._omega_max_at(volts)

    # -- run-time changes (scenarios, fault injection) ------------------------------------
    def _origin_kinematics(self) -> tuple[Vec3, Vec3]:
        s = self.state
        return s.p_N_m, s.v_N_mps

    def _place_origin(self, p_N: Vec3, v_N: Vec3) -> None:
        """Set the CG position/velocity so the body origin has ``p_N``/``v_N``."""
        x = self._x
        q: Quat = (x[6], x[7], x[8], x[9])
        c = self._mass.cg_B_m
        rc = quat.rotate(q, c)
        rv = quat.rotate(q, quat.cross((x[10], x[11], x[12]), c))
        x[0], x[1], x[2] = p_N[0] + rc[0], p_N[1] + rc[1], p_N[2] + rc[2]
        x[3], x[4], x[5] = v_N[0] + rv[0], v_N[1] + rv[1], v_N[2] + rv[2]
        if self._on_ground:
            ground.rest(x, c)
        # The air density is per tick; refresh it for the new height right away.
        self._sigma = self._atmo.density_ratio(ground.origin_height_m(x, c) + self._gear_m)
        self._u = (*self._u[:7], self._sigma, *self._u[8:])
        self._state = None

    def set_payload(
        self,
        extra_mass_kg: float,
        r_B_m: Vec3 = (0.0, 0.0, 0.1),
        extra_inertia_kgm2: Vec3 | None = None,
    ) -> None:
        """Carry ``extra_mass_kg`` at ``r_B_m`` (body FRD from the body origin; default 0.1 m
        below) with its own principal inertia; replaces any earlier payload (0 removes it).
        The CG and inertia change; the body origin's motion is continuous."""
        p_N, v_N = self._origin_kinematics()
        self._mass = with_payload(self._base_mass, extra_mass_kg, r_B_m, extra_inertia_kgm2)
        self._place_origin(p_N, v_N)
        self._rebuild()

    def set_rotor_thrust_factor(self, index: int, factor: float) -> None:
        """Scale rotor ``index``'s thrust and drag torque (1 healthy, 0.7 partial loss,
        0 failed prop/motor)."""
        if index not in range(4):
            raise IndexError(f"rotor index {index} not in 0..3")
        if not (0.0 <= factor <= 2.0):
            raise ValueError("factor must be within 0..2")
        self._factor[index] = float(factor)
        self._rebuild()

    def set_battery_sag(self, extra_ohm: float) -> None:
        """Add ``extra_ohm`` of series resistance (aged pack, bad connector); 0 removes it."""
        if not (extra_ohm >= 0.0 and math.isfinite(extra_ohm)):
            raise ValueError("extra_ohm must be finite and >= 0")
        self._battery.extra_resistance_ohm = float(extra_ohm)

    def add_wind(self, wind_N_mps: Vec3, until_t_ns: int | None = None, *, start_t_ns: int | None = None) -> int:
        """Add a constant wind (NED, m/s) from now (or ``start_t_ns``) until ``until_t_ns``
        (None: for good). Returns a handle for ``remove_wind``."""
        start = self._t_ns if start_t_ns is None else start_t_ns
        return self._wind.add_step(wind_N_mps, start, until_t_ns)

    def add_gust(
        self,
        peak_N_mps: Vec3,
        start_t_ns: int,
        duration_ns: int,
        shape: GustShape = GustShape.ONE_MINUS_COSINE,
    ) -> int:
        """Schedule a gust (NED peak, m/s) of ``shape``; returns a handle for ``remove_wind``."""
        return self._wind.add_gust(peak_N_mps, start_t_ns, duration_ns, shape)

    def remove_wind(self, handle: int) -> None:
        """Remove a wind step or gust added earlier."""
        self._wind.remove(handle)

    def reset_on_ground(self) -> None:
        """Stand the vehicle on the ground below its current position, level, same heading,
        rotors stopped. Time, battery, payload and faults are kept."""
        x = self._x
        p_N, _ = self._origin_kinematics()
        self._on_ground = True
        self._place_origin((p_N[0], p_N[1], 0.0), (0.0, 0.0, 0.0))
        x[13] = x[14] = x[15] = x[16] = 0.0
        self._state = None

    def set_kinematic_state(
        self,
        p_N_m: Vec3,
        v_N_mps: Vec3 = (0.0, 0.0, 0.0),
        q_NB: Quat = quat.IDENTITY,
        omega_B_radps: Vec3 = (0.0, 0.0, 0.0),
        rotor_omega_radps: Four | None = None,
    ) -> None:
        """Place the vehicle (body origin) anywhere at or above the ground, e.g. to start a
        test or scenario in flight. At ``h = 0`` it rests on the ground (velocities and tilt
        dropped); below the ground is refused."""
        if -p_N_m[2] < 0.0:
            raise ValueError("cannot place the vehicle below the ground (p_N_m[2] > 0)")
        x = self._x
        x[6], x[7], x[8], x[9] = quat.normalized(q_NB)
        x[10], x[11], x[12] = (float(v) for v in omega_B_radps)
        if rotor_omega_radps is not None:
            if len(rotor_omega_radps) != 4 or min(rotor_omega_radps) < 0.0:
                raise ValueError("need 4 rotor speeds >= 0")
            x[13], x[14], x[15], x[16] = (float(v) for v in rotor_omega_radps)
        self._on_ground = -p_N_m[2] == 0.0
        self._place_origin(p_N_m, v_N_mps)
