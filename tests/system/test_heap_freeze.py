"""The bench freezes what it built before the first tick (the collector's full passes skip
it, docs/performance.md) and unfreezes it when the run ends, whatever the ending."""

from __future__ import annotations

import gc

import pytest

from hil.flight.tickloop import EndReason
from tests.system.conftest import explain

pytestmark = [pytest.mark.system, pytest.mark.pty]


async def test_the_run_freezes_its_heap_and_gives_it_back(fly) -> None:
    seen: list[int] = []
    assert gc.get_freeze_count() == 0
    result = await fly("hover", duration_s=1.0, record=False, keep_trace=False,
                       progress=lambda *_: seen.append(gc.get_freeze_count()))
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    assert seen and min(seen) > 0  # every tick
    assert gc.get_freeze_count() == 0
