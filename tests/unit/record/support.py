"""Shared helpers of the recording tests."""

from __future__ import annotations

import base64
import json
from pathlib import Path
from typing import Any

from hil.record import Recorder
from hil.record.topics import TOPICS, Stamp, TopicSpec

RUN_START_NS = 1_750_000_000_123_456_789  # a Unix time with a non-zero ns part
HOST0_NS = 5_000_000_000


def expected_message(spec: TopicSpec, t_ns: int, t_host_ns: int) -> dict[str, Any]:
    """What the writer must put on the wire for the spec's example payload (JSON form)."""
    if spec.topic.startswith("/hil/wire/"):
        port, direction = spec.topic.split("/")[3:]
        return {"t_ns": t_ns, "t_host_ns": t_host_ns, "port": port, "direction": direction,
                "len": len(spec.example), "data": base64.b64encode(spec.example).decode()}
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
