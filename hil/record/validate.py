"""Check a recorded MCAP file without the indexed reader the bench reads it with.

Method (independent of the indexed reader, MCAP spec https://mcap.dev/spec): stream every record with
``StreamReader(validate_crcs=True)`` to the footer (chunk CRCs, declared schemas and channels),
validate every JSON message against its channel's JSON schema, decode every protobuf message
with the schema the file carries and check it against the topic table's JSON schema of the
same name (with ``t_ns`` / ``t_host_ns`` put back as readers do), then cross-check the message
counts with the summary's statistics. For tests and CI over run artifacts.
"""

from __future__ import annotations

import base64
import json
from collections import Counter
from dataclasses import dataclass, field
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap.records import Channel, Footer, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

from hil.record import protobuf
from hil.record.reader import _restamp
from hil.record.topics import TOPICS

_MAX_PROBLEMS = 50


@dataclass
class Validation:
    """``counts``: messages per topic seen by the stream pass; ``problems``: what is wrong
    (first ``_MAX_PROBLEMS``); ``schema_errors``: messages that do not match their schema;
    ``nulls``: messages with ``null`` where the schema says number/integer — the recording
    convention for a value that is not finite or not available (JSON has no NaN, and
    Foxglove's schema parser takes no type unions), so not a problem."""

    counts: Counter[str] = field(default_factory=Counter)
    problems: list[str] = field(default_factory=list)
    schema_errors: Counter[str] = field(default_factory=Counter)
    nulls: Counter[str] = field(default_factory=Counter)

    @property
    def ok(self) -> bool:
        return not self.problems

    def _add(self, problem: str) -> None:
        if len(self.problems) < _MAX_PROBLEMS:
            self.problems.append(problem)


def _reject_constant(token: str) -> float:
    raise ValueError(f"non-standard JSON token {token}")


def _is_null_number(err: Any) -> bool:  # a jsonschema.ValidationError
    return err.validator == "type" and err.instance is None and err.validator_value in ("number", "integer")


def _jsonable(msg: dict[str, Any]) -> dict[str, Any]:
    """A decoded protobuf message as its JSON form (bytes as base64 strings)."""
    return {k: base64.b64encode(v).decode() if isinstance(v, bytes) else v for k, v in msg.items()}


def validate(path: Path | str, *, schemas: bool = True) -> Validation:
    """Validate ``path``; never raises for a bad file (see ``Validation.problems``)."""
    import jsonschema  # here, not at module level: ``hil`` start-up time (hil.record imports this module)

    v = Validation()
    schema_recs: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    validators: dict[int, Any] = {}  # jsonschema validators
    decoders: dict[int, Callable[[bytes], dict[str, Any]]] = {}
    restamp: dict[int, Callable[[dict[str, Any], int, int], dict[str, Any]]] = {}
    run_start = 0
    by_id: Counter[int] = Counter()
    footer = False
    try:
        with Path(path).open("rb") as f:
            records = StreamReader(f, validate_crcs=True).records
            if not isinstance(next(records), Header):
                v._add("first record is not a header")
            for rec in records:
                if isinstance(rec, Schema):
                    schema_recs[rec.id] = rec
                elif isinstance(rec, Channel):
                    if rec.schema_id and rec.schema_id not in schema_recs:
                        v._add(f"channel {rec.topic} declared before its schema {rec.schema_id}")
                    channels[rec.id] = rec
                    sch = schema_recs.get(rec.schema_id)
                    if schemas and sch is not None and sch.encoding == "jsonschema":
                        schema = json.loads(sch.data)
                        validators[rec.id] = jsonschema.validators.validator_for(schema)(schema)
                    elif sch is not None and rec.message_encoding == "protobuf":
                        try:
                            decoders[rec.id] = protobuf.decoder(sch.name, bytes(sch.data))
                            restamp[rec.id] = _restamp(protobuf.field_names(sch.name, bytes(sch.data)), run_start)
                        except Exception as e:  # a descriptor set protobuf cannot load
                            v._add(f"{rec.topic}: bad protobuf schema {sch.name}: {type(e).__name__}: {e}")
                            continue
                        spec = TOPICS.get(rec.topic)
                        if schemas and spec is not None and spec.schema_name == sch.name:
                            validators[rec.id] = jsonschema.validators.validator_for(spec.schema)(spec.schema)
                elif isinstance(rec, Metadata) and rec.name == "run":
                    run_start = int(rec.metadata.get("run_start_unix_ns", "0") or 0)
                elif isinstance(rec, Message):
                    ch = channels.get(rec.channel_id)
                    if ch is None:
                        v._add(f"message on undeclared channel {rec.channel_id}")
                        continue
                    v.counts[ch.topic] += 1
                    by_id[rec.channel_id] += 1
                    if ch.message_encoding == "protobuf" and rec.channel_id in decoders:
                        try:
                            decoded = decoders[rec.channel_id](rec.data)
                        except Exception as e:  # protobuf's DecodeError and friends
                            v._add(f"{ch.topic}: bad protobuf message: {type(e).__name__}: {e}")
                            continue
                        msg = _jsonable(restamp[rec.channel_id](decoded, rec.log_time, rec.publish_time))
                    elif ch.message_encoding == "json":
                        try:
                            msg = json.loads(rec.data, parse_constant=_reject_constant)
                        except ValueError as e:
                            v._add(f"{ch.topic}: bad JSON: {e}")
                            continue
                    else:
                        continue
                    checker = validators.get(rec.channel_id)
                    if checker is not None:
                        errors = list(checker.iter_errors(msg))
                        real = [e for e in errors if not _is_null_number(e)]
                        if errors and not real:
                            v.nulls[ch.topic] += 1
                        elif real:
                            err = jsonschema.exceptions.best_match(real)
                            if not v.schema_errors[ch.topic]:
                                v._add(f"{ch.topic}: {err.message} at {list(err.absolute_path)}")
                            v.schema_errors[ch.topic] += 1
                elif isinstance(rec, Footer):
                    footer = True
    except Exception as e:  # a damaged file: McapError, CRC (ValueError), zstd, struct errors ...
        v._add(f"stream: {type(e).__name__}: {e}")
    if not footer:
        v._add("no footer (killed run? use hil recover)")
        return v
    with Path(path).open("rb") as f:
        summary = make_reader(f, validate_crcs=True).get_summary()
    if summary is None or summary.statistics is None:
        v._add("no summary statistics")
        return v
    stats = summary.statistics
    if stats.message_count != sum(v.counts.values()):
        v._add(f"statistics say {stats.message_count} messages, the stream has {sum(v.counts.values())}")
    if {c: n for c, n in stats.channel_message_counts.items() if n} != dict(by_id):
        v._add("per-channel statistics differ from the stream")
    if stats.channel_count != len(channels):
        v._add(f"statistics say {stats.channel_count} channels, the stream declares {len(channels)}")
    return v
