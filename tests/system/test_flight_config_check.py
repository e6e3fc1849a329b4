"""``[flight]`` overrides are checked by the flight code itself (``--check-config``) before a
run starts: a typo gives ``hil run`` exit 2 naming the file and the key, and nothing starts."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hil.cli import app
from hil.config.rig import load_rig
from hil.flight.flight_check import check_command

pytestmark = [pytest.mark.system]
ROOT = Path(__file__).resolve().parents[2]


def _rig(tmp_path: Path, rig_extra: str = "", scenario_extra: str = "") -> Path:
    text = (ROOT / "rigs" / "paper-quad.toml").read_text().replace(
        'config = "flightcode-paper-quad.toml"', f'config = "{ROOT / "rigs" / "flightcode-paper-quad.toml"}"')
    rig = tmp_path / "rig.toml"
    rig.write_text(text + rig_extra)
    (tmp_path / "scenarios").mkdir()
    (tmp_path / "scenarios" / "hover.toml").write_text((ROOT / "rigs" / "scenarios" / "hover.toml").read_text()
                                                      + scenario_extra)
    return rig


def _run(tmp_path: Path, rig: Path) -> tuple[int, str]:
    res = CliRunner().invoke(app, ["run", str(rig), "-s", "hover", "--duration", "0.2", "-q",
                                   "--out", str(tmp_path / "logs")], env={"COLUMNS": "400"})
    return res.exit_code, res.output


def test_a_scenario_typo_exits_2_naming_the_scenario_and_key(tmp_path: Path) -> None:
    rig = _rig(tmp_path, scenario_extra="\n[flight.attitude]\nkp_typo = 1.0\n")
    code, out = _run(tmp_path, rig)
    assert code == 2, out
    assert f"{tmp_path / 'scenarios' / 'hover.toml'}: [flight] attitude.kp_typo: unknown key" in out
    assert not (tmp_path / "logs").exists()  # nothing started


def test_a_rig_override_typo_exits_2_naming_the_rig_and_key(tmp_path: Path) -> None:
    rig = _rig(tmp_path, rig_extra="\n[flight.overrides.failsafe]\nimu_timeout = 0.1\n")
    code, out = _run(tmp_path, rig)
    assert code == 2, out
    assert f"{rig}: [flight.overrides] failsafe.imu_timeout: unknown key" in out


def test_a_wrong_value_exits_2_naming_the_key(tmp_path: Path) -> None:
    rig = _rig(tmp_path, scenario_extra='\n[flight.attitude]\nlaw = "fast"\n')
    code, out = _run(tmp_path, rig)
    assert code == 2, out
    assert "[flight] attitude.law: must be one of" in out and "'fast'" in out


def test_the_check_asks_only_the_stock_flight_code() -> None:
    import dataclasses

    rig = load_rig(None)
    assert check_command(rig) == (*rig.flight.command, "--check-config")
    other = dataclasses.replace(rig, flight=dataclasses.replace(rig.flight, command=("./my-autopilot", "{config}")))
    assert check_command(other) is None


@pytest.mark.parametrize(("typo", "ok"), [(False, True), (True, False)])
def test_flightcode_check_config_answers_one_json_line(tmp_path: Path, typo: bool, ok: bool) -> None:
    config = tmp_path / "fc.toml"
    text = (ROOT / "rigs" / "flightcode-paper-quad.toml").read_text()
    config.write_text(text.replace("\n[attitude]", "\n[attitude]\nkp_typo = 1\n", 1) if typo else text)
    done = subprocess.run([sys.executable, "-m", "flightcode", "--config", str(config), "--check-config"],
                          capture_output=True, text=True, cwd=ROOT, timeout=120, check=False)
    verdict = json.loads(done.stdout.strip().splitlines()[-1])
    assert verdict["ok"] is ok and done.returncode == (0 if ok else 2)
    if not ok:
        assert verdict["key"] == "attitude.kp_typo" and "unknown key" in verdict["reason"]
        assert "attitude.kp_typo" in done.stderr


def test_a_spidriver_bridge_is_refused_naming_file_and_key(tmp_path: Path) -> None:
    """The flight code has no SPIDriver driver: the rig says so instead of serving a Bus Pirate."""
    text = (ROOT / "rigs" / "paper-quad.toml").read_text().replace('bridge = "buspirate"', 'bridge = "spidriver"')
    text = text.replace('config = "flightcode-paper-quad.toml"', f'config = "{ROOT / "rigs" / "flightcode-paper-quad.toml"}"')
    assert 'bridge = "spidriver"' in text
    rig = tmp_path / "spi.toml"
    rig.write_text(text)
    (tmp_path / "scenarios").mkdir()
    (tmp_path / "scenarios" / "hover.toml").write_text((ROOT / "rigs" / "scenarios" / "hover.toml").read_text())
    code, out = _run(tmp_path, rig)
    assert code == 2, out
    assert f"{rig}: [adc] bridge: 'spidriver' is not supported" in out
    assert not (tmp_path / "logs").exists()
