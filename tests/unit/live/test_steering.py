"""Steering without a flight: realtime (or no tick gate) refuses pause and speed with an
event; injects go through the schedule's validation; bad ones change nothing."""

from __future__ import annotations

import json
import os
import pickle
from types import SimpleNamespace
from typing import Any

import pytest

from hil.config import ConfigError
from hil.live.steer import Steering
from hil.live.topics import INJECT_TOPIC, LEN, STEER_TOPIC


class FakeSchedule:
    def __init__(self) -> None:
        self.started: list[tuple[str, int, Any, dict[str, Any]]] = []

    def start_now(self, kind: str, t_ns: int, *, duration_s: Any = None, **params: Any) -> Any:
        if kind != "baro.bias":
            raise ConfigError(f"start_now({kind!r}): kind: unknown fault kind")
        self.started.append((kind, t_ns, duration_s, params))
        return SimpleNamespace(id=len(self.started))


def steering(*, lockstep: bool) -> tuple[Steering, int, list[tuple[int, str, str, dict[str, Any]]], FakeSchedule]:
    r, w = os.pipe()
    events: list[tuple[int, str, str, dict[str, Any]]] = []
    loop = SimpleNamespace(t_ns=5_000_000, k=2, tick_ns=2_500_000, tick_gate=None, before_tick=None)
    schedule = FakeSchedule()
    st = Steering(r, loop, SimpleNamespace(schedule=schedule), lambda *e: events.append(e), lockstep=lockstep)
    return st, w, events, schedule


def send(st: Steering, w: int, topic: str, payload: bytes) -> None:
    body = pickle.dumps(("publish", topic, payload))
    os.write(w, LEN.pack(len(body)) + body)
    st._readable()


@pytest.mark.parametrize("lockstep", [False, True])  # realtime; lockstep whose loop calls no gate (host clock)
@pytest.mark.parametrize("command", [{"command": "pause"}, {"command": "resume", "speed": 1.0}])
def test_without_a_gate_pause_and_speed_are_refused(lockstep, command):
    st, w, events, _ = steering(lockstep=lockstep)
    send(st, w, STEER_TOPIC, json.dumps(command).encode())
    st._before_tick(3, 7_500_000)
    assert [(e[1], e[2]) for e in events] == [("live", "error")]
    assert "need a lockstep run on virtual time" in events[0][3]["error"]
    assert not st.paused and st.speed == 0.0


def test_injects_are_validated_and_recorded_at_the_tick():
    st, w, events, schedule = steering(lockstep=False)
    for raw in (b'{"kind": "nope"}', b"[1]", b'{"kind": "baro.bias", "t_s": 3}', b"{",
                b'{"kind": "baro.bias", "bias_Pa": 50.0, "duration_s": 0.5}'):
        send(st, w, INJECT_TOPIC, raw)
    st._before_tick(3, 7_500_000)
    assert schedule.started == [("baro.bias", 7_500_000, 0.5, {"bias_Pa": 50.0})]
    errors = [e[3]["error"] for e in events if e[2] == "error"]
    assert len(errors) == 4
    assert "unknown fault kind" in errors[0] and "kind: required" in errors[1]
    assert "t_s: not allowed" in errors[2] and "malformed JSON" in errors[3]
    assert [e[2] for e in events if e[2] != "error"] == ["inject"]
