"""The LPC2148 bus benchmark runs to the end on its bus scenarios and prints its figures and
digests (a smoke run: no time is asserted, a benchmark's figure is not a verdict)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def test_bench_lpc2148_bus_prints_its_costs_and_digests() -> None:
    out = subprocess.run([sys.executable, "tests/bench/bench_lpc2148_bus.py", "--rounds", "1", "--only", "bus"],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    rows = [line.split() for line in out.stdout.splitlines() if " us " in line or line.rstrip().endswith(" us")]
    names = " ".join(" ".join(r) for r in rows)
    for row in ("read U0LSR", "write VICVectAddr", "tick, Timer0 only", "tick, 69-byte burst"):
        assert row in names, out.stdout
    assert all(len(r[-1]) == 12 for r in rows), out.stdout  # each row's digest
