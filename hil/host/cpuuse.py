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
from collections.abc import Callable, Iterable
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
    running at both ends, or was replaced in between (a restarted flight code).

    ``others``: the pids of processes it started (a launcher's flight code): their CPU
    between the two ends is added (all of it for one started in between; one that exited
    in between is not counted)."""

    def __init__(self, pid: Callable[[], int | None], proc: Path = Path("/proc"),
                 others: Callable[[], Iterable[int]] | None = None) -> None:
        self._pid = pid
        self._proc = proc
        self._others = others
        self._start: tuple[int, int] | None = None
        self._others_start: dict[int, int] = {}

    def _other_cpu(self, pid: int) -> dict[int, int]:
        out: dict[int, int] = {}
        for other in self._others() if self._others is not None else ():
            cpu = process_cpu_ns(other, self._proc)
            if other != pid and cpu is not None:
                out[other] = cpu
        return out

    def start(self) -> None:
        pid = self._pid()
        cpu = process_cpu_ns(pid, self._proc)
        self._start = None if pid is None or cpu is None else (pid, cpu)
        self._others_start = self._other_cpu(pid) if pid is not None else {}

    def stop(self) -> int | None:
        """ns of CPU since ``start()``."""
        if self._start is None:
            return None
        pid, cpu0 = self._start
        if self._pid() != pid:
            return None
        cpu = process_cpu_ns(pid, self._proc)
        if cpu is None:
            return None
        others = sum(max(c - self._others_start.get(p, 0), 0) for p, c in self._other_cpu(pid).items())
        return max(cpu - cpu0, 0) + others
