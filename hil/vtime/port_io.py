"""The bytes between the bench and the flight code on the scheduled ports, settled before
the scheduler's idle verdict: everything the flight code wrote taken in, everything the bench
wrote made readable at the client's end, and the readiness of the descriptors the flight
code waits on judged after that.

Why this is exact: a pty delivers through a kernel work item, but ``poll`` on either end
first runs any pending work (n_tty_poll -> tty_buffer_flush_work). So a zero-timeout poll on
the bench's own slave descriptor says whether the client could read now.
"""

from __future__ import annotations

import select
from collections.abc import Mapping
from typing import Protocol

from hil.transport.pty import WriteLog
from hil.vtime.control import ControlBlock


class ScheduledPort(Protocol):
    """What the scheduler needs of a port (``hil.transport.pty.PtyPort``)."""

    name: str

    @property
    def master_fd(self) -> int: ...
    @property
    def slave_fd(self) -> int: ...
    @property
    def rdev_key(self) -> int: ...
    write_log: WriteLog | None
    def read_available(self) -> bool: ...
    @property
    def writes_pending(self) -> bool: ...
    def drain_queued(self) -> None: ...


class PortBytes:
    """The ports the scheduler watches (``ports``, by name), found by the device number the
    shim publishes for a wait (``by_key``) and by master descriptor (``master``), and the log
    of the bench's writes to them (``written``); ``ctl``'s epoch is bumped whenever writes
    are flushed."""

    def __init__(self, ports: Mapping[str, ScheduledPort], ctl: ControlBlock) -> None:
        self.ports = dict(ports)
        self.by_key = {p.rdev_key: p for p in self.ports.values()}
        self.master = {p.master_fd: p for p in self.ports.values()}
        self.masters = list(self.master)
        #: the bench's writes to these ports: whether anything was written since an idle
        #: verdict, and which ports to flush (no per-port polling on every check)
        self.written = WriteLog()
        for p in self.ports.values():
            p.write_log = self.written
        self._ctl = ctl

    def flush_written(self) -> bool:
        """Make every byte the bench wrote since the last call readable by the client now (a
        zero-timeout poll runs the ptys' pending flush work); bumps the epoch if any."""
        written = self.written.take()
        if written:
            select.select([p.slave_fd for p in written], [], [], 0)
            self._ctl.bump_epoch()
        return bool(written)

    def settle(self, wait_r: list[int], wait_w: list[int]) -> bool:
        """Take in everything the flight code wrote, make every byte the bench wrote readable
        at the client's end, and say whether a slave descriptor the flight code waits on
        (``wait_r`` for reading, ``wait_w`` for writing) is ready once that is done.

        One zero-timeout poll does all three: polling a pty end runs its pending flush work
        before it reports, so each descriptor is judged after its own flush. A poll that found
        flight-code bytes (a device may answer them) is followed by another, and the readiness
        of the last one counts. Bumps the epoch if the bench had written anything."""
        master = self.master
        flushed = False
        while True:
            written = self.written.take()
            fds = [*self.masters, *wait_r]
            if written:
                flushed = True
                fds.extend(p.slave_fd for p in written)
            readable, writable, _ = select.select(fds, wait_w, [], 0)
            got = False
            for fd in readable:
                port = master.get(fd)
                if port is not None:
                    port.read_available()
                    got = True
            if not got:
                break
        if flushed:
            self._ctl.bump_epoch()
        if writable:
            return True
        return any(fd in wait_r for fd in readable)
