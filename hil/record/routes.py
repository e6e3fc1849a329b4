"""What the recorder's tick side hands to its writer side: the per-topic ``Route`` (channel,
clocks, counters, gathered wire chunks), the ``Kind`` of a queued item, and ``RecordBatch``,
a tick's messages queued with one put.

A queued item is ``(route, kind, t_ns, t_host_ns, payload)`` (``QueueItem``): sim time ns,
host monotonic ns; for ``Kind.BATCH`` the payload is a list of such items. ``STOP`` ends the
writer thread.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping
from typing import Any

from hil.record.topics import TopicSpec, topic_spec, wire_topic

STOP = object()


class Kind(enum.IntEnum):
    PLAIN = 0
    WIRE = 1
    TRUTH = 2  #: /sim/truth plus the derived /tf and /sim/pose
    BATCH = 3  #: a list of (route, kind, t_ns, t_host_ns, payload) queued with one put


class Route:
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


#: (route, kind, t_ns sim ns, t_host_ns host monotonic ns, payload)
QueueItem = tuple[Route, Kind, int, int, Any]


class RecordBatch:
    """Messages gathered on the tick path and queued with ONE put (``Recorder.batch()``).

    A queue put costs a few microseconds when the writer thread holds the GIL; a tick
    records ~15 messages, so the bench gathers them here and hands the list over once per
    tick. Same semantics as ``Recorder.log``/``log_wire``: payloads must not be mutated
    after they are added; unknown topics raise at once.

    ``routes`` is the recorder's route per topic, ``put_batch`` its one-put queueing of a list.
    """

    __slots__ = ("_items", "_routes", "_put_batch")

    def __init__(self, routes: Mapping[str, Route], put_batch: Callable[[list[QueueItem]], None]) -> None:
        self._routes = routes
        self._put_batch = put_batch
        self._items: list[QueueItem] = []

    def log(self, topic: str, t_ns: int, payload: dict[str, Any] | Callable[[], dict[str, Any]], t_host_ns: int) -> None:
        """``payload`` may be a no-argument callable returning it: it is then called on the
        writer thread (build big payloads from immutable records off the tick path)."""
        route = self._routes.get(topic)
        if route is None:
            topic_spec(topic)  # raises UnknownTopicError with the message
        self._items.append((route, Kind.PLAIN, t_ns, t_host_ns, payload))  # type: ignore[arg-type]

    def log_wire(self, port: str, direction: str, t_ns: int, t_host_ns: int, data: bytes) -> None:
        route = self._routes.get(f"/hil/wire/{port}/{direction}")
        if route is None:
            wire_topic(port, direction)  # raises UnknownTopicError
        self._items.append((route, Kind.WIRE, t_ns, t_host_ns, bytes(data)))  # type: ignore[arg-type]

    def __len__(self) -> int:
        return len(self._items)

    def flush(self) -> None:
        """Queue everything gathered so far (one put), then start a new batch."""
        if self._items:
            items, self._items = self._items, []
            self._put_batch(items)


__all__ = ["STOP", "Kind", "QueueItem", "RecordBatch", "Route"]
