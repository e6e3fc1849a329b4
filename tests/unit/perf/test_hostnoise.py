"""The host-interruption probe of `hil perf` (hil/perf/hostnoise.py): which steps count as gaps,
and that the probe runs one pinned process per CPU and gives each CPU's figures (no timing
asserted: what the host does is the measurement, not a property of the code)."""

from __future__ import annotations

import os

import pytest
from hypothesis import given
from hypothesis import strategies as st

from hil.perf.hostnoise import CpuNoise, measure, spin_window


def _clock(times: list[int]):
    """A clock that reads ``times`` in turn."""
    return iter(times).__next__


def test_only_steps_longer_than_the_threshold_are_gaps() -> None:
    times = [0, 100, 250, 1_250, 1_300, 1_300, 5_300]
    assert spin_window(_clock(times), 5_300, 200) == ([1_000, 4_000], 5_300)
    assert spin_window(_clock(times), 5_300, 4_000) == ([], 5_300)


def test_the_window_ends_at_the_first_reading_past_its_span() -> None:
    # the span ends at 1 000 ns: the reading at 1 250 ends it, the rest is never read
    assert spin_window(_clock([0, 100, 250, 1_250, 99_999]), 1_000, 200) == ([1_000], 1_250)


@given(st.lists(st.integers(min_value=1, max_value=10_000), min_size=1, max_size=50), st.integers(min_value=0, max_value=5_000))
def test_the_gaps_are_the_long_steps_and_never_exceed_the_span(steps: list[int], threshold: int) -> None:
    times = [0]
    for s in steps:
        times.append(times[-1] + s)
    gaps, spanned = spin_window(_clock(times), times[-1], threshold)
    assert gaps == [s for s in steps if s > threshold]
    assert spanned == times[-1] and sum(gaps) <= spanned


def test_figures_of_one_cpu() -> None:
    noise = CpuNoise(cpu=1, measured_s=2.0, gaps_ns=(300_000, 2_500_000), policy="SCHED_OTHER")
    assert noise.longest_us == 2500.0
    assert noise.lost_ms == pytest.approx(2.8)
    assert noise.per_10s() == pytest.approx(10.0)
    assert CpuNoise(0, 1.0, (), "SCHED_OTHER").longest_us == 0.0


def test_the_probe_spins_on_each_cpu_it_may_use() -> None:
    cpus = sorted(os.sched_getaffinity(0))
    result = measure(0.2, priority=10)
    assert [c.cpu for c in result] == cpus
    for c in result:
        assert 0.15 <= c.measured_s <= 1.0
        assert all(g > 200_000 for g in c.gaps_ns)
        assert c.policy in ("SCHED_FIFO priority 10", "SCHED_OTHER")
    assert os.sched_getscheduler(0) == os.SCHED_OTHER  # the probes were raised, this process not


def test_the_probe_runs_in_windows_that_real_time_throttling_never_cuts() -> None:
    # 1.2 s is two windows with a rest between them: the rest is not measured, nor a gap
    [c] = measure(1.2, cpus=[min(os.sched_getaffinity(0))], priority=10)
    assert 1.1 <= c.measured_s <= 1.5
    assert c.longest_us < 50_000  # the kernel's 50 ms throttle would show here


def test_a_bad_duration_is_refused() -> None:
    with pytest.raises(ValueError, match="seconds"):
        measure(0)
