"""The figures written in rigs/paper-quad.toml's comments, recomputed from the rig's parameters.

Each figure is read from the comment where the rig states it and compared with what the plant
and the sensor models give for the loaded rig. Changing a parameter without its comment, or a
comment without its parameter, fails here.
"""

from __future__ import annotations

import math
import re
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from hil.config.rig import Rig, load_rig
from hil.plant import Plant

RIG_PATH = Path(__file__).resolve().parents[3] / "rigs" / "paper-quad.toml"
G_MPS2 = 9.80665
#: ISA sea-level density (kg/m^3): dP/dh = -rho g near the ground
RHO_SEA_KGPM3 = 1.225
NUM = r"(-?[0-9]+(?:\.[0-9]+)?(?:e-?[0-9]+)?)"


@cache
def _rig() -> Rig:
    return load_rig(RIG_PATH)


@cache
def _text() -> str:
    return RIG_PATH.read_text()


def _figure(pattern: str) -> float:
    """The number captured by ``pattern`` (one group) in the rig file, found exactly once."""
    found = re.findall(pattern, _text())
    assert len(found) == 1, f"rigs/paper-quad.toml: {pattern!r} found {len(found)} times"
    return float(found[0])


@cache
def _hover_omega_radps() -> float:
    plant = Plant(_rig().plant, np.random.default_rng(1))
    plant.set_kinematic_state((0.0, 0.0, -10.0))  # out of ground effect
    return plant.hover_rotor_omega_radps()


def test_hover_throttle() -> None:
    plant = Plant(_rig().plant, np.random.default_rng(1))
    plant.set_kinematic_state((0.0, 0.0, -10.0))
    written = _figure(r"omega_max_ref_V = .*hover throttle " + NUM)
    assert plant.hover_throttle() == pytest.approx(written, abs=5e-4)


def test_total_thrust_is_weight_plus_payload_capacity() -> None:
    rotors = _rig().plant.rotors
    written_N = _figure(r"thrust_max_N = .*# " + NUM + r" N / 4")
    assert 4 * rotors.thrust_max_N == pytest.approx(written_N, abs=0.05)
    assert 4 * rotors.thrust_max_N == pytest.approx((_rig().plant.body.mass_kg + 1.0) * G_MPS2, rel=1e-4)


def test_rotor_aerodynamics_per_rotor_at_hover() -> None:
    aero, om = _rig().plant.aero, _hover_omega_radps()
    h_force = _figure(r"H-force: " + NUM + r" N/\(m/s\) per rotor at hover")
    inflow = _figure(r"dT/dVc = " + NUM + r" N/\(m/s\) per rotor")
    hub_moment = _figure(r"hub moment " + NUM + r" N m per m/s per rotor")
    assert aero.rotor_drag_N_per_mps_per_radps * om == pytest.approx(h_force, rel=0.05)
    assert aero.rotor_drag_vertical_N_per_mps_per_radps * om == pytest.approx(inflow, rel=0.02)
    assert aero.flapping_moment_Nm_per_mps_per_radps * om == pytest.approx(hub_moment, rel=0.02)


def test_vertical_damping_and_its_pole() -> None:
    p, om = _rig().plant, _hover_omega_radps()
    per_rotor = _figure(r"4 x " + NUM + r" N/\(m/s\) at hover speed")
    total = _figure(r"plus body drag give " + NUM + r" N/\(m/s\)")
    pole = _figure(r"a pole at " + NUM + r" rad/s")
    c_N_per_mps = 4 * p.aero.rotor_drag_vertical_N_per_mps_per_radps * om + p.aero.linear_drag_B_N_per_mps[2]
    assert p.aero.rotor_drag_vertical_N_per_mps_per_radps * om == pytest.approx(per_rotor, rel=0.02)
    assert c_N_per_mps == pytest.approx(total, rel=0.04)
    assert -c_N_per_mps / p.body.mass_kg == pytest.approx(pole, abs=0.05)


def test_vibration_frequency_and_the_accelerometer_filter() -> None:
    accel = _rig().analog.accel
    f_vib_Hz = _hover_omega_radps() / (2 * math.pi)
    assert f_vib_Hz == pytest.approx(_figure(r"its own speed \(" + NUM + r" Hz at\n# hover\)"), abs=0.6)
    f_c_Hz = 1.0 / (2 * math.pi * accel.filter_R_ohm * accel.filter_C_uF[2] * 1e-6)
    assert f_c_Hz == pytest.approx(_figure(r"C\) = " + NUM + r" Hz \(datasheet"), abs=0.05)
    kept = 1.0 / math.sqrt(1.0 + (f_vib_Hz / f_c_Hz) ** 2)
    assert f_vib_Hz == pytest.approx(_figure(r"vibration at " + NUM + r" Hz keeps"), abs=0.6)
    assert 100 * kept == pytest.approx(_figure(r"Hz keeps " + NUM + r" % of its amplitude"), abs=0.5)


def test_rotor_imbalance_of_balance_grade_g16() -> None:
    p = _rig().plant
    e_um = _figure(r"e = G / Omega = " + NUM + r" um")
    u_gmm = _figure(r"U = " + NUM + r" g mm")
    grade_mps = 16e-3  # ISO 1940-1 G16: e omega = 16 mm/s
    assert grade_mps / p.rotors.omega_max_radps * 1e6 == pytest.approx(e_um, abs=0.5)
    assert 0.045 * e_um * 1e-6 * 1e6 == pytest.approx(u_gmm, abs=0.01)  # 45 g rotating mass
    assert p.vibration.imbalance_kgm[0] == pytest.approx(u_gmm * 1e-6, rel=0.01)


def test_barometer_conditioning_stage() -> None:
    analog = _rig().analog
    baro, stage = analog.baro, analog.conditioning[0]
    sens_V_per_kPa = baro.supply_V * baro.gain_per_kPa
    sea_V = baro.supply_V * (baro.gain_per_kPa * 101.325 + baro.offset)
    field_V = (sea_V - stage.offset_V) * stage.gain
    assert field_V == pytest.approx(_figure(r"sea-level field at " + NUM + r" V"), abs=0.02)
    either_way_kPa = _figure(r"mid-scale, \+-" + NUM + r" kPa either way")
    assert 2.5 / stage.gain / sens_V_per_kPa == pytest.approx(either_way_kPa, abs=0.01)
    lsb_V = _rig().adc.mcp3204.vref_V / 4096
    m_per_code = lsb_V / stage.gain / sens_V_per_kPa * 1e3 / (RHO_SEA_KGPM3 * G_MPS2)
    assert m_per_code == pytest.approx(_figure(r"x16 \(" + NUM + r" m/LSB\)"), abs=0.005)


def test_a_changed_figure_fails() -> None:
    """The reader of the comments really compares: a figure one digit off is caught."""
    text = _text().replace("hover throttle 0.724", "hover throttle 0.734")
    written = float(re.findall(r"omega_max_ref_V = .*hover throttle " + NUM, text)[0])
    plant = Plant(_rig().plant, np.random.default_rng(1))
    plant.set_kinematic_state((0.0, 0.0, -10.0))
    assert plant.hover_throttle() != pytest.approx(written, abs=5e-4)
