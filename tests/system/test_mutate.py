"""``hil mutate`` end to end on one short scenario: the unmodified flight code flies first, a
driver defect is killed with the criterion named, a telemetry defect survives with its diff;
the JSON and the kill matrix say so, and no temporary copy is left behind."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
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


def _processes_mentioning(text: str) -> list[str]:
    """Command lines of live processes that mention ``text`` (from /proc)."""
    found = []
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            args = cmdline.read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:  # gone meanwhile
            continue
        if text in args:
            found.append(args)
    return found


@pytest.mark.timeout(300)
def test_sigterm_stops_mutate_like_ctrl_c_and_leaves_nothing_behind(tmp_path: Path) -> None:
    """SIGTERM (a CI runner cancelling the job) while a flight is under way on the default Dask
    executor: exit 130 "interrupted", no copy of the tree left, no flight left running. Before
    SIGTERM was taken as Ctrl-C, the client died at once, the running case flew on as an
    orphan and its copy stayed in the temporary directory."""
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    hil = Path(sys.executable).with_name("hil")
    cmd = [str(hil), "mutate", "-s", str(ROOT / "rigs" / "scenarios" / "hover.toml"), "--only", "tel-time-units",
           "--seeds", "1", "--workers", "1", "--min-score", "0", "--keep-kills", "--out", str(tmp_path / "out")]
    proc = subprocess.Popen(cmd, cwd=ROOT, env={**os.environ, "TMPDIR": str(scratch)}, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        flying = threading.Event()
        for _ in range(2400):  # bounded poll of the file system (up to 120 s): a log being written
            if list(scratch.glob(TMP_PREFIX + "*/logs/*.mcap.part")) or proc.poll() is not None:
                break
            flying.wait(0.05)
        assert proc.poll() is None, proc.communicate()[0]
        proc.send_signal(signal.SIGTERM)
        text, _ = proc.communicate(timeout=180)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130, text
    assert "interrupted" in text
    assert not list(scratch.glob(TMP_PREFIX + "*")), text
    assert not _processes_mentioning(str(scratch)), text
