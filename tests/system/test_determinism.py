"""Lockstep is deterministic: same rig, scenario and seed -> the same plant trajectory and
the same bytes on every control wire (IMU, ADC both ways, RC, ESC).

The flight code runs on the bench's clock (virtual time, docs/time.md), so this holds on a
loaded machine and when the flight code is stopped for seconds in the middle of a run (a
debugger, an oversubscribed campaign): the runs under load below are the test users need.
"""

from __future__ import annotations

import asyncio
import os
import signal

import numpy as np
import pytest

from hil.flight.tickloop import Clock, TickLoop
from hil.flight.devices import DeviceSet
from hil.record import iter_messages, read_wire
from hil.flight.run_result import RunResult
from hil.flight.scenario_runner import ScenarioRunner
from tests.system.conftest import explain

pytestmark = [pytest.mark.system, pytest.mark.pty]

CONTROL_WIRES = [("imu", "tx"), ("adc", "tx"), ("adc", "rx"), ("rc", "tx"), ("esc", "rx")]
TRUTH = ("truth.h_m", "truth.roll_deg", "truth.pitch_deg", "truth.yaw_deg", "truth.rotor_omega_radps")
#: CPU hogs beside the runs under load: two per core of these machines
HOGS = 4


def assert_same_flight(a: RunResult, b: RunResult) -> None:
    assert a.end_reason.value == "completed", explain(a)
    assert b.end_reason.value == "completed", explain(b)
    assert a.trace is not None and b.trace is not None
    for name in TRUTH:
        ta, va = a.trace.signal(name)
        tb, vb = b.trace.signal(name)
        np.testing.assert_array_equal(ta, tb)
        np.testing.assert_array_equal(va, vb, err_msg=name)
    assert a.log_path is not None and b.log_path is not None
    for port, direction in CONTROL_WIRES:
        wa = read_wire(a.log_path, port, direction)
        wb = read_wire(b.log_path, port, direction)
        assert len(wa) > 0, (port, direction)
        assert wa == wb, f"{port}/{direction} differs: {len(wa)} vs {len(wb)} bytes"


def flight_log(result: RunResult) -> list[str]:
    assert result.log_path is not None
    return [str(m.get("message", "")) for _, _, m in iter_messages(result.log_path, ["/fc/log"])]


async def test_two_runs_same_seed_are_identical(fly, tmp_path) -> None:
    a = await fly("altitude-step", duration_s=6.0, out_dir=tmp_path / "a")
    b = await fly("altitude-step", duration_s=6.0, out_dir=tmp_path / "b")
    assert_same_flight(a, b)


async def test_load_and_a_stopped_flight_code_change_nothing(fly, tmp_path) -> None:
    """Both runs beside 4 CPU hogs; in the second the flight code is SIGSTOPped for 2 s of
    wall time at sim time 3.5 s (armed, taking off). Identical all the same, and the
    IMU watchdog never fired (it would on the host clock: 0.1 s)."""
    stopped: list[int] = []

    def stop_mid_flight(loop: TickLoop, devices: DeviceSet, runner: ScenarioRunner) -> None:
        after = loop.after_tick
        stop_k = round(3.5e9 / loop.tick_ns)

        def after_tick(k: int, t_ns: int) -> None:
            if after is not None:
                after(k, t_ns)
            if k == stop_k and runner.flight is not None and runner.flight.pid is not None:
                pid = runner.flight.pid
                os.kill(pid, signal.SIGSTOP)
                stopped.append(pid)
                # the stimulus is wall time on purpose: the bench must wait it out
                asyncio.get_running_loop().call_later(2.0, os.kill, pid, signal.SIGCONT)

        loop.after_tick = after_tick

    a = await fly("altitude-step", duration_s=6.0, out_dir=tmp_path / "a", stress_cpu=HOGS)
    b = await fly("altitude-step", duration_s=6.0, out_dir=tmp_path / "b", stress_cpu=HOGS,
                  on_ready=stop_mid_flight)
    assert stopped, "the flight code was never stopped"
    assert a.clock is Clock.VIRTUAL and b.clock is Clock.VIRTUAL, (a.clock_note, b.clock_note)
    assert_same_flight(a, b)
    for result in (a, b):
        lines = flight_log(result)
        assert any("event=mode" in line and "new=armed" in line for line in lines), explain(result)
        assert not [line for line in lines if "imu.timeout" in line], explain(result)


async def test_another_seed_gives_another_run(fly, tmp_path) -> None:
    a = await fly("hover", duration_s=4.0, seed=1, out_dir=tmp_path / "a")
    b = await fly("hover", duration_s=4.0, seed=2, out_dir=tmp_path / "b")
    assert a.log_path is not None and b.log_path is not None
    assert read_wire(a.log_path, "imu", "tx") != read_wire(b.log_path, "imu", "tx")
