"""``hil falsify``'s report of a search: a counterexample that never completed its flight (no
margin) is printed with its reason, and exits 1."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console

from hil.fleet.falsify import command
from hil.fleet.falsify.objective import FAILED
from hil.fleet.falsify.search import Flight, Search
from tests.unit.falsify.test_space import MASS_AND_SEED, scenario

ROOT = Path(__file__).resolve().parents[3]


def test_a_flight_that_did_not_complete_is_the_counterexample(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import hil.fleet.falsify.search as search_module

    def crashed(space: Any, engine: Any, **kw: Any) -> Search:
        point = engine.out / "points" / "0000.toml"
        point.parent.mkdir(parents=True)
        point.write_text("# a point\n")
        flight = Flight(0, 0, {"faults.0.extra_mass_kg": 0.2, "scenario.seed": 7}, FAILED, "flight code exited [status 3]",
                        "flight code exited", point, None, 1.0)
        return Search([flight], "counterexample", 1.0)

    monkeypatch.setattr(search_module, "run_search", crashed)
    console = Console(file=io.StringIO(), width=300)
    code = command._run(scenario(tmp_path, MASS_AND_SEED), ROOT / "rigs" / "paper-quad.toml", flights=10, wall_s=None,
                        seed=1, workers=1, scheduler=None, use_dask=False, out=tmp_path / "out", console=console)
    printed = console.file.getvalue()  # type: ignore[attr-defined]
    assert code == 1
    assert "counterexample: flight 0: flight code exited [status 3]" in printed
    assert "reproduce: hil run" in printed


def test_a_criterion_no_name_contains_is_refused_naming_the_option(tmp_path: Path) -> None:
    from hil.config import ConfigError

    console = Console(file=io.StringIO(), width=300)
    with pytest.raises(ConfigError, match=r"--criterion 'no such claim': no criterion of the scenario has it"):
        command._run(scenario(tmp_path, MASS_AND_SEED), ROOT / "rigs" / "paper-quad.toml", flights=10, wall_s=None,
                     seed=1, workers=1, scheduler=None, use_dask=False, out=tmp_path / "out", console=console,
                     focus=("no such claim",))
    assert not (tmp_path / "out").exists()  # refused before anything is made


def test_the_focus_reaches_the_search_and_the_report(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import json

    import hil.fleet.falsify.search as search_module

    seen: dict[str, Any] = {}

    def recorded(space: Any, engine: Any, **kw: Any) -> Search:
        seen.update(kw)
        return Search([], "flight budget", 1.0)

    monkeypatch.setattr(search_module, "run_search", recorded)
    console = Console(file=io.StringIO(), width=300)
    code = command._run(scenario(tmp_path, MASS_AND_SEED), ROOT / "rigs" / "paper-quad.toml", flights=10, wall_s=None,
                        seed=1, workers=1, scheduler=None, use_dask=False, out=tmp_path / "out", console=console,
                        focus=("recovers",))
    assert code == 0 and seen["focus"] == ("recovers",)
    assert "aimed at 1 of 2 criteria: altitude recovers" in console.file.getvalue()  # type: ignore[attr-defined]
    (summary,) = (tmp_path / "out").glob("*/search.json")
    assert json.loads(summary.read_text())["criteria"] == ["altitude recovers"]
