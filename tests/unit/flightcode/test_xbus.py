"""Xbus framing and MTData decoding: golden frames from the documentation, fed whole, byte by byte and with garbage."""

from __future__ import annotations

import struct
from collections import Counter

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.drivers import mtdata, xbus
from flightcode.drivers.xbus import Mid, XbusMessage, XbusParser

# docs/protocols.md 1.2 worked frames (ReqDID identical to MT0100P; ReqBaudrate matches MT0605P;
# SetStringOutputType matches the MT Manager capture).
GOLDEN_FRAMES = [
    (0x00, b"", "FA FF 00 00 01"),
    (0x01, bytes.fromhex("00500123"), "FA FF 01 04 00 50 01 23 88"),
    (0x30, b"", "FA FF 30 00 D1"),
    (0x31, b"", "FA FF 31 00 D0"),
    (0x10, b"", "FA FF 10 00 F1"),
    (0x11, b"", "FA FF 11 00 F0"),
    (0x18, b"", "FA FF 18 00 E9"),
    (0x12, b"", "FA FF 12 00 EF"),
    (0x1C, b"", "FA FF 1C 00 E5"),
    (0x04, bytes.fromhex("0480"), "FA FF 04 02 04 80 77"),
    (0xD0, bytes.fromhex("0004"), "FA FF D0 02 00 04 2B"),
    (0xD2, bytes.fromhex("00000005"), "FA FF D2 04 00 00 00 05 26"),
    (0x8E, bytes.fromhex("0000"), "FA FF 8E 02 00 00 71"),
    (0x42, b"\x04", "FA FF 42 01 04 BA"),
]
# docs/protocols.md 1.9: MTData2, packet counter 7, identity quaternion, status word 3.
GOLDEN_MTDATA2 = bytes.fromhex(
    "FA FF 36 1F 10 20 02 00 07 20 10 10 3F 80 00 00 00 00 00 00 00 00 00 00 00 00 00 00 E0 20 04 00 00 00 03 6D")
# docs/protocols.md 1.8: legacy MTData, Euler 1.5, -2.25, 90 deg, counter 0x1234 (mode 4, settings 5).
GOLDEN_LEGACY = bytes.fromhex("FA FF 32 0E 3F C0 00 00 C0 10 00 00 42 B4 00 00 12 34 B6")
# Scottapotamas/xsens-mti docs/mtmanager_packets.md, packet example 3 (a real MTi-300 via MT Manager;
# https://github.com/Scottapotamas/xsens-mti).
MTI300_EXAMPLE3 = bytes.fromhex(
    "10 20 02 8D 90 10 60 04 00 54 DB F1 20 10 10 3F 7F 89 11 BC 11 1D FA 3B A0 CE F0 BD 73 25 73 40 20 0C BD DC F9"
    " D0 BE 3C 86 19 41 1D 0B 47 40 10 0C B9 8D B0 00 B9 F1 48 00 3C C9 04 30 40 30 0C BC B9 89 2E BB 09 8C 00 3C A7"
    " 08 00 80 20 0C BA 63 BC 01 BC 04 D6 3F BB 6D E3 FE 80 30 10 3F 80 00 01 B5 91 C0 00 B7 2A 08 00 B6 98 40 00 E0"
    " 20 04 00 40 00 03")


@pytest.mark.parametrize(("mid", "payload", "wire"), GOLDEN_FRAMES)
def test_encode_matches_documented_frames(mid: int, payload: bytes, wire: str) -> None:
    assert xbus.encode_frame(mid, payload) == bytes.fromhex(wire)


def test_set_output_configuration_of_the_flight_code() -> None:
    # docs/protocols.md 1.9 example with float32/ENU XDIs; the flight code sets the NED bit (0x4)
    # on EulerAngles, RateOfTurn and Acceleration: 0x2034, 0x8024, 0x4024.
    payload = mtdata.encode_output_configuration(mtdata.mk4_output_configuration(400))
    assert payload == bytes.fromhex("10 20 FF FF 10 60 FF FF 20 34 01 90 80 24 01 90 40 24 01 90 E0 20 FF FF")
    frame = xbus.encode_frame(Mid.SET_OUTPUT_CONFIGURATION, payload)
    assert frame[:4] == bytes.fromhex("FA FF C0 18") and sum(frame[1:]) & 0xFF == 0


def test_legacy_period_for_400_hz() -> None:
    assert mtdata.legacy_period(400) == 288
    assert mtdata.legacy_period(100) == 1152


def _stream() -> bytes:
    return b"".join(bytes.fromhex(w) for _, _, w in GOLDEN_FRAMES) + GOLDEN_MTDATA2 + GOLDEN_LEGACY


def _expected() -> list[XbusMessage]:
    out = [XbusMessage(mid, payload) for mid, payload, _ in GOLDEN_FRAMES]
    out.append(XbusMessage(0x36, GOLDEN_MTDATA2[4:-1]))
    out.append(XbusMessage(0x32, GOLDEN_LEGACY[4:-1]))
    return out


def test_parser_whole_stream() -> None:
    parser = XbusParser()
    assert parser.feed(_stream()) == _expected()
    assert parser.counters["garbage_bytes"] == 0 and parser.counters["checksum_errors"] == 0


def test_parser_byte_by_byte() -> None:
    parser = XbusParser()
    got = []
    for b in _stream():
        got += parser.feed(bytes((b,)))
    assert got == _expected()


def test_parser_with_garbage_between_frames() -> None:
    parser = XbusParser()
    junk = [b"\x00\x13", b"\xfa", b"\xfa\xfa\xff", b"hello", b"\xff\xfa\x00"]
    stream = b""
    for i, (_, _, wire) in enumerate(GOLDEN_FRAMES):
        stream += junk[i % len(junk)] + bytes.fromhex(wire)
    got = parser.feed(stream + b"\xfa")
    assert got == [XbusMessage(m, p) for m, p, _ in GOLDEN_FRAMES]
    assert parser.counters["garbage_bytes"] > 0


def test_bad_checksum_is_dropped_and_the_next_frame_found() -> None:
    parser = XbusParser()
    bad = bytearray(GOLDEN_MTDATA2)
    bad[10] ^= 0x01
    got = parser.feed(bytes(bad) + GOLDEN_LEGACY)
    assert got == [XbusMessage(0x32, GOLDEN_LEGACY[4:-1])]
    assert parser.counters["checksum_errors"] == 1


def test_extended_length_round_trip() -> None:
    payload = bytes(range(256)) * 2  # 512 bytes
    frame = xbus.encode_frame(0x36, payload)
    assert frame[:6] == bytes.fromhex("FA FF 36 FF 02 00")  # docs/protocols.md 1.2 extended header
    assert sum(frame[1:]) & 0xFF == 0
    parser = XbusParser()
    assert parser.feed(frame[:100]) == []
    assert parser.feed(frame[100:]) == [XbusMessage(0x36, payload)]


def test_length_above_the_limit_is_rejected_without_stalling() -> None:
    parser = XbusParser(max_payload=64)
    # a corrupted header claiming 200 bytes, then a real frame
    got = parser.feed(b"\xfa\xff\x36\xc8" + bytes.fromhex("FA FF 31 00 D0"))
    assert got == [XbusMessage(0x31, b"")]
    assert parser.counters["bad_length"] == 1


def holds_no_frame(payload: bytes) -> bool:
    """True if no complete, checksum-valid frame sits inside ``payload``."""
    parser = XbusParser()
    return parser.feed(payload) == []


@settings(max_examples=60, deadline=None)
@given(
    # A payload that itself holds a valid frame is ambiguous when cut before its end (see
    # test_a_frame_inside_a_payload_cut_short_is_the_documented_ambiguity).
    frames=st.lists(st.tuples(st.integers(0, 255), st.binary(max_size=300).filter(holds_no_frame)),
                    min_size=1, max_size=5),
    cuts=st.lists(st.integers(1, 50), max_size=20),
    junk=st.binary(max_size=8).filter(lambda b: b"\xfa" not in b),
)
def test_round_trip_any_fragmentation(frames: list[tuple[int, bytes]], cuts: list[int], junk: bytes) -> None:
    stream = junk + b"".join(xbus.encode_frame(mid, payload) for mid, payload in frames)
    parser = XbusParser()
    got: list[XbusMessage] = []
    pos = 0
    for cut in cuts:
        got += parser.feed(stream[pos : pos + cut])
        pos += cut
    got += parser.feed(stream[pos:])
    assert got == [XbusMessage(mid, payload) for mid, payload in frames]


def test_decode_golden_mtdata2_lacks_euler_so_is_incomplete() -> None:
    counters: Counter[str] = Counter()
    assert mtdata.mtdata2_packets(GOLDEN_MTDATA2[4:-1]) == [
        (0x1020, b"\x00\x07"), (0x2010, bytes.fromhex("3F800000" + "00" * 12)), (0xE020, b"\x00\x00\x00\x03")]
    assert mtdata.decode_mtdata2(GOLDEN_MTDATA2[4:-1], counters) is None
    assert counters["mtdata2_incomplete"] == 1


def test_real_mti300_packet_items() -> None:
    packets = dict(mtdata.mtdata2_packets(MTI300_EXAMPLE3) or [])
    assert struct.unpack(">H", packets[0x1020])[0] == 36240
    assert struct.unpack(">I", packets[0x1060])[0] == 5561329
    acc = struct.unpack(">3f", packets[0x4020])
    assert acc == pytest.approx((-0.10789835, -0.18410529, 9.81525326), abs=1e-7)
    gyr = struct.unpack(">3f", packets[0x8020])
    assert gyr == pytest.approx((-0.00086874, -0.00810772, -0.00362992), abs=1e-8)
    assert struct.unpack(">I", packets[0xE020])[0] == 0x00400003


def _mtdata2(euler: tuple[float, float, float], precision: int = 0) -> bytes:
    fmt = {0: ">3f", 3: ">3d"}[precision]
    size = struct.calcsize(fmt)
    return (struct.pack(">HBH", 0x1020, 2, 513) + struct.pack(">HBI", 0x1060, 4, 123456)
            + struct.pack(">HB", 0x2034 | precision, size) + struct.pack(fmt, *euler)
            + struct.pack(">HB3f", 0x8024, 12, 0.1, -0.2, 0.3) + struct.pack(">HB3f", 0x4024, 12, 0.5, 0.25, -9.75)
            + struct.pack(">HBI", 0xE020, 4, 0x00400003))


def test_decode_full_sample() -> None:
    data = mtdata.decode_mtdata2(_mtdata2((1.5, -2.25, 90.0)), Counter())
    assert data == mtdata.XsensData(513, 123456, (1.5, -2.25, 90.0), pytest.approx((0.1, -0.2, 0.3)),
                                  (0.5, 0.25, -9.75), 0x00400003)
    # the flight code's own layout takes the one-unpack path, with the same result
    assert mtdata._decode_mk4_fast(_mtdata2((1.5, -2.25, 90.0))) == data
    assert mtdata._decode_mk4_fast(_mtdata2((1.5, -2.25, 90.0), precision=3)) is None  # float64: general path
    assert _general(_mtdata2((1.5, -2.25, 90.0))) == data


def test_decode_float64_and_fixed_point() -> None:
    data = mtdata.decode_mtdata2(_mtdata2((1.5, -2.25, 90.0), precision=3), Counter())
    assert data is not None and data.euler_deg == (1.5, -2.25, 90.0)
    # fp12.20: 1.5 -> 0x00180000 ; fp16.32: -2.25 -> frac 0xC0000000, int -3
    fp1220 = struct.pack(">3i", 0x00180000, -0x00240000, 90 << 20)
    assert mtdata._vec3(fp1220, mtdata.XdiPrecision.FP1220) == (1.5, -2.25, 90.0)
    fp1632 = struct.pack(">Ih", 0xC0000000, -3) * 3
    assert mtdata._vec3(fp1632, mtdata.XdiPrecision.FP1632) == (-2.25, -2.25, -2.25)


def test_truncated_mtdata2_is_counted() -> None:
    counters: Counter[str] = Counter()
    assert mtdata.decode_mtdata2(_mtdata2((0.0, 0.0, 0.0))[:-2], counters) is None
    assert counters["mtdata2_truncated"] == 1


def test_decode_golden_legacy_layout() -> None:
    # The documented example uses mode 0x0004 / settings 0x00000005 (orientation only): the
    # flight code needs calibrated data too, so it reports the layout as unsupported...
    counters: Counter[str] = Counter()
    assert mtdata.legacy_mtdata_length(0x0004, 0x00000005) == 14
    assert mtdata.decode_mtdata_legacy(GOLDEN_LEGACY[4:-1], 0x0004, 0x00000005, counters) is None
    assert counters["mtdata_unsupported_layout"] == 1
    # ...and decodes its own layout: acc, gyr, mag, Euler, counter (calibrated + orientation).
    payload = struct.pack(">3f3f3f", 0.5, 0.25, -9.75, 0.1, -0.2, 0.3, 1, 2, 3) + GOLDEN_LEGACY[4:-1]
    mode, settings = int(mtdata.LEGACY_OUTPUT_MODE), int(mtdata.LEGACY_OUTPUT_SETTINGS)
    assert (mode, settings) == (0x0006, 0x80000005)
    data = mtdata.decode_mtdata_legacy(payload, mode, settings, Counter())
    assert data is not None
    assert data.counter == 0x1234 and data.sample_time_fine is None
    assert data.euler_deg == (1.5, -2.25, 90.0)
    assert data.acceleration_mps2 == (0.5, 0.25, -9.75)
    assert data.rate_of_turn_radps == pytest.approx((0.1, -0.2, 0.3))


def test_legacy_wrong_length_is_counted() -> None:
    counters: Counter[str] = Counter()
    assert mtdata.decode_mtdata_legacy(b"\x00" * 49, 0x0006, 0x80000005, counters) is None
    assert counters["mtdata_bad_length"] == 1


@settings(max_examples=60, deadline=None)
@given(counter=st.integers(0, 0xFFFF), stf=st.integers(0, 0xFFFFFFFF), status=st.integers(0, 0xFFFFFFFF),
       vals=st.lists(st.floats(width=32), min_size=9, max_size=9),
       order=st.permutations(range(6)), flip=st.integers(0, 64))
def test_fast_path_equals_the_general_decoder(counter: int, stf: int, status: int, vals: list[float],
                                              order: list[int], flip: int) -> None:
    """The one-unpack path for the flight code's own layout gives exactly what the packet walk
    gives (including None for NaN/inf), and any other order or a damaged header falls back."""
    items = [struct.pack(">HBH", 0x1020, 2, counter), struct.pack(">HBI", 0x1060, 4, stf),
             struct.pack(">HB3f", 0x2034, 12, *vals[0:3]), struct.pack(">HB3f", 0x8024, 12, *vals[3:6]),
             struct.pack(">HB3f", 0x4024, 12, *vals[6:9]), struct.pack(">HBI", 0xE020, 4, status)]
    payload = b"".join(items[i] for i in order)
    if flip < len(payload):  # damage one byte (a header or a value)
        payload = payload[:flip] + bytes((payload[flip] ^ 0x10,)) + payload[flip + 1 :]
    assert mtdata.decode_mtdata2(payload, Counter()) == _general(payload)


def _general(payload: bytes) -> mtdata.XsensData | None:
    """The packet walk of decode_mtdata2, independent of the fast path."""
    packets = mtdata.mtdata2_packets(payload)
    if packets is None:
        return None
    found: dict[int, object] = {}
    status = 0
    for xdi, data in packets:
        kind, precision = xdi & 0xFFF0, xdi & 0x3
        if kind == 0x1020 and len(data) == 2:
            found["c"] = struct.unpack(">H", data)[0]
        elif kind == 0x1060 and len(data) == 4:
            found["t"] = struct.unpack(">I", data)[0]
        elif kind in (0x2030, 0x8020, 0x4020):
            found[hex(kind)] = mtdata._vec3(data, precision)
        elif kind == 0xE020 and len(data) == 4:
            status = struct.unpack(">I", data)[0]
    need = ("c", "t", "0x2030", "0x8020", "0x4020")
    if any(found.get(k) is None for k in need):
        return None
    return mtdata.XsensData(found["c"], found["t"], found["0x2030"], found["0x8020"], found["0x4020"],  # type: ignore[arg-type]
                            status)



def test_a_frame_inside_a_payload_cut_short_is_the_documented_ambiguity() -> None:
    """Hypothesis found it: a payload that is itself a valid frame (FA FF 36 00 CB). Whole,
    the outer frame is read. Cut before the outer checksum, the parser cannot tell it from a
    stray header with a real frame behind it, and takes the inner frame: the price of
    recovering at once from a stray ``FA FF`` (XbusParser.feed). Chance on MTi data: about
    4e-7 per frame, and only when a read ends inside such a frame."""
    inner = bytes.fromhex("FA FF 36 00 CB")
    outer = xbus.encode_frame(0x00, inner)
    assert XbusParser().feed(outer) == [XbusMessage(0x00, inner)]
    parser = XbusParser()
    assert parser.feed(outer[:-1]) == [XbusMessage(0x36, b"")]
    assert parser.counters["garbage_bytes"] == 4


def test_a_stray_header_does_not_hold_back_the_frames_behind_it() -> None:
    parser = XbusParser()
    frame = xbus.encode_frame(0x36, bytes(20))
    assert parser.feed(b"\xfa\xff\x36\x3c" + frame) == [XbusMessage(0x36, bytes(20))]
