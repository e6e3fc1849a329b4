"""Recorder: round trip of every topic, file layout, counting of everything not written."""

from __future__ import annotations

import json
import math
import threading
import warnings
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.records import Attachment, Channel, Chunk, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

from hil.record import (
    Recorder,
    RecordWriteError,
    UnknownTopicError,
    iter_messages,
    message_counts,
    read_attachments,
    read_metadata,
    read_topic,
    read_wire,
)
from hil.record.topics import TOPICS, WIRE_BATCH_BYTES, Encoding
from hil.record.validate import validate
from hil.transport.base import Direction, WireRecord
from tests.unit.record.support import HOST0_NS, RUN_START_NS, expected_messages, record_examples, strict_json


def _new(path: Path, **kwargs: Any) -> Recorder:
    return Recorder(path, run_start_unix_ns=RUN_START_NS, metadata={"rig": "test"}, **kwargs)


def _raw_messages(path: Path) -> Iterator[tuple[str, Message, Schema | None]]:
    with path.open("rb") as f:
        for schema, channel, message in make_reader(f).iter_messages(log_time_order=False):
            yield channel.topic, message, schema


class Blocking(Mapping[str, Any]):
    """A payload whose encoding blocks the writer thread until released (deterministic backlog)."""

    def __init__(self) -> None:
        self.entered = threading.Event()
        self.release = threading.Event()
        self._d = {"kind": "bench", "name": "blocker", "detail": {}}

    def keys(self):  # type: ignore[override]  # dict(mapping) calls keys() first
        self.entered.set()
        assert self.release.wait(30)
        return self._d.keys()

    def __getitem__(self, k: str) -> Any:
        return self._d[k]

    def __iter__(self) -> Iterator[str]:
        return iter(self._d)

    def __len__(self) -> int:
        return len(self._d)


@pytest.mark.parametrize("writer_thread", [True, False], ids=["writer-thread", "in-caller"])
def test_every_topic_round_trips_and_validates(tmp_path: Path, writer_thread: bool) -> None:
    rec = record_examples(tmp_path / "run.mcap", n_rounds=3, writer_thread=writer_thread)
    stats = rec.close()  # idempotent: same stats again
    assert stats.path == tmp_path / "run.mcap" and stats.path.exists()
    assert not rec.part_path.exists()
    assert stats.dropped == 0
    # 3 wire chunks 2.5 ms apart fit one 100 ms wire message
    assert stats.messages_by_topic == {t: 1 if t.startswith("/hil/wire/") else 3 for t in TOPICS}
    assert stats.chunks_by_topic == {t: 3 for t in TOPICS if t.startswith("/hil/wire/")}
    v = validate(stats.path)
    assert v.ok, v.problems
    for topic, message, schema in _raw_messages(stats.path):
        spec = TOPICS[topic]
        assert schema is not None and schema.name == spec.schema_name
        assert schema.encoding == ("protobuf" if spec.encoding is Encoding.PROTOBUF else "jsonschema")
        if spec.encoding is Encoding.JSON:
            jsonschema.validate(strict_json(message.data), json.loads(schema.data))
        k = message.sequence
        if not topic.startswith("/hil/wire/"):
            assert message.log_time == RUN_START_NS + k * 2_500_000
            assert message.publish_time == HOST0_NS + k * 1000
    seen: dict[str, list[dict[str, Any]]] = {}
    for topic, log_time, msg in iter_messages(stats.path):
        seen.setdefault(topic, []).append(msg)
        assert log_time == RUN_START_NS + msg.get("t_ns", log_time - RUN_START_NS)
    assert set(seen) == set(TOPICS)
    for topic, msgs in seen.items():  # the readers give back what was logged, stamps included
        assert msgs == [m for k in range(3) for m in expected_messages(TOPICS[topic], k * 2_500_000, HOST0_NS + k * 1000)]
    wire = [m for t, _, m in iter_messages(stats.path, ["/hil/wire/imu/tx"])]
    assert [m["data"] for m in wire] == [TOPICS["/hil/wire/imu/tx"].example] * 3


def test_writing_in_the_caller_writes_what_the_writer_thread_writes(tmp_path: Path) -> None:
    """``writer_thread=False`` (the recorder child's mode) encodes and writes in ``log()``
    itself: the same messages, stamps and bytes as through the writer thread, batches too."""
    def record(path: Path, writer_thread: bool) -> list[tuple[str, int, int, bytes]]:
        rec = _new(path, writer_thread=writer_thread)
        with rec:
            for k in range(40):
                t_ns = k * 2_500_000
                batch = rec.batch()
                batch.log_wire("imu", "tx", t_ns, HOST0_NS + k, bytes([k]) * 69)
                batch.log("/hil/esc/command", t_ns, {"t_ns": t_ns, "targets_us": [1100.0 + k] * 4}, HOST0_NS + k)
                batch.log("/hil/events", t_ns, lambda k=k: {"kind": "bench", "name": f"e{k}", "detail": {}}, HOST0_NS + k)
                batch.flush()
                rec.log_wire("adc", "rx", t_ns, HOST0_NS + k, b"\x01\x02")
                rec.log_truth(t_ns, {"t_ns": t_ns, "p_N_m": [0.0, 0.0, -k / 10], "q_NB": [1.0, 0.0, 0.0, 0.0]}, HOST0_NS + k)
        return [(topic, m.log_time, m.publish_time, m.data) for topic, m, _ in _raw_messages(rec.path)]

    threaded = record(tmp_path / "a.mcap", True)
    assert threaded and threaded == record(tmp_path / "b.mcap", False)


def test_protobuf_messages_leave_out_what_the_record_says(tmp_path: Path) -> None:
    rec = _new(tmp_path / "r.mcap")
    with rec:
        rec.log("/hil/esc/command", 2_500_000, {"targets_us": [1100.0] * 4}, 7)
        rec.log("/hil/esc/command", 5_000_000, {"t_ns": 4_000_000, "targets_us": [1100.0] * 4}, 8)
    raw = [m.data for _, m, _ in _raw_messages(rec.path)]
    assert len(raw[0]) < len(raw[1])  # the first has no t_ns field: it equals its log time's sim time
    assert [m["t_ns"] for _, _, m in iter_messages(rec.path, ["/hil/esc/command"])] == [2_500_000, 4_000_000]


def test_metadata_and_attachments_come_first(tmp_path: Path) -> None:
    rec = record_examples(tmp_path / "run.mcap", n_rounds=2)
    with rec.path.open("rb") as f:
        records = list(StreamReader(f, validate_crcs=True).records)
    kinds = [type(r) for r in records[:3]]
    assert kinds == [Header, Metadata, Attachment]
    assert records[1].name == "run" and records[1].metadata["rig"] == "test"
    assert records[1].metadata["run_start_unix_ns"] == str(RUN_START_NS)
    assert records[2].name == "rig.toml" and records[2].data.startswith(b"[vehicle]")
    first_data = next(i for i, r in enumerate(records) if isinstance(r, (Chunk, Schema, Channel, Message)))
    assert first_data == 3
    meta = read_metadata(rec.path)
    assert set(meta) == {"run", "summary"}
    n_wire = sum(t.startswith("/hil/wire/") for t in TOPICS)
    assert meta["summary"]["messages_total"] == str(2 * (len(TOPICS) - n_wire) + n_wire)
    assert meta["summary"]["chunks./hil/wire/imu/tx"] == "2"
    assert meta["summary"]["dropped_total"] == "0"
    assert read_attachments(rec.path) == {"rig.toml": ("application/toml", b"[vehicle]\nmass_kg = 1.0\n")}


def test_final_metadata_is_the_verdict_record(tmp_path: Path) -> None:
    rec = _new(tmp_path / "r.mcap")
    rec.start()
    rec.log("/hil/verdict", 0, {"passed": False, "criteria": []}, 1)
    rec.close({"passed": "false", "reason": "hover_alt"})
    assert read_metadata(rec.path)["verdict"] == {"passed": "false", "reason": "hover_alt"}


def test_full_queue_drops_and_counts(tmp_path: Path) -> None:
    rec = _new(tmp_path / "r.mcap", queue_max=5)
    rec.start()
    blocker = Blocking()
    rec.log("/hil/events", 0, blocker, 0)  # type: ignore[arg-type]
    assert blocker.entered.wait(30)  # the writer is now stuck inside this message; the queue is empty
    for i in range(12):
        rec.log("/hil/events", 1 + i, {"kind": "bench", "name": "e", "detail": {"i": i}}, 0)
    rec.log_wire("esc", "rx", 20, 0, b"\x9f")
    assert rec.pending() == 5
    blocker.release.set()
    stats = rec.close()
    assert stats.dropped == 8
    assert stats.dropped_by_topic == {"/hil/events": 7, "/hil/wire/esc/rx": 1}
    assert stats.messages_by_topic["/hil/events"] == 6
    summary = read_metadata(rec.path)["summary"]
    assert summary["dropped_total"] == "8"
    assert summary["dropped./hil/events"] == "7" and summary["dropped./hil/wire/esc/rx"] == "1"
    assert int(summary["queue_high_water"]) in (5, 6)  # 6 if close()'s stop sentinel was already queued
    assert message_counts(rec.path)["/hil/events"] == 6
    details = [m["detail"] for _, _, m in iter_messages(rec.path, ["/hil/events"])]
    assert details == [{}, {"i": 0}, {"i": 1}, {"i": 2}, {"i": 3}, {"i": 4}]  # the first five after the blocker, in order


def test_per_channel_order_and_log_time_never_goes_back(tmp_path: Path) -> None:
    rec = _new(tmp_path / "r.mcap")
    rec.start()
    # interleave two channels; /hil/events goes back in sim time once (a bench bug): clamped, counted
    times = [0, 5, 10, 7, 20, 20, 30]
    for i, t in enumerate(times):
        rec.log("/hil/events", t * 1_000_000, {"kind": "scenario", "name": "e", "detail": {"i": i}}, i)
        rec.log("/hil/timing/tick", (100 - 10 * i) * 1_000_000 if i == 6 else i * 1_000_000,
                {"k": i, "imu_emit_host_ns": 0, "esc_arrival_host_ns": 0, "latency_us": 0.0, "miss": True}, i)
    stats = rec.close()
    assert stats.clamped_by_topic == {"/hil/events": 1}
    events = list(iter_messages(rec.path, ["/hil/events"]))
    assert [m["detail"] for _, _, m in events] == [{"i": i} for i in range(len(times))]
    log_times = [lt - RUN_START_NS for _, lt, _ in events]
    assert log_times == [0, 5_000_000, 10_000_000, 10_000_000, 20_000_000, 20_000_000, 30_000_000]
    assert [m["t_ns"] for _, _, m in events] == [t * 1_000_000 for t in times]  # payload keeps the truth
    ticks = read_topic(rec.path, "/hil/timing/tick")
    assert ticks["k"].tolist() == list(range(7))
    assert ticks["t_host_ns"].tolist() == list(range(7))
    assert read_metadata(rec.path)["summary"]["clamped_log_time./hil/events"] == "1"


def test_truth_derives_foxglove_transforms(tmp_path: Path) -> None:
    rec = _new(tmp_path / "r.mcap")
    rec.start()
    truth = dict(TOPICS["/sim/truth"].example)
    truth["q_NB"] = [math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4)]  # nose east
    rec.log_truth(2_500_000, truth, 7)
    rec.close()
    assert message_counts(rec.path)["/tf"] == 1 and message_counts(rec.path)["/sim/pose"] == 1
    (_, lt, tf), = iter_messages(rec.path, ["/tf"])
    assert lt == RUN_START_NS + 2_500_000
    assert tf["timestamp"] == {"sec": lt // 10**9, "nsec": lt % 10**9}
    assert tf["translation"] == {"x": -0.2, "y": 0.1, "z": 1.5}
    assert all(abs(tf["rotation"][k] - v) < 1e-12 for k, v in {"x": 0, "y": 0, "z": 0, "w": 1}.items())


def test_numpy_values_and_non_finite_floats(tmp_path: Path) -> None:
    rec = _new(tmp_path / "r.mcap")
    rec.start()
    truth = dict(TOPICS["/sim/truth"].example)
    truth["p_N_m"] = np.array([1.0, 2.0, -3.0])
    truth["mass_kg"] = np.float32(1.25)
    truth["on_ground"] = np.bool_(True)
    rec.log("/sim/truth", 0, truth, 0)
    rec.log("/hil/timing/tick", 0, {"k": np.int64(3), "imu_emit_host_ns": 1, "esc_arrival_host_ns": 0,
                                    "latency_us": float("nan"), "miss": True}, 0)
    rec.log("/hil/events", 0, {"kind": "x", "name": "y", "detail": {"v": float("inf")}}, 0)
    stats = rec.close()
    # protobuf carries NaN as it is; JSON has none: null, counted
    assert stats.nonfinite_by_topic == {"/hil/events": 1} and stats.dropped == 0
    for topic, message, _ in _raw_messages(rec.path):
        if TOPICS[topic].encoding is Encoding.JSON:
            strict_json(message.data)  # valid JSON everywhere: NaN became null
    t = read_topic(rec.path, "/sim/truth")
    assert t["p_N_m"].tolist() == [[1.0, 2.0, -3.0]] and t["mass_kg"].tolist() == [1.25]
    assert t["on_ground"].dtype == bool
    tick = read_topic(rec.path, "/hil/timing/tick")
    assert tick["k"].tolist() == [3] and math.isnan(tick["latency_us"][0])


def test_unencodable_payload_is_counted_not_fatal(tmp_path: Path) -> None:
    rec = _new(tmp_path / "r.mcap")
    rec.start()
    rec.log("/hil/events", 0, {"kind": "bench", "name": "x", "detail": object()}, 0)  # type: ignore[dict-item]
    rec.log("/hil/events", 1, "not a dict", 0)  # type: ignore[arg-type]
    rec.log("/hil/events", 2, {"kind": "bench", "name": "ok", "detail": {}}, 0)
    stats = rec.close()
    assert stats.dropped == 2 and stats.messages_by_topic["/hil/events"] == 1
    summary = read_metadata(rec.path)["summary"]
    assert summary["unencodable./hil/events"] == "2" and summary["error./hil/events"].startswith("TypeError")


def test_programming_errors_are_loud(tmp_path: Path) -> None:
    rec = _new(tmp_path / "r.mcap")
    with pytest.raises(RuntimeError):
        rec.log("/hil/events", 0, {}, 0)
    rec.start()
    with pytest.raises(UnknownTopicError):
        rec.log("/hil/event", 0, {}, 0)
    with pytest.raises(UnknownTopicError):
        rec.log_wire("gps", "tx", 0, 0, b"x")
    with pytest.raises(UnknownTopicError):
        rec.log_wire("imu", "TX", 0, 0, b"x")
    with pytest.raises(RuntimeError):
        rec.start()
    rec.close()
    with pytest.warns(RuntimeWarning):
        rec.log("/hil/events", 0, {"kind": "bench", "name": "late", "detail": {}}, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rec.log("/hil/events", 0, {"kind": "bench", "name": "late", "detail": {}}, 0)  # counted, warned once
    assert rec.dropped_after_close == 2
    with pytest.raises(TypeError):
        Recorder(tmp_path / "x.mcap", run_start_unix_ns=0, metadata={"seed": 7})  # type: ignore[dict-item]


def test_refuses_to_overwrite(tmp_path: Path) -> None:
    record_examples(tmp_path / "r.mcap", n_rounds=1)
    with pytest.raises(FileExistsError):
        _new(tmp_path / "r.mcap").start()
    (tmp_path / "s.mcap.part").write_bytes(b"left over from a killed run")
    with pytest.raises(FileExistsError):
        _new(tmp_path / "s.mcap").start()
    assert (tmp_path / "s.mcap.part").read_bytes() == b"left over from a killed run"


def test_context_manager_and_abort(tmp_path: Path) -> None:
    with pytest.raises(ZeroDivisionError):
        with _new(tmp_path / "r.mcap") as rec:
            rec.log("/hil/events", 0, {"kind": "bench", "name": "a", "detail": {}}, 0)
            1 / 0  # noqa: B018
    meta = read_metadata(tmp_path / "r.mcap")
    assert meta["verdict"]["status"] == "aborted" and "ZeroDivisionError" in meta["verdict"]["error"]
    assert message_counts(tmp_path / "r.mcap")["/hil/events"] == 1
    never = _new(tmp_path / "never.mcap")
    assert never.close().messages_by_topic == {} and not (tmp_path / "never.mcap").exists()


def test_tap_records_transport_wire_records(tmp_path: Path) -> None:
    rec = _new(tmp_path / "r.mcap")
    rec.start()
    rec.tap(WireRecord("rc", Direction.TX, -5_000_000, 11, b"\x01\x02"))
    # a WireRecord holds bytes (compiled, it checks); the writer takes any bytes-like
    rec.log_wire("rc", "tx", 0, 12, bytearray(b"\x03"))  # type: ignore[arg-type]
    rec.tap(WireRecord("esc", Direction.RX, 0, 13, b"\x84\x00"))
    rec.log_wire("esc", "rx", 1, 14, memoryview(b"\x85"))  # type: ignore[arg-type]
    rec.close()
    rc = read_topic(rec.path, "/hil/wire/rc/tx")
    assert rc["log_time_ns"].tolist() == [RUN_START_NS - 5_000_000, RUN_START_NS]
    assert rc["t_ns"].tolist() == [-5_000_000, 0] and rc["len"].tolist() == [2, 1]
    assert list(rc["data"]) == [b"\x01\x02", b"\x03"]
    esc = read_topic(rec.path, "/hil/wire/esc/rx")
    assert esc["port"].tolist() == ["esc", "esc"] and list(esc["data"]) == [b"\x84\x00", b"\x85"]


def test_chunks_are_zstd_and_small(tmp_path: Path) -> None:
    rec = _new(tmp_path / "r.mcap")
    with rec:
        for k in range(3000):
            rec.log_truth(k * 2_500_000, TOPICS["/sim/truth"].example, k)
            rec.log_wire("imu", "tx", k * 2_500_000, k, bytes(range(k % 200)))
    with rec.path.open("rb") as f:
        chunks = [r for r in StreamReader(f, emit_chunks=True).records if isinstance(r, Chunk)]
    assert len(chunks) > 10
    assert {c.compression for c in chunks} == {"zstd"}
    assert max(c.uncompressed_size for c in chunks) <= 65536
    # filled, not flushed early: a chunk closes before the next message would overflow it (a wire message
    # holds up to WIRE_BATCH_BYTES)
    assert min(c.uncompressed_size for c in chunks[:-1]) >= 65536 - WIRE_BATCH_BYTES - 1024
    assert max(len(c.data) for c in chunks) <= 65536


def test_disk_failure_raises_on_close_and_keeps_the_part_file(tmp_path: Path) -> None:
    rec = _new(tmp_path / "r.mcap", chunk_size=1024)
    rec.start()
    assert rec._sink is not None

    def full(data: bytes) -> int:
        raise OSError(28, "No space left on device")

    rec._sink.write = full  # type: ignore[method-assign]
    for k in range(200):
        rec.log("/hil/events", k, {"kind": "bench", "name": "e", "detail": {"x": "x" * 50}}, 0)
    with pytest.raises(RecordWriteError):
        rec.close()
    with pytest.raises(RecordWriteError):
        rec.close()  # idempotent, still loud
    assert rec.part_path.exists() and not rec.path.exists()


def test_failed_start_leaves_nothing_half_open(tmp_path: Path) -> None:
    (tmp_path / "r.mcap").write_bytes(b"previous run")
    rec = _new(tmp_path / "r.mcap")
    with pytest.raises(FileExistsError):
        rec.start()
    with pytest.raises(RuntimeError):
        rec.log("/hil/events", 0, {"kind": "bench", "name": "x", "detail": {}}, 0)
    assert rec.close().messages_by_topic == {}
    bad = Recorder(tmp_path / "a.mcap", run_start_unix_ns=0, metadata={},
                   attachments=[("rig.toml", "application/toml", b"x")])
    bad._attachments = [("rig.toml", 7, b"x")]  # type: ignore[list-item]  # fails inside the header writing
    with pytest.raises(AttributeError):  # int has no .encode()
        bad.start()
    assert not (tmp_path / "a.mcap.part").exists()


def test_bad_truth_and_bad_times_do_not_kill_the_writer(tmp_path: Path) -> None:
    rec = _new(tmp_path / "r.mcap")
    rec.start()
    rec.log_truth(0, {"h_m": 1.0}, 0)  # no p_N_m / q_NB: /sim/truth written, /tf and /sim/pose counted
    rec.log("/hil/events", "soon", {"kind": "bench", "name": "x", "detail": {}}, 0)  # type: ignore[arg-type]
    rec.log("/hil/events", 1, {"kind": "bench", "name": "ok", "detail": {}}, 0)
    stats = rec.close()
    assert stats.messages_by_topic["/sim/truth"] == 1 and stats.messages_by_topic["/hil/events"] == 1
    assert stats.dropped_by_topic == {"/tf": 1, "/sim/pose": 1, "/hil/events": 1}
    summary = read_metadata(rec.path)["summary"]
    assert summary["error./tf"].startswith("KeyError") and summary["unencodable./hil/events"] == "1"


def test_a_quiet_wire_is_written_within_a_batch_of_sim_time(tmp_path: Path) -> None:
    # the boot exchange on imu/rx must not wait in the writer until close (a killed run would lose it)
    rec = _new(tmp_path / "r.mcap")
    with rec:
        rec.log_wire("imu", "rx", -1_000_000, 1, b"\xfa\xff\x30\x00\xd1")
        for k in range(100):  # 250 ms of another wire
            rec.log_wire("imu", "tx", k * 2_500_000, 2 + k, b"\xfa")
    with rec.path.open("rb") as f:  # file order is write order
        order = [r.channel_id for r in StreamReader(f).records if isinstance(r, Message)]
    channels = {t: r.channel_id for t, r in rec._routes.items()}
    tx = [i for i, c in enumerate(order) if c == channels["/hil/wire/imu/tx"]]
    assert len(tx) == 3 and order.index(channels["/hil/wire/imu/rx"]) < tx[-1]  # not held until close
    assert rec.close().chunks_by_topic == {"/hil/wire/imu/rx": 1, "/hil/wire/imu/tx": 100}
    assert read_wire(rec.path, "imu", "rx") == b"\xfa\xff\x30\x00\xd1"
