"""Ctrl-C and SIGTERM as a cancel of the running task (``hil run``); a second one exits at once.

A run cancelled this way ends as ``EndReason.INTERRUPTED`` and still stops the flight code,
closes its ports and finalizes its log (hil/flight/run.py); a KeyboardInterrupt raised
anywhere in the event loop would not give it that chance. The stop takes at most the rig's
``[flight] stop_grace_s`` plus the log's close. A second Ctrl-C or SIGTERM does not wait for
that: what the run registered with :func:`on_hard_exit` (SIGKILL to the flight command's
process tree, removal of the run directory) is done at once and the process exits with
status 130; the recorder child then closes the log as aborted, or leaves a ``.part`` file
that ``hil recover`` salvages.

SIGQUIT (Ctrl-\\ in a terminal) prints where each of the run's tasks waits, on stderr, and the
run goes on: a run that seems to hang says what it waits for. Every thread's Python stack comes
first (faulthandler, from the signal itself), so a run blocked outside its event loop says where too.
"""

from __future__ import annotations

import asyncio
import contextlib
import contextvars
import faulthandler
import os
import signal
import sys
from collections.abc import Awaitable, Callable
from typing import TextIO, TypeVar

_T = TypeVar("_T")

#: the exit status of a second Ctrl-C or SIGTERM (128 + SIGINT, as a shell reports Ctrl-C)
HARD_EXIT_STATUS = 130


class HardExit:
    """What must be done before the process exits at once: each callback, last registered
    first, errors ignored (the process is leaving)."""

    def __init__(self) -> None:
        self._actions: dict[int, Callable[[], None]] = {}
        self._next = 0

    def add(self, action: Callable[[], None]) -> Callable[[], None]:
        key = self._next
        self._next += 1
        self._actions[key] = action

        def take_back() -> None:
            self._actions.pop(key, None)

        return take_back

    def run(self) -> None:
        for key in sorted(self._actions, reverse=True):
            with contextlib.suppress(Exception):
                self._actions[key]()


#: the hard exit of the run this task belongs to (set by ``cancelled_by_signals``)
_HARD_EXIT: contextvars.ContextVar[HardExit | None] = contextvars.ContextVar("hil_hard_exit", default=None)


def dump_tasks(file: TextIO | None = None) -> None:
    """Where each task of the running loop waits (its stack), on ``file`` (default stderr)."""
    out = file or sys.stderr
    tasks = asyncio.all_tasks(asyncio.get_running_loop())
    print(f"hil: {len(tasks)} tasks (SIGQUIT)", file=out)
    for task in sorted(tasks, key=lambda t: t.get_name()):
        print(f"--- {task.get_name()}: {task.get_coro()!r}", file=out)
        for line in await_chain(task.get_coro()):
            print(f"  {line}", file=out)
        waiter = getattr(task, "_fut_waiter", None)  # the future the task sleeps on (asyncio's own field)
        if waiter is not None:
            print(f"  the task waits for {waiter!r}"[:800], file=out)
    out.flush()


def await_chain(coro: object) -> list[str]:
    """Where a suspended coroutine waits: each coroutine it awaits, down to the awaited object
    (a future, a sleep), one line each. A task's own stack shows only its outermost frame."""
    lines = []
    for _ in range(64):  # an await chain is short; the bound guards a cycle
        frame = getattr(coro, "cr_frame", None) or getattr(coro, "gi_frame", None)
        if frame is None:
            lines.append(f"awaits {coro!r}"[:500])
            break
        lines.append(f"{frame.f_code.co_filename}:{frame.f_lineno} in {frame.f_code.co_name}")
        inner = getattr(coro, "cr_await", None) or getattr(coro, "gi_yieldfrom", None)
        if inner is None:
            break
        coro = inner
    return lines


def _trace_threads_on(sig: int) -> bool:
    """faulthandler's dump of every thread on ``sig``, chained to the handler before it; False
    where stderr has no file descriptor (a test's captured stream)."""
    try:
        fd = sys.stderr.fileno()
    except (AttributeError, OSError, ValueError):
        return False
    faulthandler.register(sig, file=fd, all_threads=True, chain=True)
    return True


def on_hard_exit(action: Callable[[], None]) -> Callable[[], None]:
    """Have ``action`` done if a second signal makes this run's process exit at once; returns
    the call that takes it back. Outside ``cancelled_by_signals`` it does nothing."""
    hard = _HARD_EXIT.get()
    if hard is None:
        return lambda: None
    return hard.add(action)


async def cancelled_by_signals(aw: Awaitable[_T]) -> _T:
    """Await ``aw`` with SIGINT and SIGTERM cancelling the current task meanwhile; a second
    one does the registered hard-exit actions and exits with status 130."""
    current = asyncio.current_task()
    assert current is not None
    loop = asyncio.get_running_loop()
    hard = HardExit()
    token = _HARD_EXIT.set(hard)
    signalled: list[int] = []

    def on_signal() -> None:
        if signalled:
            hard.run()
            os._exit(HARD_EXIT_STATUS)
        signalled.append(1)
        current.cancel()

    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, on_signal)
    loop.add_signal_handler(signal.SIGQUIT, dump_tasks)
    # and every thread's Python stack from the signal itself: a run whose loop is blocked in a
    # call (a pipe it reads, a child it waits for) never runs dump_tasks
    traced = _trace_threads_on(signal.SIGQUIT)
    try:
        return await aw
    except asyncio.CancelledError:
        if not signalled:
            raise
        # cancelled by a signal before the run could take it (before the flight started): the
        # process exits as a shell reports Ctrl-C, saying so, instead of with a traceback
        print("interrupted before the flight started", file=sys.stderr)
        raise SystemExit(HARD_EXIT_STATUS) from None
    finally:
        if traced:
            faulthandler.unregister(signal.SIGQUIT)
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGQUIT):
            loop.remove_signal_handler(sig)
        _HARD_EXIT.reset(token)
