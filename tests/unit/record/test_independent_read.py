"""An independent read of produced files (hil.record.validate): every record streamed with
chunk CRCs checked, every message decoded against its channel's schema, counts equal to the
summary statistics; and the check itself fails on damaged or non-conforming files."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from mcap.reader import make_reader
from mcap.records import DataEnd
from mcap.stream_reader import StreamReader

from hil.record import Recorder, read_metadata
from hil.record.topics import TOPICS
from hil.record.validate import validate
from tests.unit.record.support import RUN_START_NS, record_examples


def validate_file(path: Path) -> Counter[str]:
    """Counts per topic of a file that must be valid (assertion otherwise)."""
    v = validate(path)
    assert v.ok, v.problems
    return v.counts


def test_produced_file_passes_the_independent_read(tmp_path: Path) -> None:
    rec = record_examples(tmp_path / "run.mcap", n_rounds=200, chunk_size=16384)
    counts = validate_file(rec.path)
    # 200 wire chunks 2.5 ms apart: 5 messages of 100 ms per wire topic
    assert counts == Counter({t: 5 if t.startswith("/hil/wire/") else 200 for t in TOPICS})
    assert dict(counts) == rec.close().messages_by_topic
    assert read_metadata(rec.path)["summary"]["messages_total"] == str(sum(counts.values()))


def test_a_flipped_byte_is_caught(tmp_path: Path) -> None:
    rec = record_examples(tmp_path / "run.mcap", n_rounds=50)
    with rec.path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.chunk_indexes
    data = bytearray(rec.path.read_bytes())
    for ci in summary.chunk_indexes:  # the middle of every chunk
        data[ci.chunk_start_offset + ci.chunk_length // 2] ^= 0x40
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    v = validate(bad)
    assert not v.ok and v.problems[0].startswith("stream: ")


def test_truncation_is_caught(tmp_path: Path) -> None:
    rec = record_examples(tmp_path / "run.mcap", n_rounds=50)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(rec.path.read_bytes()[: rec.path.stat().st_size // 2])
    v = validate(cut)
    assert not v.ok and any("no footer" in p for p in v.problems)


def test_schema_mismatch_is_caught(tmp_path: Path) -> None:
    rec = Recorder(tmp_path / "r.mcap", run_start_unix_ns=RUN_START_NS, metadata={})
    with rec:
        rec.log("/hil/rc/pulses", 0, {"pulse_us": [1500] * 8, "present": True}, 0)
        rec.log("/hil/rc/pulses", 1, {"pulse_us": [1500] * 6, "present": True}, 0)  # wrong length (protobuf)
        rec.log("/hil/esc/command", 1, {"targets": [1100.0] * 4}, 0)  # misspelt field: protobuf cannot encode it
        rec.log("/hil/verdict", 1, {"passed": "yes", "criteria": []}, 0)  # wrong type (JSON)
    stats = rec.close()
    assert stats.dropped_by_topic == {"/hil/esc/command": 1}  # refused at writing, counted
    v = validate(rec.path)
    assert v.schema_errors == Counter({"/hil/rc/pulses": 1, "/hil/verdict": 1})
    assert len(v.problems) == 2 and v.counts["/hil/rc/pulses"] == 2


def test_data_end_present(tmp_path: Path) -> None:
    rec = record_examples(tmp_path / "run.mcap", n_rounds=1)
    with rec.path.open("rb") as f:
        assert any(isinstance(r, DataEnd) for r in StreamReader(f).records)


def test_null_numbers_are_the_nan_convention_not_errors(tmp_path: Path) -> None:
    # JSON channels only: protobuf carries NaN as it is
    rec = Recorder(tmp_path / "r.mcap", run_start_unix_ns=RUN_START_NS, metadata={})
    tf = dict(TOPICS["/tf"].example)
    with rec:
        for k, x in enumerate((float("nan"), None, "high")):
            rec.log("/tf", k, {**tf, "translation": {"x": x, "y": 0.0, "z": 0.0}}, 0)
    v = validate(rec.path)
    assert v.nulls == Counter({"/tf": 2})
    assert v.schema_errors == Counter({"/tf": 1}) and len(v.problems) == 1
