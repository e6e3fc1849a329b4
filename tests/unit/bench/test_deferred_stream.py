"""A deferred trace stream (realtime runs): released chunks wait in a queue and reach the
subscribers one call at a time, while the caller has time (hil/flight/run.py ``pump_before``)."""

from __future__ import annotations

import numpy as np

from hil import clock
from hil.flight.run import SLACK_MARGIN_NS, SLACK_MAX_QUEUED, pump_before
from hil.analysis.trace_stream import Chunk, TraceStream

TICK_NS = 2_500_000


def _stream(deferred: bool, log: list[tuple[str, int]]) -> TraceStream:
    stream = TraceStream(horizon_ns=0, chunk_ticks=2, deferred=deferred)
    stream.define("truth", {"a": 1})
    for name in ("first", "second"):
        stream.subscribe(lambda chunk, name=name: log.append((name, int(chunk.t_ns[0]) if len(chunk.t_ns) else -1)))
    return stream


def _feed(stream: TraceStream, ticks: range) -> None:
    for k in ticks:
        stream.row("truth", k * TICK_NS, (float(k),))


def test_deferred_chunks_wait_and_arrive_in_order_one_call_at_a_time() -> None:
    log: list[tuple[str, int]] = []
    stream = _stream(True, log)
    _feed(stream, range(6))
    assert log == [] and stream.queued_chunks == 3  # released (ticks 0-1, 2-3, 4-5), not delivered
    asked: list[int] = []

    def twice() -> bool:
        asked.append(len(log))
        return len(asked) <= 3

    assert stream.pump(twice) == 3
    assert asked == [0, 1, 2, 3]  # asked before every call
    assert log == [("first", 0), ("second", 0), ("first", 2 * TICK_NS)]
    assert stream.queued_chunks == 2
    stream.finish()  # delivers the rest, and the final chunk (no ticks left: empty)
    assert log == [("first", 0), ("second", 0), ("first", 2 * TICK_NS), ("second", 2 * TICK_NS),
                   ("first", 4 * TICK_NS), ("second", 4 * TICK_NS), ("first", -1), ("second", -1)]
    assert stream.queued_chunks == 0


def test_deferred_and_direct_streams_deliver_the_same_chunks() -> None:
    got: dict[bool, list[Chunk]] = {True: [], False: []}
    for deferred in (True, False):
        stream = TraceStream(horizon_ns=3 * TICK_NS, chunk_ticks=4, deferred=deferred)
        stream.define("truth", {"a": 2})
        stream.subscribe(got[deferred].append)
        for k in range(37):
            stream.row("truth", k * TICK_NS, (float(k), -float(k)))
            stream.point("tm.x", k * TICK_NS - TICK_NS, float(k))
            if deferred and k % 5 == 0:
                stream.pump(lambda: True)
        stream.finish()
    assert len(got[True]) == len(got[False]) > 2
    for a, b in zip(got[True], got[False], strict=True):
        np.testing.assert_array_equal(a.t_ns, b.t_ns)
        np.testing.assert_array_equal(a.rows["truth"], b.rows["truth"])
        np.testing.assert_array_equal(a.points["tm.x"][1], b.points["tm.x"][1])
        assert a.final == b.final


def test_a_direct_stream_delivers_at_release() -> None:
    log: list[tuple[str, int]] = []
    stream = _stream(False, log)
    _feed(stream, range(2))
    assert log == [("first", 0), ("second", 0)] and stream.queued_chunks == 0


def test_pump_before_stops_short_of_the_deadline() -> None:
    log: list[tuple[str, int]] = []
    stream = _stream(True, log)
    _feed(stream, range(4))
    now = clock.monotonic_ns()
    # no time left before this deadline, and the queue is short: nothing runs
    assert pump_before(stream, now + SLACK_MARGIN_NS // 2) == 0 and log == []
    # a deadline far away: everything queued runs
    assert pump_before(stream, now + 10**12) == 4 and stream.queued_chunks == 0


def test_pump_before_makes_one_call_when_too_much_is_queued() -> None:
    log: list[tuple[str, int]] = []
    stream = _stream(True, log)
    _feed(stream, range(2 * (SLACK_MAX_QUEUED + 1)))
    assert stream.queued_chunks == SLACK_MAX_QUEUED + 1
    past = clock.monotonic_ns() - 10**9
    assert pump_before(stream, past) == 1 and log == [("first", 0)]
    assert pump_before(stream, past) == 1  # the first chunk is now fully delivered...
    assert stream.queued_chunks == SLACK_MAX_QUEUED and pump_before(stream, past) == 0  # ...and that is enough


def test_the_margin_leaves_room_for_the_pacers_spin() -> None:
    assert SLACK_MARGIN_NS > clock.SPIN_NS


def test_a_deferred_stream_without_subscribers_queues_nothing() -> None:
    stream = TraceStream(horizon_ns=0, chunk_ticks=2, deferred=True)
    stream.define("truth", {"a": 1})
    _feed(stream, range(7))
    assert stream.queued_chunks == 0 and stream.pump(lambda: True) == 0
    stream.finish()


def test_released_chunks_keep_their_values_while_the_stream_goes_on() -> None:
    # what the stream appends and releases after a chunk must not show through it (the
    # chunk's arrays may not share memory with what the stream still holds)
    chunks: list[Chunk] = []
    stream = TraceStream(horizon_ns=2 * TICK_NS, chunk_ticks=3)
    stream.define("esc", {"b": 1})
    stream.define("truth", {"a": 2})
    stream.subscribe(chunks.append)
    n = 50
    for k in range(n):
        stream.row("esc", k * TICK_NS, (10.0 * k,))
        stream.point("tm.x", k * TICK_NS - TICK_NS, -float(k))
        stream.row("truth", k * TICK_NS, (float(k), -float(k)))
    stream.finish()
    assert len(chunks) > 5
    k = np.arange(n)
    np.testing.assert_array_equal(np.concatenate([c.t_ns for c in chunks]), k * TICK_NS)
    np.testing.assert_array_equal(np.concatenate([c.rows["truth"] for c in chunks]), np.column_stack([k, -k]))
    np.testing.assert_array_equal(np.concatenate([c.rows["esc"] for c in chunks]), 10.0 * k[:, None])
    points = [c.points["tm.x"] for c in chunks if "tm.x" in c.points]
    np.testing.assert_array_equal(np.concatenate([p[0] for p in points]), k * TICK_NS - TICK_NS)
    np.testing.assert_array_equal(np.concatenate([p[1] for p in points]), -k.astype(float))
