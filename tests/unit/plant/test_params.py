"""Parameters: the paper's numbers as defaults, and strict validation as the rig loader does it."""

from __future__ import annotations

import math
import tomllib

import pydantic
import pytest

from hil.plant import FrameLayout, GustShape, PlantParams, RotorParams

G = 9.80665
ADAPTER = pydantic.TypeAdapter(PlantParams)


def test_defaults_are_the_papers_vehicle() -> None:
    p = PlantParams()
    assert p.body.mass_kg == 1.1  # Table 1
    assert p.body.inertia_B_kgm2[0] == 0.0153  # docs/controllers.md 2.3
    assert p.rotors.layout is FrameLayout.X
    assert 2 * p.rotors.arm_length_m == 0.5  # 500 mm motor to motor
    assert p.rotors.omega_max_radps * 60 / (2 * math.pi) == pytest.approx(8000.0)
    assert 4 * p.rotors.thrust_max_N == pytest.approx(2.1 * G)  # 20.6 N: 1.1 kg + 1 kg lift
    assert 4 * p.rotors.thrust_max_N == pytest.approx(20.6, abs=0.05)
    assert (p.battery.cells, p.battery.capacity_Ah) == (3, 2.1)
    assert (p.rotors.tau_up_s, p.rotors.tau_down_s) == (0.0125, 0.025)  # docs/protocols.md 6.1
    assert (p.tick_ns, p.substeps) == (2_500_000, 4)
    # F = F_max d^2 => d_h = sqrt(m g / F_max) = 0.724 at omega_max (docs/controllers.md 3.1).
    assert math.sqrt(1.1 * G / (4 * p.rotors.thrust_max_N)) == pytest.approx(0.724, abs=5e-4)


def test_rotor_coefficients() -> None:
    r = RotorParams()
    assert r.k_T_N_per_radps2 * r.omega_max_radps**2 == pytest.approx(r.thrust_max_N)
    assert r.k_Q_Nm_per_radps2 / r.k_T_N_per_radps2 == pytest.approx(r.torque_per_thrust_m)


RIG = """
[plant]
substeps = 8
[plant.body]
mass_kg = 1.4
inertia_B_kgm2 = [0.018, 0.018, 0.027]
[plant.rotors]
layout = "+"
tau_up_s = 0.035
[plant.wind]
mean_N_mps = [3.0, 0.0, 0.0]
[[plant.wind.gusts]]
peak_N_mps = [0.0, 4.0, 0.0]
start_t_ns = 5_000_000_000
duration_ns = 2_000_000_000
shape = "1-cos"
"""


def test_rig_toml_validates_into_nested_frozen_params() -> None:
    p = ADAPTER.validate_python(tomllib.loads(RIG)["plant"])
    assert isinstance(p, PlantParams)
    assert p.substeps == 8
    assert p.body.mass_kg == 1.4 and p.body.inertia_B_kgm2 == (0.018, 0.018, 0.027)
    assert p.rotors.layout is FrameLayout.PLUS and p.rotors.tau_up_s == 0.035
    assert p.rotors.tau_down_s == 0.025  # untouched keys keep the paper's defaults
    assert p.wind.gusts[0].shape is GustShape.ONE_MINUS_COSINE
    assert p.wind.gusts[0].peak_N_mps == (0.0, 4.0, 0.0)
    with pytest.raises(AttributeError):
        p.body.mass_kg = 2.0  # type: ignore[misc]


@pytest.mark.parametrize(
    ("table", "where"),
    [
        ({"body": {"mass_kg": 1.1, "colour": "red"}}, ("body", "colour")),
        ({"rotors": {"tau_up": 0.01}}, ("rotors", "tau_up")),
        ({"unknown": 1}, ("unknown",)),
    ],
)
def test_unknown_keys_are_rejected_with_their_path(table: dict[str, object], where: tuple[str, ...]) -> None:
    with pytest.raises(pydantic.ValidationError) as err:
        ADAPTER.validate_python(table)
    assert tuple(err.value.errors()[0]["loc"]) == where


@pytest.mark.parametrize(
    "table",
    [
        {"body": {"mass_kg": -1.0}},
        {"rotors": {"layout": "h"}},
        {"rotors": {"spin_ccw_from_above": [True, False]}},
        {"battery": {"soc_initial": 1.5}},
        {"substeps": 0},
        {"wind": {"gusts": [{"peak_N_mps": [1, 0, 0], "start_t_ns": 0, "duration_ns": 0}]}},
    ],
)
def test_bad_values_are_rejected(table: dict[str, object]) -> None:
    with pytest.raises(pydantic.ValidationError):
        ADAPTER.validate_python(table)
