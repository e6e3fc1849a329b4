"""The plant's state stepped in sim time: the quad-rotor, its rotors, battery and
environment, with its truth and sensor snapshots (``SteppedPlant``; ``hil/plant/plant.py``'s
``Plant`` adds the run-time changes scenarios and faults make).

Theory of operation. ``step(t_ns, throttle)`` integrates from the current sim time to
``t_ns`` with the four ESC throttles held. The interval is cut on the tick grid
(``tick_ns`` from ``t0_ns``); per tick the slow parts are updated once, explicitly: the wind
(on its own sim-time grid), the air density at the current height, and the battery
operating point from the rotors' shaft power, which sets ``omega_max`` and so the speed
commands ``throttle * omega_max``. The tick is then integrated with ``substeps`` fixed RK4
steps of the 17-state model (dynamics.py), with ground contact handled between sub-steps
(ground.py). The rotor-imbalance phases advance with every sub-step (vibration.py); the
vibration reaches the sensors as tones in ``sensors()`` (sensing.py), not the rigid body.
Nothing here reads a clock or does I/O; the only randomness is the wind's and the
vibration's Generators, passed in.

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
from hil.plant.atmosphere import Atmosphere
from hil.plant.battery import Battery
from hil.plant.dynamics import DynamicsConstants, Inputs, make_derivative, rk4_step
from hil.plant.hub_gusts import NO_GUST_OFFSETS, gust_offsets_B
from hil.plant.params import PlantParams
from hil.plant.records import PlantState, SensorTruth
from hil.plant.rigid_body import MassProperties, base_mass_properties
from hil.plant.rotors import lag_step, rotor_geometry
from hil.plant.sensing import Sensing
from hil.plant.vibration import RotorImbalance
from hil.plant.wind import WindModel

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Four = tuple[float, float, float, float]


class SteppedPlant:
    """6-DOF quad-rotor with rotor lag, battery, drag, ground effect, ground contact, wind,
    stepped in sim time, and what it gives out (truth, sensor inputs, hover figures).

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
        self._g = params.environment.gravity_mps2
        self._gear_m = params.body.gear_depth_m
        self._base_mass = base_mass_properties(params.body)
        self._mass = self._base_mass
        self._factor = [1.0, 1.0, 1.0, 1.0]
        self._throttle: Four = (0.0, 0.0, 0.0, 0.0)
        self._wind_now: Vec3 = self._wind.at(t0_ns)
        self._sigma = self._atmo.density_ratio(self._gear_m)
        self._omega_max = self._omega_max_at(self._battery.voltage_V)
        self._u: Inputs = (0.0, 0.0, 0.0, 0.0, *self._wind_now, self._sigma, *NO_GUST_OFFSETS)
        q0 = quat.from_euler(0.0, 0.0, params.initial_yaw_rad)
        self._x = [0.0] * 6 + list(q0) + [0.0] * 7
        self._on_ground = True
        ground.rest(self._x, self._mass.cg_B_m)
        self.last_touchdown: ground.Touchdown | None = None
        self._vib: RotorImbalance | None = None
        if params.vibration.enabled:
            cw = tuple(not ccw for ccw in params.rotors.spin_ccw_from_above)
            vib_rng = rng.spawn(1)[0] if vibration_rng is None else vibration_rng
            self._vib = RotorImbalance(params.vibration, cw, vib_rng)
        wash = BaroWash(params.aero, params.rotors)
        self._sensing = Sensing(params.sensors, self._atmo, wash, self._g, self._gear_m, self._vib)
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
                quat.to_matrix(quat.conj(self._sensing.q_BS)),
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
        offsets = gust_offsets_B(self._wind.gradient_N, x, self._hubs_B)
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

    def sensors(self) -> SensorTruth:
        """Noise-free sensor inputs at ``t_ns`` (see SensorTruth)."""
        a_N, alpha = self.accelerations()
        return self._sensing.truth(self._t_ns, self._x, a_N, alpha, self._mass.cg_B_m, self._thrusts())

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
