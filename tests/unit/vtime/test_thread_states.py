"""The bench's reading of the kernel's thread states (futex-blocked flight-code threads)."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time

from hil.vtime.control import ThreadStates, asleep_in_kernel


def _in_syscall(pid: int, tid: int, number: int) -> bool:
    """The thread is blocked in system call ``number`` (/proc/<pid>/task/<tid>/syscall)."""
    with open(f"/proc/{pid}/task/{tid}/syscall", "rb") as f:
        return f.read().split(b" ", 1)[0] == str(number).encode()


def test_a_blocked_thread_reads_asleep_and_a_gone_process_as_nothing_to_wait_for() -> None:
    states = ThreadStates()
    r, w = os.pipe()
    t = threading.Thread(target=os.read, args=(r, 1))
    t.start()
    pid, tid = os.getpid(), t.native_id
    assert tid is not None
    # Wait until it is blocked in read(2) itself (syscall 0 on x86-64), not merely asleep: on
    # a loaded machine a new thread can sleep waiting for the GIL on its way there, and wake.
    while not _in_syscall(pid, tid, 0):
        time.sleep(0.001)  # releases the GIL: the thread gets to its read
    assert states.asleep(pid, tid) and asleep_in_kernel(pid, tid)
    assert states.asleep(pid, tid)  # the open file is re-read: same answer
    me = threading.get_native_id()
    assert not states.asleep(pid, me)  # this thread is running while it asks
    os.write(w, b"x")
    t.join()
    os.close(r)
    os.close(w)
    # join() returns once the thread's Python part is done; the kernel task lives on for its
    # exit, and reads running until then. Wait for the kernel to remove it.
    while os.path.exists(f"/proc/{pid}/task/{tid}"):
        os.sched_yield()
    assert states.asleep(pid, tid)  # gone: nothing to wait for (its file is closed)

    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        while not states.asleep(child.pid, child.pid):
            os.sched_yield()
    finally:
        child.kill()
        child.wait()
    assert states.asleep(child.pid, child.pid)
    states.forget(child.pid)
    states.close()
    assert states._fds == {}


def _state(pid: int) -> bytes:
    with open(f"/proc/{pid}/stat", "rb") as f:
        stat = f.read()
    return stat[stat.rindex(b")") + 2 :][:1]


def test_an_exited_unreaped_process_reads_as_nothing_to_wait_for() -> None:
    """A zombie (exited, its parent has not waited yet) will not run again: waiting for it to
    fall asleep would wait forever."""
    states = ThreadStates()
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        states.asleep(child.pid, child.pid)  # opens its stat file: the zombie is read through it
        child.kill()
        while _state(child.pid) != b"Z":  # not reaped: no wait() until the end
            os.sched_yield()
        assert states.asleep(child.pid, child.pid)
        assert asleep_in_kernel(child.pid, child.pid)
    finally:
        child.kill()
        child.wait()
        states.close()
