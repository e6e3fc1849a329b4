"""The campaign: the baseline goes first and a failure stops it; exit codes; bad input; the
worker flies from a temporary copy that never leaks."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console

from hil.config import ConfigError
from hil.fleet.mutation import cli_run, runner, worker
from hil.fleet.mutation.edits import Edit, snapshot

from .fakes import result, run

ROOT = Path(__file__).resolve().parents[3]
SCEN = ROOT / "rigs" / "scenarios"


def opts(tmp_path: Path, **kw: Any) -> dict[str, Any]:
    o = {"rig": ROOT / "rigs" / "paper-quad.toml", "scenarios": [SCEN / "fault-imu-silence.toml", SCEN / "hover.toml"],
         "exclude": None, "catalogue": ROOT / "rigs" / "mutation" / "flightcode.toml", "equivalents": None,
         "tree": ROOT / "flightcode", "only": ["ctl-yaw-rate-sign", "tel-time-units"], "no_catalogue": False,
         "operators": 0, "operator_seed": 1, "seeds": 2, "matrix": False, "keep_kills": False, "min_score": 0.5, "min_operator_score": 0.8,
         "workers": 1, "scheduler": None, "executor": "process", "mode": "lockstep", "out": tmp_path / "out"}
    o.update(kw)
    return o


def _console() -> Console:
    return Console(record=True, width=200)


def test_baseline_failure_stops_the_campaign_and_names_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    flown: list[str] = []

    def fake_execute(plan, tasks, on_result, stop_file, tag):  # noqa: ANN001
        for t in tasks:
            flown.append(t["case_id"])
            bad = t["scenario_name"] == "hover" and t["seeds"] == [2]
            on_result(result(t["mutant"], run(t["scenario_name"], not bad, ["RMS altitude error"] if bad else None,
                                              seed=t["seeds"][0])))
        return False

    monkeypatch.setattr(runner, "execute", fake_execute)
    con = _console()
    assert cli_run.run(opts(tmp_path), con) == 2
    text = con.export_text()
    assert "baseline failed, no mutant flown" in text and "hover seed 2 (RMS altitude error)" in text
    assert flown and all(c.startswith("baseline-") for c in flown)  # no mutant task was submitted
    assert sorted(flown) == sorted(f"baseline-{s}-s{n}" for s in ("fault-imu-silence", "hover") for n in (1, 2))
    (cdir,) = (tmp_path / "out").iterdir()
    assert "RMS altitude error" in (cdir / "baseline-failures.json").read_text()


@pytest.mark.parametrize(("min_score", "code"), [(0.5, 0), (0.51, 1)])
def test_exit_code_is_the_score_against_min_score(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                  min_score: float, code: int) -> None:
    def fake_execute(plan, tasks, on_result, stop_file, tag):  # noqa: ANN001
        for t in tasks:
            s = t["scenario_name"].split(",")[0]
            killed = t["mutant"] == "ctl-yaw-rate-sign"
            on_result(result(t["mutant"], run(s, not killed, ["yaw rate error"] if killed else None)))
        return False

    monkeypatch.setattr(runner, "execute", fake_execute)
    con = _console()
    assert cli_run.run(opts(tmp_path, min_score=min_score), con) == code
    (cdir,) = (tmp_path / "out").iterdir()
    assert {p.name for p in cdir.iterdir()} >= {"report.json", "heatmap.png", "mutants.jsonl", "baseline.jsonl"}
    text = con.export_text()
    assert "ctl-yaw-rate-sign" in text and "fault-imu-silence: yaw rate error" in text
    assert "survivor tel-time-units" in text and "+        (rec.t_ns // 1_000_000)" in text


@pytest.mark.parametrize(("kw", "message"), [
    ({"only": ["no-such-mutant"]}, "--only: no such mutant: no-such-mutant"),
    ({"exclude": ["nope"]}, "--exclude: no such scenario"),
    ({"scenarios": [SCEN / "missing.toml"]}, "missing.toml: no such scenario"),
    ({"mode": "fast"}, "--mode"),
    ({"seeds": 0}, "--seeds"),
    ({"min_score": 2.0}, "--min-score"),
    ({"min_operator_score": -0.1}, "--min-operator-score"),
    ({"catalogue": ROOT / "nope.toml"}, "nope.toml: cannot read"),
    ({"rig": ROOT / "nope-rig.toml"}, "nope-rig.toml: no such rig"),
])
def test_bad_input_exits_2_before_flying(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kw: dict[str, Any],
                                         message: str) -> None:
    monkeypatch.setattr(runner, "execute", lambda *a: pytest.fail("flew"))
    con = _console()
    assert cli_run.run(opts(tmp_path, **kw), con) == 2
    assert message in con.export_text()


def test_suite_excludes_and_orders_shortest_first() -> None:
    suite = runner.load_suite(ROOT / "rigs" / "paper-quad.toml", [SCEN], ["paper-literal-weights"])
    names = [s.stem for s in suite.scenarios]
    assert "paper-literal-weights" not in names and names[0] == "arm-idle" and len(names) >= 12
    with pytest.raises(ConfigError, match="empty"):
        runner.load_suite(ROOT / "rigs" / "paper-quad.toml", [SCEN / "hover.toml"], ["hover"])


# ---- the worker -----------------------------------------------------------------------------
def _task(tmp_path: Path, *, first_kill: bool = True, keep: bool = False) -> dict[str, Any]:
    files = snapshot(ROOT / "flightcode")
    files["modes.py"] = files["modes.py"].replace(b"auto_disarm_s: float = 5.0", b"auto_disarm_s: float = 9.0")
    return {"case_id": "m", "mutant": "m", "tree_name": "flightcode", "files": files,
            "rig_name": "paper-quad.toml", "rig_files": runner.rig_files(ROOT / "rigs" / "paper-quad.toml"),
            "scenarios": [{"name": n, "text": b"[scenario]\n"} for n in ("a", "b", "c")], "seeds": [1, 2],
            "stop_at_first_kill": first_kill, "keep_kills": keep, "mode": "lockstep", "timeout_s": 10.0,
            "stop_file": str(tmp_path / "STOP")}


@pytest.fixture
def tmpdir_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    root = tmp_path / "tmp"
    root.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(root))
    return root


def _fake_case(seen: list[dict[str, Any]], kill: tuple[str, int] | None, boom: bool = False):  # noqa: ANN202
    def fake(params: dict[str, Any]) -> dict[str, Any]:
        seen.append(params)
        cwd = Path(params["cwd"])
        assert b"auto_disarm_s: float = 9.0" in (cwd / "flightcode" / "modes.py").read_bytes()  # the mutant
        assert Path(params["rig"]).is_file() and (Path(params["rig"]).parent / "flightcode-paper-quad.toml").is_file()
        assert Path(params["scenario"]).is_file()
        if boom:
            raise RuntimeError("bench fell over")
        killed = kill == (params["scenario_name"], params["seed"])
        log = None
        if killed:
            Path(params["log_path"]).parent.mkdir(parents=True, exist_ok=True)
            Path(params["log_path"]).write_bytes(b"MCAP")
            log = params["log_path"]
        return {"scenario": params["scenario_name"], "seed": params["seed"], "passed": not killed,
                "end_reason": "completed", "criteria": [{"name": "c1", "passed": not killed}], "log": log}
    return fake


def test_worker_flies_a_copy_stops_at_first_kill_and_leaves_no_temp_dir(
        tmp_path: Path, tmpdir_root: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[dict[str, Any]] = []
    monkeypatch.setattr(worker, "run_case", _fake_case(seen, ("b", 1)))
    out = worker.run_mutant(_task(tmp_path, keep=True))
    assert [(r["scenario"], r["seed"], r["passed"]) for r in out["runs"]] == [("a", 1, True), ("a", 2, True),
                                                                               ("b", 1, False)]
    assert out["runs"][-1]["failed"] == ["c1"] and out["runs"][-1]["mcap"] == b"MCAP"
    assert seen[0]["keep_logs"] == "failed"
    assert list(tmpdir_root.iterdir()) == []
    assert b"9.0" not in (ROOT / "flightcode" / "modes.py").read_bytes()  # never edited in place


def test_worker_matrix_flies_everything(tmp_path: Path, tmpdir_root: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[dict[str, Any]] = []
    monkeypatch.setattr(worker, "run_case", _fake_case(seen, ("a", 1)))
    out = worker.run_mutant(_task(tmp_path, first_kill=False))
    assert len(out["runs"]) == 6 and out["runs"][0]["mcap"] is None and seen[0]["keep_logs"] == "none"
    assert list(tmpdir_root.iterdir()) == []


def test_worker_cleans_up_when_the_case_raises(tmp_path: Path, tmpdir_root: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(worker, "run_case", _fake_case([], None, boom=True))
    with pytest.raises(RuntimeError, match="bench fell over"):
        worker.run_mutant(_task(tmp_path))
    assert list(tmpdir_root.iterdir()) == []


def test_a_lost_task_is_an_error_not_a_kill() -> None:
    lost = runner._lost({"case_id": "m", "scenario": "a", "seed": 1, "end_reason": "worker died", "message": "x"})
    assert lost["runs"][0]["end_reason"] == "worker died"
    from hil.fleet.mutation.report import status
    assert status(lost, False) == "error"
    assert Edit("a", "b", "c").file == "a"
