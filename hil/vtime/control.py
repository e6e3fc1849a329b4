"""The bench's side of the control block: the shared file, its FIFOs, the clock it publishes.

Files, all in the run's 0700 directory:

* ``vtime.ctl`` (0600): header + one slot per flight-code thread (``hvt_abi.h``), mapped
  MAP_SHARED by the bench and by the shim in the flight-code process;
* ``vtime.ctl.n``: FIFO, the shim writes one byte whenever a thread blocks (the bench
  reads it on its event loop);
* ``vtime.ctl.wNN``: one FIFO per slot; the bench writes one byte to end that thread's
  wait (its deadline came, or its wait set must be re-checked). The bench holds every FIFO
  open read-write, so a thread sees a hang-up only when the bench is gone.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import mmap
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Final

from hil import clock
from hil.native.frozen import by_fields
from hil.vtime import abi

#: CLOCK_MONOTONIC of the flight code at its start: far from any real uptime, so a clock
#: mix-up (a value from the host clock compared with a virtual one) is visible at once.
MONO_BASE_NS = 1_000_000 * 1_000_000_000
#: CLOCK_REALTIME of the flight code at its start: 2013-01-01T00:00:00Z, fixed so that runs
#: are reproducible (the paper's era; the MCAP's own log_time is the real run start).
REAL_BASE_NS = 1_356_998_400 * 1_000_000_000
#: TAI - UTC since 2017-01-01
TAI_OFFSET_NS = 37 * 1_000_000_000


@dataclass(frozen=True, init=False)
class ThreadView:
    """One flight-code thread as the bench sees it (a snapshot of its slot)."""

    index: int
    tid: int
    pid: int
    seq: int
    blocked: bool
    deadline_ns: int | None  #: flight-code clock, None for no deadline
    cpu_ns: int
    seen_epoch: int
    keys: tuple[tuple[int, int], ...] | None  #: (rdev key, poll events); None: not known (epoll)
    spin_yields: int
    #: how a blocked thread waits (``abi.Wait``): on fds and its wake FIFO (FD), or in a wait
    #: another thread or process ends (FUTEX, CHILD, READ: the kernel must have it asleep)
    wait_kind: int = 0
    #: a CHILD wait's target as wait4 takes it: -1 any child, >0 that pid, 0 its own group, < -1 a group
    wait_pid: int = -1

    def __init__(self, index: int, tid: int, pid: int, seq: int, blocked: bool, deadline_ns: int | None, cpu_ns: int,
                 seen_epoch: int, keys: tuple[tuple[int, int], ...] | None, spin_yields: int,
                 wait_kind: int = 0, wait_pid: int = -1) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "index", index)
        object.__setattr__(self, "tid", tid)
        object.__setattr__(self, "pid", pid)
        object.__setattr__(self, "seq", seq)
        object.__setattr__(self, "blocked", blocked)
        object.__setattr__(self, "deadline_ns", deadline_ns)
        object.__setattr__(self, "cpu_ns", cpu_ns)
        object.__setattr__(self, "seen_epoch", seen_epoch)
        object.__setattr__(self, "keys", keys)
        object.__setattr__(self, "spin_yields", spin_yields)
        object.__setattr__(self, "wait_kind", wait_kind)
        object.__setattr__(self, "wait_pid", wait_pid)

    @property
    def confirmed(self) -> bool:
        """A wait the bench cannot end and must see asleep in the kernel (not on fds)."""
        return self.wait_kind != _FD

    def __reduce__(self) -> tuple[type, tuple[object, ...]]:
        return by_fields(self)  # compiled records pickle by field (hil/native/frozen.py)


# The record's field positions and values, as plain ints: compiled, a Final name is a C static,
# where ``abi.SLOT_SEQ`` would be a lookup in another module's dict (a dozen per changed slot).
_SEQ: Final = abi.SLOT_SEQ
_NKEYS: Final = abi.SLOT_NKEYS
_KEY_RDEV: Final = abi.SLOT_KEY_RDEV
_KEY_EVENTS: Final = abi.SLOT_KEY_EVENTS
_DEADLINE: Final = abi.SLOT_DEADLINE
_TID: Final = abi.SLOT_TID
_PID: Final = abi.SLOT_PID
_STATE: Final = abi.SLOT_STATE
_CPU: Final = abi.SLOT_CPU
_SEEN_EPOCH: Final = abi.SLOT_SEEN_EPOCH
_SPIN_YIELDS: Final = abi.SLOT_SPIN_YIELDS
_WAIT_KIND: Final = abi.SLOT_WAIT_KIND
_WAIT_PID: Final = abi.SLOT_WAIT_PID
_KEYS_UNKNOWN: Final = int(abi.KEYS_UNKNOWN)
_MAX_KEYS: Final = int(abi.MAX_KEYS)
_NO_DEADLINE: Final = int(abi.NO_DEADLINE)
_BLOCKED: Final = int(abi.State.BLOCKED)
_FD: Final = int(abi.Wait.FD)


def _view(index: int, raw: tuple[int, ...]) -> ThreadView:
    """The :class:`ThreadView` of slot ``index`` from its ``abi.SLOT_STRUCT`` record."""
    seq = raw[_SEQ]
    nkeys = raw[_NKEYS]
    keys: tuple[tuple[int, int], ...] | None = None
    if nkeys != _KEYS_UNKNOWN:
        n = min(nkeys, _MAX_KEYS)
        keys = tuple((raw[_KEY_RDEV + k], raw[_KEY_EVENTS + k]) for k in range(n))
    deadline = raw[_DEADLINE]
    return ThreadView(
        index, raw[_TID], raw[_PID], seq,
        bool(seq & 1) and raw[_STATE] == _BLOCKED,
        None if deadline == _NO_DEADLINE else deadline,
        raw[_CPU], raw[_SEEN_EPOCH], keys, raw[_SPIN_YIELDS], raw[_WAIT_KIND], raw[_WAIT_PID],
    )


class ControlBlock:
    """Create, map and drive the control block of one run."""

    #: dropped by ``close`` before the map (compiled classes delete only what is listed)
    __deletable__ = ["header", "slots", "_slot_bytes", "_tids"]

    def __init__(self, run_dir: Path, *, spin_limit: int = 100_000, spin_quantum_ns: int = 100_000) -> None:
        self.path = Path(run_dir) / "vtime.ctl"
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o600)
        try:
            os.ftruncate(fd, abi.BLOCK_SIZE)
            self._map = mmap.mmap(fd, abi.BLOCK_SIZE, mmap.MAP_SHARED, mmap.PROT_READ | mmap.PROT_WRITE)
        finally:
            os.close(fd)
        self.header = abi.Header.from_buffer(self._map)
        self.slots = (abi.Slot * abi.MAX_THREADS).from_buffer(self._map, ctypes.sizeof(abi.Header))
        self._slots_at = ctypes.sizeof(abi.Header)
        self._slot_size = ctypes.sizeof(abi.Slot)
        self._slot_bytes = memoryview(self._map)[self._slots_at : abi.BLOCK_SIZE]
        #: every slot's tid, read in one C call (``tolist``) by ``threads``: a strided view
        self._tids = self._slot_bytes.cast("i")[abi.Slot.tid.offset // 4 :: self._slot_size // 4]
        #: per slot: (its record's bytes, the view made of them), reused while they are unchanged
        self._views: list[tuple[bytes, ThreadView] | None] = [None] * abi.MAX_THREADS
        h = self.header
        h.version, h.max_threads, h.slot_size = abi.VERSION, abi.MAX_THREADS, ctypes.sizeof(abi.Slot)
        h.mono_base_ns, h.real_base_ns, h.tai_offset_ns = MONO_BASE_NS, REAL_BASE_NS, TAI_OFFSET_NS
        h.spin_limit, h.spin_quantum_ns = spin_limit, spin_quantum_ns
        h.bench_pid = os.getpid()
        h.mode = abi.Mode.VIRTUAL
        h.magic = abi.MAGIC  # last: a shim maps only a complete block
        self.notify_fd = self._fifo(f"{self.path}.n")
        self.wake_fds = [self._fifo(f"{self.path}.w{i:02d}") for i in range(abi.MAX_THREADS)]
        self._closed = False

    @staticmethod
    def _fifo(path: str) -> int:
        os.mkfifo(path, 0o600)
        # read-write: never blocks on open, never reports EOF to us, and the shim's end hangs
        # up only when this descriptor is closed (the bench is gone)
        return os.open(path, os.O_RDWR | os.O_NONBLOCK | os.O_CLOEXEC)

    def env(self, library: Path, inherited: dict[str, str] | None = None) -> dict[str, str]:
        """Environment entries that make a process attach: LD_PRELOAD (kept in front of any
        preload the user has) and the block's path."""
        inherited = dict(os.environ) if inherited is None else inherited
        preload = " ".join(p for p in (str(library), inherited.get("LD_PRELOAD", "")) if p)
        return {"LD_PRELOAD": preload, "HIL_VT_CTL": str(self.path)}

    # -- the clock ----------------------------------------------------------------------------
    @property
    def now_ns(self) -> int:
        return self.header.now_ns

    def set_now(self, fc_ns: int) -> None:
        """Publish the flight code's clock (seqlock: readers retry while time_seq is odd)."""
        h = self.header
        h.time_seq += 1
        h.now_ns = fc_ns
        h.time_seq += 1

    def bump_epoch(self) -> int:
        self.header.epoch = (self.header.epoch + 1) & 0xFFFFFFFF
        return self.header.epoch

    @property
    def epoch(self) -> int:
        return self.header.epoch

    # -- threads ------------------------------------------------------------------------------
    def threads(self) -> list[ThreadView]:
        """Snapshot of every claimed slot.

        The tids say which slots are claimed (one C call for all); each claimed slot's record
        is copied whole, in memory order (``seq`` before the rest, as the seqlock-style
        re-check in the scheduler, ``seq``, expects). A record whose bytes did not change
        since the last snapshot gives the same :class:`ThreadView` (the view is a pure
        function of the record) without being unpacked. A tenth of the cost of unpacking all
        16 slots; the scheduler asks several times a tick."""
        out: list[ThreadView] = []
        views = self._views
        block, at, size = self._map, self._slots_at, self._slot_size
        for i, tid in enumerate(self._tids.tolist()):
            if not tid:
                continue
            start = at + i * size
            record = block[start : start + size]
            cached = views[i]
            if cached is not None and cached[0] == record:
                out.append(cached[1])
                continue
            raw = abi.SLOT_STRUCT.unpack(record)
            if not raw[abi.SLOT_TID]:
                continue  # released between the two reads
            view = _view(i, raw)
            views[i] = (record, view)
            out.append(view)
        return out

    def seq(self, index: int) -> int:
        return self.slots[index].seq

    def attached_pids(self) -> set[int]:
        return {s.pid for s in self.slots if s.tid}

    def clear_process(self, pid: int) -> None:
        """Free the slots of a process that is gone (killed threads never release theirs).

        A slot is judged by its thread, not by its ``pid`` field: a thread claiming a slot
        sets ``tid`` first and ``pid`` after, so for a moment a live thread's slot still
        names the process that had it before, one that may be gone."""
        for s in self.slots:
            tid = s.tid
            if tid and s.pid == pid and not pid_alive(tid):
                self.free_slot(s, tid)

    def clear_gone(self, root: int | None, gone: Callable[[int], bool]) -> int:
        """Free the slots of the running threads, not ``root``'s, that ``gone(tid)`` says have
        exited (a zombie's, killed, never freed); how many. By thread, as ``clear_process``."""
        freed = [t for t in self.threads() if not t.blocked and t.pid != root and gone(t.tid)]
        for t in freed:
            self.clear_thread(t)
        return len(freed)

    def unchanged(self, threads: list[ThreadView], states: ThreadStates) -> bool:
        """Every slot of ``threads`` is as read, and every wait the kernel must confirm is still
        asleep there (woken, a thread is runnable before it publishes anything)."""
        return all(self.seq(t.index) == t.seq and (not t.confirmed or states.asleep(t.pid, t.tid)) for t in threads)

    def clear_thread(self, view: ThreadView) -> None:
        """Free the slot of ``view``'s thread, which is gone, if that thread still holds it."""
        self.free_slot(self.slots[view.index], view.tid)

    @staticmethod
    def free_slot(slot: abi.Slot, tid: int) -> None:
        if slot.tid == tid:
            slot.state = abi.State.FREE
            slot.tid = 0

    def wake(self, index: int) -> None:
        """End thread ``index``'s wait (it re-checks its fds, then its deadline)."""
        try:
            os.write(self.wake_fds[index], b"w")
        except BlockingIOError:
            pass  # the FIFO is full of wake-ups already

    def drain_notifications(self) -> int:
        """Read the notifications that have come (bytes). A read shorter than asked for has
        emptied the FIFO, so it ends there instead of reading again to fail with EAGAIN; a
        notification after it makes the FIFO readable again."""
        n = 0
        while True:
            try:
                got = os.read(self.notify_fd, 4096)
            except BlockingIOError:
                return n
            n += len(got)
            if len(got) < 4096:
                return n

    # -- usage --------------------------------------------------------------------------------
    def calls(self) -> dict[str, int]:
        """Interposed calls the flight code made, by name (only those used)."""
        return {c.name.lower(): int(self.header.calls[c]) for c in abi.Call if self.header.calls[c]}

    def uncovered(self) -> dict[str, int]:
        return {name: n for name, n in self.calls().items() if abi.Call[name.upper()] >= abi.FIRST_UNCOVERED}

    @property
    def attached(self) -> int:
        return self.header.attached

    # -- end ----------------------------------------------------------------------------------
    def free_run(self) -> None:
        """Stop scheduling: the flight code's clocks continue at the host's rate from here and
        its waits use host timeouts (teardown: SIGTERM handling, late log lines)."""
        if self._closed or self.header.mode == abi.Mode.FREE_RUN:
            return
        self.header.free_run_host_ns = clock.monotonic_ns()
        self.header.mode = abi.Mode.FREE_RUN
        for i, s in enumerate(self.slots):
            if s.tid:
                self.wake(i)

    def close(self) -> None:
        if self._closed:
            return
        self.free_run()
        self._closed = True
        for fd in (self.notify_fd, *self.wake_fds):
            with contextlib.suppress(OSError):
                os.close(fd)
        # ctypes views keep exports of the map alive; drop them before closing it
        self._tids.release()
        self._slot_bytes.release()
        del self.header, self.slots, self._slot_bytes, self._tids
        with contextlib.suppress(BufferError):
            self._map.close()
        for p in [self.path, Path(f"{self.path}.n"), *(Path(f"{self.path}.w{i:02d}") for i in range(abi.MAX_THREADS))]:
            with contextlib.suppress(FileNotFoundError):
                p.unlink()


def asleep_in_kernel(pid: int, tid: int) -> bool:
    """True if the kernel has thread ``tid`` asleep (state S or D) or gone (no task, a zombie Z,
    dead X): a futex wake-up, a child's exit or a pipe write makes a thread runnable (R)
    before it returns to the shim."""
    try:
        with open(f"/proc/{pid}/task/{tid}/stat", "rb") as f:
            return _sleeping(f.read())
    except OSError:
        return True  # gone: nothing left to wait for (the exit is noticed separately)


def _sleeping(stat: bytes) -> bool:
    i = stat.rindex(b")") + 2  # the state letter follows "(comm) "
    # Z and X: exited, not yet reaped: it will not run again (the exit is noticed separately)
    return stat[i : i + 1] in (b"S", b"D", b"Z", b"X")


class ThreadStates:
    """:func:`asleep_in_kernel` for the threads the bench asks about every tick: each stat
    file stays open and is re-read with one ``pread`` (procfs regenerates it at offset 0),
    instead of open + read + close: about 10 us less per thread and check on this VM."""

    def __init__(self) -> None:
        self._fds: dict[tuple[int, int], int] = {}

    def asleep(self, pid: int, tid: int) -> bool:
        key = (pid, tid)
        fd = self._fds.get(key)
        try:
            if fd is None:
                fd = self._fds[key] = os.open(f"/proc/{pid}/task/{tid}/stat", os.O_RDONLY | os.O_CLOEXEC)
            return _sleeping(os.pread(fd, 1024, 0))
        except (OSError, ValueError):
            self.forget(pid)
            return True  # gone: nothing left to wait for (the exit is noticed separately)

    def forget(self, pid: int) -> None:
        """Close the files of process ``pid``'s threads (it exited or restarted)."""
        for key in [k for k in self._fds if k[0] == pid]:
            with contextlib.suppress(OSError):
                os.close(self._fds.pop(key))

    def close(self) -> None:
        for pid in {k[0] for k in self._fds}:
            self.forget(pid)


def pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except OSError as exc:
        return exc.errno == errno.EPERM
    return True
