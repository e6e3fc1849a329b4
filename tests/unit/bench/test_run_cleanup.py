"""A run's cleanup is not cut short by a stop that comes while the run is ending."""

from __future__ import annotations

import asyncio

import pytest

from hil.flight.run_finish import despite_cancel as _despite_cancel


async def test_a_cancel_during_cleanup_lets_the_step_finish_and_is_taken_back() -> None:
    steps: list[str] = []
    started = asyncio.Event()

    async def stop_flight_code() -> int:
        started.set()
        for _ in range(5):  # a SIGTERM and the wait for the exit: several turns of the loop
            await asyncio.sleep(0)
        steps.append("flight code stopped")
        return 0

    async def ending_run() -> str:
        rc = await _despite_cancel(stop_flight_code())
        steps.append("log finalized")
        task = asyncio.current_task()
        assert task is not None and task.cancelling() == 0  # the cancel was taken back
        return f"completed, rc {rc}"

    run = asyncio.ensure_future(ending_run())
    await started.wait()
    run.cancel()  # a test's teardown calls stop() just as the run ends on its own
    assert await run == "completed, rc 0"
    assert steps == ["flight code stopped", "log finalized"]


async def test_a_cancelled_step_itself_still_raises() -> None:
    async def step() -> None:
        raise asyncio.CancelledError

    with pytest.raises(asyncio.CancelledError):
        await _despite_cancel(step())
