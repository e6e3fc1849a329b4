"""``hil falsify --mutant``: the mutant's tree travels with every case, edited, beside its
context files, and an unknown id or a stale edit is an error naming the catalogue."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from hil.config import ConfigError
from hil.fleet.campaign_bundle import WORK_DIR
from hil.fleet.falsify.mutant import load_mutant
from hil.fleet.falsify.search import fly_reference, run_search
from hil.fleet.falsify.space import load_space
from tests.unit.falsify.test_search import Judge, judge
from tests.unit.falsify.test_space import MASS_AND_SEED, scenario

ROOT = Path(__file__).resolve().parents[3]


def _catalogue(tmp_path: Path, old: str = "return a + b", context: str = "") -> Path:
    tree = tmp_path / "fc"
    tree.mkdir()
    (tree / "ops.py").write_text("def add(a, b):\n    return a + b\n")
    (tree / "__pycache__").mkdir()
    (tree / "__pycache__" / "ops.cpython-311.pyc").write_bytes(b"\0")
    cat = tmp_path / "cat.toml"
    cat.write_text(f'''[target]
name = "toy"
tree = "{tree}"
{context}

[[mutant]]
id = "add-is-sub"
layer = "control"
kind = "operator"
file = "ops.py"
old = "{old}"
new = "return a - b"
effect = "sums become differences"
''')
    return cat


def test_the_bundle_carries_the_edited_tree_and_nothing_else(tmp_path: Path) -> None:
    m = load_mutant(_catalogue(tmp_path), "add-is-sub")
    bundle = m.bundle()
    assert set(bundle) == {f"{WORK_DIR}/fc/ops.py"}  # no caches
    mode, data = bundle[f"{WORK_DIR}/fc/ops.py"]
    assert data == b"def add(a, b):\n    return a - b\n" and mode == 0o644
    assert "-    return a + b" in m.diff and "+    return a - b" in m.diff
    assert (tmp_path / "fc" / "ops.py").read_text().endswith("a + b\n")  # the tree itself untouched


def test_context_files_ride_beside_the_tree(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "cfg.toml").write_text("x = 1\n")
    monkeypatch.chdir(tmp_path)
    m = load_mutant(_catalogue(tmp_path, context='context = ["cfg.toml"]'), "add-is-sub")
    assert m.bundle()[f"{WORK_DIR}/cfg.toml"] == (0o644, b"x = 1\n")
    written = m.write(tmp_path / "out")
    assert (written / "fc" / "ops.py").read_text().endswith("a - b\n") and (written / "cfg.toml").is_file()
    assert (tmp_path / "out" / "mutant.diff").read_text() == m.diff


def test_unknown_ids_and_stale_edits_name_the_catalogue(tmp_path: Path) -> None:
    cat = _catalogue(tmp_path)
    with pytest.raises(ConfigError, match=r"cat.toml: --mutant: no mutant 'nope' \(known: add-is-sub\)"):
        load_mutant(cat, "nope")
    stale = tmp_path / "stale"
    stale.mkdir()
    with pytest.raises(ConfigError, match=r"cat.toml: add-is-sub: ops.py: the edit's old text occurs 0 times"):
        load_mutant(_catalogue(stale, old="return b + a"), "add-is-sub")


def test_every_case_of_the_search_carries_the_mutant(tmp_path: Path) -> None:
    seen: list[dict[str, Any]] = []
    engine = judge(tmp_path, extra_files=load_mutant(_catalogue(tmp_path), "add-is-sub").bundle())
    original = engine.fly

    def fly(cases: list[dict[str, Any]], handle: Any) -> bool:
        seen.extend(cases)
        return original(cases, handle)

    object.__setattr__(engine, "fly", fly)
    run_search(load_space(scenario(tmp_path, MASS_AND_SEED)), engine, flights=20, wall_s=None, seed=3)
    assert seen and all(c["files"][f"{WORK_DIR}/fc/ops.py"][1].endswith(b"a - b\n") for c in seen)


def test_the_shipped_catalogue_loads_every_mutant() -> None:
    """Each entry of the Python catalogue still applies to flightcode/ (as hil mutate needs)."""
    path = ROOT / "rigs" / "mutation" / "flightcode.toml"
    ids = [m["id"] for m in tomllib.loads(path.read_text())["mutant"]]
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        trees = [load_mutant(path, i) for i in ids]
    finally:
        os.chdir(cwd)
    assert all(f"{WORK_DIR}/flightcode/__main__.py" in t.bundle() for t in trees)


def test_cli_error_for_an_unknown_mutant_is_rc_2(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "hil.cli", "falsify", "rigs/scenarios/fault-imu-silence.toml",
                           "--mutant", "nope", "--out", str(tmp_path)], cwd=ROOT, capture_output=True, text=True,
                          timeout=120, env=dict(os.environ, COLUMNS="400"))
    assert proc.returncode == 2
    assert "error: rigs/mutation/flightcode.toml: --mutant: no mutant 'nope'" in proc.stdout
    assert list(tmp_path.iterdir()) == []


@dataclass(frozen=True)
class MutantJudge(Judge):
    """The mutant fails past 0.3 kg, the flight code past 0.6 kg."""

    def fly(self, cases: list[dict[str, Any]], handle: Any) -> bool:
        for case in cases:
            mass = tomllib.loads(case["files"][case["scenario"]][1].decode())["faults"][0]["extra_mass_kg"]
            m = (0.3 if f"{WORK_DIR}/fc/ops.py" in case["files"] else 0.6) - mass
            handle({"case_id": case["case_id"], "end_reason": "completed", "wall_s": 0.0,
                    "criteria": [{"name": "altitude recovers", "margin": m, "passed": m >= 0}]})
        return False


def test_the_reference_flight_says_whether_a_counterexample_separates(tmp_path: Path) -> None:
    base = judge(tmp_path)
    engine = MutantJudge(base.rig, 2, False, None, base.out,
                         extra_files=load_mutant(_catalogue(tmp_path), "add-is-sub").bundle())
    space = load_space(scenario(tmp_path, MASS_AND_SEED))
    search = run_search(space, engine, flights=200, wall_s=None, seed=3)
    cx = search.counterexample
    assert cx is not None and cx.values["faults.0.extra_mass_kg"] > 0.3
    ref = fly_reference(space, engine, cx)
    assert ref is not None and ref.values == cx.values
    assert (ref.objective >= 0) == (cx.values["faults.0.extra_mass_kg"] <= 0.6)
    # a point past what the flight code itself survives is no separation
    heavy = dataclasses.replace(cx, values={**cx.values, "faults.0.extra_mass_kg": 0.9})
    space.write(heavy.values, heavy.scenario_file, "heavier")
    ref = fly_reference(space, engine, heavy)
    assert ref is not None and ref.objective < 0
