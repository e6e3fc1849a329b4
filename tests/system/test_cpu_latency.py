"""A run's CPU latency request (hil/host/cpulatency.py): the bench holds it while the run flies,
in lockstep and realtime, nothing it starts holds it, it is gone when the run ends, and
``cpu_latency = "require"`` on a host that refuses it stops before anything is created."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import pytest

from hil.host import cpulatency
from hil.flight.tickloop import EndReason, Mode
from hil.config import ConfigError
from hil.config.rig import load_rig
from tests.system.conftest import at_tick, explain

pytestmark = [pytest.mark.system, pytest.mark.pty]


def _writers_on(pid: int | str, path: Path) -> int:
    """How many descriptors process ``pid`` has open on ``path``."""
    n = 0
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            n += os.readlink(f"/proc/{pid}/fd/{fd}") == str(path)
        except OSError:
            continue
    return n


@pytest.mark.parametrize("mode", [Mode.LOCKSTEP, Mode.REALTIME])
async def test_the_bench_holds_the_request_while_the_run_flies(fly, mode: Mode) -> None:
    seen: dict[str, int] = {}

    def look(runner) -> None:
        seen["bench"] = _writers_on("self", cpulatency.DEVICE)
        seen["flight"] = _writers_on(runner.flight.pid, cpulatency.DEVICE)

    result = await fly("hover", duration_s=0.5, mode=mode, on_ready=at_tick(100, look))
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    assert _writers_on("self", cpulatency.DEVICE) == 0  # dropped with the run
    got = result.cpu_latency
    assert got is not None
    if not cpulatency.allowed():  # a user without root: the run goes on, and says so
        assert not got.held and str(cpulatency.DEVICE) in got.reason
        assert (mode is Mode.REALTIME) == any("idle CPUs may sleep" in n for n in result.notes)
        assert seen == {"bench": 0, "flight": 0}
        return
    assert got.held and got.target_us == 0
    assert seen == {"bench": 1, "flight": 0}
    from hil.record import read_metadata

    assert result.log_path is not None
    assert read_metadata(result.log_path)["verdict"]["cpu_latency"] == "CPU wake-up latency held at 0 us"


async def test_off_never_asks(fly) -> None:
    rig = load_rig(None)
    rig = dataclasses.replace(rig, host=dataclasses.replace(rig.host, cpu_latency="off"))
    held: list[int] = []
    look = at_tick(50, lambda runner: held.append(_writers_on("self", cpulatency.DEVICE)))
    result = await fly("hover", rig=rig, duration_s=0.2, on_ready=look)
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    assert held == [0] and result.cpu_latency is not None and not result.cpu_latency.held


async def test_require_refused_by_the_host_names_the_rig_key_and_leaves_nothing(
        fly, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cpulatency, "DEVICE", tmp_path / "no-cpu-latency-device")
    rig = load_rig(None)
    rig = dataclasses.replace(rig, host=dataclasses.replace(rig.host, cpu_latency="require"))
    with pytest.raises(ConfigError) as err:
        await fly("hover", rig=rig, duration_s=1.0, out_dir=tmp_path / "logs")
    assert str(rig.path) in str(err.value) and '[host] cpu_latency = "require"' in str(err.value)
    assert "no-cpu-latency-device" in str(err.value)
    assert not (tmp_path / "logs").exists()


async def test_auto_where_refused_flies_and_says_so_in_realtime(fly, tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cpulatency, "DEVICE", tmp_path / "no-cpu-latency-device")
    result = await fly("hover", duration_s=0.3, mode=Mode.REALTIME)
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    assert result.cpu_latency is not None and not result.cpu_latency.held
    assert "no-cpu-latency-device" in result.cpu_latency.reason
    assert any("idle CPUs may sleep" in n and "no-cpu-latency-device" in n for n in result.notes)
