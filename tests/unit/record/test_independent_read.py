"""An independent read of a produced file: every record streamed with chunk CRCs checked,
every message decoded against its channel's schema, counts equal the summary statistics.

Method from research/ecosystem.md section 2 (Python-side validator): StreamReader to the
footer (not the indexed reader the bench's own reader uses), then cross-check the summary.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import jsonschema
import pytest
import zstandard
from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from mcap.records import Channel, DataEnd, Footer, Header, Message, Schema
from mcap.stream_reader import CRCValidationError, StreamReader

from hil.record.topics import TOPICS
from tests.unit.record.support import record_examples, strict_json


def validate_file(path: Path) -> Counter[str]:
    """Stream-validate ``path``; returns messages per topic (raises AssertionError/ValueError)."""
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    validators: dict[int, jsonschema.Draft202012Validator] = {}
    counts: Counter[str] = Counter()
    by_id: Counter[int] = Counter()
    saw_footer = False
    with path.open("rb") as f:
        records = StreamReader(f, validate_crcs=True).records
        first = next(records)
        assert isinstance(first, Header)
        for rec in records:
            if isinstance(rec, Schema):
                schemas[rec.id] = rec
            elif isinstance(rec, Channel):
                assert rec.schema_id in schemas, f"channel {rec.topic} before its schema"
                channels[rec.id] = rec
                validators[rec.id] = jsonschema.Draft202012Validator(json.loads(schemas[rec.schema_id].data))
            elif isinstance(rec, Message):
                assert rec.channel_id in channels, f"message on undeclared channel {rec.channel_id}"
                assert channels[rec.channel_id].message_encoding == "json"
                validators[rec.channel_id].validate(strict_json(rec.data))
                counts[channels[rec.channel_id].topic] += 1
                by_id[rec.channel_id] += 1
            elif isinstance(rec, Footer):
                saw_footer = True
    assert saw_footer, "stream ended without a footer"
    with path.open("rb") as f:
        summary = make_reader(f, validate_crcs=True).get_summary()
    assert summary is not None and summary.statistics is not None
    assert summary.statistics.message_count == sum(counts.values())
    assert {cid: n for cid, n in summary.statistics.channel_message_counts.items() if n} == dict(by_id)
    assert summary.statistics.channel_count == len(channels)
    return counts


def test_produced_file_passes_the_independent_read(tmp_path: Path) -> None:
    rec = record_examples(tmp_path / "run.mcap", n_rounds=200, chunk_size=16384)
    counts = validate_file(rec.path)
    assert counts == Counter({t: 200 for t in TOPICS})
    assert dict(counts) == rec.close().messages_by_topic


def test_the_validator_catches_a_flipped_byte(tmp_path: Path) -> None:
    # a validator that cannot fail proves nothing: corrupt one byte in the middle of each chunk
    rec = record_examples(tmp_path / "run.mcap", n_rounds=50)
    with rec.path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.chunk_indexes
    data = bytearray(rec.path.read_bytes())
    for ci in summary.chunk_indexes:
        data[ci.chunk_start_offset + ci.chunk_length // 2] ^= 0x40
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises((CRCValidationError, zstandard.ZstdError)):
        validate_file(bad)


def test_the_validator_catches_truncation(tmp_path: Path) -> None:
    rec = record_examples(tmp_path / "run.mcap", n_rounds=50)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(rec.path.read_bytes()[: rec.path.stat().st_size // 2])
    with pytest.raises(EndOfFile):
        validate_file(cut)


def test_data_end_present(tmp_path: Path) -> None:
    rec = record_examples(tmp_path / "run.mcap", n_rounds=1)
    with rec.path.open("rb") as f:
        assert any(isinstance(r, DataEnd) for r in StreamReader(f).records)
