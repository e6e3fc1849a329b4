"""The rig's ``[flight.overrides]`` are merged over the flight code's config template, and a
scenario's ``[flight]`` over both."""

from __future__ import annotations

import tomllib
from pathlib import Path

from hil.config.rig import load_rig
from hil.flight.run_files import write_flight_config
from hil.config.scenario import Scenario


class _Port:
    def __init__(self, name: str) -> None:
        self.path = f"/dev/fake-{name}"
        self.client_path = self.path  # what the flight code opens (hil.transport.base.Port)


def _write(tmp_path: Path, flight: dict) -> dict:
    rig = load_rig(None)
    scenario = Scenario.model_validate({"scenario": {"name": "t", "duration_s": 1.0}, "flight": flight})
    ports = {n: _Port(n) for n in ("imu", "adc", "rc", "esc", "telemetry")}
    path = write_flight_config(rig, scenario, ports, tmp_path)  # type: ignore[arg-type]
    return tomllib.loads(Path(path).read_text())


def test_rig_overrides_reach_the_flight_code(tmp_path: Path) -> None:
    rig = load_rig(None)
    assert rig.flight.overrides["attitude"]["k0_per_s"] == 4.0
    cfg = _write(tmp_path, {})
    assert cfg["attitude"]["omega1_radps"] == 5.0 and cfg["attitude"]["k0_per_s"] == 4.0
    assert cfg["attitude"]["tau_ff_s"] == 0.005
    assert cfg["attitude"]["omega2_radps"] == 15.0  # untouched keys stay the template's


def test_scenario_flight_wins_over_the_rig(tmp_path: Path) -> None:
    cfg = _write(tmp_path, {"attitude": {"tau_ff_s": 0.02}})
    assert cfg["attitude"]["tau_ff_s"] == 0.02 and cfg["attitude"]["k0_per_s"] == 4.0
