"""One MCAP file per run, written by a background thread fed through a bounded queue.

The tick path only calls ``log``/``log_wire``/``log_truth``: a topic check and a queue put
(no encoding, no I/O). The writer thread encodes (protobuf or JSON, per topic: topics.py),
stamps, gathers wire bytes into 100 ms messages and adds messages to an
``mcap.writer.Writer`` (zstd chunks of at most ``chunk_size`` uncompressed bytes, 64 KiB by
default: a 1 MiB chunk flush stalls 3-14 ms, research/limits.md section 5).

File life cycle (research/ecosystem.md section 1, "crash behaviour"):

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
import json
import math
import os
import queue
import threading
import warnings
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
import orjson
from mcap.data_stream import RecordBuilder
from mcap.records import Channel, Schema
from mcap.well_known import MessageEncoding, SchemaEncoding
import mcap.writer as _mcap_writer
from mcap.writer import CompressionType, Writer

import hil
from hil.record import frames
from hil.record.protobuf import encoder as protobuf_encoder
from hil.record.topics import (
    TOPICS,
    WIRE_BATCH_BYTES,
    WIRE_BATCH_NS,
    Encoding,
    Stamp,
    TopicSpec,
    UnknownTopicError,
    topic_spec,
    wire_topic,
)
from hil.transport.base import WireRecord

_LIBRARY = f"mav-hil-bench/{hil.__version__} mcap-python"
#: The MCAP header's profile: this project's conventions (docs/recording.md "Profile"): JSON
#: messages described by JSON Schema, log_time = run start + sim time, the topic table of
#: hil/record/topics.py. Not one of MCAP's well-known ROS profiles, which would promise ROS types.
PROFILE = "mav-hil"
#: A log holds a whole flight (rig, gains, every byte): owner read/write, group read, nothing
#: for others; the process umask narrows it further (umask 077 -> 0600).
LOG_FILE_MODE = 0o640
#: With a backlog, the writer blocks for _YIELD_S after every _YIELD_EVERY messages. Without
#: it a busy writer keeps the GIL for the 5 ms switch interval and the tick thread's wake-ups
#: wait that long (measured: median 2.2 ms late -> 0.3 ms; costs ~25 % of writer throughput).
#: A bare GIL release (select with timeout 0) is too short for the tick thread to get in.
_YIELD_EVERY = 8
_YIELD_S = 20e-6
_STOP = object()
_MESSAGE_OVERHEAD = 31  # opcode 1 + length 8 + channel id 2 + sequence 4 + log time 8 + publish time 8
#: zstd level of the chunks. mcap-python compresses with zstandard's default (3) and has no
#: option; level 6 makes a run's file 4 % smaller for +0.2 ms per 64 KiB chunk, on the
#: recorder's own process (measured on a 48 s mission: 5.88 -> 5.66 MB of chunks; level 15
#: gains 5 % more at 10x the CPU).
ZSTD_LEVEL = 6


class _LeveledZstd:
    """Stands in for the ``zstandard`` module inside ``mcap.writer`` (it only calls
    ``compress``): the same function at ``ZSTD_LEVEL``. Thread-safe (no shared compressor)."""

    def __init__(self, module: Any) -> None:
        self._module = module

    def compress(self, data: bytes) -> bytes:
        return self._module.compress(data, ZSTD_LEVEL)  # type: ignore[no-any-return]

    def __getattr__(self, name: str) -> Any:
        return getattr(self._module, name)


if getattr(_mcap_writer, "zstandard", None) is not None and not isinstance(_mcap_writer.zstandard, _LeveledZstd):
    _mcap_writer.zstandard = _LeveledZstd(_mcap_writer.zstandard)  # type: ignore[assignment]


def _record_size(record: Schema | Channel) -> int:
    builder = RecordBuilder()
    record.write(builder)
    return builder.count


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


class _Kind(enum.IntEnum):
    PLAIN = 0
    WIRE = 1
    TRUTH = 2  #: /sim/truth plus the derived /tf and /sim/pose
    BATCH = 3  #: a list of (route, kind, t_ns, t_host_ns, payload) queued with one put


class RecordBatch:
    """Messages gathered on the tick path and queued with ONE put (``Recorder.batch()``).

    A queue put costs a few microseconds when the writer thread holds the GIL; a tick
    records ~15 messages, so the bench gathers them here and hands the list over once per
    tick. Same semantics as ``Recorder.log``/``log_wire``: payloads must not be mutated
    after they are added; unknown topics raise at once.
    """

    __slots__ = ("_items", "_rec")

    def __init__(self, recorder: Recorder) -> None:
        self._rec = recorder
        self._items: list[tuple[_Route, _Kind, int, int, Any]] = []

    def log(self, topic: str, t_ns: int, payload: dict[str, Any] | Callable[[], dict[str, Any]], t_host_ns: int) -> None:
        """``payload`` may be a no-argument callable returning it: it is then called on the
        writer thread (build big payloads from immutable records off the tick path)."""
        route = self._rec._routes.get(topic)
        if route is None:
            topic_spec(topic)  # raises UnknownTopicError with the message
        self._items.append((route, _Kind.PLAIN, t_ns, t_host_ns, payload))  # type: ignore[arg-type]

    def log_wire(self, port: str, direction: str, t_ns: int, t_host_ns: int, data: bytes) -> None:
        route = self._rec._routes.get(f"/hil/wire/{port}/{direction}")
        if route is None:
            wire_topic(port, direction)  # raises UnknownTopicError
        self._items.append((route, _Kind.WIRE, t_ns, t_host_ns, bytes(data)))  # type: ignore[arg-type]

    def __len__(self) -> int:
        return len(self._items)

    def flush(self) -> None:
        """Queue everything gathered so far (one put), then start a new batch."""
        if self._items:
            items, self._items = self._items, []
            self._rec._put_batch(items)


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


class _Route:
    """Per-topic state: channel id, encoder, last log time, sequence, counters, and for wire
    topics the chunks gathered for the next message."""

    __slots__ = ("spec", "port", "direction", "channel_id", "last_log_time", "seq", "written", "dropped",
                 "clamped", "nonfinite", "unencodable", "first_error", "encode", "chunks", "wire",
                 "wire_bytes")

    def __init__(self, spec: TopicSpec) -> None:
        self.spec = spec
        self.encode: Callable[[Mapping[str, Any]], bytes] | None = None  # protobuf topics (set at start)
        self.chunks = 0
        self.wire: list[tuple[int, int, bytes]] = []  # (t_ns, t_host_ns, data) not yet written
        self.wire_bytes = 0
        parts = spec.topic.split("/")  # /hil/wire/<port>/<dir> -> ['', 'hil', 'wire', port, dir]
        wire = len(parts) == 5 and parts[1:3] == ["hil", "wire"]
        self.port = parts[3] if wire else ""
        self.direction = parts[4] if wire else ""
        self.channel_id = 0
        self.last_log_time = 0
        self.seq = 0
        self.written = 0
        self.dropped = 0  #: queue full, unencodable, write failure, after close
        self.clamped = 0
        self.nonfinite = 0
        self.unencodable = 0
        self.first_error = ""


class _SinkProxy:
    """Write-through stream for ``mcap.writer.Writer`` (write/tell/flush over a raw fd): every
    record it emits (header, metadata, a whole chunk) reaches the OS at once, so a SIGKILL
    cannot lose it. Not an ``io.RawIOBase``: mcap would wrap that in a BufferedWriter."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self._pos = 0

    def write(self, data: bytes) -> int:
        view = memoryview(data)
        while view:
            n = os.write(self.fd, view)
            view = view[n:]
        self._pos += len(data)
        return len(data)

    def tell(self) -> int:
        return self._pos

    def flush(self) -> None:
        return None


def _json_default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, (tuple, set, frozenset)):
        return list(o)
    raise TypeError(f"{type(o).__name__} is not JSON serialisable")


def _sanitise(o: Any) -> tuple[Any, int]:
    """Replace non-finite floats by None (JSON has no NaN); returns (value, how many)."""
    if isinstance(o, float):
        return (o, 0) if math.isfinite(o) else (None, 1)
    if isinstance(o, dict):
        n = 0
        out: dict[str, Any] = {}
        for k, v in o.items():
            out[k], m = _sanitise(v)
            n += m
        return out, n
    if isinstance(o, (list, tuple)):
        items = [_sanitise(v) for v in o]
        return [v for v, _ in items], sum(m for _, m in items)
    if isinstance(o, (np.ndarray, np.generic)):
        return _sanitise(_json_default(o))
    return o, 0


def _encode(payload: Mapping[str, Any]) -> tuple[bytes, int]:
    # orjson is ~10x faster than json here (it runs for every message on the writer
    # thread, which shares the GIL with the tick). It writes NaN/inf as null silently, so
    # output with a null goes the exact (slow) way to count the non-finite values.
    try:
        data = orjson.dumps(payload, default=_json_default, option=orjson.OPT_SERIALIZE_NUMPY)
    except TypeError:
        data = b"null"
    if b"null" not in data:
        return data, 0
    try:
        return json.dumps(payload, separators=(",", ":"), allow_nan=False, default=_json_default).encode(), 0
    except ValueError:  # NaN or inf somewhere
        clean, n = _sanitise(payload)
        return json.dumps(clean, separators=(",", ":"), allow_nan=False, default=_json_default).encode(), n


def _adc_tick(conversions: list[Mapping[str, Any]]) -> dict[str, Any]:
    """``hil.AdcConversions`` fields from single-conversion payloads (``hil.AdcConversion``)."""
    first = conversions[0]
    t0 = int(first.get("t_ns", 0))
    out: dict[str, Any] = {"t_ns": t0} if "t_ns" in first else {}
    out |= {"channel": [int(c["channel"]) for c in conversions], "code": [int(c["code"]) for c in conversions],
            "volts": [float(c["volts"]) for c in conversions]}
    if any("t_ns" in c and int(c["t_ns"]) != t0 for c in conversions):
        out["dt_ns"] = [int(c.get("t_ns", t0)) - t0 for c in conversions]
    for key in ("single_ended", "vref_V"):
        if all(key in c for c in conversions):
            out[key] = [c[key] for c in conversions]
    if "port" in first:
        out["port"] = first["port"]
    return out


def _str_dict(d: Mapping[str, Any], what: str, *, strict: bool) -> dict[str, str]:
    out: dict[str, str] = {}
    for k, v in d.items():
        if strict and not (isinstance(k, str) and isinstance(v, str)):
            raise TypeError(f"{what}: keys and values must be str, got {k!r}: {v!r}")
        out[str(k)] = v if isinstance(v, str) else str(v)
    return out


class Recorder:
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
        self._metadata = _str_dict(metadata, "metadata", strict=True)
        self._attachments = [(str(n), str(m), bytes(d)) for n, m, d in attachments]
        self._chunk_size = int(chunk_size)
        self._queue_max = int(queue_max)
        self._threaded = bool(writer_thread)
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._routes: dict[str, _Route] = {t: _Route(s) for t, s in TOPICS.items()}
        self._state = _State.NEW
        self._lock = threading.Lock()  # state changes and the (rare) drop counters
        self._thread: threading.Thread | None = None
        self._writer: Writer | None = None
        self._sink: _SinkProxy | None = None
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
        sink = _SinkProxy(fd)
        try:
            writer = self._begin_file(sink)
        except BaseException:
            os.close(fd)
            self.part_path.unlink()  # ours (O_EXCL), and holds nothing worth keeping
            raise
        self._sink, self._writer = sink, writer
        if self._threaded:
            self._thread = threading.Thread(target=self._run, name=f"mcap-writer {self.path.name}", daemon=True)
        with self._lock:
            self._transition("start")
        if self._thread is not None:
            self._thread.start()

    def _begin_file(self, sink: _SinkProxy) -> Writer:
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
                self._chunk_bytes += _record_size(
                    Schema(id=sid, name=spec.schema_name, encoding=schema_encoding, data=data))
            if pb:
                route.encode = protobuf_encoder(spec.schema_name, data)
            meta = {"description": spec.description, "units": spec.units}
            route.channel_id = w.register_channel(spec.topic, message_encoding, schema_ids[spec.schema_name], meta)
            self._chunk_bytes += _record_size(Channel(
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
        self._put(route, _Kind.PLAIN, t_ns, t_host_ns, payload)  # type: ignore[arg-type]

    def log_wire(self, port: str, direction: str, t_ns: int, t_host_ns: int, data: bytes) -> None:
        """Queue raw bytes of ``port`` (``direction`` "tx" bench->client or "rx") for ``/hil/wire/<port>/<dir>``."""
        route = self._routes.get(f"/hil/wire/{port}/{direction}")
        if route is None:
            wire_topic(port, direction)  # raises UnknownTopicError
        self._put(route, _Kind.WIRE, t_ns, t_host_ns, bytes(data))  # type: ignore[arg-type]

    def log_truth(self, t_ns: int, truth: dict[str, Any], t_host_ns: int) -> None:
        """Queue a ``/sim/truth`` payload; the writer also derives ``/tf`` and ``/sim/pose`` (ENU/FLU)."""
        self._put(self._routes["/sim/truth"], _Kind.TRUTH, t_ns, t_host_ns, truth)

    def tap(self, record: WireRecord) -> None:
        """A ``Port.tap`` callback: records a transport's ``WireRecord``."""
        self.log_wire(record.port, record.direction.value, record.t_ns, record.t_host_ns, record.data)

    def _put(self, route: _Route, kind: _Kind, t_ns: int, t_host_ns: int, payload: Any) -> None:
        if self._state is not _State.RUNNING:
            self._not_running(route)
        elif not self._threaded:
            self._handle((route, kind, t_ns, t_host_ns, payload))
        elif self._queue.qsize() >= self._queue_max:
            with self._lock:
                route.dropped += 1
        else:
            self._queue.put((route, kind, t_ns, t_host_ns, payload))

    def batch(self) -> RecordBatch:
        """A :class:`RecordBatch` feeding this recorder (one queue put per ``flush()``)."""
        return RecordBatch(self)

    def _put_batch(self, items: list[tuple[_Route, _Kind, int, int, Any]]) -> None:
        if self._state is not _State.RUNNING:
            for item in items:
                self._not_running(item[0])
        elif not self._threaded:
            self._handle((items[0][0], _Kind.BATCH, 0, 0, items))
        elif self._queue.qsize() >= self._queue_max:
            with self._lock:
                for item in items:
                    item[0].dropped += 1
        else:
            self._queue.put((items[0][0], _Kind.BATCH, 0, 0, items))

    def _not_running(self, route: _Route) -> None:
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

    # ---- writer thread ---------------------------------------------------------------------
    def _run(self) -> None:
        q = self._queue
        pause = threading.Event()  # never set: a GIL-free wait of _YIELD_S
        burst = 0
        while True:
            try:
                item = q.get_nowait()
            except queue.Empty:
                burst = 0
                item = q.get()
            if item is _STOP:
                self._flush_wire(None)
                return
            depth = q.qsize() + 1
            if depth > self._high_water:
                self._high_water = depth
            self._handle(item)
            burst += len(item[4]) if item[1] is _Kind.BATCH else 1  # type: ignore[index]
            if burst >= _YIELD_EVERY:
                burst = 0
                pause.wait(_YIELD_S)  # block briefly: lets the tick thread take the GIL

    def _handle(self, item: tuple[_Route, _Kind, int, int, Any]) -> None:
        route, kind, t_ns, t_host_ns, payload = item
        if kind is _Kind.BATCH:
            for sub in payload:
                self._handle(sub)
            self._flush_wire(self._latest_t_ns)  # one tick done: write out wire bytes older than a batch
            return
        if self._fatal is not None:
            route.dropped += 1
            return
        try:
            if callable(payload):  # a deferred payload: built here, off the tick path
                payload = payload()
            if kind is _Kind.WIRE:
                t_ns = int(t_ns)
                if t_ns > self._latest_t_ns:
                    self._latest_t_ns = t_ns
                if route.wire and (t_ns - route.wire[0][0] >= WIRE_BATCH_NS
                                   or route.wire_bytes + len(payload) > WIRE_BATCH_BYTES):
                    self._emit_wire(route)
                route.wire.append((t_ns, int(t_host_ns), payload))
                route.wire_bytes += len(payload)
                route.chunks += 1
                if t_ns - self._swept_t_ns >= WIRE_BATCH_NS:  # wire logged outside tick batches too
                    self._swept_t_ns = t_ns
                    self._flush_wire(t_ns)
            else:
                self._emit(route, t_ns, t_host_ns, payload, complete=True)
                if kind is _Kind.TRUTH:
                    for topic, derive in (("/tf", frames.truth_to_tf), ("/sim/pose", frames.truth_to_pose)):
                        derived = self._routes[topic]
                        try:
                            msg = derive(payload)
                        except (KeyError, TypeError, ValueError, IndexError) as e:  # truth without p_N_m/q_NB
                            self._unencodable(derived, e)
                            continue
                        self._emit(derived, t_ns, t_host_ns, msg, complete=True)
        except OSError as e:  # the file is broken: count everything from here on
            self._fatal = e
            route.dropped += 1
        except Exception as e:  # never let one message kill the writer thread (e.g. bad t_ns type)
            self._unencodable(route, e)

    def _flush_wire(self, now_t_ns: int | None) -> None:
        """Write the gathered wire bytes of every port whose first chunk is a batch older than
        ``now_t_ns`` (all of them if None): a quiet port must not hold its bytes until close."""
        for route in self._routes.values():
            if route.wire and (now_t_ns is None or now_t_ns - route.wire[0][0] >= WIRE_BATCH_NS):
                try:
                    self._emit_wire(route)
                except OSError as e:
                    self._fatal = e
                    route.dropped += 1
                except Exception as e:  # never let one message kill the writer thread
                    self._unencodable(route, e)

    def _emit_wire(self, route: _Route) -> None:
        """One ``hil.WireChunks`` message of the chunks gathered on ``route``."""
        chunks, route.wire, route.wire_bytes = route.wire, [], 0
        t0, h0, _ = chunks[0]
        dt_ns = [0] * len(chunks)
        dt_host_ns = [0] * len(chunks)
        for i in range(1, len(chunks)):
            dt_ns[i] = chunks[i][0] - chunks[i - 1][0]
            dt_host_ns[i] = chunks[i][1] - chunks[i - 1][1]
        data = b"".join(c[2] for c in chunks)
        msg = {"t_ns": t0, "t_host_ns": h0, "port": route.port, "direction": route.direction, "len": len(data),
               "data": data, "chunk_len": [len(c[2]) for c in chunks], "chunk_dt_ns": dt_ns,
               "chunk_dt_host_ns": dt_host_ns}
        self._emit(route, t0, h0, msg, complete=True)

    @staticmethod
    def _unencodable(route: _Route, e: BaseException) -> None:
        route.unencodable += 1
        route.dropped += 1
        if not route.first_error:
            route.first_error = f"{type(e).__name__}: {e}"

    def _emit(self, route: _Route, t_ns: int, t_host_ns: int, payload: Mapping[str, Any], *,
              complete: bool) -> None:
        spec = route.spec
        log_time = self.run_start_unix_ns + int(t_ns)
        if log_time < route.last_log_time:
            route.clamped += 1
            log_time = route.last_log_time
        if log_time < 0:
            route.clamped += 1
            log_time = 0
        route.last_log_time = log_time
        publish_time = max(0, int(t_host_ns))
        if route.encode is not None:
            try:
                data = route.encode(self._compact(route, payload, log_time, t_ns, publish_time))
            except (TypeError, ValueError, AttributeError, KeyError) as e:  # not this topic's fields/types
                self._unencodable(route, e)
                return
            nonfinite = 0
        elif complete:
            try:
                if spec.stamp is Stamp.FOXGLOVE:
                    msg = dict(spec.defaults)
                    msg.update(payload)
                    msg["timestamp"] = {"sec": log_time // 1_000_000_000, "nsec": log_time % 1_000_000_000}
                else:
                    msg = dict(payload)
                    msg.setdefault("t_ns", int(t_ns))
                    if spec.stamp is Stamp.TIMING:
                        msg.setdefault("t_host_ns", int(t_host_ns))
                data, nonfinite = _encode(msg)
            except (TypeError, ValueError, AttributeError) as e:  # a payload that is not a JSON object
                self._unencodable(route, e)
                return
        else:
            data, nonfinite = _encode(payload)
        if nonfinite:
            route.nonfinite += 1
        assert self._writer is not None
        size = _MESSAGE_OVERHEAD + len(data)
        if self._chunk_messages and self._chunk_bytes + size > self._chunk_size:
            self._writer.flush()  # finish the chunk before it would pass chunk_size (mcap closes it after)
            self._chunk_bytes = self._chunk_messages = 0
        self._writer.add_message(route.channel_id, log_time, data, publish_time, route.seq & 0xFFFFFFFF)
        self._chunk_bytes += size
        self._chunk_messages += 1
        route.seq += 1
        route.written += 1

    def _compact(self, route: _Route, payload: Mapping[str, Any], log_time: int, t_ns: int,
                 publish_time: int) -> dict[str, Any]:
        """A protobuf topic's fields: ``t_ns``/``t_host_ns`` only where the record's log time /
        publish time do not already say them (readers put them back)."""
        msg = dict(payload)
        if route.spec.schema_name == "hil.AdcConversions" and not isinstance(msg.get("code"), (list, tuple)):
            msg = _adc_tick([msg])  # one conversion logged on its own (e.g. a copied old log)
        msg_t_ns = msg.pop("t_ns", t_ns)
        if int(msg_t_ns) != log_time - self.run_start_unix_ns:
            msg["t_ns"] = int(msg_t_ns)
        if route.spec.stamp is Stamp.TIMING:
            host = msg.pop("t_host_ns", publish_time)
            if int(host) != publish_time:
                msg["t_host_ns"] = int(host)
        return msg

    # ---- closing ---------------------------------------------------------------------------
    def _summary(self) -> dict[str, str]:
        s: dict[str, str] = {
            "messages_total": str(sum(r.written for r in self._routes.values())),
            "dropped_total": str(sum(r.dropped for r in self._routes.values())),
            "queue_high_water": str(self._high_water),
            "queue_max": str(self._queue_max),
            "chunk_size": str(self._chunk_size),
        }
        for t, r in self._routes.items():
            s[f"messages.{t}"] = str(r.written)
            if r.chunks:
                s[f"chunks.{t}"] = str(r.chunks)
            for key, n in (("dropped", r.dropped), ("clamped_log_time", r.clamped),
                           ("nonfinite", r.nonfinite), ("unencodable", r.unencodable)):
                if n:
                    s[f"{key}.{t}"] = str(n)
            if r.first_error:
                s[f"error.{t}"] = r.first_error
        if self._fatal is not None:
            s["writer_error"] = f"{type(self._fatal).__name__}: {self._fatal}"
        return s

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
            self._queue.put(_STOP)
            self._thread.join()
        else:
            self._flush_wire(None)  # what the writer thread does when it stops
        while True:  # producers that raced with close(): count, never lose silently
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                break
            if item is not _STOP:
                item[0].dropped += 1
        error: BaseException | None = self._fatal
        try:
            if error is None:
                self._writer.flush()  # close the open chunk so verdict/summary come after every message
                if final_metadata is not None:
                    self._writer.add_metadata("verdict", _str_dict(final_metadata, "final_metadata", strict=False))
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


__all__ = ["RecordStats", "RecordWriteError", "Recorder", "UnknownTopicError"]
