"""The bare lockstep skeleton of `hil perf` runs its exchange to the end (no timing asserted:
its RTF is a benchmark figure)."""

from __future__ import annotations

import pytest

from hil.perf.skeleton import TICK_NS, run_skeleton

pytestmark = pytest.mark.pty


async def test_the_skeleton_completes_every_tick() -> None:
    result = await run_skeleton(0.05)
    assert result.ticks == round(0.05e9 / TICK_NS) == 20
    assert result.wall_s > 0 and result.rtf > 0
    # both sides' CPU is measured (a figure, not a bound): the bench side's own process time
    # and the flight side's from /proc/<pid>/schedstat
    assert result.bench_cpu_per_tick_us > 0
    assert result.flight_cpu_per_tick_us > 0
