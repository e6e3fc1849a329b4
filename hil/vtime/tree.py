"""The flight command's process tree as the kernel lists it (``/proc``).

The rig's command may be a launcher (``sh -c``, ``make``, ``strace -f``, ``gdb``) whose
children are the flight code. Virtual time must see every process of that tree, and the
bench must end every one of them. The kernel lists a thread's children in
``/proc/<pid>/task/<tid>/children`` (``CONFIG_PROC_CHILDREN``); a process is identified by its
pid and its start time (field 22 of ``stat``), so a reused pid is never taken for a member.

A member that loses its parent is reparented to the nearest subreaper (the bench, see
:func:`become_subreaper`), and stays a member: the tree is "everything the command started",
not the kernel's current parentage.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import platform
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from hil.vtime.abi import Wait
from hil.vtime.control import ThreadView

PR_SET_CHILD_SUBREAPER = 36
_CHILD = int(Wait.CHILD)

#: system call numbers of the calls a process of the tree is commonly found blocked in, by
#: machine (the first field of /proc/<pid>/syscall): the stall message names them
_SYSCALLS: Mapping[str, Mapping[int, str]] = {
    "x86_64": {
        0: "read", 1: "write", 7: "poll", 19: "readv", 23: "select", 34: "pause", 35: "nanosleep",
        43: "accept", 45: "recvfrom", 47: "recvmsg", 61: "wait4", 72: "fcntl", 73: "flock",
        101: "ptrace", 128: "rt_sigtimedwait", 130: "rt_sigsuspend", 202: "futex",
        230: "clock_nanosleep", 232: "epoll_wait", 247: "waitid", 270: "pselect6", 271: "ppoll",
        281: "epoll_pwait", 288: "accept4", 441: "epoll_pwait2",
    },
    "aarch64": {
        22: "epoll_pwait", 25: "fcntl", 32: "flock", 63: "read", 64: "write", 65: "readv",
        72: "pselect6", 73: "ppoll", 98: "futex", 101: "nanosleep", 115: "clock_nanosleep",
        117: "ptrace", 133: "rt_sigsuspend", 137: "rt_sigtimedwait", 202: "accept",
        207: "recvfrom", 212: "recvmsg", 242: "accept4", 260: "wait4", 95: "waitid",
        441: "epoll_pwait2",
    },
}


@dataclass(frozen=True)
class ProcState:
    """One process as ``/proc/<pid>/stat`` shows it."""

    pid: int
    comm: str
    state: str  #: R running, S/D asleep, T stopped, t traced-stopped, Z zombie, X dead
    ppid: int
    pgid: int
    session: int
    start: int  #: start time (clock ticks since boot): with the pid, the process's identity

    @property
    def dead(self) -> bool:
        return self.state in ("Z", "X")

    @property
    def stopped(self) -> bool:
        return self.state in ("T", "t")


def read_stat(pid: int) -> ProcState | None:
    """Process ``pid``'s stat line, or None if there is no such process."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            raw = f.read()
    except OSError:
        return None
    return parse_stat(pid, raw)


def exited(pid: int) -> bool:
    """Process ``pid`` has exited: gone, or a zombie (its threads never run again)."""
    st = read_stat(pid)
    return st is None or st.dead


def parse_stat(pid: int, raw: bytes) -> ProcState | None:
    try:
        close = raw.rindex(b")")
        comm = raw[raw.index(b"(") + 1 : close].decode(errors="replace")
        fields = raw[close + 2 :].split()
        # after "(comm) ": state ppid pgrp session ... starttime is the 20th of these
        return ProcState(pid, comm, fields[0].decode(), int(fields[1]), int(fields[2]), int(fields[3]),
                         int(fields[19]))
    except (ValueError, IndexError):
        return None


def children_of(pid: int, tids: Iterable[int] | None = None) -> set[int]:
    """The kernel's children of process ``pid`` (of the threads ``tids``, default all of them)."""
    if tids is None:
        try:
            tids = [int(t) for t in os.listdir(f"/proc/{pid}/task")]
        except OSError:
            return set()
    out: set[int] = set()
    for tid in tids:
        try:
            with open(f"/proc/{pid}/task/{tid}/children", "rb") as f:
                out.update(int(c) for c in f.read().split())
        except (OSError, ValueError):
            continue
    return out


def what_it_waits_in(pid: int, tid: int | None = None) -> str:
    """The system call thread ``tid`` of ``pid`` is blocked in, by name where known, else the
    kernel function it sleeps in (``wchan``); "running" if it is not blocked."""
    base = f"/proc/{pid}" if tid is None else f"/proc/{pid}/task/{tid}"
    try:
        with open(f"{base}/syscall", "rb") as f:
            first = f.read().split(maxsplit=1)[0].decode()
    except (OSError, IndexError):
        first = ""
    if first == "running":
        return "running"
    if first.lstrip("-").isdigit():
        number = int(first)
        name = _SYSCALLS.get(platform.machine(), {}).get(number)
        if name is not None:
            return name
        if number >= 0:
            return f"system call {number}"
    try:
        with open(f"{base}/wchan", "rb") as f:
            wchan = f.read().decode(errors="replace").strip()
    except OSError:
        wchan = ""
    return f"kernel function {wchan}" if wchan and wchan != "0" else "an unknown call"


class ProcessTree:
    """Every process the flight command started (see the module docstring).

    The virtual-time scheduler asks for the members at every idle check that is not cached, so
    the files are kept open and re-read with one ``pread`` (procfs regenerates them at offset
    0): a flight code alone costs one read per thread of its children files."""

    def __init__(self, root: int) -> None:
        self.root = root
        #: pid -> start time, for every member seen alive
        self.members: dict[int, int] = {}
        self._children_fds: dict[tuple[int, int], int] = {}
        self._stat_fds: dict[int, int] = {}
        st = self.state(root)
        if st is not None:
            self.members[root] = st.start

    def _children(self, pid: int, tids: Iterable[int]) -> list[int]:
        out: list[int] = []
        fds = self._children_fds
        for tid in tids:
            key = (pid, tid)
            fd = fds.get(key)
            try:
                if fd is None:
                    fd = fds[key] = os.open(f"/proc/{pid}/task/{tid}/children", os.O_RDONLY | os.O_CLOEXEC)
                raw = os.pread(fd, 4096, 0)
            except OSError:
                _close(fds.pop(key, None))
                continue
            if raw:  # most threads have no children: nothing to parse
                if len(raw) == 4096:  # hundreds of children: read the whole file
                    with open(f"/proc/{pid}/task/{tid}/children", "rb") as f:
                        raw = f.read()
                out.extend(int(c) for c in raw.split())
        return out

    def discover(self, threads: Mapping[int, Iterable[int]]) -> list[int]:
        """Add the descendants not known yet; returns every member. ``threads``: pid -> the
        tids the clock shim knows of it (its slots: an attached process's threads); a member
        not in it has its threads listed from /proc. A pid in ``threads`` that is not a member
        yet (a child that claimed a slot, an orphan) is taken in if it is alive."""
        for pid in threads:
            if pid not in self.members:
                self.admit(pid)
        queue = list(self.members)
        seen = set(queue)
        i = 0
        while i < len(queue):
            pid = queue[i]
            i += 1
            known = threads.get(pid)
            tids: Iterable[int]
            if known is None:
                try:
                    tids = [int(t) for t in os.listdir(f"/proc/{pid}/task")]
                except OSError:
                    continue
            else:
                tids = known if pid in known else (pid, *known)
            for child in self._children(pid, tids):
                if child not in seen:
                    seen.add(child)
                    if child in self.members or self.admit(child):
                        queue.append(child)
        return list(self.members)

    def all_in_slots(self, threads: list[ThreadView]) -> bool:
        """Every live member has slots among ``threads``: none runs or waits where the clock
        shim cannot see (a launcher's child between fork and exec, a static program). A zombie
        does not count (it never runs again), unless a waiter of the tree is about to reap it:
        the kernel marks a child a zombie before it wakes the waiter, so a waiter can still read
        asleep after its child died."""
        root = self.root
        tids: dict[int, list[int]] = {}
        for t in threads:
            known = tids.get(t.pid)
            if known is None:
                known = tids[t.pid] = []
            if t.tid > 0:  # -1: reserved by pthread_create, not started yet
                known.append(t.tid)
        if len(tids) == 1 and len(self.members) == 1 and root in tids and root in self.members:
            # the flight code alone (the common case, checked at every idle verdict): one read
            # per thread, and only children found need the whole walk
            mine = tids[root]
            if not self._children(root, mine if root in mine else (root, *mine)):
                return True
        waiters = [t for t in threads if t.blocked and t.wait_kind == _CHILD]
        for pid in self.discover(tids):
            if pid not in tids:
                st = self.state(pid)
                if st is None:
                    continue
                if not st.dead or (waiters and _reaped_soon(st, waiters)):
                    return False
        return True

    def admit(self, pid: int) -> bool:
        """Take process ``pid`` in as a member (found outside the tree: an orphan); False if gone."""
        st = self.state(pid)
        if st is None:
            return False
        self.members[pid] = st.start
        return True

    def state(self, pid: int) -> ProcState | None:
        """Member ``pid`` now; None (and it is dropped) if it is gone or its pid was reused."""
        fd = self._stat_fds.get(pid)
        try:
            if fd is None:
                fd = os.open(f"/proc/{pid}/stat", os.O_RDONLY | os.O_CLOEXEC)
                self._stat_fds[pid] = fd
            st = parse_stat(pid, os.pread(fd, 1024, 0))
        except OSError:
            st = None
        start = self.members.get(pid)
        if st is None or (start is not None and st.start != start):
            self.forget(pid)
            return None
        return st

    def alive(self) -> list[ProcState]:
        """The members that still exist (zombies included)."""
        self.discover({})
        return [st for st in (self.state(pid) for pid in list(self.members)) if st is not None]

    def forget(self, pid: int) -> None:
        self.members.pop(pid, None)
        _close(self._stat_fds.pop(pid, None))
        for key in [k for k in self._children_fds if k[0] == pid]:
            _close(self._children_fds.pop(key))

    def close(self) -> None:
        for pid in {*self.members, *self._stat_fds, *(k[0] for k in self._children_fds)}:
            self.forget(pid)


def _reaped_soon(zombie: ProcState, waiters: list[ThreadView]) -> bool:
    """A thread blocked in a wait for a child (``abi.Wait.CHILD``) will be woken by ``zombie``:
    it is that waiter's child or tracee, and the wait's target (wait4's ``pid``) takes it."""
    tracer: int | None = None
    for t in waiters:
        if zombie.ppid != t.pid:
            if tracer is None:
                tracer = _tracer(zombie.pid)
            if tracer != t.pid:
                continue
        target = t.wait_pid
        if target == -1 or target == zombie.pid or (target < -1 and zombie.pgid == -target):
            return True
        if target == 0:
            waiter = read_stat(t.pid)
            if waiter is None or waiter.pgid == zombie.pgid:
                return True
    return False


def _tracer(pid: int) -> int:
    """The process tracing ``pid`` (0: none), from /proc/<pid>/status."""
    try:
        with open(f"/proc/{pid}/status", "rb") as f:
            for line in f:
                if line.startswith(b"TracerPid:"):
                    return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        pass
    return 0


def _close(fd: int | None) -> None:
    if fd is not None:
        with contextlib.suppress(OSError):
            os.close(fd)


def set_subreaper(on: bool) -> bool:
    """Make this process the reaper of its orphaned descendants, or stop being it
    (``PR_SET_CHILD_SUBREAPER``): a process of the flight command whose parent exits is then
    reparented here, not to init, so the bench still finds it. False where refused (not Linux)."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return int(libc.prctl(PR_SET_CHILD_SUBREAPER, int(on), 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False
