"""Closed-loop tests of the flight code with the ``hil_bench`` pytest fixture: copy this file
into your tests and change the sticks, waits and bounds to your vehicle's.

Run:  pytest examples/test_my_flight_code.py -v  [--hil-keep-logs hil-logs]

Every ``start`` runs the flight code as its own process against the emulated devices on
ptys, in lockstep (one 400 Hz tick per IMU sample, faster than real time), and records an
MCAP log that is kept when the test fails (its path is printed). All times below are sim
seconds. See docs/pytest-plugin.md.
"""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.asyncio  # harmless with asyncio_mode = "auto", needed without it

RIG = "paper-quad"
#: the RC script: throttle low + yaw right for 1 s arms, then the throttle stick to 1200 us
#: (= a 2 m altitude setpoint on this rig: 10 m over 1000-2000 us) with a 1 s ramp
TAKE_OFF = [
    {"t_s": 0.5, "action": "arm"},
    {"t_s": 2.5, "channel": 3, "pulse_us": 1200, "ramp_s": 1.0},
]
MIN_US = 1000.0  #: the ESCs' arming level: motors stopped
TICK_S = 0.0025  #: the bench's tick, the IMU's 400 Hz sample period


def motors_at_minimum(bench) -> bool:
    return bench.esc_command is not None and max(bench.esc_command.pulse_us) <= MIN_US


def level_within(bench, limit_deg: float) -> bool:
    return abs(bench.truth.roll_deg) < limit_deg and abs(bench.truth.pitch_deg) < limit_deg


async def take_off(hil_bench, duration_s: float):
    bench = await hil_bench.start(rig=RIG, sticks=TAKE_OFF, duration_s=duration_s, seed=1)
    await bench.until(lambda b: b.flight_mode == "ARMED", timeout_s=3.0)
    await bench.until(lambda b: b.truth.h_m > 1.5, timeout_s=5.0)
    return bench


async def test_take_off_and_hover(hil_bench):
    bench = await take_off(hil_bench, duration_s=12.0)
    assert bench.flight_mode == "FLYING"
    await bench.run_for(4.0)  # the altitude loop settles
    # every tick for 2 s: altitude within 0.5 m of the setpoint, level within 3 deg
    await bench.always(lambda b: 1.5 < b.truth.h_m < 2.5 and level_within(b, 3.0), for_s=2.0)
    assert abs(bench.telemetry["alt_est_m"] - bench.truth.h_m) < 0.3  # the estimator agrees

    # after the run: the whole record is there
    await bench.stop()
    t_s, h_m = bench.signal("truth.h_m")
    assert h_m[t_s > 7.0].max() < 2.5
    assert bench.timing().no_command == 0  # the loop answered every IMU sample


async def test_rc_loss_descends_and_disarms_on_the_ground(hil_bench):
    bench = await take_off(hil_bench, duration_s=20.0)
    async with bench.fault("rc.signal_loss") as loss:  # the transmitter is off for the whole block
        t_fs = await bench.until(lambda b: b.flight_mode == "FAILSAFE_RC", timeout_s=1.0)
        # [failsafe] rc_loss_s = 0.5 s after the last good PPM frame (22.5 ms frames)
        assert 0.5 - 0.0225 <= t_fs - loss.t_start_s < 0.6
        # a controlled descent: level, and no faster than a fall would be
        await bench.always(lambda b: level_within(b, 5.0) and b.truth.climb_mps > -1.0, for_s=1.0)
        await bench.until(lambda b: b.flight_mode == "DISARMED", timeout_s=10.0)
        assert bench.truth.h_m < 0.5, "disarmed while still in the air"
        await bench.until(lambda b: b.truth.on_ground, timeout_s=1.0)
        assert motors_at_minimum(bench)


async def test_imu_silence_stops_the_motors(hil_bench):
    bench = await take_off(hil_bench, duration_s=10.0)
    # The IMU watchdog is the flight code's IMU read timeout ([failsafe] imu_timeout_s = 0.1 s).
    # In lockstep the flight code runs on the bench's clock (docs/time.md), so the watchdog fires
    # 0.1 s of sim time after the last sample, to the tick, on a quiet or a loaded machine.
    async with bench.fault("imu.silence") as loss:
        t_min = await bench.until(motors_at_minimum, timeout_s=0.2)
    t_last_sample = loss.t_start_s - TICK_S  # the fault silenced the sample of its first tick
    assert t_min - t_last_sample == pytest.approx(0.1, abs=1e-6)
    # data back after a real gap: the flight code disarms (re-arm to fly) and the vehicle drops
    await bench.until(lambda b: b.flight_mode == "DISARMED", timeout_s=0.5)
    await bench.always(motors_at_minimum, for_s=0.5)


async def test_a_short_imu_stall_is_flown_through(hil_bench):
    bench = await take_off(hil_bench, duration_s=10.0)
    # A delivery stall shorter than the watchdog: the flight code holds its last command, then
    # flies on with the samples that come back.
    async with bench.fault("imu.silence", duration_s=0.05):
        await bench.always(lambda b: not motors_at_minimum(b), for_s=0.05)
    await bench.always(lambda b: b.flight_mode == "FLYING" and not motors_at_minimum(b), for_s=0.5)
