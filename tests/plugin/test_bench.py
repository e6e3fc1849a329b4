"""The ``hil_bench`` fixture on short lockstep runs with the real flight code: sim-time waits,
faults for the body of a block, live values, the record after the run, stop and clean-up."""

from __future__ import annotations

import numpy as np
import pytest

from hil.flight.tickloop import EndReason
from hil.config import ConfigError
from hil.testing.records import PredicateFailed, RunEnded, SimTimeout
from hil.record import iter_messages, read_metadata

pytestmark = [pytest.mark.system, pytest.mark.pty]

RIG = None  # the default rig (paper-quad)
TICK_S = 0.0025
ARM = [{"t_s": 0.5, "action": "arm"}]  # throttle low + yaw right held 1 s: ARMED at ~1.5 s + telemetry


def _events(log) -> list[dict]:
    return [m for _, _, m in iter_messages(log, ["/hil/events"])]


async def test_waits_faults_and_record(hil_bench) -> None:
    bench = await hil_bench.start(rig=RIG, sticks=ARM, duration_s=3.0, seed=3)
    assert bench.t_s >= 0.0 and bench.truth.on_ground

    # run_for: the first tick at or after now + 0.1 s of sim time
    t0 = bench.t_s
    t = await bench.run_for(0.1)
    assert t0 + 0.1 - 1e-9 <= t < t0 + 0.1 + TICK_S
    assert bench.t_s >= t  # the bench keeps ticking; it never goes back

    # until: the tick at which the predicate first held, judged every tick
    t_armed = await bench.until(lambda b: b.flight_mode == "ARMED", timeout_s=2.5)
    assert 1.5 <= t_armed < 2.5 and bench.t_s >= t_armed
    assert bench.esc_command is not None and bench.esc_command.pulse_us == (1100.0,) * 4  # idle when armed
    assert all(bench.esc_armed)

    with pytest.raises(SimTimeout, match=r"until\(lambda b: False\) did not hold within 0.05 s of sim time"):
        t_start = bench.t_s
        await bench.until(lambda b: False, timeout_s=0.05)
    assert bench.t_s >= t_start + 0.05
    with pytest.raises(ZeroDivisionError):
        await bench.until(lambda b: 1 / 0, timeout_s=1.0)

    t_end = await bench.always(lambda b: b.truth.on_ground, for_s=0.05)
    assert bench.t_s >= t_end
    t_mark = bench.t_s + 0.02
    with pytest.raises(PredicateFailed, match=r"always\(lambda b: b.t_s < t_mark\) was false at t = "):
        await bench.always(lambda b: b.t_s < t_mark, for_s=1.0)
    assert bench.t_s >= t_mark

    # a fault for the body of a block: IMU silence -> the flight code's watchdog -> motors at minimum
    with pytest.raises(ConfigError, match="unknown fault kind"):
        async with bench.fault("imu.slience"):
            pass
    with pytest.raises(ConfigError, match="unknown parameter"):
        async with bench.fault("imu.silence", port="imu"):
            pass
    async with bench.fault("imu.silence") as silence:
        assert silence.t_end_s is None and bench.schedule is not None
        assert [a.kind for a in bench.schedule.active()] == ["imu.silence"]
        t_min = await bench.until(lambda b: max(b.esc_command.pulse_us) <= 1000.0, timeout_s=0.2)  # the 0.1 s watchdog, sim time
    assert silence.t_start_s <= t_min < silence.t_end_s
    assert bench.schedule.active() == []
    with pytest.raises(RuntimeError, match="still going"):
        bench.record("/hil/imu/sample")

    # the run ends at its duration while the test waits
    with pytest.raises(RunEnded, match=r"the run ended \(completed\)"):
        await bench.until(lambda b: False, timeout_s=60.0)
    result = await bench.finish()
    assert result.end_reason is EndReason.COMPLETED and result.log_path.exists()

    # the record: no IMU sample while silenced, samples on both sides of the gap
    imu = bench.record("/hil/imu/sample")
    t_imu = imu["t_ns"] / 1e9
    assert not np.any((t_imu >= silence.t_start_s - 1e-9) & (t_imu < silence.t_end_s - 1e-9))
    assert np.any(t_imu < silence.t_start_s) and np.any(t_imu >= silence.t_end_s)
    events = {(e["kind"], e["name"]): e for e in _events(result.log_path)}
    assert events[("fault", "imu.silence start")]["t_ns"] == round(silence.t_start_s * 1e9)
    assert events[("fault", "imu.silence end")]["t_ns"] == round(silence.t_end_s * 1e9)
    held = [e["detail"] for e in _events(result.log_path) if e["name"] == "until held"]
    assert [d["predicate"] for d in held] == [
        'lambda b: b.flight_mode == "ARMED"', "lambda b: max(b.esc_command.pulse_us) <= 1000.0"]
    assert [d["t_s"] for d in held] == [t_armed, t_min]
    # the trace agrees with until: telemetry first says ARMED (mode 2) at t_armed
    t_s, mode = bench.signal("tm.mode")
    assert t_s[np.argmax(mode == 2)] == pytest.approx(t_armed)
    timing = bench.timing()
    assert timing.samples == len(bench.record("/hil/timing/tick")["t_ns"]) > 1000
    # on the bench's clock the flight code's 0.1 s watchdog answered the silence exactly 0.1 s
    # of sim time after the last sample before it, with minimum pulses
    esc = bench.record("/hil/esc/command")
    t_last = int(imu["t_ns"][t_imu < silence.t_start_s].max())
    after = esc["t_ns"] > t_last
    assert int(esc["t_ns"][after][0]) == t_last + 100_000_000
    assert np.all(esc["targets_us"][after][0] <= 1000.0)


async def test_stop_scenario_faults_and_live_values(hil_bench) -> None:
    scenario = {"faults": [{"kind": "telemetry.dropout", "t_s": 0.2, "duration_s": 0.1}]}
    bench = await hil_bench.start(rig=RIG, scenario=scenario, duration_s=30.0)
    await bench.run_for(0.15)
    assert bench.imu_sample is not None and bench.imu_sample.t_ns <= round(bench.t_s * 1e9)
    assert bench.last_event("SampleSent") is bench.imu_sample
    assert bench.esc_command is not None and bench.esc_command.pulse_us == (1000.0,) * 4  # disarmed
    assert bench.telemetry is not None and bench.flight_mode in ("BOOT", "DISARMED")  # BOOT: baro zeroing
    counters = bench.counters
    assert counters["port.imu"]["bytes_tx"] > 0 and counters["port.esc"]["bytes_rx"] > 0
    assert set(counters) >= {"imu", "adc", "rc", "esc", "telemetry", "ground"}
    truth = bench.truth
    assert truth.h_m == 0.0 and truth.on_ground and truth.state.h_m == truth.h_m
    await bench.until(lambda b: b.t_s >= 0.35, timeout_s=1.0)  # past the dropout
    pid = bench.flight.pid

    result = await bench.stop()
    assert result.end_reason is EndReason.INTERRUPTED and bench.stopped_by_test
    assert not bench.running and bench.flight.returncode is not None and bench.flight.pid == pid
    assert (await bench.stop()) is result  # idempotent
    meta = read_metadata(result.log_path)
    assert meta["verdict"]["end_reason"] == "interrupted"
    names = [(e["kind"], e["name"], e["t_ns"]) for e in _events(result.log_path)]
    assert ("fault", "telemetry.dropout start", 200_000_000) in names
    assert ("fault", "telemetry.dropout end", 300_000_000) in names
    assert next(n for k, n, _ in names if k == "pytest") == "test"
    assert [n for k, n, _ in names if k == "pytest"][-1] == "stop"
    with pytest.raises(RunEnded):
        await bench.run_for(0.1)

    # a second bench of the same test: its own log, run to its own end
    second = await hil_bench.start(rig=RIG, duration_s=0.2, seed=2)
    assert second is not bench and second.t_s >= 0.0
    done = await second.finish()
    assert done.end_reason is EndReason.COMPLETED and done.seed == 2 and done.sim_s >= 0.2
    assert done.log_path.name.endswith("live_values-2.mcap") and done.log_path != result.log_path
    assert hil_bench.keep_path(second).name == done.log_path.name
