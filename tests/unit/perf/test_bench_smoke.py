"""The plant's and the recorder child's benchmarks run to the end on a small load and print
their figures (smoke runs: no time is asserted, a benchmark's figure is not a verdict)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]


def _run(*args: str) -> str:
    out = subprocess.run([sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout


def test_bench_plant_prints_its_costs() -> None:
    out = _run("tests/bench/bench_plant.py", "200")
    assert "step only" in out and "step+state+sensors" in out


@pytest.mark.pty
@pytest.mark.system
def test_bench_recorder_child_captures_a_flight_and_prints_its_cost(tmp_path: Path) -> None:
    batches = tmp_path / "batches.pkl"
    out = _run("tests/bench/bench_recorder_child.py", "--rounds", "1", "--batches", str(batches),
               "-s", "hover", "--seed", "1", "--duration", "0.5")
    assert batches.stat().st_size > 0
    assert "this checkout" in out and "CPU us per tick" in out
