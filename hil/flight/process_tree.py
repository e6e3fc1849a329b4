"""The bench owns every process the flight command starts, and ends every one of them.

The command runs in a session and process group of its own (``start_new_session``), with a
token in its environment (``HIL_FLIGHT_TREE``). While any flight runs, the bench is the
subreaper of its descendants (``PR_SET_CHILD_SUBREAPER``), so a process of the tree whose
parent exits (a launcher killed first, a daemon's double fork) is reparented to the bench,
not to init, and is still found: as a member of the tree seen before (``hil/vtime/tree.py``),
by its session, or by the token in its environment.

Ending it: SIGTERM to the group and to every member outside it, ``[flight] stop_grace_s`` of
wall time for all of them to exit, then SIGKILL to whatever is left, children found meanwhile
included; the zombies reparented to the bench are reaped. A cgroup would track the tree too,
but only where one can be made and written (root, a delegated subtree, a read-write cgroup2
mount): the session, the subreaper and /proc work for any user on any Linux.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import signal
from collections.abc import Callable

from hil import clock
from hil.vtime.tree import ProcessTree, ProcState, children_of, read_stat, set_subreaper

TOKEN_ENV = "HIL_FLIGHT_TREE"
#: wall seconds between looks while waiting for the tree to exit
POLL_S = 0.02
#: wall seconds to wait for SIGKILL to take (a process in uninterruptible sleep dies later)
KILL_WAIT_S = 2.0

_owners = [0]  #: trees owned by this process now: it is the subreaper while there is one


def carrying(token: str) -> list[int]:
    """Every live process, anywhere in /proc, whose environment carries this tree's token."""
    mark = f"{TOKEN_ENV}={token}".encode()
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/environ", "rb") as f:
                env = f.read().split(b"\0")
        except OSError:
            continue
        st = read_stat(int(entry))
        if st is not None and not st.dead and mark in env:
            found.append(int(entry))
    return found


async def end_cancelled_start(token: str) -> None:
    """A start cancelled while asyncio was still starting the command (a Ctrl-C or SIGTERM at
    that moment): asyncio killed the command's own process, but not what it had started
    already (``make``'s flight code), which the bench then owned without knowing. SIGKILL to
    every process carrying the token until none is left (``KILL_WAIT_S`` at most), reaping
    those reparented to the bench."""
    me = os.getpid()
    give_up = clock.monotonic_ns() + int(KILL_WAIT_S * 1e9)
    seen: set[int] = set()
    while True:
        pids = carrying(token)
        seen.update(pids)
        for pid in pids:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.kill(pid, signal.SIGKILL)
        for pid in children_of(me) & seen:  # a zombie's environment can no longer be read
            st = read_stat(pid)
            if st is not None and st.dead:
                with contextlib.suppress(ChildProcessError):
                    os.waitpid(pid, os.WNOHANG)
        if not pids or clock.monotonic_ns() >= give_up:
            return
        await asyncio.sleep(POLL_S)


class TreeOwner:
    """The processes of one start of the flight command (``root``: the command's own pid)."""

    def __init__(self, root: int, token: str) -> None:
        self.root = root
        self.token = token
        self.tree = ProcessTree(root)
        self._closed = False

    @staticmethod
    def hold() -> None:
        """This process reaps the orphans of the flight command from now (call before the start;
        each hold is given back by one ``release``, which ``close`` makes)."""
        if _owners[0] == 0:
            set_subreaper(True)
        _owners[0] += 1

    @staticmethod
    def release() -> None:
        _owners[0] -= 1
        if _owners[0] == 0:
            set_subreaper(False)

    def _adopt_strays(self) -> None:
        """Children of the bench that belong to this tree: its session or its token (orphans)."""
        me = os.getpid()
        for pid in children_of(me):
            if pid in self.tree.members:
                continue
            st = read_stat(pid)
            if st is None:
                continue
            if st.session == self.root or self._has_token(pid):
                self.tree.admit(pid)

    def _has_token(self, pid: int) -> bool:
        try:
            with open(f"/proc/{pid}/environ", "rb") as f:
                return f"{TOKEN_ENV}={self.token}".encode() in f.read().split(b"\0")
        except OSError:
            return False

    def live(self) -> list[ProcState]:
        """The members that have not exited (zombies are done); none once closed."""
        if self._closed:
            return []
        self._adopt_strays()
        return [st for st in self.tree.alive() if not st.dead]

    def signal(self, sig: int) -> None:
        """``sig`` to the command's process group (it catches a child forked meanwhile) and to
        every live member outside it. The group only while a member is seen in it: the root's
        pid, once reaped, may name someone else's group."""
        live = self.live()
        if any(st.pgid == self.root for st in live):
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(self.root, sig)
        for st in live:
            if st.pgid != self.root:
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.kill(st.pid, sig)

    async def wait_gone(self, timeout_s: float, root_reaped: Callable[[], bool]) -> bool:
        """Wait (wall time) until no member is left and the root has been reaped."""
        give_up = clock.monotonic_ns() + int(timeout_s * 1e9)
        while True:
            self.reap()
            if root_reaped() and not self.live():
                return True
            if clock.monotonic_ns() >= give_up:
                return False
            await asyncio.sleep(POLL_S)

    async def end(self, grace_s: float, root_reaped: Callable[[], bool]) -> list[ProcState]:
        """SIGTERM, ``grace_s`` to exit, SIGKILL to what is left; returns what survived
        SIGKILL for ``KILL_WAIT_S`` (nothing, unless a process is stuck in the kernel)."""
        self.signal(signal.SIGTERM)
        if not await self.wait_gone(grace_s, root_reaped):
            self.signal(signal.SIGKILL)
            await self.wait_gone(KILL_WAIT_S, root_reaped)
        self.reap()
        return self.live()

    def kill_now(self) -> None:
        """SIGKILL to the whole tree, without waiting (the bench exits at once)."""
        self.signal(signal.SIGKILL)

    def reap(self) -> None:
        """Reap the members that died as children of the bench (orphans reparented to it); the
        root is reaped by its own watcher."""
        me = os.getpid()
        for pid in list(self.tree.members):
            if pid == self.root:
                continue
            st = self.tree.state(pid)
            if st is not None and st.dead and st.ppid == me:
                with contextlib.suppress(ChildProcessError):
                    os.waitpid(pid, os.WNOHANG)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self.tree.close()
        self.release()
