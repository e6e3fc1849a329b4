"""Old (JSON-era) and new (compact) logs read alike: the readers, validation, recovery,
replay's port list and the timing analysis give the same shapes for both."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
from mcap.reader import make_reader

from hil.record import chunk_counts, iter_messages, message_counts, read_topic, read_wire, recover, validate
from hil.record.topics import TOPICS
from hil.fleet.replay import replay_ports
from hil.analysis.timing import analyze_log
from tests.unit.record.support import HOST0_NS, RUN_START_NS, expected_messages, record_examples

OLD = Path(__file__).with_name("data") / "json-v1.mcap"
ROUNDS = 4  # how the fixture was made (data/README.md)


def _new(tmp_path: Path) -> Path:
    return record_examples(tmp_path / "new.mcap", n_rounds=ROUNDS).path


def test_the_fixture_is_the_old_format() -> None:
    with OLD.open("rb") as f:
        channels = make_reader(f).get_summary().channels.values()  # type: ignore[union-attr]
    assert {c.message_encoding for c in channels} == {"json"}
    assert message_counts(OLD)["/hil/adc/conversion"] == ROUNDS  # one message per conversion
    assert message_counts(OLD)["/hil/wire/imu/tx"] == ROUNDS  # one message per transport write


def test_old_and_new_logs_give_the_same_wire_bytes_and_chunks(tmp_path: Path) -> None:
    new = _new(tmp_path)
    for path in (OLD, new):
        chunks = [m for _, _, m in iter_messages(path, ["/hil/wire/imu/tx"])]
        assert [m["data"] for m in chunks] == [TOPICS["/hil/wire/imu/tx"].example] * ROUNDS
        assert [m["t_ns"] for m in chunks] == [k * 2_500_000 for k in range(ROUNDS)]
        assert [m["t_host_ns"] for m in chunks] == [HOST0_NS + k * 1000 for k in range(ROUNDS)]
        assert read_wire(path, "imu", "tx") == TOPICS["/hil/wire/imu/tx"].example * ROUNDS
        assert chunk_counts(path)["/hil/wire/imu/tx"] == ROUNDS
        assert replay_ports(path)["imu"] == ROUNDS


def test_old_and_new_logs_give_the_same_columns(tmp_path: Path) -> None:
    new = _new(tmp_path)
    for topic in ("/sim/truth", "/hil/imu/sample", "/hil/esc/command", "/hil/timing/tick", "/tf", "/fc/log"):
        old_cols, new_cols = read_topic(OLD, topic), read_topic(new, topic)
        assert set(old_cols) == set(new_cols), topic
        for key, column in old_cols.items():
            assert column.shape == new_cols[key].shape, (topic, key)
            if column.dtype.kind == "f":  # new: float32 where the topic says so
                assert np.allclose(column, new_cols[key], rtol=1e-6, equal_nan=True), (topic, key)
            else:
                assert column.tolist() == new_cols[key].tolist(), (topic, key)


def test_adc_conversions_read_one_row_per_conversion_in_both(tmp_path: Path) -> None:
    new = _new(tmp_path)
    old = read_topic(OLD, "/hil/adc/conversion")
    assert old["code"].tolist() == [2048] * ROUNDS  # the old example: one conversion a round
    got = read_topic(new, "/hil/adc/conversion")  # the new example: four conversions a tick
    per_tick = expected_messages(TOPICS["/hil/adc/conversion"], 0, 0)
    assert got["code"].tolist() == [c["code"] for c in per_tick] * ROUNDS
    assert got["t_ns"].tolist() == [k * 2_500_000 for k in range(ROUNDS) for _ in per_tick]
    assert got["log_time_ns"].tolist() == [RUN_START_NS + t for t in got["t_ns"].tolist()]
    assert set(old) <= set(got)


def test_validate_recover_and_timing_take_both(tmp_path: Path) -> None:
    new = _new(tmp_path)
    for name, path in (("old", OLD), ("new", new)):
        v = validate(path)
        assert v.ok, (name, v.problems)
        part = tmp_path / f"{name}.mcap.part"
        shutil.copy(path, part)
        out = tmp_path / f"{name}-recovered.mcap"
        assert recover(part, out) == sum(message_counts(path).values())
        assert read_wire(out, "imu", "tx") == read_wire(path, "imu", "tx")
        rep = analyze_log(path)
        assert rep.samples == ROUNDS and rep.latency_us.p50 == 180.0
