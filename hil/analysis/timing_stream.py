"""The run's timing figures kept as streams in bounded memory: what the tick loop and the
device set record per sample (latency, lateness, bench cost, command periods), whose
percentiles match the batch report of :mod:`hil.analysis.timing` to within
``STREAM_RESOLUTION``.

Values are ns unless a name says otherwise; host ns are the bench's monotonic clock.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from hil.native.frozen import by_fields

#: relative width of a StreamingStats bin: percentiles are within half of it (0.25 %)
STREAM_RESOLUTION = 0.005
#: the width of one histogram bin in log space
_LOG_STEP = math.log1p(STREAM_RESOLUTION)


class StreamingStats:
    """Count, mean, min, max and percentiles of a stream of numbers in bounded memory.

    A run's timing figures used to keep every sample (a list of ints per tick: tens of MB
    for a 10-minute flight). This keeps exact count, sum, min and max, and a sparse
    histogram with logarithmic bins of relative width ``STREAM_RESOLUTION`` (plus an exact
    bin for 0): memory grows with the spread of the values (about 5 000 bins for 1 ns .. 10 s
    at 0.5 %), never with the number of samples. ``percentile(q)`` is the bin's centre, within
    0.25 % of the value ``numpy.percentile(..., method="lower")`` gives. ``append`` keeps it a
    drop-in for the lists it replaces.
    """

    __slots__ = ("_bins", "n", "total", "min", "max")

    def __init__(self, values: Iterable[float] = ()) -> None:
        self._bins: dict[int, int] = {}
        self.n = 0
        self.total = 0.0
        self.min = math.inf
        self.max = -math.inf
        for v in values:
            self.append(v)

    def append(self, value: float, count: int = 1) -> None:
        """Add ``value`` (``count`` times); non-finite values are left out."""
        v = float(value)
        if not math.isfinite(v):
            return
        self.n += count
        self.total += v * count
        if v < self.min:
            self.min = v
        if v > self.max:
            self.max = v
        if v == 0.0:
            key = 0
        else:  # bins are +-(1 + k) for |v| in [(1+r)^k, (1+r)^(k+1)); k may be negative (|v| < 1)
            k = math.floor(math.log(abs(v)) / _LOG_STEP)
            key = (k + (1 << 40)) if v > 0 else -(k + (1 << 40))
        self._bins[key] = self._bins.get(key, 0) + count

    def extend(self, values: np.ndarray) -> None:
        """Add a block of values (a held signal repeats each: one bin update per distinct value)."""
        v = np.asarray(values, dtype=float)
        distinct, counts = np.unique(v[np.isfinite(v)], return_counts=True)
        for value, count in zip(distinct.tolist(), counts.tolist(), strict=True):
            self.append(value, count)

    def __len__(self) -> int:
        return self.n

    def __bool__(self) -> bool:
        return self.n > 0

    @property
    def mean(self) -> float:
        return self.total / self.n if self.n else math.nan

    def _centre(self, key: int) -> float:
        if key == 0:
            return 0.0
        k = abs(key) - (1 << 40)
        mid = math.exp((k + 0.5) * _LOG_STEP)
        return mid if key > 0 else -mid

    def percentile(self, q: float) -> float:
        """The ``q``-th percentile (0..100); NaN if empty. Exact at 0 and 100 (min, max)."""
        if not self.n:
            return math.nan
        if q <= 0:
            return self.min
        if q >= 100:
            return self.max
        rank = q / 100.0 * (self.n - 1)  # the order statistic numpy's "lower" method picks
        seen = 0
        for key in sorted(self._bins, key=self._centre):
            seen += self._bins[key]
            if seen > rank:
                return min(max(self._centre(key), self.min), self.max)
        return self.max

    def memory_bins(self) -> int:
        """Histogram bins held (what the memory grows with)."""
        return len(self._bins)


class PeriodStats:
    """Intervals between consecutive arrival times, streamed: period and |period - nominal|."""

    __slots__ = ("_last", "nominal", "period", "jitter")

    def __init__(self, nominal: float) -> None:
        self._last: int | None = None
        self.nominal = nominal
        self.period = StreamingStats()
        self.jitter = StreamingStats()

    def arrival(self, t: int) -> None:
        if self._last is not None:
            d = t - self._last
            self.period.append(d)
            self.jitter.append(abs(d - self.nominal))
        self._last = t


@dataclass(frozen=True, init=False)
class LatencySample:
    """How one IMU sample was answered. Host ns from the bench's monotonic clock; sim ns."""

    t_ns: int  #: the sample's sim time
    t_emit_host_ns: int  #: when the bench wrote it
    t_arrival_host_ns: int | None  #: when its ESC command arrived (None: no command, a miss)
    t_arrival_ns: int | None = None  #: virtual time: the command's sim time
    fc_cpu_ns: int | None = None  #: virtual time: the flight code's CPU time for it (host ns)
    lateness_ns: int | None = None  #: realtime: how late the tick that emitted it started (host ns)

    def __init__(self, t_ns: int, t_emit_host_ns: int, t_arrival_host_ns: int | None, t_arrival_ns: int | None = None,
                 fc_cpu_ns: int | None = None, lateness_ns: int | None = None) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "t_emit_host_ns", t_emit_host_ns)
        object.__setattr__(self, "t_arrival_host_ns", t_arrival_host_ns)
        object.__setattr__(self, "t_arrival_ns", t_arrival_ns)
        object.__setattr__(self, "fc_cpu_ns", fc_cpu_ns)
        object.__setattr__(self, "lateness_ns", lateness_ns)

    def __reduce__(self) -> tuple[type, tuple[object, ...]]:
        return by_fields(self)  # compiled records pickle by field (hil/native/frozen.py)


class LatencyStats:
    """The run's response-time figures from every ``LatencySample``, streamed (hil/flight/devices.py
    feeds it as samples arrive): host latency and the ESC command period on the host clock and
    on sim time (virtual time)."""

    __slots__ = ("host_latency_ns", "host_period", "sim_period", "samples")

    def __init__(self, tick_ns: int = 2_500_000) -> None:
        self.samples = 0
        self.host_latency_ns = StreamingStats()
        self.host_period = PeriodStats(tick_ns)
        self.sim_period = PeriodStats(tick_ns)

    def add(self, s: LatencySample) -> None:
        self.samples += 1
        if s.t_arrival_host_ns is not None:
            self.host_latency_ns.append(s.t_arrival_host_ns - s.t_emit_host_ns)
            self.host_period.arrival(s.t_arrival_host_ns)
        if s.t_arrival_ns is not None:
            self.sim_period.arrival(s.t_arrival_ns)
