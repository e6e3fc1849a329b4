"""XBee module: AT parameters over API, TX/RX frames through a link, transparent and command mode."""

from __future__ import annotations

import numpy as np
import pytest

from emulators.xbee import (
    ApiParser,
    AtStatus,
    FrameType,
    LinkParams,
    RadioLink,
    TxOption,
    XBeeModule,
    XBeeParams,
    at_command,
    encode_frame,
    tx16,
    tx64,
)

MS = 1_000_000
S = 1_000_000_000
VEHICLE = XBeeParams()
GROUND = XBeeParams(my=0x0000, dl=0x0001, sl=0x40A1B202, ni="GROUND", ce=1)


def pair(vp: XBeeParams = VEHICLE, gp: XBeeParams = GROUND, lp: LinkParams | None = None,
         ) -> tuple[XBeeModule, XBeeModule, RadioLink]:
    v = XBeeModule(vp, np.random.default_rng(1), "telemetry")
    g = XBeeModule(gp, np.random.default_rng(2), "ground")
    link = RadioLink(lp or LinkParams(), np.random.default_rng(3))
    link.attach(v)
    link.attach(g)
    return v, g, link


def frames_of(m: XBeeModule) -> list[bytes]:
    return ApiParser(escaped=m.ap == 2).feed(m.take_output())


def at(m: XBeeModule, cmd: str, param: bytes = b"", fid: int = 1, queue: bool = False) -> tuple[int, bytes]:
    m.receive(encode_frame(at_command(fid, cmd, param, queue=queue), escaped=m.ap == 2), 0)
    m.advance(10 * MS)  # the module takes at_response_delay_us to answer
    (resp,) = frames_of(m)
    assert resp[0] == FrameType.AT_RESPONSE and resp[1] == fid and resp[2:4] == cmd.encode()
    return resp[4], resp[5:]


def test_startup_parameters_digi_xbee_reads() -> None:
    v = XBeeModule(VEHICLE, np.random.default_rng(0))
    # digi-xbee 1.5.0 XBeeDevice.open(): AP, then HV VR SH SL NI MY CE as AT queue (0x09) frames.
    want = {"AP": b"\x01", "HV": b"\x18\x42", "VR": b"\x10\xef", "SH": b"\x00\x13\xa2\x00",
            "SL": b"\x40\xa1\xb2\x01", "NI": b"VEHICLE", "MY": b"\x00\x01", "CE": b"\x00",
            "BD": b"\x00\x00\x00\x07", "CH": b"\x0c", "ID": b"\x33\x32", "NP": b"\x00\x64"}
    for i, (cmd, value) in enumerate(want.items(), start=1):
        assert at(v, cmd, fid=i, queue=True) == (AtStatus.OK, value)


def test_set_queue_apply_and_errors() -> None:
    v = XBeeModule(VEHICLE, np.random.default_rng(0))
    assert at(v, "MY", b"\x00\x05", queue=True) == (AtStatus.OK, b"")
    assert at(v, "MY") == (AtStatus.OK, b"\x00\x01")  # queued, not applied
    assert at(v, "AC") == (AtStatus.OK, b"")
    assert at(v, "MY") == (AtStatus.OK, b"\x00\x05")
    assert at(v, "CH", b"\x30") == (AtStatus.INVALID_PARAMETER, b"")
    assert at(v, "SH", b"\x01") == (AtStatus.INVALID_PARAMETER, b"")
    assert at(v, "ZZ") == (AtStatus.INVALID_COMMAND, b"")
    assert at(v, "NI", b"QUAD") == (AtStatus.OK, b"")
    assert at(v, "NI") == (AtStatus.OK, b"QUAD")


def test_frame_id_zero_gets_no_response() -> None:
    v = XBeeModule(VEHICLE, np.random.default_rng(0))
    v.receive(encode_frame(at_command(0, "AP")), 0)
    v.advance(10 * MS)
    assert v.take_output() == b""


def test_at_response_takes_the_configured_time() -> None:
    v = XBeeModule(XBeeParams(at_response_delay_us=2_000), np.random.default_rng(0))
    v.receive(encode_frame(at_command(1, "AP")), 5 * MS)
    v.advance(5 * MS + 1_999_999)
    assert v.take_output() == b""
    v.advance(7 * MS)
    assert v.take_output() == bytes.fromhex("7E 00 06 88 01 41 50 00 01 E4")
    now = XBeeModule(XBeeParams(at_response_delay_us=0), np.random.default_rng(0))
    now.receive(encode_frame(at_command(1, "AP")), 0)
    assert now.take_output() == bytes.fromhex("7E 00 06 88 01 41 50 00 01 E4")


def test_tx16_reaches_ground_as_rx16_with_status() -> None:
    v, g, link = pair()
    v.receive(encode_frame(tx16(0x42, 0x0000, b"telemetry!")), 10 * MS)
    link.advance(10 * MS)
    assert v.take_output() == b"" and g.take_output() == b""  # still in the air
    link.advance(20 * MS)
    (rx,) = frames_of(g)
    assert rx == bytes([0x81, 0x00, 0x01, 40, 0x00]) + b"telemetry!"
    assert frames_of(v) == [bytes([0x89, 0x42, 0x00])]
    assert at(g, "DB") == (AtStatus.OK, bytes([40]))


def test_tx64_and_rx64_when_no_16bit_address() -> None:
    v, g, link = pair(vp=XBeeParams(my=0xFFFE))
    v.receive(encode_frame(tx64(3, g.address64, b"x")), 0)
    link.advance(10 * MS)
    (rx,) = frames_of(g)
    assert rx[0] == FrameType.RX_64 and int.from_bytes(rx[1:9], "big") == v.address64 and rx[11:] == b"x"
    assert frames_of(v) == [bytes([0x89, 3, 0])]


def test_unicast_to_nobody_reports_no_ack() -> None:
    v, g, link = pair()
    v.receive(encode_frame(tx16(9, 0x0777, b"?")), 0)
    link.advance(100 * MS)
    assert frames_of(v) == [bytes([0x89, 9, 1])] and g.take_output() == b""


def test_broadcast_option_bits() -> None:
    v, g, link = pair()
    v.receive(encode_frame(tx16(1, 0xFFFF, b"all", options=TxOption.BROADCAST_PAN)), 0)
    link.advance(10 * MS)
    (rx,) = frames_of(g)
    assert rx[4] == 0x02 | 0x04 and rx[5:] == b"all"


def test_oversize_payload_not_sent() -> None:
    v, g, link = pair()
    v.receive(encode_frame(tx16(1, 0, bytes(101))), 0)
    link.advance(100 * MS)
    assert g.take_output() == b"" and v.counters["tx_oversize"] == 1


def test_escaped_api_mode() -> None:
    v, g, link = pair(gp=XBeeParams(ap=2, my=0, dl=1))
    v.receive(encode_frame(tx16(1, 0, b"\x7e\x11")), 0)
    link.advance(10 * MS)
    raw = g.take_output()
    assert raw.count(0x7E) == 1 and b"\x7d\x5e\x7d\x31" in raw
    assert ApiParser(escaped=True).feed(raw)[0][5:] == b"\x7e\x11"


def test_reset_announces_in_api_mode() -> None:
    v = XBeeModule(VEHICLE, np.random.default_rng(0))
    v.reset(0)
    assert v.take_output() == bytes.fromhex("7E 00 02 8A 00 75")
    t = XBeeModule(XBeeParams(ap=0), np.random.default_rng(0))
    t.reset(0)
    assert t.take_output() == b""


def test_baud_mismatch_is_not_understood() -> None:
    v = XBeeModule(VEHICLE, np.random.default_rng(0))
    v.line_settings_changed(9600, 0)
    v.receive(encode_frame(at_command(1, "AP")), 0)
    assert v.take_output() == b"" and v.counters["rx_bad_baud_bytes"] == 8
    v.line_settings_changed(115200, 0)
    assert at(v, "AP") == (AtStatus.OK, b"\x01")


# -- transparent mode --------------------------------------------------------------------------
def transparent_pair(bd: int = 7, ro: int = 3) -> tuple[XBeeModule, XBeeModule, RadioLink]:
    return pair(vp=XBeeParams(ap=0, bd=bd, ro=ro), gp=XBeeParams(ap=0, my=0, dl=1, bd=bd))


def test_transparent_packetises_after_ro_silence() -> None:
    v, g, link = transparent_pair(bd=3)  # 9600 baud: 1 char = 1.0417 ms, RO=3 -> 3.125 ms
    v.receive(b"hello ", 0)
    v.receive(b"world", 1 * MS)
    for t in (3 * MS, 4 * MS):
        v.advance(t)
        link.advance(t)
    assert v.counters["rf_packets_out"] == 0  # 3.0 ms of silence < 3.125 ms
    v.advance(5 * MS)
    link.advance(20 * MS)
    assert g.take_output() == b"hello world" and v.counters["rf_packets_out"] == 1


def test_transparent_splits_at_100_bytes() -> None:
    v, g, link = transparent_pair()
    v.receive(bytes(range(250)), 0)
    assert v.counters["rf_packets_out"] == 2
    v.advance(1 * MS)
    link.advance(50 * MS)
    assert v.counters["rf_packets_out"] == 3 and g.take_output() == bytes(range(250))


def enter_command_mode(m: XBeeModule, t0: int) -> int:
    """Guard time, +++, guard time; returns the time command mode was entered."""
    m.advance(t0)
    m.receive(b"+++", t0)
    t = t0 + 1000 * MS
    m.advance(t)
    return t


def test_command_mode_enter_query_set_exit() -> None:
    v, g, link = transparent_pair()
    t = enter_command_mode(v, 2 * S)
    assert v.take_output() == b"OK\r" and v.in_command_mode
    v.receive(b"ATMY\r", t)
    assert v.take_output() == b"1\r"
    v.receive(b"ATSH\r", t)
    assert v.take_output() == b"13A200\r"
    v.receive(b"ATDL 0,RO 5\r", t)
    assert v.take_output() == b"OK\rOK\r"
    v.receive(b"ATXX\r", t)
    assert v.take_output() == b"ERROR\r"
    v.receive(b"ATCN\r", t)
    assert v.take_output() == b"OK\r" and not v.in_command_mode
    assert v.regs.num("RO") == 5
    assert g.take_output() == b"" and v.counters["rf_packets_out"] == 0  # +++ was not sent


def test_plus_without_guard_time_is_data() -> None:
    v, g, link = transparent_pair()
    v.receive(b"a", 1 * S)
    v.advance(1 * S + 100 * MS)  # "a" goes out after RO
    v.receive(b"+++", 1 * S + 500 * MS)  # only 0.4 s of silence before: data
    v.advance(3 * S)
    link.advance(3 * S)
    assert not v.in_command_mode and v.take_output() == b""
    assert g.take_output() == b"a+++" and v.counters["rf_packets_out"] == 2


def test_plus_followed_by_data_is_data() -> None:
    v, g, link = transparent_pair()
    v.advance(2 * S)
    v.receive(b"+++x", 2 * S)
    v.advance(4 * S)
    link.advance(4 * S)
    assert not v.in_command_mode and g.take_output() == b"+++x"


def test_command_mode_times_out() -> None:
    v, _, _ = transparent_pair()
    t = enter_command_mode(v, 2 * S)
    v.take_output()
    v.receive(b"ATRO 7\r", t)
    v.advance(t + 10 * S - 1)
    assert v.in_command_mode
    v.advance(t + 10 * S)  # CT = 0x64 x 100 ms
    assert not v.in_command_mode and v.regs.num("RO") == 7


def test_switch_to_api_mode_from_command_mode() -> None:
    v, g, link = transparent_pair()
    t = enter_command_mode(v, 2 * S)
    v.receive(b"ATAP\r", t)
    assert v.take_output() == b"OK\r0\r"
    v.receive(b"ATAP1,CN\r", t)
    assert v.take_output() == b"OK\rOK\r" and v.ap == 1
    v.receive(encode_frame(at_command(1, "AP")), t)
    v.advance(t + 10 * MS)
    assert frames_of(v) == [bytes([0x88, 1, 0x41, 0x50, 0, 1])]


def test_api_to_transparent_receiver() -> None:
    v, g, link = pair(gp=XBeeParams(ap=0, my=0, dl=1))
    v.receive(encode_frame(tx16(1, 0, b"raw bytes")), 0)
    link.advance(10 * MS)
    assert g.take_output() == b"raw bytes"


@pytest.mark.parametrize("bd,baud", [(0, 1200), (3, 9600), (7, 115200), (250000, 250000)])
def test_bd_codes(bd: int, baud: int) -> None:
    assert XBeeModule(XBeeParams(bd=bd), np.random.default_rng(0)).baud == baud


def test_remote_at_command_round_trip() -> None:
    from emulators.xbee.frames import remote_at_command

    v, g, link = pair()
    # digi-xbee's lookup of a 16-bit-only sender: SH of 0x0001, 64-bit address unknown.
    g.receive(encode_frame(remote_at_command(9, 0xFFFFFFFFFFFFFFFF, 0x0001, "SH", options=0)), 0)
    link.advance(50 * MS)
    (resp,) = frames_of(g)
    assert resp[0] == FrameType.REMOTE_AT_RESPONSE and resp[1] == 9
    assert int.from_bytes(resp[2:10], "big") == v.address64 and resp[10:12] == b"\x00\x01"
    assert resp[12:14] == b"SH" and resp[14] == AtStatus.OK and resp[15:] == b"\x00\x13\xa2\x00"
    assert v.take_output() == b""  # the remote host sees nothing
    # A remote set with "apply" changes the vehicle module.
    g.receive(encode_frame(remote_at_command(10, v.address64, 0xFFFE, "NI", b"QUAD")), 50 * MS)
    link.advance(100 * MS)
    assert frames_of(g)[0][14] == AtStatus.OK and v.regs.get("NI") == "QUAD"


def test_remote_at_to_nobody_reports_failure() -> None:
    from emulators.xbee.frames import remote_at_command

    v, g, link = pair()
    g.receive(encode_frame(remote_at_command(3, 0xFFFFFFFFFFFFFFFF, 0x0BAD, "SH")), 0)
    link.advance(1000 * MS)
    (resp,) = frames_of(g)
    assert resp[0] == FrameType.REMOTE_AT_RESPONSE and resp[14] == AtStatus.REMOTE_FAILED


@pytest.mark.parametrize("ap", [1, 2])
def test_module_byte_by_byte_with_garbage(ap: int) -> None:
    v = XBeeModule(XBeeParams(ap=ap), np.random.default_rng(0))
    frames = [at_command(i, cmd) for i, cmd in enumerate(["AP", "MY", "CH", "NI"], start=1)]
    bad = bytearray(encode_frame(at_command(9, "SH"), escaped=ap == 2))
    bad[-1] ^= 0x55  # bad checksum: dropped silently, like the module
    stream = b"\x00garbage\x11" + bytes(bad) + b"".join(encode_frame(f, escaped=ap == 2) + b"\xff\x00" for f in frames)
    for b in stream:
        v.receive(bytes([b]), 0)
    v.advance(10 * MS)
    resp = ApiParser(escaped=ap == 2).feed(v.take_output())
    assert [r[1] for r in resp] == [1, 2, 3, 4] and all(r[4] == AtStatus.OK for r in resp)
    assert resp[0][5:] == bytes([ap]) and resp[3][5:] == b"VEHICLE"
    assert v.counters["api_bad_checksum"] == 1


def test_software_reset_answers_then_announces() -> None:
    v = XBeeModule(VEHICLE, np.random.default_rng(0))
    v.receive(encode_frame(at_command(1, "MY", b"\x00\x09", queue=True)), 0)
    v.receive(encode_frame(at_command(2, "FR")), 0)
    v.advance(10 * MS)
    assert frames_of(v) == [bytes([0x88, 1, 0x4D, 0x59, 0]), bytes([0x88, 2, 0x46, 0x52, 0]), bytes([0x8A, 0x01])]
    assert at(v, "MY") == (AtStatus.OK, b"\x00\x01")  # the queued change was lost
