"""The bench as the flight code's scheduler (virtual time, docs/time.md).

The flight code's clock reads sim time (the shim maps its clocks onto the control block).
The bench advances that clock only when the flight code is **idle**: every thread it has
is blocked in an interposed wait, none of those waits can end by itself (no fd it waits on
is readable, no deadline has passed), and every byte either side wrote has been taken in
(the bench drained the flight code's output; its own output is readable at the other end).
Then nothing the flight code does depends on how fast the host is, and the next event is
either the next tick or the earliest deadline the flight code is waiting for.

The flight code is the rig's command's whole process tree (``hil/vtime/tree.py``): each process
has its threads in slots, or is gone; a launcher's wait for its child or on a pipe is kernel-
confirmed (``abi.Wait.CHILD``, ``READ``); one waiting where the shim cannot see ends the run
(``hil/vtime/hidden.py``).

Why the check is exact: the bytes are settled by polls that run the ptys' pending delivery
first (``hil/vtime/port_io.py``); the shim publishes the device numbers it waits on before
it sleeps, and re-reads the slot's sequence number after the check to catch a thread that
moved meanwhile.
"""

from __future__ import annotations

import asyncio
import select
from collections.abc import Callable, Mapping

from hil import clock
from hil.vtime import hidden
from hil.vtime.control import ControlBlock, ThreadStates, ThreadView, pid_alive
from hil.vtime.port_io import PortBytes, ScheduledPort
from hil.vtime.stall import HiddenWait, ShimLost, Stall, shim_mapped
from hil.vtime.tree import ProcessTree, exited

# the port protocol and the stall records are used here and stay importable from here
__all__ = ["HiddenWait", "INLINE_BUDGET_S", "INLINE_WAIT_S", "SETTLE_FIRST_S", "SETTLE_MAX_S", "ScheduledPort",
           "ShimLost", "Stall", "VirtualClock", "resolve_pending", "shim_mapped"]

POLLIN, POLLPRI, POLLOUT = select.POLLIN, select.POLLPRI, select.POLLOUT
#: re-check pauses (wall s) while a waiter is on its way to sleep, or a process without slots lives
SETTLE_FIRST_S = 0.0001
SETTLE_MAX_S = 0.005
#: idle waits in lockstep, each a few hundred us, are made without a turn of the event loop
#: (see :meth:`VirtualClock.idle`): one wait at most this long (wall s) before the loop runs
INLINE_WAIT_S = 0.002
#: and the event loop runs at least this often (wall s) while the waits go on inline: a
#: wait that needs the loop makes the turn, or else the next wait yields to it first
INLINE_BUDGET_S = 0.010


class VirtualClock:
    """Sim time for one flight-code process tree, driven by the tick loop.

    Bench time ``t_ns`` (the plant's sim time) and the flight code's clock differ by a
    constant offset that changes once, when boot ends (``rebase``), so the flight code's
    clock never jumps while the plant starts at 0.
    """

    def __init__(
        self,
        ctl: ControlBlock,
        ports: Mapping[str, ScheduledPort],
        *,
        stall_warn_s: float = 5.0,
        on_stall: Callable[[Stall], None] | None = None,
        inline_wait_s: float = INLINE_WAIT_S,
    ) -> None:
        self.ctl = ctl
        #: the ports' bytes; the idle check and the inline waits reach its maps directly
        self._io = PortBytes(ports, ctl)
        self.ports = self._io.ports
        self._by_key = self._io.by_key
        self._master = self._io.master
        #: what ends an idle wait: a shim notification or bytes from the flight code
        self._wait_fds = [ctl.notify_fd, *self._io.masters]
        self.inline_wait_s = inline_wait_s
        #: idle waits made inline / through the event loop (the run's ``idle_waits`` metadata)
        self.inline_waits = 0
        self.loop_waits = 0
        #: the bench's writes to these ports (``PortBytes.written``)
        self._written = self._io.written
        self.offset_ns = 0
        self.t_ns = 0
        self.pid: int | None = None
        self._woken: dict[int, int] = {}  #: slot -> the seq it was woken at (wake once per wait)
        #: slot -> (tid, its CPU time at the last ``cpu_ns``), every process of the tree
        self._cpu_last: dict[int, tuple[int, int]] = {}
        #: every process the flight command started (None until a process is attached)
        self._tree: ProcessTree | None = None
        self.stall_warn_s = stall_warn_s
        self.on_stall = on_stall
        #: the shim's path: checked in /proc/<pid>/maps when the flight code stalls
        self.library: str | None = None
        self.stalls = 0
        self._loop = asyncio.get_running_loop()
        self._loop.add_reader(ctl.notify_fd, self._on_notify)
        #: loop time by which the event loop must have had a turn (waits go inline until then)
        self._turn_due = self._loop.time() + INLINE_BUDGET_S
        self._waiter: asyncio.Future[None] | None = None
        self._closed = False
        #: check_idle found a thread that published a futex wait but is not asleep in the
        #: kernel yet: it sends no further notification when it gets there, so re-check soon
        self._settling = False
        self._states = ThreadStates()  #: the kernel's view of futex-blocked threads
        #: anything that may end the flight code's idleness: a notification, a poke, a wake
        self._events = 0
        #: (events, port writes) when the flight code was last found idle, and the slots then:
        #: while both are unchanged it is still idle and its slots are as they were
        self._idle_at: tuple[int, int] | None = None
        self._snapshot: list[ThreadView] = []

    # -- clock ------------------------------------------------------------------------------------
    def start(self, t_ns: int) -> None:
        """The flight code's clock reads 0 at bench time ``t_ns``."""
        self.offset_ns = -t_ns
        self.set_time(t_ns)

    def rebase(self, old_t_ns: int, new_t_ns: int) -> None:
        """Bench time ``old_t_ns`` is called ``new_t_ns`` from now on (the flight code's clock
        is unchanged); the tick loop starts at 0 after boot."""
        self.offset_ns += old_t_ns - new_t_ns
        self.t_ns += new_t_ns - old_t_ns

    def set_time(self, t_ns: int) -> None:
        self.t_ns = t_ns
        self.ctl.set_now(t_ns + self.offset_ns)

    def fc_ns(self, t_ns: int) -> int:
        return t_ns + self.offset_ns

    # -- flight-code threads -------------------------------------------------------------------------
    def attach(self, pid: int | None) -> None:
        """The flight code process to schedule (after a start or restart)."""
        self.pid = pid
        self._woken.clear()
        self._events += 1
        if self._tree is not None:
            self._tree.close()
        self._tree = ProcessTree(pid) if pid is not None else None

    def attached(self) -> bool:
        return self.pid is not None and self.pid in self.ctl.attached_pids()

    async def wait_attached(self, timeout_s: float, running: Callable[[], bool]) -> bool:
        """Wait (wall time) until the shim in the flight-code process has mapped the block.

        The shim attaches before the program's main() and says so on the notify FIFO, so
        this takes milliseconds; a program that cannot be preloaded never does. False on
        timeout or if the process ended first."""
        loop = self._loop
        give_up = loop.time() + timeout_s
        while not self.attached():
            if not running() or loop.time() >= give_up:
                return False
            waiter = loop.create_future()
            self._waiter = waiter
            handle = loop.call_at(give_up, resolve_pending, waiter)
            try:
                await waiter
            finally:
                self._waiter = None
                handle.cancel()
        return True

    def process_gone(self, pid: int | None) -> None:
        if self._closed:
            return
        if pid is not None:
            self.ctl.clear_process(pid)
            self._states.forget(pid)
        self.poke()

    def next_deadline(self) -> int | None:
        """Bench time of the earliest deadline a blocked flight-code thread waits for."""
        deadlines = [t.deadline_ns for t in self._threads() if t.blocked and t.deadline_ns is not None]
        return min(deadlines) - self.offset_ns if deadlines else None

    def wake_due(self) -> None:
        """End the waits whose deadline sim time has reached (each wait once)."""
        now = self.fc_ns(self.t_ns)
        for t in self._threads():
            if t.blocked and t.deadline_ns is not None and t.deadline_ns <= now:
                self._wake(t)

    def _wake(self, t: ThreadView) -> None:
        if t.confirmed:
            self._events += 1  # it ends on the host clock by itself (a futex cannot wait on our
            return  # FIFO): whatever was found idle before is not any more
        if self._woken.get(t.index) != t.seq:
            self._woken[t.index] = t.seq
            self._events += 1
            self.ctl.wake(t.index)

    def cpu_ns(self) -> int:
        """Host CPU ns the flight code's tree used since the last call (as each thread last blocked)."""
        last, now, delta = self._cpu_last, {}, 0
        for t in self._threads():
            before = last.get(t.index)
            delta += t.cpu_ns - (before[1] if before is not None and before[0] == t.tid else 0)
            now[t.index] = (t.tid, t.cpu_ns)
        self._cpu_last = now
        return max(delta, 0)

    # -- bytes ------------------------------------------------------------------------------------------
    def flush_written(self) -> bool:
        """Make every byte the bench wrote since the last call readable by the client now (a
        zero-timeout poll runs the ptys' pending flush work); bumps the epoch if any."""
        return self._io.flush_written()

    # -- idle ---------------------------------------------------------------------------------------------
    def _on_notify(self) -> None:
        self.ctl.drain_notifications()
        self.poke()

    def poke(self) -> None:
        """Something changed that may end a wait for idle (a thread blocked, a process exited)."""
        self._events += 1
        waiter = self._waiter
        if waiter is not None and not waiter.done():
            waiter.set_result(None)

    def _still_idle(self) -> bool:
        """Found idle, and nothing has happened since that could change it (no notification,
        poke or wake, no byte written by the bench): the check need not be made again."""
        return self._idle_at is not None and self._idle_at == (self._events, self._written.count)

    def _threads(self) -> list[ThreadView]:
        """The slots: the snapshot of the last idle verdict while it holds, else read now."""
        return self._snapshot if self._still_idle() else self.ctl.threads()

    def check_idle(self) -> bool:
        """One exact check (see the module docstring); never waits."""
        self._settling = False
        if self._still_idle():
            return True
        self._idle_at = None
        threads = self.ctl.threads()
        root = self.pid
        if not any(t.pid == root for t in threads):
            return False  # not attached yet, or restarting: nothing to schedule
        for t in threads:
            if not t.blocked:
                if t.pid != root and not pid_alive(t.tid):  # gone (by tid: clear_process; a zombie: _clear_exited)
                    self.ctl.clear_thread(t)
                    continue
                return False
        # the descriptors its waits are on, ours only (the bench does not control when any
        # other becomes ready); judged after the bytes are settled, before the verdict
        readable: list[int] = []
        writable: list[int] = []
        by_key = self._by_key
        for t in threads:
            if t.keys is None:
                continue
            for key, events in t.keys:
                port = by_key.get(key)
                if port is None:
                    continue
                if events & (POLLIN | POLLPRI):
                    readable.append(port.slave_fd)
                if events & POLLOUT:
                    writable.append(port.slave_fd)
        ready = self._io.settle(readable, writable)
        now = self.fc_ns(self.t_ns)
        epoch = self.ctl.epoch
        for t in threads:
            if t.deadline_ns is not None and t.deadline_ns <= now:
                self._wake(t)
                return False
            if t.confirmed:
                if t.tid < 0 or not self._states.asleep(t.pid, t.tid):
                    self._settling = True  # another thread or process just woke it, or it is about to sleep
                    return False
                continue
            if t.keys is None and t.seen_epoch != epoch:
                # an epoll set: only a check made after our last write counts
                self._wake(t)
                return False
        if ready:
            return False  # it is waking up (or about to) on bytes already there
        if not all(self.ctl.seq(t.index) == t.seq for t in threads):
            return False
        if self._tree is not None:
            # last: /proc reads. A process the shim cannot see: nothing says when it exits. And the
            # walk reads after the slots: a launcher woken meanwhile (its child reaped, the next
            # forked after its children were read) makes it stale, so the slots must be unchanged.
            if not self._tree.all_in_slots(threads) or not self.ctl.unchanged(threads, self._states):
                self._settling = True
                return False
        if not any(t.confirmed and t.deadline_ns is not None for t in threads):
            # a timed futex wait ends on the host clock without telling anyone: never cached
            self._idle_at, self._snapshot = (self._events, self._written.count), threads
        return True

    async def idle(self, running: Callable[[], bool]) -> bool:
        """Wait until the flight code is idle; False if it is not running (exited, killed).

        Waits on the shim's notifications (a thread blocked) and on ``poke``; nothing polls.
        After ``stall_warn_s`` of wall time without idle, ``on_stall`` hears about it once
        (a debugger stop or a SIGSTOP is not an error: the wait goes on); a process that
        waits where the shim cannot see raises :class:`HiddenWait` once confirmed
        (``hil/vtime/hidden.py``).

        Waits are made inline (:meth:`_wait_inline`) while the event loop has had a turn
        within ``INLINE_BUDGET_S``; past that this call yields to the loop first, so a run
        whose waits all go inline still lets the loop's other work in (the tests' own tasks,
        a ``stop``, process exits) every 10 ms."""
        loop = self._loop
        if loop.time() >= self._turn_due:
            await asyncio.sleep(0)
            self._turn_due = loop.time() + INLINE_BUDGET_S
        watch: hidden.StallWatch | None = None
        settle_s = SETTLE_FIRST_S
        ask = True  # whether ``running`` may have changed: only a turn of the event loop
        while True:  # reaps a process or runs a restart, so an inline wait cannot change it
            if ask and not running():
                return False
            if self.check_idle():
                return True
            if not self._settling and loop.time() < self._turn_due and self._wait_inline():
                ask = False
                continue
            ask = True
            self._turn_due = loop.time() + INLINE_BUDGET_S  # the event loop turns below
            self.loop_waits += 1
            self._clear_exited()
            if watch is None:
                watch = hidden.StallWatch(loop.time(), self.stall_warn_s)
            waiter = loop.create_future()
            self._waiter = waiter
            # the stall warning, then a look for a hidden wait every CONFIRM_S
            handle = loop.call_at(watch.due, resolve_pending, waiter)
            # a thread between its futex-wait notification and its sleep: look again after a
            # short, growing pause (the only wait here that is not an event)
            recheck = loop.call_later(settle_s, resolve_pending, waiter) if self._settling else None
            settle_s = min(settle_s * 2, SETTLE_MAX_S) if self._settling else SETTLE_FIRST_S
            try:
                await waiter
            finally:
                self._waiter = None
                handle.cancel()
                if recheck is not None:
                    recheck.cancel()
            if loop.time() >= watch.due:
                self._look(watch)

    def _wait_inline(self) -> bool:
        """Wait for what ends an idle wait without a turn of the event loop, and handle it as
        the loop's readers and writers would: a shim notification, bytes from the flight code
        (the device models answer at once), room for bytes a port has queued. False, with
        nothing handled, if nothing came within ``inline_wait_s``: then the caller waits
        through the event loop, which also runs everything else (process exits, the stall
        timer, signals).

        Why: a lockstep tick waits for the flight code three to five times (its ADC request,
        its ESC command, each time it blocks); through asyncio each wait costs a loop
        iteration, a future and a timer (tests/bench/bench_vtime.py measures it)."""
        queued = [p.master_fd for p in self.ports.values() if p.writes_pending]
        readable, writable, _ = select.select(self._wait_fds, queued, [], self.inline_wait_s)
        if not readable and not writable:
            return False
        self.inline_waits += 1
        notify_fd = self.ctl.notify_fd
        for fd in readable:
            if fd == notify_fd:
                self._on_notify()
            else:
                self._master[fd].read_available()
        for fd in writable:
            self._master[fd].drain_queued()
        return True

    def _clear_exited(self) -> None:
        """Free the slots of the tree's zombies (killed, never freed): a /proc read each, not inline."""
        self._events += self.ctl.clear_gone(self.pid, exited)

    def _look(self, watch: hidden.StallWatch) -> None:
        """A wait for idle has lasted: the stall warning (once), or raise :class:`HiddenWait`
        for a process confirmed to wait where the shim cannot see."""
        if not watch.reported and self.pid is not None:
            hidden.check_shim(self.pid, self.library)
        found = hidden.suspects(self._tree, self.ctl.threads(), self.library) if self._tree is not None else []
        if watch.look(self._loop.time(), found):
            self.stalls += 1
            if self.on_stall is not None:
                self.on_stall(Stall(self.stall_warn_s, tuple(self.ctl.threads()), hidden.unseen_lines(found)))

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._states.close()
            if self._tree is not None:
                self._tree.close()
            self._loop.remove_reader(self.ctl.notify_fd)


def resolve_pending(fut: asyncio.Future[None]) -> None:
    """Resolve ``fut`` with None unless it is already done (a timer or wake-up callback)."""
    if not fut.done():
        fut.set_result(None)
