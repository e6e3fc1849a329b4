"""The firmware's RC input drivers against flightcode's on the same streams: the capture-record
parser and the PPM decoder (firmware/src/drivers/ppm.c), and the SBUS parser (sbus.c). Any
byte stream, cut anywhere (hypothesis): the same records, frames and counts."""

from __future__ import annotations

import ctypes as C

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.drivers import ppm_capture, sbus
from tests.unit.firmware.fwcodecs import (
    PPM_COUNTERS,
    SBUS_FN,
    CaptureParserT,
    Codecs,
    EdgeT,
    PpmDecoderT,
    PpmParamsT,
    SbusFrameT,
    SbusParserT,
)


@pytest.fixture(scope="module")
def fw(tmp_path_factory: pytest.TempPathFactory) -> Codecs:
    return Codecs(tmp_path_factory.mktemp("codecs"))


def c_decode(fw: Codecs, chunks: list[bytes], params: ppm_capture.PpmParams) -> tuple[list, list, dict, dict]:
    """Records and frames of the C parser + decoder over ``chunks``, and their counters."""
    parser, dec = CaptureParserT(), PpmDecoderT()
    p = PpmParamsT(params.sync_min_us, params.pulse_min_us, params.pulse_max_us, params.min_channels,
                   params.max_channels, params.lock_frames, params.edge == "rising", params.stale_ms)
    fw.dll.ppm_init(C.byref(dec), C.byref(p))
    records, frames = [], []
    edges = (EdgeT * 16)()
    widths = (C.c_uint16 * 16)()
    for chunk in chunks:
        while chunk:
            took = fw.dll.capture_parser_push(C.byref(parser), chunk, len(chunk))
            chunk = chunk[took:]
            while True:
                n = fw.dll.capture_parser_pop(C.byref(parser), edges, 16)
                for e in edges[:n]:
                    records.append((e.seq, e.level, bool(e.overrun), e.t_us))
                    count = fw.dll.ppm_edge(C.byref(dec), C.byref(e), widths)
                    if count > 0:
                        frames.append(tuple(widths[:count]))
                if n < 16:
                    break
    wire = {"garbage_bytes": parser.garbage_bytes, "crc_errors": parser.crc_errors, "bad_flags": parser.bad_flags}
    return records, frames, wire, {name: getattr(dec, name) for name in PPM_COUNTERS}


def ppm_stream(channels: list[int], frames: int, seq0: int = 0) -> bytes:
    """Capture records of a PPM train (falling-edge separators of 300 us, sync gap)."""
    out, t, seq = b"", 0, seq0
    for _ in range(frames):
        for width in [*channels, 22500 - sum(channels)]:
            out += ppm_capture.encode_record(seq, 0, False, t & 0xFFFF)
            seq += 1
            out += ppm_capture.encode_record(seq, 1, False, (t + 300) & 0xFFFF)
            seq += 1
            t += width
    return out


@settings(max_examples=150, deadline=None)
@given(st.lists(st.integers(900, 2100), min_size=5, max_size=9), st.integers(26, 32),
       st.lists(st.tuples(st.integers(0, 4000), st.binary(min_size=1, max_size=8)), max_size=4),
       st.lists(st.integers(1, 50), min_size=1, max_size=10))
def test_same_records_frames_and_counts_as_flightcode(fw: Codecs, channels: list[int], n_frames: int,
                                                      damage: list[tuple[int, bytes]], cuts: list[int]) -> None:
    stream = bytearray(ppm_stream(channels, n_frames))
    for pos, junk in damage:  # garbage and corrupted bytes anywhere
        pos %= len(stream)
        stream[pos:pos] = junk
    stream = bytes(stream)
    chunks, i, k = [], 0, 0
    while i < len(stream):
        chunks.append(stream[i:i + cuts[k % len(cuts)]])
        i, k = i + cuts[k % len(cuts)], k + 1
    params = ppm_capture.PpmParams()
    py_parser, py_dec = ppm_capture.CaptureParser(), ppm_capture.PpmDecoder(params)
    py_records, py_frames = [], []
    for chunk in chunks:
        for rec in py_parser.feed(chunk):
            py_records.append((rec.seq, rec.level, rec.overrun, rec.t_us))
            frame = py_dec.record(rec)
            if frame is not None:
                py_frames.append(frame)
    records, frames, wire, counts = c_decode(fw, chunks, params)
    assert records == py_records
    assert frames == py_frames
    assert wire == {k: py_parser.counters[k] for k in wire}
    assert counts == {k: py_dec.counters[k] for k in counts}


def test_a_clean_train_locks_and_decodes(fw: Codecs) -> None:
    channels = [1500, 1100, 1000, 1900, 1500, 1500, 1500, 1500]
    _, frames, _, counts = c_decode(fw, [ppm_stream(channels, 30)], ppm_capture.PpmParams())
    assert counts["locks"] == 1
    assert frames and all(f == tuple(channels) for f in frames)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.lists(st.integers(0, 2047), min_size=16, max_size=16), st.sampled_from([0, 4, 8, 12]),
                          st.sampled_from([0x00, 0x04, 0x14])), max_size=6),
       st.lists(st.binary(max_size=6), max_size=6), st.lists(st.integers(1, 30), min_size=1, max_size=8))
def test_sbus_frames_as_flightcode(fw: Codecs, frames: list, junk: list[bytes], cuts: list[int]) -> None:
    stream = b""
    for k, (raw, flags, end) in enumerate(frames):
        stream += (junk[k] if k < len(junk) else b"") + sbus.encode_frame(tuple(raw), flags, end)
    chunks, i, k = [], 0, 0
    while i < len(stream):
        chunks.append(stream[i:i + cuts[k % len(cuts)]])
        i, k = i + cuts[k % len(cuts)], k + 1
    py = sbus.SbusParser()
    expected = [(f.raw, f.flags) for c in chunks for f in py.feed(c)]
    got: list[tuple[tuple[int, ...], int]] = []

    def on_frame(_ctx: int, frame: C.POINTER(SbusFrameT)) -> None:  # type: ignore[valid-type]
        f = frame.contents
        got.append((tuple(f.raw), f.flags))

    fn = SBUS_FN(on_frame)
    parser = SbusParserT()
    fw.dll.sbus_parser_init(C.byref(parser))
    for c in chunks:
        fw.dll.sbus_parser_feed(C.byref(parser), c, len(c), fn, None)
    assert got == expected
    assert (parser.garbage_bytes, parser.frames) == (py.counters["garbage_bytes"], py.counters["frames"])
