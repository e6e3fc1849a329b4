"""Device faults (XSENS, RC receiver, ESCs, telemetry link) seen where the flight code or the
plant would see them, and that each ends when it should."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from emulators.rc.sbus import unpack_sbus
from emulators.rc.script import Setpoint, StickScript
from emulators.xbee.frames import ApiParser, tx16
from emulators.xbee.frames import encode_frame as xbee_frame
from emulators.xsens.defs import MID
from hil.faults import load_faults
from hil.config.rig import Rig
from tests.unit.faults.harness import (
    Bench,
    arm_and_spin,
    capture_records,
    imu_samples,
    ppm_frames,
    set_multiple_targets,
    xbus_frames,
)

WAKEUP = bytes.fromhex("FA FF 3E 00 C3")  # docs/protocols.md §1 worked frames


def bench(rig: Rig, raw: list[dict[str, Any]], **kw: Any) -> Bench:
    return Bench(rig, load_faults(raw, rig, source="test"), **kw)


# -- XSENS ------------------------------------------------------------------------------------------
async def test_imu_silence_stops_data_and_the_counter_jumps_when_it_returns(frig: Rig) -> None:
    b = bench(frig, [{"kind": "imu.silence", "t_s": 0.1, "duration_s": 0.1}])
    await b.run_to(0.3)
    assert b.received("imu", 0.1, 0.2) == b""
    counters = [s["counter"] for s in imu_samples(b.received("imu"))]
    assert counters[:40] == list(range(40)) and counters[40] == 80  # 40 samples never sent
    assert b.devices.imu.counters["silenced_samples"] == 40


async def test_imu_reset_wakes_up_and_streams_again_after_the_ack_window(frig: Rig) -> None:
    b = bench(frig, [{"kind": "imu.reset", "t_s": 0.1}])
    await b.run_to(0.7)
    assert b.received("imu", 0.1, 0.1025).startswith(WAKEUP)
    assert b.received("imu", 0.1025, 0.6) == b""  # waiting 500 ms for a WakeUpAck that never comes
    frames, _ = xbus_frames(b.received("imu", 0.6))
    assert [f.mid for f in frames[:3]] == [MID.CONFIGURATION, MID.EMTS_DATA, MID.MTDATA2]  # mk4 start-up
    assert imu_samples(b.received("imu", 0.6))[0]["counter"] == 0
    (t0, n0, d0), (t1, n1, d1) = b.fault_events()
    assert (t0, t1, n0, n1) == (100_000_000, 100_000_000, "imu.reset start", "imu.reset end")
    assert d0["changed"] == {"state_before": "MEASUREMENT", "state": "WAKEUP"} and d1["instant"]


async def test_imu_packet_counter_jump(frig: Rig) -> None:
    b = bench(frig, [{"kind": "imu.counter_jump", "t_s": 0.1, "delta": 1000}])
    await b.run_to(0.15)
    counters = [s["counter"] for s in imu_samples(b.received("imu"))]
    assert np.diff(counters).tolist() == [1] * 39 + [1001] + [1] * 20


# -- RC -----------------------------------------------------------------------------------------------
async def test_rc_signal_loss_no_pulses_in_the_window(rig: Rig) -> None:
    b = bench(rig, [{"kind": "rc.signal_loss", "t_s": 0.2, "duration_s": 0.2}])
    await b.run_to(0.6)
    times = [t for t, _ in b.chunks("rc")]
    gap = [t for t in times if 0.2e9 + 22.5e6 <= t < 0.4e9]  # frames started before 0.2 s still finish
    assert gap == [] and any(0.4e9 <= t < 0.4e9 + 25e6 for t in times)
    frames = ppm_frames(capture_records(b.received("rc")))
    assert all(len(f) == 8 for f in frames)
    assert b.devices.ppm.counters["frames_lost"] == 9 and type(b.devices.ppm.script) is StickScript


async def test_rc_single_glitch_and_glitch_train(rig: Rig) -> None:
    b = bench(rig, [{"kind": "rc.glitch", "t_s": 0.1, "channel": 2, "width_us": 30}])
    await b.run_to(0.3)
    sizes = [len(f) for f in ppm_frames(capture_records(b.received("rc")))]
    assert sizes.count(9) == 1 and sizes.count(8) == len(sizes) - 1  # one channel cut in two
    b = bench(rig, [{"kind": "rc.glitch", "t_s": 0.1, "duration_s": 0.1, "interval_s": 0.0225}])
    await b.run_to(0.3)
    frames = ppm_frames(capture_records(b.received("rc")))
    assert [len(f) for f in frames].count(9) in (4, 5) and b.devices.ppm.counters["glitches"] in (4, 5)
    assert b.fault_events(" end")[0][2]["changed"]["glitches"] == b.devices.ppm.counters["glitches"]


async def test_rc_channel_count_changes_and_comes_back(rig: Rig) -> None:
    b = bench(rig, [{"kind": "rc.channel_count", "t_s": 0.1, "duration_s": 0.2, "n_channels": 5}])
    await b.run_to(0.5)
    sizes = [len(f) for f in ppm_frames(capture_records(b.received("rc")))]
    assert 5 in sizes and sizes[0] == 8 and sizes[-1] == 8
    assert sizes.count(5) in (8, 9, 10)


async def test_rc_channel_stuck_at_its_value_while_the_stick_moves(rig: Rig) -> None:
    script = StickScript([Setpoint(0.15, 1, 1800.0)])
    b = bench(rig, [{"kind": "rc.channel_stuck", "t_s": 0.1, "duration_s": 0.2, "channel": 1}], script=script)
    await b.run_to(0.5)
    ch1 = [f[0] for f in ppm_frames(capture_records(b.received("rc")))]
    assert all(abs(v - 1500) <= 3 for v in ch1[:13]) and all(abs(v - 1800) <= 3 for v in ch1[-6:])
    start = b.fault_events(" start")[0][2]["changed"]
    assert start == {"channel": 1, "pulse_us": 1500}


def sbus_frames(b: Bench) -> list[tuple[int, bytes]]:
    return [(t, d[i : i + 25]) for t, d in b.chunks("rc", 0.1, 0.4) for i in range(0, len(d), 25)]


async def test_sbus_flags_raise_failsafe_while_the_channels_keep_coming(rig: Rig) -> None:
    sbus = dataclasses.replace(rig, rc=dataclasses.replace(rig.rc, frontend="sbus"))
    b, clean = bench(sbus, [{"kind": "rc.sbus_flags", "t_s": 0.2, "duration_s": 0.1}]), Bench(sbus)
    for x in (b, clean):
        await x.run_to(0.4)
    pairs = list(zip(sbus_frames(b), sbus_frames(clean), strict=True))
    assert len(pairs) > 20
    for (t, got), (_, want) in pairs:
        g, w = unpack_sbus(got), unpack_sbus(want)
        assert g is not None and w is not None and g.channels_raw == w.channels_raw
        assert not w.failsafe and not w.frame_lost
        assert g.failsafe == g.frame_lost == (0.2e9 <= t < 0.3e9), t


# -- ESC ----------------------------------------------------------------------------------------------
async def test_esc_refuses_to_arm_while_the_fault_lasts(rig: Rig) -> None:
    b = bench(rig, [{"kind": "esc.refuse_arm", "t_s": 0.0, "duration_s": 1.0, "esc": 1}])
    await arm_and_spin(b, 1500.0)
    await b.run_to(0.9)
    assert [e.armed for e in b.devices.escs] == [True, False, True, True]
    assert b.devices.plant.state.rotor_omega_radps[1] == 0.0 and b.devices.plant.state.rotor_omega_radps[0] > 100
    await b.write("esc", set_multiple_targets([1000.0] * 4))
    await b.run_to(1.6)
    assert all(e.armed for e in b.devices.escs)


async def test_esc_desync_drops_thrust_sporadically(rig: Rig) -> None:
    b = bench(rig, [{"kind": "esc.desync", "t_s": 0.7, "duration_s": 1.0, "esc": 0, "rate_hz": 10.0}])
    await arm_and_spin(b, 1500.0)
    zeros = []
    while b.t_ns < 2.2e9:
        await b.tick()
        zeros.append(b.devices.throttle[0] == 0.0)
    n = b.devices.escs[0].counters["desyncs"]
    assert 4 <= n <= 20 and sum(zeros) > 40  # 0.1 s each
    assert not any(zeros[-150:]) and b.devices.escs[3].counters["desyncs"] == 0


async def test_esc_stuck_output_ignores_the_input(rig: Rig) -> None:
    b = bench(rig, [{"kind": "esc.stuck", "t_s": 0.8, "duration_s": 0.4, "esc": 2, "throttle": 0.3}])
    await arm_and_spin(b, 1500.0)
    await b.run_to(0.9)
    await b.write("esc", set_multiple_targets([1700.0] * 4))
    await b.run_to(1.1)
    thr = b.devices.throttle
    assert thr[2] == 0.3 and thr[0] > 0.6
    await b.run_to(1.3)
    assert b.devices.throttle[2] == b.devices.throttle[0]


# -- telemetry link -------------------------------------------------------------------------------------
async def downlink(b: Bench, until_s: float, every_s: float = 0.02) -> None:
    """The flight code sends a TX16 to the ground station every ``every_s``."""
    n = 0
    while b.t_ns < until_s * 1e9:
        if b.k % round(every_s / 0.0025) == 0:
            n += 1
            await b.write("telemetry", xbee_frame(tx16(n & 0xFF or 1, 0x0000, bytes([n & 0xFF]) * 20)))
        await b.tick()


async def test_telemetry_dropout_nothing_reaches_the_ground(rig: Rig) -> None:
    b = bench(rig, [{"kind": "telemetry.dropout", "t_s": 0.2, "duration_s": 0.2}])
    await downlink(b, 0.6)
    got = [t for t, _ in b.chunks("ground")]
    assert not [t for t in got if 0.21e9 <= t < 0.4e9]
    assert len([t for t in got if t < 0.2e9]) >= 9 and len([t for t in got if t >= 0.42e9]) >= 8
    statuses = [f for f in ApiParser().feed(b.received("telemetry", 0.2, 0.4)) if f[0] == 0x89]
    assert statuses and all(f[2] == 1 for f in statuses)  # no ACK
    assert b.devices.link.counters["failed"] >= 9


async def test_telemetry_loss_costs_retries(rig: Rig) -> None:
    clean, b = bench(rig, []), bench(rig, [{"kind": "telemetry.loss", "t_s": 0.0, "loss_probability": 0.5}])
    for x in (clean, b):
        await downlink(x, 1.0)
    c, f = clean.devices.link.counters, b.devices.link.counters
    assert c["attempts"] == c["packets"] == 50
    assert 1.6 < f["attempts"] / f["packets"] < 2.4  # each attempt lost with p = 0.5
