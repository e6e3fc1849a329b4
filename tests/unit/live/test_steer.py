"""hil/live/steer.py without a server: a dead server never holds a paused run, its errors
become events and a note, and a seek either steps forward or says why it cannot."""

from __future__ import annotations

import asyncio
import os
import pickle
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from hil.live.steer import Steering, seek_ticks
from hil.live.topics import LEN

TICK_NS = 2_500_000
RUN_START_UNIX_NS = 1_700_000_000_000_000_000


class FakeLoop:
    def __init__(self) -> None:
        self.k = 0
        self.t_ns = 0
        self.tick_ns = TICK_NS
        self.tick_gate: Any = None
        self.before_tick: Any = None


class Harness:
    def __init__(self) -> None:
        self.r, self.w = os.pipe()
        os.set_blocking(self.r, False)
        self.loop = FakeLoop()
        self.events: list[tuple[str, dict[str, Any]]] = []
        self.notes: list[str] = []
        self.steering = Steering(self.r, self.loop, runner=None, log_event=self._log, lockstep=True,
                                 note=self.notes.append, run_start_unix_ns=RUN_START_UNIX_NS)
        self.steering.attach()

    def _log(self, t_ns: int, kind: str, name: str, detail: dict[str, Any]) -> None:
        self.events.append((name, detail))

    def send(self, item: tuple[Any, ...]) -> None:
        body = pickle.dumps(item)
        os.write(self.w, LEN.pack(len(body)) + body)

    async def ticks(self, n: int) -> None:
        """Run the gate ``n`` times, as the tick loop does before each tick."""
        for _ in range(n):
            await self.loop.tick_gate()
            self.loop.k += 1
            self.loop.t_ns += TICK_NS

    def names(self) -> list[str]:
        return [name for name, _ in self.events]


async def test_a_paused_run_goes_on_when_the_server_process_ends() -> None:
    h = Harness()
    h.send(("publish", "/hil/steer", b'{"command": "pause"}'))
    await asyncio.sleep(0)  # the reader takes the command
    gate = asyncio.ensure_future(h.ticks(1))
    await asyncio.sleep(0.05)
    assert not gate.done() and "paused" in h.names()  # held by the pause
    os.close(h.w)  # the server's process died: end of file on the pipe
    await asyncio.wait_for(gate, 5)
    assert "server gone" in h.names()
    assert h.steering.fd == -1 and h.steering.server_gone
    assert any("the live server ended at t = 0.000 s" in n for n in h.notes)
    await asyncio.wait_for(h.ticks(3), 5)  # and never waits again
    h.steering.close()


async def test_server_errors_are_events_and_a_note() -> None:
    h = Harness()
    h.send(("server error", 1, "/sim/truth: RuntimeError: channel closed"))
    h.send(("server error", 57, "/sim/truth: RuntimeError: channel closed"))
    await asyncio.sleep(0.01)
    errors = [d for name, d in h.events if name == "server error"]
    assert [e["errors"] for e in errors] == [1, 57]
    h.steering.close()
    os.close(h.w)
    assert h.notes == ["live view: the server could not serve 57 message(s) (first: /sim/truth: "
                       "RuntimeError: channel closed); the recording has them"]


async def test_a_seek_forward_steps_to_that_time_and_pauses() -> None:
    h = Harness()
    await h.ticks(4)  # t = 10 ms
    target_ns = 100_000_000 + 1  # just past 100 ms: the first tick at or after it
    h.send(("playback", "pause", 1.0, RUN_START_UNIX_NS + target_ns))
    await asyncio.sleep(0.01)
    run = asyncio.ensure_future(h.ticks(200))
    await asyncio.sleep(0.1)
    assert not run.done()
    paused_at = [d["t_s"] for name, d in h.events if name == "paused"]
    assert paused_at == [0.1025]  # 10 ms + 37 ticks, the first tick at or after the target
    run.cancel()
    h.steering.close()
    os.close(h.w)


async def test_a_seek_back_is_refused_and_changes_nothing() -> None:
    h = Harness()
    await h.ticks(40)  # t = 100 ms
    h.send(("playback", "pause", 1.0, RUN_START_UNIX_NS + 50_000_000))
    await asyncio.sleep(0.01)
    await asyncio.wait_for(h.ticks(5), 5)  # not paused
    [error] = [d for name, d in h.events if name == "error"]
    assert error["topic"] == "playback" and "cannot go back" in error["error"] and "MCAP" in error["error"]
    assert "paused" not in h.names()
    h.steering.close()
    os.close(h.w)


@given(st.integers(-10**12, 10**12), st.integers(0, 10**12), st.integers(1, 10**8))
def test_seek_ticks_reaches_the_first_tick_at_or_after_the_target(target_ns: int, now_ns: int, tick_ns: int) -> None:
    n = seek_ticks(target_ns, now_ns, tick_ns)
    if target_ns <= now_ns:
        assert n == 0
    else:
        assert now_ns + n * tick_ns >= target_ns > now_ns + (n - 1) * tick_ns
