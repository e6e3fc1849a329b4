"""``hil falsify`` end to end: a range that holds a known failure (a payload past what the
vehicle can lift) is found within a small budget, and the scenario it writes reproduces the
failure with ``hil run``, to the same margin; a range the flight code survives ends with 0."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from hil.record import iter_messages

pytestmark = [pytest.mark.system, pytest.mark.pty]
ROOT = Path(__file__).resolve().parents[2]


def _scenario(tmp_path: Path, base: str, vary: str) -> Path:
    path = tmp_path / f"{base}-search.toml"
    path.write_text((ROOT / "rigs" / "scenarios" / f"{base}.toml").read_text().split("\n# What `hil falsify` may vary")[0] + vary)
    return path


def _hil(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "hil.cli", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=900)


def _search(scenario: Path, tmp_path: Path) -> tuple[subprocess.CompletedProcess[str], Path]:
    """``hil falsify`` on 8 flights, 2 workers; its result and output directory."""
    run = _hil("falsify", str(scenario), "--flights", "8", "--workers", "2", "--executor", "process",
               "--out", str(tmp_path / "out"))
    (directory,) = (tmp_path / "out").iterdir()
    return run, directory


def _verdict(log: Path) -> dict[str, dict[str, object]]:
    ((_, _, verdict),) = list(iter_messages(log, ["/hil/verdict"]))
    return {c["name"]: c for c in verdict["criteria"]}


def test_a_payload_past_what_it_lifts_is_found_and_its_scenario_reproduces_it(tmp_path: Path) -> None:
    scenario = _scenario(tmp_path, "fault-payload", '''
[[falsify.vary]]
key = "faults.0.extra_mass_kg"
range = [0.1, 1.5]
''')
    run, directory = _search(scenario, tmp_path)
    assert run.returncode == 1, run.stdout + run.stderr
    summary = json.loads((directory / "search.json").read_text())
    cx = summary["counterexample"]
    assert summary["stopped"] == "counterexample" and cx["lowest_scaled_margin"] < 0, summary
    assert cx["values"]["faults.0.extra_mass_kg"] > 0.5  # a payload the vehicle cannot recover from
    rows = list(csv.DictReader((directory / "margins.csv").open()))
    assert len(rows) == summary["flights"] >= 8 and (directory / "progress.png").stat().st_size > 10_000
    assert any(float(r["lowest_scaled_margin"]) >= 0 for r in rows)  # light payloads passed on the way
    found = _verdict(Path(cx["log"]))[cx["criterion"]]
    assert not found["passed"]

    again = _hil("run", "rigs/paper-quad.toml", "-s", str(directory / "counterexample.toml"), "--out",
                 str(tmp_path / "again"), "-q")
    assert again.returncode == 1, again.stdout + again.stderr
    (log,) = (tmp_path / "again").glob("*.mcap")
    assert _verdict(log)[cx["criterion"]] == found  # the same flight: the same value and margin


def test_a_range_the_flight_code_survives_ends_with_0_and_the_closest_margin(tmp_path: Path) -> None:
    scenario = _scenario(tmp_path, "fault-imu-silence", '''
[[falsify.vary]]
key = "faults.0.duration_s"
range = [0.15, 0.3]
''')
    run, directory = _search(scenario, tmp_path)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "no flight failed; closest: flight" in run.stdout, run.stdout
    summary = json.loads((directory / "search.json").read_text())
    assert summary["counterexample"] is None and summary["best"]["lowest_scaled_margin"] >= 0
    assert not (directory / "counterexample.toml").exists()
