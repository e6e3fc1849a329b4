"""Campaign files: validation with file/key errors, seeds, sweeps, the case list."""

from __future__ import annotations

from pathlib import Path

import pytest

from hil.fleet.campaign_file import KeepLogs, load_campaign
from hil.config import ConfigError

ROOT = Path(__file__).resolve().parents[3]
DATA = Path(__file__).with_name("data")


def _write(tmp_path: Path, text: str) -> Path:
    (tmp_path / "hover-2s.toml").write_bytes((DATA / "hover-2s.toml").read_bytes())
    path = tmp_path / "c.toml"
    path.write_text(text)
    return path


BASE = '[campaign]\nname = "t"\nscenarios = ["hover-2s.toml"]\n'


def test_the_example_campaign_loads() -> None:
    c = load_campaign(ROOT / "rigs" / "campaigns" / "hover-gains.toml")
    assert c.seeds == (1, 2, 3)
    assert c.flight_sweep == (("attitude.tau_ff_s", (0.005, 0.020)),)
    assert [s for s, _ in c.scenarios] == ["hover"]
    assert len(c.cases(Path("/nonexistent"))) == 6


def test_the_board_suite_flies_every_scenario_a_board_takes_on_seeds_1_to_3() -> None:
    c = load_campaign(ROOT / "rigs" / "campaigns" / "board-suite.toml")
    shipped = {p.stem for p in (ROOT / "rigs" / "scenarios").glob("*.toml")}
    # left out: the paper's literal weights (not a verdict), and a fault on a link a board lacks
    assert {s for s, _ in c.scenarios} == shipped - {"paper-literal-weights", "fault-rc-bit-errors"}
    assert c.seeds == (1, 2, 3) and c.rig_path.name == "paper-quad-lpc2148.toml"


def test_cases_are_scenarios_x_sweep_points_x_seeds(tmp_path: Path) -> None:
    path = _write(tmp_path, '[campaign]\nname = "t"\nscenarios = ["hover-2s.toml", "altitude-step"]\n'
                            'seeds = {from = 5, count = 3}\nduration_s = 1.5\nkeep_logs = "none"\n'
                            '[sweep.flight]\n"attitude.tau_ff_s" = [0.02, 0.03]\n'
                            '[sweep.rig.plant.body]\nmass_kg = [1.1, 1.4]\n')
    c = load_campaign(path)
    assert c.seeds == (5, 6, 7)
    assert c.rig_sweep == (("plant.body.mass_kg", (1.1, 1.4)),)
    cases = c.cases(tmp_path / "run")
    assert len(cases) == 2 * 2 * 2 * 3
    assert [x["case_id"] for x in cases[:2]] == ["0000", "0001"]
    first = cases[0]
    assert (first["scenario_name"], first["seed"], first["duration_s"], first["keep_logs"]) == ("hover-2s", 5, 1.5, "none")
    assert first["flight_overrides"] == {"attitude.tau_ff_s": 0.02}
    assert first["rig_overrides"] == {"plant.body.mass_kg": 1.1}
    assert first["log_name"] == "0000_hover-2s_s5.mcap"
    points = {(x["scenario_name"], x["flight_overrides"]["attitude.tau_ff_s"], x["rig_overrides"]["plant.body.mass_kg"],
               x["seed"]) for x in cases}
    assert len(points) == len(cases)
    assert c.cases(tmp_path, keep_logs=KeepLogs.ALL)[0]["keep_logs"] == "all"


@pytest.mark.parametrize(("text", "where"), [
    (BASE + "bogus = 1\n", "campaign.bogus"),
    (BASE + "[extra]\nx = 1\n", "extra"),
    (BASE + "seeds = {from = 1, count = 2, step = 3}\n", "campaign.seeds"),
    (BASE + "seeds = [1, -2]\n", "campaign.seeds"),
    (BASE + "seeds = [1, 1]\n", "[campaign] seeds: a seed appears twice"),
    (BASE + 'keep_logs = "some"\n', "campaign.keep_logs"),
    (BASE + 'mode = "fast"\n', "campaign.mode"),
    (BASE + "workers = 0\n", "campaign.workers"),
    ('[campaign]\nname = "t"\n', "campaign.scenarios"),
    ('[campaign]\nname = "t"\nscenarios = ["no-such-scenario"]\n', "[campaign] scenarios: no-such-scenario"),
    (BASE + 'rig = "no-such-rig"\n', "[campaign] rig: no-such-rig"),
    (BASE + "[sweep]\nplant = {}\n", "sweep.plant"),
    (BASE + '[sweep.flight]\n"attitude.tau_ff_s" = 0.02\n', "[sweep.flight] attitude.tau_ff_s: a sweep is a non-empty list"),
    (BASE + '[sweep.flight]\n"attitude.no_such_gain" = [1.0]\n', "[sweep.flight] attitude.no_such_gain: not a key"),
    (BASE + '[sweep.flight]\n"attitude.tau_ff_s" = ["fast"]\n', "[sweep.flight] attitude.tau_ff_s: 'fast' is not"),
    (BASE + '[sweep.flight]\n"attitude" = [1.0]\n', "[sweep.flight] attitude: 1.0 is not"),
    (BASE + '[sweep.rig]\n"plant.body.mass_lb" = [2.0]\n', "[sweep.rig] plant.body.mass_lb = 2.0: "),
    (BASE + '[sweep.rig]\n"plant.body.mass_kg" = ["heavy"]\n', "[sweep.rig] plant.body.mass_kg = 'heavy': "),
])
def test_errors_name_the_file_and_the_key(tmp_path: Path, text: str, where: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError) as err:
        load_campaign(path)
    message = str(err.value)
    assert str(path) in message and where in message, message


def test_a_rig_override_error_gives_the_component_reason(tmp_path: Path) -> None:
    path = _write(tmp_path, BASE + '[sweep.rig]\n"plant.body.mass_lb" = [2.0]\n')
    with pytest.raises(ConfigError, match=r"\[sweep\.rig\] plant\.body\.mass_lb = 2\.0: \[plant\] body\.mass_lb: Unexpected keyword"):
        load_campaign(path)
