"""The C flight code's rig and flight config are the Python flight code's, but for the flight
code: rigs/paper-quad-c.toml is rigs/paper-quad.toml but for [rig] and [flight], and
rigs/firmware-paper-quad.toml is the Python template with rigs/paper-quad.toml's
[flight.overrides] written in place (the firmware's gains are generated from it)."""

from __future__ import annotations

import tomllib
from pathlib import Path

from hil.flight.run_files import deep_merge

RIGS = Path(__file__).resolve().parents[3] / "rigs"


def _load(name: str) -> dict:
    return tomllib.loads((RIGS / name).read_text())


def test_c_rig_is_the_python_rig_but_for_the_flight_code() -> None:
    py, c = _load("paper-quad.toml"), _load("paper-quad-c.toml")
    assert set(py) == set(c)
    for table in py:
        if table not in ("rig", "flight"):
            assert c[table] == py[table], table
    assert c["rig"]["tick_ns"] == py["rig"]["tick_ns"]
    assert c["flight"]["config"] == "firmware-paper-quad.toml"
    assert "overrides" not in c["flight"]  # the gains are in the config the design is made from
    for key in ("boot_timeout_s", "barrier_timeout_s", "required_devices"):
        assert c["flight"][key] == py["flight"][key], key


def test_firmware_config_is_the_template_with_the_rigs_overrides() -> None:
    template = _load("flightcode-paper-quad.toml")
    overrides = _load("paper-quad.toml")["flight"]["overrides"]
    assert _load("firmware-paper-quad.toml") == deep_merge(template, overrides)
