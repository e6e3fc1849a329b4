"""Ground contact: rests without jitter, lifts off when thrust exceeds weight, lands from any
descent without blowing up, never goes below the ground."""

from __future__ import annotations

import math

import pytest

from hil.plant.quat import from_euler

from .support import NO_DRAG, TICK_NS, G, make_plant, run


def test_resting_vehicle_stays_exactly_put() -> None:
    plant = make_plant(initial_yaw_rad=0.7)
    start = plant.state
    assert start.on_ground and start.h_m == 0.0
    truths = []
    for k in range(800):  # 2 s, rotors spinning up to half throttle (below lift-off)
        run(plant, 1, [0.5] * 4)
        s = plant.state
        assert (s.p_N_m, s.v_N_mps, s.q_NB, s.omega_B_radps) == (start.p_N_m, (0.0,) * 3, start.q_NB, (0.0,) * 3)
        assert s.on_ground and s.h_m == 0.0
        if k > 400:
            truths.append(plant.sensors())
    assert len({t.f_acc_B_mps2 for t in truths}) == 1  # no jitter in what the sensors see
    assert truths[-1].f_acc_B_mps2 == pytest.approx((0.0, 0.0, -G), abs=1e-12)
    assert truths[-1].f_S_mps2 == pytest.approx((0.0, 0.0, -G), abs=1e-12)  # S: FRD convention
    assert plant.state.rotor_omega_radps[0] > 0.4 * plant.omega_max_radps
    assert sum(plant.state.thrust_N) < plant.state.mass_kg * G
    assert plant.counters["liftoffs"] == 0


def test_lifts_off_only_when_thrust_exceeds_weight() -> None:
    plant = make_plant()
    ground_hover = plant.hover_throttle()  # includes ground effect
    run(plant, 400, [0.98 * ground_hover] * 4)
    assert plant.state.on_ground and plant.state.h_m == 0.0
    weight = plant.state.mass_kg * G
    assert sum(plant.state.thrust_N) < weight
    airborne_at = None
    for k in range(400):
        run(plant, 1, [1.05 * ground_hover] * 4)
        if not plant.state.on_ground:
            airborne_at = k
            break
    assert airborne_at is not None
    assert sum(plant.state.thrust_N) > weight
    run(plant, 200, [1.1 * ground_hover] * 4)
    s = plant.state
    assert not s.on_ground and s.h_m > 0.1 and s.v_N_mps[2] < 0.0
    assert plant.counters["liftoffs"] == 1


@pytest.mark.parametrize(
    ("v_down_mps", "attitude", "rates", "throttle"),
    [
        (0.3, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.64),  # gentle: just below the ground hover throttle
        (3.0, (0.2, -0.1, 1.0), (0.5, 0.2, 1.0), 0.3),  # hard, tilted, spinning
        (15.0, (1.2, 0.4, -2.0), (5.0, -4.0, 2.0), 0.0),  # a crash
    ],
)
def test_landing_never_goes_below_ground_or_explodes(
    v_down_mps: float, attitude: tuple[float, float, float], rates: tuple[float, float, float], throttle: float
) -> None:
    plant = make_plant()
    om = plant.hover_rotor_omega_radps()
    plant.set_kinematic_state(
        (2.0, -1.0, -3.0),
        v_N_mps=(1.0, 0.5, v_down_mps),
        q_NB=from_euler(*attitude),
        omega_B_radps=rates,
        rotor_omega_radps=(om,) * 4,
    )
    heights = []
    for _ in range(1200):  # 3 s
        run(plant, 1, [throttle] * 4)
        s = plant.state
        heights.append(s.h_m)
        assert all(math.isfinite(v) for v in s.p_N_m + s.v_N_mps + s.q_NB + s.omega_B_radps)
        assert max(abs(v) for v in s.v_N_mps) < 50.0
    assert min(heights) >= 0.0
    s = plant.state
    assert s.on_ground and s.h_m == 0.0 and s.v_N_mps == (0.0, 0.0, 0.0)
    assert abs(s.euler_rpy_rad[0]) < 1e-12 and abs(s.euler_rpy_rad[1]) < 1e-12  # level on its gear
    td = plant.last_touchdown
    assert td is not None and td.v_down_mps >= v_down_mps - 1e-9
    assert plant.counters["touchdowns"] >= 1
    # It stays down: heights after the first contact are all exactly zero.
    first = heights.index(0.0)
    assert set(heights[first:]) == {0.0}


def test_touchdown_record_and_reset() -> None:
    plant = make_plant(aero=NO_DRAG)
    plant.set_kinematic_state((5.0, 5.0, -1.0), v_N_mps=(0.0, 0.0, 2.0), q_NB=from_euler(0.1, 0.0, 0.4))
    run(plant, 400, [0.0] * 4)
    td = plant.last_touchdown
    assert td is not None
    # Free fall from 1 m at 2 m/s: v^2 = 4 + 2 g h (contact is detected at the end of a
    # 0.625 ms sub-step, so up to g * 0.625 ms late).
    assert td.v_down_mps == pytest.approx(math.sqrt(4.0 + 2 * G * 1.0), abs=G * 0.000625)
    assert td.tilt_rad == pytest.approx(0.1, abs=1e-3)
    assert 0 < td.t_ns < 400 * TICK_NS
    assert plant.state.p_N_m[:2] == pytest.approx((5.0, 5.0), abs=0.01)
    assert plant.state.euler_rpy_rad[2] == pytest.approx(0.4, abs=1e-9)  # heading kept

    plant.set_kinematic_state((0.0, 0.0, -20.0), v_N_mps=(3.0, 0.0, 0.0), rotor_omega_radps=(500.0,) * 4)
    plant.reset_on_ground()
    s = plant.state
    assert s.on_ground and s.h_m == 0.0 and s.rotor_omega_radps == (0.0,) * 4 and s.v_N_mps == (0.0,) * 3


def test_cannot_place_below_ground() -> None:
    plant = make_plant()
    with pytest.raises(ValueError, match="below the ground"):
        plant.set_kinematic_state((0.0, 0.0, 0.5))
