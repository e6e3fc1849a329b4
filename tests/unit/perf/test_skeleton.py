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


@pytest.mark.parametrize("steps", [0, 1, 2, 3, 4, 6, 10])
async def test_a_cancel_at_any_step_of_the_start_ends_it_and_closes_every_pty(steps: int) -> None:
    """Ctrl-C while the skeleton starts its flight side (Python 3.11's subprocess start hung on
    a cancel while connecting pipes: hil/flight/spawn.py): it ends, no pty is left open."""
    import asyncio
    import os

    before = set(os.listdir("/proc/self/fd"))
    task = asyncio.create_task(run_skeleton(0.05))
    for _ in range(steps):
        await asyncio.sleep(0)
    task.cancel()
    done, _ = await asyncio.wait([task], timeout=30)
    assert done, "the cancelled start hung"
    assert task.cancelled() or task.exception() is None
    assert set(os.listdir("/proc/self/fd")) <= before
