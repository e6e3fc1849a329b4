"""Config: the example loads, every error names file, key and reason, every key is documented."""

from __future__ import annotations

import dataclasses
import tomllib
import typing
from pathlib import Path

import pydantic
import pytest

from flightcode.config import ConfigError, FlightConfig, load, parse

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE = ROOT / "rigs" / "flightcode-paper-quad.toml"
DOC = ROOT / "docs" / "flightcode.md"
PORTS = "".join(f'[ports.{n}]\npath = "/dev/{n}"\nbaud = 115200\n' for n in ("imu", "adc", "rc", "esc", "telemetry"))


def _keys(cls: type, prefix: str = "") -> list[str]:
    """Every dotted leaf key of a config dataclass."""
    out = []
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        tp = hints[f.name]
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        inner = args[0] if args and dataclasses.is_dataclass(args[0]) else tp
        if dataclasses.is_dataclass(inner):
            out += _keys(inner, f"{prefix}{f.name}.")  # type: ignore[arg-type]
        else:
            out.append(prefix + f.name)
    return out


def test_example_loads_and_states_the_defaults() -> None:
    cfg = load(EXAMPLE)
    assert cfg.ports.imu.baud == 921600 and cfg.ports.telemetry is not None
    # The example writes every default out: it must agree with the code.
    assert dataclasses.replace(cfg, ports=parse(PORTS).ports) == parse(PORTS)


def test_minimal_config_is_the_paper_vehicle() -> None:
    cfg = parse(PORTS)
    assert cfg.T_s == 0.0025 and cfg.vehicle.m_kg == 1.1 and cfg.attitude.law == "generalised"


def test_every_key_is_documented_and_in_the_example() -> None:
    doc = DOC.read_text()
    example = tomllib.loads(EXAMPLE.read_text())
    for key in _keys(FlightConfig):
        leaf = key.rsplit(".", 1)[-1]
        assert f"`{leaf}`" in doc, f"{key} is not documented in docs/flightcode.md"
        node = example
        for part in key.split("."):
            assert part in node, f"{key} is missing from {EXAMPLE.name}"
            node = node[part]


@pytest.mark.parametrize(
    ("text", "key", "reason"),
    [
        ("", "ports", "missing"),
        (PORTS.replace('path = "/dev/imu"\n', ""), "ports.imu.path", "missing"),
        (PORTS + "[imu]\nrate = 400\n", "imu.rate", "unknown key"),
        (PORTS + "[wings]\nspan_m = 1\n", "wings", "unknown key"),
        (PORTS + "[rc.capture]\nlock = 3\n", "rc.capture.lock", "unknown key"),
        (PORTS + "[rc]\nmax_angle_deg = '30'\n", "rc.max_angle_deg", "must be a number"),
        (PORTS + "[imu]\nrate_hz = 400.0\n", "imu.rate_hz", "must be an integer"),
        (PORTS + "[imu]\nrate_hz = true\n", "imu.rate_hz", "must be an integer"),
        (PORTS + "[telemetry]\nenable = 1\n", "telemetry.enable", "true or false"),
        (PORTS + "[telemetry]\nap_mode = 3\n", "telemetry.ap_mode", "must be one of 1, 2"),
        (PORTS + "[attitude]\nlaw = 'fast'\n", "attitude.law", "must be one of 'generalised', 'paper_literal'"),
        (PORTS + "[adc]\naccel_channels = [1, 2]\n", "adc.accel_channels", "exactly 3"),
        (PORTS + "[adc]\naccel_channels = [1, 1, 2]\n", "adc.accel_channels", "four different"),
        (PORTS + "[adc]\nspi_speed_hz = 3000000\n", "adc.spi_speed_hz", "must be one of"),
        (PORTS + "[adc.accel]\nmount_B = ['+X', '+X', '+Z']\n", "adc.accel.mount_B", "once"),
        (PORTS + "[vehicle]\nm_kg = -1.0\n", "vehicle.m_kg", "must be > 0"),
        (PORTS + "[vehicle]\nF_max_N = 5.0\n", "vehicle.F_max_N", "cannot lift"),
        (PORTS + "[imu]\nrate_hz = 300\n", "imu.rate_hz", "divisors of 400"),
        (PORTS + "[esc]\nidle_us = 900.0\n", "esc.idle_us", "min_us <= idle_us"),
        (PORTS + "[rc.capture]\npulse_max_us = 3000\n", "rc.capture.sync_min_us", "pulse_max_us < sync_min_us"),
        (PORTS.replace("[ports.telemetry]", "[ports.x]"), "ports.x", "unknown key"),
        (PORTS.split("[ports.telemetry]")[0], "ports.telemetry", "telemetry.enable is true"),
        (PORTS + "[ports.imu.extra]\n", "ports.imu.extra", "unknown key"),
        ("imu = 3\n" + PORTS, "imu", "must be a table"),
        (PORTS + "[failsafe]\nimu_timeout_s = 0.001\n", "failsafe.imu_timeout_s", "longer than one sample"),
        (PORTS + "[plausibility]\nbaro_flat_readings = 1\n", "plausibility.baro_flat_readings", "0 (off) or >= 2"),
        (PORTS + "[plausibility]\nbaro_flat_std_Pa = 0.0\n", "plausibility.baro_flat_std_Pa", "must be > 0"),
        (PORTS + "[plausibility]\nbaro_motion_window_s = 0.3\n", "plausibility.baro_motion_window_s",
         "at least two blocks"),
        (PORTS + "[plausibility]\nbaro_motion_max_m = -1.0\n", "plausibility.baro_motion_max_m", "must be > 0"),
    ],
)
def test_errors_name_file_key_and_reason(tmp_path: Path, text: str, key: str, reason: str) -> None:
    path = tmp_path / "vehicle.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load(path)
    assert err.value.key == key
    assert reason in err.value.reason
    assert str(err.value).startswith(f"{path}: {key}: ")


def test_telemetry_port_optional_when_disabled() -> None:
    cfg = parse(PORTS.split("[ports.telemetry]")[0] + "[telemetry]\nenable = false\n")
    assert cfg.ports.telemetry is None


def test_bad_toml_and_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "broken.toml"
    path.write_text("[ports\n")
    with pytest.raises(ConfigError, match="broken.toml: not valid TOML"):
        load(path)
    with pytest.raises(ConfigError, match="nothere.toml: cannot read"):
        load(tmp_path / "nothere.toml")


def test_the_same_tables_validate_with_pydantic() -> None:
    # The bench validates rig tables into these dataclasses with pydantic (extra="forbid").
    data = tomllib.loads(EXAMPLE.read_text())
    assert pydantic.TypeAdapter(FlightConfig).validate_python(data) == load(EXAMPLE)
    data["kf"]["q_x"] = 1.0
    with pytest.raises(pydantic.ValidationError):
        pydantic.TypeAdapter(FlightConfig).validate_python(data)
