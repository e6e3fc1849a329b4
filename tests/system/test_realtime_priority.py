"""A realtime run's scheduling (hil/host/rtsched.py): the tick loop and the flight code run on
SCHED_FIFO where the host allows it, the recorder does not, the bench's thread is put back
when the run ends, and ``policy = "fifo"`` on a host that refuses it stops before anything is
created."""

from __future__ import annotations

import errno
import os
from pathlib import Path

import pytest

from hil.flight.tickloop import EndReason, Mode
from hil.config import ConfigError
from hil.config.rig import load_rig
from hil.host.rtsched import RtPolicy, fifo_allowed
from tests.system.conftest import at_tick, explain

pytestmark = [pytest.mark.system, pytest.mark.pty]


def _host_allows_fifo() -> bool:
    return fifo_allowed(10)


async def test_the_tick_loop_and_the_flight_code_run_fifo_and_the_recorder_does_not(fly, tmp_path: Path) -> None:
    seen: dict[str, int] = {}
    before = (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)
    children_before = set(_children())

    def look(runner) -> None:
        seen["bench"] = os.sched_getscheduler(0)
        seen["pacer"] = _thread_policies()["hil-pacer"]
        seen["flight"] = os.sched_getscheduler(runner.flight.pid)
        seen["flight_priority"] = os.sched_getparam(runner.flight.pid).sched_priority
        others = [p for p in set(_children()) - children_before if p != runner.flight.pid]
        seen["others"] = max((os.sched_getscheduler(p) for p in others), default=-1)

    result = await fly("hover", duration_s=1.0, mode=Mode.REALTIME, on_ready=at_tick(200, look))
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    assert (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority) == before
    assert result.rt_scheduling is not None
    if not _host_allows_fifo():
        assert result.rt_scheduling.policy is RtPolicy.NORMAL
        assert any("default scheduling policy" in n for n in result.notes)
        return
    assert result.rt_scheduling.policy is RtPolicy.FIFO and result.rt_scheduling.priority == 50
    assert seen["bench"] == seen["pacer"] == os.SCHED_FIFO
    assert (seen["flight"], seen["flight_priority"]) == (os.SCHED_FIFO, 50)
    assert seen["others"] == os.SCHED_OTHER  # the recorder child
    from hil.record import read_metadata

    assert result.log_path is not None
    assert read_metadata(result.log_path)["verdict"]["rt_scheduling"] == "SCHED_FIFO priority 50"


async def test_lockstep_is_not_raised(fly) -> None:
    result = await fly("hover", duration_s=0.2)
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    assert result.rt_scheduling is None


async def test_fifo_refused_by_the_host_names_the_rig_key_and_leaves_nothing(fly, tmp_path: Path,
                                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    import dataclasses

    def refuse(pid: int, policy: int, param: os.sched_param) -> None:
        raise PermissionError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(os, "sched_setscheduler", refuse)
    rig = load_rig(None)
    rig = dataclasses.replace(rig, realtime=dataclasses.replace(rig.realtime, policy="fifo"))
    with pytest.raises(ConfigError) as err:
        await fly("hover", rig=rig, duration_s=1.0, mode=Mode.REALTIME, out_dir=tmp_path / "logs")
    assert str(rig.path) in str(err.value) and '[realtime] policy = "fifo"' in str(err.value)
    assert "ulimit -r" in str(err.value)
    assert not (tmp_path / "logs").exists()


def _thread_policies() -> dict[str, int]:
    """This process's threads by name, and their policies (the pacer is ``hil-pacer``)."""
    import threading

    return {t.name: os.sched_getscheduler(t.native_id) for t in threading.enumerate()
            if t.native_id is not None and t.name in ("MainThread", "hil-pacer")}


def _children() -> list[int]:
    pid = os.getpid()
    out: list[int] = []
    for task in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{task}/children", encoding="ascii") as f:
                out += [int(p) for p in f.read().split()]
        except OSError:
            continue
    return out
