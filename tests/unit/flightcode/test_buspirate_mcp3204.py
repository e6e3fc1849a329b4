"""Bus Pirate binary SPI and the MCP3204 reader: entry, pipelined reads, resync without crashing."""

from __future__ import annotations

import io

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.drivers import buspirate_spi as bp
from flightcode.drivers import mcp3204
from flightcode.drivers.base import DeviceError
from flightcode.drivers.buspirate_spi import BusPirateSpi
from flightcode.drivers.mcp3204 import Mcp3204Reader
from flightcode.log import Logger
from tests.unit.flightcode.fakes import FakeBusPirate, FakeSerial

CODES = {0: 2420, 1: 2703, 2: 2048, 3: 1392}


def _bridge(attempts: int = 2) -> tuple[BusPirateSpi, FakeBusPirate, FakeSerial, io.StringIO]:
    port = FakeSerial("adc")
    dev = FakeBusPirate(port, lambda ch: CODES[ch])
    out = io.StringIO()
    return BusPirateSpi(port, speed_hz=1_000_000, entry_attempts=attempts, reply_timeout_s=0.02,
                        log=Logger(out)), dev, port, out


def test_mcp3204_requests_match_the_datasheet_framing() -> None:
    # protocols.md 2: single-ended CH0..CH3 = 06 00 00, 06 40 00, 06 80 00, 06 C0 00.
    assert [mcp3204.request(ch).hex(" ") for ch in range(4)] == ["06 00 00", "06 40 00", "06 80 00", "06 c0 00"]
    assert mcp3204.request(1, single_ended=False) == bytes.fromhex("04 40 00")


def test_mcp3204_decode_and_null_bit() -> None:
    assert mcp3204.decode(bytes.fromhex("FF E9 74")) == 0x974  # hi-Z bits 7..5 ignored
    assert mcp3204.decode(bytes.fromhex("00 0F FF")) == 4095
    assert mcp3204.decode(bytes.fromhex("00 1F FF")) is None  # null bit set: wrong mode/framing
    assert mcp3204.decode(b"\x00\x01") is None


def test_pipelined_write_and_reply_layout() -> None:
    frames = [mcp3204.request(ch) for ch in range(4)]
    wire = bp.encode_transfers(frames)
    # protocols.md 7.1: 02 -> 01; 12 06 40 00 -> 01 ?? (0 B11..B8) (B7..B0); 03 -> 01
    assert wire[:6] == bytes.fromhex("02 12 06 00 00 03")
    assert wire == b"".join(b"\x02\x12" + f + b"\x03" for f in frames)
    assert len(wire) == 24 and bp.reply_length(frames) == 24
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
    assert port.written[0] == bytes(20) and port.written[1] == b"\x01"
    assert dev.config_bytes == [0x8A, 0x63, 0x49]
    assert "event=adc.spi_mode attempts=1" in out.getvalue()


def test_entry_reply_check() -> None:
    assert bp.entry_reply_ok(b"BBIO1SPI1")
    assert bp.entry_reply_ok(b"\r\nHiZ>BBIO1BBIO1BBIO1SPI1")
    assert not bp.entry_reply_ok(b"BBIO1xSPI1")
    assert not bp.entry_reply_ok(b"SPI1")
    assert not bp.entry_reply_ok(b"BBIO1BBIO1")


def test_entry_retries_then_succeeds() -> None:
    bridge, dev, port, out = _bridge(attempts=3)
    dev.garbage_next = b"\x00garbage"  # first BBIO1 reply is lost in line noise
    bridge.enter_spi()
    assert bridge.in_sync
    assert "event=adc.entry_retry attempt=1" in out.getvalue()


def test_dead_bridge_fails_boot_naming_the_adc() -> None:
    bridge, dev, _, _ = _bridge(attempts=2)
    dev.dead = True
    with pytest.raises(DeviceError) as err:
        bridge.enter_spi()
    assert err.value.device == "adc" and "2 attempt" in err.value.reason and "BBIO1" in err.value.reason


def _reader() -> tuple[Mcp3204Reader, BusPirateSpi, FakeBusPirate, FakeSerial]:
    bridge, dev, port, _ = _bridge()
    bridge.enter_spi()
    reader = Mcp3204Reader(bridge, (0, 1, 2, 3), resync_interval_ns=250_000_000, resync_timeout_s=0.01)
    return reader, bridge, dev, port


def test_one_write_one_read_per_tick() -> None:
    reader, _, dev, port = _reader()
    writes, reads = len(port.written), port.reads
    assert reader.read_codes(0) == (2420, 2703, 2048, 1392)
    assert len(port.written) - writes == 1 and port.reads - reads == 1
    assert dev.transactions == 4


def test_channel_order_follows_the_map() -> None:
    bridge, dev, _, _ = _bridge()
    bridge.enter_spi()
    reader = Mcp3204Reader(bridge, (3, 0, 2, 1), resync_interval_ns=1, resync_timeout_s=0.01)
    assert reader.read_codes(0) == (1392, 2420, 2048, 2703)


def test_garbage_reply_resyncs_next_tick_and_recovers() -> None:
    reader, bridge, dev, port = _reader()
    dev.garbage_next = b"\x01\x01\xff\xff\xff\x00" * 4  # a bad ack in the third byte of each channel
    assert reader.read_codes(0) is None
    assert bridge.counters["bad_ack"] == 1 and not bridge.in_sync
    assert reader.read_codes(2_500_000) == (2420, 2703, 2048, 1392)  # re-entered SPI mode first
    assert bridge.counters["resyncs"] == 1 and bridge.in_sync


def test_silent_bridge_is_retried_only_every_interval() -> None:
    reader, bridge, dev, _ = _reader()
    dev.dead = True
    assert reader.read_codes(0) is None  # short reply
    assert reader.read_codes(2_500_000) is None  # resync attempt fails
    assert bridge.counters["resync_failures"] == 1
    for k in range(2, 100):  # within the 250 ms interval: no further attempt
        assert reader.read_codes(k * 2_500_000) is None
    assert bridge.counters["resyncs"] == 1 and reader.counters["skipped_out_of_sync"] == 98
    dev.dead = False
    assert reader.read_codes(255_000_000) == (2420, 2703, 2048, 1392)
    assert bridge.counters["resyncs"] == 2


def test_null_bit_error_forces_a_resync() -> None:
    reader, bridge, dev, _ = _reader()
    dev.garbage_next = (b"\x01\x01\x00\x1f\xff\x01") * 4
    assert reader.read_codes(0) is None
    assert reader.counters["null_bit_errors"] == 1 and not bridge.in_sync
    assert reader.read_codes(2_500_000) is not None


@settings(max_examples=40, deadline=None)
@given(garbage=st.binary(min_size=1, max_size=40))
def test_any_garbage_reply_never_raises(garbage: bytes) -> None:
    reader, bridge, dev, _ = _reader()
    dev.garbage_next = garbage
    first = reader.read_codes(0)
    # either the garbage happened to be a valid-looking reply, or it was rejected; then recovery
    assert first is None or len(first) == 4
    assert reader.read_codes(2_500_000) == (2420, 2703, 2048, 1392) or reader.read_codes(5_000_000) == (
        2420, 2703, 2048, 1392)
