"""The search loop (hil/fleet/falsify/search.py) on a stand-in engine that judges each point
at once from its written scenario: it stops at a failure, respects its budget, restarts a
converged population, and is the same search for the same seed."""

from __future__ import annotations

import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hil.fleet.falsify.search import Engine, run_search
from hil.fleet.falsify.space import load_space
from tests.unit.falsify.test_space import MASS_AND_SEED, scenario


@dataclass(frozen=True)
class Judge(Engine):
    """Each case's result from its scenario's payload mass: ``margin(mass)`` for "altitude recovers"."""

    margin: Callable[[float], float] = lambda mass: 0.5 - mass

    def fly(self, cases: list[dict[str, Any]], handle: Callable[[dict[str, Any]], None]) -> bool:
        for case in cases:
            data = tomllib.loads(case["files"][case["scenario"]][1].decode())
            m = self.margin(data["faults"][0]["extra_mass_kg"])
            handle({"case_id": case["case_id"], "end_reason": "completed", "wall_s": 0.0,
                    "criteria": [{"name": "altitude recovers", "margin": m, "passed": m >= 0}]})
        return False


def judge(tmp_path: Path, **kw: Any) -> Judge:
    out = tmp_path / "out"
    out.mkdir(exist_ok=True)
    rig = Path(__file__).resolve().parents[3] / "rigs" / "paper-quad.toml"
    return Judge(rig, 2, False, None, out, **kw)


def test_it_stops_at_the_generation_with_a_failure(tmp_path: Path) -> None:
    space = load_space(scenario(tmp_path, MASS_AND_SEED))
    search = run_search(space, judge(tmp_path), flights=200, wall_s=None, seed=3)
    assert search.stopped == "counterexample"
    cx = search.counterexample
    assert cx is not None and cx.values["faults.0.extra_mass_kg"] > 0.5
    assert cx.objective == min(f.objective for f in search.flights) < 0
    assert len({f.generation for f in search.flights}) == search.flights[-1].generation + 1


def test_a_flat_objective_restarts_until_the_budget_and_never_passes_it(tmp_path: Path) -> None:
    space = load_space(scenario(tmp_path, MASS_AND_SEED))
    search = run_search(space, judge(tmp_path, margin=lambda mass: 0.25), flights=45, wall_s=None, seed=3)
    assert search.stopped == "flight budget" and search.counterexample is None
    assert 30 <= len(search.flights) <= 45  # whole generations of 10 (popsize 5 x 2 dimensions)
    assert len({tuple(f.values.values()) for f in search.flights}) > 10  # new draws after converging


def test_the_same_seed_is_the_same_search(tmp_path: Path) -> None:
    space = load_space(scenario(tmp_path, MASS_AND_SEED))
    a = run_search(space, judge(tmp_path), flights=60, wall_s=None, seed=5)
    b = run_search(space, judge(tmp_path), flights=60, wall_s=None, seed=5)
    assert [f.values for f in a.flights] == [f.values for f in b.flights]


def test_progress_never_counts_past_its_budget(tmp_path: Path) -> None:
    """A budget smaller than the first generation: that generation flies whole, and the
    progress's budget is the generation's size ([10/10], never [10/4])."""
    seen: list[tuple[int, int]] = []
    space = load_space(scenario(tmp_path, MASS_AND_SEED))
    search = run_search(space, judge(tmp_path, margin=lambda mass: 0.25), flights=4, wall_s=None, seed=3,
                        on_flight=lambda f, budget: seen.append((f.index + 1, budget)))
    assert len(search.flights) == 10 and search.stopped == "flight budget"
    assert all(i <= budget for i, budget in seen) and {b for _, b in seen} == {10}
