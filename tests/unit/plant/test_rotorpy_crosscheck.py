"""Independent cross-check of the plant against RotorPy (PyPI ``rotorpy`` 3.0.0, UPenn's
multirotor simulator; its ``Multirotor`` has the same rotor-drag/flapping family of models).

Same vehicle parameters and rotor speeds in both; the frames differ by a fixed rotation:
RotorPy's body is x forward, y left, z up and its world z is up, ours are FRD/NED, so every
vector maps by T = diag(1, -1, -1) (a 180 deg turn about x) and a quaternion (w, x, y, z)
by (w, x, -y, -z). Differences by design (documented in docs/aerodynamics.md), removed here
by choosing parameters:

* flapping sign: RotorPy's ``M = -k_flap w (v x e3)`` pitches the nose *down* for forward
  airspeed (its shipped vehicles all have k_flap = 0); ours tilts the disk away from the
  relative wind (nose up, as a helicopter's flapping back). RotorPy gets ``-k_f`` here.
* body drag: RotorPy ``-|v| C v`` at the CoM; ours per axis ``-(c1 + c2 |v_i|) v_i`` at the
  centre of pressure. Compared with airspeed along one body axis, c1 = 0 and cp at the CG.
* ours scale all aerodynamics with the air density ratio (ISA at the height); RotorPy's
  coefficients are multiplied by that ratio here. Ours also have ground effect (off at
  100 m), rotor inertia (gyroscopic and reaction torques; set to zero here), separate
  spin-up/down time constants (set equal), battery-limited speed, no translational lift
  (RotorPy ``k_h`` = 0 here).

Tolerances: the wrench (as accelerations) to 1e-9 relative: the models are the same
algebra. The 5 s open-loop flight: RotorPy integrates with RK45 (rtol 1e-10) and ours with
fixed-step RK4 at 1.25 ms, so 1 mm in position, 0.01 deg in attitude.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hil.plant import AeroParams, PlantParams, RotorParams, WindParams
from hil.plant.atmosphere import Atmosphere
from hil.plant.params_environment import EnvironmentParams
from hil.plant.rotors import rotor_geometry
from tests.unit.plant.support import make_plant

rotorpy_multirotor = pytest.importorskip("rotorpy.vehicles.multirotor")

T = np.diag([1.0, -1.0, -1.0])
G_ROTORPY = 9.81  # RotorPy's gravity constant


def _params(quadratic: float, wind_N: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> PlantParams:
    p = PlantParams()
    return replace(
        p,
        rotors=replace(p.rotors, rotor_inertia_kgm2=0.0, tau_down_s=p.rotors.tau_up_s),
        aero=replace(
            p.aero,
            linear_drag_B_N_per_mps=(0.0, 0.0, 0.0),
            quadratic_drag_B_N_per_mps2=(quadratic, quadratic, 2 * quadratic),
            centre_of_pressure_B_m=(0.0, 0.0, 0.0),
            ground_effect=False,
        ),
        environment=replace(p.environment, gravity_mps2=G_ROTORPY),
        # a stiff battery that does not drain: omega_max (and so the speeds) stay put
        battery=replace(p.battery, internal_resistance_ohm=0.0, capacity_Ah=1e6),
        wind=WindParams(mean_N_mps=wind_N),
    )


def _rotorpy_vehicle(p: PlantParams, sigma: float):
    rp: RotorParams = p.rotors
    ap: AeroParams = p.aero
    geom = rotor_geometry(rp)
    jxx, jyy, jzz = p.body.inertia_B_kgm2
    params = {
        "mass": p.body.mass_kg, "Ixx": jxx, "Iyy": jyy, "Izz": jzz, "Ixy": 0.0, "Iyz": 0.0, "Ixz": 0.0,
        "num_rotors": 4,
        "rotor_radius": rp.radius_m,
        "rotor_pos": {f"r{i}": T @ np.array(pos) for i, pos in enumerate(geom.position_B_m)},
        # our s_i is the yaw torque sign about z down; RotorPy's about z up
        "rotor_directions": -np.array(geom.spin_sign),
        "rI": np.zeros(3),
        "c_Dx": sigma * ap.quadratic_drag_B_N_per_mps2[0],
        "c_Dy": sigma * ap.quadratic_drag_B_N_per_mps2[1],
        "c_Dz": sigma * ap.quadratic_drag_B_N_per_mps2[2],
        "k_eta": sigma * rp.k_T_N_per_radps2,
        "k_m": sigma * rp.k_Q_Nm_per_radps2,
        "k_d": sigma * ap.rotor_drag_N_per_mps_per_radps,
        "k_z": sigma * ap.rotor_drag_vertical_N_per_mps_per_radps,
        "k_h": 0.0,
        "k_flap": -sigma * ap.flapping_moment_Nm_per_mps_per_radps,  # sign: see module doc
        "tau_m": rp.tau_up_s,
        "rotor_speed_min": 0.0,
        "rotor_speed_max": 2000.0,
    }  # fmt: skip
    return rotorpy_multirotor.Multirotor(
        params, aero=True, enable_ground=False, integrator_kwargs={"method": "RK45", "rtol": 1e-10, "atol": 1e-12}
    )


def _rotorpy_state(plant, wind_N) -> dict[str, np.ndarray]:
    s = plant.state
    qw, qx, qy, qz = s.q_NB
    return {
        "x": T @ np.array(s.p_N_m),
        "v": T @ np.array(s.v_N_mps),
        "q": np.array([qx, -qy, -qz, qw]),
        "w": T @ np.array(s.omega_B_radps),
        "wind": T @ np.array(wind_N),
        "rotor_speeds": np.array(s.rotor_omega_radps),
    }


def _sigma(plant) -> float:
    s = plant.state
    return s.thrust_N[0] / (plant.params.rotors.k_T_N_per_radps2 * s.rotor_omega_radps[0] ** 2)


STATES = [
    # (v_N, omega_B, rpy_deg, rotor speeds, wind_N, body drag on)
    ((2.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (600.0, 600.0, 600.0, 600.0), (0.0, 0.0, 0.0), True),
    ((0.0, -3.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 30.0), (610.0, 590.0, 600.0, 605.0), (0.0, 0.0, 0.0), False),
    ((0.0, 0.0, 1.5), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (600.0, 600.0, 600.0, 600.0), (0.0, 0.0, 0.0), True),
    ((1.0, 2.0, -0.5), (1.2, -0.7, 0.4), (10.0, -5.0, 45.0), (550.0, 640.0, 600.0, 580.0), (3.0, -1.0, 0.5), False),
    ((0.0, 0.0, 0.0), (0.0, 0.0, 2.0), (0.0, 0.0, 0.0), (600.0, 600.0, 620.0, 620.0), (0.0, 0.0, 0.0), False),
    ((-4.0, 1.0, 0.0), (0.3, 0.3, -0.3), (-15.0, 20.0, -60.0), (700.0, 500.0, 650.0, 560.0), (-2.0, 2.0, 0.0), False),
]


@pytest.mark.parametrize("v_N, w_B, rpy_deg, omegas, wind_N, body_drag", STATES)
def test_forces_and_moments_match_rotorpy(v_N, w_B, rpy_deg, omegas, wind_N, body_drag) -> None:
    from hil.plant import quat

    p = _params(0.03 if body_drag else 0.0, wind_N)
    plant = make_plant(p)
    q = quat.from_euler(*(math.radians(a) for a in rpy_deg))
    plant.set_kinematic_state((0.0, 0.0, -100.0), v_N, q, w_B, omegas)
    a_N, alpha_B = plant.accelerations()
    vehicle = _rotorpy_vehicle(p, _sigma(plant))
    state = _rotorpy_state(plant, wind_N)
    s_dot = vehicle._s_dot_fn(0.0, rotorpy_multirotor.Multirotor._pack_state(state), state["rotor_speeds"])
    np.testing.assert_allclose(T @ np.array(a_N), s_dot[3:6], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(T @ np.array(alpha_B), s_dot[10:13], rtol=1e-9, atol=1e-9)


class _FixedDensity(Atmosphere):
    """Our atmosphere with the density held at one value (RotorPy has none)."""

    def __init__(self, params: EnvironmentParams, sigma: float) -> None:
        super().__init__(params)
        self._sigma = sigma

    def density_ratio(self, h_field_m: float) -> float:
        return self._sigma


def test_open_loop_5s_trajectory_matches_rotorpy() -> None:
    """Constant, slightly uneven rotor speeds in a side wind: the vehicle climbs, drifts,
    yaws and tips over; both simulators must agree for 5 s."""
    wind_N = (1.5, -1.0, 0.0)
    p = _params(0.0, wind_N)  # body drag: |v| v vs per axis differ off-axis (module doc)
    plant = make_plant(p)
    omegas = (612.0, 608.0, 611.0, 609.0)
    plant.set_kinematic_state((0.0, 0.0, -100.0), (0.0, 0.0, 0.0), rotor_omega_radps=omegas)
    sigma = _sigma(plant)
    # RotorPy has no atmosphere: hold our density at its 100 m value (ours follows the
    # height, 1e-4 per m, which over the 14 m this flight falls would move it ~0.2 m)
    plant._atmo = _FixedDensity(plant._atmo.params, sigma)
    om_max = plant.omega_max_radps
    vehicle = _rotorpy_vehicle(p, sigma)
    state = _rotorpy_state(plant, wind_N)
    tick = p.tick_ns
    for k in range(1, 2001):  # 5 s, throttles that command exactly these speeds
        plant.step(k * tick, [o / om_max for o in omegas])
    # RotorPy in 20 ms steps (each integrated to rtol 1e-10)
    for _ in range(250):
        state = vehicle.step(state, {"cmd_motor_speeds": np.array(omegas)}, 0.02)
    s = plant.state
    assert abs(s.euler_rpy_rad[0]) + abs(s.euler_rpy_rad[1]) > math.radians(5.0)  # it did tip
    np.testing.assert_allclose(T @ np.array(s.p_N_m), state["x"], atol=1e-3)
    np.testing.assert_allclose(T @ np.array(s.v_N_mps), state["v"], atol=1e-3)
    qw, qx, qy, qz = s.q_NB
    ours = np.array([qx, -qy, -qz, qw])
    theirs = state["q"] * np.sign(np.dot(state["q"], ours))
    assert np.max(np.abs(ours - theirs)) < math.radians(0.01) / 2
