"""docs/foxglove-live-layout.json: every topic it shows is served by default, and its publish
panels are prepared for the topics the bench takes."""

from __future__ import annotations

import json
from pathlib import Path

from hil.live.topics import CLIENT_SCHEMAS, DEFAULT_TOPICS, INJECT_TOPIC, STEER_TOPIC
from hil.live.steer import _steer_problem

LAYOUT = Path(__file__).resolve().parents[3] / "docs" / "foxglove-live-layout.json"


def test_live_layout_shows_default_topics_and_publishes_to_the_bench():
    cfg = json.loads(LAYOUT.read_text())["configById"]
    shown = [p["value"].split(".", 1)[0] for pid, c in cfg.items() if pid.startswith("Plot!") for p in c["paths"]]
    shown += [c["topicToRender"] for pid, c in cfg.items() if pid.startswith("Log!")]
    shown += [c["topicPath"] for pid, c in cfg.items() if pid.startswith("RawMessages!")]
    assert shown and set(shown) <= set(DEFAULT_TOPICS), set(shown) - set(DEFAULT_TOPICS)
    publish = {c["topicName"]: c for pid, c in cfg.items() if pid.startswith("Publish!")}
    assert set(publish) == {INJECT_TOPIC, STEER_TOPIC}
    for topic, c in publish.items():
        assert c["datatype"] == CLIENT_SCHEMAS[topic]["title"]
    assert _steer_problem(json.loads(publish[STEER_TOPIC]["value"])) == ""
    assert json.loads(publish[INJECT_TOPIC]["value"])["kind"]
