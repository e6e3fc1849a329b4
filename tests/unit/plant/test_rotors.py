"""Rotors: pulse mapping, lag time constants, layout and spin, ground-effect gain."""

from __future__ import annotations

import math
from itertools import pairwise

import pytest

from hil.plant import AeroParams, FrameLayout, RotorParams
from hil.plant.aero import GroundEffect
from hil.plant.rotors import lag_step, rotor_geometry, throttle_from_pulse_us

from .support import STIFF_BATTERY, TICK_NS, hover_at, make_plant, run


@pytest.mark.parametrize(
    ("pulse_us", "throttle"),
    [(1000.0, 0.0), (1500.0, 0.5), (1724.0, 0.724), (2000.0, 1.0), (900.0, 0.0), (2100.0, 1.0), (math.nan, 0.0)],
)
def test_throttle_from_pulse(pulse_us: float, throttle: float) -> None:
    assert throttle_from_pulse_us(pulse_us) == pytest.approx(throttle)


def test_throttle_from_pulse_custom_range() -> None:
    assert throttle_from_pulse_us(1550.0, min_us=1100.0, max_us=1900.0) == pytest.approx(0.5625)
    with pytest.raises(ValueError):
        throttle_from_pulse_us(1500.0, min_us=2000.0, max_us=1000.0)


def test_x_and_plus_layouts() -> None:
    x = rotor_geometry(RotorParams())
    a = 0.25 / math.sqrt(2)
    expected_x = [(a, a), (-a, -a), (a, -a), (-a, a)]  # FR, RL, FL, RR
    for (px, py, pz), (ex, ey) in zip(x.position_B_m, expected_x, strict=True):
        assert (px, py, pz) == pytest.approx((ex, ey, -0.05))
    assert x.spin_sign == (1.0, 1.0, -1.0, -1.0)
    plus = rotor_geometry(RotorParams(layout=FrameLayout.PLUS))
    expected_plus = [(0.0, 0.25), (0.0, -0.25), (0.25, 0.0), (-0.25, 0.0)]  # R, L, F, B
    for (px, py, _), (ex, ey) in zip(plus.position_B_m, expected_plus, strict=True):
        assert (px, py) == pytest.approx((ex, ey), abs=1e-15)


def test_lag_step_is_the_exact_first_order_response() -> None:
    assert lag_step(0.0, 100.0, 0.0125, 0.0125, 0.025) == pytest.approx(100.0 * (1 - math.exp(-1)))
    assert lag_step(100.0, 0.0, 0.025, 0.0125, 0.025) == pytest.approx(100.0 * math.exp(-1))


@pytest.mark.parametrize("airborne", [False, True])
def test_motor_time_constants_up_and_down(airborne: bool) -> None:
    # A stiff battery keeps omega_max (so the command) constant while the rotors spin up.
    plant = make_plant(battery=STIFF_BATTERY, rotors=RotorParams(tau_up_s=0.025, tau_down_s=0.05))
    if airborne:
        hover_at(plant, 500.0)
        plant.set_kinematic_state((0.0, 0.0, -500.0), rotor_omega_radps=(0.0,) * 4)
    om_max = plant.omega_max_radps
    run(plant, 10, [0.3] * 4)  # 25 ms = tau_up
    cmd = 0.3 * om_max
    assert plant.state.rotor_omega_radps[0] == pytest.approx(cmd * (1 - math.exp(-1)), rel=2e-3)
    run(plant, 190, [0.3] * 4)
    assert plant.state.rotor_omega_radps[0] == pytest.approx(cmd, rel=2e-3)
    start = plant.state.rotor_omega_radps[0]
    run(plant, 20, [0.0] * 4)  # 50 ms = tau_down
    assert plant.state.rotor_omega_radps[0] == pytest.approx(start * math.exp(-1), rel=2e-3)


def test_ground_effect_gain() -> None:
    ge = GroundEffect(AeroParams(), RotorParams())
    heights = [0.2, 0.25, 0.3, 0.5, 1.0, 2.0, 5.0]
    gains = [ge.gain(z) for z in heights]
    assert all(g1 < g0 for g0, g1 in pairwise(gains))
    assert gains[1] == pytest.approx(1.14, abs=0.01)  # resting rotor plane, 0.25 m up
    assert ge.gain(ge.cutoff_m * 1.01) == 1.0
    assert ge.gain(ge.cutoff_m * 0.99) - 1.0 < 1.1e-4
    assert ge.gain(0.01) == AeroParams().ground_effect_max_gain
    assert GroundEffect(AeroParams(ground_effect=False), RotorParams()).gain(0.3) == 1.0


def test_ground_effect_reduces_to_cheeseman_bennett() -> None:
    # Far-apart rotors and no body term: the single-rotor 1 / (1 - (R/4z)^2).
    rotors = RotorParams(arm_length_m=1000.0)
    ge = GroundEffect(AeroParams(ground_effect_body_coeff=0.0), rotors)
    r = rotors.radius_m
    for z in (0.5 * r, r, 2.0 * r):
        assert ge.gain(z) == pytest.approx(1.0 / (1.0 - (r / (4 * z)) ** 2), rel=1e-9)


def test_thrust_is_larger_near_the_ground() -> None:
    plant = make_plant()
    om = (600.0,) * 4
    plant.set_kinematic_state((0.0, 0.0, -10.0), rotor_omega_radps=om)
    high = plant.state.thrust_N[0]
    plant.set_kinematic_state((0.0, 0.0, -0.3), rotor_omega_radps=om)
    low = plant.state.thrust_N[0]
    plant.set_kinematic_state((0.0, 0.0, 0.0), rotor_omega_radps=om)
    resting = plant.state.thrust_N[0]
    assert plant.state.on_ground
    assert resting > 1.1 * high and resting > low > 1.03 * high
    # The ground hover throttle is lower, and slightly above it the vehicle lifts off and
    # floats on the ground cushion (thrust falls with height) instead of climbing away.
    plant.reset_on_ground()
    assert plant.hover_throttle() < 0.7 < make_plant_hover_at(10.0)
    thr = [plant.hover_throttle() * 1.02] * 4
    run(plant, 400, thr)
    heights = []
    for _ in range(800):
        run(plant, 1, thr)
        heights.append(plant.state.h_m)
    assert min(heights) > 0.02 and max(heights) < 0.5
    assert plant.counters["liftoffs"] == 1 and plant.counters["touchdowns"] == 0
    assert plant.t_ns == 1200 * TICK_NS


def make_plant_hover_at(h_m: float) -> float:
    plant = make_plant()
    hover_at(plant, h_m)
    return plant.hover_throttle()
