"""Maestro Set Multiple Targets and the XBee API link: golden bytes, garbage, non-blocking writes."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.drivers import maestro, xbee
from flightcode.drivers.maestro import EscParams, MaestroEsc
from flightcode.drivers.xbee import XbeeApiParser, XbeeTelemetryLink
from tests.unit.flightcode.fakes import FakeMaestro, FakeSerial


def test_maestro_golden_set_multiple_targets() -> None:
    # Maestro User's Guide 5.e (docs/protocols.md 6.2): ch3 = 0, ch4 = 6000 -> 9F 02 03 00 00 70 2E
    assert maestro.set_multiple_targets(3, [0, 6000]) == bytes.fromhex("9F 02 03 00 00 70 2E")
    assert maestro.quarter_us(1500.0) == 6000


def test_four_motors_in_one_write() -> None:
    port = FakeSerial("esc")
    fake = FakeMaestro(port)
    esc = MaestroEsc(port, EscParams())
    esc.write_pulses_us((1000.0, 1500.0, 1724.25, 2000.0))
    assert port.written == [bytes.fromhex("9F 04 00 20 1F 70 2E 71 35 40 3E")]
    assert fake.pulses_us == [1000.0, 1500.0, 1724.25, 2000.0]


def test_pulses_are_clamped_and_throttle_maps_linearly() -> None:
    port = FakeSerial("esc")
    esc = MaestroEsc(port, EscParams(first_channel=2))
    esc.write_pulses_us((500.0, 2500.0, 1200.0, 1800.0))
    # channels 2..5; clamped to 1000 and 2000 us
    assert port.written == [maestro.set_multiple_targets(2, [4000, 8000, 4800, 7200])]
    assert esc.pulses_from_throttle((0.0, 0.5, 0.724, 1.2)) == pytest.approx((1000.0, 1500.0, 1724.0, 2000.0))
    esc.write_minimum()
    assert esc.last_pulses_us == (1000.0,) * 4


def test_short_write_is_counted_not_raised() -> None:
    port = FakeSerial("esc")
    port.accept_limit = 5
    esc = MaestroEsc(port, EscParams())
    esc.write_pulses_us((1500.0,) * 4)
    assert esc.counters["short_writes"] == 1


# -- XBee -------------------------------------------------------------------------------------------
# docs/protocols.md 8.2 worked frames (escape example and TX status checksum match Digi's printed ones).
GOLDEN_API = [
    ("08 01 41 50", "7E 00 04 08 01 41 50 65"),
    ("88 01 41 50 00 01", "7E 00 06 88 01 41 50 00 01 E4"),
    ("01 01 00 00 00 68 65 6C 6C 6F", "7E 00 0A 01 01 00 00 00 68 65 6C 6C 6F E9"),
    ("89 01 00", "7E 00 03 89 01 00 75"),
    ("81 00 01 28 00 68 65 6C 6C 6F", "7E 00 0A 81 00 01 28 00 68 65 6C 6C 6F 41"),
    ("8A 00", "7E 00 02 8A 00 75"),
]


@pytest.mark.parametrize(("data", "wire"), GOLDEN_API)
def test_api_frames(data: str, wire: str) -> None:
    assert xbee.api_frame(bytes.fromhex(data), escaped=False) == bytes.fromhex(wire)


def test_tx16_hello_and_escape_example() -> None:
    assert xbee.tx16(1, 0x0000, b"hello") == bytes.fromhex("01 01 00 00 00 68 65 6C 6C 6F")
    assert xbee.api_frame(bytes.fromhex("23 11"), escaped=True) == bytes.fromhex("7E 00 02 23 7D 31 CB")
    with pytest.raises(ValueError):
        xbee.tx16(1, 0, bytes(101))


@pytest.mark.parametrize("escaped", [False, True])
def test_parser_whole_bytewise_garbage(escaped: bool) -> None:
    datas = [bytes.fromhex(d) for d, _ in GOLDEN_API] + [bytes.fromhex("81 7E 7D 11 13 00 7E")]
    stream = b"".join(b"\x00\x55" + xbee.api_frame(d, escaped) for d in datas)
    assert XbeeApiParser(escaped).feed(stream) == datas
    parser = XbeeApiParser(escaped)
    got = []
    for b in stream:
        got += parser.feed(bytes((b,)))
    assert got == datas and parser.counters["garbage_bytes"] == 2 * len(datas)


def test_parser_drops_bad_checksum_and_finds_the_next_frame() -> None:
    bad = bytearray(xbee.api_frame(bytes.fromhex("89 01 00"), False))
    bad[-1] ^= 1
    parser = XbeeApiParser(False)
    assert parser.feed(bytes(bad) + xbee.api_frame(bytes.fromhex("8A 00"), False)) == [bytes.fromhex("8A 00")]
    assert parser.counters["checksum_errors"] == 1


def test_escaped_parser_recovers_from_a_truncated_frame() -> None:
    parser = XbeeApiParser(True)
    full = xbee.api_frame(bytes.fromhex("89 05 00"), True)
    assert parser.feed(full[:4] + full) == [bytes.fromhex("89 05 00")]
    assert parser.counters["truncated_frames"] == 1


@settings(max_examples=60, deadline=None)
@given(datas=st.lists(st.binary(min_size=1, max_size=110), min_size=1, max_size=4), escaped=st.booleans(),
       cuts=st.lists(st.integers(1, 40), max_size=10))
def test_parser_round_trip(datas: list[bytes], escaped: bool, cuts: list[int]) -> None:
    stream = b"".join(xbee.api_frame(d, escaped) for d in datas)
    parser = XbeeApiParser(escaped)
    got, pos = [], 0
    for cut in cuts:
        got += parser.feed(stream[pos : pos + cut])
        pos += cut
    got += parser.feed(stream[pos:])
    assert got == datas


def _link(request_status: bool = False) -> tuple[XbeeTelemetryLink, FakeSerial]:
    port = FakeSerial("telemetry")
    return XbeeTelemetryLink(port, escaped=False, dest16=0x0001, request_status=request_status,
                             max_out_waiting=100), port


def test_link_sends_tx16_to_the_ground() -> None:
    link, port = _link()
    assert link.send(b"abc")
    assert port.written == [xbee.api_frame(bytes.fromhex("01 00 00 01 00") + b"abc", False)]


def test_link_drops_instead_of_blocking() -> None:
    link, port = _link()
    port.out_waiting = 101
    assert not link.send(b"abc")
    assert port.written == [] and link.counters["dropped_busy"] == 1


def test_link_frame_ids_and_tx_status() -> None:
    link, port = _link(request_status=True)
    link.send(b"a")
    link.send(b"b")
    assert [w[4] for w in port.written] == [1, 2]
    port.feed(xbee.api_frame(bytes.fromhex("89 01 00"), False) + xbee.api_frame(bytes.fromhex("89 02 01"), False)
              + b"\x13junk" + xbee.api_frame(bytes.fromhex("8A 00"), False))
    link.drain()
    assert link.counters["tx_ok"] == 1 and link.counters["tx_status_1"] == 1 and link.counters["rx_frame_8a"] == 1
