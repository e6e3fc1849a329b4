"""What the live server serves: the recorded topics a person watches, at most 50 Hz each,
and the two topics the app publishes on (``/hil/inject``, ``/hil/steer``).

The channels and schemas are the recorder's (hil/record/topics.py): the server registers
each served topic with the schema bytes the MCAP file registers and sends the very bytes the
recorder writes, so the live view and the file cannot disagree.
"""

from __future__ import annotations

import ipaddress
import json
import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

#: what a person watches: pose and /tf, attitude and altitude truth, motors, telemetry (the
#: altitude estimate and setpoints), the flight code's log, events and faults, timing
DEFAULT_TOPICS: tuple[str, ...] = (
    "/tf", "/sim/pose", "/sim/truth", "/hil/esc/command", "/hil/esc/output", "/fc/telemetry", "/fc/log", "/hil/events",
    "/hil/timing/tick", "/hil/verdict",
)
#: the default set is decimated to at most one message per this much sim time per topic (50 Hz)
MIN_PERIOD_NS = 20_000_000
#: irregular topics where every message matters: never decimated
EVERY_MESSAGE: frozenset[str] = frozenset({"/fc/log", "/hil/events", "/hil/verdict"})
#: frames on the pipe from the server to the bench: a little-endian length, then a pickle
LEN = struct.Struct("<I")
INJECT_TOPIC = "/hil/inject"
STEER_TOPIC = "/hil/steer"

#: a catalogue fault as a scenario's [[faults]] entry, less ``t_s`` (it starts at the next tick)
INJECT_SCHEMA: dict[str, Any] = {
    "title": "hil.Inject", "type": "object",
    "description": "Start a catalogue fault now: the fields of a scenario's [[faults]] entry (docs/faults.md) "
                   "without t_s. Example: {\"kind\": \"imu_dropout\", \"duration_s\": 0.5}",
    "properties": {"kind": {"type": "string", "description": "fault kind (hil faults lists them)"},
                   "duration_s": {"type": "number", "description": "s; omitted: until the end of the run"}},
    "required": ["kind"], "additionalProperties": True,
}
STEER_SCHEMA: dict[str, Any] = {
    "title": "hil.Steer", "type": "object",
    "description": "Steer a lockstep run: pause, resume (at speed x real time; 0 = as fast as possible) "
                   "or step N ticks then pause.",
    "properties": {"command": {"type": "string", "enum": ["pause", "resume", "step"]},
                   "speed": {"type": "number", "description": "x real time; 0 = as fast as possible"},
                   "ticks": {"type": "integer", "minimum": 1, "description": "ticks to run (step)"}},
    "required": ["command"], "additionalProperties": False,
}
CLIENT_SCHEMAS: dict[str, dict[str, Any]] = {INJECT_TOPIC: INJECT_SCHEMA, STEER_TOPIC: STEER_SCHEMA}


@dataclass(frozen=True)
class LiveConfig:
    """``hil run --live``: bind address and port (0: ephemeral), served topics, and how the
    bench announces the URL (``announce(url)``, called once the server listens)."""

    host: str = "127.0.0.1"
    port: int = 0
    topics: tuple[str, ...] = DEFAULT_TOPICS
    announce: Callable[[str], None] | None = field(default=None, compare=False)

    @property
    def loopback(self) -> bool:
        try:
            return ipaddress.ip_address(self.host).is_loopback
        except ValueError:
            return self.host == "localhost"

    def limited(self, topic: str) -> bool:
        """Decimated to ``MIN_PERIOD_NS``: the default set, less the every-message topics."""
        return topic in DEFAULT_TOPICS and topic not in EVERY_MESSAGE


def select_topics(spec: str | None) -> tuple[str, ...]:
    """The served topics: the default set, widened by ``spec`` (comma-separated topics, or
    ``all``). Raises ValueError naming an unknown topic."""
    from hil.record.topics import TOPICS  # here: the CLI parses options before heavy imports

    if not spec:
        return DEFAULT_TOPICS
    if spec.strip() == "all":
        return tuple(TOPICS)
    extra = [t.strip() for t in spec.split(",") if t.strip()]
    unknown = [t for t in extra if t not in TOPICS]
    if unknown:
        raise ValueError(f"--live-topics: unknown topic {unknown[0]!r} (topics: all, or any of hil/record/topics.py, "
                         "docs/recording.md)")
    return DEFAULT_TOPICS + tuple(t for t in extra if t not in DEFAULT_TOPICS)


def client_schema_bytes(topic: str) -> bytes:
    return json.dumps(CLIENT_SCHEMAS[topic]).encode()


__all__ = ["CLIENT_SCHEMAS", "DEFAULT_TOPICS", "EVERY_MESSAGE", "INJECT_TOPIC", "LEN", "LiveConfig", "MIN_PERIOD_NS",
           "STEER_TOPIC", "client_schema_bytes", "select_topics"]
