"""The bench's telemetry decoder: the slice-based plain-frame parse against the byte-by-byte
reference, and whole frames of the flight code's own encoder decoded fed whole, byte by byte
and behind garbage."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from hil.flight import telemetry as tm


def _frame(data: bytes, *, escaped: bool = False, bad_checksum: bool = False) -> bytes:
    body = len(data).to_bytes(2, "big") + data + bytes([(0xFF - sum(data) + (1 if bad_checksum else 0)) & 0xFF])
    if escaped:
        out = bytearray()
        for b in body:
            if b in (0x7E, 0x7D, 0x11, 0x13):
                out += bytes([0x7D, b ^ 0x20])
            else:
                out.append(b)
        body = bytes(out)
    return bytes([tm.START]) + body


streams = st.one_of(
    st.binary(max_size=80).map(lambda b: bytes([tm.START]) + b),
    st.tuples(st.binary(min_size=1, max_size=40), st.booleans(), st.integers(0, 60), st.binary(max_size=8)).map(
        lambda a: _frame(a[0], bad_checksum=a[1])[: a[2] or None] + a[3]
    ),
    st.binary(min_size=1, max_size=600).map(lambda b: _frame(b)),
    st.binary(min_size=2, max_size=3).map(lambda b: bytes([tm.START]) + b + b"\x7e"),
)


@settings(max_examples=400, deadline=None)
@given(streams)
def test_the_plain_parse_agrees_with_the_byte_by_byte_reference(buf: bytes) -> None:
    b = bytearray(buf)
    assert tm._parse_plain(b) == tm._parse(b, escaped=False)


def _payload(seq: int) -> bytes:
    values = [1, 3, seq, 12_345, 0] + [0.1 * i for i in range(10)] + [6000, 6004, 6008, 6012] + [0.5, 0.01, -0.02, 0.003] + list(range(8))
    return tm._V1.pack(*values)


def _tx16(payload: bytes) -> bytes:
    return bytes([tm.TX16, 0, 0x00, 0x01, 0]) + payload


def test_frames_decode_whole_byte_by_byte_and_behind_garbage() -> None:
    frames = [_frame(_tx16(_payload(s)), escaped=s % 2 == 1) for s in range(6)]
    wire = b"\x13\x00garbage\x7e\x00" + b"".join(frames)
    for chunks in ([wire], [wire[i : i + 1] for i in range(len(wire))]):
        dec = tm.TelemetryDecoder()
        got = [d for c in chunks for d in dec.feed(c)]
        assert [d["seq"] for d in got] == list(range(6))
        assert got[0]["mode_name"] == "FLYING" and got[0]["pulses_us"] == [1500.0, 1501.0, 1502.0, 1503.0]


def test_a_bad_checksum_is_counted_and_the_next_frame_still_decodes() -> None:
    dec = tm.TelemetryDecoder()
    wire = _frame(_tx16(_payload(1)), bad_checksum=True) + _frame(_tx16(_payload(2)))
    assert [d["seq"] for d in dec.feed(wire)] == [2]
    assert dec.bad_checksums == 1
