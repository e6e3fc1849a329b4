"""The run's trace as a stream: what the criteria read, in time order, in bounded memory.

The run appends its signals here as it does to :class:`hil.analysis.trace.Trace` (``define``, ``row``,
``point``), but nothing is kept for the whole run: rows and points wait in a short delay line
and leave it as :class:`Chunk` s, oldest first, to the subscribers (the streaming criteria,
hil/analysis/criteria_stream.py), then are dropped.

Why a delay line: an irregular series' point may be stamped earlier than the tick it arrives
on (telemetry carries the sim time of the IMU sample it belongs to, up to 1 s back,
hil/flight/runlog.py), and a criterion must see it before the ticks it precedes, as the whole-run
trace does. A tick leaves once the newest tick is ``horizon_ns`` later; chunks hold at least
``chunk_ticks`` ticks (the subscribers' numpy work is per chunk, not per tick). Held in
memory: at most ``horizon_ns`` plus ``chunk_ticks`` ticks of rows (about 2 s, 30 kB at 400 Hz)
and the points stamped in that span. A point stamped at or before a tick that already left is
counted in ``late_points`` and goes out with the next chunk (its effect then starts late).

Every group is appended once per tick at the same times (the grid); ``Trace`` allows groups
on their own times, the stream does not (ValueError when a chunk leaves).

Deferred delivery (``deferred=True``, the realtime runs): a subscriber's work on a chunk has a
cost per chunk, not per tick (the criteria's numpy calls: 0.5-2.3 ms for all of them, once a
second), and delivered inside one tick it made the next tick late and cost that sample its
command. A deferred stream queues the released chunks instead, and :meth:`pump` hands them to
the subscribers one call at a time while its caller has time (the realtime tick loop: what is
left of the tick before the next deadline). Every subscriber still sees every chunk in order;
:meth:`finish` delivers what is still queued.
"""

from __future__ import annotations

import bisect
from array import array
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from hil.native.frozen import by_fields

#: ticks a chunk holds at least (one second at 400 Hz)
CHUNK_TICKS = 400


@dataclass(frozen=True)
class Chunk:
    """Consecutive ticks and the points stamped among them.

    ``t_ns``: the ticks' sim times, shape (n,), int64. ``rows``: group -> values, shape
    (n, group width), float64. ``points``: series -> (t_ns (m,) int64, values (m,) float64),
    the points stamped after the previous chunk's last tick and at or before this chunk's last
    tick; the last chunk of a run (``final``) also has those stamped after the last tick, and
    may have no ticks.
    """

    t_ns: np.ndarray
    rows: Mapping[str, np.ndarray]
    points: Mapping[str, tuple[np.ndarray, np.ndarray]]
    final: bool = False

    def __reduce__(self) -> tuple[type, tuple[object, ...]]:
        return by_fields(self)  # compiled records pickle by field (hil/native/frozen.py)


Subscriber = Callable[[Chunk], None]


class _Pending:
    """A group's rows not yet released: times and flattened values."""

    __slots__ = ("width", "times", "values")

    def __init__(self, width: int) -> None:
        self.width = width
        self.times = array("q")
        self.values = array("d")


class TraceStream:
    """Delay line of the run's signals (see module docstring)."""

    def __init__(self, *, horizon_ns: int = 1_250_000_000, chunk_ticks: int = CHUNK_TICKS, grid: str = "truth",
                 deferred: bool = False) -> None:
        self.horizon_ns = horizon_ns
        self.deferred = deferred
        self.chunk_ticks = chunk_ticks
        self.grid = grid
        self.fields: dict[str, dict[str, int]] = {}
        self.series: dict[str, None] = {}  #: names of the irregular series seen so far, in order
        self.late_points = 0
        self.finished = False
        self._rows: dict[str, _Pending] = {}
        self._points: dict[str, tuple[array[int], array[float]]] = {}
        self._subscribers: list[Subscriber] = []
        self._released_t_ns: int | None = None  # the last released tick
        self._check_at = chunk_ticks
        #: deferred: released chunks and the index of the next subscriber to hand each to
        self._queue: deque[tuple[Chunk, int]] = deque()

    def subscribe(self, fn: Subscriber) -> None:
        self._subscribers.append(fn)

    @property
    def queued_chunks(self) -> int:
        """Deferred: released chunks not yet handed to every subscriber."""
        return len(self._queue)

    def pump(self, more: Callable[[], bool]) -> int:
        """Deferred: hand queued chunks to the subscribers, one call at a time, while
        ``more()`` says so (asked before each call); returns the calls made."""
        calls = 0
        n = len(self._subscribers)
        while self._queue and more():
            chunk, i = self._queue[0]
            if i + 1 < n:
                self._queue[0] = (chunk, i + 1)
            else:
                self._queue.popleft()
            self._subscribers[i](chunk)
            calls += 1
        return calls

    # -- writing (the Trace API) ------------------------------------------------------------
    def define(self, group: str, fields: dict[str, int]) -> None:
        """Declare a per-tick group: field name -> number of columns, in row order."""
        self.fields[group] = dict(fields)
        self._rows[group] = _Pending(sum(fields.values()))

    def row(self, group: str, t_ns: int, values: tuple[float, ...]) -> None:
        """Append one row of a group (values in the declared field order, flattened)."""
        rows = self._rows[group]
        if len(values) != rows.width:
            raise ValueError(f"a row of {len(values)} values for a group of {rows.width} columns")
        rows.times.append(t_ns)
        rows.values.extend(values)
        if group == self.grid and len(rows.times) >= self._check_at:
            self._release(final=False)

    def point(self, name: str, t_ns: int, value: float) -> None:
        """Append one sample of an irregular scalar series."""
        series = self._points.get(name)
        if series is None:
            series = self._points[name] = (array("q"), array("d"))
            self.series[name] = None
        series[0].append(t_ns)
        series[1].append(float(value))

    def finish(self) -> None:
        """The run is over: release everything still held and deliver what is queued (once)."""
        if not self.finished:
            self.finished = True
            self._release(final=True)
            self.pump(_always)

    # -- releasing ------------------------------------------------------------------------------
    def _ready(self, final: bool) -> int:
        """How many of the held ticks may leave now."""
        n = min((len(r.times) for r in self._rows.values()), default=0)
        if final or n == 0:
            return n
        grid = self._rows[self.grid].times
        return bisect.bisect_right(grid, grid[n - 1] - self.horizon_ns, 0, n)

    def _release(self, final: bool) -> None:
        n = self._ready(final)
        if not final and n < self.chunk_ticks:
            self._check_at = len(self._rows[self.grid].times) + self.chunk_ticks // 4
            return
        grid_t = self._rows[self.grid].times
        t_ns = np.array(grid_t[:n], dtype=np.int64)
        rows: dict[str, np.ndarray] = {}
        for group, pending in self._rows.items():
            if group != self.grid and pending.times[:n] != grid_t[:n]:
                raise ValueError(f"trace group {group!r} is not on the {self.grid!r} tick grid")
            cut = n * pending.width
            rows[group] = np.array(pending.values[:cut], dtype=np.float64).reshape(n, pending.width)
            pending.times, pending.values = pending.times[n:], pending.values[cut:]
        boundary = int(t_ns[-1]) if n else self._released_t_ns
        points: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        for name, (times, values) in self._points.items():
            j = len(times) if final or boundary is None else bisect.bisect_right(times, boundary)
            if j == 0:
                continue
            if self._released_t_ns is not None:
                self.late_points += bisect.bisect_right(times, self._released_t_ns, 0, j)
            points[name] = (np.array(times[:j], dtype=np.int64), np.array(values[:j], dtype=np.float64))
            self._points[name] = (times[j:], values[j:])
        if n:
            self._released_t_ns = boundary
        self._check_at = len(self._rows[self.grid].times) + self.chunk_ticks
        chunk = Chunk(t_ns, rows, points, final)
        if self.deferred:
            if self._subscribers:  # a chunk no one takes is not queued
                self._queue.append((chunk, 0))
            return
        for fn in self._subscribers:
            fn(chunk)


def _always() -> bool:
    return True


class TraceSink(Protocol):
    """What a run writes its signals to (hil/flight/runlog.py): this stream, a whole-run
    :class:`hil.analysis.trace.Trace`, or both through a :class:`TraceTee`."""

    def define(self, group: str, fields: dict[str, int]) -> None: ...

    def row(self, group: str, t_ns: int, values: tuple[float, ...]) -> None: ...

    def point(self, name: str, t_ns: int, value: float) -> None: ...


class TraceTee:
    """Several trace sinks fed as one (the stream, and the whole-run Trace when kept)."""

    def __init__(self, *sinks: TraceSink) -> None:
        self.sinks = sinks

    def define(self, group: str, fields: dict[str, int]) -> None:
        for s in self.sinks:
            s.define(group, fields)

    def row(self, group: str, t_ns: int, values: tuple[float, ...]) -> None:
        for s in self.sinks:
            s.row(group, t_ns, values)

    def point(self, name: str, t_ns: int, value: float) -> None:
        for s in self.sinks:
            s.point(name, t_ns, value)
