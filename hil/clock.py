"""The only module that reads the OS clock.

Everything else receives time as an argument (sim time, ``int`` ns) or asks this module
for host monotonic time. Pacers for realtime mode live here too.
"""

from __future__ import annotations

import queue
import threading
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # asyncio is imported where it is used: `import hil` (and `hil --help`) stays light
    import asyncio



#: Host CLOCK_MONOTONIC in ns (for emit stamps, timeouts and compute measurement). The
#: builtin itself, not a wrapper: the tick path reads it about 17 times a tick.
monotonic_ns = time.monotonic_ns


def wall_ns() -> int:
    """Unix time in ns (only for the run's start stamp and file names)."""
    return time.time_ns()


#: ``monotonic_ns`` when this module was first imported: ``hil/__init__.py`` imports it first, so
#: this is the bench's first line of Python, a few tens of ms after the interpreter started.
_IMPORTED_NS = time.monotonic_ns()


def bench_start_monotonic_ns() -> int:
    """When this bench process started, on the ``monotonic_ns`` time line. For start-up figures.

    Not the kernel's process start time: a shell that ``exec``s its last command (``sh -c
    "pip install ... && hil run"``) hands its own start time, and the whole install, to the
    program it becomes (the kernel's start time is kept across ``exec``). The first import of
    ``hil`` is this program's own start, less the interpreter's start-up (tens of ms).
    """
    return _IMPORTED_NS


#: Sleep until this close to the deadline, then spin (docs/performance.md, Realtime pacing: p99 < 1 us under RT,
#: ~16 us at normal priority; costs ~8 % of a core at 400 Hz).
SPIN_NS = 200_000


def sleep_until_ns(deadline_ns: int, spin_ns: int = SPIN_NS) -> int:
    """Block the calling thread until monotonic ``deadline_ns``; return the wake time."""
    while True:
        now = time.monotonic_ns()
        remaining = deadline_ns - now
        if remaining <= 0:
            return now
        if remaining > spin_ns:
            time.sleep((remaining - spin_ns) / 1e9)


class RealtimePacer:
    """Absolute 400 Hz deadlines for the realtime mode.

    asyncio's own timers round epoll timeouts up to whole milliseconds (docs/performance.md),
    so a helper thread sleeps to just before each deadline, spins the rest, and wakes the
    loop with ``call_soon_threadsafe``. ``wait(deadline_ns)`` returns the lateness in ns
    as observed on the event loop (including the hand-over).
    """

    def __init__(self, spin_ns: int = SPIN_NS) -> None:
        self.spin_ns = spin_ns
        self._requests: queue.SimpleQueue[tuple[int, asyncio.Future[int], asyncio.AbstractEventLoop] | None] = (
            queue.SimpleQueue()
        )
        self._thread = threading.Thread(target=self._run, name="hil-pacer", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while True:
            item = self._requests.get()
            if item is None:
                return
            deadline_ns, fut, loop = item
            sleep_until_ns(deadline_ns, self.spin_ns)
            loop.call_soon_threadsafe(_resolve, fut, deadline_ns)

    async def wait(self, deadline_ns: int) -> int:
        import asyncio

        loop = asyncio.get_running_loop()
        fut: asyncio.Future[int] = loop.create_future()
        self._requests.put((deadline_ns, fut, loop))
        return await fut

    def close(self) -> None:
        self._requests.put(None)


def _resolve(fut: asyncio.Future[int], deadline_ns: int) -> None:
    if not fut.done():
        fut.set_result(time.monotonic_ns() - deadline_ns)
