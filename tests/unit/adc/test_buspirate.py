"""Bus Pirate v3 binary mode in front of the MCP3204, without a pty.

Byte vectors from the DP wiki "SPI (binary)" / "Bitbang" pages and the firmware
(DangerousPrototypes/Bus_Pirate Firmware/binIO.c, SPI.c, baseUI.c): 20 x 00 -> "BBIO1";
01 -> "SPI1"; 02/03 -> 01; 1x + n bytes -> 01 + n bytes; 04 wH wL rH rL + w bytes -> 01 + r
bytes or 00 at once for lengths > 4096; 8x/6x/4x -> 01; unknown -> 00; 0F -> 01 + reset.
MCP3204 request 06 40 00 from DS21298E Fig. 6-1.
"""

from __future__ import annotations

import hypothesis.strategies as st
from hypothesis import given, settings
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule

from emulators.buspirate import BusPirate, BusPirateParams, BusPirateProtocolError, BusPirateSpi, Mode
from emulators.buspirate.terminal import PROMPT
from emulators.mcp3204 import Mcp3204, Mcp3204Conversion, Mcp3204Params, fig61_decode, fig61_request

VOLTS = [5.0 * (0.009 * 101.325 - 0.095), 1.0, 2.5, 4.999]
CODES = [3346, 819, 2048, 4095]


def make(**kw: object) -> BusPirate:
    adc = Mcp3204(Mcp3204Params(), lambda ch, t: VOLTS[ch])
    bp = BusPirate(BusPirateParams(**kw), adc)  # type: ignore[arg-type]
    bp.take_output()  # the power-up banner, flushed by the host's open
    return bp


def talk(bp: BusPirate, data: bytes, t_ns: int = 0) -> bytes:
    bp.receive(data, t_ns)
    return bp.take_output()


def spi_ready(**kw: object) -> BusPirate:
    bp = make(**kw)
    assert talk(bp, b"\x00" * 20 + b"\x01") == b"BBIO1SPI1"
    assert talk(bp, b"\x8a") == b"\x01"  # 3.3 V push-pull, idle low, active-to-idle: mode 0
    return bp


def read_channel(bp: BusPirate, ch: int) -> int:
    rx = talk(bp, b"\x02\x12" + fig61_request(ch) + b"\x03")
    assert rx[:2] == b"\x01\x01" and rx[-1:] == b"\x01"
    return fig61_decode(rx[2:5])


def test_power_up_banner_parses_like_flashrom() -> None:
    adc = Mcp3204(Mcp3204Params(), lambda ch, t: 0.0)
    banner = BusPirate(BusPirateParams(), adc).take_output().decode()
    # flashrom: the word after "irate ", the word after "irmware ", then "HiZ>".
    hw = banner.split("irate ", 1)[1].split()[0]
    fw = banner.split("irmware ", 1)[1].split()[0]
    assert (hw, fw) == ("v3.5", "v6.1")
    assert banner.endswith("HiZ>")
    assert "Bus Pirate v3.5\r\n" in banner and "Firmware v6.1 " in banner


def test_twenty_zeros_and_not_nineteen() -> None:
    bp = make()
    assert talk(bp, b"\x00" * 19) == b""
    assert bp.mode is Mode.TERMINAL
    assert talk(bp, b"\x00") == b"BBIO1"
    assert talk(bp, b"\x00") == b"BBIO1"  # every further 00 in BBIO answers again


def test_zeros_fragmented_and_terminal_text_echoed() -> None:
    bp = make()
    out = b"".join(talk(bp, b"\x00") for _ in range(10))
    out += talk(bp, b"hi\x08\r")  # echoed, erased, then a syntax error and the prompt
    assert out == b"hi\x08 \x08\r\nSyntax error at char 1\r\n" + PROMPT
    assert talk(bp, b"\x00" * 10) == b"BBIO1"  # the count is cumulative until a reset


def test_terminal_i_and_reset_commands() -> None:
    bp = make()
    assert talk(bp, b"i\r").startswith(b"i\r\nBus Pirate v3.5\r\n")
    assert talk(bp, b"\r") == b"\r\n" + PROMPT
    out = talk(bp, b"#\r")
    assert out.startswith(b"#\r\nRESET\r\n\r\nBus Pirate v3.5") and out.endswith(PROMPT)
    assert talk(bp, b"\x01\x1b[A") == b"\x07"  # control char: bell; arrow key: swallowed


def test_spi_entry_exit_and_reset_to_terminal() -> None:
    bp = make()
    assert talk(bp, b"\x00" * 20 + b"\x01\x01\x00\x01") == b"BBIO1SPI1SPI1BBIO1SPI1"
    assert talk(bp, b"\x00\x0f") == b"BBIO1\x01\r\nBus Pirate v3.5\r\n" + talk_banner_tail()
    assert bp.mode is Mode.TERMINAL
    assert talk(bp, b"\x00" * 20) == b"BBIO1"


def talk_banner_tail() -> bytes:
    return (
        b"Firmware v6.1 r1676  Bootloader v4.4\r\n"
        b"DEVID:0x0447 REVID:0x3046 (24FJ64GA002 B8)\r\nhttp://dangerousprototypes.com\r\nHiZ>"
    )


def test_golden_reads_all_channels() -> None:
    bp = spi_ready()
    assert [read_channel(bp, ch) for ch in range(4)] == CODES
    # pipelined in one write, as docs/protocols.md §7.1 and flashrom's old-firmware path do
    rx = talk(bp, bytes.fromhex("02 13 06 40 00 00 03"))
    assert rx == bytes.fromhex("01 01 00 03 33 99 01")  # 4th byte: B1..B8 LSB first
    ev = bp.take_events()
    assert [e.code for e in ev if isinstance(e, Mcp3204Conversion)] == CODES + [819]
    assert [e.mosi for e in ev if isinstance(e, BusPirateSpi)][-1] == bytes.fromhex("06 40 00 00")


def test_byte_by_byte_and_with_garbage_between() -> None:
    bp = spi_ready()
    stream = b"\x02\x12" + fig61_request(2) + b"\x03"
    rx = b"".join(talk(bp, bytes([b])) for b in stream)
    assert fig61_decode(rx[2:5]) == 2048
    # garbage between transactions: unknown commands answer 00 and change nothing
    assert talk(bp, b"\x07\x20\x3f\xa5") == b"\x00\x00\x00\x00"
    assert read_channel(bp, 1) == 819
    assert bp.counters["unknown_spi_command"] == 4
    assert sum(isinstance(e, BusPirateProtocolError) for e in bp.take_events()) == 4


def test_cs_never_raised_between_conversions_is_answered_like_the_part() -> None:
    bp = spi_ready()
    rx = talk(bp, b"\x02\x12" + fig61_request(1) + b"\x12" + fig61_request(1) + b"\x03")
    assert fig61_decode(rx[2:5]) == CODES[1]
    trailer = f"{CODES[1]:012b}"[::-1][1:] + "0" * 13  # B1..B11 LSB first, then zeros
    assert rx[6:9] == int(trailer, 2).to_bytes(3, "big")  # no new conversion
    assert bp.counters["mcp3204_cs_not_raised_between_conversions"] == 1
    assert bp.counters["mcp3204_conversions"] == 1 and bp.counters["mcp3204_protocol_errors"] == 1


def test_write_then_read_with_and_without_cs_and_length_checks() -> None:
    bp = spi_ready()
    # Linux mcp320x style through 04: write 1 byte, read 2 (the firmware clocks 0xFF).
    rx = talk(bp, bytes([0x04, 0, 1, 0, 2, 1 << 6 | 1 << 5 | 2 << 2]))
    assert rx[0] == 1 and (rx[1] << 4 | rx[2] >> 4) == 2048
    # 05 leaves CS alone: frame it with 02/03 ourselves
    rx = talk(bp, b"\x02" + bytes([0x05, 0, 3, 0, 0]) + fig61_request(0) + b"\x03")
    assert rx == b"\x01\x01\x01"  # CS, 05 ack (no read bytes), CS
    # out of range: 00 at once; the firmware then reads the would-be data as commands
    assert talk(bp, bytes([0x04, 0x10, 0x01, 0x00, 0x01]) + b"\x01") == b"\x00SPI1"
    assert talk(bp, bytes([0x04, 0x00, 0x00, 0x10, 0x01])) == b"\x00"
    rx = talk(bp, bytes([0x04, 0x00, 0x00, 0x10, 0x00]))  # 4096 is still allowed
    assert len(rx) == 4097 and rx[0] == 1
    assert bp.counters["write_then_read_bad_length"] == 2
    # fragmented header and data
    out = b"".join(talk(bp, bytes([b])) for b in bytes([0x04, 0, 3, 0, 0]) + fig61_request(1))
    assert out == b"\x01"


def test_config_sets_the_spi_mode_of_the_exchange() -> None:
    bp = spi_ready()
    assert talk(bp, b"\x8c") == b"\x01" and bp.spi_mode == 3  # idle high, CKE 0
    assert [read_channel(bp, ch) for ch in range(4)] == CODES
    for cfg, mode in ((0x88, 1), (0x8E, 2)):  # wrong clock phase: data one bit late
        assert talk(bp, bytes([cfg])) == b"\x01" and bp.spi_mode == mode
        assert read_channel(bp, 0) == CODES[0] >> 1
    assert talk(bp, b"\x8a") == b"\x01" and read_channel(bp, 0) == CODES[0]


def test_open_drain_default_needs_pullups_or_push_pull() -> None:
    bp = make()
    assert talk(bp, b"\x00" * 20 + b"\x01") == b"BBIO1SPI1"
    assert read_channel(bp, 0) == 0  # HiZ outputs, no pull-ups: the part sees nothing
    assert bp.counters["spi_bytes_lines_undriven"] == 3
    assert talk(bp, b"\x4c") == b"\x01"  # power + pull-ups on
    assert read_channel(bp, 0) == CODES[0]
    bp2 = make(target_pullups=True)
    talk(bp2, b"\x00" * 20 + b"\x01")
    assert read_channel(bp2, 0) == CODES[0]


def test_peripherals_speed_and_readbacks() -> None:
    bp = spi_ready()
    assert talk(bp, b"\x4b\x63\x50\x70\x90") == b"\x01\x01\x4b\x63\x8a"
    assert bp.sck_Hz == 1_000_000
    assert talk(bp, b"\x67") == b"\x01" and round(bp.sck_Hz) == 125_000  # v6.1's broken "8 MHz"
    assert talk(bp, b"\x68") == b"\x00"  # 01101xxx is not a speed command
    bp2 = spi_ready(readback_commands=False, firmware="v6.2 r2151")
    assert talk(bp2, b"\x50\x70\x90") == b"\x00\x00\x00"
    assert talk(bp2, b"\x67") == b"\x01" and bp2.sck_Hz == 8_000_000


def test_sniffer_other_modes_and_selftest() -> None:
    bp = spi_ready()
    assert talk(bp, b"\x0e") == b"\x01" and bp.mode is Mode.SNIFF
    assert talk(bp, b"\x55\x01") == b"SPI1"  # the first byte ends the sniffer
    assert talk(bp, b"\x00\x02\x42\x01\x00") == b"BBIO1I2C1I2C1BBIO1"
    assert talk(bp, b"\x10\x05\xff") == b"\x00\x05\x01"
    assert talk(bp, b"\x12\x01\x02\x03\x04\x05\x13\x14\x16") == b"\x01\x01\x00\x00" + b"\x00" * 4
    assert talk(bp, b"\x08\x17") == b"\x00\x00"
    assert bp.counters["unknown_bbio_command"] == 2


def test_adc_stream_follows_uart_rate_until_a_byte() -> None:
    bp = make()
    talk(bp, b"\x00" * 20)
    talk(bp, b"\x15", t_ns=1_000_000)
    bp.advance(1_000_000 + 2 * 86_805 * 10)  # 10 pairs of bytes at 115200 8N1
    assert bp.take_output() == b"\x00" * 20
    assert talk(bp, b"\x00", t_ns=3_000_000) == b"" and bp.mode is Mode.BBIO


def test_bitbang_pins_read_the_mcp3204() -> None:
    bp = make()
    talk(bp, b"\x00" * 20)
    # outputs: CS, CLK, MOSI (dir bit 0); MISO and AUX inputs: 010 1 0 0 1 0 = 0x52
    assert talk(bp, b"\x52")[0] & 0xE0 == 0x40
    talk(bp, bytes([0x80 | 0x01]))  # CS high
    bits = []
    talk(bp, b"\x80")  # CS low, CLK low
    for bit in f"{int.from_bytes(fig61_request(0), 'big'):024b}":
        mosi = 0x08 if bit == "1" else 0
        talk(bp, bytes([0x80 | mosi]))
        read = talk(bp, bytes([0x80 | mosi | 0x04]))[0]  # CLK high: the part latched DIN
        bits.append("1" if read & 0x02 else "0")
    talk(bp, bytes([0x81]))
    assert int("".join(bits), 2) & 0xFFF == CODES[0]


def test_wrong_baud_is_dropped() -> None:
    bp = make()
    bp.line_settings_changed(9600, 0)
    assert talk(bp, b"\x00" * 40) == b""
    assert bp.counters["bytes_at_wrong_baud"] == 40
    bp.line_settings_changed(115200, 0)
    assert talk(bp, b"\x00" * 20) == b"BBIO1"


@settings(deadline=None, max_examples=60)
@given(st.binary(max_size=300), st.lists(st.integers(1, 40), max_size=30))
def test_fragmentation_never_changes_the_answer_nor_raises(data: bytes, cuts: list[int]) -> None:
    prefix = b"\x00" * 20 + b"\x01\x8a"
    whole = make()
    expect = talk(whole, prefix + data)
    split = make()
    out, pos = bytearray(talk(split, prefix)), 0
    for n in cuts:
        out += talk(split, data[pos : pos + n])
        pos += n
    out += talk(split, data[pos:])
    assert bytes(out) == expect
    assert whole.mode is split.mode


class ModeMachine(RuleBasedStateMachine):
    """Single-byte commands against a model of the firmware's mode loop."""

    def __init__(self) -> None:
        super().__init__()
        self.bp = make()
        self.mode = Mode.TERMINAL
        self.zeros = 0
        self.line = 0

    def send(self, byte: int) -> bytes:
        return talk(self.bp, bytes([byte]))

    @rule(byte=st.sampled_from([0x00, 0x01, 0x02, 0x03, 0x0F, ord("a"), 0x0D]))
    def command(self, byte: int) -> None:
        out = self.send(byte)
        m = self.mode
        if m is Mode.TERMINAL:
            if byte == 0:
                self.zeros += 1
                expect = b"BBIO1" if self.zeros == 20 else b""
                self.mode = Mode.BBIO if self.zeros == 20 else m
            elif byte == ord("a"):
                self.line += 1
                expect = b"a"
            elif byte == 0x0D:
                expect = b"\r\n" + (b"Syntax error at char 1\r\n" if self.line else b"") + PROMPT
                self.line = 0
            else:
                expect = b"\x07"
            assert out == expect
        elif m is Mode.BBIO:
            table = {0x00: (b"BBIO1", m), 0x01: (b"SPI1", Mode.SPI), 0x02: (b"I2C1", Mode.OTHER),
                     0x03: (b"ART1", Mode.OTHER), 0x0D: (b"\x00", m)}
            if byte in table:
                assert out == table[byte][0]
                self.mode = table[byte][1]
            elif byte == 0x0F:
                assert out.startswith(b"\x01\r\nBus Pirate") and out.endswith(PROMPT)
                self.mode, self.zeros, self.line = Mode.TERMINAL, 0, 0
            else:
                assert len(out) == 1  # pin direction: the pin read
        elif m is Mode.SPI:
            table = {0x00: (b"BBIO1", Mode.BBIO), 0x01: (b"SPI1", m), 0x02: (b"\x01", m), 0x03: (b"\x01", m),
                     0x0F: (b"\x00", m), ord("a"): (b"\x01", m), 0x0D: (b"\x01", Mode.SNIFF)}
            assert out == table[byte][0]
            self.mode = table[byte][1]
        elif m is Mode.OTHER:
            table = {0x00: (b"BBIO1", Mode.BBIO), 0x01: (self.bp._other_version, m)}
            assert out == table.get(byte, (b"", m))[0]
            self.mode = table.get(byte, (b"", m))[1]
        elif m is Mode.SNIFF:
            assert out == b""
            self.mode = Mode.SPI

    @invariant()
    def same_mode(self) -> None:
        assert self.bp.mode is self.mode


TestModeMachine = ModeMachine.TestCase
TestModeMachine.settings = settings(max_examples=40, stateful_step_count=60, deadline=None)
