"""Shared helpers of the recording tests."""

from __future__ import annotations

import base64
import json
from pathlib import Path
from typing import Any

import numpy as np

from hil.record import Recorder
from hil.record.topics import TOPICS, Stamp, TopicSpec

RUN_START_NS = 1_750_000_000_123_456_789  # a Unix time with a non-zero ns part
HOST0_NS = 5_000_000_000


def _f32(value: Any) -> Any:
    """Numbers as a float32 protobuf field gives them back."""
    if isinstance(value, float):
        return float(np.float32(value))
    if isinstance(value, list):
        return [_f32(v) for v in value]
    if isinstance(value, dict):
        return {k: _f32(v) for k, v in value.items()}
    return value


def stored_message(spec: TopicSpec, t_ns: int, t_host_ns: int) -> dict[str, Any]:
    """The JSON form of what the writer stores for the spec's example payload logged once
    (wire bytes: a one-chunk ``hil.WireChunks``; bytes as base64), with t_ns/t_host_ns."""
    if spec.topic.startswith("/hil/wire/"):
        port, direction = spec.topic.split("/")[3:]
        return {"t_ns": t_ns, "t_host_ns": t_host_ns, "port": port, "direction": direction,
                "len": len(spec.example), "data": base64.b64encode(spec.example).decode(),
                "chunk_len": [len(spec.example)], "chunk_dt_ns": [0], "chunk_dt_host_ns": [0]}
    return expected_message(spec, t_ns, t_host_ns)


def expected_messages(spec: TopicSpec, t_ns: int, t_host_ns: int) -> list[dict[str, Any]]:
    """What ``hil.record`` readers give back for the spec's example logged once: wire chunks
    and ADC conversions one dict each, float32 topics rounded to float32."""
    if spec.topic.startswith("/hil/wire/"):
        port, direction = spec.topic.split("/")[3:]
        return [{"t_ns": t_ns, "t_host_ns": t_host_ns, "port": port, "direction": direction,
                 "len": len(spec.example), "data": spec.example}]
    msg = expected_message(spec, t_ns, t_host_ns)
    if spec.float32:
        msg = _f32(msg)
    if spec.schema_name == "hil.AdcConversions":
        keys = [k for k in msg if isinstance(msg[k], list)]
        return [{"t_ns": t_ns, **{k: msg[k][i] for k in keys}} for i in range(len(msg["code"]))]
    return [msg]


def expected_message(spec: TopicSpec, t_ns: int, t_host_ns: int) -> dict[str, Any]:
    """The spec's example payload with the stamps the writer adds (JSON form, not wire topics)."""
    if spec.stamp is Stamp.FOXGLOVE:
        log_time = RUN_START_NS + t_ns
        return {**spec.defaults, **spec.example,
                "timestamp": {"sec": log_time // 10**9, "nsec": log_time % 10**9}}
    msg = {**spec.example, "t_ns": t_ns}
    if spec.stamp is Stamp.TIMING:
        msg["t_host_ns"] = t_host_ns
    return msg


def log_example(rec: Recorder, spec: TopicSpec, t_ns: int, t_host_ns: int) -> None:
    """Log the spec's example the way the bench would (wire topics through log_wire)."""
    if spec.topic.startswith("/hil/wire/"):
        port, direction = spec.topic.split("/")[3:]
        rec.log_wire(port, direction, t_ns, t_host_ns, spec.example)
    else:
        rec.log(spec.topic, t_ns, spec.example, t_host_ns)


def record_examples(path: Path, n_rounds: int = 3, **kwargs: Any) -> Recorder:
    """A closed recording with every topic's example logged ``n_rounds`` times."""
    rec = Recorder(path, run_start_unix_ns=RUN_START_NS, metadata={"rig": "test", "seed": "1"},
                   attachments=[("rig.toml", "application/toml", b"[vehicle]\nmass_kg = 1.0\n")], **kwargs)
    with rec:
        for k in range(n_rounds):
            for spec in TOPICS.values():
                log_example(rec, spec, k * 2_500_000, HOST0_NS + k * 1000)
    return rec


def strict_json(data: bytes) -> Any:
    """json.loads that refuses NaN/Infinity (what browsers and Foxglove accept)."""
    def bad(token: str) -> Any:
        raise ValueError(f"non-standard JSON token {token}")
    return json.loads(data, parse_constant=bad)
