"""``[plant.vibration] enabled = false`` gives the sensors exactly what they gave before the
vibration model existed: the default rig flown open loop (tests/unit/vibration/open_loop.py),
ADC volts and XSENS outputs against the values recorded on the tree before it (commit 78c9cb1)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np

from hil.config.rig import Rig, load_rig
from tests.unit.vibration import open_loop


def _with_vibration(rig: Rig, enabled: bool) -> Rig:
    vib = dataclasses.replace(rig.plant.vibration, enabled=enabled)
    return dataclasses.replace(rig, plant=dataclasses.replace(rig.plant, vibration=vib))


def test_vibration_off_reproduces_the_sensor_outputs_from_before_the_model() -> None:
    golden = json.loads(open_loop.GOLDEN.read_text())
    got = open_loop.run(open_loop.as_recorded(_with_vibration(load_rig(), False)))
    for key in ("t_ns", "volts", "acc", "rate", "h_m"):
        np.testing.assert_allclose(np.array(got[key]), np.array(golden[key]), rtol=1e-12, atol=1e-12, err_msg=key)


def test_vibration_on_changes_only_what_the_sensors_read() -> None:
    """The default rig (vibration on): same flight (truth height), different readings."""
    golden = json.loads(open_loop.GOLDEN.read_text())
    got = open_loop.run(open_loop.as_recorded(load_rig()))
    assert got["h_m"] == golden["h_m"]
    d_acc = np.abs(np.array(got["acc"]) - np.array(golden["acc"]))
    d_volts = np.abs(np.array(got["volts"]) - np.array(golden["volts"]))
    assert d_acc[:, :2].max() > 0.1  # m/s^2 in the rotor plane at the XSENS
    assert d_volts[:, 1:].max() > 1e-3  # V on the ADXL335 channels (0.3 mV per LSB-ish noise floor)
    assert d_volts[:, 0].max() == 0.0  # the barometer does not feel it
