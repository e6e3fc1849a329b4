"""Starting a subprocess so that a cancel cannot hang the start (a SIGTERM or Ctrl-C at the
moment ``hil run`` starts the flight command).

Python 3.11's asyncio, cancelled inside ``subprocess_exec`` while it connects the child's pipes,
kills the child and then waits, in its own clean-up, for the transport to finish; a transport
finishes only once every pipe it connected has closed, and the ones it never connected never
do (CPython gh-125502, gh-103847). The start then never ends: ``hil run`` sat idle after a
SIGTERM at a launcher's boot, its one task cancelling. Here the cancel waits for the start to
finish (connecting takes a few loop iterations), ends what was started, and is raised then.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T", bound=asyncio.SubprocessTransport)
P = TypeVar("P", bound=asyncio.BaseProtocol)


async def uncancelled_start(spawn: asyncio.Future[tuple[T, P]],
                            end: Callable[[T], Any] = lambda transport: transport.close()) -> tuple[T, P]:
    """``spawn``'s (transport, protocol), a future of ``loop.subprocess_exec`` started as its own
    task. Cancelled meanwhile: the start finishes first, ``end(transport)`` ends what it
    started (by default ``close``: SIGKILL to the command's own process), then CancelledError."""
    cancels = 0
    while not spawn.done():
        try:
            await asyncio.shield(spawn)
        except asyncio.CancelledError:
            cancels += 1
        except BaseException:  # noqa: BLE001 - the start failed: spawn holds it, raised below
            break
    if cancels:
        if not spawn.cancelled() and spawn.exception() is None:
            end(spawn.result()[0])
        raise asyncio.CancelledError
    return spawn.result()


__all__ = ["uncancelled_start"]
