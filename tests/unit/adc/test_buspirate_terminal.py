"""The Bus Pirate v3 terminal (firmware v6.1): byte-exact transcripts of ``b``, ``i``, ``?``,
``#`` and ``m``, the UART rate switch, and a property test of the prompts.

Expected bytes are written out here from public documentation, not from the emulator: the
firmware's v3 string table (DangerousPrototypes/Bus_Pirate
Firmware/translations/v3_bpstrings_en_US.txt: BPMSG1085 "Ready", 1093 "RESET", 1110 "Syntax
error at char ", 1111 "x. exit(without change)", 1112 "no mode change", 1133 the speed menu,
1134 "Adjust your terminal", 1211 "\\r\\nInvalid choice, try again", 1251 "Space to continue",
HLP1000-1022 the help table; the second field 1 = followed by CR LF), its terminal code
(baseUI.c serviceuser: echo, CR LF on Enter, the prompt "HiZ>"; getnumber: "\\r\\n(" default
")>", four digits at most, x leaves at once; setBaudRate: "Enter raw value for BRG", default 34;
the v3 UART at Fcy / 4 / (BRG + 1) = 4 MHz / (BRG + 1)), and the DP wiki "Bus Pirate menu
options guide" transcripts of "?" and "i".
"""

from __future__ import annotations

import hypothesis.strategies as st
from hypothesis import given, settings

from emulators.buspirate import BusPirate, BusPirateParams, BusPirateUartRate
from emulators.buspirate.terminal import State
from emulators.mcp3204 import Mcp3204, Mcp3204Params

SPEED_MENU = (
    b"Set serial port speed: (bps)\r\n"
    b" 1. 300\r\n 2. 1200\r\n 3. 2400\r\n 4. 4800\r\n 5. 9600\r\n 6. 19200\r\n 7. 38400\r\n 8. 57600\r\n 9. 115200\r\n"
    b"10. BRG raw value\r\n"
)
CONFIRM = b"Adjust your terminal\r\nSpace to continue\r\n"
VERSION = (
    b"Bus Pirate v3.5\r\n"
    b"Firmware v6.1 r1676  Bootloader v4.4\r\n"
    b"DEVID:0x0447 REVID:0x3046 (24FJ64GA002 B8)\r\n"
    b"http://dangerousprototypes.com\r\n"
)
HELP = (
    b" General\t\t\t\t\tProtocol interaction\r\n"
    b" ---------------------------------------------------------------------------\r\n"
    b" ?\tThis help\t\t\t(0)\tList current macros\r\n"
    b" =X/|X\tConverts X/reverse X\t\t(x)\tMacro x\r\n"
    b" ~\tSelftest\t\t\t[\tStart\r\n"
    b" #\tReset\t\t\t\t]\tStop\r\n"
    b" $\tJump to bootloader\t\t{\tStart with read\r\n"
    b" &/%\tDelay 1 us/ms\t\t\t}\tStop\r\n"
    b" a/A/@\tAUXPIN (low/HI/READ)\t\t\"abc\"\tSend string\r\n"
    b" b\tSet baudrate\t\t\t123\r\n"
    b" c/C\tAUX assignment (aux/CS)\t\t0x123\r\n"
    b" d/D\tMeasure ADC (once/CONT.)\t0b110\tSend value\r\n"
    b" f\tMeasure frequency\t\tr\tRead\r\n"
    b" g/S\tGenerate PWM/Servo\t\t/\tCLK hi\r\n"
    b" h\tCommandhistory\t\t\t\\\tCLK lo\r\n"
    b" i\tVersioninfo/statusinfo\t\t^\tCLK tick\r\n"
    b" l/L\tBitorder (msb/LSB)\t\t-\tDAT hi\r\n"
    b" m\tChange mode\t\t\t_\tDAT lo\r\n"
    b" o\tSet output type\t\t\t.\tDAT read\r\n"
    b" p/P\tPullup resistors (off/ON)\t!\tBit read\r\n"
    b" s\tScript engine\t\t\t:\tRepeat e.g. r:10\r\n"
    b" v\tShow volts/states\t\t.\tBits to read/write e.g. 0x55.2\r\n"
    b" w/W\tPSU (off/ON)\t\t<x>/<x= >/<0>\tUsermacro x/assign x/list all\r\n"
)
MODES = (
    b"1. HiZ\r\n2. 1-WIRE\r\n3. UART\r\n4. I2C\r\n5. SPI\r\n6. 2WIRE\r\n7. 3WIRE\r\n8. LCD\r\n9. DIO\r\n"
    b"x. exit(without change)\r\n"
)


def make() -> BusPirate:
    bp = BusPirate(BusPirateParams(), Mcp3204(Mcp3204Params(), lambda ch, t: 1.0))
    bp.take_output()
    bp.line_settings_changed(115200, 0)  # the host opened at the power-up rate
    return bp


def talk(bp: BusPirate, data: bytes, one_at_a_time: bool = False) -> bytes:
    out = bytearray()
    for chunk in ([bytes([b]) for b in data] if one_at_a_time else [data]):
        bp.receive(chunk, 0)
        out += bp.take_output()
    return bytes(out)


# -- b: the PC-side speed menu -------------------------------------------------------------------
def test_b_preset_transcript_and_the_switch() -> None:
    bp = make()
    assert talk(bp, b"b\r") == b"b\r\n" + SPEED_MENU + b"\r\n(9)>"
    assert talk(bp, b"8\r") == b"8\r\n" + CONFIRM
    assert bp.uart_baud_bps == 57600
    assert [e for e in bp.take_events() if isinstance(e, BusPirateUartRate)] == [BusPirateUartRate(0, 57600)]
    # the host still at 115200: framing errors, dropped (its space does not count)
    assert talk(bp, b" ") == b""
    assert bp.counters["bytes_at_wrong_baud"] == 1
    bp.line_settings_changed(57600, 0)  # the host follows (termios on the pty)
    assert talk(bp, b"zz") == b""  # anything but a space is read and dropped
    assert talk(bp, b" ") == b"HiZ>"
    assert talk(bp, b"i\r") == b"i\r\n" + VERSION + b"HiZ>"


def test_b_option_10_raw_brg_transcript() -> None:
    bp = make()
    out = talk(bp, b"b\r10\r3\r", one_at_a_time=True)
    assert out == (b"b\r\n" + SPEED_MENU + b"\r\n(9)>10\r\n" + b"Enter raw value for BRG\r\n" + b"\r\n(34)>3\r\n"
                   + CONFIRM)
    assert bp.uart_baud_bps == 1_000_000  # 4 MHz / (3 + 1)
    bp.line_settings_changed(1_000_000, 0)
    assert talk(bp, b" ") == b"HiZ>"


def test_b_brg_default_and_two_mbaud() -> None:
    bp = make()
    assert talk(bp, b"b\r10\r\r").endswith(b"\r\n(34)>\r\n" + CONFIRM)
    assert bp.uart_baud_bps == 114285  # BRG 34: the firmware's "115200"
    bp.line_settings_changed(114285, 0)
    talk(bp, b" ")
    assert talk(bp, b"b 10 1\r") == b"b 10 1\r\n" + CONFIRM  # arguments on the command line
    assert bp.uart_baud_bps == 2_000_000


def test_b_arguments_skip_the_menu_and_invalid_choices_ask_again() -> None:
    bp = make()
    assert talk(bp, b"b 7\r") == b"b 7\r\n" + CONFIRM
    assert bp.uart_baud_bps == 38400
    bp.line_settings_changed(38400, 0)
    assert talk(bp, b" ") == b"HiZ>"
    out = talk(bp, b"b\r0\r11\r12345", one_at_a_time=True)
    assert out == (b"b\r\n" + SPEED_MENU + b"\r\n(9)>0\r\n" + b"\r\nInvalid choice, try again\r\n" + b"\r\n(9)>"
                   + b"11\r\n" + b"\r\nInvalid choice, try again\r\n" + b"\r\n(9)>" + b"1234\x07")
    assert talk(bp, b"\x08\x08\x08\x08\x08x") == b"\x08 \x08" * 4 + b"\x07\x07"  # no x here: bell
    assert talk(bp, b"\r") == b"\r\n" + CONFIRM  # empty: the default, 115200
    assert bp.uart_baud_bps == 115200


def test_reset_brings_the_uart_back_to_its_power_up_rate() -> None:
    bp = make()
    talk(bp, b"b 5\r")
    bp.line_settings_changed(9600, 0)
    talk(bp, b" ")
    assert bp.uart_baud_bps == 9600
    out = talk(bp, b"#\r")
    assert out == b"#\r\nRESET\r\n\r\n" + VERSION + b"HiZ>"
    assert bp.uart_baud_bps == 115200


# -- i, ?, #, m --------------------------------------------------------------------------------------
def test_i_and_help_transcripts() -> None:
    bp = make()
    assert talk(bp, b"i\r") == b"i\r\n" + VERSION + b"HiZ>"
    assert talk(bp, b"?\r") == b"?\r\n" + HELP + b"HiZ>"
    assert talk(bp, b"i ?\r") == b"i ?\r\n" + VERSION + HELP + b"HiZ>"
    assert talk(bp, b"iq\r") == b"iq\r\n" + VERSION + b"Syntax error at char 2\r\nHiZ>"


def test_m_menu_transcripts() -> None:
    bp = make()
    assert talk(bp, b"m\r") == b"m\r\n" + MODES + b"\r\n(1)>"
    assert talk(bp, b"x") == b"no mode change\r\nHiZ>"  # x leaves at once, no echo
    assert talk(bp, b"m\r\r") == b"m\r\n" + MODES + b"\r\n(1)>\r\nReady\r\nHiZ>"
    assert talk(bp, b"m\r10\r1\r", one_at_a_time=True) == (
        b"m\r\n" + MODES + b"\r\n(1)>10\r\n\r\nInvalid choice, try again\r\n\r\n(1)>1\r\nReady\r\nHiZ>")
    assert talk(bp, b"m 1\r") == b"m 1\r\nReady\r\nHiZ>"
    assert talk(bp, b"m 12\r") == b"m 12\r\nNonexistent protocol!\r\nHiZ>"
    # other modes' setup dialogs are not emulated: counted, no change
    assert talk(bp, b"m 5\r") == b"m 5\r\nno mode change\r\nHiZ>"
    assert bp.terminal.unemulated_modes == 1


def test_binary_mode_after_a_speed_change() -> None:
    bp = make()
    talk(bp, b"b\r10\r3\r")
    bp.line_settings_changed(1_000_000, 0)
    assert talk(bp, b" ") == b"HiZ>"
    assert talk(bp, b"\x00" * 20) == b"BBIO1"  # flashrom at 1 Mbaud: binary mode works
    assert talk(bp, b"\x01") == b"SPI1"


# -- properties ----------------------------------------------------------------------------------------
@settings(max_examples=200, deadline=None)
@given(st.lists(st.sampled_from([b"b", b"m", b"i", b"?", b"x", b"-", b" ", b"\r", b"\x08", b"\x00", b"1", b"0",
                                 b"9", b"5", b"q", b"\x1b"]), max_size=60))
def test_any_keys_never_crash_and_a_reset_always_recovers(keys: list[bytes]) -> None:
    bp = make()
    for key in keys:
        bp.line_settings_changed(bp.uart_baud_bps, 0)  # a host that always follows
        talk(bp, key)
    reachable = {300, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200} | {4_000_000 // (k + 1) for k in range(256)}
    assert bp.uart_baud_bps in reachable
    if bp.mode.name == "TERMINAL":
        bp.terminal.reset()
        assert bp.terminal.state is State.LINE


@given(st.integers(min_value=0, max_value=9999))
def test_brg_prompt_keeps_the_low_byte(brg: int) -> None:
    bp = make()
    out = talk(bp, b"b\r10\r" + str(brg).encode() + b"\r")
    if brg <= 32767:
        assert out.endswith(CONFIRM)
        assert bp.uart_baud_bps == 4_000_000 // ((brg & 0xFF) + 1)
