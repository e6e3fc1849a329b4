"""The flight code's IMU-loss watchdog on the bench's clock: it fires exactly
``imu_timeout_s`` of sim time after the last sample, beside CPU hogs as on a quiet machine
(on the host clock it fired whenever the host was slow, and under load mid-flight)."""

from __future__ import annotations

import numpy as np
import pytest

from hil.flight.tickloop import Clock
from hil.config import load_toml
from hil.record import iter_messages, read_topic
from hil.config.rig import load_rig
from tests.system.conftest import explain

pytestmark = [pytest.mark.system, pytest.mark.pty]

SILENCE_T_NS = 10_000_000_000  # rigs/scenarios/fault-imu-silence.toml


async def test_imu_watchdog_fires_exactly_after_imu_timeout_under_load(fly) -> None:
    rig = load_rig(None)
    timeout_ns = round(load_toml(rig.flight_config_path)["failsafe"]["imu_timeout_s"] * 1e9)
    result = await fly("fault-imu-silence", duration_s=10.2, stress_cpu=4)
    assert result.end_reason.value == "completed", explain(result)
    assert result.clock is Clock.VIRTUAL, result.clock_note
    assert result.log_path is not None
    t_imu = read_topic(result.log_path, "/hil/imu/sample")["t_ns"]
    esc = read_topic(result.log_path, "/hil/esc/command")
    t_esc, targets = esc["t_ns"], esc["targets_us"]
    t_last = int(t_imu[t_imu < SILENCE_T_NS].max())
    # the last sample is answered at its own sim time; then nothing until the watchdog
    answered = t_esc == t_last
    assert np.any(answered) and np.max(targets[answered]) > 1000.0, "flying before the silence"
    later = t_esc > t_last
    assert int(t_esc[later][0]) == t_last + timeout_ns, (t_last, t_esc[later][:3])
    assert np.all(targets[later][0] <= 1000.0)  # motors to minimum
    # the watchdog fired every 0.1 s of the silence (10.0975 s, 10.1975 s) and never before it:
    # its count starts at 1 with the fault, load caused none
    timeouts = [str(m.get("message")) for _, _, m in iter_messages(result.log_path, ["/fc/log"])
                if "imu.timeout" in str(m.get("message"))]
    assert [t.split("timeouts=")[1].split()[0] for t in timeouts] == ["1", "2"], timeouts
