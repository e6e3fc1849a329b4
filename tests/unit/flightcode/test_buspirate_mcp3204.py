"""Bus Pirate binary SPI and the MCP3204 reader: entry, pipelined reads, resync without crashing."""

from __future__ import annotations

import io

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.drivers import buspirate_protocol as bp
from flightcode.drivers import mcp3204
from flightcode.drivers.base import DeviceError
from flightcode.drivers.buspirate_spi import BusPirateSpi
from flightcode.drivers.mcp3204 import Mcp3204Reader
from flightcode.log import Logger
from tests.unit.flightcode.fakes import FakeBusPirate, FakeClock, FakeSerial

CODES = {0: 2420, 1: 2703, 2: 2048, 3: 1392}
TICK_NS = 2_500_000


def _bridge(attempts: int = 2) -> tuple[BusPirateSpi, FakeBusPirate, FakeSerial, io.StringIO]:
    clock = FakeClock()
    port = FakeSerial("adc", clock, timeout_s=0.01)  # a starved read blocks the 10 ms timeout
    dev = FakeBusPirate(port, lambda ch: CODES[ch])
    out = io.StringIO()
    return BusPirateSpi(port, speed_hz=1_000_000, entry_attempts=attempts, reply_timeout_s=0.02, quiet_s=0.01,
                        resync_interval_ns=250_000_000, log=Logger(out), clock=clock), dev, port, out


def test_mcp3204_requests_match_the_datasheet_framing() -> None:
    # the start bit at the second clock (Linux mcp320x's alignment): 0 1 S D2 D1 D0 0 0, then 24
    # clocks for the code and its LSB-first repeat
    assert [mcp3204.request(ch).hex(" ") for ch in range(4)] == ["60 00 00 00", "64 00 00 00", "68 00 00 00",
                                                                "6c 00 00 00"]
    assert mcp3204.request(1, single_ended=False) == bytes.fromhex("44 00 00 00")


def test_mcp3204_decode_and_null_bit() -> None:
    assert mcp3204.decode(bytes.fromhex("FE 97 49 2E")) == 0x974  # hi-Z bits 7..1 of byte 0 ignored
    assert mcp3204.decode(bytes.fromhex("00 FF FF FE")) == 4095
    assert mcp3204.decode(bytes.fromhex("01 FF FF FE")) is None  # null bit set: wrong mode/framing
    assert mcp3204.decode(b"\x00\x01") is None
    assert mcp3204.decode(bytes.fromhex("00 0F FF")) is None  # no repeat: not this driver's frame


def _frame(code: int) -> bytes:
    """The MISO bytes the MCP3204 sends for ``code`` (DS21298E section 5.0)."""
    bits = [0] * 7 + [0] + [(code >> (11 - i)) & 1 for i in range(12)] + [(code >> i) & 1 for i in range(1, 12)]
    bits += [0] * (32 - len(bits))  # 7 hi-Z bits, the null bit, B11..B0, B1..B11, a zero
    return bytes(int("".join(map(str, bits[8 * k + 0 : 8 * k + 8])), 2) for k in range(4))


@given(code=st.integers(0, 4095), bit=st.integers(0, 31))
def test_the_lsb_first_repeat_catches_a_flipped_data_bit(code: int, bit: int) -> None:
    miso = _frame(code)
    assert mcp3204.decode(miso) == code and mcp3204.repeat_agrees(miso, code)
    flipped = bytearray(miso)
    flipped[bit // 8] ^= 0x80 >> (bit % 8)
    got = mcp3204.decode(bytes(flipped))
    # a flipped B1..B11, either copy, is caught; B0 (sent once) passes as one LSB; the null bit
    # is the framing's; hi-Z and trailing zeros carry nothing
    if got is not None and got != code:
        assert not mcp3204.repeat_agrees(bytes(flipped), got) or got ^ code == 1
    if got == code and not mcp3204.repeat_agrees(bytes(flipped), got):
        assert 20 <= bit <= 30  # the repeat's own bits


def test_pipelined_write_and_reply_layout() -> None:
    frames = [mcp3204.request(ch) for ch in range(4)]
    wire = bp.encode_transfers(frames)
    # docs/protocols.md 7.1: 02 -> 01; 13 64 00 00 00 -> 01 (?..? 0) (B11..B4) (B3..B0 B1..B4) (B5..B11 0); 03 -> 01
    assert wire[:7] == bytes.fromhex("02 13 60 00 00 00 03")
    assert wire == b"".join(b"\x02\x13" + f + b"\x03" for f in frames)
    assert len(wire) == 28 and bp.reply_length(frames) == 28
    reply = b"".join(b"\x01\x01" + bytes((0, c >> 8, c & 0xFF)) + b"\x01" for c in (1, 2, 3, 4))
    assert bp.decode_transfers(reply, [3] * 4) == [bytes((0, 0, c)) for c in (1, 2, 3, 4)]
    assert bp.decode_transfers(reply[:-1], [3] * 4) == "short"
    assert bp.decode_transfers(b"\x00" + reply[1:], [3] * 4) == "bad_ack"


def test_setup_commands() -> None:
    # 0x8A = 3.3 V outputs, idle low, CKE 1 (SPI mode 0); 0x63 = 1 MHz; 0x49 power on, CS high; 03 CS high
    assert bp.setup_commands(1_000_000) == bytes.fromhex("8A 63 49 03")
    assert bp.setup_commands(2_000_000)[1] == 0x64


@pytest.mark.parametrize("start_mode", ["terminal", "bbio", "spi"])
def test_entry_from_any_mode(start_mode: str) -> None:
    bridge, dev, port, out = _bridge()
    dev.mode = start_mode
    bridge.enter_spi()
    assert dev.mode == "spi" and bridge.in_sync
    # flashrom's entry: the zeros, then 00 -> BBIO1, 01 -> SPI1 and each setup command alone
    assert port.written == [bytes(20), b"\x00", b"\x01", b"\x8a", b"\x63", b"\x49", b"\x03"]
    assert dev.config_bytes == [0x8A, 0x63, 0x49]
    assert "event=adc.spi_mode attempts=1" in out.getvalue()


def _entry(seq: bp.EntrySequence, replies: list[bytes], dt_s: float = 0.001) -> list[tuple[bool, bytes]]:
    now = 0.0
    steps = [(True, seq.start(now))]
    for data in replies:
        now += dt_s
        steps.append(seq.step(data, now))
    return steps


def test_entry_sequence_golden_exchange() -> None:
    # DP wiki "SPI (binary)" / flashrom buspirate_spi_init: 00 -> BBIO1, 01 -> SPI1, then each
    # configuration command is acknowledged with 0x01.
    seq = bp.EntrySequence(bp.entry_script(1_000_000), quiet_s=0.0025, reply_timeout_s=0.1)
    steps = _entry(seq, [b"\r\nHiZ>", b"BBIO1", b"", b"", b"", b"BBIO1", b"SPI1", b"\x01", b"\x01", b"\x01", b"\x01"])
    writes = [w for _, w in steps if w]
    assert writes == [bytes(20), b"\x00", b"\x01", b"\x8a", b"\x63", b"\x49", b"\x03"]
    assert [f for f, w in steps if w] == [True, True, False, False, False, False, False]  # flush before 00
    assert seq.state is bp.EntryState.DONE and seq.drained == 11


def test_entry_sequence_byte_by_byte_and_with_garbage() -> None:
    script = bp.entry_script(1_000_000)
    seq = bp.EntrySequence(script, quiet_s=0.0025, reply_timeout_s=0.1)
    replies = [b"", b"", b"", *[bytes((c,)) for c in b"BBIO1"], *[bytes((c,)) for c in b"SPI1"], *[b"\x01"] * 4]
    _entry(seq, replies)
    assert seq.state is bp.EntryState.DONE
    for bad, reason in ((b"BBIO2", "00 answered 42 42 49 4f 32 (expected BBIO1)"),
                        (b"BBIO1B", "00 answered 42 42 49 4f 31 42 (expected BBIO1)"),
                        (b"\x01", "00 answered 01 (expected BBIO1)")):
        seq = bp.EntrySequence(script, quiet_s=0.0025, reply_timeout_s=0.1)
        _entry(seq, [b"", b"", b"", bad])
        assert seq.state is bp.EntryState.FAILED and seq.reason == reason


def test_entry_sequence_times_out_and_bounds_a_babbling_line() -> None:
    script = bp.entry_script(1_000_000)
    seq = bp.EntrySequence(script, quiet_s=0.0025, reply_timeout_s=0.01)
    _entry(seq, [b""] * 20)
    assert seq.state is bp.EntryState.FAILED and seq.reason == "no BBIO1 after 00 (got nothing)"
    seq = bp.EntrySequence(script, quiet_s=0.0025, reply_timeout_s=0.01)
    _entry(seq, [b"HiZ>"] * 20)  # never quiet
    assert seq.state is bp.EntryState.FAILED and seq.reason.startswith("line not quiet")


def test_ack_prefix_check() -> None:
    reply = b"".join(b"\x01\x01" + bytes((0, c >> 8, c & 0xFF)) + b"\x01" for c in (1, 2, 3, 4))
    assert all(bp.acks_ok(reply[:n], [3] * 4) for n in range(25))
    assert not bp.acks_ok(b"\x01\x00", [3] * 4)
    assert not bp.acks_ok(reply[:5] + b"\x00", [3] * 4)
    assert not bp.acks_ok(reply + b"\x01", [3] * 4)  # longer than the reply


def test_noise_on_the_zeros_answer_is_drained_and_on_a_reply_retried() -> None:
    bridge, dev, port, out = _bridge(attempts=3)
    dev.garbage_next = b"\x00garbage"  # the BBIO1 after the zeros is lost in line noise: drained
    bridge.enter_spi()
    assert bridge.in_sync and "event=adc.spi_mode attempts=1 speed_hz=1000000 drained=8" in out.getvalue()

    bridge, dev, port, out = _bridge(attempts=3)
    answer = port.on_write

    def noisy(data: bytes) -> None:
        if data == b"\x00" and not dev.config_bytes and "retry" not in out.getvalue():
            dev.garbage_next = b"BBI\xff1"  # the answer to the single 00 is garbled once
        answer(data)

    port.on_write = noisy
    bridge.enter_spi()
    assert bridge.in_sync
    assert 'event=adc.entry_retry attempt=1 reason="00 answered 42 42 49 ff 31 (expected BBIO1)"' in out.getvalue()


def test_dead_bridge_fails_boot_naming_the_adc() -> None:
    bridge, dev, _, _ = _bridge(attempts=2)
    dev.dead = True
    with pytest.raises(DeviceError) as err:
        bridge.enter_spi()
    assert err.value.device == "adc" and "2 attempt" in err.value.reason and "BBIO1" in err.value.reason


def _reader() -> tuple[Mcp3204Reader, BusPirateSpi, FakeBusPirate, FakeSerial]:
    bridge, dev, port, _ = _bridge()
    bridge.enter_spi()
    return Mcp3204Reader(bridge, (0, 1, 2, 3)), bridge, dev, port


def test_one_write_one_read_per_tick() -> None:
    reader, _, dev, port = _reader()
    writes, reads = len(port.written), port.reads
    assert reader.read_codes(0) == (2420, 2703, 2048, 1392)
    assert len(port.written) - writes == 1 and port.reads - reads == 1
    assert port.written[-1] == bytes.fromhex("02 13 60 00 00 00 03 02 13 64 00 00 00 03 02 13 68 00 00 00 03 02 13 6c 00 00 00 03")
    assert dev.transactions == 4


def test_channel_order_follows_the_map() -> None:
    bridge, dev, _, _ = _bridge()
    bridge.enter_spi()
    reader = Mcp3204Reader(bridge, (3, 0, 2, 1))
    assert reader.read_codes(0) == (1392, 2420, 2048, 2703)


def _until_codes(reader: Mcp3204Reader, port: FakeSerial, k0: int, limit: int = 200) -> int:
    """Samples from k0 until codes come back (each sample 0.5 ms of wall time); returns k."""
    for k in range(k0, k0 + limit):
        if reader.read_codes(k * TICK_NS) is not None:
            return k
        assert port.clock is not None
        port.clock.advance(0.0005)
    raise AssertionError("no codes")


def test_garbage_reply_resyncs_without_blocking_and_recovers() -> None:
    reader, bridge, dev, port = _reader()
    dev.garbage_next = b"\x01\x01\xff\xff\xff\xff\x00" * 4  # a bad ack in the last byte of each channel
    assert reader.read_codes(0) is None
    assert bridge.counters["bad_ack"] == 1 and not bridge.in_sync
    writes = len(port.written)
    k = _until_codes(reader, port, 1)
    # first reply_timeout_s for the rest of the garbled reply, then the zeros and quiet_s
    assert port.written[writes] == bytes(20) and bridge.counters["resyncs"] == 1
    assert k * 0.0005 >= 0.02 + 0.01
    assert bridge.in_sync and reader.read_codes((k + 1) * TICK_NS) == (2420, 2703, 2048, 1392)


def test_silent_bridge_is_retried_only_every_interval() -> None:
    reader, bridge, dev, port = _reader()
    dev.dead = True
    for k in range(400):  # one second of samples
        assert reader.read_codes(k * TICK_NS) is None
        assert port.clock is not None
        port.clock.advance(0.0005)
    assert bridge.counters["replies_lost"] == 1 and bridge.counters["requests"] == 1
    assert 1 <= bridge.counters["resync_failures"] <= 4  # per resync interval, not per sample
    dev.dead = False
    _until_codes(reader, port, 400, limit=400)
    assert reader.counters["reads"] == 1


def test_a_repeat_that_disagrees_is_no_reading_and_no_resync() -> None:
    reader, bridge, dev, port = _reader()
    good = bytes.fromhex("00 72 6c 9c")  # 1830 (0x726), as the MCP3204 model sends it
    assert mcp3204.decode(good) == 1830 and mcp3204.repeat_agrees(good, 1830)
    dev.garbage_next = (b"\x01\x01" + bytes.fromhex("00 62 6c 9c") + b"\x01") * 4  # B8 flipped on MISO
    assert reader.read_codes(0) is None
    assert reader.counters["repeat_errors"] == 1 and reader.counters["failed_reads"] == 1
    assert bridge.in_sync and bridge.counters["resyncs"] == 0  # a bit error, not the framing
    port.clock.advance(0.0025)
    assert reader.read_codes(TICK_NS) == (2420, 2703, 2048, 1392)


def test_null_bit_error_forces_a_resync() -> None:
    reader, bridge, dev, port = _reader()
    dev.garbage_next = (b"\x01\x01\x01\xff\xff\xfe\x01") * 4
    assert reader.read_codes(0) is None
    assert reader.counters["null_bit_errors"] == 1 and not bridge.in_sync
    _until_codes(reader, port, 1)
    assert bridge.counters["resyncs"] == 1


@settings(max_examples=40, deadline=None)
@given(garbage=st.binary(min_size=1, max_size=40))
def test_any_garbage_reply_never_raises(garbage: bytes) -> None:
    reader, bridge, dev, port = _reader()
    dev.garbage_next = garbage
    first = reader.read_codes(0)
    # either the garbage happened to be a valid-looking reply, or it was rejected; then recovery
    assert first is None or len(first) == 4
    k = _until_codes(reader, port, 1, limit=2000)
    assert reader.read_codes((k + 1) * TICK_NS) == (2420, 2703, 2048, 1392)
