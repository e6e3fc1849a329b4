"""Aerodynamic moments: rotor drag at the hubs, flapping, centre of pressure, rotational
damping through the hubs' own velocities, and gust differences across the airframe."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hil.plant import AeroParams, PlantParams, RotorParams
from hil.plant.rotors import rotor_geometry
from tests.unit.plant.support import NO_DRAG, make_plant

HOVER_OMEGA = 609.0


def _aero(**fields: object) -> AeroParams:
    return replace(NO_DRAG, ground_effect=False, **fields)  # type: ignore[arg-type]


def _moment_B(aero: AeroParams, v_N=(0.0, 0.0, 0.0), w_B=(0.0, 0.0, 0.0), omegas=(HOVER_OMEGA,) * 4) -> np.ndarray:
    """Total moment about the CG (N m, body) = J alpha + w x J w, from the plant."""
    plant = make_plant(aero=aero, rotors=RotorParams(rotor_inertia_kgm2=0.0))
    plant.set_kinematic_state((0.0, 0.0, -50.0), v_N, omega_B_radps=w_B, rotor_omega_radps=omegas)
    _, alpha = plant.accelerations()
    j = np.array(plant.mass_properties.inertia_B_kgm2)
    w = np.array(w_B)
    return j @ np.array(alpha) + np.cross(w, j @ w)


def _sigma() -> float:
    plant = make_plant()
    plant.set_kinematic_state((0.0, 0.0, -50.0))
    return plant._sigma  # density ratio at 50 m


def _reference_moment(aero: AeroParams, v_B, w_B, omegas) -> np.ndarray:
    """Independent numpy evaluation of the per-hub model (docs/aerodynamics.md), thrust and
    yaw drag torques excluded (equal speeds cancel them)."""
    sig = _sigma()
    geom = rotor_geometry(RotorParams())
    m = np.zeros(3)
    for pos, om in zip(geom.position_B_m, omegas, strict=True):
        r = np.array(pos)
        v = np.array(v_B) + np.cross(w_B, r)
        h = -sig * om * np.array([aero.rotor_drag_N_per_mps_per_radps * v[0],
                                  aero.rotor_drag_N_per_mps_per_radps * v[1],
                                  aero.rotor_drag_vertical_N_per_mps_per_radps * v[2]])  # fmt: skip
        m += np.cross(r, h) + sig * aero.flapping_moment_Nm_per_mps_per_radps * om * np.cross([0.0, 0.0, 1.0], v)
    return m


def test_forward_airspeed_pitches_the_nose_up() -> None:
    """Moving forward (relative wind from the nose): flapping tilts the disks back and the
    H-force acts above the CG; both pitch the nose up (+y in FRD), neither rolls."""
    for aero in (_aero(flapping_moment_Nm_per_mps_per_radps=2.8e-5), _aero(rotor_drag_N_per_mps_per_radps=1e-4)):
        m = _moment_B(aero, v_N=(3.0, 0.0, 0.0))
        assert m[1] > 1e-3, m
        assert abs(m[0]) < 1e-9
        np.testing.assert_allclose(m, _reference_moment(aero, (3.0, 0.0, 0.0), (0, 0, 0), (HOVER_OMEGA,) * 4), atol=1e-12)


def test_sideways_airspeed_rolls_away_from_the_wind() -> None:
    aero = AeroParams(ground_effect=False, centre_of_pressure_B_m=(0.0, 0.0, 0.0))
    m = _moment_B(aero, v_N=(0.0, 2.0, 0.0))  # moving right: relative wind from the right
    assert m[0] < -1e-3  # rolls left, away from the relative wind


def test_default_magnitudes_at_1_mps() -> None:
    """The sourced defaults: ~0.0127 N m per m/s of flapping for the vehicle at hover speed,
    and 4 x 0.06 N/(m/s) x 0.05 m of H-force moment: about the same."""
    d = AeroParams()
    flap = _moment_B(_aero(flapping_moment_Nm_per_mps_per_radps=d.flapping_moment_Nm_per_mps_per_radps), (1.0, 0, 0))
    assert 0.011 < flap[1] < 0.014
    hforce = _moment_B(_aero(rotor_drag_N_per_mps_per_radps=d.rotor_drag_N_per_mps_per_radps), (1.0, 0, 0))
    assert 0.010 < hforce[1] < 0.014


def test_body_rotation_is_damped_through_the_hub_velocities() -> None:
    """A roll or pitch rate moves the hubs up and down (inflow drag k_z), a yaw rate moves
    them sideways (H-force): each gives a moment against the rotation."""
    aero = _aero(rotor_drag_N_per_mps_per_radps=1e-4, rotor_drag_vertical_N_per_mps_per_radps=5.4e-4)
    for axis in range(3):
        w = [0.0, 0.0, 0.0]
        w[axis] = 1.0
        m = _moment_B(aero, w_B=tuple(w))
        assert m[axis] < -1e-3, (axis, m)
        np.testing.assert_allclose(m, _reference_moment(aero, (0, 0, 0), w, (HOVER_OMEGA,) * 4), atol=1e-12)
    # roll damping: 4 hubs at |y| = 0.177 m (sum y^2 = 0.125 m^2), k_z w = 0.33 N/(m/s) each,
    # plus the H-force of the hubs' sideways motion 0.05 m above the CG: 0.0415 N m per rad/s
    m = _moment_B(aero, w_B=(1.0, 0.0, 0.0))
    sig = _sigma()
    assert math.isclose(-m[0], sig * HOVER_OMEGA * (5.4e-4 * 0.125 + 1e-4 * 4 * 0.05**2), rel_tol=1e-9)


def test_centre_of_pressure_below_the_cg_rolls_with_the_side_wind() -> None:
    """Body drag at a point below the CG: a relative wind from the right pushes the bottom
    to the left, so the top leans into the wind: right wing down, positive roll."""
    aero = _aero(linear_drag_B_N_per_mps=(0.1, 0.1, 0.2), centre_of_pressure_B_m=(0.0, 0.0, 0.05))
    m = _moment_B(aero, v_N=(0.0, 2.0, 0.0))  # relative wind from the right
    # F_y = -0.1 * 2 sigma at z = +0.05: M_x = r_y F_z - r_z F_y = +0.05 * 0.2 sigma
    assert math.isclose(m[0], 0.05 * 0.2 * _sigma(), rel_tol=1e-9)


@settings(max_examples=40, deadline=None)
@given(
    st.tuples(*(st.floats(-5.0, 5.0) for _ in range(3))),
    st.tuples(*(st.floats(-3.0, 3.0) for _ in range(3))),
    st.tuples(*(st.floats(300.0, 800.0) for _ in range(4))),
)
def test_per_hub_model_matches_an_independent_evaluation(v_B, w_B, omegas) -> None:
    """Rotor drag and flapping only (no body drag, equal-speed thrust moments removed by
    subtracting the still-air case): the plant's unrolled scalar code equals a numpy
    evaluation of the same formulas at random states."""
    aero = _aero(
        rotor_drag_N_per_mps_per_radps=1e-4,
        rotor_drag_vertical_N_per_mps_per_radps=5.4e-4,
        flapping_moment_Nm_per_mps_per_radps=2.8e-5,
    )
    still = _moment_B(NO_DRAG, (0.0, 0.0, 0.0), w_B, omegas)
    m = _moment_B(aero, v_B, w_B, omegas) - still
    np.testing.assert_allclose(m, _reference_moment(aero, v_B, w_B, omegas), atol=1e-9)


def test_uniform_wind_and_motion_through_still_air_are_the_same() -> None:
    """Only the air-relative velocity matters: wind (-2, 1, 0) on a still vehicle makes the
    same moment as the vehicle moving at (2, -1, 0) through still air."""
    from hil.plant import WindParams

    p = replace(PlantParams(), wind=WindParams(mean_N_mps=(-2.0, 1.0, 0.0)))
    plant = make_plant(p)
    plant.set_kinematic_state((0.0, 0.0, -50.0), rotor_omega_radps=(HOVER_OMEGA,) * 4)
    in_wind = plant.accelerations()
    plant2 = make_plant()
    plant2.set_kinematic_state((0.0, 0.0, -50.0), (2.0, -1.0, 0.0), rotor_omega_radps=(HOVER_OMEGA,) * 4)
    np.testing.assert_allclose(in_wind[1], plant2.accelerations()[1], atol=1e-12)
    np.testing.assert_allclose(in_wind[0], plant2.accelerations()[0], atol=1e-12)
