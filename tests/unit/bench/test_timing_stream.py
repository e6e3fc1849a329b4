"""Timing statistics are streamed: their memory does not grow with the flight's length, and
their percentiles agree with numpy's on the same samples (within the histogram resolution).

A memory measurement with a generous bound (tracemalloc), not a timed assertion."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.flight.tickloop import TickStats
from hil.analysis.timing_stream import LatencySample
from hil.analysis.timing_stream import STREAM_RESOLUTION, LatencyStats, StreamingStats
from tests.unit.bench.traced import traced

TICK_NS = 2_500_000


def _feed(ticks: int, seed: int = 1) -> tuple[TickStats, LatencyStats]:
    """What a run's timing keeps for ``ticks`` ticks (the bench's and the devices' statistics)."""
    rng = np.random.default_rng(seed)
    st, lat = TickStats(), LatencyStats(TICK_NS)
    host = 10**12
    cost = rng.lognormal(12.8, 0.6, ticks).astype(int).tolist()  # ~360 us, long tail
    cpu = rng.lognormal(12.3, 0.3, ticks).astype(int).tolist()
    for k in range(ticks):
        t = k * TICK_NS
        host += TICK_NS + int(cost[k] // 8)
        st.latencies_ns.append(cpu[k] // 4)
        st.tick_cost_ns.append(cost[k])
        st.fc_cpu_ns.append(cpu[k])
        lat.add(LatencySample(t, host, host + cost[k] // 2, t + cpu[k] // 4, cpu[k]))
    return st, lat


def _traced_bytes(ticks: int) -> int:
    return traced(lambda: _feed(ticks))[1]


def test_memory_of_a_10_minute_flight_is_that_of_a_10_s_one() -> None:
    short = _traced_bytes(10 * 400)  # 10 s
    long = _traced_bytes(600 * 400)  # 10 minutes: lists of every sample took ~76 MB here
    # streamed, except the flight code's CPU per sample, kept whole by design (8 bytes a
    # sample, so the summary and `hil timing` compute from the same values): 1.9 MB
    per_sample_cpu = 8 * (600 - 10) * 400
    assert long - short < 1_000_000 + per_sample_cpu, (short, long)
    assert long < 2_000_000 + per_sample_cpu


@pytest.mark.parametrize("q", [1, 50, 90, 99, 99.9])
def test_percentiles_agree_with_numpy(q: float) -> None:
    rng = np.random.default_rng(7)
    for values in (rng.lognormal(12, 1, 20_000), rng.integers(0, 3000, 20_000).astype(float),
                   np.r_[np.zeros(500), rng.normal(0, 1e4, 5000)]):
        s = StreamingStats(values.tolist())
        ref = float(np.percentile(values, q, method="lower"))
        assert math.isclose(s.percentile(q), ref, rel_tol=STREAM_RESOLUTION, abs_tol=1e-9)
        assert s.max == values.max() and s.min == values.min() and len(s) == values.size
        assert math.isclose(s.mean, values.mean(), rel_tol=1e-9, abs_tol=1e-9)


def test_empty_and_non_finite() -> None:
    s = StreamingStats([math.nan, math.inf])
    assert len(s) == 0 and not s and math.isnan(s.percentile(50)) and math.isnan(s.mean)
    s.append(5)
    assert s.percentile(0) == s.percentile(100) == 5 and abs(s.percentile(50) - 5) <= 5 * STREAM_RESOLUTION


def test_period_and_host_latency_from_samples() -> None:
    lat = LatencyStats(TICK_NS)
    for k in range(100):
        t = k * TICK_NS
        lat.add(LatencySample(t, 1000 + t, 1000 + t + 300_000 if k != 50 else None, t + 10_000))
    assert lat.samples == 100 and len(lat.host_latency_ns) == 99
    assert abs(lat.host_latency_ns.percentile(50) - 300_000) <= 300_000 * STREAM_RESOLUTION
    assert lat.sim_period.period.percentile(50) == pytest.approx(TICK_NS, rel=STREAM_RESOLUTION)
    assert lat.sim_period.jitter.max == 0
    assert lat.host_period.period.max == 2 * TICK_NS  # the miss: two periods between arrivals


def test_extend_counts_repeated_values_as_appends() -> None:
    """A held signal's block (each value repeated) gives what appending each sample gives."""
    rng = np.random.default_rng(3)
    held = np.repeat(rng.lognormal(5, 0.5, 200), 8)
    held[::17] = math.nan
    a, b = StreamingStats(held.tolist()), StreamingStats()
    for block in np.array_split(held, 7):
        b.extend(block)
    assert (a.n, a.min, a.max) == (b.n, b.min, b.max) and a._bins == b._bins
    assert math.isclose(a.total, b.total, rel_tol=1e-12)
