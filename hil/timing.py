"""Timing of the flight code's 400 Hz loop, from a run's MCAP log (or arrays).

Figures (all microseconds unless noted):

* **period**: host-time interval between consecutive ESC commands (the loop's output
  cadence). In realtime mode this is the loop's real period; in lockstep it is paced by
  the bench and reported for completeness.
* **latency**: IMU sample emitted (bench, host clock) -> ESC command received. This is the
  flight code's response time including both pty hops. In lockstep it is the compute
  latency of one sample, checked against the 2.5 ms budget even though the run itself is
  faster than real time.
* **jitter**: period minus its nominal value.
* **misses**: samples whose latency exceeded the budget, plus samples with no command at
  all (barrier timeouts).
* **compute**: the flight code's own per-loop compute time as it reports in telemetry.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from hil.devices import LatencySample

NOMINAL_PERIOD_US = 2500.0
#: relative width of a StreamingStats bin: percentiles are within half of it (0.25 %)
STREAM_RESOLUTION = 0.005


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

    _LOG_STEP = math.log1p(STREAM_RESOLUTION)

    def __init__(self, values: Iterable[float] = ()) -> None:
        self._bins: dict[int, int] = {}
        self.n = 0
        self.total = 0.0
        self.min = math.inf
        self.max = -math.inf
        for v in values:
            self.append(v)

    def append(self, value: float) -> None:
        v = float(value)
        if not math.isfinite(v):
            return
        self.n += 1
        self.total += v
        if v < self.min:
            self.min = v
        if v > self.max:
            self.max = v
        if v == 0.0:
            key = 0
        else:  # bins are +-(1 + k) for |v| in [(1+r)^k, (1+r)^(k+1)); k may be negative (|v| < 1)
            k = math.floor(math.log(abs(v)) / self._LOG_STEP)
            key = (k + (1 << 40)) if v > 0 else -(k + (1 << 40))
        self._bins[key] = self._bins.get(key, 0) + 1

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
        mid = math.exp((k + 0.5) * self._LOG_STEP)
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


class LatencyStats:
    """The run's response-time figures from every ``LatencySample``, streamed (hil/devices.py
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


@dataclass(frozen=True)
class Stats:
    n: int
    p50: float
    p99: float
    p999: float
    max: float
    mean: float

    @staticmethod
    def of(values: np.ndarray) -> Stats:
        v = np.asarray(values, dtype=float)
        v = v[np.isfinite(v)]
        if v.size == 0:
            nan = float("nan")
            return Stats(0, nan, nan, nan, nan, nan)
        return Stats(
            int(v.size),
            float(np.percentile(v, 50)),
            float(np.percentile(v, 99)),
            float(np.percentile(v, 99.9)),
            float(v.max()),
            float(v.mean()),
        )


@dataclass(frozen=True)
class TimingReport:
    samples: int
    budget_us: float
    latency_us: Stats
    period_us: Stats
    jitter_us: Stats  #: |period - nominal|
    compute_us: Stats
    misses: int  #: latency over budget
    no_command: int  #: barrier timeouts (no ESC command for a sample)

    def as_dict(self) -> dict[str, object]:
        return asdict(self)


def analyze_arrays(
    latency_us: np.ndarray,
    esc_arrival_host_ns: np.ndarray,
    *,
    compute_us: np.ndarray | None = None,
    budget_us: float = NOMINAL_PERIOD_US,
    nominal_period_us: float = NOMINAL_PERIOD_US,
) -> TimingReport:
    """The report from raw per-sample arrays; negative latency marks a missing command."""
    lat = np.asarray(latency_us, dtype=float)
    missing = lat < 0
    lat_ok = lat[~missing]
    arrivals = np.asarray(esc_arrival_host_ns, dtype=np.int64)
    arrivals = arrivals[arrivals > 0]
    period = np.diff(arrivals) / 1e3 if arrivals.size > 1 else np.zeros(0)
    jitter = np.abs(period - nominal_period_us)
    comp = np.zeros(0) if compute_us is None else np.asarray(compute_us, dtype=float)
    return TimingReport(
        samples=int(lat.size),
        budget_us=budget_us,
        latency_us=Stats.of(lat_ok),
        period_us=Stats.of(period),
        jitter_us=Stats.of(jitter),
        compute_us=Stats.of(comp),
        misses=int(np.sum(lat_ok > budget_us)),
        no_command=int(np.sum(missing)),
    )


def analyze_log(log: Path, budget_us: float = NOMINAL_PERIOD_US) -> TimingReport:
    """The report of a run's MCAP (topics /hil/timing/tick and /fc/telemetry)."""
    from hil.record import read_topic

    tick = read_topic(log, "/hil/timing/tick")
    tm = read_topic(log, "/fc/telemetry")
    compute = None
    for key in ("compute_last_us", "compute_us", "loop_compute_us"):
        if key in tm and tm[key].size:
            compute = tm[key]
            break
    if not tick or "latency_us" not in tick:
        return analyze_arrays(np.zeros(0), np.zeros(0), compute_us=compute, budget_us=budget_us)
    return analyze_arrays(tick["latency_us"], tick["esc_arrival_host_ns"], compute_us=compute, budget_us=budget_us)


def plot_latency(log: Path, png: Path, budget_us: float = NOMINAL_PERIOD_US) -> Path | None:
    """Latency over time and its histogram, with the budget marked; None if no timing data."""
    from hil.record import read_topic

    tick = read_topic(log, "/hil/timing/tick")
    if not tick or "latency_us" not in tick or tick["latency_us"].size == 0:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lat = tick["latency_us"].astype(float)
    t = (tick["log_time_ns"] - tick["log_time_ns"][0]) / 1e9
    ok = lat >= 0
    arrivals = tick["esc_arrival_host_ns"].astype(np.int64)
    arrivals = arrivals[arrivals > 0]
    period = np.diff(arrivals) / 1e3
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    axes[0].plot(t[ok], lat[ok], ".", ms=1)
    axes[0].axhline(budget_us, color="r", ls="--", label=f"budget {budget_us:g} us")
    axes[0].set_xlabel("sim time [s]")
    axes[0].set_ylabel("IMU -> ESC latency [us]")
    axes[0].legend()
    axes[1].hist(lat[ok], bins=100, log=True)
    axes[1].axvline(budget_us, color="r", ls="--")
    axes[1].set_xlabel("latency [us]")
    axes[1].set_ylabel("samples")
    if period.size:
        axes[2].hist(period, bins=100, log=True)
        axes[2].axvline(NOMINAL_PERIOD_US, color="g", ls="--", label="2.5 ms")
        axes[2].legend()
    axes[2].set_xlabel("ESC command period [us] (host clock)")
    for ax in axes:
        ax.grid(True)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)
    return png
