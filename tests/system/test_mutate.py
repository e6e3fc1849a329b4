"""``hil mutate`` end to end on one short scenario: the unmodified flight code flies first, a
driver defect is killed with the criterion named, a telemetry defect survives with its diff;
the JSON and the kill matrix say so, and no temporary copy is left behind."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import pytest
from rich.console import Console

from hil.fleet.mutation import cli_run
from hil.fleet.mutation.worker import TMP_PREFIX

pytestmark = pytest.mark.system
ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.timeout(600)
def test_mutate_kills_one_and_reports_a_survivor(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # a temporary directory of this run's own (the worker processes inherit TMPDIR), so that
    # another hil mutate on the machine cannot add or remove copies under the check's eyes
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setenv("TMPDIR", str(scratch))
    monkeypatch.setattr(tempfile, "tempdir", None)  # gettempdir() reads TMPDIR again
    out = tmp_path / "out"
    opts = {"rig": ROOT / "rigs" / "paper-quad.toml", "scenarios": [ROOT / "rigs" / "scenarios" / "fault-imu-silence.toml"],
            "exclude": None, "catalogue": ROOT / "rigs" / "mutation" / "flightcode.toml", "equivalents": None,
            "tree": ROOT / "flightcode", "only": ["drv-mtdata-gyro-y-sign", "tel-time-units"], "no_catalogue": False,
            "operators": 0, "operator_seed": 1, "seeds": 1, "matrix": False, "keep_kills": True, "min_score": 0.5, "min_operator_score": 0.8,
            "workers": 2, "scheduler": None, "executor": "process", "mode": "lockstep", "out": out}
    con = Console(record=True, width=200)
    code = cli_run.run(opts, con)
    text = con.export_text()
    assert code == 0, text  # 1 killed of 2 = 0.5 >= --min-score 0.5
    (cdir,) = out.iterdir()
    report = json.loads((cdir / "report.json").read_text())
    m = {x["id"]: x for x in report["mutants"]}
    assert m["drv-mtdata-gyro-y-sign"]["status"] == "killed", text
    assert m["drv-mtdata-gyro-y-sign"]["kills"] == {"fault-imu-silence": ["flying before the fault"]}
    assert m["tel-time-units"]["status"] == "survived"
    assert "+        (rec.t_ns // 1_000_000) & 0xFFFFFFFF," in m["tel-time-units"]["diff"]
    assert report["score"]["score"] == 0.5 and report["meta"]["baseline_flights"] == 1
    assert (cdir / "kills" / "drv-mtdata-gyro-y-sign-fault-imu-silence-s1.mcap").stat().st_size > 0
    assert (cdir / "heatmap.png").stat().st_size > 0
    assert "fault-imu-silence: flying before the fault" in text and "survivor tel-time-units" in text
    assert tempfile.gettempdir() == str(scratch)
    assert not list(scratch.glob(TMP_PREFIX + "*"))
    assert b"1_000_000" not in (ROOT / "flightcode" / "telemetry.py").read_bytes()
