"""The firmware's estimation and control built once per session for two flight configs: the
bench's rig (rigs/paper-quad.toml's retuned gains over the template's defaults) and the
template's defaults (docs/controllers.md 2.6 and 3.2)."""

from __future__ import annotations

from pathlib import Path

import pytest

from flightcode.config import FlightConfig, load
from tests.unit.firmware import cfw

PORTS = """
[ports.imu]
path = "/dev/null"
baud = 921600
[ports.adc]
path = "/dev/null"
baud = 115200
[ports.rc]
path = "/dev/null"
baud = 115200
[ports.esc]
path = "/dev/null"
baud = 115200
[telemetry]
enable = false
"""

#: rigs/paper-quad.toml's [flight.overrides], written into a flight config
RIG_OVERRIDES = """
[attitude]
omega1_radps = 5.0
k0_per_s = 4.0
tau_ff_s = 0.005
[altitude]
q_int = 0.04
q_z = 0.003
"""


def write_config(directory: Path, name: str, extra: str = "") -> Path:
    path = directory / f"{name}.toml"
    path.write_text(PORTS + extra)
    return path


@pytest.fixture(scope="session")
def fw_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("firmware")


@pytest.fixture(scope="session")
def rig_config(fw_dir: Path) -> Path:
    return write_config(fw_dir, "rig", RIG_OVERRIDES)


@pytest.fixture(scope="session")
def rig_cfg(rig_config: Path) -> FlightConfig:
    return load(rig_config)


@pytest.fixture(scope="session")
def lib(rig_config: Path, fw_dir: Path) -> cfw.Lib:
    return cfw.build(rig_config, fw_dir / "rig")


@pytest.fixture(scope="session")
def template_config(fw_dir: Path) -> Path:
    return write_config(fw_dir, "template")


@pytest.fixture(scope="session")
def template_lib(template_config: Path, fw_dir: Path) -> cfw.Lib:
    return cfw.build(template_config, fw_dir / "template")
