"""The flight command's process tree as /proc shows it (hil/vtime/tree.py), and the judgement of
a process the clock shim cannot see through (hil/vtime/hidden.py)."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

from hil.vtime import abi
from hil.vtime.control import ThreadView
from hil.vtime.hidden import CONFIRM_S, StallWatch, Suspect, confirmed
from hil.vtime.stall import HiddenWait
from hil.vtime.tree import ProcessTree, parse_stat, what_it_waits_in


def _until(predicate, timeout_s: float = 30.0) -> None:
    give_up = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < give_up, "not reached in time"
        time.sleep(0.01)


def _view(pid: int, tid: int, blocked: bool, kind: abi.Wait = abi.Wait.CHILD, wait_pid: int = -1) -> ThreadView:
    return ThreadView(0, tid, pid, 1 if blocked else 0, blocked, None, 0, 0, (), 0, int(kind), wait_pid)


def test_the_tree_finds_a_launchers_children_and_drops_the_gone() -> None:
    script = f"{sys.executable} -c 'import time; time.sleep(60)' & sleep 60; echo"
    sh = subprocess.Popen(["sh", "-c", script], start_new_session=True)
    tree = ProcessTree(sh.pid)
    try:
        want = sorted(["sh", "sleep", os.path.basename(sys.executable)[:15]])
        _until(lambda: sorted(st.comm for st in (tree.state(p) for p in tree.discover({})) if st is not None) == want)
        members = tree.discover({})
        assert members[0] == sh.pid and len(members) == 3
        _until(lambda: what_it_waits_in(sh.pid) == "wait4")
        sleep = next(p for p in members if (st := tree.state(p)) is not None and st.comm == "sleep")
        _until(lambda: what_it_waits_in(sleep) == "clock_nanosleep")
        # a process with slots is known by them: here the children have none
        assert tree.all_in_slots([_view(sh.pid, sh.pid, True)]) is False
        os.kill(sleep, 9)
        _until(lambda: (st := tree.state(sleep)) is None or st.dead)
    finally:
        os.killpg(sh.pid, 9)
        sh.wait()
    _until(lambda: tree.alive() == [])
    assert tree.members == {}
    tree.close()


def test_a_zombie_keeps_the_tree_from_idle_only_while_its_waiter_is_about_to_reap_it() -> None:
    """A child that exited but is not reaped never runs again: only live members need slots.
    But the kernel marks it a zombie before it wakes a parent waiting for it, so a parent in a
    wait that takes that child is about to run, though it may still read asleep."""
    parent = subprocess.Popen([sys.executable, "-c",
                               "import os, time\nif os.fork() == 0:\n    os._exit(0)\ntime.sleep(60)"])
    tree = ProcessTree(parent.pid)
    try:
        _until(lambda: len(tree.discover({})) == 2)
        child = next(p for p in tree.discover({}) if p != parent.pid)
        _until(lambda: (st := tree.state(child)) is not None and st.dead)
        assert tree.all_in_slots([_view(parent.pid, parent.pid, True, abi.Wait.FD)]) is True  # it sleeps
        assert tree.all_in_slots([_view(parent.pid, parent.pid, True)]) is False  # wait(): it will reap it
        assert tree.all_in_slots([_view(parent.pid, parent.pid, True, wait_pid=child)]) is False
        assert tree.all_in_slots([_view(parent.pid, parent.pid, True, wait_pid=-os.getpgid(parent.pid))]) is False
        assert tree.all_in_slots([_view(parent.pid, parent.pid, True, wait_pid=child + 10**6)]) is True  # another
    finally:
        parent.kill()
        parent.wait()
        tree.close()


def test_stat_lines_with_odd_command_names_parse() -> None:
    raw = b"12 (a) b (c) S 1 12 12 0 -1 4194560 100 0 0 0 5 5 0 0 20 0 1 0 777 0 0\n"
    st = parse_stat(12, raw)
    assert st is not None and (st.comm, st.state, st.ppid, st.pgid, st.session, st.start) == ("a) b (c", "S", 1, 12, 12, 777)
    assert parse_stat(12, b"garbage") is None


def _suspect(run_ns: int = 5, syscall: bytes = b"34 0x0", shimless: bool = False, pid: int = 10) -> Suspect:
    return Suspect(pid, pid, "launcher", 99, "pause", syscall, run_ns, shimless)


def test_a_suspect_is_confirmed_only_in_the_same_wait_without_running() -> None:
    first = [_suspect()]
    assert confirmed(first, [_suspect()]) == [_suspect()]
    assert confirmed(first, [_suspect(run_ns=6)]) == []  # it ran in between: it is not stuck
    assert confirmed(first, [_suspect(syscall=b"7 0x0")]) == []  # another call
    assert confirmed(first, [_suspect(pid=11)]) == []  # another process
    # a process without the shim is suspect for being there, whatever it does
    assert confirmed([_suspect(shimless=True)], [_suspect(run_ns=9, shimless=True)]) != []


def test_the_stall_watch_reports_once_then_raises_on_a_confirmed_suspect() -> None:
    watch = StallWatch(100.0, 5.0)
    assert watch.due == 105.0 and not watch.reported
    assert watch.look(105.0, [_suspect()]) is True  # the stall warning
    assert watch.due == 105.0 + CONFIRM_S
    assert watch.look(106.0, [_suspect(run_ns=7)]) is False  # it ran: looked at again later
    with pytest.raises(HiddenWait, match=r"process 10 \(launcher\) of the flight command waits in pause"):
        watch.look(107.0, [_suspect(run_ns=7)])


def test_a_stopped_process_resets_the_watch() -> None:
    """None: a process is stopped (a debugger): nothing is confirmed across it."""
    watch = StallWatch(0.0, 5.0)
    watch.look(5.0, [_suspect()])
    assert watch.look(6.0, None) is False
    assert watch.look(7.0, [_suspect()]) is False  # first seen again after the stop
