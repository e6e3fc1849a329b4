"""The firmware reads the Python flight code's config format with its errors: for each bad
config, `fc --check-config` names the same dotted key with the same reason as
`python -m flightcode --check-config` (exit 2, one JSON line), and a design input that differs
from the build's generated gains is refused, naming the key."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.unit.firmware.fwbuild import ROOT, host_binary

BASE = (ROOT / "rigs" / "firmware-paper-quad.toml").read_text()


@pytest.fixture(scope="module")
def fc() -> Path:
    return host_binary()


def check(cmd: list[str], path: Path) -> tuple[int, dict]:
    proc = subprocess.run([*cmd, "--config", str(path), "--check-config"], capture_output=True, text=True,
                          timeout=60, cwd=ROOT)
    return proc.returncode, json.loads(proc.stdout.strip().splitlines()[-1])


def edited(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "vehicle.toml"
    path.write_text(text)
    return path


def test_shipped_config_is_valid(fc: Path, tmp_path: Path) -> None:
    assert check([str(fc)], ROOT / "rigs" / "firmware-paper-quad.toml") == (0, {"flightcode_check": 1, "ok": True})


CASES = {
    "unknown key": BASE + "\n[esc.spin]\nx = 1\n",
    "unknown table": BASE + "\n[gimbal]\npan = 1\n",
    "enum": BASE.replace('law = "generalised"', 'law = "fast"'),
    "number as string": BASE.replace("max_angle_deg = 30.0", 'max_angle_deg = "30"'),
    "integer as float": BASE.replace("rate_hz = 400", "rate_hz = 400.0"),
    "bool as int": BASE.replace("enable = true", "enable = 1"),
    "not finite": BASE.replace("center_us = 1500.0", "center_us = inf"),
    "negative": BASE.replace("k0_per_s = 4.0", "k0_per_s = -1.0"),
    "zero": BASE.replace("descend_mps = 0.5", "descend_mps = 0.0"),
    "array length": BASE.replace("accel_channels = [1, 2, 3]", "accel_channels = [1, 2]"),
    "array element": BASE.replace("accel_channels = [1, 2, 3]", 'accel_channels = [1, 2, "3"]'),
    "channels clash": BASE.replace("baro_channel = 0", "baro_channel = 1"),
    "rc channels": BASE.replace("channel_yaw = 4", "channel_yaw = 3"),
    "spi speed": BASE.replace("spi_speed_hz = 1000000", "spi_speed_hz = 3_000_000"),
    "esc order": BASE.replace("idle_us = 1100.0", "idle_us = 900.0"),
    "ratio": BASE.replace("landed_collective_ratio = 0.7", "landed_collective_ratio = 1.5"),
    "flat window": BASE.replace("baro_flat_readings = 40", "baro_flat_readings = 1"),
    "motion window": BASE.replace("baro_motion_window_s = 1.5", "baro_motion_window_s = 0.3"),
    "ports missing": BASE[:BASE.index("[ports.imu]")] + BASE[BASE.index("[ports.adc]"):],
    "telemetry port": BASE[:BASE.index("[ports.telemetry]")] + BASE[BASE.index("# -- IMU"):],
    "mk4 rate": BASE.replace("rate_hz = 400", "rate_hz = 300"),
    "not toml": BASE + "\n[broken\n",
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_errors_name_the_same_key_and_reason_as_flightcode(fc: Path, tmp_path: Path, case: str) -> None:
    assert CASES[case] != BASE, "the edit must change the file"
    path = edited(tmp_path, CASES[case])
    rc_py, py = check([sys.executable, "-m", "flightcode"], path)
    rc_c, c = check([str(fc)], path)
    assert rc_py == rc_c == 2
    assert c["ok"] is False and c["file"] == str(path)
    assert c["key"] == py["key"]
    if case == "not toml":  # each parser words its own syntax errors; both say where
        assert c["reason"].startswith("not valid TOML: line ")
    else:
        assert c["reason"] == py["reason"]


def test_a_design_input_of_another_value_is_refused(fc: Path, tmp_path: Path) -> None:
    """The LQI gains were generated for q_int = 0.04: a config asking for 0.05 is not this
    build's controller, so the firmware refuses it (Python would design anew at start-up)."""
    path = edited(tmp_path, BASE.replace("q_int = 0.04", "q_int = 0.05"))
    rc, c = check([str(fc)], path)
    assert rc == 2 and c["key"] == "altitude.q_int"
    assert "design input" in c["reason"] and "FLIGHT_CONFIG" in c["reason"]
    rc_py, _ = check([sys.executable, "-m", "flightcode"], path)
    assert rc_py == 0
