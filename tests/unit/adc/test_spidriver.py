"""SPIDriver protocol in front of the MCP3204, driven by the unmodified PyPI client in-process.

Sources: jamesbowman/spidriver firmware/main.fs (``service``: '?', 'e', 's', 'u', 'a', 'b',
'x', 0x80+n-1 transfers, 0xC0+n-1 writes; ``info``: the 80-byte status with the CRC16 of
all SPI bytes), c/common/spidriver.c (the host's CCITT table, used here as the oracle),
the PyPI client spidriver 1.1.1 (unmodified, with its serial port replaced by a loopback
onto the emulator).
"""

from __future__ import annotations

from collections import deque

import hypothesis.strategies as st
import pytest
import spidriver
from hypothesis import given, settings

from emulators.mcp3204 import Mcp3204, Mcp3204Params, fig61_decode, fig61_request
from emulators.spidriver import SpiDriver, SpiDriverParams, SpiDriverSpi

VOLTS = [5.0 * (0.009 * 101.325 - 0.095), 1.0, 2.5, 4.999]
CODES = [3346, 819, 2048, 4095]


def make(**kw: object) -> SpiDriver:
    adc = Mcp3204(Mcp3204Params(), lambda ch, t: VOLTS[ch])
    return SpiDriver(SpiDriverParams(**kw), adc)  # type: ignore[arg-type]


class Loopback:
    """The part of pyserial's Serial the client uses, wired straight to the emulator."""

    def __init__(self, dev: SpiDriver) -> None:
        self.dev = dev
        self.rx: deque[int] = deque()

    def write(self, data: bytes) -> int:
        self.dev.receive(bytes(data), 0)
        self.rx.extend(self.dev.take_output())
        return len(data)

    def read(self, n: int = 1) -> bytes:
        return bytes(self.rx.popleft() for _ in range(min(n, len(self.rx))))

    def inWaiting(self) -> int:  # noqa: N802 - pyserial's name
        return len(self.rx)


@pytest.fixture
def client(monkeypatch: pytest.MonkeyPatch) -> tuple[spidriver.SPIDriver, SpiDriver]:
    dev = make()
    monkeypatch.setattr(spidriver.serial, "Serial", lambda *a, **k: Loopback(dev))
    return spidriver.SPIDriver("/dev/null"), dev


def c_host_crc(data: bytes, crc: int) -> int:
    """crc_update() of c/common/spidriver.c with its table generated from polynomial 0x1021."""
    table = []
    for i in range(256):
        c = i << 8
        for _ in range(8):
            c = ((c << 1) ^ 0x1021) if c & 0x8000 else c << 1
        table.append(c & 0xFFFF)
    for b in data:
        crc = (table[((crc >> 8) ^ b) & 0xFF] ^ (crc << 8)) & 0xFFFF
    return crc


def test_client_connects_and_parses_status(client: tuple[spidriver.SPIDriver, SpiDriver]) -> None:
    s, dev = client
    assert (s.product, s.serial, s.uptime, s.voltage, s.temp) == ("spidriver2", "DO01JUHT", 5, 5.012, 26.3)
    assert (s.a, s.b, s.cs, s.mode, s.ccitt_crc) == (1, 1, 1, 0, 0xFFFF)
    line = dev.status_line(0)
    assert len(line) == 80 and line[:1] == b"[" and line[-1:] == b"]"


def test_client_reads_all_four_channels(client: tuple[spidriver.SPIDriver, SpiDriver]) -> None:
    s, dev = client
    codes = []
    for ch in range(4):
        s.sel()
        codes.append(fig61_decode(s.writeread(fig61_request(ch))))
        s.unsel()
    assert codes == CODES
    # Linux framing with the client's write() then read() (which clocks 0xFF)
    s.sel()
    s.write(bytes([1 << 6 | 1 << 5 | 1 << 2]))
    rx = s.read(2)
    s.unsel()
    assert (rx[0] << 4 | rx[1] >> 4) == 819
    assert dev.counters["transfers"] == 5 and dev.counters["writes"] == 1


def test_crc_covers_mosi_then_miso_like_the_c_host(client: tuple[spidriver.SPIDriver, SpiDriver]) -> None:
    s, dev = client
    expect = s.ccitt_crc
    s.sel()
    rx = s.writeread(fig61_request(0))
    s.write(b"\x12\x34")
    s.unsel()
    expect = c_host_crc(rx, c_host_crc(fig61_request(0), expect))
    expect = c_host_crc(b"\x12\x34", expect)
    s.getstatus()
    assert s.ccitt_crc == expect == dev.crc


def test_pins_mode_and_detach(client: tuple[spidriver.SPIDriver, SpiDriver]) -> None:
    s, dev = client
    s.seta(0)
    s.setb(0)
    s.sel()
    s.getstatus()
    assert (s.a, s.b, s.cs) == (0, 0, 0)
    s.unsel()
    s.setmode(3)
    s.getstatus()
    assert s.mode == 3
    s.sel()
    assert fig61_decode(s.writeread(fig61_request(1))) == 819
    s.unsel()
    s.setmode(1)  # wrong clock phase: the data arrive one bit late
    s.sel()
    assert fig61_decode(s.writeread(fig61_request(1))) == 819 >> 1
    s.unsel()
    s.setmode(0)
    s.detach()
    assert not dev.attached
    s.sel()  # drives the outputs again
    assert dev.attached and fig61_decode(s.writeread(fig61_request(2))) == 2048
    s.unsel()


def test_spidriver1_identity_has_ten_fields_and_ignores_m() -> None:
    dev = make(product="spidriver1")
    dev.receive(b"?", 0)
    fields = dev.take_output()[1:-1].decode().split()
    assert len(fields) == 10 and fields[0] == "spidriver1"
    dev.receive(b"m\x03", 0)
    assert dev.mode == 0 and dev.counters["ignored_bytes"] == 2  # "m" unknown, then 03 ignored too


def test_flush_echo_unknown_and_fragments() -> None:
    dev = make()
    dev.receive(b"@" * 64, 0)
    assert dev.take_output() == b"" and dev.counters["ignored_bytes"] == 0
    for b in (0x55, 0x00, 0xFF, 0xAA):
        dev.receive(b"e", 0)
        dev.receive(bytes([b]), 0)
        assert dev.take_output() == bytes([b])
    dev.receive(b"Z!", 0)
    assert dev.counters["ignored_bytes"] == 2
    out = b""
    for b in b"s\x82" + fig61_request(3) + b"u":
        dev.receive(bytes([b]), 7)
        out += dev.take_output()
    assert fig61_decode(out) == 4095
    spi = [e for e in dev.take_events() if isinstance(e, SpiDriverSpi)]
    assert spi[-1] == SpiDriverSpi(7, fig61_request(3), out)


def test_uptime_follows_sim_time() -> None:
    dev = make()
    assert dev.status_line(62_500_000_000)[20:31] == b" 000000067 "


def test_wrong_baud_is_dropped() -> None:
    dev = make()
    dev.line_settings_changed(115200, 0)
    dev.receive(b"e\x55", 0)
    assert dev.take_output() == b"" and dev.counters["bytes_at_wrong_baud"] == 2


@settings(deadline=None, max_examples=60)
@given(st.binary(max_size=300), st.lists(st.integers(1, 70), max_size=20))
def test_fragmentation_never_changes_the_answer_nor_raises(data: bytes, cuts: list[int]) -> None:
    whole = make()
    whole.receive(data, 0)
    split = make()
    pos = 0
    for n in cuts:
        split.receive(data[pos : pos + n], 0)
        pos += n
    split.receive(data[pos:], 0)
    assert split.take_output() == whole.take_output()
    assert split.crc == whole.crc
