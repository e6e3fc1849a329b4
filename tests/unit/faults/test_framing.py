"""Frame boundaries and checksum corruption per protocol (hil/faults/framing.py).

Golden frames: Xbus from docs/protocols.md §1 "Worked frames" (ReqDID identical to the
MT0100P example, ReqBaudrate to the MT0605P example) and the MTi-300 capture in
Scottapotamas/xsens-mti docs/mtmanager_packets.md (MT Manager,
https://github.com/Scottapotamas/xsens-mti); XBee API
from docs/protocols.md §8.2 (TX status and the AP=2 escaping example match Digi's
printed examples in the XBee 802.15.4 manual).
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from emulators.rc.capture import CaptureRecord, crc8, pack_record
from emulators.rc.sbus import SbusFrame, pack_sbus
from emulators.xbee.frames import ApiParser
from emulators.xbee.frames import encode_frame as xbee_frame
from emulators.xsens.codec import FrameParser
from emulators.xsens.codec import encode_frame as xbus_frame
from hil.faults.framing import Protocol, corrupt_checksum, flip_last_byte, split

H = bytes.fromhex
REQ_DID = H("FA FF 00 00 01")
REQ_BAUD = H("FA FF 18 00 E9")
GOTO_CONFIG_ACK = H("FA FF 31 00 D0")
# MTData2 payload of the MTi-300 capture (11 items, 139 bytes)
MTI300_PAYLOAD = H(
    "10 20 02 A6 55 10 60 04 00 57 47 2E 20 10 10 3F 7F 7D C4 BC 10 10 7D 3B A1 57 70 BD 7E C6 56 40 20 0C BD A2 1A"
    " F8 BE 2A 8E 96 41 1D 27 A2 40 10 0C B9 4F C8 00 B9 DA 24 00 3C C9 28 80 40 30 0C 3C 02 C8 9C 3C 35 F6 C8 3C DB"
    " 0C 00 80 20 0C BB B1 7D 81 BB 96 32 00 3C 01 E8 41 80 30 10 3F 80 00 00 B6 E3"
)
TX_STATUS = H("7E 00 03 89 01 00 75")
RX16_HELLO = H("7E 00 0A 81 00 01 28 00 68 65 6C 6C 6F 41")
ESCAPED = H("7E 00 02 23 7D 31 CB")  # 7E 00 02 23 11 CB with 0x11 (XON) escaped


def rng(seed: int = 0) -> np.random.Generator:
    return np.random.default_rng(seed)


def test_xbus_golden_frames_split_whole_and_with_garbage() -> None:
    mtdata = H("FA FF 36") + bytes((len(MTI300_PAYLOAD),)) + MTI300_PAYLOAD
    mtdata += bytes((-sum(mtdata[1:]) & 0xFF,))
    assert FrameParser().feed(mtdata)  # a valid frame
    stream = REQ_DID + mtdata + REQ_BAUD
    assert split(Protocol.XBUS, stream) == [(REQ_DID, True), (mtdata, True), (REQ_BAUD, True)]
    garbage = H("00 13 FA")  # a stray preamble that does not start a frame that fits
    got = split(Protocol.XBUS, H("55 AA") + GOTO_CONFIG_ACK + garbage)
    assert got == [(H("55 AA"), False), (GOTO_CONFIG_ACK, True), (H("00 13"), False), (H("FA"), False)]
    assert split(Protocol.XBUS, mtdata[:50]) == [(mtdata[:50], False)]  # cut by the end of the chunk


def test_xbus_extended_length_frame() -> None:
    frame = xbus_frame(0x36, bytes(range(256)) + bytes(44))  # 300 bytes: FA FF 36 FF 01 2C ...
    assert frame[:6] == H("FA FF 36 FF 01 2C")
    assert split(Protocol.XBUS, frame + REQ_DID) == [(frame, True), (REQ_DID, True)]


def test_xbus_checksum_corruption_is_detected_and_nothing_else_changes() -> None:
    for seed in range(20):
        bad = corrupt_checksum(Protocol.XBUS, REQ_BAUD, rng(seed))
        assert bad[:-1] == REQ_BAUD[:-1] and bad[-1] != REQ_BAUD[-1]
        parser = FrameParser()
        assert parser.feed(bad) == [] and parser.stats.checksum_errors == 1


def test_xbee_api_frames_and_escaped_frames() -> None:
    assert split(Protocol.XBEE_API, TX_STATUS + RX16_HELLO) == [(TX_STATUS, True), (RX16_HELLO, True)]
    assert split(Protocol.XBEE_API_ESCAPED, ESCAPED + TX_STATUS) == [(ESCAPED, True), (TX_STATUS, True)]
    assert split(Protocol.XBEE_API_ESCAPED, ESCAPED[:5]) == [(ESCAPED[:5], False)]  # ends inside an escape
    for seed in range(30):
        for proto, frame in ((Protocol.XBEE_API, RX16_HELLO), (Protocol.XBEE_API_ESCAPED, ESCAPED)):
            bad = corrupt_checksum(proto, frame, rng(seed))
            parser = ApiParser(escaped=proto is Protocol.XBEE_API_ESCAPED)
            assert parser.feed(bad) == [], bad.hex(" ")
            assert parser.counters.bad_checksum == 1
            # the frame data survive: only the checksum is wrong
            assert split(proto, bad) == [(bad, True)]


def test_capture_sbus_and_maestro() -> None:
    recs = [pack_record(CaptureRecord(i, bool(i & 1), False, 1000 * i)) for i in range(3)]
    assert split(Protocol.CAPTURE, b"".join(recs)) == [(r, True) for r in recs]
    bad = corrupt_checksum(Protocol.CAPTURE, recs[1], rng())
    assert bad[:5] == recs[1][:5] and crc8(bad[1:5]) != bad[5]
    sbus = pack_sbus(SbusFrame(tuple(range(16))))
    assert split(Protocol.SBUS, sbus + sbus[:10]) == [(sbus, True), (sbus[:10], False)]
    cmd = H("84 00 70 2E 55")  # Pololu set target with a CRC-7 byte (7 bits)
    for seed in range(30):
        crc_bad = corrupt_checksum(Protocol.MAESTRO_CRC, cmd, rng(seed))
        assert crc_bad[:-1] == cmd[:-1] and crc_bad[-1] != cmd[-1] and crc_bad[-1] < 0x80
    assert split(Protocol.BUSPIRATE, b"\x02\x12") == [(b"\x02\x12", True)]
    assert split(Protocol.BUSPIRATE, b"") == []


def test_flip_last_byte() -> None:
    for seed in range(20):
        out = flip_last_byte(b"\x01\x02\x03", rng(seed))
        assert out[:2] == b"\x01\x02" and out[2] != 3
    assert flip_last_byte(b"", rng()) == b""


frames_st = st.lists(
    st.tuples(st.integers(0x00, 0xFF), st.binary(max_size=300)), min_size=1, max_size=6
)


@settings(deadline=None, max_examples=60)
@given(frames_st)
def test_xbus_split_of_concatenated_frames_returns_them(items: list[tuple[int, bytes]]) -> None:
    frames = [xbus_frame(mid, payload) for mid, payload in items]
    assert split(Protocol.XBUS, b"".join(frames)) == [(f, True) for f in frames]


@settings(deadline=None, max_examples=60)
@given(st.lists(st.binary(min_size=1, max_size=60), min_size=1, max_size=5), st.booleans())
def test_xbee_split_of_concatenated_frames_returns_them(datas: list[bytes], escaped: bool) -> None:
    frames = [xbee_frame(d, escaped=escaped) for d in datas]
    proto = Protocol.XBEE_API_ESCAPED if escaped else Protocol.XBEE_API
    assert split(proto, b"".join(frames)) == [(f, True) for f in frames]
    assert ApiParser(escaped=escaped).feed(b"".join(frames)) == datas


@settings(deadline=None, max_examples=60)
@given(st.binary(max_size=200))
def test_split_never_loses_or_reorders_bytes(data: bytes) -> None:
    for proto in Protocol:
        assert b"".join(seg for seg, _ in split(proto, data)) == data
