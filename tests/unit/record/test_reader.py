"""reader.py: columns, shapes, dtypes, counts, torn files; codec properties with hypothesis."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hil.record import (
    Recorder,
    TornRecordingError,
    iter_messages,
    message_counts,
    read_metadata,
    read_topic,
    read_wire,
)
from hil.record.topics import TOPICS
from tests.unit.record.support import RUN_START_NS, expected_messages, record_examples


def test_read_topic_shapes_and_dtypes(tmp_path: Path) -> None:
    rec = record_examples(tmp_path / "r.mcap", n_rounds=4)
    truth = read_topic(rec.path, "/sim/truth")
    assert truth["log_time_ns"].dtype == np.int64
    assert truth["log_time_ns"].tolist() == [RUN_START_NS + k * 2_500_000 for k in range(4)]
    assert truth["p_N_m"].shape == (4, 3) and truth["p_N_m"].dtype == np.float64
    assert truth["q_NB"].shape == (4, 4)
    assert truth["euler_deg.yaw"].tolist() == [5.0] * 4
    assert truth["on_ground"].dtype == bool
    assert truth["t_ns"].dtype == np.int64
    rc = read_topic(rec.path, "/hil/rc/pulses")
    assert rc["pulse_us"].dtype == np.float64 and rc["pulse_us"].shape == (4, 8)  # protobuf float (JSON-era: int)
    esc = read_topic(rec.path, "/hil/esc/output")
    assert esc["armed"].dtype == bool and esc["armed"].shape == (4, 4)
    log = read_topic(rec.path, "/fc/log")
    assert log["timestamp.sec"].tolist() == [(RUN_START_NS + k * 2_500_000) // 10**9 for k in range(4)]
    assert log["message"].tolist() == ["armed"] * 4
    counters = read_topic(rec.path, "/hil/device/counters")
    assert counters["counters.imu.bad_checksum"].tolist() == [0] * 4
    verdict = read_topic(rec.path, "/hil/verdict")
    assert verdict["criteria"].dtype == object and verdict["criteria"][0][0]["name"] == "hover_alt"


def test_ragged_and_missing_fields(tmp_path: Path) -> None:
    rec = Recorder(tmp_path / "r.mcap", run_start_unix_ns=RUN_START_NS, metadata={})
    with rec:
        rec.log("/fc/telemetry", 0, {"a": 1, "v": [1.0, 2.0]}, 0)
        rec.log("/fc/telemetry", 1, {"b": "x", "v": [1.0]}, 0)
        rec.log("/fc/telemetry", 2, {"a": 2.5, "v": [3.0, 4.0]}, 0)
    tel = read_topic(rec.path, "/fc/telemetry")
    assert np.isnan(tel["a"][1]) and tel["a"][2] == 2.5
    assert tel["b"].dtype == object and tel["b"].tolist() == [None, "x", None]
    assert tel["v"].dtype == object  # ragged lists stay lists


def test_empty_and_unknown_topics(tmp_path: Path) -> None:
    rec = Recorder(tmp_path / "r.mcap", run_start_unix_ns=RUN_START_NS, metadata={})
    with rec:
        rec.log("/hil/events", 0, {"kind": "bench", "name": "x", "detail": {}}, 0)
    empty = read_topic(rec.path, "/hil/rc/pulses")
    assert list(empty) == ["log_time_ns"] and empty["log_time_ns"].shape == (0,)
    with pytest.raises(KeyError):
        read_topic(rec.path, "/nope")
    counts = message_counts(rec.path)
    assert set(counts) == set(TOPICS) and counts["/hil/events"] == 1 and counts["/hil/rc/pulses"] == 0


def test_iter_messages_filters_and_orders(tmp_path: Path) -> None:
    rec = record_examples(tmp_path / "r.mcap", n_rounds=3)
    all_msgs = list(iter_messages(rec.path))
    assert len(all_msgs) == 3 * sum(len(expected_messages(s, 0, 0)) for s in TOPICS.values())
    for topic in TOPICS:  # each topic in order; across topics by the stored message's log time
        times = [lt for t, lt, _ in all_msgs if t == topic]
        assert times == sorted(times) and len(times) >= 3
    stored = [lt for _, lt, _ in iter_messages(rec.path, expand=False)]
    assert stored == sorted(stored) and len(stored) == 3 * len(TOPICS) - 2 * sum(t.startswith("/hil/wire/") for t in TOPICS)
    only = {t for t, _, _ in iter_messages(rec.path, ["/tf", "/fc/log"])}
    assert only == {"/tf", "/fc/log"}


def test_part_files_are_refused(tmp_path: Path) -> None:
    rec = record_examples(tmp_path / "r.mcap", n_rounds=3)
    torn = tmp_path / "t.mcap.part"
    torn.write_bytes(rec.path.read_bytes()[:-20])
    for fn in (read_metadata, message_counts, lambda p: list(iter_messages(p)), lambda p: read_topic(p, "/tf")):
        with pytest.raises(TornRecordingError):
            fn(torn)


# ---- codec properties ----------------------------------------------------------------------
finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
vec3 = st.lists(finite, min_size=3, max_size=3)


@settings(deadline=None, max_examples=25)
@given(chunks=st.lists(st.binary(max_size=300), min_size=1, max_size=30),
       t0=st.integers(-10**12, 10**12))
def test_wire_bytes_round_trip_exactly(chunks: list[bytes], t0: int) -> None:
    with tempfile.TemporaryDirectory() as d:
        rec = Recorder(Path(d) / "w.mcap", run_start_unix_ns=RUN_START_NS, metadata={}, chunk_size=1024)
        with rec:
            for i, c in enumerate(chunks):
                rec.log_wire("telemetry", "rx", t0 + i, i, c)
        assert read_wire(rec.path, "telemetry", "rx") == b"".join(chunks)
        wire = read_topic(rec.path, "/hil/wire/telemetry/rx")
        assert wire["len"].tolist() == [len(c) for c in chunks]
        assert wire["t_ns"].tolist() == [t0 + i for i in range(len(chunks))]


@settings(deadline=None, max_examples=25)
@given(rows=st.lists(st.tuples(vec3, finite, st.booleans(), st.integers(-2**62, 2**62)), min_size=1, max_size=20))
def test_truth_values_round_trip_exactly(rows: list[tuple[list[float], float, bool, int]]) -> None:
    with tempfile.TemporaryDirectory() as d:
        rec = Recorder(Path(d) / "t.mcap", run_start_unix_ns=RUN_START_NS, metadata={})
        with rec:
            for k, (p, h, g, n) in enumerate(rows):
                truth: dict[str, Any] = {**TOPICS["/sim/truth"].example, "p_N_m": p, "h_m": h, "on_ground": g}
                rec.log("/sim/truth", k, truth, 0)
                rec.log("/fc/telemetry", k, {"n": n}, 0)
        got = read_topic(rec.path, "/sim/truth")
        f32 = np.float32  # /sim/truth is float32 (docs/recording.md "Encoding")
        with np.errstate(over="ignore"):
            assert np.array_equal(got["p_N_m"], np.asarray([p for p, _, _, _ in rows], dtype=f32), equal_nan=True)
            assert np.array_equal(got["h_m"], np.asarray([h for _, h, _, _ in rows], dtype=f32), equal_nan=True)
        assert got["on_ground"].tolist() == [g for _, _, g, _ in rows]
        assert read_topic(rec.path, "/fc/telemetry")["n"].tolist() == [n for *_, n in rows]


@settings(deadline=None, max_examples=20)
@given(values=st.lists(st.one_of(finite, st.just(math.nan), st.just(math.inf), st.just(-math.inf)),
                       min_size=1, max_size=10))
def test_non_finite_become_nan_on_read_and_are_counted(values: list[float]) -> None:
    with tempfile.TemporaryDirectory() as d:
        rec = Recorder(Path(d) / "n.mcap", run_start_unix_ns=RUN_START_NS, metadata={})
        with rec:
            for k, v in enumerate(values):
                rec.log("/hil/adc/conversion", k, {"channel": 1, "code": 7, "volts": v}, 0)  # protobuf
                rec.log("/fc/telemetry", k, {"v": v}, 0)  # JSON
        stats = rec.close()
        for topic, key in (("/hil/adc/conversion", "volts"), ("/fc/telemetry", "v")):
            got = read_topic(rec.path, topic)[key]
            for v, g in zip(values, got, strict=True):
                if topic.startswith("/hil"):  # protobuf float32: NaN stays NaN, big finite values become inf
                    with np.errstate(over="ignore"):
                        assert math.isnan(g) if math.isnan(v) else g == np.float32(v)
                else:  # JSON: null for any non-finite
                    assert math.isnan(g) if not math.isfinite(v) else g == v
        bad = sum(not math.isfinite(v) for v in values)
        # protobuf carries NaN and inf as they are; JSON writes null and counts it
        assert stats.nonfinite_by_topic.get("/fc/telemetry", 0) == bad
        assert "/hil/adc/conversion" not in stats.nonfinite_by_topic
