"""The recorder's writer side: each queued message stamped, encoded and added to the MCAP
file, on the writer thread (or in ``log()`` when ``writer_thread=False``).

Times: ``log_time = run_start_unix_ns + t_ns`` (sim time; clamped so it never goes backwards
on a channel, clamps are counted), ``publish_time = t_host_ns`` (host monotonic), and both
are written into payloads as the topic table says (``topics.Stamp``). Wire bytes are
gathered per port into ``hil.WireChunks`` messages of at most ``WIRE_BATCH_NS``; chunks are
closed before they pass ``chunk_size`` uncompressed bytes. Nothing is dropped silently:
an unencodable payload or a write failure is counted on its route (``_summary``).
"""

from __future__ import annotations

import os
import queue
import threading
from collections.abc import Callable, Mapping
from typing import Any

from mcap.data_stream import RecordBuilder
from mcap.records import Channel, Schema
from mcap.writer import Writer

from hil.record import frames
from hil.record.mcap_append import MessageAppender
from hil.record.payload import adc_tick, encode_json
from hil.record.routes import STOP, Kind, QueueItem, Route
from hil.record.topics import WIRE_BATCH_BYTES, WIRE_BATCH_NS, Stamp

#: With a backlog, the writer blocks for _YIELD_S after every _YIELD_EVERY messages. Without
#: it a busy writer keeps the GIL for the 5 ms switch interval and the tick thread's wake-ups
#: wait that long (measured: median 2.2 ms late -> 0.3 ms; costs ~25 % of writer throughput).
#: A bare GIL release (select with timeout 0) is too short for the tick thread to get in.
_YIELD_EVERY = 8
_YIELD_S = 20e-6
MESSAGE_OVERHEAD = 31  # opcode 1 + length 8 + channel id 2 + sequence 4 + log time 8 + publish time 8


def record_size(record: Schema | Channel) -> int:
    """Bytes ``record`` takes in the file (it counts toward the open chunk's size)."""
    builder = RecordBuilder()
    record.write(builder)
    return builder.count


class SinkProxy:
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


class MessageEmitter:
    """The writer side of ``hil.record.writer.Recorder`` (its base class): the writer-thread
    loop, wire gathering, stamping and encoding, chunk sizing and the ``summary`` counts.

    The attributes below are the recorder's, set in ``Recorder.__init__``/``start()``.
    """

    run_start_unix_ns: int  #: Unix time of sim time 0, ns
    _routes: dict[str, Route]
    _queue: queue.SimpleQueue[Any]
    _writer: Writer | None
    #: ``_writer``'s message append (``MessageAppender``), set with it
    _append: Callable[[int, int, bytes, int, int], None]
    _fatal: BaseException | None  #: the write failure that broke the file
    _high_water: int
    _queue_max: int
    _chunk_size: int
    _chunk_bytes: int
    _chunk_messages: int
    _latest_t_ns: int
    _swept_t_ns: int
    #: (topic, log_time, message bytes) of every message written: the live server (hil/live)
    mirror: Callable[[str, int, bytes], None] | None = None

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
            if item is STOP:
                self._flush_wire(None)
                return
            depth = q.qsize() + 1
            if depth > self._high_water:
                self._high_water = depth
            self._handle(item)
            burst += len(item[4]) if item[1] is Kind.BATCH else 1  # type: ignore[index]
            if burst >= _YIELD_EVERY:
                burst = 0
                pause.wait(_YIELD_S)  # block briefly: lets the tick thread take the GIL

    def _handle(self, item: QueueItem) -> None:
        route, kind, t_ns, t_host_ns, payload = item
        if kind is Kind.BATCH:
            for sub in payload:
                self._handle(sub)
            self._flush_wire(self._latest_t_ns)  # one tick done: write out wire bytes older than a batch
            return
        if kind is Kind.WIRE:
            self._gather_wire(route, t_ns, t_host_ns, payload)
        else:
            self._plain(route, kind, t_ns, t_host_ns, payload)

    def _gather_wire(self, route: Route, t_ns: int, t_host_ns: int, payload: Any) -> None:
        """One wire chunk (bytes, or a callable giving them) onto its port's next message."""
        if self._fatal is not None:
            route.dropped += 1
            return
        try:
            if callable(payload):
                payload = payload()
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
        except OSError as e:  # the file is broken: count everything from here on
            self._fatal = e
            route.dropped += 1
        except Exception as e:  # never let one message kill the writer thread (e.g. bad t_ns type)
            self._unencodable(route, e)

    def _plain(self, route: Route, kind: Kind, t_ns: int, t_host_ns: int, payload: Any) -> None:
        """One message (``Kind.PLAIN``, or ``Kind.TRUTH`` with its derived ``/tf`` and ``/sim/pose``)."""
        if self._fatal is not None:
            route.dropped += 1
            return
        try:
            if callable(payload):  # a deferred payload: built here, off the tick path
                payload = payload()
            self._emit(route, t_ns, t_host_ns, payload, complete=True)
            if kind is Kind.TRUTH:
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

    def _emit_wire(self, route: Route) -> None:
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
    def _unencodable(route: Route, e: BaseException) -> None:
        route.unencodable += 1
        route.dropped += 1
        if not route.first_error:
            route.first_error = f"{type(e).__name__}: {e}"

    def _emit(self, route: Route, t_ns: int, t_host_ns: int, payload: Mapping[str, Any], *,
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
                data, nonfinite = encode_json(msg)
            except (TypeError, ValueError, AttributeError) as e:  # a payload that is not a JSON object
                self._unencodable(route, e)
                return
        else:
            data, nonfinite = encode_json(payload)
        if nonfinite:
            route.nonfinite += 1
        assert self._writer is not None
        size = MESSAGE_OVERHEAD + len(data)
        if self._chunk_messages and self._chunk_bytes + size > self._chunk_size:
            self._writer.flush()  # finish the chunk before it would pass chunk_size (mcap closes it after)
            self._chunk_bytes = self._chunk_messages = 0
        self._append(route.channel_id, log_time, data, publish_time, route.seq & 0xFFFFFFFF)
        if self.mirror is not None:
            self.mirror(spec.topic, log_time, data)
        self._chunk_bytes += size
        self._chunk_messages += 1
        route.seq += 1
        route.written += 1

    def _compact(self, route: Route, payload: Mapping[str, Any], log_time: int, t_ns: int,
                 publish_time: int) -> dict[str, Any]:
        """A protobuf topic's fields: ``t_ns``/``t_host_ns`` only where the record's log time /
        publish time do not already say them (readers put them back)."""
        msg = dict(payload)
        if route.spec.schema_name == "hil.AdcConversions" and not isinstance(msg.get("code"), (list, tuple)):
            msg = adc_tick([msg])  # one conversion logged on its own (e.g. a copied old log)
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


__all__ = ["MESSAGE_OVERHEAD", "MessageEmitter", "SinkProxy", "record_size"]
