"""The firmware's Xbus parser and MTData decoding (firmware/src/drivers/xbus.c, mtdata.c) on the
golden frames of tests/golden/xsens (public documentation and an MTi-300 capture): fed whole,
byte by byte and with garbage, and against the Python flight code's parser on the same streams."""

from __future__ import annotations

import json
import math
import struct
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.drivers import mtdata, xbus
from tests.unit.firmware.fwcodecs import Codecs

GOLDEN = json.loads((Path(__file__).resolve().parents[2] / "golden" / "xsens" / "xsens_vectors.json").read_text())
FRAMES = [(f["name"], f["mid"], bytes.fromhex(f["payload"]), bytes.fromhex(f["hex"])) for f in GOLDEN["frames"]]
MTDATA2 = [(p["name"], bytes.fromhex(p["payload_hex"]), p["decoded"]) for p in GOLDEN["mtdata2_payloads"]]


@pytest.fixture(scope="module")
def fw(tmp_path_factory: pytest.TempPathFactory) -> Codecs:
    return Codecs(tmp_path_factory.mktemp("codecs"))


@pytest.mark.parametrize(("name", "mid", "payload", "wire"), FRAMES, ids=[f[0] for f in FRAMES])
def test_golden_frame_encodes_and_parses(fw: Codecs, name: str, mid: int, payload: bytes, wire: bytes) -> None:
    assert fw.encode(mid, payload) == wire
    whole = fw.parser()
    assert whole.feed(wire) == [(mid, payload)]
    bytewise = fw.parser()
    assert bytewise.feed_all(wire[i:i + 1] for i in range(len(wire))) == [(mid, payload)]
    assert whole.counters == bytewise.counters == {"frames": 1, "garbage_bytes": 0, "checksum_errors": 0,
                                                   "bad_length": 0}


def test_golden_stream_with_garbage_whole_and_byte_by_byte(fw: Codecs) -> None:
    """Every golden frame, each behind garbage that holds stray preambles, a truncated header and
    a corrupted copy: all frames come out in order, both ways, and the garbage is counted."""
    junk = [b"\x00\x13", b"\xfa", b"\xfa\xff\x36", b"\xfa\xfa\xff\x42\x01\x04\xbb", b"\x55" * 7]
    stream = b""
    expected = []
    for i, (_name, mid, payload, wire) in enumerate(FRAMES):
        stream += junk[i % len(junk)] + wire
        expected.append((mid, payload))
    stream += b"\xfa"  # a trailing half preamble is kept for the next read
    whole = fw.parser()
    assert whole.feed(stream) == expected
    bytewise = fw.parser()
    assert bytewise.feed_all(stream[i:i + 1] for i in range(len(stream))) == expected
    assert whole.counters["frames"] == len(FRAMES)
    assert whole.counters["garbage_bytes"] > 0
    assert whole.counters["checksum_errors"] >= 1  # the corrupted Error frame


def test_checksum_error_dropped_and_counted(fw: Codecs) -> None:
    good = fw.encode(0x42, b"\x04")
    bad = good[:-1] + bytes(((good[-1] + 1) & 0xFF,))
    p = fw.parser()
    assert p.feed(bad + good) == [(0x42, b"\x04")]
    assert p.counters["checksum_errors"] == 1


def test_huge_length_does_not_swallow_the_stream(fw: Codecs) -> None:
    """A corrupted header claiming more than max_payload is a bad length, and one claiming more
    than has arrived does not hide a complete frame already behind it."""
    p = fw.parser(max_payload=64)
    sample = fw.encode(0x36, bytes(64))
    assert p.feed(b"\xfa\xff\x36\xff\x10\x00" + sample) == [(0x36, bytes(64))]
    assert p.counters["bad_length"] == 1
    q = fw.parser()
    assert q.feed(b"\xfa\xff\x36\xf0" + sample) == [(0x36, bytes(64))]


def test_bytes_needed(fw: Codecs) -> None:
    p = fw.parser()
    frame = fw.encode(0x36, bytes(64))
    assert p.bytes_needed(69) == 69
    p.feed(frame[:10])
    assert p.bytes_needed(69) == 59


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(st.binary(max_size=20), st.sampled_from([f[3] for f in FRAMES])), max_size=12),
       st.lists(st.integers(1, 40), min_size=1, max_size=20))
def test_same_messages_and_counters_as_the_python_parser(fw: Codecs, pieces: list[bytes], cuts: list[int]) -> None:
    """Any stream, cut anywhere: the C parser delivers what flightcode's XbusParser delivers."""
    stream = b"".join(pieces)
    chunks, i, k = [], 0, 0
    while i < len(stream):
        n = cuts[k % len(cuts)]
        chunks.append(stream[i:i + n])
        i, k = i + n, k + 1
    py = xbus.XbusParser(max_payload=400)
    expected = [(m.mid, m.payload) for c in chunks for m in py.feed(c)]
    c = fw.parser(max_payload=400)
    assert c.feed_all(chunks) == expected
    for key in ("frames", "checksum_errors", "bad_length"):
        assert c.counters[key] == py.counters[key], key


def test_output_configuration_is_the_flight_codes(fw: Codecs) -> None:
    assert fw.mk4_output_configuration(400) == mtdata.encode_output_configuration(mtdata.mk4_output_configuration(400))


@pytest.mark.parametrize(("name", "payload", "decoded"), MTDATA2, ids=[p[0] for p in MTDATA2])
def test_mti300_captures_decode_as_the_python_flight_code(fw: Codecs, name: str, payload: bytes,
                                                          decoded: dict[str, object]) -> None:
    """The captured MTi-300 packets carry quaternions, not Euler angles: both flight codes
    refuse them as incomplete (the loop needs Euler angles), counted the same way."""
    data, counters = fw.decode2(payload)
    py_counters: Counter[str] = Counter()
    assert (data is None) == (mtdata.decode_mtdata2(payload, py_counters) is None)
    assert counters.mtdata2_incomplete == py_counters["mtdata2_incomplete"]
    assert counters.mtdata2_truncated == py_counters["mtdata2_truncated"]


def _mk4_payload(counter: int, stf: int, euler: tuple[float, ...], gyr: tuple[float, ...], acc: tuple[float, ...],
                 status: int) -> bytes:
    return struct.pack(">HBH HBI HB3f HB3f HB3f HBI", 0x1020, 2, counter, 0x1060, 4, stf, 0x2034, 12, *euler,
                       0x8024, 12, *gyr, 0x4024, 12, *acc, 0xE020, 4, status)


finite = st.floats(-1e6, 1e6, width=32)


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 0xFFFF), st.integers(0, 0xFFFFFFFF), st.tuples(finite, finite, finite),
       st.tuples(finite, finite, finite), st.tuples(finite, finite, finite), st.integers(0, 0xFFFFFFFF))
def test_mk4_sample_decodes_exactly(fw: Codecs, counter: int, stf: int, euler: tuple[float, ...],
                                    gyr: tuple[float, ...], acc: tuple[float, ...], status: int) -> None:
    payload = _mk4_payload(counter, stf, euler, gyr, acc, status)
    data, _ = fw.decode2(payload)
    assert data is not None
    assert (data.counter, data.sample_time_fine, data.status) == (counter, stf, status)
    assert tuple(data.euler_deg) == euler and tuple(data.rate_of_turn_radps) == gyr
    assert tuple(data.acceleration_mps2) == acc
    # the general path (items reordered) decodes the same sample
    reordered = payload[57:] + payload[:57]
    again, _ = fw.decode2(reordered)
    assert again is not None and tuple(again.euler_deg) == euler and again.counter == counter


def test_non_finite_value_refused_as_python_does(fw: Codecs) -> None:
    payload = _mk4_payload(1, 40, (math.nan, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, -9.8), 0)
    data, counters = fw.decode2(payload)
    py: Counter[str] = Counter()
    assert data is None and mtdata.decode_mtdata2(payload, py) is None
    assert counters.mtdata2_incomplete == py["mtdata2_incomplete"] == 1


def test_legacy_golden_mtdata(fw: Codecs) -> None:
    """docs/protocols.md 1.8: orientation only (mode 4, settings 5) is not a layout the loop can
    fly (no calibrated data): refused as flightcode refuses it; the flight code's own layout
    decodes."""
    frame = next(f for f in FRAMES if f[0].startswith("Legacy MTData"))
    data, counters = fw.decode_legacy(frame[2], 0x0004, 0x00000005)
    assert data is None and counters.mtdata_unsupported_layout == 1
    mode, settings = mtdata.LEGACY_OUTPUT_MODE, mtdata.LEGACY_OUTPUT_SETTINGS
    payload = struct.pack(">9f3fH", 0.1, 0.2, -9.8, 0.01, 0.02, 0.03, 0.0, 0.0, 0.0, 1.5, -2.25, 90.0, 0x1234)
    data, _ = fw.decode_legacy(payload, mode, settings)
    py = mtdata.decode_mtdata_legacy(payload, mode, settings, Counter())
    assert data is not None and py is not None
    assert data.counter == py.counter == 0x1234
    assert tuple(data.euler_deg) == pytest.approx(py.euler_deg)
    assert tuple(data.acceleration_mps2) == pytest.approx(py.acceleration_mps2)
