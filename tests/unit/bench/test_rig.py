"""Rig and scenario files: the default ones load; bad input names file, key and reason."""

from __future__ import annotations

from pathlib import Path

import pytest

from hil.config import SCENARIOS_DIR, ConfigError
from hil.config.rig import load_rig
from hil.config.scenario import load_scenario
from hil.flight.scenario_runner import ScenarioRunner

ROOT = Path(__file__).resolve().parents[3]


def _rig(tmp_path: Path, extra: str) -> Path:
    text = (ROOT / "rigs" / "paper-quad.toml").read_text().replace(
        'config = "flightcode-paper-quad.toml"', f'config = "{ROOT / "rigs" / "flightcode-paper-quad.toml"}"'
    )
    path = tmp_path / "rig.toml"
    path.write_text(text + "\n" + extra)
    return path


def test_default_rig_loads_with_its_values() -> None:
    rig = load_rig(None)
    assert rig.name == "paper-quad" and rig.tick_ns == 2_500_000
    assert rig.plant.body.mass_kg == 1.1
    assert rig.imu.baud_bps == 921600
    assert rig.analog.conditioning[0].gain == 16.0
    assert rig.device_baud("imu") == 921600 and rig.device_baud("adc") == 115200


@pytest.mark.parametrize("scenario", sorted(p.stem for p in SCENARIOS_DIR.glob("*.toml")))
def test_every_shipped_scenario_loads_and_its_faults_fit_the_rig(scenario: str) -> None:
    rig = load_rig(None)
    path = rig.scenario_path(scenario)
    sc = load_scenario(path)
    runner = ScenarioRunner(sc, rig, path)  # checks the faults against the rig
    assert sc.criteria, f"{scenario} has no criteria"
    assert runner.faults is not None


def test_unknown_key_names_file_table_and_key(tmp_path: Path) -> None:
    path = _rig(tmp_path, "[imu.extra]\nfoo = 1\n")
    with pytest.raises(ConfigError) as err:
        load_rig(path)
    assert str(path) in str(err.value) and "[imu] extra" in str(err.value)


def test_wrong_type_names_the_key_and_the_value(tmp_path: Path) -> None:
    text = _rig(tmp_path, "").read_text().replace("baud_bps = 921600", 'baud_bps = "fast"')
    path = tmp_path / "rig2.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_rig(path)
    msg = str(err.value)
    assert "[imu] baud_bps" in msg and "'fast'" in msg


@pytest.mark.parametrize("key", ["truth_divider", "pose_divider", "counters_divider"])
def test_a_record_divider_below_one_names_the_key(tmp_path: Path, key: str) -> None:
    """A divider of 0 would divide by zero at the first tick: refused at load instead."""
    text = _rig(tmp_path, "").read_text()
    start = text.index(f"\n{key} = ") + 1
    end = text.index("#", start)
    path = tmp_path / "rig2.toml"
    path.write_text(text[:start] + f"{key} = 0 " + text[end:])
    with pytest.raises(ConfigError) as err:
        load_rig(path)
    assert str(path) in str(err.value) and f"[record] {key}" in str(err.value)


def test_unknown_table(tmp_path: Path) -> None:
    path = _rig(tmp_path, "[motors]\nn = 4\n")
    with pytest.raises(ConfigError, match=r"top level\] motors: unknown key"):
        load_rig(path)


def test_scenario_errors_name_the_entry(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('[scenario]\nname = "x"\nduration_s = 5\n[[sticks]]\nt_s = 1\nchannel = 3\n')
    with pytest.raises(ConfigError) as err:
        load_scenario(bad)
    assert str(bad) in str(err.value) and "sticks.0" in str(err.value) and "exactly one of" in str(err.value)


def test_a_fault_the_rig_cannot_apply_is_refused_at_load(tmp_path: Path) -> None:
    bad = tmp_path / "bad-fault.toml"
    bad.write_text(
        '[scenario]\nname = "x"\nduration_s = 5\n'
        '[[faults]]\nkind = "wire.silence"\nt_s = 1\nport = "gps"\n'
        '[[criteria]]\nname = "c"\nsignal = "truth.h_m"\nmetric = "max"\nmax = 1\n'
    )
    rig = load_rig(None)
    with pytest.raises(ConfigError) as err:
        ScenarioRunner(load_scenario(bad), rig, bad)
    assert str(bad) in str(err.value) and "#0" in str(err.value) and "port" in str(err.value)


def test_a_gesture_too_short_for_the_flight_code_is_refused(tmp_path: Path) -> None:
    bad = tmp_path / "short-arm.toml"
    bad.write_text('[scenario]\nname = "x"\nduration_s = 5\n[[sticks]]\nt_s = 1\naction = "arm"\nduration_s = 0.5\n')
    with pytest.raises(ConfigError, match=r"sticks\.0.*longer than the 1 s"):
        load_scenario(bad)


@pytest.mark.parametrize(("table", "old", "new", "key"), [
    ("realtime", 'policy = "auto"', 'policy = "always"', "policy"),
    ("realtime", "priority = 50", "priority = 99", "priority"),
    ("realtime", "priority = 50", "priority = 0", "priority"),
    ("host", 'cpu_latency = "auto"', 'cpu_latency = "poll"', "cpu_latency"),
    ("host", "cpu_latency_us = 0", "cpu_latency_us = -1", "cpu_latency_us"),
    ("host", "cpu_latency_us = 0", "cpu_latency_us = 2_000_000_001", "cpu_latency_us"),
])
def test_a_bad_host_facing_table_names_the_key(tmp_path: Path, table: str, old: str, new: str, key: str) -> None:
    text = _rig(tmp_path, "").read_text()
    assert text.count(f"\n{old} ") == 1
    path = tmp_path / "rig2.toml"
    path.write_text(text.replace(f"\n{old} ", f"\n{new} "))
    with pytest.raises(ConfigError) as err:
        load_rig(path)
    assert str(path) in str(err.value) and f"[{table}] {key}" in str(err.value)


def test_the_realtime_table_is_read() -> None:
    rig = load_rig(None)
    assert (rig.realtime.policy, rig.realtime.priority) == ("auto", 50)


def test_the_host_table_is_read() -> None:
    rig = load_rig(None)
    assert (rig.host.cpu_latency, rig.host.cpu_latency_us) == ("auto", 0)


@pytest.mark.parametrize(("value", "reason"), [("0", "greater than 0"), ("-1.5", "greater than 0"),
                                               ("601", "less than or equal to 600"), ('"3 s"', "")])
def test_a_bad_stop_grace_names_the_file_and_the_key(tmp_path: Path, value: str, reason: str) -> None:
    text = _rig(tmp_path, "").read_text().replace("barrier_timeout_s = 0.5", f"barrier_timeout_s = 0.5\nstop_grace_s = {value}")
    path = tmp_path / "rig2.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_rig(path)
    assert str(path) in str(err.value) and "[flight] stop_grace_s" in str(err.value) and reason in str(err.value)


def test_the_stop_grace_is_read_and_defaults_to_a_few_seconds(tmp_path: Path) -> None:
    assert load_rig(None).flight.stop_grace_s == 3.0
    text = _rig(tmp_path, "").read_text().replace("barrier_timeout_s = 0.5", "barrier_timeout_s = 0.5\nstop_grace_s = 0.25")
    path = tmp_path / "rig2.toml"
    path.write_text(text)
    assert load_rig(path).flight.stop_grace_s == 0.25
