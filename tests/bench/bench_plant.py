"""Benchmark of the plant (not a test): cost of one 2.5 ms tick in microseconds.

Run: ``.venv/bin/python tests/bench/bench_plant.py [N_TICKS]`` (same as
``python -m hil.perf.plant_tick``). Prints the median and p99 of ``plant.step`` alone and of
``step + state + sensors()`` (what the bench does every tick) with the default RK4
sub-steps. Budget (docs/performance.md, What bounds the speed): well under 10 % of the tick.
"""

from __future__ import annotations

from hil.perf.plant_tick import main

if __name__ == "__main__":
    raise SystemExit(main())
