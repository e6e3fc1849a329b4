"""Ctrl-C and SIGTERM as a cancel of the running task (``hil run``).

A run cancelled this way ends as ``EndReason.INTERRUPTED`` and still stops the flight code,
closes its ports and finalizes its log (hil/flight/run.py); a KeyboardInterrupt raised
anywhere in the event loop would not give it that chance.
"""

from __future__ import annotations

import asyncio
import signal
from collections.abc import Awaitable
from typing import TypeVar

_T = TypeVar("_T")


async def cancelled_by_signals(aw: Awaitable[_T]) -> _T:
    """Await ``aw`` with SIGINT and SIGTERM cancelling the current task meanwhile."""
    current = asyncio.current_task()
    assert current is not None
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, current.cancel)
    try:
        return await aw
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)
