"""The plant as the bench drives it: ``Plant``, the quad-rotor stepped in sim time
(``hil/plant/stepping.py``), and the changes scenarios and fault injection make to it while it
runs: payload, rotor thrust loss, battery sag, wind steps and gusts, placing the vehicle.

Reference point: ``p_N_m``/``v_N_mps``/``h_m`` are of the body origin (hub centre), which is
the empty vehicle's CG; the integrator tracks the CG, which moves with a payload. Placing the
vehicle or changing its mass keeps the body origin's motion continuous.
"""

from __future__ import annotations

import math

from hil.plant import ground, quat
from hil.plant.params_environment import GustShape
from hil.plant.records import PlantState, SensorTruth
from hil.plant.rigid_body import with_payload
from hil.plant.stepping import SteppedPlant

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Four = tuple[float, float, float, float]

__all__ = ["Plant", "PlantState", "SensorTruth"]


class Plant(SteppedPlant):
    """6-DOF quad-rotor with rotor lag, battery, drag, ground effect, ground contact, wind
    (``SteppedPlant``: the constructor, ``step``, ``state``, ``sensors`` ...), and the
    run-time changes below.

    ``params``: PlantParams; ``rng``: the Generator for the wind turbulence; ``t0_ns``: the
    sim time of the initial state (at rest on the ground, level, heading
    ``params.initial_yaw_rad``, rotors stopped); ``vibration_rng``: the Generator of the
    rotor imbalances (None: a child spawned from ``rng``, which leaves ``rng``'s own draws
    unchanged).
    """

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
