"""``hil devices --live``: the options of ``hil run --live`` (hil/live/options.py), parsed the same
way and handed to the devices' server; a bad one exits 2 with nothing started."""

from __future__ import annotations

from typing import Any

import pytest
from typer.testing import CliRunner

from hil.cli import app
from hil.flight import devices_live, run_setup
from hil.live.topics import DEFAULT_TOPICS


@pytest.fixture
def served(monkeypatch: pytest.MonkeyPatch) -> list[dict[str, Any]]:
    """What ``hil devices`` asked to serve (nothing is started)."""
    calls: list[dict[str, Any]] = []

    def serve(rig: str | None, scenario: str | None, **kwargs: Any) -> dict[str, dict[str, int]]:
        calls.append(kwargs)
        return {}

    monkeypatch.setattr(devices_live, "serve_devices_blocking", serve)
    return calls


def _devices(*args: str) -> Any:
    return CliRunner().invoke(app, ["devices", *args], env={"COLUMNS": "200"})


def test_live_defaults_to_loopback_on_a_free_port(served: list[dict[str, Any]]) -> None:
    assert _devices("--live", "--duration", "1").exit_code == 0
    live = served[0]["live"]
    assert (live.host, live.port, live.topics, live.loopback) == ("127.0.0.1", 0, DEFAULT_TOPICS, True)
    assert live.announce is not None and served[0]["duration_s"] == 1.0
    assert _devices().exit_code == 0 and served[1]["live"] is None


def test_live_address_and_topics(served: list[dict[str, Any]]) -> None:
    assert _devices("--live", "--live-addr", "0.0.0.0:8765", "--live-topics", "/hil/imu/sample").exit_code == 0
    live = served[0]["live"]
    assert (live.host, live.port, live.loopback) == ("0.0.0.0", 8765, False)
    assert live.topics == DEFAULT_TOPICS + ("/hil/imu/sample",)


@pytest.mark.parametrize("args, words", [
    (["--live-topics", "all"], "--live-topics: needs --live"),
    (["--live-addr", "127.0.0.1:1"], "--live-addr: needs --live"),
    (["--live", "--live-addr", "host:port"], "HOST:PORT"),
    (["--live", "--live-topics", "/no/such"], "unknown topic '/no/such'"),
])
def test_bad_live_options_exit_2_and_start_nothing(args: list[str], words: str, served: list[dict[str, Any]]) -> None:
    res = _devices(*args)
    assert res.exit_code == 2 and words in res.output, res.output
    assert served == []


def test_a_resource_that_cannot_be_had_exits_1(monkeypatch: pytest.MonkeyPatch) -> None:
    def serve(*_: Any, **__: Any) -> None:
        raise run_setup.RunStartError("the run could not start (starting the recorder): OSError: no")

    monkeypatch.setattr(devices_live, "serve_devices_blocking", serve)
    res = _devices("--live")
    assert res.exit_code == 1 and "starting the recorder" in res.output, res.output


def test_help_names_the_live_options() -> None:
    res = _devices("--help")
    assert all(opt in res.output for opt in ("--live", "--live-addr", "--live-topics", "/hil/inject")), res.output
