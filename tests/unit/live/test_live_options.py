"""--live/--live-topics parsing, the served topic set, and the steer message checks."""

from __future__ import annotations

import pytest

from hil.live.options import LOOPBACK, LiveOptionError, parse_live
from hil.live.steer import _steer_problem
from hil.live.topics import DEFAULT_TOPICS, EVERY_MESSAGE, LiveConfig, select_topics
from hil.record.topics import TOPICS


def test_default_is_loopback_on_an_ephemeral_port():
    cfg = parse_live(LOOPBACK, None)
    assert (cfg.host, cfg.port, cfg.topics, cfg.loopback) == ("127.0.0.1", 0, DEFAULT_TOPICS, True)
    assert parse_live(None, None, live=False) is None


def test_explicit_address_beyond_loopback():
    cfg = parse_live("0.0.0.0:8765", None)
    assert (cfg.host, cfg.port, cfg.loopback) == ("0.0.0.0", 8765, False)
    assert parse_live("[::1]:9000", None).loopback


@pytest.mark.parametrize("addr, topics, record, words", [
    ("127.0.0.1:99999", None, True, "port 0..65535"),
    ("host:port", None, True, "HOST:PORT"),
    (LOOPBACK, "/no/such", True, "unknown topic '/no/such'"),
    (None, "all", True, "--live-topics: needs --live"),
    ("0.0.0.0:1", None, True, "--live-addr: needs --live"),
    (LOOPBACK, None, False, "--no-record"),
])
def test_bad_options_say_which_and_why(addr, topics, record, words):
    with pytest.raises(LiveOptionError, match=words):
        parse_live(addr, topics, record=record, live=not words.endswith("needs --live"))


def test_topic_sets_come_from_the_recorders_table():
    assert set(DEFAULT_TOPICS) <= set(TOPICS)
    assert select_topics("all") == tuple(TOPICS)
    assert select_topics("/hil/imu/sample") == DEFAULT_TOPICS + ("/hil/imu/sample",)
    cfg = LiveConfig(topics=select_topics("all"))
    assert cfg.limited("/sim/truth") and not cfg.limited("/hil/events") and not cfg.limited("/hil/imu/sample")
    assert EVERY_MESSAGE <= set(DEFAULT_TOPICS)


@pytest.mark.parametrize("msg, words", [
    ({"command": "pause"}, ""), ({"command": "resume", "speed": 1.0}, ""), ({"command": "step", "ticks": 4}, ""),
    ([1], "JSON object"), ({"command": "fly"}, "command: must be"), ({"command": "resume", "speed": -1}, "speed"),
    ({"command": "step", "ticks": 0}, "ticks"), ({"command": "step", "ticks": True}, "ticks"),
    ({"command": "pause", "when": 1}, "when: unknown key"),
])
def test_steer_messages_are_checked(msg, words):
    problem = _steer_problem(msg)
    assert (words in problem) if words else problem == ""
