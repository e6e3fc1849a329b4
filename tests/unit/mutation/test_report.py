"""The report: statuses, score, kill matrix, survivors with diffs, equivalents, timing-only."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

from rich.console import Console

from hil.fleet.mutation import report as rep

from .fakes import result, run, spec

SCEN = ["hover", "step"]


def _report() -> dict:
    specs = [spec("k1"), spec("k2"), spec("s1"), spec("eq"), spec("err"), spec("t1", compute_only=True),
             spec("op1", origin="operator")]
    results = {
        "k1": result("k1", run("hover", False, ["RMS roll error"])),
        "k2": result("k2", run("hover", True), run("step", False, end="flight code exited")),
        "s1": result("s1", run("hover", True), run("step", True)),
        "eq": result("eq", run("hover", True), run("step", True)),
        "err": result("err", run("hover", False, end="worker died")),
        "t1": result("t1", run("hover", True), run("step", True)),
        "op1": result("op1", run("hover", False, ["overshoot"])),
    }
    diffs = {m.id: f"--- a/{m.id}\n+++ b/{m.id}\n" for m in specs}
    return rep.build(specs, results, diffs, {"eq": "the changed branch is never reached in flight"}, SCEN,
                     {"wall_s": 3.0})


def test_statuses_and_score() -> None:
    r = _report()
    st = {m["id"]: m["status"] for m in r["mutants"]}
    assert st == {"k1": "killed", "k2": "killed", "s1": "survived", "eq": "equivalent", "err": "error",
                  "t1": "survived", "op1": "killed"}
    assert r["by_origin"]["catalogue"] == {"mutants": 6, "killed": 2, "survived": 2, "equivalent": 1, "errors": 1,
                                           "score": 0.5}
    assert r["by_origin"]["operator"]["score"] == 1.0
    assert r["score"]["score"] == 3 / 5


def test_kill_matrix_names_scenario_and_criterion() -> None:
    m = {x["id"]: x for x in _report()["mutants"]}
    assert m["k1"]["kills"] == {"hover": ["RMS roll error"]}
    assert m["k2"]["kills"] == {"step": ["flight ended: flight code exited"]}
    assert m["s1"]["kills"] == {} and m["s1"]["diff"].startswith("--- a/s1")
    assert m["k1"]["diff"] is None  # diffs are shown for survivors and equivalents
    assert m["eq"]["equivalent_reason"].startswith("the changed branch")


def test_survivors_by_layer_and_timing_only() -> None:
    r = _report()
    assert r["survivors_by_layer"] == {"control": ["s1", "t1"]}
    assert r["timing_only"] == [{"id": "t1", "status": "survived"}]


def test_exit_code_follows_min_score() -> None:
    r = _report()
    assert rep.exit_code(r, 0.5) == 0  # catalogue 0.5, operators 1.0
    assert rep.exit_code(r, 0.51) == 1
    assert rep.exit_code(r, 0.5, 1.0) == 0
    assert rep.targets(r, 0.5, 0.8) == [("catalogue", 0.5, True), ("operator", 0.8, True)]
    empty = rep.build([spec("e")], {}, {}, {}, SCEN, {})
    assert empty["mutants"][0]["status"] == "not run" and rep.exit_code(empty, 0.0) == 1


def test_outputs(tmp_path: Path) -> None:
    r = _report()
    rep.write_json(r, tmp_path / "r.json")
    assert json.loads((tmp_path / "r.json").read_text())["score"]["killed"] == 3
    rep.plot_heatmap(r, tmp_path / "h.png")
    assert (tmp_path / "h.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    r["targets"] = rep.targets(r, 0.95, 0.8)
    con = Console(record=True, width=200)
    rep.print_report(con, r)
    text = con.export_text()
    assert "hover: RMS roll error" in text and "survivor s1" in text and "--- a/s1" in text
    assert "catalogue: 2 killed, 2 survived, 1 equivalent, 1 errors of 6: score 50.0 %" in text
    assert "only a calibrated timing check could catch: t1 (survived)" in text
    assert "target catalogue >= 95 %: NOT met" in text and "target operator >= 80 %: met" in text


def test_the_heatmap_of_one_mutant_fits_its_labels(tmp_path: Path) -> None:
    """A one-mutant campaign: the rotated scenario names fit (no tight_layout warning)."""
    r = _report()
    r["mutants"] = r["mutants"][:1]
    r["scenarios"] = [*r["scenarios"], "fault-baro-port-blocked-on-the-longest-name"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rep.plot_heatmap(r, tmp_path / "h.png")
