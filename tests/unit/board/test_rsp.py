"""GDB's remote-protocol framing (hil/board/rsp.py): the manual's packets, fed whole, byte by
byte and among garbage; escapes; damaged packets answered ``-``."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from hil.board import rsp

#: packets GDB sends (GDB manual, Appendix E, "Packets"), with the checksum as its "Overview"
#: defines it (the sum of the data's bytes modulo 256)
GOLDEN = [(b"$g#67", b"g"), (b"$?#3f", b"?"), (b"$m0,4#fd", b"m0,4"), (b"$qC#b4", b"qC"),
          (b"$vCont?#49", b"vCont?"), (b"$c#63", b"c"), (b"$s#73", b"s"), (b"$k#6b", b"k")]


def _packets(items: list[rsp.Packet | rsp.Event]) -> list[bytes]:
    return [i.data for i in items if isinstance(i, rsp.Packet)]


def test_golden_packets_whole_and_byte_by_byte() -> None:
    wire = b"".join(w for w, _ in GOLDEN)
    assert _packets(rsp.Decoder().feed(wire)) == [d for _, d in GOLDEN]
    dec = rsp.Decoder()
    got = [item for b in wire for item in dec.feed(bytes([b]))]
    assert _packets(got) == [d for _, d in GOLDEN] and dec.nak_due == 0
    for w, d in GOLDEN:
        assert rsp.encode(d) == w


def test_garbage_between_packets_is_dropped_and_acks_and_interrupts_are_events() -> None:
    dec = rsp.Decoder()
    out = dec.feed(b"\x00noise+$g#67-\x03junk$?#3f")
    assert out == [rsp.Event.ACK, rsp.Packet(b"g"), rsp.Event.NAK, rsp.Event.INTERRUPT, rsp.Packet(b"?")]
    assert dec.dropped == len(b"\x00noise") + len(b"junk")


def test_a_damaged_packet_is_answered_nak_and_the_next_one_is_read() -> None:
    dec = rsp.Decoder()
    assert _packets(dec.feed(b"$g#68$?#3f")) == [b"?"] and dec.nak_due == 1
    assert _packets(dec.feed(b"$g#zz")) == [] and dec.nak_due == 2


def test_escapes() -> None:
    data = b"a#b$c}d*e"
    wire = rsp.encode(data)
    assert b"}\x03" in wire and b"}\x04" in wire and b"}]" in wire and b"}\x0a" in wire
    assert _packets(rsp.Decoder().feed(wire)) == [data]


@given(st.lists(st.binary(max_size=40), max_size=8), st.integers(1, 7))
def test_any_packets_round_trip_in_any_chunks(datas: list[bytes], chunk: int) -> None:
    wire = b"".join(rsp.encode(d) for d in datas)
    dec = rsp.Decoder()
    got = [item for i in range(0, len(wire), chunk) for item in dec.feed(wire[i : i + chunk])]
    assert _packets(got) == datas and dec.nak_due == 0
