"""Xbus framing and payload codecs against golden vectors (sources in the JSON) and properties."""

from __future__ import annotations

import math
import struct
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from emulators.xsens import legacy
from emulators.xsens.codec import Frame, FrameError, FrameParser, checksum, decode_frame, encode_frame
from emulators.xsens.config_msg import CONFIGURATION_SIZE, Configuration, mk4_trailer
from emulators.xsens.defs import LegacyMode, Precision
from emulators.xsens.mtdata2 import decode_values, encode_values, pack_packets, unpack_packets
from tests.unit.xsens.vectors import frame, hexb, vectors

GOLDEN = vectors()["frames"]
IDS = [f["name"] for f in GOLDEN]


@pytest.mark.parametrize("vec", GOLDEN, ids=IDS)
def test_golden_frame_encodes_to_the_documented_bytes(vec: dict) -> None:
    assert encode_frame(vec["mid"], hexb(vec["payload"])) == hexb(vec["hex"])


@pytest.mark.parametrize("vec", GOLDEN, ids=IDS)
def test_golden_frame_decodes_to_the_documented_fields(vec: dict) -> None:
    assert decode_frame(hexb(vec["hex"])) == Frame(vec["mid"], hexb(vec["payload"]))


def _all_frames() -> tuple[bytes, list[Frame]]:
    stream = b"".join(hexb(v["hex"]) for v in GOLDEN)
    return stream, [Frame(v["mid"], hexb(v["payload"])) for v in GOLDEN]


def test_parser_whole_stream() -> None:
    stream, expected = _all_frames()
    p = FrameParser()
    assert p.feed(stream) == expected
    assert p.stats.frames_ok == len(expected) and p.stats.resync_bytes == 0 and p.pending == 0


def test_parser_byte_by_byte() -> None:
    stream, expected = _all_frames()
    p = FrameParser()
    got = [f for i in range(len(stream)) for f in p.feed(stream[i : i + 1])]
    assert got == expected


def test_parser_with_garbage_between_and_trailing() -> None:
    # Garbage that a resynchronising parser must step over: stray bytes, and complete but
    # corrupted frames (whose own length field is short, so they resolve at once).
    garbage = [b"\x00\x13", b"\xfa\xff\x30\x00\x00", b"hello", b"\xfa\xff\x42\x01\x04\x00", b"\xff\xfe"]
    stream, expected = b"", []
    for i, v in enumerate(GOLDEN):
        stream += garbage[i % len(garbage)] + hexb(v["hex"])
        expected.append(Frame(v["mid"], hexb(v["payload"])))
    stream += b"\xfa\xff\x36"  # trailing partial frame
    p = FrameParser()
    got = [f for i in range(0, len(stream), 7) for f in p.feed(stream[i : i + 7])]
    assert got == expected
    assert p.stats.resync_bytes > 0
    assert p.pending == 3  # the trailing partial frame waits for more bytes


def test_bad_checksum_is_dropped_and_counted_then_resyncs() -> None:
    bad = bytearray(hexb(frame("GoToConfig")["hex"]))
    bad[-1] ^= 0x01
    p = FrameParser()
    assert p.feed(bytes(bad) + hexb(frame("ReqDID")["hex"])) == [Frame(0x00)]
    assert p.stats.checksum_errors == 1


def test_oversized_length_is_garbage_and_the_next_frame_is_found() -> None:
    p = FrameParser(max_payload=64)
    junk = b"\xfa\xff\x30\xff\x10\x00"  # claims a 4096-byte payload
    assert p.feed(junk + hexb(frame("ReqDID")["hex"])) == [Frame(0x00)]
    assert p.stats.oversize_frames == 1


def test_partial_frame_is_discarded_after_the_inter_byte_timeout() -> None:
    p = FrameParser(timeout_ns=10_000_000)
    assert p.feed(b"\xfa\xff\x30", t_ns=0) == []  # truncated GoToConfig: LEN would be the next byte
    assert p.feed(hexb(frame("ReqDID")["hex"]), t_ns=50_000_000) == [Frame(0x00)]
    assert p.stats.timeouts == 1


def test_extended_length_frame_checksum_includes_length_bytes() -> None:
    payload = bytes(range(256)) * 2  # 512 bytes
    raw = encode_frame(0x36, payload)
    assert raw[:6] == b"\xfa\xff\x36\xff\x02\x00"
    assert (sum(raw[1:-1]) + raw[-1]) & 0xFF == 0
    assert raw[-1] == checksum(raw[1:-1])
    assert decode_frame(raw) == Frame(0x36, payload)
    assert FrameParser(max_payload=1024).feed(raw) == [Frame(0x36, payload)]


def test_strict_decode_rejects_defects() -> None:
    good = hexb(frame("Error 0x04")["hex"])
    for bad in (good[:-1], good + b"\x00", b"\x00" + good[1:], good[:-1] + bytes(((good[-1] + 1) & 0xFF,))):
        with pytest.raises(FrameError):
            decode_frame(bad)


@settings(max_examples=100, deadline=None)
@given(mid=st.integers(0, 255), bid=st.integers(0, 255), payload=st.binary(max_size=700))
def test_frame_round_trip_including_extended_length(mid: int, bid: int, payload: bytes) -> None:
    raw = encode_frame(mid, payload, bid)
    assert decode_frame(raw) == Frame(mid, payload, bid)
    assert (raw[3] == 0xFF) == (len(payload) > 254)
    assert FrameParser(max_payload=1024).feed(raw) == [Frame(mid, payload, bid)]


@settings(max_examples=100, deadline=None)
@given(junk=st.binary(max_size=64), mid=st.integers(0, 255), payload=st.binary(max_size=40),
       cut=st.integers(1, 9))
def test_parser_finds_frame_after_arbitrary_garbage(junk: bytes, mid: int, payload: bytes, cut: int) -> None:
    raw = encode_frame(mid, payload)
    # Garbage can announce a long frame itself; the inter-byte gap before the real frame
    # flushes that partial frame, as on the device.
    p = FrameParser(max_payload=254, timeout_ns=1)
    p.feed(junk, t_ns=0)
    got = [f for i in range(0, len(raw), cut) for f in p.feed(raw[i : i + cut], t_ns=10)]
    assert got and got[-1] == Frame(mid, payload)


# -- MTData2 values and packets --------------------------------------------------------------

_NAMES = {0x1020: "PacketCounter", 0x1060: "SampleTimeFine", 0x2010: "Quaternion", 0x4020: "Acceleration",
          0x4010: "DeltaV", 0x4030: "FreeAcceleration", 0x8020: "RateOfTurn", 0x8030: "DeltaQ",
          0xC020: "MagneticField", 0x0810: "Temperature", 0x3010: "BaroPressure", 0xE020: "StatusWord"}


@pytest.mark.parametrize("vec", vectors()["mtdata2_payloads"], ids=lambda v: v["name"])
def test_mti300_payload_decodes_to_the_listed_values_and_reencodes(vec: dict) -> None:
    payload = hexb(vec["payload_hex"])
    packets = unpack_packets(payload)
    assert pack_packets(packets) == payload
    decoded: dict[str, Any] = {}
    for xdi, data in packets:
        name = _NAMES[xdi]
        if name in ("PacketCounter", "SampleTimeFine", "BaroPressure", "StatusWord"):
            decoded[name] = int.from_bytes(data, "big")
        else:
            values = decode_values(data, Precision.FLOAT32)
            assert encode_values(values, Precision.FLOAT32) == data
            decoded[name] = list(values)
    expected = vec["decoded"]
    assert set(decoded) == set(expected)
    for name, want in expected.items():
        if isinstance(want, int):
            assert decoded[name] == want, name
        else:
            assert decoded[name] == pytest.approx(want, rel=1e-6, abs=1e-8), name


def test_fixed_point_formats_match_the_documented_layouts() -> None:
    # 12.20: i32 = v * 2^20; 16.32: u32 fraction then i16 integer (xspublic XsMessage_getDataFP1632).
    assert encode_values([1.5], Precision.FP1220) == struct.pack(">i", 3 << 19)
    assert encode_values([-1.0], Precision.FP1220) == struct.pack(">i", -(1 << 20))
    assert encode_values([1.5], Precision.FP1632) == struct.pack(">Ih", 1 << 31, 1)
    assert encode_values([-0.5], Precision.FP1632) == struct.pack(">Ih", 1 << 31, -1)
    assert encode_values([2.0], Precision.FLOAT64) == struct.pack(">d", 2.0)
    assert encode_values([1e9], Precision.FP1220) == struct.pack(">i", (1 << 31) - 1)  # saturates


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(-2000, 2000, allow_nan=False), min_size=1, max_size=9),
       st.sampled_from(list(Precision)))
def test_value_codec_round_trip(values: list[float], precision: Precision) -> None:
    back = decode_values(encode_values(values, precision), precision)
    tol = {Precision.FLOAT32: 1e-6, Precision.FP1220: 2**-20, Precision.FP1632: 2**-32, Precision.FLOAT64: 0.0}
    for a, b in zip(values, back, strict=True):
        if precision is Precision.FLOAT32:
            assert b == pytest.approx(a, rel=1e-6, abs=1e-30)
        else:
            assert math.isclose(a, b, abs_tol=tol[precision])


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 0xFFFF), st.binary(max_size=255)), max_size=8))
def test_mtdata2_packets_round_trip(packets: list[tuple[int, bytes]]) -> None:
    assert unpack_packets(pack_packets(packets)) == packets


def test_truncated_mtdata2_payload_is_rejected() -> None:
    payload = hexb(vectors()["mtdata2_payloads"][5]["payload_hex"])
    for cut in (1, 2, 4, len(payload) - 1):
        with pytest.raises(ValueError):
            unpack_packets(payload[:cut])


# -- Configuration (118 bytes) and legacy MTData ----------------------------------------------

def test_mti300_configuration_both_ways() -> None:
    c = vectors()["configuration_mti300"]
    payload = hexb(c["payload"])
    assert len(payload) == CONFIGURATION_SIZE == 118
    d = c["decoded"]
    cfg = Configuration.unpack(payload)
    assert (cfg.master_device_id, cfg.sample_period, cfg.output_skip_factor, cfg.num_devices, cfg.device_id,
            cfg.mtdata_length, cfg.output_mode, cfg.output_settings) == (
        d["master_device_id"], d["sample_period"], d["output_skip_factor"], d["num_devices"], d["device_id"],
        d["mtdata_length"], d["output_mode"], d["output_settings"])
    assert cfg.trailer == hexb(d["trailer"]) == mk4_trailer(39, (1, 8, 2, 37, 70964))
    assert cfg.pack() == payload
    assert encode_frame(0x0D, payload)[-1] == int(c["frame_checksum"], 16)
    with pytest.raises(ValueError):
        Configuration.unpack(payload[:-1])


def test_legacy_mtdata_example_both_ways() -> None:
    vec = frame("Legacy MTData example (Euler 1.5, -2.25, 90; counter 0x1234)")
    mode, settings_ = LegacyMode.ORIENTATION, 0x0000_0005
    payload = hexb(vec["payload"])
    assert legacy.mtdata_length(mode, settings_) == len(payload) == 14
    assert legacy.decode(mode, settings_, payload) == {"euler": (1.5, -2.25, 90.0), "sample_counter": 0x1234}
    # Encoding: a quaternion whose ZYX angles are exactly those (floats round-trip through float32).
    from emulators.xsens.frames import euler_deg_to_quat

    s = legacy.LegacySample(0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                            euler_deg_to_quat(1.5, -2.25, 90.0), 0, 0x1234)
    assert legacy.encode(mode, settings_, s) == payload
