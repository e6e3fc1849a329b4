"""The serial line sampler: a receiver at its own rate and format reads what the line carries;
the whole-frame fast path gives what sampling every bit gives."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from emulators.lpc2148.line import (
    FORMAT_8N1,
    FrameFormat,
    LineFrame,
    LineReceiver,
    Parity,
    format_from_lcr,
    frame_levels,
)


def send(rx: LineReceiver, data: bytes, bit: float, fmt: FrameFormat = FORMAT_8N1, start: float = 0.0) -> None:
    t = start
    for v in data:
        f = LineFrame(t, bit, frame_levels(v, fmt), v, fmt)
        rx.push(f)
        t = f.end


def test_frame_levels_and_lcr_formats() -> None:
    assert frame_levels(0x41, FORMAT_8N1) == (0, 1, 0, 0, 0, 0, 0, 1, 0, 1)
    even = FrameFormat(8, Parity.EVEN, 1)
    assert frame_levels(0x03, even)[9] == 0 and frame_levels(0x01, even)[9] == 1
    assert format_from_lcr(0x03) == FORMAT_8N1
    assert format_from_lcr(0x1B) == FrameFormat(8, Parity.EVEN, 1)
    assert format_from_lcr(0x04) == FrameFormat(5, Parity.NONE, 2)


def test_same_rate_reads_every_byte_at_its_stop_bit() -> None:
    rx = LineReceiver()
    send(rx, b"AB", 100.0)
    got = rx.take(1e9, 100.0, FORMAT_8N1)
    assert [(c.value, c.done) for c in got] == [(0x41, 950.0), (0x42, 1950.0)]
    assert not any(c.framing_error for c in got)


def test_double_rate_receiver_reads_garbage_with_framing_errors() -> None:
    rx = LineReceiver()
    send(rx, b"Hello, world", 100.0)
    got = rx.take(1e9, 50.0, FORMAT_8N1)
    assert bytes(c.value for c in got) != b"Hello, world"
    assert any(c.framing_error for c in got)


def test_parity_mismatch_is_flagged() -> None:
    rx = LineReceiver()
    send(rx, bytes([0x03]), 100.0)  # 8N1: the stop bit (1) lands where 8E1 expects parity 0
    got = rx.take(1e9, 100.0, FrameFormat(8, Parity.EVEN, 1))
    assert got[0].value == 0x03 and got[0].parity_error


def test_a_break_is_all_zeros() -> None:
    rx = LineReceiver()
    rx.push(LineFrame(0.0, 100.0, (0,) * 20 + (1,), 0, FORMAT_8N1))
    got = rx.take(1e9, 100.0, FORMAT_8N1)
    assert got[0].break_ and got[0].framing_error and got[0].value == 0


@settings(max_examples=200)
@given(data=st.binary(min_size=1, max_size=12), ratio=st.floats(0.9, 1.1), gap=st.floats(0.0, 30.0),
       fmt_lcr=st.sampled_from([0x03, 0x1B, 0x0B, 0x07, 0x02]))
def test_fast_path_equals_bit_sampling(data: bytes, ratio: float, gap: float, fmt_lcr: int) -> None:
    fmt = format_from_lcr(fmt_lcr)
    fast, slow = LineReceiver(), LineReceiver(fast_path=False)
    for rx in (fast, slow):
        t = 0.0
        for v in data:
            f = LineFrame(t, 100.0, frame_levels(v, fmt), v, fmt)
            rx.push(f)
            t = f.end + gap
    assert fast.take(1e9, 100.0 * ratio, fmt) == slow.take(1e9, 100.0 * ratio, fmt)


@given(data=st.binary(min_size=1, max_size=20), ratio=st.floats(0.96, 1.04))
def test_within_four_percent_every_byte_arrives(data: bytes, ratio: float) -> None:
    rx = LineReceiver(fast_path=False)
    send(rx, data, 100.0)
    got = rx.take(1e9, 100.0 * ratio, FORMAT_8N1)
    assert bytes(c.value for c in got) == data and not any(c.framing_error for c in got)
