"""The bench's reading of the kernel's thread states (futex-blocked flight-code threads)."""

from __future__ import annotations

import os
import subprocess
import sys
import threading

from hil.vtime.control import ThreadStates, asleep_in_kernel


def test_a_thread_asleep_on_a_lock_reads_asleep_and_a_gone_process_as_nothing_to_wait_for() -> None:
    states = ThreadStates()
    release = threading.Event()
    started = threading.Event()

    def sleeper() -> None:
        started.set()
        release.wait()

    t = threading.Thread(target=sleeper)
    t.start()
    started.wait()
    pid, tid = os.getpid(), t.native_id
    assert tid is not None
    # until the kernel has it asleep it may read running; it gets there without our help
    while not states.asleep(pid, tid):
        os.sched_yield()
    assert states.asleep(pid, tid) and asleep_in_kernel(pid, tid)  # the file is re-read, same answer
    me = threading.get_native_id()
    assert not states.asleep(pid, me)  # this thread is running while it asks
    release.set()
    t.join()
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
