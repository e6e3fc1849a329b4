"""The recorder in its own process: the tick path pays one pickle per tick, nothing more.

A :class:`~hil.record.writer.Recorder` in a thread shares the bench's GIL: while its
writer encodes and compresses, the event loop waits for the GIL when the flight code's ADC
request arrives, and that wait lands in the flight code's response time (measured on the
bench: ~360 -> ~650 us median). Here the same Recorder runs in a forked child; the bench
gathers a tick's messages into a list, pickles it (tens of microseconds) and writes the
bytes to the child's pipe without blocking (enlarged to ``PIPE_BYTES``). No thread: a sender
thread cost a GIL hand-over per tick, paid on the tick path and in the flight code's response
time. When the child falls behind and the pipe is full, the rest waits in a local buffer that
the next tick's write sends first; past ``backlog_max`` bytes the write blocks (back-pressure,
nothing dropped). Deferred payloads (callables) are pickled as they are and built in the child.

Crash safety is the Recorder's: the child gets SIGKILL with the bench (PR_SET_PDEATHSIG), so
a killed run leaves a torn ``.part`` that ``hil recover`` salvages; Ctrl-C in a terminal is
ignored by the child (the bench closes it cleanly).
"""

from __future__ import annotations

import ctypes
import dataclasses
import os
import pickle
import fcntl
import signal
import struct
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hil.record.topics import topic_spec, wire_topic
from hil.record.writer import Recorder, RecordStats

if TYPE_CHECKING:
    from hil.live.topics import LiveConfig

_LEN = struct.Struct("<I")
_BATCH = 0
_CLOSE = 1
PR_SET_PDEATHSIG = 1
F_SETPIPE_SZ = 1031
#: the command pipe's capacity: about a second of recording, so a busy child does not stall
#: the tick path (the kernel caps it at /proc/sys/fs/pipe-max-size, 1 MiB by default)
PIPE_BYTES = 1 << 20
_KNOWN_WIRE: set[tuple[str, str]] = set()


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        n = os.write(fd, view)
        view = view[n:]


def _read_exact(fd: int, n: int) -> bytes | None:
    chunks: list[bytes] = []
    while n:
        chunk = os.read(fd, n)
        if not chunk:
            return None
        chunks.append(chunk)
        n -= len(chunk)
    return b"".join(chunks)


def _close_others(keep: tuple[int, ...]) -> None:
    """Close every fd from 3 up but ``keep``: the bench's ptys and files are none of ours."""
    low = 3
    for fd in sorted(keep):
        os.closerange(low, fd)
        low = fd + 1
    os.closerange(low, 65536)


def _child(cmd_fd: int, result_fd: int, path: Path, kwargs: dict[str, Any], live: LiveConfig | None = None,
           steer_fd: int = -1, end_unix_ns: int = 0) -> None:
    """The child process: a Recorder fed from the command pipe (and the live server beside it)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the bench's to handle
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except OSError:
        pass
    _close_others((cmd_fd, result_fd, steer_fd) if live is not None else (cmd_fd, result_fd))
    rec = Recorder(path, **kwargs, writer_thread=False)  # this process only records
    error = ""
    server = None
    try:
        rec.start()
        if live is not None:
            from hil.live.server import LiveServer

            server = LiveServer(live, run_start_unix_ns=kwargs["run_start_unix_ns"], end_unix_ns=end_unix_ns,
                                steer_fd=steer_fd)
            port = server.start()
            rec.mirror = server.mirror
    except BaseException as exc:  # reported to the parent, which raises it
        _write_all(result_fd, pickle.dumps(("error", repr(exc))))
        os._exit(1)
    _write_all(result_fd, pickle.dumps(("started", port if server is not None else 0)))
    final: dict[str, str] | None = None
    while True:
        head = _read_exact(cmd_fd, _LEN.size)
        if head is None:
            error = "the bench closed the pipe without closing the recording"
            break
        body = _read_exact(cmd_fd, _LEN.unpack(head)[0])
        if body is None:
            error = "torn message from the bench"
            break
        kind, payload = pickle.loads(body)
        if kind == _CLOSE:
            final = payload
            break
        rec.write_now(payload)  # wire bytes: topic None, item = (port, direction, data)
    if final is None:
        final = {"status": "aborted", "error": error}
    try:
        stats = rec.close(final)
        _write_all(result_fd, pickle.dumps(("stats", stats)))
    except BaseException as exc:
        _write_all(result_fd, pickle.dumps(("error", repr(exc))))
    if server is not None:
        server.close()
    os._exit(0)


class ProcessBatch:
    """A tick's messages; ``flush()`` pickles them and writes the bytes to the child."""

    __slots__ = ("_items", "_owner")

    def __init__(self, owner: ProcessRecorder) -> None:
        self._owner = owner
        self._items: list[tuple[str | None, int, int, Any]] = []

    def log(self, topic: str, t_ns: int, payload: dict[str, Any] | Callable[[], dict[str, Any]], t_host_ns: int) -> None:
        if topic not in self._owner.topics:
            topic_spec(topic)  # raises UnknownTopicError with the message
        self._items.append((topic, t_ns, t_host_ns, payload))

    def log_wire(self, port: str, direction: str, t_ns: int, t_host_ns: int, data: bytes) -> None:
        if (port, direction) not in _KNOWN_WIRE:
            wire_topic(port, direction)  # raises UnknownTopicError
            _KNOWN_WIRE.add((port, direction))
        self._items.append((None, t_ns, t_host_ns, (port, direction, bytes(data))))

    def __len__(self) -> int:
        return len(self._items)

    def flush(self) -> None:
        if self._items:
            items, self._items = self._items, []
            self._owner._send(_BATCH, items)


class ProcessRecorder:
    """Same life cycle and tick-path API as :class:`Recorder` (``start``, ``batch``, ``log``,
    ``log_wire``, ``close``), with the writing done by a child process."""

    def __init__(
        self,
        path: Path,
        *,
        run_start_unix_ns: int,
        metadata: dict[str, str],
        attachments: Iterable[tuple[str, str, bytes]] = (),
        chunk_size: int = 65536,
        queue_max: int = 200_000,
        backlog_max: int = 64 << 20,
        live: LiveConfig | None = None,
        duration_ns: int = 0,
    ) -> None:
        from hil.record.topics import TOPICS

        self.path = Path(path)
        self.topics = set(TOPICS)
        #: Unix ns of sim time 0 (the app's timeline: log time = this + sim time)
        self.run_start_unix_ns = run_start_unix_ns
        self._kwargs: dict[str, Any] = {
            "run_start_unix_ns": run_start_unix_ns,
            "metadata": dict(metadata),
            "attachments": list(attachments),
            "chunk_size": chunk_size,
            "queue_max": queue_max,
        }
        self._pid: int | None = None
        self._cmd_fd = -1
        self._result_fd = -1
        #: bytes the full pipe could not take yet (sent first by the next write)
        self._backlog = bytearray()
        self._backlog_batches = 0  #: batches with bytes in the backlog
        self.backlog_max = backlog_max
        self.backlog_peak = 0  #: the largest the backlog got, bytes
        self._stats: RecordStats | None = None
        self.dropped = 0  #: batches that could not be handed to the child (it died)
        self._single = ProcessBatch(self)
        #: ``hil run --live``: the live server's settings; its port once started, and the
        #: read end of the pipe its app commands come on (hil/live/steer.py takes it with
        #: :meth:`take_steer_fd`; closed here if no one did)
        self.live = live
        self.live_port = 0
        self.steer_fd = -1
        self._end_unix_ns = run_start_unix_ns + max(duration_ns, 0)

    @property
    def pid(self) -> int | None:
        """The writing child's process id while it runs (its CPU is the recording's cost)."""
        return self._pid

    # -- life cycle ------------------------------------------------------------------------------
    def start(self) -> None:
        cmd_r, cmd_w = os.pipe()
        res_r, res_w = os.pipe()
        steer_r, steer_w = os.pipe() if self.live is not None else (-1, -1)
        pid = os.fork()
        if pid == 0:  # pragma: no cover - the child (exits via os._exit)
            try:
                os.close(cmd_w)
                os.close(res_r)
                _child(cmd_r, res_w, self.path, self._kwargs, self.live, steer_w, self._end_unix_ns)
            finally:
                os._exit(1)
        os.close(cmd_r)
        os.close(res_w)
        if steer_w >= 0:
            os.close(steer_w)
        self._pid, self._cmd_fd, self._result_fd, self.steer_fd = pid, cmd_w, res_r, steer_r
        kind, detail = self._result()
        if kind != "started":
            self._reap()
            self._close_steer()
            raise OSError(f"recorder process could not start {self.path}: {detail}")
        self.live_port = int(detail or 0)
        try:
            fcntl.fcntl(cmd_w, F_SETPIPE_SZ, PIPE_BYTES)
        except OSError:
            pass  # a lower pipe-max-size: the default 64 KiB, and the backlog takes the rest
        os.set_blocking(cmd_w, False)

    def _result(self) -> tuple[str, Any]:
        data = bytearray()
        while True:
            chunk = os.read(self._result_fd, 65536)
            if not chunk:
                break
            data += chunk
            try:
                return pickle.loads(bytes(data))  # type: ignore[no-any-return]
            except (pickle.UnpicklingError, EOFError):
                continue
        return ("error", "the recorder process ended without a result")

    def _reap(self) -> None:
        if self._pid is not None:
            try:
                os.waitpid(self._pid, 0)
            except ChildProcessError:
                pass
            self._pid = None

    def take_steer_fd(self) -> int:
        """The steering pipe's read end, now the caller's to close (-1: none, or taken)."""
        fd, self.steer_fd = self.steer_fd, -1
        return fd

    def _close_steer(self) -> None:
        if self.steer_fd >= 0:
            os.close(self.steer_fd)
            self.steer_fd = -1

    # -- tick path --------------------------------------------------------------------------------
    def batch(self) -> ProcessBatch:
        return ProcessBatch(self)

    def log(self, topic: str, t_ns: int, payload: dict[str, Any], t_host_ns: int) -> None:
        self._single.log(topic, t_ns, payload, t_host_ns)
        self._single.flush()

    def log_wire(self, port: str, direction: str, t_ns: int, t_host_ns: int, data: bytes) -> None:
        self._single.log_wire(port, direction, t_ns, t_host_ns, data)
        self._single.flush()

    def _send(self, kind: int, payload: Any) -> None:
        body = pickle.dumps((kind, payload), protocol=pickle.HIGHEST_PROTOCOL)
        data = _LEN.pack(len(body)) + body
        backlog = self._backlog
        if self._cmd_fd < 0:
            self.dropped += 1
            return
        if backlog:
            backlog += data
            self._backlog_batches += 1
            self._write_backlog()
        else:
            try:
                n = os.write(self._cmd_fd, data)
            except BlockingIOError:
                n = 0
            except OSError:  # the child died: count what could not be handed over
                self._child_gone()
                return
            if n < len(data):
                backlog += memoryview(data)[n:]
                self._backlog_batches = 1
        if len(backlog) > self.backlog_peak:
            self.backlog_peak = len(backlog)
        if len(backlog) > self.backlog_max:
            self._drain_blocking()  # the child is far behind: wait for it rather than grow

    def _write_backlog(self) -> None:
        backlog = self._backlog
        try:
            n = os.write(self._cmd_fd, backlog)
        except BlockingIOError:
            return
        except OSError:
            self._child_gone(in_backlog=True)
            return
        del backlog[:n]
        if not backlog:
            self._backlog_batches = 0

    def _drain_blocking(self) -> None:
        """Hand the whole backlog over, waiting for the child to read it."""
        if self._cmd_fd < 0 or not self._backlog:
            return
        os.set_blocking(self._cmd_fd, True)
        try:
            _write_all(self._cmd_fd, bytes(self._backlog))
            self._backlog.clear()
            self._backlog_batches = 0
        except OSError:
            self._child_gone(in_backlog=True)
        finally:
            os.set_blocking(self._cmd_fd, False)

    def _child_gone(self, *, in_backlog: bool = False) -> None:
        """The pipe broke (the child died): the pending batches (and this one, unless it is
        among them) are lost, and counted."""
        self.dropped += self._backlog_batches + (0 if in_backlog else 1)
        self._backlog.clear()
        self._backlog_batches = 0

    # -- end --------------------------------------------------------------------------------------
    def close(self, final_metadata: dict[str, str] | None = None) -> RecordStats:
        """Hand over what is queued, close the recording in the child, return its stats."""
        self._close_steer()  # a steering pipe no one took (the run ended before its steering began)
        if self._stats is not None:
            return self._stats
        if self._pid is None:
            raise RuntimeError("ProcessRecorder.close() before start()")
        self._send(_CLOSE, {k: str(v) for k, v in (final_metadata or {}).items()})
        self._drain_blocking()
        os.close(self._cmd_fd)
        kind, detail = self._result()
        os.close(self._result_fd)
        self._reap()
        if kind != "stats":
            raise OSError(f"recorder process failed to finish {self.path}: {detail}")
        stats: RecordStats = detail
        if self.dropped:
            stats = dataclasses.replace(stats, dropped=stats.dropped + self.dropped)
        self._stats = stats
        return stats
