"""Steal time: how long the hypervisor kept this virtual machine's CPUs from running.

On a virtual machine the host schedules each virtual CPU as one of its own threads. While
the host runs something else, a guest thread that was running or about to run simply stops:
no guest priority (``SCHED_FIFO``), no CPU latency request, nothing inside the guest can
prevent it or even see it happen, except afterwards, in the time the kernel books as
*steal* (KVM's paravirtual steal clock and its kin, summed per CPU in ``/proc/stat``).

A realtime run with its tick loop and flight code at ``SCHED_FIFO`` on an otherwise quiet
guest has nothing left inside the guest that can hold it up for milliseconds, so samples
without a command in such a run come with steal time (tests/bench/bench_realtime_steal.py
splits N realtime hovers by it, docs/time.md). A run reports the steal time it saw
(``timing["host_steal_ms"]``), and a realtime run whose misses came with steal time says so
in a note.

Units: ``/proc/stat`` counts in clock ticks (``USER_HZ``, 100 per second on Linux), so a
figure is a multiple of 10 ms and, each CPU's count being truncated, a pause shorter than a
clock tick can read 0. Hosts that are not virtual machines count 0; kernels that do not
count steal time (a column missing) give None.
"""

from __future__ import annotations

import os
from pathlib import Path

#: the kernel's per-CPU time accounting
PROC_STAT = Path("/proc/stat")
#: the steal column's index among the values of a ``cpu`` line (user nice system idle iowait
#: irq softirq steal guest guest_nice; proc(5))
_STEAL = 7


def read_steal_ms(path: Path = PROC_STAT) -> float | None:
    """Steal time of all CPUs together since boot, ms; None where it is not counted (no such
    file, or a kernel without the column)."""
    try:
        with open(path, "rb") as f:
            first = f.readline().split()
    except OSError:
        return None
    # the first line is the sum over CPUs: "cpu  user nice system idle iowait irq softirq steal ..."
    if len(first) <= _STEAL + 1 or first[0] != b"cpu":
        return None
    try:
        ticks = int(first[_STEAL + 1])
    except ValueError:
        return None
    return ticks * 1000.0 / os.sysconf("SC_CLK_TCK")


class StealMeter:
    """Steal time over a stretch of a run: ``start()``, then ``stop()`` returns the ms (None
    where the host does not count it, or if it was never started)."""

    def __init__(self, path: Path = PROC_STAT) -> None:
        self.path = path
        self._start_ms: float | None = None

    def start(self) -> None:
        self._start_ms = read_steal_ms(self.path)

    def stop(self) -> float | None:
        if self._start_ms is None:
            return None
        end = read_steal_ms(self.path)
        return None if end is None else max(end - self._start_ms, 0.0)


def realtime_note(steal_ms: float, late_ticks: int, no_command: int) -> str | None:
    """A realtime run's note when its misses came with steal time, else None."""
    if steal_ms <= 0 or (late_ticks == 0 and no_command == 0):
        return None
    return (f"the hypervisor kept this machine's CPUs from running for {steal_ms:.0f} ms during the run "
            f"(steal time, /proc/stat): no priority inside a virtual machine prevents that, and its "
            f"{late_ticks} late ticks and {no_command} samples without a command may come from it "
            "(docs/time.md, \"Steal time\")")
