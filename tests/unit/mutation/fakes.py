"""Fake results and specs for the mutation tests (no flight flown)."""

from __future__ import annotations

from typing import Any

from hil.fleet.mutation.edits import Edit
from hil.fleet.mutation.runner import MutantSpec


def spec(mid: str, *, origin: str = "catalogue", compute_only: bool = False) -> MutantSpec:
    return MutantSpec(mid, origin, "control", "sign", f"{mid} does harm", (Edit("m.py", "a", "b"),),  # type: ignore[arg-type]
                      compute_only)


def run(scenario: str, passed: bool, failed: list[str] | None = None, end: str = "completed",
        seed: int = 1) -> dict[str, Any]:
    return {"scenario": scenario, "seed": seed, "passed": passed, "end_reason": end, "message": "",
            "failed": failed or [], "criteria": [], "wall_s": 1.0, "output_tail": [], "mcap": None}


def result(mid: str, *runs: dict[str, Any]) -> dict[str, Any]:
    return {"case_id": mid, "mutant": mid, "runs": list(runs), "wall_s": 2.0}
