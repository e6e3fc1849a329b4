"""The topic table: schemas are valid, Foxglove-parseable, examples conform, docs in sync."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import jsonschema
import pytest

from hil.record import protobuf
from hil.record.topics import (
    SCHEMA_DIR,
    Encoding,
    TOPICS,
    WIRE_DIRECTIONS,
    WIRE_PORTS,
    UnknownTopicError,
    topic_spec,
    topics_markdown,
    wire_topic,
)
from tests.unit.record.support import HOST0_NS, expected_message, stored_message

ROOT = Path(__file__).resolve().parents[3]

REQUIRED_TOPICS = [
    "/sim/truth", "/tf", "/sim/pose", "/hil/imu/sample", "/hil/adc/conversion", "/hil/rc/pulses",
    "/hil/esc/command", "/hil/esc/output", "/fc/telemetry", "/fc/log", "/hil/timing/tick", "/hil/events",
    "/hil/verdict", "/hil/device/counters",
] + [f"/hil/wire/{p}/{d}" for p in ("imu", "adc", "adc-spidriver", "rc", "esc", "telemetry", "ground")
     for d in ("tx", "rx")]


def foxglove_parse(schema: dict[str, Any], path: str = "") -> None:
    """The rules of Foxglove's JSON-schema parser, raising where it raises.

    Port of foxglove/studio packages/mcap-support/src/parseJsonSchema.ts (addFieldsRecursive):
    every object needs "type": "object" and "properties"; a field is a oneOf of numeric
    consts, or boolean / string (contentEncoding only base64) / number / integer / object /
    array whose items are boolean / string (no contentEncoding) / number / integer / object.
    """
    if schema.get("type") != "object":
        raise ValueError(f"{path}: expected type object, got {schema.get('type')!r}")
    for name, field in schema["properties"].items():
        where = f"{path}.{name}"
        if isinstance(field.get("oneOf"), list):
            if not all(isinstance(alt.get("const"), (int, float)) for alt in field["oneOf"]):
                raise ValueError(f"{where}: oneOf alternatives must have number values")
            continue
        t = field.get("type")
        if t == "string":
            if field.get("contentEncoding") not in (None, "base64"):
                raise ValueError(f"{where}: unsupported contentEncoding")
        elif t in ("boolean", "number", "integer"):
            pass
        elif t == "object":
            foxglove_parse(field, where)
        elif t == "array":
            item = field["items"]
            if item.get("type") == "object":
                foxglove_parse(item, where)
            elif item.get("type") == "string":
                if "contentEncoding" in item:
                    raise ValueError(f"{where}: contentEncoding in array items")
            elif item.get("type") not in ("boolean", "number", "integer"):
                raise ValueError(f"{where}: unsupported item type {item.get('type')!r}")
        else:
            raise ValueError(f"{where}: unsupported type {t!r}")


def test_foxglove_rules_port_rejects_what_foxglove_rejects() -> None:
    # the checker itself must be able to fail (type arrays, null, missing properties, bad oneOf)
    bad = [
        {"type": "object", "properties": {"x": {"type": ["number", "null"]}}},
        {"type": "object", "properties": {"x": {"type": "null"}}},
        {"type": "object", "properties": {"x": {"type": "object"}}},
        {"type": "object", "properties": {"x": {"oneOf": [{"const": "a"}]}}},
        {"type": "object", "properties": {"x": {"type": "string", "contentEncoding": "base16"}}},
        {"type": "object", "properties": {"x": {"type": "array", "items": {"type": "array"}}}},
    ]
    for schema in bad:
        with pytest.raises((ValueError, KeyError)):
            foxglove_parse(schema)


def test_every_required_topic_is_in_the_table() -> None:
    missing = [t for t in REQUIRED_TOPICS if t not in TOPICS]
    assert not missing


@pytest.mark.parametrize("topic", sorted(TOPICS))
def test_schema_is_valid_and_foxglove_parseable(topic: str) -> None:
    spec = TOPICS[topic]
    jsonschema.Draft202012Validator.check_schema(spec.schema)
    foxglove_parse(dict(spec.schema))
    if spec.encoding is Encoding.PROTOBUF:  # the generated descriptor loads and has every field
        assert protobuf.field_names(spec.schema_name, spec.schema_bytes()) == set(spec.schema["properties"])
    else:
        assert json.loads(spec.schema_bytes()) == spec.schema
    if spec.schema_name.startswith("foxglove."):
        assert spec.schema["title"] == spec.schema_name


@pytest.mark.parametrize("topic", sorted(TOPICS))
def test_stamped_example_conforms_to_its_schema(topic: str) -> None:
    spec = TOPICS[topic]
    jsonschema.validate(stored_message(spec, -1_000_000 if "wire" in topic else 2_500_000, HOST0_NS),
                        spec.schema)


def test_schemas_are_strict_enough_to_catch_mistakes() -> None:
    # a misspelt field or a wrong-length vector must fail validation in tests
    truth = expected_message(TOPICS["/sim/truth"], 0, 0)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({**truth, "p_N": [0, 0, 0]}, TOPICS["/sim/truth"].schema)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({**truth, "q_NB": [1, 0, 0]}, TOPICS["/sim/truth"].schema)
    log = expected_message(TOPICS["/fc/log"], 0, 0)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({**log, "level": 7}, TOPICS["/fc/log"].schema)


def test_vendored_foxglove_schemas_are_the_official_files() -> None:
    # byte lengths of foxglove/foxglove-sdk schemas/jsonschema/*.json at 40ea5ebec266
    sizes = {"foxglove.FrameTransform.json": 4824, "foxglove.PoseInFrame.json": 4348, "foxglove.Log.json": 3780}
    for name, size in sizes.items():
        assert len((SCHEMA_DIR / name).read_bytes()) == size
    log = json.loads((SCHEMA_DIR / "foxglove.Log.json").read_text())
    assert [alt["const"] for alt in log["properties"]["level"]["oneOf"]] == [0, 1, 2, 3, 4, 5]
    assert log["properties"]["timestamp"]["properties"]["nsec"]["maximum"] == 999_999_999


def test_unknown_topics_are_errors() -> None:
    with pytest.raises(UnknownTopicError):
        topic_spec("/hil/imu/samples")
    with pytest.raises(UnknownTopicError):
        wire_topic("gps", "tx")
    with pytest.raises(UnknownTopicError):
        wire_topic("imu", "in")
    assert wire_topic("adc-spidriver", "rx") == "/hil/wire/adc-spidriver/rx"
    assert len(WIRE_PORTS) * len(WIRE_DIRECTIONS) == sum(t.startswith("/hil/wire/") for t in TOPICS)


def test_docs_topics_table_is_current() -> None:
    doc = (ROOT / "docs" / "recording.md").read_text()
    assert topics_markdown() in doc, "regenerate the table in docs/recording.md from topics_markdown()"
