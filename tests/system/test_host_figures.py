"""What a run reports of its host.

* Steal time (hil/host/steal.py): every run's timing carries what the hypervisor took over its
  tick loop, and so does its log. A realtime run whose samples went without a command while
  the host took time says so in a note.
* The cores it kept busy (hil/host/cpuuse.py): the flight code's and the recorder's CPU per
  tick beside the bench's, and their sum over the wall time."""

from __future__ import annotations

import json
import os

import pytest

import hil.flight.run
from hil.flight.tickloop import EndReason, Mode
from hil.record import read_metadata
from hil.host.steal import read_steal_ms
from tests.system.conftest import explain

pytestmark = [pytest.mark.system, pytest.mark.pty]


async def test_a_run_reports_the_steal_time_of_its_tick_loop(fly) -> None:
    if read_steal_ms() is None:
        pytest.skip("this kernel does not count steal time")
    result = await fly("hover", duration_s=0.5)
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    steal_ms = result.timing["host_steal_ms"]
    assert 0.0 <= steal_ms <= 1000 * result.timing["wall_s"] * 64  # at most every CPU, the whole run
    assert result.log_path is not None
    logged = json.loads(read_metadata(result.log_path)["verdict"]["timing"])
    assert logged["host_steal_ms"] == steal_ms


class _StolenMeter:
    """A host that took 30 ms during the tick loop."""

    def start(self) -> None:
        pass

    def stop(self) -> float:
        return 30.0


async def test_realtime_misses_with_steal_time_get_a_note(fly, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(hil.flight.run, "StealMeter", _StolenMeter)
    # ADC replies held 3 ms: no sample's command can come within its 2.5 ms tick
    result = await fly("hover", duration_s=0.3, mode=Mode.REALTIME, stress_adc_delay_us=3000.0)
    assert result.timing["host_steal_ms"] == 30.0
    assert result.timing["rt_no_command"] > 0, explain(result)
    [note] = [n for n in result.notes if "steal time" in n]
    assert "30 ms" in note and f"{result.timing['rt_no_command']:.0f} samples without a command" in note


async def test_no_note_when_the_host_took_nothing(fly, monkeypatch: pytest.MonkeyPatch) -> None:
    class _Nothing(_StolenMeter):
        def stop(self) -> float:
            return 0.0

    monkeypatch.setattr(hil.flight.run, "StealMeter", _Nothing)
    result = await fly("hover", duration_s=0.3, mode=Mode.REALTIME, stress_adc_delay_us=3000.0)
    assert result.timing["host_steal_ms"] == 0.0 and result.timing["rt_no_command"] > 0
    assert not [n for n in result.notes if "steal time" in n]


async def test_a_recorded_run_reports_the_cpu_of_each_process_and_the_cores_it_kept_busy(fly) -> None:
    result = await fly("hover", duration_s=1.0)
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    t = result.timing
    per_tick = t["bench_cpu_per_tick_us"] + t["fc_cpu_per_tick_us"] + t["recorder_cpu_per_tick_us"]
    assert t["fc_cpu_per_tick_us"] > 0 and t["recorder_cpu_per_tick_us"] > 0
    # the sum over the tick loop's wall time (ticks / wall s = ticks per s)
    assert t["cores_used"] == pytest.approx(per_tick * 1e-6 * t["ticks"] / t["wall_s"], rel=1e-6)
    assert 0 < t["cores_used"] <= len(os.sched_getaffinity(0)) + 0.5  # /proc counts in 10 ms steps


async def test_an_unrecorded_run_has_no_recorder_to_count(fly) -> None:
    result = await fly("hover", duration_s=0.5, record=False)
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    assert "recorder_cpu_per_tick_us" not in result.timing
    assert result.timing["cores_used"] > 0
