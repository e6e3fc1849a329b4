"""Rotor imbalance in the plant (hil/plant/vibration.py): the force's magnitude and frequency,
phase continuity through a speed change, the rigid-body response at the sensors, seeding, and
that it leaves the rigid-body motion alone."""

from __future__ import annotations

import dataclasses
import math

import hypothesis.strategies as st
import numpy as np
import pytest
from hypothesis import given, settings

from hil.config import ConfigError, validate
from hil.plant import Plant, PlantParams, VibrationParams
from hil.plant.params_vehicle import ROTOR_ROTATING_MASS_KG, SensorMountParams, iso1940_imbalance_kgm
from hil.plant.records import VibrationTone
from hil.plant.vibration import RotorImbalance

TICK_NS = 2_500_000
U = 1.0e-6  # kg m
NO_SPREAD = VibrationParams(imbalance_kgm=(U, U, U, U), imbalance_spread=0.0, phase_rad=(0.0, 0.0, 0.0, 0.0))


def value(tone: VibrationTone, dt_s: float = 0.0) -> np.ndarray:
    phi = tone.phase_rad + tone.omega_radps * dt_s
    return np.array(tone.re) * math.cos(phi) - np.array(tone.im) * math.sin(phi)


def point_mass_params(vib: VibrationParams = NO_SPREAD, **sensors: tuple[float, float, float]) -> PlantParams:
    """Default vehicle with the given vibration and sensor positions (default: both at the CG)."""
    mount = SensorMountParams(**{"imu_position_B_m": (0.0, 0.0, 0.0), "accel_position_B_m": (0.0, 0.0, 0.0), **sensors})
    return PlantParams(vibration=vib, sensors=mount)


def spinning(params: PlantParams, omega: tuple[float, float, float, float], seed: int = 0) -> Plant:
    plant = Plant(params, np.random.default_rng(seed), vibration_rng=np.random.default_rng(seed + 100))
    plant.set_kinematic_state((0.0, 0.0, -10.0), rotor_omega_radps=omega)
    return plant


def test_iso1940_grades_give_the_documented_imbalances() -> None:
    w = 8000 * 2 * math.pi / 60
    assert iso1940_imbalance_kgm(6.3, ROTOR_ROTATING_MASS_KG, w) == pytest.approx(3.38e-7, rel=2e-3)
    assert iso1940_imbalance_kgm(16.0, ROTOR_ROTATING_MASS_KG, w) == pytest.approx(8.6e-7, rel=2e-3)
    assert VibrationParams().imbalance_kgm == (8.6e-7,) * 4


def test_force_magnitude_is_u_omega_squared_at_the_cg() -> None:
    """One rotor spinning, sensors at the CG: |a| = U w^2 / m, constant along the rotation
    (a rotating vector of that length in the rotor plane, nothing along z)."""
    w = 600.0
    plant = spinning(point_mass_params(), (w, 0.0, 0.0, 0.0))
    f_S, _, f_acc = plant.sensors().vib_f_S, plant.sensors().vib_omega_S, plant.sensors().vib_f_acc_B
    assert len(f_S) == len(f_acc) == 1
    tone = f_acc[0]
    assert tone.omega_radps == w
    m = plant.mass_properties.mass_kg
    for dt in np.linspace(0.0, 2 * math.pi / w, 17):
        a = value(tone, dt)
        assert np.hypot(a[0], a[1]) == pytest.approx(U * w * w / m, rel=1e-12)
        assert a[2] == pytest.approx(0.0, abs=1e-15)


def test_frequency_is_the_rotor_speed_and_the_sense_its_spin() -> None:
    """Stepping the plant, the force direction turns by omega dt: clockwise from above (+x to
    +y) for rotors 2, 3, counter-clockwise for 0, 1."""
    w = 500.0
    for rotor, sense in ((0, -1.0), (1, -1.0), (2, 1.0), (3, 1.0)):
        omega = [0.0] * 4
        omega[rotor] = w
        params = point_mass_params()
        plant = spinning(params, tuple(omega))  # type: ignore[arg-type]
        plant.step(0, (0.0,) * 4)
        hold = (w / plant.omega_max_radps,) * 4
        angles = []
        for k in range(1, 4):
            cmd = [0.0] * 4
            cmd[rotor] = hold[rotor]
            plant.step(k * 250_000, cmd)  # 0.25 ms: 0.125 rad per step at 500 rad/s
            a = value(plant.sensors().vib_f_acc_B[0])
            angles.append(math.atan2(a[1], a[0]))
        steps = np.diff(np.unwrap(angles))
        assert steps == pytest.approx([sense * w * 250e-6] * 2, rel=1e-3)


def test_phase_is_the_integral_of_the_speed_and_continuous_through_a_speed_change() -> None:
    """The heavy-spot angle integrates omega (trapezoidal per sub-step): through a spin-up it
    equals the integral of the rotor speed, and the sensed force has no jump."""
    params = point_mass_params()
    plant = spinning(params, (300.0,) * 4)
    vib = plant.rotor_imbalance
    assert vib is not None
    total = 0.0
    prev_w = plant.state.rotor_omega_radps[0]
    prev_a = value(plant.sensors().vib_f_acc_B[0])
    biggest_jump = 0.0
    for k in range(1, 81):
        thr = 0.9 if k < 40 else 0.5  # spin up hard, then down
        plant.step(k * TICK_NS, (thr,) * 4)
        w = plant.state.rotor_omega_radps[0]
        # exact integral of the first-order lag towards this tick's held command
        cmd = thr * plant.omega_max_radps
        tau = params.rotors.tau_up_s if cmd > prev_w else params.rotors.tau_down_s
        T = TICK_NS * 1e-9
        total += cmd * T + (prev_w - cmd) * tau * (1.0 - math.exp(-T / tau))
        prev_w = w
        a = value(plant.sensors().vib_f_acc_B[0])
        # between samples the vector turns by < omega dt; a jump would show as a larger chord
        chord = np.linalg.norm(a - prev_a) / max(np.linalg.norm(a), 1e-12)
        biggest_jump = max(biggest_jump, chord / (w * TICK_NS * 1e-9))
        prev_a = a
    assert vib.phase_rad[0] == pytest.approx(math.fmod(total, 2 * math.pi), abs=5e-3)
    assert biggest_jump < 1.1  # chord 2 sin(x/2) <= x, plus the magnitude change


def test_rigid_body_response_at_an_offset_sensor() -> None:
    """At a sensor off the CG the acceleration is F/m + alpha x r with alpha = J^-1 (h x F);
    the rate is the integral of alpha (amplitude |alpha| / omega, 90 deg behind)."""
    r_imu = (0.05, -0.02, -0.03)
    params = point_mass_params(imu_position_B_m=r_imu)
    w = 700.0
    plant = spinning(params, (0.0, 0.0, w, 0.0))  # rotor 2: front-left
    s = plant.sensors()
    mp = plant.mass_properties
    hub = np.array([0.25 * math.cos(math.radians(315)), 0.25 * math.sin(math.radians(315)), -0.05])
    j_inv = np.linalg.inv(np.array(mp.inertia_B_kgm2))
    for dt in (0.0, 1e-3, 3.3e-3):
        theta = s.vib_f_S[0].phase_rad + w * dt
        force = U * w * w * np.array([math.cos(theta), math.sin(theta), 0.0])  # clockwise from above
        alpha = j_inv @ np.cross(hub - np.array(mp.cg_B_m), force)
        expect = force / mp.mass_kg + np.cross(alpha, np.array(r_imu) - np.array(mp.cg_B_m))
        np.testing.assert_allclose(value(s.vib_f_S[0], dt), expect, atol=1e-12)
        # rate: d/dt of the rate tone equals alpha
        h = 1e-7
        rate_dot = (value(s.vib_omega_S[0], dt + h) - value(s.vib_omega_S[0], dt - h)) / (2 * h)
        np.testing.assert_allclose(rate_dot, alpha, rtol=1e-5, atol=1e-9)


def test_imu_tones_are_in_the_sensor_frame() -> None:
    """An IMU turned 90 deg in yaw sees the body x vibration on its -y axis."""
    turned = dataclasses.replace(point_mass_params(), sensors=SensorMountParams(
        imu_position_B_m=(0.0, 0.0, 0.0), accel_position_B_m=(0.0, 0.0, 0.0), imu_rotation_BS_rpy_deg=(0.0, 0.0, 90.0)))
    s_turned = spinning(turned, (600.0, 0.0, 0.0, 0.0)).sensors()
    s_body = spinning(point_mass_params(), (600.0, 0.0, 0.0, 0.0)).sensors()
    a_B = value(s_body.vib_f_acc_B[0])
    a_S = value(s_turned.vib_f_S[0])
    np.testing.assert_allclose(a_S, (a_B[1], -a_B[0], a_B[2]), atol=1e-12)


def test_no_tones_at_rest_or_when_off() -> None:
    assert Plant(PlantParams(), np.random.default_rng(0)).sensors().vib_f_S == ()
    off = point_mass_params(dataclasses.replace(NO_SPREAD, enabled=False))
    plant = spinning(off, (600.0,) * 4)
    s = plant.sensors()
    assert s.vib_f_S == s.vib_omega_S == s.vib_f_acc_B == ()
    assert plant.rotor_imbalance is None


def test_vibration_does_not_move_the_rigid_body() -> None:
    """The same flight with and without imbalance: identical truth (sensor-only model)."""
    runs = []
    for enabled in (True, False):
        params = dataclasses.replace(PlantParams(), vibration=dataclasses.replace(VibrationParams(), enabled=enabled))
        plant = Plant(params, np.random.default_rng(3))
        for k in range(1, 401):
            plant.step(k * TICK_NS, (0.8, 0.78, 0.79, 0.8))
        runs.append(plant.state)
    assert runs[0] == runs[1]


def test_magnitudes_and_phases_come_from_the_vibration_generator() -> None:
    params = VibrationParams()
    a = RotorImbalance(params, (False, False, True, True), np.random.default_rng(5))
    b = RotorImbalance(params, (False, False, True, True), np.random.default_rng(5))
    c = RotorImbalance(params, (False, False, True, True), np.random.default_rng(6))
    assert a.imbalance_kgm == b.imbalance_kgm and a.phase_rad == b.phase_rad
    assert a.imbalance_kgm != c.imbalance_kgm and a.phase_rad != c.phase_rad
    assert all(0.5 * 8.6e-7 <= u <= 1.5 * 8.6e-7 for u in a.imbalance_kgm)
    fixed = RotorImbalance(dataclasses.replace(params, imbalance_spread=0.0, phase_rad=(0.1, 0.2, 0.3, 7.0)),
                           (False,) * 4, np.random.default_rng(5))
    assert fixed.imbalance_kgm == (8.6e-7,) * 4
    assert fixed.phase_rad == pytest.approx([0.1, 0.2, 0.3, 7.0 - 2 * math.pi])


def test_plant_without_a_vibration_generator_leaves_the_wind_draws_alone() -> None:
    """The default child Generator is spawned, not drawn, from the plant's: the wind (its
    only other user) sees the same numbers with the model on or off."""
    rng_a, rng_b = np.random.default_rng(11), np.random.default_rng(11)
    Plant(PlantParams(), rng_a)
    Plant(dataclasses.replace(PlantParams(), vibration=VibrationParams(enabled=False)), rng_b)
    assert rng_a.standard_normal(4).tolist() == rng_b.standard_normal(4).tolist()


@pytest.mark.parametrize(
    ("table", "reason"),
    [
        ({"imbalance_spread": 1.0}, "imbalance_spread must be in [0, 1)"),
        ({"imbalance_kgm": [0.86, 0.86, 0.86, 0.86]}, "the unit is kg m, not g mm"),
        ({"imbalance_kgm": [-1e-7, 0.0, 0.0, 0.0]}, "imbalance_kgm must be finite and >= 0"),
        ({"phase_rad": [0.0, 1.0, "nan", 0.0]}, "phase_rad needs 4 finite angles"),
        ({"enable": True}, "vibration.enable"),
    ],
)
def test_rig_errors_name_file_key_and_reason(table: dict[str, object], reason: str) -> None:
    with pytest.raises(ConfigError) as err:
        validate(PlantParams, {"vibration": table}, file="rigs/x.toml", section="plant")
    msg = str(err.value)
    assert msg.startswith("rigs/x.toml: [plant] vibration") and reason in msg


@settings(max_examples=40, deadline=None)
@given(
    omega=st.floats(50.0, 900.0),
    u=st.floats(1e-8, 1e-5),
    phase=st.floats(0.0, 2 * math.pi),
    rotor=st.integers(0, 3),
    dt=st.floats(0.0, 0.01),
)
def test_property_cg_acceleration_magnitude_and_angle(
    omega: float, u: float, phase: float, rotor: int, dt: float
) -> None:
    """Any speed, imbalance, phase and rotor: at the CG the tone's value is a vector of length
    U w^2 / m in the rotor plane, at angle phase + w dt (mirrored for counter-clockwise rotors)."""
    vib = VibrationParams(imbalance_kgm=(u, u, u, u), imbalance_spread=0.0, phase_rad=(phase,) * 4)
    speeds = [0.0] * 4
    speeds[rotor] = omega
    plant = spinning(point_mass_params(vib), tuple(speeds))  # type: ignore[arg-type]
    tone = plant.sensors().vib_f_acc_B[0]
    a = value(tone, dt)
    m = plant.mass_properties.mass_kg
    assert math.hypot(a[0], a[1]) == pytest.approx(u * omega * omega / m, rel=1e-9)
    sense = 1.0 if rotor >= 2 else -1.0
    expect = phase + omega * dt
    angle = math.atan2(sense * a[1], a[0])
    assert math.remainder(angle - expect, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)
