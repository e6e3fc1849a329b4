"""Races between the bench's idle verdict and the flight command's processes.

The bench frees the slots of threads that are gone, and only those. A thread claiming a slot sets its ``tid`` first and its ``pid`` after (hil/vtime/shim.c,
``claim``), so for a moment a live thread's slot names the process that held the slot before,
which may be gone. Judged by that ``pid``, the bench freed the slot under the live thread,
which then waited where the bench no longer looked: a launcher's flight code hung at boot, or
a forked child was reported as never having loaded the shim (about 1 run in 30 beside CPU
hogs).

The verdict reads /proc after the slots (the launcher's children), so a launcher that woke
meanwhile makes it stale: strace, done with its probe child and forking the flight code while
the bench read its children, was judged idle with no child outside the slots (the tracer test
failed in about half its runs on this machine)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from hil.vtime import abi
from hil.vtime.control import ControlBlock, asleep_in_kernel
from hil.vtime.scheduler import VirtualClock


@pytest.fixture
def ctl(tmp_path: Path) -> Iterator[ControlBlock]:
    block = ControlBlock(tmp_path)
    try:
        yield block
    finally:
        block.close()


@pytest.fixture
def live() -> Iterator[int]:
    """The pid of a live process (its main thread's tid), asleep in a read."""
    proc = subprocess.Popen([sys.executable, "-c", "import sys; print(flush=True); sys.stdin.read()"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        assert proc.stdout is not None and proc.stdout.readline() == b"\n"
        deadline = time.monotonic() + 30
        # the state, not a pause: from its print to its read it is runnable for a moment
        while not asleep_in_kernel(proc.pid, proc.pid):
            assert time.monotonic() < deadline, "the reader never went to sleep"
            os.sched_yield()
        yield proc.pid
    finally:
        proc.kill()
        proc.wait()


def _reaped_pid() -> int:
    proc = subprocess.Popen(["true"])
    proc.wait()
    return proc.pid


def _block(ctl: ControlBlock, index: int, pid: int, kind: abi.Wait) -> None:
    """Slot ``index`` as thread ``pid`` leaves it blocked in a ``kind`` wait."""
    s = ctl.slots[index]
    s.tid, s.pid, s.state, s.seq, s.wait_kind, s.wait_pid = pid, pid, abi.State.BLOCKED, 1, kind, -1
    s.deadline_ns, s.nkeys = abi.NO_DEADLINE, 0


def _claim(ctl: ControlBlock, index: int, tid: int, pid: int) -> None:
    """Slot ``index`` as a thread leaves it mid-claim: its tid, running, the old owner's pid."""
    s = ctl.slots[index]
    s.tid, s.pid, s.state = tid, pid, abi.State.RUNNING


async def test_a_live_thread_keeps_a_slot_that_still_names_a_process_that_is_gone(ctl: ControlBlock, live: int) -> None:
    gone = _reaped_pid()
    _claim(ctl, 3, live, gone)
    ctl.clear_process(gone)
    assert ctl.slots[3].tid == live

    vc = VirtualClock(ctl, {})
    vc.attach(live + 10**6)  # another root: the claim is a process of the tree
    try:
        vc.check_idle()
        assert ctl.slots[3].tid == live, "the idle check freed a live thread's slot"
        vc._clear_exited()
        assert ctl.slots[3].tid == live, "the zombie sweep freed a live thread's slot"
    finally:
        vc.close()


async def test_the_slot_of_a_thread_that_is_gone_is_freed(ctl: ControlBlock, live: int) -> None:
    gone = _reaped_pid()
    _claim(ctl, 1, gone, gone)
    _claim(ctl, 2, live, live)
    vc = VirtualClock(ctl, {})
    vc.attach(live)
    try:
        vc.check_idle()
        assert (ctl.slots[1].tid, ctl.slots[2].tid) == (0, live)
        _claim(ctl, 1, gone, gone)
        vc._clear_exited()
        assert (ctl.slots[1].tid, ctl.slots[2].tid) == (0, live)
        _claim(ctl, 1, gone, gone)
        ctl.clear_process(gone)
        assert (ctl.slots[1].tid, ctl.slots[2].tid) == (0, live)
    finally:
        vc.close()


async def test_a_launcher_that_moves_while_the_bench_reads_its_children_is_not_idle(ctl: ControlBlock,
                                                                                     live: int) -> None:
    """The launcher (``live``, asleep in the kernel) waits for a child; while the bench walks
    /proc its wait ends and it blocks again (a new seq): the walk's finding is stale."""
    _block(ctl, 0, live, abi.Wait.CHILD)
    vc = VirtualClock(ctl, {})
    vc.attach(live)
    assert vc._tree is not None
    walk = vc._tree.all_in_slots

    def moving(threads: list) -> bool:
        found = walk(threads)
        ctl.slots[0].seq += 2  # woke, forked, blocked again: all after the slots were read
        return found

    try:
        assert vc.check_idle(), "the launcher alone, asleep in its wait, is idle"
        vc._idle_at = None
        vc._tree.all_in_slots = moving  # type: ignore[method-assign]
        assert not vc.check_idle(), "a verdict on slots that changed during the /proc walk"
    finally:
        vc.close()
