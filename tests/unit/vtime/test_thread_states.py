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
