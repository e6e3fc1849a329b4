"""Campaigns end to end: real lockstep cases through the process pool and through Dask, a case
whose process is SIGKILLed, a worker that dies, and Ctrl-C."""

from __future__ import annotations

import asyncio
import io
import json
import os
import signal
import math
import statistics
import threading
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console

from hil.fleet.campaign import CampaignRun, run_campaign
from hil.fleet.campaign_file import KeepLogs, load_campaign
from hil.record import read_attachments, read_metadata
from tests.unit.campaign import cases as fake

pytestmark = [pytest.mark.system, pytest.mark.pty]
DATA = Path(__file__).with_name("data")
ROOT = Path(__file__).resolve().parents[3]


def _quiet() -> Console:
    return Console(file=io.StringIO(), width=200)


def _campaign_file(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "campaign.toml"
    path.write_text(f'[campaign]\nname = "t"\nscenarios = ["{DATA / "hover-2s.toml"}"]\n{body}')
    return path


def _jsonl(run: CampaignRun) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (run.dir / "results.jsonl").read_text().splitlines()]


def _check_two_seed_run(run: CampaignRun) -> list[dict[str, Any]]:
    """What both executors must produce for data/two-seeds.toml."""
    lines = _jsonl(run)
    assert sorted(r["case_id"] for r in lines) == ["0000", "0001"]
    by_seed = {r["seed"]: r for r in lines}
    assert set(by_seed) == {1, 2}
    for r in lines:
        assert r["passed"] and r["end_reason"] == "completed", r
        assert r["scenario"] == "hover-2s" and r["returncode"] == 0
        assert r["overrides"] == {"flight.adc.read_timeout_s": 0.3}
        assert [c["name"] for c in r["criteria"]] == ["stays on the ground", "level"]
        assert all(c["passed"] and c["value"] is not None for c in r["criteria"])
        assert r["timing"]["ticks"] == 801 and r["sim_s"] == pytest.approx(2.0025)
        assert r["wall_s"] > 0
    summary = json.loads((run.dir / "summary.json").read_text())
    assert summary == json.loads(json.dumps(run.summary))
    assert (summary["cases"], summary["done"], summary["passed"], summary["failed"]) == (2, 2, 2, 0)
    assert not summary["interrupted"] and summary["cancelled"] == 0
    assert summary["flights_per_hour"] == pytest.approx(2 / summary["wall_s"] * 3600)
    scen = summary["by_scenario"]["hover-2s"]
    assert (scen["cases"], scen["passed"], scen["end_reasons"]) == (2, 2, {"completed": 2})
    assert set(scen["worst"]) == {"stays on the ground", "level"}
    assert scen["timing_median"]["rtf"] > 0
    cpu_s = [r["timing"]["cores_used"] * r["timing"]["wall_s"] for r in lines]
    assert summary["cpu_s_per_flight"] == pytest.approx(statistics.median(cpu_s)) and min(cpu_s) > 0
    assert scen["timing_median"]["cores_used"] == pytest.approx(statistics.median(r["timing"]["cores_used"] for r in lines))
    assert (run.dir / "campaign.toml").read_text() == (DATA / "two-seeds.toml").read_text()
    assert not (run.dir / "STOP").exists()
    assert not (run.dir / "cases").exists() or not any((run.dir / "cases").iterdir())  # passed: nothing left
    assert run.passed
    return lines


def test_two_cases_through_the_process_pool(tmp_path: Path) -> None:
    campaign = load_campaign(DATA / "two-seeds.toml")
    run = run_campaign(campaign, executor="process", out_dir=tmp_path, console=_quiet())
    assert run.summary["executor"] == "process pool x2"
    for r in _check_two_seed_run(run):
        log = Path(r["log"])  # keep_logs = "all"
        assert log.parent == run.dir / "logs" and log.exists()
        assert read_metadata(log)["run"]["seed"] == str(r["seed"])
        # the override reached the flight code's config through the recorded scenario
        scenario = read_attachments(log)["hover-2s.toml"][1].decode()
        assert "read_timeout_s = 0.3" in scenario


def test_two_cases_through_a_dask_local_cluster(tmp_path: Path) -> None:
    pytest.importorskip("distributed")
    campaign = load_campaign(DATA / "two-seeds.toml")
    run = run_campaign(campaign, executor="dask", out_dir=tmp_path, keep_logs=KeepLogs.NONE, console=_quiet())
    assert run.summary["executor"] == "dask LocalCluster x2 (TLS)"
    for r in _check_two_seed_run(run):
        assert r["log"] is None
    assert not list((run.dir / "logs").glob("*.mcap*"))


def test_a_case_whose_process_is_killed_is_a_failure_not_a_crashed_campaign(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = _campaign_file(tmp_path, f'rig = "{DATA / "killer-rig.toml"}"\nseeds = [1, 2]\nworkers = 1\n')
    worker_tmp = tmp_path / "worker-tmp"
    worker_tmp.mkdir()
    monkeypatch.setenv("TMPDIR", str(worker_tmp))
    run = run_campaign(load_campaign(path), executor="process", out_dir=tmp_path, console=_quiet())
    lines = _jsonl(run)
    assert len(lines) == 2
    for r in lines:
        assert not r["passed"] and r["end_reason"] == "case crashed", r
        assert r["returncode"] == -signal.SIGKILL and "signal 9" in r["message"]
        assert r["log"].endswith(".mcap.part")  # the bench never finalized it; hil recover can
        assert (Path(r["case_dir"]) / "output.txt").exists()
    assert (run.summary["failed"], run.summary["passed"], run.summary["interrupted"]) == (2, 0, False)
    assert sorted(run.summary["failed_cases"]) == ["0000", "0001"]
    assert not run.passed
    # the killed bench could not remove its run directory: it went with the case's directory
    assert list(worker_tmp.iterdir()) == []


@pytest.mark.parametrize(("keep", "record"), [("all", True), ("failed", True), ("none", False)])
def test_keep_logs_none_flies_unrecorded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, keep: str,
                                         record: bool) -> None:
    """A log that would be deleted whatever the verdict is not written at all."""
    import hil.flight.run
    from hil.fleet import campaign_case
    from hil.flight.tickloop import EndReason
    from hil.flight.run_result import RunResult

    asked: dict[str, Any] = {}

    async def fake_flight(rig, scenario, **kwargs):  # noqa: ANN001, ANN202
        asked.update(kwargs)
        return RunResult(None, EndReason.COMPLETED, [], 0, [], {}, {})

    monkeypatch.setattr(hil.flight.run, "run_flight_async", fake_flight)
    params = {"case_id": "0000", "rig": str(ROOT / "rigs" / "paper-quad.toml"), "scenario": str(DATA / "hover-2s.toml"),
              "seed": 1, "mode": "lockstep", "duration_s": None, "flight_overrides": {}, "rig_overrides": {},
              "case_dir": str(tmp_path), "log_path": str(tmp_path / "x.mcap"), "keep_logs": keep}
    result = asyncio.run(campaign_case._fly(params))
    assert asked["record"] is record
    assert result["log"] is None and result["passed"]


def test_a_dead_worker_fails_only_its_own_case(tmp_path: Path) -> None:
    path = _campaign_file(tmp_path, f"seeds = [1, {fake.DIE_SEED}, 3]\nworkers = 2\n")
    run = run_campaign(load_campaign(path), executor="process", out_dir=tmp_path, console=_quiet(),
                       case_fn=fake.die_on_seed_13)
    by_seed = {r["seed"]: r for r in _jsonl(run)}
    assert set(by_seed) == {1, fake.DIE_SEED, 3}
    assert by_seed[1]["passed"] and by_seed[3]["passed"]
    assert by_seed[fake.DIE_SEED]["end_reason"] == "worker died"
    assert run.summary["failed_cases"] == ["0001"]
    assert run.summary["by_scenario"]["hover-2s"]["worst"]["c"] == {"value": 3.0, "bound": "<= 100", "passed": True,
                                                                    "margin": 97.0, "case_id": "0002"}


def test_the_worst_case_of_a_criterion_is_its_smallest_margin() -> None:
    """Whichever way a criterion is bounded, the case nearest to failing it is the worst."""
    from hil.fleet.campaign_summary import _badness

    def row(value: float, margin: float | None, passed: bool = True) -> dict[str, Any]:
        return {"value": value, "bound": ">= 1 and <= 3", "margin": margin, "passed": passed}

    near_low, middle, near_high = row(1.1, 0.1), row(2.0, 1.0), row(2.95, 0.05)
    ranked = sorted([middle, near_low, near_high], key=_badness)
    assert ranked == [middle, near_low, near_high]
    assert _badness(row(3.5, -0.5, passed=False)) > _badness(near_high)
    assert _badness(row(math.nan, None, passed=False)) > _badness(row(3.5, -0.5, passed=False))


def _wait_for(path_glob: tuple[Path, str], timeout_s: float = 60.0) -> None:
    """Poll the file system (the second case's log appearing), bounded."""
    directory, pattern = path_glob
    seen = threading.Event()
    for _ in range(int(timeout_s / 0.05)):
        if directory.exists() and list(directory.glob(pattern)):
            return
        seen.wait(0.05)
    raise AssertionError(f"no {pattern} in {directory}")


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
def test_ctrl_c_stops_the_running_case_cancels_the_rest_and_still_writes_the_results(
        tmp_path: Path, sig: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C, and SIGTERM (a CI runner cancelling the job) the same way: before SIGTERM was
    taken as Ctrl-C, the client died at once and the running case flew on as an orphan."""
    path = _campaign_file(tmp_path, 'seeds = [1, 2, 3]\nworkers = 1\nkeep_logs = "failed"\n')
    worker_tmp = tmp_path / "worker-tmp"  # where the pool's workers make the cases' directories
    worker_tmp.mkdir()
    monkeypatch.setenv("TMPDIR", str(worker_tmp))

    def interrupt_once_seed_2_flies(result: dict[str, Any]) -> None:
        if result["seed"] == 1:
            _wait_for((worker_tmp, "hil-case-*/logs/0001_*.mcap.part"))
            os.kill(os.getpid(), sig)  # what Ctrl-C in the terminal (or a job's cancel) does to the campaign

    run = run_campaign(load_campaign(path), executor="process", out_dir=tmp_path, console=_quiet(),
                       on_result=interrupt_once_seed_2_flies, case_fn=fake.first_fake_then_real)
    s = json.loads((run.dir / "summary.json").read_text())
    assert s["interrupted"] and s["cases"] == 3
    lines = _jsonl(run)
    assert [r["seed"] for r in lines[:2]] == [1, 2]
    assert lines[0]["passed"]
    stopped = lines[1]
    assert stopped["end_reason"] == "interrupted" and not stopped["passed"], stopped
    assert read_metadata(stopped["log"])["verdict"]["end_reason"] == "interrupted"  # finalized, not .part
    # Seed 3 never flies: cancelled in the executor's queue, or (already handed to the worker)
    # refused by run_case because the stop flag was up.
    assert [(r["seed"], r["end_reason"], r["log"]) for r in lines[2:]] in ([], [(3, "cancelled", None)])
    assert (s["passed"], s["failed"], s["stopped"] + s["cancelled"]) == (1, 0, 2)
    assert s["done"] == len(lines) and s["done"] + s["cancelled"] == 3
    assert not (run.dir / "STOP").exists()
    assert not run.passed
    assert list(worker_tmp.iterdir()) == []  # the case's directory went with it


def test_ctrl_c_reaches_a_dask_worker_that_cannot_see_the_stop_file(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """On a cluster without a shared filesystem the STOP file is the client's alone: the stop
    travels as a Dask event, and the running case still ends interrupted with its log
    finalized and brought back."""
    path = _campaign_file(tmp_path, 'seeds = [1, 2, 3]\nworkers = 1\nkeep_logs = "failed"\n')
    worker_tmp = tmp_path / "worker-tmp"
    worker_tmp.mkdir()
    monkeypatch.setenv("TMPDIR", str(worker_tmp))

    def interrupt_once_seed_2_flies(result: dict[str, Any]) -> None:
        if result["seed"] == 1:
            _wait_for((worker_tmp, "hil-case-*/logs/0001_*.mcap.part"))
            os.kill(os.getpid(), signal.SIGINT)

    run = run_campaign(load_campaign(path), executor="dask", out_dir=tmp_path, console=_quiet(),
                       on_result=interrupt_once_seed_2_flies, case_fn=fake.first_fake_then_real_blind)
    lines = _jsonl(run)
    stopped = lines[1]
    assert stopped["seed"] == 2 and stopped["end_reason"] == "interrupted", stopped
    assert Path(stopped["log"]).parent == run.dir / "logs"
    assert read_metadata(stopped["log"])["verdict"]["end_reason"] == "interrupted"
    assert run.summary["interrupted"] and not run.passed
    assert list(worker_tmp.glob("hil-case-*")) == []


def test_local_cluster_speaks_tls_and_refuses_clients_without_its_credentials() -> None:
    """The local Dask cluster listens with TLS and mutual authentication: a client without the
    temporary credentials (any other local user) cannot connect."""
    pytest.importorskip("distributed")
    from distributed import Client

    from hil.fleet.campaign_executors import start_local_cluster

    with start_local_cluster(1) as cluster:
        assert cluster.scheduler_address.startswith("tls://127.0.0.1:")
        assert cluster.security.require_encryption
        with Client(cluster, security=cluster.security) as ok:
            assert ok.submit(sum, [1, 2]).result(timeout=60) == 3
        with pytest.raises(Exception):  # noqa: B017 - TLS handshake refused or timed out, per version
            Client(cluster.scheduler_address, timeout="3s")
        plain = cluster.scheduler_address.replace("tls://", "tcp://")
        with pytest.raises(Exception):  # noqa: B017
            Client(plain, timeout="3s")
