"""CPU used by the processes of a run over its tick loop: the bench, the flight code and the
recorder child together, against the wall time.

In lockstep the bench and the flight code take turns, and the recorder child works beside
them. So one flight keeps more than one core busy. On a host with C cores, W flights at a
time (a campaign's workers) can then be at most C / ``cores_used`` times faster than one,
whatever else is done: sharing the cores never makes a flight need less CPU
(docs/performance.md, Cores per flight).

Read from ``/proc/<pid>/stat`` (user + system time, in clock ticks of 10 ms): good to about
1 % over a few seconds of ticks.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from hil.host.procstat import STIME, UTIME, stat_fields

_NS_PER_TICK = 1_000_000_000 // os.sysconf("SC_CLK_TCK")


def process_cpu_ns(pid: int | None, proc: Path = Path("/proc")) -> int | None:
    """User + system CPU time of process ``pid`` so far (all its threads), ns; None if there
    is no such process (or no pid)."""
    fields = None if pid is None else stat_fields(pid, proc)
    if fields is None:
        return None
    try:
        return (int(fields[UTIME]) + int(fields[STIME])) * _NS_PER_TICK
    except (IndexError, ValueError):
        return None


class ChildCpu:
    """The CPU a child process used between ``start()`` and ``stop()``; None if it was not
    running at both ends, or was replaced in between (a restarted flight code)."""

    def __init__(self, pid: Callable[[], int | None], proc: Path = Path("/proc")) -> None:
        self._pid = pid
        self._proc = proc
        self._start: tuple[int, int] | None = None

    def start(self) -> None:
        pid = self._pid()
        cpu = process_cpu_ns(pid, self._proc)
        self._start = None if pid is None or cpu is None else (pid, cpu)

    def stop(self) -> int | None:
        """ns of CPU since ``start()``."""
        if self._start is None:
            return None
        pid, cpu0 = self._start
        if self._pid() != pid:
            return None
        cpu = process_cpu_ns(pid, self._proc)
        return None if cpu is None else max(cpu - cpu0, 0)
