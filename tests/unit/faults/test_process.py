"""Process faults on a real child process (``sleep``) through hil.flight.process.FlightProcess."""

from __future__ import annotations

import asyncio
import shutil
from pathlib import Path

import pytest

from hil.config import ConfigError
from hil.faults import load_faults
from hil.flight.process import FlightProcess
from hil.config.rig import Rig
from tests.unit.faults.harness import Bench

SLEEP = shutil.which("sleep") or "/bin/sleep"


@pytest.fixture
async def flight(tmp_path: Path) -> FlightProcess:
    proc = FlightProcess([SLEEP, "30"], cwd=tmp_path, on_line=lambda stream, line: None)
    await proc.start()
    yield proc
    await proc.stop(grace_s=1.0)


async def test_kill_ends_the_flight_code(rig: Rig, flight: FlightProcess) -> None:
    b = Bench(rig, load_faults([{"kind": "process.kill", "t_s": 0.01}], rig, source="t"), flight=flight)
    pid = flight.pid
    await b.tick(4)  # up to 7.5 ms
    assert flight.running and b.fault_events() == []
    await b.tick()  # 10 ms
    await asyncio.wait_for(flight.exited.wait(), 5.0)
    assert flight.returncode == -9 and flight.killed_by_bench
    (_, start, d), (_, end, _) = b.fault_events()
    assert (start, end) == ("process.kill start", "process.kill end") and d["changed"] == {"pid": pid, "was_running": True}


async def test_restart_kills_and_starts_again_without_an_exit(rig: Rig, flight: FlightProcess) -> None:
    b = Bench(rig, load_faults([{"kind": "process.restart", "t_s": 0.0, "duration_s": 0.01}], rig, source="t"),
              flight=flight)
    old, exited = flight.proc, flight.exited  # the event the tick loop watches (hil/flight/tickloop.py)
    assert old is not None
    await b.tick()  # t = 0: killed (a task reaps it)
    assert await asyncio.wait_for(old.wait(), 5.0) == -9
    await b.tick(3)  # down for 10 ms of sim time
    assert not flight.running and not exited.is_set() and len(b.schedule.tasks) == 1
    await b.tick()  # t = 10 ms: started again
    await asyncio.wait_for(asyncio.gather(*b.schedule.tasks), 5.0)
    assert flight.running and flight.pid != old.pid and not exited.is_set() and flight.exited is exited
    names = [n for _, n, _ in b.fault_events()]
    assert names == ["process.restart start", "process.restart end", "process.restart started"]
    assert b.fault_events(" started")[0][2] == {"pid": flight.pid}
    flight.kill()  # the new process's exit is an exit again
    await asyncio.wait_for(exited.wait(), 5.0)


async def test_restart_cancelled_while_down_leaves_the_flight_code_exited(rig: Rig, flight: FlightProcess) -> None:
    b = Bench(rig, load_faults([{"kind": "process.restart", "t_s": 0.0, "duration_s": 1.0}], rig, source="t"),
              flight=flight)
    old, exited = flight.proc, flight.exited
    assert old is not None
    await b.tick()
    await asyncio.wait_for(old.wait(), 5.0)
    await b.schedule.aclose()
    assert exited.is_set() and flight.exited is exited and not flight.running and b.schedule.tasks == ()
    assert await asyncio.wait_for(flight.stop(), 5.0) == -9


async def test_stop_during_the_downtime_does_not_hang(rig: Rig, flight: FlightProcess) -> None:
    b = Bench(rig, load_faults([{"kind": "process.restart", "t_s": 0.0, "duration_s": 1.0}], rig, source="t"),
              flight=flight)
    old = flight.proc
    assert old is not None
    await b.tick()
    await asyncio.wait_for(old.wait(), 5.0)
    assert await asyncio.wait_for(flight.stop(), 5.0) == -9
    await b.schedule.aclose()


async def test_a_restart_that_cannot_start_is_an_exit_and_is_logged(
    rig: Rig, flight: FlightProcess, tmp_path: Path
) -> None:
    b = Bench(rig, load_faults([{"kind": "process.restart", "t_s": 0.0, "duration_s": 0.005}], rig, source="t"),
              flight=flight)
    exited = flight.exited
    flight.argv = [str(tmp_path / "no-such-flight-code")]
    await b.tick(3)
    await asyncio.wait_for(exited.wait(), 5.0)
    await asyncio.gather(*b.schedule.tasks, return_exceptions=True)
    (_, name, detail), = b.fault_events(" error")
    assert name == "process.restart error" and "FileNotFoundError" in detail["error"]


async def test_process_faults_need_a_flight_process(rig: Rig) -> None:
    faults = load_faults([{"kind": "process.kill", "t_s": 1.0}], rig, source="s.toml")
    with pytest.raises(ConfigError, match=r"s.toml: \[\[faults\]\] #0 \(process.kill\) kind: needs the flight code"):
        Bench(rig, faults)
    b = Bench(rig)
    with pytest.raises(ConfigError, match="needs the flight code"):
        b.schedule.start_now("process.restart", 0, duration_s=0.1)
