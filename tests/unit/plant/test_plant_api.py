"""The bench-facing API: payload, faults, sensor truth, time handling, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.plant import Plant, PlantParams, PlantState, SensorMountParams, SensorTruth
from hil.perf.plant_tick import measure_tick_cost
from hil.plant.quat import from_euler, mul, rotate, rotate_inv

from .support import NO_DRAG, STIFF_BATTERY, TICK_NS, G, hover_at, make_plant, run


def test_payload_scales_the_hover_throttle_by_sqrt_of_mass() -> None:
    plant = make_plant(battery=STIFF_BATTERY)
    hover_at(plant, 10.0)
    d1 = plant.hover_throttle()
    plant.set_payload(0.3)  # the paper's +300 g
    d2 = plant.hover_throttle()
    assert plant.state.mass_kg == pytest.approx(1.4)
    assert d2 / d1 == pytest.approx(math.sqrt(1.4 / 1.1), rel=1e-12)
    # With the default (sagging) pack the extra current costs a little more throttle.
    sag = make_plant()
    hover_at(sag, 10.0)
    s1 = sag.hover_throttle()
    sag.set_payload(0.3)
    assert sag.hover_throttle() / s1 == pytest.approx(math.sqrt(1.4 / 1.1), rel=0.025)
    assert sag.hover_throttle() / s1 > math.sqrt(1.4 / 1.1)
    sag.set_payload(0.0)
    assert sag.hover_throttle() == pytest.approx(s1)


def test_payload_in_flight_is_continuous_and_held_by_the_new_hover_throttle() -> None:
    plant = make_plant()
    hover_at(plant, 10.0)
    run(plant, 40, lambda p: [p.hover_throttle()] * 4)
    before = plant.state
    plant.set_payload(0.3, (0.0, 0.0, 0.1))
    after = plant.state
    assert after.p_N_m == pytest.approx(before.p_N_m, abs=1e-12)
    assert after.v_N_mps == pytest.approx(before.v_N_mps, abs=1e-12)
    mp = plant.mass_properties
    assert mp.cg_B_m == pytest.approx((0.0, 0.0, 0.03 / 1.4))
    # Parallel axis about the new CG: 0.0153 + 1.1 c^2 + 0.3 (0.1 - c)^2.
    c = 0.03 / 1.4
    assert mp.inertia_B_kgm2[0][0] == pytest.approx(0.0153 + 1.1 * c**2 + 0.3 * (0.1 - c) ** 2)
    # The rotors catch up with the new command within a few time constants (the vehicle
    # sinks meanwhile); from then on the vertical acceleration is nil.
    run(plant, 200, lambda p: [p.hover_throttle()] * 4)
    v0 = plant.state.v_N_mps[2]
    assert 0.0 < v0 < 0.2
    assert abs(plant.accelerations()[0][2]) < 0.02
    run(plant, 400, lambda p: [p.hover_throttle()] * 4)
    assert abs(plant.accelerations()[0][2]) < 0.005
    assert 0.0 < plant.state.v_N_mps[2] <= v0  # vertical drag only damps the sink rate


def test_forward_payload_pitches_the_nose_down() -> None:
    plant = make_plant(aero=NO_DRAG)
    hover_at(plant, 10.0)
    plant.set_payload(0.2, (0.1, 0.0, 0.0))
    alpha = plant.accelerations()[1]
    c_x = plant.mass_properties.cg_B_m[0]
    expected = -c_x * sum(plant.state.thrust_N) / plant.mass_properties.inertia_B_kgm2[1][1]
    assert alpha[1] == pytest.approx(expected, rel=1e-9)
    assert alpha[1] < -1.0


def test_rotor_thrust_factor() -> None:
    plant = make_plant(aero=NO_DRAG)
    hover_at(plant, 20.0)
    plant.set_rotor_thrust_factor(2, 0.7)
    t = plant.state.thrust_N
    assert t[2] == pytest.approx(0.7 * t[0])
    plant.set_rotor_thrust_factor(2, 1.0)
    plant.set_rotor_thrust_factor(0, 0.0)  # front-right motor fails
    assert plant.state.thrust_N[0] == 0.0
    a_N, alpha = plant.accelerations()
    assert alpha[0] > 1.0 and alpha[1] < -1.0  # rolls right, pitches nose down
    assert a_N[2] > 0.2 * G  # and sinks
    assert plant.hover_throttle() == pytest.approx(make_hover(20.0) * math.sqrt(4 / 3), rel=0.01)
    with pytest.raises(IndexError):
        plant.set_rotor_thrust_factor(4, 0.5)
    with pytest.raises(ValueError):
        plant.set_rotor_thrust_factor(1, -0.1)


def make_hover(h_m: float) -> float:
    plant = make_plant(aero=NO_DRAG)
    hover_at(plant, h_m)
    return plant.hover_throttle()


def test_imu_truth_at_its_mounting_point_and_frame() -> None:
    mount = SensorMountParams(
        imu_position_B_m=(0.1, 0.05, -0.03),
        imu_rotation_BS_rpy_deg=(180.0, 0.0, 90.0),
        accel_position_B_m=(0.03, 0.0, -0.02),
    )
    plant = make_plant(aero=NO_DRAG, sensors=mount)
    q = from_euler(0.1, -0.2, 0.3)
    w = (0.4, -0.3, 2.0)
    plant.set_kinematic_state((0.0, 0.0, -100.0), q_NB=q, omega_B_radps=w)  # free fall, rotors off
    truth = plant.sensors()
    q_BS = from_euler(math.pi, 0.0, math.pi / 2)
    assert truth.q_NS == pytest.approx(mul(q, q_BS))
    assert truth.omega_S_radps == pytest.approx(rotate_inv(q_BS, w))
    # Free fall: the only specific force is the centripetal/Euler acceleration of the offset point.
    alpha = np.array(plant.accelerations()[1])
    for r, f_B in (
        ((0.1, 0.05, -0.03), rotate(q_BS, truth.f_S_mps2)),
        ((0.03, 0.0, -0.02), truth.f_acc_B_mps2),
    ):
        expected = np.cross(alpha, r) + np.cross(w, np.cross(w, r))
        np.testing.assert_allclose(f_B, expected, atol=1e-12)
    assert np.linalg.norm(truth.f_acc_B_mps2) > 0.1


def test_specific_force_in_hover_and_tilted_rest() -> None:
    plant = make_plant()
    hover_at(plant, 10.0)
    truth = plant.sensors()
    assert truth.f_acc_B_mps2 == pytest.approx((0.0, 0.0, -G), abs=1e-9)
    assert truth.f_S_mps2 == pytest.approx((0.0, 0.0, -G), abs=1e-9)
    assert truth.q_NS == plant.state.q_NB  # default mount: aligned with the body


def test_baro_sees_rotor_wash_near_the_ground() -> None:
    plant = make_plant()
    p_still = plant.sensors().p_static_Pa
    run(plant, 400, [0.6] * 4)  # spinning, still on the ground
    p_spin = plant.sensors().p_static_Pa
    assert p_spin - p_still > 5.0  # overpressure: reads ~0.5 m or more too low
    hover_at(plant, 10.0)
    wash_10 = plant.sensors().p_static_Pa - plant._atmo.pressure_Pa(10.0 + 0.2 + 0.02)
    assert abs(wash_10) < 0.01


def test_time_handling_and_input_cleaning() -> None:
    plant = make_plant()
    plant.step(10 * TICK_NS, [0.1] * 4)
    assert plant.t_ns == 10 * TICK_NS
    plant.step(10 * TICK_NS, [0.1] * 4)  # no time passes: fine
    with pytest.raises(ValueError, match="backwards"):
        plant.step(9 * TICK_NS, [0.1] * 4)
    with pytest.raises(ValueError):
        plant.step(11 * TICK_NS, [0.1] * 3)
    plant.step(11 * TICK_NS, [math.nan, 1.5, -0.2, 0.3])
    assert plant.counters["throttle_nan"] == 1 and plant.counters["throttle_clamped"] == 2


def test_irregular_steps_cover_the_same_physics() -> None:
    a, b = make_plant(), make_plant()
    hover_at(a, 10.0)
    hover_at(b, 10.0)
    thr = [0.75, 0.74, 0.76, 0.73]
    run(a, 40, thr)
    for t in (1_000_000, 37_000_000, 99_000_000, 100_000_000):  # odd boundaries, same end
        b.step(t, thr)
    assert b.state.t_ns == a.state.t_ns
    assert b.state.p_N_m == pytest.approx(a.state.p_N_m, abs=1e-6)
    assert b.state.omega_B_radps == pytest.approx(a.state.omega_B_radps, abs=1e-6)


def test_same_seed_same_run() -> None:
    def trace(seed: int) -> PlantState:
        from hil.plant import WindParams

        plant = make_plant(seed=seed, wind=WindParams(turbulence_sigma_N_mps=(1.0, 1.0, 0.5)))
        run(plant, 200, [0.8] * 4)
        run(plant, 200, [0.72, 0.73, 0.72, 0.71])
        return plant.state

    assert trace(1) == trace(1)
    assert trace(1) != trace(2)


def test_snapshots_are_frozen_and_typed() -> None:
    plant = Plant(PlantParams(), np.random.default_rng(0), t0_ns=5 * TICK_NS)
    s, truth = plant.state, plant.sensors()
    assert isinstance(s, PlantState) and isinstance(truth, SensorTruth)
    assert s.t_ns == truth.t_ns == 5 * TICK_NS
    with pytest.raises(AttributeError):
        s.h_m = 3.0  # type: ignore[misc]
    assert len(s.rotor_omega_radps) == len(s.thrust_N) == 4


def test_benchmark_function_reports_costs() -> None:
    r = measure_tick_cost(20)
    assert r["n_ticks"] == 20 and r["substeps"] == 4
    for key in ("step_median_us", "step_p99_us", "tick_median_us", "tick_p99_us", "budget_pct"):
        assert math.isfinite(r[key]) and r[key] > 0.0
    assert r["tick_p99_us"] >= r["tick_median_us"] >= r["step_median_us"]
