"""SIGQUIT during ``hil run`` (hil/flight/signals.py): each task's stack on stderr, and the run
goes on; outside a run the default action is back."""

from __future__ import annotations

import asyncio
import os
import signal

import pytest

from hil.flight import signals


async def test_sigquit_says_where_the_run_waits_and_it_goes_on(monkeypatch: pytest.MonkeyPatch,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    dumped = asyncio.Event()
    real = signals.dump_tasks

    def dump_and_say() -> None:
        real()
        dumped.set()

    monkeypatch.setattr(signals, "dump_tasks", dump_and_say)
    gate = asyncio.Event()

    async def waits_at_the_gate() -> int:
        await gate.wait()
        return 7

    async def quit_then_open() -> None:
        os.kill(os.getpid(), signal.SIGQUIT)
        await dumped.wait()
        gate.set()

    opener = asyncio.create_task(quit_then_open(), name="opener")
    assert await signals.cancelled_by_signals(waits_at_the_gate()) == 7  # not cancelled, not ended
    await opener
    err = capsys.readouterr().err
    assert "(SIGQUIT)" in err and "waits_at_the_gate" in err and "--- opener" in err, err
    # the whole await chain, down to the innermost coroutine: asyncio's Event.wait, where the gate is
    assert "asyncio/locks.py" in err and "in wait" in err, err


def test_the_await_chain_names_every_coroutine_down_to_the_future() -> None:
    async def inner(fut: asyncio.Future[None]) -> None:
        await fut

    async def outer(fut: asyncio.Future[None]) -> None:
        await inner(fut)

    async def main() -> list[str]:
        fut = asyncio.get_running_loop().create_future()
        task = asyncio.create_task(outer(fut))
        await asyncio.sleep(0)
        chain = signals.await_chain(task.get_coro())
        task.cancel()
        return chain

    chain = asyncio.run(main())
    assert [line.rsplit(" in ", 1)[-1] for line in chain[:2]] == ["outer", "inner"], chain
    assert chain[2].startswith("awaits "), chain
    assert signal.getsignal(signal.SIGQUIT) == signal.SIG_DFL
