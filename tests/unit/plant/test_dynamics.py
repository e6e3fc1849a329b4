"""Rigid-body dynamics: hover, free fall, torque -> angular acceleration, conservation laws,
control-effect signs and RK4 convergence."""

from __future__ import annotations

import math
from dataclasses import replace
from itertools import pairwise

import numpy as np
import pytest

from hil.plant import BodyParams, FrameLayout, Plant, PlantParams, RotorParams
from hil.plant.quat import from_euler, to_matrix
from hil.plant.rotors import rotor_geometry

from .support import NO_DRAG, G, hover_at, make_plant, run


def test_hover_throttle_holds_altitude() -> None:
    plant = make_plant()
    hover_at(plant, 10.0)
    a_N, alpha = plant.accelerations()
    assert max(abs(a) for a in a_N + alpha) < 1e-9
    assert plant.hover_throttle() == pytest.approx(0.724, abs=0.002)  # docs/controllers.md 3.1, full pack
    run(plant, 2000, lambda p: [p.hover_throttle()] * 4)  # 5 s
    s = plant.state
    assert s.h_m == pytest.approx(10.0, abs=2e-3)
    assert max(abs(v) for v in s.v_N_mps) < 1e-3
    assert max(abs(a) for a in s.euler_rpy_rad) < 1e-9
    assert not s.on_ground
    assert s.battery_soc < 0.995  # the pack drained and the throttle followed


def test_free_fall_at_g_without_drag() -> None:
    plant = make_plant(aero=NO_DRAG)
    plant.set_kinematic_state((0.0, 0.0, -100.0))
    run(plant, 800, [0.0] * 4)  # 2 s
    s = plant.state
    assert s.h_m == pytest.approx(100.0 - 0.5 * G * 2.0**2, abs=1e-9)
    assert s.v_N_mps[2] == pytest.approx(G * 2.0, abs=1e-9)
    assert s.q_NB == (1.0, 0.0, 0.0, 0.0)
    truth = plant.sensors()
    assert max(abs(f) for f in truth.f_S_mps2 + truth.f_acc_B_mps2) < 1e-9  # weightless


def test_drag_slows_a_fall() -> None:
    plant = make_plant()
    plant.set_kinematic_state((0.0, 0.0, -100.0))
    run(plant, 800, [0.0] * 4)
    assert 0.5 * G * 2.0 < plant.state.v_N_mps[2] < 0.97 * G * 2.0


def _expected_alpha(plant: Plant, with_gyro: bool) -> np.ndarray:
    """J^-1 (M - w x (J w + h_rotors)) from the snapshot, in numpy (independent code)."""
    s = plant.state
    p = plant.params.rotors
    mp = plant.mass_properties
    j = np.array(mp.inertia_B_kgm2)
    c = np.array(mp.cg_B_m)
    geom = rotor_geometry(p)
    om = np.array(s.rotor_omega_radps)
    thrust = np.array(s.thrust_N)
    sigma = thrust[0] / (p.k_T_N_per_radps2 * om[0] ** 2)  # high up: no ground effect
    m = np.zeros(3)
    for pos, t in zip(geom.position_B_m, thrust, strict=True):
        m += np.cross(np.array(pos) - c, [0.0, 0.0, -t])
    m[2] += sum(sp * p.k_Q_Nm_per_radps2 * sigma * w * w for sp, w in zip(geom.spin_sign, om, strict=True))
    w = np.array(s.omega_B_radps)
    h = np.zeros(3)
    if with_gyro:
        h[2] = -sum(sp * p.rotor_inertia_kgm2 * wi for sp, wi in zip(geom.spin_sign, om, strict=True))
    return np.linalg.solve(j, m - np.cross(w, j @ w + h))


def test_torque_gives_angular_acceleration_through_the_full_inertia() -> None:
    # No rotor inertia here, so the motors' reaction torque does not enter (tested below).
    plant = make_plant(aero=NO_DRAG, rotors=RotorParams(rotor_inertia_kgm2=0.0))
    plant.set_payload(0.3, (0.05, -0.03, 0.1))  # lateral offset: CG shift and products of inertia
    assert abs(plant.mass_properties.inertia_B_kgm2[0][1]) > 1e-4
    plant.set_kinematic_state((0.0, 0.0, -500.0), rotor_omega_radps=(520.0, 610.0, 580.0, 650.0))
    alpha = plant.accelerations()[1]
    np.testing.assert_allclose(alpha, _expected_alpha(plant, with_gyro=False), rtol=1e-12, atol=1e-12)
    assert min(abs(a) for a in alpha) > 0.05  # all three axes excited
    # ... and with the body rotating: the w x J w terms.
    plant.set_kinematic_state(
        (0.0, 0.0, -500.0), omega_B_radps=(1.5, -2.0, 3.0), rotor_omega_radps=(520.0, 610.0, 580.0, 650.0)
    )
    np.testing.assert_allclose(plant.accelerations()[1], _expected_alpha(plant, False), rtol=1e-12, atol=1e-12)


def test_rotor_gyroscopic_torque() -> None:
    plant = make_plant(aero=NO_DRAG, rotors=RotorParams(rotor_inertia_kgm2=2e-4))
    # CCW pair faster than CW pair: net rotor angular momentum along -z_B (up).
    plant.set_kinematic_state(
        (0.0, 0.0, -500.0), omega_B_radps=(1.0, 0.5, 0.0), rotor_omega_radps=(700.0, 700.0, 500.0, 500.0)
    )
    alpha = np.array(plant.accelerations()[1])
    with_gyro = _expected_alpha(plant, with_gyro=True)
    without = _expected_alpha(plant, with_gyro=False)
    np.testing.assert_allclose(alpha[:2], with_gyro[:2], rtol=1e-12, atol=1e-12)
    assert np.linalg.norm(with_gyro[:2] - without[:2]) > 1.0  # the term matters


def test_torque_free_rotation_conserves_energy_momentum_and_norm() -> None:
    body = BodyParams(inertia_B_kgm2=(0.0153, 0.021, 0.03), inertia_offdiag_B_kgm2=(0.001, -0.0005, 0.0008))
    plant = make_plant(aero=NO_DRAG, body=body)
    w0 = (2.0, -1.0, 3.0)
    plant.set_kinematic_state((0.0, 0.0, -1000.0), q_NB=from_euler(0.3, -0.2, 1.0), omega_B_radps=w0)
    j = np.array(plant.mass_properties.inertia_B_kgm2)

    def invariants() -> tuple[float, np.ndarray, float]:
        s = plant.state
        w = np.array(s.omega_B_radps)
        r = np.array(to_matrix(s.q_NB))
        return 0.5 * w @ j @ w, r @ j @ w, math.sqrt(sum(c * c for c in s.q_NB))

    e0, l0, _ = invariants()
    for _ in range(10):
        run(plant, 400, [0.0] * 4)  # 10 s in all
        e, l_N, norm = invariants()
        assert e == pytest.approx(e0, rel=1e-9)
        np.testing.assert_allclose(l_N, l0, rtol=0, atol=1e-9 * np.linalg.norm(l0))
        assert norm == pytest.approx(1.0, abs=1e-14)
    assert plant.state.omega_B_radps != pytest.approx(w0, abs=0.1)  # it did tumble


def _rates_after(layout: FrameLayout, throttle_scale: tuple[float, float, float, float]) -> tuple[float, ...]:
    plant = make_plant(rotors=RotorParams(layout=layout))
    hover_at(plant, 50.0)
    base = plant.hover_throttle()
    run(plant, 100, [base * k for k in throttle_scale])  # 0.25 s
    return plant.state.omega_B_radps


@pytest.mark.parametrize("layout", [FrameLayout.X, FrameLayout.PLUS])
def test_yaw_torque_sign_per_spin_direction(layout: FrameLayout) -> None:
    # Rotors 0 and 1 turn counter-clockwise seen from above: speeding them up yaws the nose right.
    _, _, r_ccw = _rates_after(layout, (1.05, 1.05, 0.95, 0.95))
    _, _, r_cw = _rates_after(layout, (0.95, 0.95, 1.05, 1.05))
    assert r_ccw > 0.05
    assert r_cw < -0.05
    assert r_ccw == pytest.approx(-r_cw, rel=0.1)


def test_roll_and_pitch_signs_x_frame() -> None:
    p, _, _ = _rates_after(FrameLayout.X, (0.98, 1.02, 1.02, 0.98))  # left rotors (1 RL, 2 FL) up
    assert p > 0.1  # right wing down
    _, q, _ = _rates_after(FrameLayout.X, (1.02, 0.98, 1.02, 0.98))  # front rotors (0 FR, 2 FL) up
    assert q > 0.1  # nose up


def test_rk4_substep_convergence() -> None:
    # Smooth manoeuvre (rotors spinning up, tumbling, linear drag only) with different sub-steps.
    aero = replace(NO_DRAG, linear_drag_B_N_per_mps=(0.1, 0.1, 0.2), angular_drag_B_Nm_per_radps=(0.001,) * 3)

    def final_state(substeps: int) -> np.ndarray:
        plant = make_plant(PlantParams(aero=aero, substeps=substeps))
        plant.set_kinematic_state(
            (0.0, 0.0, -100.0),
            v_N_mps=(3.0, -2.0, 1.0),
            q_NB=from_euler(0.2, 0.1, 0.5),
            omega_B_radps=(2.0, -1.0, 1.5),
            rotor_omega_radps=(300.0, 400.0, 350.0, 450.0),
        )
        run(plant, 40, [0.8, 0.9, 0.85, 0.95])  # 0.1 s
        s = plant.state
        return np.array(s.p_N_m + s.v_N_mps + s.q_NB + s.omega_B_radps + tuple(o / 100 for o in s.rotor_omega_radps))

    ref = final_state(128)
    errors = [np.linalg.norm(final_state(n) - ref) for n in (1, 2, 4, 8)]
    ratios = [a / b for a, b in pairwise(errors)]
    assert all(r > 10.0 for r in ratios), (errors, ratios)  # fourth order: 16 per halving
    assert errors[2] < 1e-6  # the default 4 sub-steps
