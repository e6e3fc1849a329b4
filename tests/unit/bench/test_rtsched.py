"""Realtime scheduling (hil/host/rtsched.py): the tick loop's thread, and what it starts, on
SCHED_FIFO where the host allows it, put back afterwards, and a clear refusal where
``policy = "fifo"`` asks for what the host does not give."""

from __future__ import annotations

import errno
import os
import subprocess
import sys
import threading

import pytest

from hil.host.rtsched import RealtimePriority, RtPolicy, RtSchedError, fifo_allowed

FIFO = os.SCHED_FIFO


def _refuse(pid: int, policy: int, param: os.sched_param) -> None:
    raise PermissionError(errno.EPERM, "Operation not permitted")


def _host_allows_fifo() -> bool:
    return fifo_allowed(10)


def test_auto_on_a_host_that_refuses_runs_as_before_and_says_why() -> None:
    before = (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)
    rt = RealtimePriority(RtPolicy.AUTO, 50, setscheduler=_refuse)
    with rt as got:
        assert got.policy is RtPolicy.NORMAL
        assert (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority) == before
    assert "SCHED_FIFO priority 50 was refused" in got.reason and "ulimit -r" in got.reason
    assert got.describe().startswith("SCHED_OTHER (")


def test_fifo_on_a_host_that_refuses_is_an_error_before_anything_runs() -> None:
    rt = RealtimePriority(RtPolicy.FIFO, 50, setscheduler=_refuse)
    with pytest.raises(RtSchedError, match="needs root, CAP_SYS_NICE or a real-time priority limit of at least 50"):
        rt.probe()
    with pytest.raises(RtSchedError):
        rt.__enter__()


def test_normal_never_asks() -> None:
    asked: list[int] = []
    with RealtimePriority(RtPolicy.NORMAL, 50, setscheduler=lambda pid, p, prm: asked.append(pid)) as got:
        pass
    assert got.policy is RtPolicy.NORMAL and asked == []


def test_the_thread_and_what_it_starts_are_raised_for_the_block() -> None:
    """Where the host allows it (root or CAP_SYS_NICE, as CI): the calling thread runs FIFO in
    the block and is put back after it; a thread (the realtime pacer's) and a process (the
    flight code) started in the block inherit it."""
    if not _host_allows_fifo():
        got = RealtimePriority(RtPolicy.AUTO, 10).__enter__()
        assert got.policy is RtPolicy.NORMAL and "refused" in got.reason
        return
    before = (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)
    seen: list[tuple[int, int]] = []

    def in_thread() -> None:
        seen.append((os.sched_getscheduler(0), os.sched_getparam(0).sched_priority))

    with RealtimePriority(RtPolicy.AUTO, 10) as got:
        assert got.policy is RtPolicy.FIFO and got.describe() == "SCHED_FIFO priority 10"
        assert (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority) == (FIFO, 10)
        thread = threading.Thread(target=in_thread)
        thread.start()
        thread.join()
        child = subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.read()"], stdin=subprocess.PIPE)
        try:
            assert (os.sched_getscheduler(child.pid), os.sched_getparam(child.pid).sched_priority) == (FIFO, 10)
        finally:
            child.communicate(b"")
    assert seen == [(FIFO, 10)]
    assert (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority) == before


def test_hil_perf_s_bare_pacer_runs_on_the_realtime_run_s_scheduling() -> None:
    """`hil perf` compares the realtime run's lateness with the bare pacer's: both on the same
    scheduling, and the thread is put back after the pacer's loop."""
    from hil.perf.measure import bare_timer_loop

    before = (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)
    rt = RealtimePriority(RtPolicy.AUTO, 10)
    late_us = bare_timer_loop(20, 1_000_000, priority=rt)
    assert late_us.shape == (20,) and (late_us >= 0).all()
    assert rt.result is not None and rt.result.policy is (RtPolicy.FIFO if _host_allows_fifo() else RtPolicy.NORMAL)
    assert (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority) == before
