"""Acting on a bench's run from the test: catalogue faults applied at the next tick for the
body of an ``async with`` block (docs/faults.md)."""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator
from typing import Any

from hil.testing.records import S, InjectedFault, RunEnded
from hil.testing.simtime import BenchSimTime


class BenchActions(BenchSimTime):
    """What a test does to the run while it goes (the scenario's sticks and events play on their own)."""

    @contextlib.asynccontextmanager
    async def fault(self, kind: str, duration_s: float | None = None, **params: Any) -> AsyncIterator[InjectedFault]:
        """Apply catalogue fault ``kind`` (``hil faults``) at the next tick for the body of the
        block; it ends at the first tick after the block (or after ``duration_s`` of sim time,
        if that comes first). Invalid kinds or parameters raise ``hil.config.ConfigError``."""
        from hil.faults import CATALOGUE, Timing

        schedule = self.schedule

        def start(t_ns: int) -> InjectedFault:
            assert schedule is not None
            handle = schedule.start_now(kind, t_ns, duration_s=duration_s, **params)
            instant = CATALOGUE[kind].timing is Timing.INSTANT  # acted once, already over
            return InjectedFault(kind, handle, t_ns / S, t_ns / S if instant else None)

        injected: InjectedFault = await self._at_next_tick(start, f"the start of fault {kind}")
        try:
            yield injected
        finally:
            def stop(t_ns: int) -> None:
                assert schedule is not None
                if any(a.handle == injected.handle for a in schedule.active()):
                    schedule.stop(injected.handle, t_ns)
                    injected.t_end_s = t_ns / S

            if self.running:
                with contextlib.suppress(RunEnded):
                    await self._at_next_tick(stop, f"the end of fault {kind}")
            if injected.t_end_s is None and duration_s is not None:
                injected.t_end_s = injected.t_start_s + duration_s
