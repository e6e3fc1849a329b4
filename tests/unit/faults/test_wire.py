"""Wire faults on a real DeviceSet: what the flight code reads (or the device hears) while each
fault is active, compared with a fault-free twin of the same seed, and that it ends on time."""

from __future__ import annotations

from typing import Any

import pytest

from emulators.rc.capture import unpack_record
from emulators.xbee.frames import ApiParser, tx16
from emulators.xbee.frames import encode_frame as xbee_frame
from emulators.xsens.uart import receive_at_wrong_baud
from hil.faults import load_faults
from hil.config.rig import Rig
from tests.unit.faults.harness import Bench, adc_enter_spi, adc_read, xbus_frames

GOTO_CONFIG = bytes.fromhex("FA FF 30 00 D1")  # docs/protocols.md §1 worked frames
GOTO_CONFIG_ACK = bytes.fromhex("FA FF 31 00 D0")


async def twins(rig: Rig, raw: list[dict[str, Any]], until_s: float, seed: int = 1) -> tuple[Bench, Bench]:
    """The same bench with and without ``raw`` faults, run to ``until_s``."""
    faulty = Bench(rig, load_faults(raw, rig, source="test"), seed=seed)
    clean = Bench(rig, seed=seed)
    await faulty.run_to(until_s)
    await clean.run_to(until_s)
    return faulty, clean


def window(raw: dict[str, Any]) -> dict[str, Any]:
    return {"t_s": 0.1, "duration_s": 0.1, **raw}


async def test_silence_tx_cuts_the_stream_for_exactly_its_window(frig: Rig) -> None:
    b, clean = await twins(frig, [window({"kind": "wire.silence", "port": "imu"})], 0.3)
    assert b.received("imu", 0.1, 0.2) == b"" and len(clean.received("imu", 0.1, 0.2)) > 1000
    assert b.received("imu", 0.0, 0.1) == clean.received("imu", 0.0, 0.1)
    assert b.received("imu", 0.2, 0.3) == clean.received("imu", 0.2, 0.3)
    (t0, start, d0), (t1, end, d1) = b.fault_events()
    assert (t0, start, t1, end) == (100_000_000, "wire.silence start", 200_000_000, "wire.silence end")
    assert d0["target"] == "port imu tx" and d0["changed"] == {"port": "imu", "direction": "tx"}
    assert d1["changed"]["counts"]["tx_bytes_out"] == 0 and d1["changed"]["counts"]["tx_bytes_in"] > 1000
    assert b.devices.wire_filters == {}


async def test_silence_rx_the_device_never_hears_the_host(frig: Rig) -> None:
    b = Bench(frig, load_faults([window({"kind": "wire.silence", "port": "imu", "direction": "rx"})], frig, source="t"))
    await b.run_to(0.15)
    await b.write("imu", GOTO_CONFIG)
    await b.run_to(0.25)
    assert b.devices.imu.measuring and GOTO_CONFIG_ACK not in b.received("imu")
    await b.write("imu", GOTO_CONFIG)  # after the fault: answered
    await b.tick()
    assert not b.devices.imu.measuring and b.received("imu", 0.25).endswith(GOTO_CONFIG_ACK)


async def test_byte_loss_drops_a_fraction_of_bytes_and_keeps_the_rest_in_order(frig: Rig) -> None:
    b, clean = await twins(frig, [window({"kind": "wire.byte_loss", "port": "imu", "loss_probability": 0.2})], 0.3)
    for (t, got), (tc, want) in zip(b.chunks("imu", 0.1, 0.2), clean.chunks("imu", 0.1, 0.2), strict=True):
        it = iter(want)
        assert t == tc and all(byte in it for byte in got)  # a subsequence
    lost = 1 - len(b.received("imu", 0.1, 0.2)) / len(clean.received("imu", 0.1, 0.2))
    assert 0.17 < lost < 0.23
    assert b.received("imu", 0.2) == clean.received("imu", 0.2)


async def test_bit_flips_at_the_given_rate_without_changing_lengths(frig: Rig) -> None:
    b, clean = await twins(frig, [window({"kind": "wire.bit_flips", "port": "imu", "bit_error_rate": 0.01})], 0.3)
    got, want = b.received("imu", 0.1, 0.2), clean.received("imu", 0.1, 0.2)
    assert len(got) == len(want)
    flips = sum((x ^ y).bit_count() for x, y in zip(got, want))
    assert 0.008 < flips / (8 * len(want)) < 0.012
    assert b.received("imu", 0.2) == clean.received("imu", 0.2)
    end = b.fault_events(" end")[0][2]
    assert end["changed"]["counts"]["bits_flipped"] == flips


async def test_bad_checksum_on_xbus_corrupts_only_checksums(frig: Rig) -> None:
    b, clean = await twins(frig, [window({"kind": "wire.bad_checksum", "port": "imu"})], 0.3)
    got, want = b.received("imu", 0.1, 0.2), clean.received("imu", 0.1, 0.2)
    frames, parser = xbus_frames(got)
    assert len(xbus_frames(want)[0]) == 40 and frames == []
    assert parser.stats.checksum_errors >= 40  # (the parser also trips over preambles inside payloads)
    for (_, g), (_, w) in zip(b.chunks("imu", 0.1, 0.2), clean.chunks("imu", 0.1, 0.2), strict=True):
        assert g[:-1] == w[:-1] and g[-1] != w[-1]
    assert xbus_frames(b.received("imu", 0.2))[1].stats.checksum_errors == 0


async def test_bad_checksum_probability_hits_a_fraction_of_frames(frig: Rig) -> None:
    b, clean = await twins(frig, [{"kind": "wire.bad_checksum", "port": "imu", "t_s": 0.0, "probability": 0.5}], 0.5)
    pairs = list(zip(b.chunks("imu"), clean.chunks("imu"), strict=True))
    hit = sum(g != w for (_, g), (_, w) in pairs)
    assert len(pairs) == 201 and 0.35 < hit / 201 < 0.65
    assert len(xbus_frames(b.received("imu"))[0]) == 201 - hit


async def test_bad_checksum_on_rc_capture_records(rig: Rig) -> None:
    b, clean = await twins(rig, [window({"kind": "wire.bad_checksum", "port": "rc"})], 0.3)
    got = b.received("rc", 0.1, 0.2)
    recs = [got[i : i + 6] for i in range(0, len(got), 6)]
    assert len(recs) > 20 and all(unpack_record(r) is None for r in recs)
    want = clean.received("rc", 0.1, 0.2)
    assert all(r[:5] == want[i * 6 : i * 6 + 5] for i, r in enumerate(recs))
    tail = b.received("rc", 0.2)
    assert tail == clean.received("rc", 0.2) and all(unpack_record(tail[i : i + 6]) for i in range(0, len(tail), 6))


async def test_bad_checksum_on_xbee_api_frames_to_the_flight_code(rig: Rig) -> None:
    raw = [{"kind": "wire.bad_checksum", "port": "telemetry", "t_s": 0.0, "duration_s": 0.05}]
    b = Bench(rig, load_faults(raw, rig, source="t"))
    await b.tick()
    await b.write("telemetry", xbee_frame(tx16(1, 0x0000, b"hello")))
    await b.run_to(0.04)
    bad = b.received("telemetry")
    parser = ApiParser()
    assert parser.feed(bad) == [] and parser.counters.bad_checksum == 1 and bad[3] == 0x89  # TX status
    assert ApiParser().feed(b.received("ground")) != []  # the radio delivered it; only the wire lied
    await b.run_to(0.06)
    await b.write("telemetry", xbee_frame(tx16(2, 0x0000, b"again")))
    await b.run_to(0.1)
    (status,) = ApiParser().feed(b.received("telemetry", 0.05))
    assert status[:2] == b"\x89\x02"


async def test_bad_checksum_last_byte_mode_on_any_port(rig: Rig) -> None:
    raw = [{"kind": "wire.bad_checksum", "port": "adc", "t_s": 0.0, "duration_s": 0.05, "mode": "last_byte"}]
    b = Bench(rig, load_faults(raw, rig, source="t"))
    await b.tick()
    await b.write("adc", b"\x00" * 20)
    got = b.ports["adc"].client.read_now()
    assert got[:-1] == b"BBIO"[:4] and got[-1:] != b"1"
    await b.run_to(0.06)
    await adc_enter_spi(b)
    assert 0 < await adc_read(b, 1) < 4095  # the line is clean again


@pytest.mark.parametrize("kind", ["wire.truncate", "wire.duplicate"])
async def test_truncated_and_duplicated_frames(frig: Rig, kind: str) -> None:
    b, clean = await twins(frig, [window({"kind": kind, "port": "imu"})], 0.3)
    pairs = list(zip(b.chunks("imu", 0.1, 0.2), clean.chunks("imu", 0.1, 0.2), strict=True))
    assert len(pairs) == 40
    for (_, got), (_, want) in pairs:
        if kind == "wire.truncate":
            assert 1 <= len(got) < len(want) and want.startswith(got)
        else:
            assert got == want + want
    assert b.received("imu", 0.2) == clean.received("imu", 0.2)


async def test_duplicate_on_capture_records_keeps_record_alignment(rig: Rig) -> None:
    b, clean = await twins(rig, [window({"kind": "wire.duplicate", "port": "rc", "probability": 0.5})], 0.3)
    got, want = b.received("rc", 0.1, 0.2), clean.received("rc", 0.1, 0.2)
    recs = [unpack_record(got[i : i + 6]) for i in range(0, len(got), 6)]
    assert all(recs) and len(want) < len(got) < 2 * len(want)


async def test_delay_holds_bytes_in_sim_time_and_keeps_their_order(frig: Rig) -> None:
    raw = [window({"kind": "wire.delay", "port": "imu", "delay_s": 0.01})]
    b, clean = await twins(frig, raw, 0.3)
    got = dict(b.chunks("imu"))
    for t, data in clean.chunks("imu", 0.1, 0.2):
        assert got[t + 10_000_000].startswith(data)  # 4 ticks later, first in its tick
    assert b.received("imu") == clean.received("imu")  # nothing lost, nothing reordered
    assert 100_000_000 not in got and b.devices.wire_filters == {}


async def test_jitter_varies_the_delay_but_never_reorders(frig: Rig) -> None:
    raw = [window({"kind": "wire.delay", "port": "imu", "delay_s": 0.002, "jitter_s": 0.02})]
    b, clean = await twins(frig, raw, 0.4)
    assert b.received("imu") == clean.received("imu")  # same bytes, same order
    arrivals = []  # (first byte offset, tick it reached the client)
    offset = 0
    for t, data in b.chunks("imu"):
        arrivals.append((offset, t))
        offset += len(data)
    offset, delays = 0, []
    for t, data in clean.chunks("imu"):
        got = max(ta for off, ta in arrivals if off <= offset)
        if 0.1e9 <= t < 0.2e9:
            delays.append(got - t)
        offset += len(data)
    assert min(delays) >= 2_500_000 and max(delays) <= 22_500_000 + 2_500_000
    assert len(set(delays)) > 3  # jitter, not one fixed delay


async def test_baud_mismatch_reclocks_the_bit_stream(frig: Rig) -> None:
    raw = [window({"kind": "wire.baud_mismatch", "port": "imu", "rate_error": 0.06})]
    b, clean = await twins(frig, raw, 0.3)
    for (_, got), (_, want) in zip(b.chunks("imu", 0.1, 0.2), clean.chunks("imu", 0.1, 0.2), strict=True):
        assert got == receive_at_wrong_baud(want, round(921_600 * 1.06), 921_600) and got != want
    frames, _ = xbus_frames(b.received("imu", 0.1, 0.2))
    assert not [f for f in frames if f.mid == 0x36]  # (zeros from framing errors can pass as a frame)
    start = b.fault_events(" start")[0][2]["changed"]
    assert (start["host_baud_bps"], start["device_baud_bps"]) == (921_600, 976_896)
    assert b.received("imu", 0.2) == clean.received("imu", 0.2)


async def test_baud_mismatch_garbles_what_the_host_sends(frig: Rig) -> None:
    raw = [window({"kind": "wire.baud_mismatch", "port": "imu", "direction": "both", "device_baud_bps": 115_200})]
    b, clean = Bench(frig, load_faults(raw, frig, source="t")), Bench(frig)
    for bench in (b, clean):
        bench.ports["imu"].client.open(921_600)
        await bench.run_to(0.15)
    await b.write("imu", GOTO_CONFIG)
    await b.tick()
    assert b.devices.imu.measuring and b.devices.imu.counters["commands"] == 0  # arrived as garbage
    (_, got), (_, want) = b.chunks("imu", 0.14, 0.1425)[0], clean.chunks("imu", 0.14, 0.1425)[0]
    # an 8x slower transmitter: each of its bits spans 8 host bit times
    assert got == receive_at_wrong_baud(want, 115_200, 921_600) and len(got) > len(want)


async def test_baud_mismatch_uses_the_rate_the_host_opened_the_port_with(rig: Rig) -> None:
    raw = [window({"kind": "wire.baud_mismatch", "port": "rc", "rate_error": -0.1})]
    b, clean = Bench(rig, load_faults(raw, rig, source="t")), Bench(rig)
    for bench in (b, clean):
        bench.ports["rc"].client.open(57_600)
        await bench.run_to(0.2)
    start = b.fault_events(" start")[0][2]["changed"]
    assert (start["host_baud_bps"], start["device_baud_bps"]) == (57_600, 103_680)
    for (_, got), (_, want) in zip(b.chunks("rc", 0.1, 0.2), clean.chunks("rc", 0.1, 0.2), strict=True):
        assert got == receive_at_wrong_baud(want, 103_680, 57_600)


async def test_same_seed_same_corruption_other_seed_other(frig: Rig) -> None:
    raw = [
        {"kind": "wire.bit_flips", "port": "imu", "t_s": 0.0, "bit_error_rate": 0.02},
        {"kind": "wire.byte_loss", "port": "imu", "t_s": 0.05, "loss_probability": 0.1},
        {"kind": "wire.delay", "port": "imu", "t_s": 0.0, "delay_s": 0.0, "jitter_s": 0.01},
    ]
    one, two = await twins(frig, raw, 0.2, seed=7)
    again, _ = await twins(frig, raw, 0.2, seed=7)
    other, _ = await twins(frig, raw, 0.2, seed=8)
    assert one.chunks("imu") == again.chunks("imu")
    assert one.received("imu") != other.received("imu")
    assert one.received("imu") != two.received("imu")
