"""The flight loop's garbage collection: frozen after boot, deferred to between iterations,
at CPython's own thresholds; the process gets its collector back on the way out."""

from __future__ import annotations

import gc
from collections.abc import Iterator

import pytest

from flightcode.gc_policy import LoopCollector


@pytest.fixture
def collector() -> Iterator[LoopCollector]:
    c = LoopCollector((100, 3, 2))
    yield c
    c.stop()  # the test process keeps its automatic collection whatever happened


def _cycles(n: int) -> None:
    for _ in range(n):
        a: list[object] = []
        a.append(a)  # unreachable once the loop moves on: only the collector frees it


def test_start_freezes_the_boot_objects_and_takes_over(collector: LoopCollector) -> None:
    assert gc.isenabled()
    collector.start()
    assert collector.running and not gc.isenabled()
    assert gc.get_freeze_count() > 0
    collector.stop()
    assert gc.isenabled() and gc.get_freeze_count() == 0 and not collector.running


def test_nothing_is_collected_below_the_threshold(collector: LoopCollector) -> None:
    collector.start()
    gc.collect(0)  # counts from zero
    _cycles(10)
    assert collector.after_iteration() is None
    assert not collector.collections


def test_generations_follow_cpythons_thresholds(collector: LoopCollector) -> None:
    """Thresholds (100, 3, 2), counts must exceed them as in CPython: over 100 allocations
    a young collection; once 4 young ones are counted, a middle one instead; once 3 middle
    ones are counted, the next is a full one (the oldest generation over its threshold)."""
    collector.start()
    gc.collect(2)  # all counts from zero
    picked = []
    for _ in range(16):
        _cycles(400)
        picked.append(collector.after_iteration())
    assert picked == [0, 0, 0, 0, 1] * 3 + [2]
    assert collector.collections == {0: 12, 1: 3, 2: 1}


def test_garbage_is_reclaimed_between_iterations(collector: LoopCollector) -> None:
    collector.start()
    gc.collect(2)
    before = len(gc.get_objects(generation=0))
    for _ in range(20):
        _cycles(150)
        collector.after_iteration()
    assert len(gc.get_objects(generation=0)) <= before + 150 * 2  # not 20 x 150 cycles piling up


def test_stop_leaves_a_disabled_collector_disabled() -> None:
    gc.disable()
    try:
        c = LoopCollector()
        c.start()
        c.stop()
        assert not gc.isenabled()
    finally:
        gc.enable()


@pytest.mark.parametrize("bad", [(0, 10, 10), (700, 10)])
def test_bad_thresholds_are_refused(bad: tuple[int, ...]) -> None:
    with pytest.raises(ValueError):
        LoopCollector(bad)  # type: ignore[arg-type]


def test_after_iteration_before_start_does_nothing() -> None:
    assert LoopCollector().after_iteration() is None
