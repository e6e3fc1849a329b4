"""RC decoders: capture records + PPM (sync, validity, channel-count lock, loss) and SBUS."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.drivers import ppm_capture as pc
from flightcode.drivers import sbus
from flightcode.drivers.ppm_capture import CaptureParser, CaptureRecord, CaptureRcInput, PpmDecoder, PpmParams
from flightcode.drivers.sbus import SbusParams, SbusParser, SbusRcInput
from tests.unit.flightcode.fakes import FakeSerial, capture_record, ppm_edges, sbus_frame

# docs/rc-capture-format.md worked examples (timer 0x1234.., across the wrap, overrun).
GOLDEN_RECORDS = [
    ("A5 17 00 34 12 D6", CaptureRecord(0x17, 0, False, 0x1234)),
    ("A5 18 01 60 13 30", CaptureRecord(0x18, 1, False, 0x1360)),
    ("A5 19 00 10 18 DE", CaptureRecord(0x19, 0, False, 0x1810)),
    ("A5 40 00 00 FD 66", CaptureRecord(0x40, 0, False, 0xFD00)),
    ("A5 41 01 2C FE 40", CaptureRecord(0x41, 1, False, 0xFE2C)),
    ("A5 42 00 DC 02 FF", CaptureRecord(0x42, 0, False, 0x02DC)),
    ("A5 43 02 00 0A 41", CaptureRecord(0x43, 0, True, 0x0A00)),
]
STREAM = b"".join(bytes.fromhex(w) for w, _ in GOLDEN_RECORDS)
RECORDS = [r for _, r in GOLDEN_RECORDS]


def test_crc8_check_value() -> None:
    assert pc.crc8(b"123456789") == 0xF4  # CRC-8/SMBUS check value


@pytest.mark.parametrize(("wire", "record"), GOLDEN_RECORDS)
def test_encode_golden_records(wire: str, record: CaptureRecord) -> None:
    assert pc.encode_record(record.seq, record.level, record.overrun, record.t_us) == bytes.fromhex(wire)


def test_parse_whole_and_byte_by_byte() -> None:
    assert CaptureParser().feed(STREAM) == RECORDS
    parser = CaptureParser()
    got = []
    for b in STREAM:
        got += parser.feed(bytes((b,)))
    assert got == RECORDS


def test_parse_with_garbage_and_false_sync_bytes() -> None:
    parser = CaptureParser()
    stream = b"\xa5\xa5\x00" + STREAM[:6] + b"\x13\xa5\x17" + STREAM[6:] + b"\xa5"
    assert parser.feed(stream) == RECORDS
    assert parser.counters["crc_errors"] + parser.counters["garbage_bytes"] >= 5


def test_reserved_flag_bits_reject_a_record() -> None:
    body = bytes((0x17, 0x04, 0x34, 0x12))
    parser = CaptureParser()
    assert parser.feed(b"\xa5" + body + bytes((pc.crc8(body),))) == []
    assert parser.counters["bad_flags"] == 1


@settings(max_examples=60, deadline=None)
@given(records=st.lists(st.tuples(st.integers(0, 255), st.integers(0, 1), st.booleans(), st.integers(0, 0xFFFF)),
                        max_size=20),
       cuts=st.lists(st.integers(1, 13), max_size=30))
def test_parser_round_trip_any_fragmentation(records: list[tuple[int, int, bool, int]], cuts: list[int]) -> None:
    stream = b"".join(capture_record(s, lv, t, ov) for s, lv, ov, t in records)
    parser = CaptureParser()
    got, pos = [], 0
    for cut in cuts:
        got += parser.feed(stream[pos : pos + cut])
        pos += cut
    got += parser.feed(stream[pos:])
    assert got == [CaptureRecord(s, lv, ov, t) for s, lv, ov, t in records]


def test_golden_channel_widths() -> None:
    # docs/rc-capture-format.md: (0x1810 - 0x1234) & 0xFFFF = 1500 us, (0x02DC - 0xFD00) & 0xFFFF = 1500 us.
    dec = PpmDecoder(PpmParams(min_channels=1, lock_frames=1))
    lead = [CaptureRecord(0x15, 0, False, 0x0000), CaptureRecord(0x16, 1, False, 0x012C)]  # sync gap follows
    for rec in lead + RECORDS[:3]:
        dec.record(rec)
    assert dec._channels == [1500]
    dec = PpmDecoder(PpmParams(min_channels=1, lock_frames=1))
    lead = [CaptureRecord(0x3E, 0, False, 0xE000), CaptureRecord(0x3F, 1, False, 0xE12C)]
    for rec in lead + RECORDS[3:6]:
        dec.record(rec)
    assert dec._channels == [1500]
    dec.record(RECORDS[6])  # overrun: the frame in progress is dropped
    assert dec._channels == [] and dec.counters["overruns"] == 1


def _records(frames: list[list[float]], start_us: int = 1000, frame_us: int = 22_500, seq0: int = 0,
             polarity_low_sep: bool = True) -> list[CaptureRecord]:
    out = []
    seq = seq0
    for k, ch in enumerate(frames):
        for t, level in ppm_edges(start_us + k * frame_us, ch):
            out.append(CaptureRecord(seq & 0xFF, level if polarity_low_sep else 1 - level, False, t & 0xFFFF))
            seq += 1
    return out


def _decode(dec: PpmDecoder, records: list[CaptureRecord]) -> list[tuple[int, ...]]:
    return [f for f in (dec.record(r) for r in records) if f is not None]


CH8 = [1500.0, 1600.0, 1000.0, 2000.0, 1100.0, 1200.0, 1300.0, 1400.0]


def test_frames_after_the_count_locks() -> None:
    dec = PpmDecoder(PpmParams(lock_frames=3))
    frames = _decode(dec, _records([CH8] * 6))
    # A frame completes at the next sync gap and the first has no sync before it: frames
    # 1..4 complete, 1 and 2 while the count is locking.
    assert frames == [tuple(int(c) for c in CH8)] * 2
    assert dec.locked_channels == 8 and dec.counters["unlocked_frames"] == 2


@pytest.mark.parametrize("low_separators", [True, False])
@pytest.mark.parametrize("edge", ["falling", "rising"])
def test_either_polarity_and_edge(low_separators: bool, edge: str) -> None:
    dec = PpmDecoder(PpmParams(lock_frames=1, edge=edge))  # type: ignore[arg-type]
    frames = _decode(dec, _records([CH8] * 3, polarity_low_sep=low_separators))
    assert frames and all(f == tuple(int(c) for c in CH8) for f in frames)


def test_channel_count_change_relocks_after_n_frames() -> None:
    dec = PpmDecoder(PpmParams(lock_frames=3))
    ch6 = CH8[:6]
    recs = _records([CH8] * 5 + [ch6] * 6)
    frames = _decode(dec, recs)
    # CH8 frames 1..4 (two while locking), then ch6 frames 5..9 (two while relocking)
    assert frames[:2] == [tuple(int(c) for c in CH8)] * 2
    assert frames[2:] == [tuple(int(c) for c in ch6)] * 3
    assert dec.counters["locks"] == 2


def test_short_frame_is_rejected() -> None:
    dec = PpmDecoder(PpmParams(lock_frames=1, min_channels=5))
    assert _decode(dec, _records([CH8[:4]] * 4)) == []
    assert dec.counters["short_frames"] == 2


def test_glitch_pulse_drops_the_frame() -> None:
    dec = PpmDecoder(PpmParams(lock_frames=1))
    recs = _records([CH8] * 5)
    # a 400 us glitch: insert an extra falling/rising pair inside frame 2's third channel
    i = next(i for i, r in enumerate(recs) if r.t_us >= 1000 + 2 * 22_500 + 3500)
    t = recs[i - 1].t_us + 400
    glitch = [CaptureRecord(0, 0, False, t), CaptureRecord(0, 1, False, t + 100)]
    recs = recs[:i] + glitch + recs[i:]
    recs = [CaptureRecord(k & 0xFF, r.level, r.overrun, r.t_us) for k, r in enumerate(recs)]
    frames = _decode(dec, recs)
    assert len(frames) == 2 and dec.counters["bad_pulses"] >= 1


@pytest.mark.parametrize("fault", ["overrun", "seq_gap", "missing_edge"])
def test_lost_captures_drop_the_frame_in_progress(fault: str) -> None:
    dec = PpmDecoder(PpmParams(lock_frames=1))
    recs = _records([CH8] * 5)
    i = 25  # inside frame 1 (18 edges per frame)
    if fault == "overrun":
        r = recs[i]
        recs[i] = CaptureRecord(r.seq, r.level, True, r.t_us)
    elif fault == "seq_gap":
        recs = recs[:i] + [CaptureRecord((r.seq + 5) & 0xFF, r.level, r.overrun, r.t_us) for r in recs[i:]]
    else:
        recs = recs[:i] + [CaptureRecord((r.seq - 1) & 0xFF, r.level, r.overrun, r.t_us) for r in recs[i + 1 :]]
    frames = _decode(dec, recs)
    assert len(frames) == 2  # frames 1..3 complete; 1 is lost, 2 and 3 are fine
    key = {"overrun": "overruns", "seq_gap": "sequence_gaps", "missing_edge": "missing_edges"}[fault]
    assert dec.counters[key] == 1


@settings(max_examples=40, deadline=None)
@given(frames=st.lists(st.lists(st.integers(800, 2200), min_size=8, max_size=8), min_size=3, max_size=6),
       start=st.integers(0, 0xFFFF))
def test_random_frames_decode_exactly(frames: list[list[int]], start: int) -> None:
    dec = PpmDecoder(PpmParams(lock_frames=1))
    got = _decode(dec, _records([[float(c) for c in f] for f in frames], start_us=start))
    assert got == [tuple(f) for f in frames[1:-1]]


def _capture_input(params: PpmParams = PpmParams(lock_frames=2)) -> tuple[CaptureRcInput, FakeSerial]:
    port = FakeSerial("rc")
    return CaptureRcInput(port, params), port


def test_input_polls_without_blocking_and_stamps_sensor_time() -> None:
    rc, port = _capture_input()
    assert rc.poll(0) is None and rc.latest is None
    recs = _records([CH8] * 4)
    port.feed(b"".join(pc.encode_record(r.seq, r.level, r.overrun, r.t_us) for r in recs))
    frame = rc.poll(90_000_000)
    assert frame is not None and frame.t_ns == 90_000_000 and frame.channels_us == tuple(CH8)
    assert rc.latest == frame


def test_stale_stream_restarts_the_decoder() -> None:
    rc, port = _capture_input(PpmParams(lock_frames=1))
    recs = _records([CH8] * 4)
    wire = [pc.encode_record(r.seq, r.level, r.overrun, r.t_us) for r in recs]
    port.feed(b"".join(wire[:45]))  # up to the middle of frame 2
    assert rc.poll(50_000_000) is not None
    port.feed(b"".join(wire[45:]))  # the rest arrives after 70 ms of silence
    rc.poll(120_000_000)
    assert rc.decoder.counters["stale_restarts"] == 1
    assert rc.decoder.counters["frames"] == 1  # frame 2 straddled the silence: dropped


# -- SBUS ----------------------------------------------------------------------------------------
# docs/protocols.md 5.2: all 16 channels raw 992, no flags.
GOLDEN_SBUS = bytes.fromhex("0F E0 03 1F F8 C0 07 3E F0 81 0F 7C E0 03 1F F8 C0 07 3E F0 81 0F 7C 00 00")


def test_sbus_golden_frame() -> None:
    assert sbus.encode_frame((992,) * 16) == GOLDEN_SBUS
    frames = SbusParser().feed(GOLDEN_SBUS)
    assert frames == [sbus.SbusFrame((992,) * 16, 0)]


def test_sbus_scaling() -> None:
    # ArduPilot: pwm = raw * 0.625 + 875; 172/992/1811 -> 982.5/1495/2006.875 us
    port = FakeSerial("rc")
    rc = SbusRcInput(port, SbusParams())
    port.feed(sbus.encode_frame((172, 992, 1811) + (992,) * 13))
    frame = rc.poll(0)
    assert frame is not None and frame.channels_us[:3] == (982.5, 1495.0, 2006.875)


def test_sbus_byte_by_byte_and_garbage() -> None:
    parser = SbusParser()
    frame2 = sbus_frame([1000.0] * 16)
    stream = b"\x0f\x00\xff" + GOLDEN_SBUS + b"\x00\x0f" + frame2
    got = []
    for b in stream:
        got += parser.feed(bytes((b,)))
    assert [f.raw for f in got] == [(992,) * 16, (200,) * 16]
    assert parser.counters["garbage_bytes"] == 5


def test_sbus_failsafe_frames_do_not_refresh_rc() -> None:
    port = FakeSerial("rc")
    rc = SbusRcInput(port, SbusParams())
    port.feed(sbus_frame([1500.0] * 8))
    assert rc.poll(0) is not None
    port.feed(sbus_frame([1500.0] * 8, flags=sbus.FLAG_FAILSAFE | sbus.FLAG_FRAME_LOST))
    assert rc.poll(14_000_000) is None and rc.latest is not None and rc.latest.t_ns == 0
    port.feed(sbus_frame([1600.0] * 8, flags=sbus.FLAG_FRAME_LOST))  # warning only
    frame = rc.poll(28_000_000)
    assert frame is not None and frame.channels_us[0] == 1600.0
    assert rc.counters["failsafe_frames"] == 1 and rc.counters["frame_lost_flags"] == 2


@settings(max_examples=60, deadline=None)
@given(raw=st.lists(st.integers(0, 2047), min_size=16, max_size=16), flags=st.integers(0, 15),
       end=st.sampled_from([0x00, 0x04, 0x14, 0x24, 0x34]))
def test_sbus_round_trip(raw: list[int], flags: int, end: int) -> None:
    frames = SbusParser().feed(sbus.encode_frame(tuple(raw), flags, end))
    assert frames == [sbus.SbusFrame(tuple(raw), flags)]
