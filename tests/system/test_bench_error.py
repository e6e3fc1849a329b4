"""A bench bug mid-flight: the run ends with a bench error, the log is finalized and keeps the
traceback (the run the bug spoiled is where it is found)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hil.flight.tickloop import EndReason, Mode
from hil.record import iter_messages
from hil.flight.run import run_flight
from tests.system.conftest import at_tick

pytestmark = [pytest.mark.system, pytest.mark.pty]


def _bench_bug(runner: object) -> None:
    raise ZeroDivisionError("a bench bug")


def test_a_bench_error_ends_the_run_and_its_traceback_is_logged(tmp_path: Path) -> None:
    res = run_flight(None, "hover", mode=Mode.LOCKSTEP, duration_s=1.0, out_dir=tmp_path, on_ready=at_tick(40, _bench_bug))
    assert res.end_reason is EndReason.ERROR
    assert res.message == "bench error: ZeroDivisionError: a bench bug"
    assert res.log_path is not None and res.log_path.suffix == ".mcap"  # finalized, not a .part
    errors = [m for _, _, m in iter_messages(res.log_path, ["/hil/events"]) if m.get("name") == "bench error"]
    assert len(errors) == 1
    detail = errors[0]["detail"]
    detail = json.loads(detail) if isinstance(detail, str) else detail
    assert "ZeroDivisionError: a bench bug" in detail["traceback"]
    assert "after_tick" in detail["traceback"]  # the frame that raised
