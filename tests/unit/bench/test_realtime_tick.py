"""The realtime tick: its bookkeeping waits for the sample's ESC command (up to a share of the
tick), so the event loop is free to serve the flight code while it computes."""

from __future__ import annotations

import asyncio
import time
from typing import Any

import pytest

import hil.flight.tickloop
from hil.flight.tickloop import RT_ANSWER_SHARE, Mode, TickLoop

TICK_NS = 2_500_000


class _Devices:
    """The DeviceSet calls the tick loop makes, with a fake flight code answering each sample
    ``answer_s`` after it is emitted (None: never)."""

    def __init__(self, answer_s: float | None, *, sees_unread: bool = True, answer_after_next: bool = False) -> None:
        self.answer_s = answer_s
        #: answer each sample only once the next one is out (a flight code a sample behind),
        #: whatever the host's timing: not after a wall delay, which a loaded host stretches
        self.answer_after_next = answer_after_next
        self.on_esc_command: Any = None
        self.answered: set[int] = set()
        self.latencies: list[Any] = []
        self.k = -1  #: the newest sample emitted
        self.answering = -1  #: the sample the fake flight code is answering now
        self.sees_unread = sees_unread  #: False: a port whose client's end the bench cannot see

    def newest_sample_unread(self) -> bool:
        """The fake flight code reads a sample only when it answers it: any newer one is unread."""
        return self.sees_unread and self.k > self.answering

    def emit_rc_early(self, t_ns: int) -> None: ...
    async def confirm_rc(self) -> None: ...
    def actuate_and_step(self, t_ns: int) -> None: ...
    def latch_analog(self, t_ns: int) -> None: ...
    def finish_tick(self, t_ns: int) -> None: ...

    def note_latency(self, sample: Any) -> None:
        self.latencies.append(sample)

    def emit_imu(self, t_ns: int) -> tuple[bool, bool]:
        k = self.k = t_ns // TICK_NS
        if self.answer_after_next and k > 0:
            # runs when the tick loop next yields: after this sample's emission is booked
            asyncio.get_running_loop().call_soon(self._answer, k - 1, t_ns - TICK_NS)
        if self.answer_s is not None:
            loop = asyncio.get_running_loop()
            loop.call_later(self.answer_s, self._answer, k, t_ns)
        return True, True

    def _answer(self, k: int, t_ns: int) -> None:
        self.answered.add(k)
        self.answering = k
        self.on_esc_command(time.monotonic_ns(), t_ns)


def _loop(devices: _Devices, ticks: int, seen: list[tuple[int, bool]]) -> TickLoop:
    return TickLoop(
        devices,  # type: ignore[arg-type]  # the realtime path only
        mode=Mode.REALTIME, tick_ns=TICK_NS, duration_ns=(ticks - 1) * TICK_NS, barrier_timeout_s=0.5,
        boot_timeout_s=1.0, after_tick=lambda k, t: seen.append((k, k in devices.answered)),
    )


def test_bookkeeping_follows_the_samples_command(monkeypatch: pytest.MonkeyPatch) -> None:
    # The wait is measured from the tick's wall deadline: on a loaded machine a late tick has
    # less of it left, so the test lets it wait up to 1 s (the answer comes 0.3 ms after emit).
    monkeypatch.setattr(hil.flight.tickloop, "RT_ANSWER_SHARE", 400.0)
    devices = _Devices(answer_s=0.0003)
    seen: list[tuple[int, bool]] = []
    loop = _loop(devices, 40, seen)
    asyncio.run(loop.run())
    assert len(seen) == 40
    # every tick's bookkeeping ran after its own sample's command had arrived
    assert all(answered for _k, answered in seen)
    assert loop.stats.no_command == 0 and len(loop.stats.latencies_ns) == 40


def test_no_command_does_not_hold_the_tick_and_is_counted() -> None:
    devices = _Devices(answer_s=None)
    seen: list[tuple[int, bool]] = []
    loop = _loop(devices, 20, seen)
    asyncio.run(loop.run())
    assert [k for k, _ in seen] == list(range(20))  # every tick still ran its bookkeeping
    assert loop.stats.no_command == 19  # each sample but the last was followed by the next
    assert all(s.t_arrival_host_ns is None for s in devices.latencies)
    assert 0 < RT_ANSWER_SHARE < 1


def test_a_command_after_the_next_sample_is_credited_to_none() -> None:
    # each answer comes after the next sample is out, which is unread then
    devices = _Devices(answer_s=None, answer_after_next=True)
    loop = _loop(devices, 20, [])
    asyncio.run(loop.run())
    assert loop.stats.no_command == 19
    assert len(loop.stats.latencies_ns) == 0  # no sample got a command it could not have had
    assert loop.stats.late_commands == len(devices.answered) > 10  # the answers that came in the run


def test_where_the_client_end_is_unseen_the_first_command_after_a_sample_answers_it() -> None:
    # an attached serial line: the bench cannot tell, and credits as it always did
    devices = _Devices(answer_s=None, sees_unread=False, answer_after_next=True)
    loop = _loop(devices, 20, [])
    asyncio.run(loop.run())
    assert loop.stats.late_commands == 0 and len(loop.stats.latencies_ns) > 10


def test_slack_work_gets_each_next_deadline_after_the_bookkeeping() -> None:
    devices = _Devices(answer_s=0.0003)
    seen: list[tuple[int, bool]] = []
    loop = _loop(devices, 10, seen)
    calls: list[tuple[int, int]] = []  # (ticks whose bookkeeping ran, deadline)
    loop.slack_work = lambda deadline_ns: calls.append((len(seen), deadline_ns))
    asyncio.run(loop.run())
    start = loop.stats.wall_start_ns
    assert calls == [(k + 1, start + (k + 1) * TICK_NS) for k in range(10)]


def test_lockstep_has_no_slack_work() -> None:
    """Lockstep ticks have no deadline; the tick loop never calls slack work there (the
    wall-clock lockstep path shares the realtime loop)."""
    devices = _Devices(answer_s=0.0)
    loop = TickLoop(
        devices,  # type: ignore[arg-type]
        mode=Mode.LOCKSTEP, tick_ns=TICK_NS, duration_ns=4 * TICK_NS, barrier_timeout_s=0.5, boot_timeout_s=1.0,
    )
    called: list[int] = []
    loop.slack_work = called.append
    asyncio.run(loop.run())
    assert loop.stats.ticks == 5 and called == []


def test_the_first_realtime_tick_is_due_a_tick_after_the_start() -> None:
    """Tick 0 is scheduled one tick ahead (the pacer's thread starts, and the flight code gets
    a whole tick for its first sample), so it is not late by construction; every later
    deadline follows from it."""
    from hil import clock

    devices = _Devices(answer_s=0.0003)
    seen: list[tuple[int, bool]] = []
    loop = _loop(devices, 5, seen)
    before_ns = clock.monotonic_ns()
    asyncio.run(loop.run())
    assert loop.stats.wall_start_ns >= before_ns + TICK_NS
    assert len(seen) == 5
