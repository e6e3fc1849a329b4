"""The ``Recorder``: one MCAP file per run, its life cycle and its tick-path API; the file is
written by a background thread fed through a bounded queue.

The tick path only calls ``log``/``log_wire``/``log_truth`` (or a ``RecordBatch``,
hil/record/routes.py): a topic check and a queue put (no encoding, no I/O). The writer
thread (hil/record/emit.py) encodes (protobuf or JSON, per topic: topics.py; payload.py),
stamps, gathers wire bytes into 100 ms messages and adds messages to an
``mcap.writer.Writer`` (zstd chunks of at most ``chunk_size`` uncompressed bytes, 64 KiB by
default: a 1 MiB chunk flush stalls for milliseconds, docs/performance.md, Recording; zstd level:
zstd_level.py).

File life cycle (docs/recording.md; MCAP spec https://mcap.dev/spec: summary and footer last):

* ``start()`` creates ``<path>.part``, writes the header, the ``run`` metadata and the
  attachments straight to the OS, so a SIGKILLed run still has them;
* every finished chunk goes straight to the OS too (an unbuffered sink), so a killed run
  loses at most the open chunk plus what is still queued; ``hil.record.recover`` salvages it;
* ``close()`` drains the queue, writes the ``verdict`` (caller's) and ``summary`` (counts)
  metadata, the summary section and footer, fsyncs and renames ``.part`` -> ``path``.

Times: ``log_time = run_start_unix_ns + t_ns`` (sim time; clamped so it never goes backwards
on a channel, clamps are counted), ``publish_time = t_host_ns`` (host monotonic), and both
are written into payloads as the topic table says (``topics.Stamp``).

Nothing is dropped silently: a full queue, an unencodable payload, a write failure or a
log() after close() are counted per topic; the counts are in the ``summary`` metadata
record and in ``close()``'s ``RecordStats``.
"""

from __future__ import annotations

import enum
import os
import queue
import threading
import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any

from mcap.records import Channel, Schema
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer

import hil
from hil.record.emit import MessageEmitter, SinkProxy, record_size
from hil.record.mcap_append import MessageAppender
from hil.record.payload import str_dict
from hil.record.protobuf import encoder as protobuf_encoder
from hil.record.routes import STOP, Kind, QueueItem, RecordBatch, Route
from hil.record.topics import TOPICS, Encoding, UnknownTopicError, topic_spec, wire_topic
# executes the one patch of mcap.writer's zstandard (chunks at ZSTD_LEVEL) before any Writer exists
from hil.record.zstd_level import ZSTD_LEVEL
from hil.transport.base import WireRecord

_LIBRARY = f"mav-hil-bench/{hil.__version__} mcap-python"
#: The MCAP header's profile: this project's conventions (docs/recording.md "Profile"): JSON
#: messages described by JSON Schema, log_time = run start + sim time, the topic table of
#: hil/record/topics.py. Not one of MCAP's well-known ROS profiles, which would promise ROS types.
PROFILE = "mav-hil"
#: A log holds a whole flight (rig, gains, every byte): owner read/write, group read, nothing
#: for others; the process umask narrows it further (umask 077 -> 0600).
LOG_FILE_MODE = 0o640


class RecordWriteError(RuntimeError):
    """The file could not be written (disk full, I/O error); the ``.part`` file is kept."""


class _State(enum.Enum):
    NEW = "new"
    RUNNING = "running"
    CLOSED = "closed"


# (state, action) -> next state; anything else is a programming error
_TRANSITIONS: dict[tuple[_State, str], _State] = {
    (_State.NEW, "start"): _State.RUNNING,
    (_State.NEW, "close"): _State.CLOSED,
    (_State.RUNNING, "close"): _State.CLOSED,
}


@dataclass(frozen=True)
class RecordStats:
    """Result of ``Recorder.close()``. Counts per topic include topics with zero messages."""

    messages_by_topic: dict[str, int]
    dropped: int
    path: Path
    dropped_by_topic: dict[str, int] = field(default_factory=dict)
    clamped_by_topic: dict[str, int] = field(default_factory=dict)  #: log_time clamped (went backwards)
    nonfinite_by_topic: dict[str, int] = field(default_factory=dict)  #: JSON messages with NaN/inf written as null
    #: wire topics: transport reads/writes recorded (several per MCAP message)
    chunks_by_topic: dict[str, int] = field(default_factory=dict)



class Recorder(MessageEmitter):
    """Records one run to ``path`` (an ``.mcap`` file; written as ``<path>.part`` until closed).

    ``run_start_unix_ns``: Unix time of sim time 0 (log_time = run_start_unix_ns + t_ns).
    ``metadata``: str -> str, written as the ``run`` metadata record at ``start()``
    (rig, scenario, seed, versions, git SHA ...). ``attachments``: (name, media_type, data)
    written right after it (rig and scenario files). ``chunk_size``: uncompressed bytes per
    zstd chunk. ``queue_max``: queued messages beyond which ``log()`` drops (and counts).
    ``writer_thread``: encode and write on a thread of its own (the default: ``log()`` only
    queues), or in the caller's ``log()`` (no queue: a process that does nothing but record,
    such as the recorder child of ``hil.record.process``, saves a thread hand-over per batch).
    """

    def __init__(self, path: Path, *, run_start_unix_ns: int, metadata: dict[str, str],
                 attachments: Iterable[tuple[str, str, bytes]] = (), chunk_size: int = 65536,
                 queue_max: int = 200_000, writer_thread: bool = True) -> None:
        if run_start_unix_ns < 0:
            raise ValueError("run_start_unix_ns must be >= 0")
        if chunk_size <= 0 or queue_max <= 0:
            raise ValueError("chunk_size and queue_max must be > 0")
        self.path = Path(path)
        self.part_path = self.path.with_name(self.path.name + ".part")
        self.run_start_unix_ns = int(run_start_unix_ns)
        self._metadata = str_dict(metadata, "metadata", strict=True)
        self._attachments = [(str(n), str(m), bytes(d)) for n, m, d in attachments]
        self._chunk_size = int(chunk_size)
        self._queue_max = int(queue_max)
        self._threaded = bool(writer_thread)
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._routes: dict[str, Route] = {t: Route(s) for t, s in TOPICS.items()}
        self._wire_routes: dict[tuple[str, str], Route] = {}  #: (port, direction) -> route, as met
        self._state = _State.NEW
        self._lock = threading.Lock()  # state changes and the (rare) drop counters
        self._thread: threading.Thread | None = None
        self._writer: Writer | None = None
        self._sink: SinkProxy | None = None
        self._fatal: BaseException | None = None
        self._high_water = 0
        self._after_close = 0
        self._stats: RecordStats | None = None
        self._chunk_bytes = 0  # uncompressed bytes in the open chunk (we close it before chunk_size)
        self._chunk_messages = 0
        self._close_error: RecordWriteError | None = None
        self._latest_t_ns = -(1 << 62)  # latest wire chunk's sim time (closes stale wire batches)
        self._swept_t_ns = -(1 << 62)

    # ---- life cycle ------------------------------------------------------------------------
    def _check(self, action: str) -> _State:
        nxt = _TRANSITIONS.get((self._state, action))
        if nxt is None:
            raise RuntimeError(f"Recorder: cannot {action} when {self._state.value}")
        return nxt

    def _transition(self, action: str) -> None:
        self._state = self._check(action)

    def start(self) -> None:
        """Create ``<path>.part``; write header, ``run`` metadata and attachments; start the writer thread
        (unless ``writer_thread=False``).

        Refuses (FileExistsError) to overwrite an existing ``path`` or ``.part`` file. If
        start() fails the recorder stays unstarted (close() is then a no-op).
        """
        with self._lock:
            self._check("start")
        if self.path.exists():
            raise FileExistsError(f"{self.path} exists")
        fd = os.open(self.part_path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, LOG_FILE_MODE)
        sink = SinkProxy(fd)
        try:
            writer = self._begin_file(sink)
        except BaseException:
            os.close(fd)
            self.part_path.unlink()  # ours (O_EXCL), and holds nothing worth keeping
            raise
        self._sink, self._writer = sink, writer
        self._append = MessageAppender(writer).add
        if self._threaded:
            self._thread = threading.Thread(target=self._run, name=f"mcap-writer {self.path.name}", daemon=True)
        with self._lock:
            self._transition("start")
        if self._thread is not None:
            self._thread.start()

    def _begin_file(self, sink: SinkProxy) -> Writer:
        """Header, ``run`` metadata, attachments (straight to the OS), then schemas and channels."""
        w = Writer(sink, chunk_size=self._chunk_size, compression=CompressionType.ZSTD,  # type: ignore[arg-type]
                   enable_crcs=True, enable_data_crcs=False)
        w.start(profile=PROFILE, library=_LIBRARY)
        run = dict(self._metadata)
        run.setdefault("run_start_unix_ns", str(self.run_start_unix_ns))
        run["record.chunk_size"] = str(self._chunk_size)
        run["record.queue_max"] = str(self._queue_max)
        w.add_metadata("run", run)
        for name, media_type, data in self._attachments:
            w.add_attachment(self.run_start_unix_ns, self.run_start_unix_ns, name, media_type, data)
        schema_ids: dict[str, int] = {}
        for route in self._routes.values():
            spec = route.spec
            pb = spec.encoding is Encoding.PROTOBUF
            schema_encoding = SchemaEncoding.Protobuf if pb else SchemaEncoding.JSONSchema
            message_encoding = MessageEncoding.Protobuf if pb else MessageEncoding.JSON
            data = spec.schema_bytes()
            if spec.schema_name not in schema_ids:
                sid = schema_ids[spec.schema_name] = w.register_schema(spec.schema_name, schema_encoding, data)
                self._chunk_bytes += record_size(
                    Schema(id=sid, name=spec.schema_name, encoding=schema_encoding, data=data))
            if pb:
                route.encode = protobuf_encoder(spec.schema_name, data)
            meta = {"description": spec.description, "units": spec.units}
            route.channel_id = w.register_channel(spec.topic, message_encoding, schema_ids[spec.schema_name], meta)
            self._chunk_bytes += record_size(Channel(
                id=route.channel_id, topic=spec.topic, message_encoding=message_encoding,
                schema_id=schema_ids[spec.schema_name], metadata=meta))
        return w

    def __enter__(self) -> Recorder:
        if self._state is _State.NEW:
            self.start()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if exc is None:
            self.close()
            return
        try:
            self.close({"status": "aborted", "error": f"{exc_type.__name__ if exc_type else ''}: {exc}"})
        except RecordWriteError as err:  # the original exception matters more; keep both visible
            exc.add_note(f"recording also failed: {err}")

    # ---- the tick path ---------------------------------------------------------------------
    def log(self, topic: str, t_ns: int, payload: dict[str, Any], t_host_ns: int) -> None:
        """Queue one message (non-blocking). ``t_ns`` sim time ns, ``t_host_ns`` host monotonic ns.

        ``payload`` follows the topic's schema (without the fields the writer stamps) and must
        not be mutated afterwards (it is encoded later, in the writer thread).
        Raises ``UnknownTopicError`` for a topic not in the table.
        """
        route = self._routes.get(topic)
        if route is None:
            topic_spec(topic)  # raises UnknownTopicError with the message
        self._put(route, Kind.PLAIN, t_ns, t_host_ns, payload)  # type: ignore[arg-type]

    def log_wire(self, port: str, direction: str, t_ns: int, t_host_ns: int, data: bytes) -> None:
        """Queue raw bytes of ``port`` (``direction`` "tx" bench->client or "rx") for ``/hil/wire/<port>/<dir>``."""
        route = self._routes.get(f"/hil/wire/{port}/{direction}")
        if route is None:
            wire_topic(port, direction)  # raises UnknownTopicError
        self._put(route, Kind.WIRE, t_ns, t_host_ns, bytes(data))  # type: ignore[arg-type]

    def log_truth(self, t_ns: int, truth: dict[str, Any], t_host_ns: int) -> None:
        """Queue a ``/sim/truth`` payload; the writer also derives ``/tf`` and ``/sim/pose`` (ENU/FLU)."""
        self._put(self._routes["/sim/truth"], Kind.TRUTH, t_ns, t_host_ns, truth)

    def tap(self, record: WireRecord) -> None:
        """A ``Port.tap`` callback: records a transport's ``WireRecord``."""
        self.log_wire(record.port, record.direction.value, record.t_ns, record.t_host_ns, record.data)

    def _put(self, route: Route, kind: Kind, t_ns: int, t_host_ns: int, payload: Any) -> None:
        if self._state is not _State.RUNNING:
            self._not_running(route)
        elif not self._threaded:
            self._handle((route, kind, t_ns, t_host_ns, payload))
        elif self._queue.qsize() >= self._queue_max:
            with self._lock:
                route.dropped += 1
        else:
            self._queue.put((route, kind, t_ns, t_host_ns, payload))

    def write_now(self, items: Iterable[tuple[str | None, int, int, Any]]) -> None:
        """``writer_thread=False`` only: each item written at once, in order, exactly as
        ``log(topic, t_ns, payload, t_host_ns)`` or, for ``topic`` None, ``log_wire(*payload,
        ...)`` with ``payload = (port, direction, data)`` would: the recorder child's batch
        (hil/record/process.py) without a call per layer for each of its ~10 messages a tick."""
        if self._threaded or self._state is not _State.RUNNING:
            for topic, t_ns, t_host_ns, payload in items:
                if topic is None:
                    self.log_wire(payload[0], payload[1], t_ns, t_host_ns, payload[2])
                else:
                    self.log(topic, t_ns, payload, t_host_ns)
            return
        routes, wires, gather, plain, kind = self._routes, self._wire_routes, self._gather_wire, self._plain, Kind.PLAIN
        for topic, t_ns, t_host_ns, payload in items:
            if topic is None:
                port, direction, data = payload
                route = wires.get((port, direction))
                if route is None:
                    route = routes.get(f"/hil/wire/{port}/{direction}")
                    if route is None:
                        wire_topic(port, direction)  # raises UnknownTopicError
                    wires[(port, direction)] = route  # type: ignore[assignment]
                gather(route, t_ns, t_host_ns, bytes(data))  # type: ignore[arg-type]
            else:
                route = routes.get(topic)
                if route is None:
                    topic_spec(topic)  # raises UnknownTopicError with the message
                plain(route, kind, t_ns, t_host_ns, payload)  # type: ignore[arg-type]

    def batch(self) -> RecordBatch:
        """A :class:`RecordBatch` feeding this recorder (one queue put per ``flush()``)."""
        return RecordBatch(self._routes, self._put_batch)

    def _put_batch(self, items: list[QueueItem]) -> None:
        if self._state is not _State.RUNNING:
            for item in items:
                self._not_running(item[0])
        elif not self._threaded:
            self._handle((items[0][0], Kind.BATCH, 0, 0, items))
        elif self._queue.qsize() >= self._queue_max:
            with self._lock:
                for item in items:
                    item[0].dropped += 1
        else:
            self._queue.put((items[0][0], Kind.BATCH, 0, 0, items))

    def _not_running(self, route: Route) -> None:
        if self._state is _State.NEW:
            raise RuntimeError("Recorder.log() before start()")
        with self._lock:
            self._after_close += 1
        if self._after_close == 1:
            warnings.warn(f"Recorder: message on {route.spec.topic} after close() was dropped "
                          "(further ones are counted silently in Recorder.dropped_after_close)",
                          RuntimeWarning, stacklevel=4)

    @property
    def dropped_after_close(self) -> int:
        """Messages logged after ``close()`` (not in the file, not in its summary)."""
        return self._after_close

    def pending(self) -> int:
        """Messages queued and not yet written."""
        return self._queue.qsize()


    def close(self, final_metadata: dict[str, str] | None = None) -> RecordStats:
        """Drain the queue, write ``verdict`` (``final_metadata``) and ``summary`` metadata,
        finish the file and rename ``.part`` -> ``path``. Idempotent; safe on error paths.

        Raises ``RecordWriteError`` (every call) if the file could not be written; the
        ``.part`` file is then left for ``hil recover``.
        """
        with self._lock:
            if self._state is _State.CLOSED:
                if self._close_error is not None:
                    raise self._close_error
                assert self._stats is not None
                return self._stats
            was_running = self._state is _State.RUNNING
            self._transition("close")
        if not was_running:
            self._stats = RecordStats({}, 0, self.path)
            return self._stats
        assert self._writer is not None and self._sink is not None
        if self._thread is not None:
            self._queue.put(STOP)
            self._thread.join()
        else:
            self._flush_wire(None)  # what the writer thread does when it stops
        while True:  # producers that raced with close(): count, never lose silently
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                break
            if item is not STOP:
                item[0].dropped += 1
        error: BaseException | None = self._fatal
        try:
            if error is None:
                self._writer.flush()  # close the open chunk so verdict/summary come after every message
                if final_metadata is not None:
                    self._writer.add_metadata("verdict", str_dict(final_metadata, "final_metadata", strict=False))
                self._writer.add_metadata("summary", self._summary())
                self._writer.finish()
                os.fsync(self._sink.fd)
        except OSError as e:
            error = e
        finally:
            os.close(self._sink.fd)
        if error is None:
            os.replace(self.part_path, self.path)
        routes = self._routes.values()
        self._stats = RecordStats(
            messages_by_topic={r.spec.topic: r.written for r in routes},
            dropped=sum(r.dropped for r in routes),
            path=self.path if error is None else self.part_path,
            dropped_by_topic={r.spec.topic: r.dropped for r in routes if r.dropped},
            clamped_by_topic={r.spec.topic: r.clamped for r in routes if r.clamped},
            nonfinite_by_topic={r.spec.topic: r.nonfinite for r in routes if r.nonfinite},
            chunks_by_topic={r.spec.topic: r.chunks for r in routes if r.chunks})
        if error is not None:
            self._close_error = RecordWriteError(f"recording {self.part_path} failed: {error}")
            raise self._close_error from error
        return self._stats


__all__ = ["LOG_FILE_MODE", "PROFILE", "ZSTD_LEVEL", "RecordBatch", "RecordStats", "RecordWriteError", "Recorder",
           "UnknownTopicError"]
