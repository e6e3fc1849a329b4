"""The Bus Pirate v3 user terminal (firmware v6.1) as host tools meet it.

After a reset the firmware prints CR LF, the version information and the ``HiZ>`` prompt.
Printable characters echo into a line buffer; backspace erases; Enter (CR or LF) answers
CR LF and runs the line, one command character after the other (spaces skipped):

* ``i`` version information (in HiZ mode nothing else), ``?`` the help table,
* ``#`` reset (``RESET``, then the power-up banner, the UART back at its power-up rate),
* ``m`` the mode menu: the nine modes of a v3 build, ``x. exit(without change)`` and the
  number prompt ``(1)>``; ``x`` answers ``no mode change``, 1 (HiZ) ``Ready``. The other
  modes' setup dialogs are not emulated: choosing one answers ``no mode change`` and
  counts it (:attr:`Terminal.unemulated_modes`),
* ``b`` the PC-side UART speed menu: presets 1-9 (300 ... 115200 bit/s) and 10, a raw
  BRG value (prompt ``Enter raw value for BRG``, default 34). The firmware then says
  ``Adjust your terminal`` / ``Space to continue`` at the old rate, switches its UART and
  ignores everything until a space arrives at the new rate; then the prompt. ``b 8`` or
  ``b 10 3`` on the command line skip the menus,
* anything else: ``Syntax error at char N``.

Number prompts (``(default)>``) take up to four digits (more ring the bell), backspace,
a leading ``-``, Enter (empty: the default), and ``x`` where the menu allows leaving.
Out of range: ``Invalid choice, try again`` and the prompt again. 0x00 bytes at the
command line are counted, never echoed; the 20th enters binary mode (cumulative until a
reset, as in the firmware's main loop).

Sources (strings reproduced as documented, no code copied): the firmware's v3 string
table (DangerousPrototypes/Bus_Pirate Firmware/translations/v3_bpstrings_en_US.txt:
BPMSG1085, 1093, 1110-1112, 1133, 1134, 1211, 1251, HLP1000-1022), its terminal code
(baseUI.c: serviceuser, getnumber, setBaudRate, changemode; the v3 UART1 at BRGH = 1,
Fcy 16 MHz, so a raw BRG value gives 4 MHz / (BRG + 1)), the v3 build's protocol list
(HiZ, 1-WIRE, UART, I2C, SPI, 2WIRE, 3WIRE, LCD, DIO) and the DP wiki "Bus Pirate menu
options guide" transcripts.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from emulators.buspirate.defs import BELL, ZEROS_TO_BINARY
from emulators.buspirate.params import BusPirateParams

PROMPT = b"HiZ>"
LINE_MAX = 255  #: baseUI.c CMDBUFLEN 256 with the end marker
CRLF = b"\r\n"

#: the v3 UART1 clock with BRGH = 1: bit/s = UART_CLOCK_HZ / (BRG + 1)
UART_CLOCK_HZ = 4_000_000
#: menu options 1-9 of ``b`` in bit/s (firmware UARTspeed BRG values 13332 ... 34)
BAUD_PRESETS_BPS = (300, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200)
BRG_OPTION = 10  #: ``b`` option 10: a raw BRG value
BRG_DEFAULT = 34  #: the BRG prompt's default (115200 bit/s nominal, 114286 real)
NUMBER_DIGITS_MAX = 4  #: getnumber keeps at most four digits

#: the modes of a v3 build, in menu order
MODES = ("HiZ", "1-WIRE", "UART", "I2C", "SPI", "2WIRE", "3WIRE", "LCD", "DIO")

BAUD_MENU = (
    b"Set serial port speed: (bps)\r\n 1. 300\r\n 2. 1200\r\n 3. 2400\r\n 4. 4800\r\n 5. 9600\r\n"
    b" 6. 19200\r\n 7. 38400\r\n 8. 57600\r\n 9. 115200\r\n10. BRG raw value\r\n"
)
BRG_QUESTION = b"Enter raw value for BRG\r\n"
ADJUST = b"Adjust your terminal\r\nSpace to continue\r\n"
INVALID = b"\r\nInvalid choice, try again\r\n"
MODE_MENU = b"".join(f"{i}. {name}\r\n".encode() for i, name in enumerate(MODES, 1)) + b"x. exit(without change)\r\n"
NO_MODE_CHANGE = b"no mode change\r\n"
READY = b"Ready\r\n"
RESET = b"RESET\r\n"
SYNTAX_ERROR = "Syntax error at char {}\r\n"
ERASE = b"\x08 \x08"
HELP = b"".join(
    line + CRLF
    for line in (
        b" General\t\t\t\t\tProtocol interaction",
        b" ---------------------------------------------------------------------------",
        b" ?\tThis help\t\t\t(0)\tList current macros",
        b" =X/|X\tConverts X/reverse X\t\t(x)\tMacro x",
        b" ~\tSelftest\t\t\t[\tStart",
        b" #\tReset\t\t\t\t]\tStop",
        b" $\tJump to bootloader\t\t{\tStart with read",
        b" &/%\tDelay 1 us/ms\t\t\t}\tStop",
        b' a/A/@\tAUXPIN (low/HI/READ)\t\t"abc"\tSend string',
        b" b\tSet baudrate\t\t\t123",
        b" c/C\tAUX assignment (aux/CS)\t\t0x123",
        b" d/D\tMeasure ADC (once/CONT.)\t0b110\tSend value",
        b" f\tMeasure frequency\t\tr\tRead",
        b" g/S\tGenerate PWM/Servo\t\t/\tCLK hi",
        b" h\tCommandhistory\t\t\t\\\tCLK lo",
        b" i\tVersioninfo/statusinfo\t\t^\tCLK tick",
        b" l/L\tBitorder (msb/LSB)\t\t-\tDAT hi",
        b" m\tChange mode\t\t\t_\tDAT lo",
        b" o\tSet output type\t\t\t.\tDAT read",
        b" p/P\tPullup resistors (off/ON)\t!\tBit read",
        b" s\tScript engine\t\t\t:\tRepeat e.g. r:10",
        b" v\tShow volts/states\t\t.\tBits to read/write e.g. 0x55.2",
        b" w/W\tPSU (off/ON)\t\t<x>/<x= >/<0>\tUsermacro x/assign x/list all",
    )
)


def brg_baud_bps(brg: int) -> int:
    """The UART rate (bit/s, rounded down) of a raw BRG register value."""
    return UART_CLOCK_HZ // (brg + 1)


class State(Enum):
    """What the terminal does with the next byte."""

    LINE = "command line"
    NUMBER = "number prompt"
    WAIT_SPACE = "waiting for a space at the new rate"


class Menu(Enum):
    """Which question a number prompt answers."""

    BAUD = "b: serial port speed"
    BRG = "b 10: raw BRG value"
    MODE = "m: bus mode"


@dataclass(frozen=True)
class Question:
    """A number prompt: default, accepted range and whether ``x`` leaves it."""

    default: int
    minimum: int
    maximum: int
    exit_allowed: bool


QUESTIONS: dict[Menu, Question] = {
    Menu.BAUD: Question(9, 1, 10, False),
    Menu.BRG: Question(BRG_DEFAULT, 0, 32767, False),
    Menu.MODE: Question(1, 1, len(MODES), True),
}


class Terminal:
    """Line discipline and menus of the terminal.

    :meth:`feed` takes one received byte and returns (bytes to send, enter binary mode
    now). A ``b`` command that completes leaves the new UART rate in
    :meth:`take_baud_change` (bit/s): the device switches after sending what ``feed``
    returned (the confirmation goes out at the old rate).
    """

    def __init__(self, params: BusPirateParams) -> None:
        self.params = params
        self.zeros = 0
        self.line = bytearray()
        self.state = State.LINE
        self.unemulated_modes = 0  #: mode choices whose setup dialog is not emulated
        self._escape = 0  # bytes of an ANSI escape sequence still to swallow
        self._menu = Menu.BAUD
        self._digits = bytearray()
        self._negative = False
        self._rest = b""  # the command line after a command that opened a prompt
        self._baud_change: int | None = None

    def version_info(self) -> bytes:
        """What the ``i`` command (and a reset) prints."""
        p = self.params
        text = (
            f"Bus Pirate {p.hardware}\r\n"
            f"Firmware {p.firmware}  Bootloader {p.bootloader}\r\n"
            f"{p.device_id}\r\n"
            "http://dangerousprototypes.com\r\n"
        )
        return text.encode("ascii")

    def reset(self) -> bytes:
        """Power-up or reset: clear state and return the banner with the prompt."""
        self.zeros = 0
        self.line.clear()
        self._escape = 0
        self.state = State.LINE
        self._digits.clear()
        self._negative = False
        self._rest = b""
        self._baud_change = self.params.baud_bps  # the UART restarts at its power-up rate
        return b"\r\n" + self.version_info() + PROMPT

    def take_baud_change(self) -> int | None:
        """The UART rate (bit/s) a completed ``b`` command asks for, once; else None."""
        baud, self._baud_change = self._baud_change, None
        return baud

    # -- bytes in ---------------------------------------------------------------------------
    def feed(self, byte: int) -> tuple[bytes, bool]:
        """One received byte -> (bytes to send, enter binary mode now)."""
        return _HANDLERS[self.state](self, byte)

    def _feed_line(self, byte: int) -> tuple[bytes, bool]:
        if self._escape:
            self._escape -= 1
            if byte == ord("[") and self._escape == 0:
                self._escape = 1  # ESC [ x: one more byte (arrow keys)
            return b"", False
        if byte == 0x00:
            self.zeros += 1
            return b"", self.zeros == ZEROS_TO_BINARY
        if byte == 0x1B:
            self._escape = 1
            return b"", False
        if byte in (0x0D, 0x0A):
            line = bytes(self.line)
            self.line.clear()
            return CRLF + self._run(line), False
        if byte == 0x08:
            if self.line:
                self.line.pop()
                return ERASE, False
            return bytes([BELL]), False
        if 0x20 <= byte < 0x7F and len(self.line) < LINE_MAX:
            self.line.append(byte)
            return bytes([byte]), False
        return bytes([BELL]), False

    def _feed_number(self, byte: int) -> tuple[bytes, bool]:
        q = QUESTIONS[self._menu]
        if byte == 0x08:
            if self._digits:
                self._digits.pop()
                return ERASE, False
            if self._negative:
                self._negative = False
                return ERASE, False
            return bytes([BELL]), False
        if byte in (0x0D, 0x0A):
            return CRLF + self._answer(), False
        if byte == ord("-"):
            if self._digits:
                return bytes([BELL]), False
            self._negative = True
            return b"-", False
        if byte == ord("x") and q.exit_allowed:
            return self._chosen(-1), False  # leaves at once: no echo, no line end
        if 0x30 <= byte <= 0x39:
            if len(self._digits) >= NUMBER_DIGITS_MAX:
                return bytes([BELL]), False
            self._digits.append(byte)
            return bytes([byte]), False
        return bytes([BELL]), False

    def _feed_wait_space(self, byte: int) -> tuple[bytes, bool]:
        if byte != 0x20:
            return b"", False  # the firmware reads and drops until the space
        self.state = State.LINE
        return self._continue(), False

    # -- commands ---------------------------------------------------------------------------
    def _run(self, line: bytes) -> bytes:
        """Run a command line from its start; the prompt when it is done."""
        self._rest = line
        return self._continue()

    def _continue(self) -> bytes:
        """Run what is left of the command line (after a prompt or a baud change)."""
        out = bytearray()
        line, self._rest = self._rest, b""
        pos = 0
        while pos < len(line):
            c = line[pos : pos + 1]
            pos += 1
            if c in (b" ", b","):
                continue
            if c == b"i":
                out += self.version_info()
            elif c == b"?":
                out += HELP
            elif c == b"#":
                return bytes(out) + RESET + self.reset()
            elif c == b"b":
                return bytes(out) + self._baud_command(line[pos:])
            elif c == b"m":
                return bytes(out) + self._mode_command(line[pos:])
            else:
                out += SYNTAX_ERROR.format(pos).encode()
                break
        return bytes(out) + PROMPT

    def _baud_command(self, args: bytes) -> bytes:
        words = args.split()
        speed = _int_or_none(words[0]) if words else None
        if speed is None or not 1 <= speed <= BRG_OPTION:
            return BAUD_MENU + self._ask(Menu.BAUD)
        if speed == BRG_OPTION:
            brg = _int_or_none(words[1]) if len(words) > 1 else None
            if not brg:  # the firmware asks when no (or a zero) value follows
                return BRG_QUESTION + self._ask(Menu.BRG)
            return self._switch(brg_baud_bps(brg & 0xFF))
        return self._switch(BAUD_PRESETS_BPS[speed - 1])

    def _mode_command(self, args: bytes) -> bytes:
        words = args.split()
        mode = _int_or_none(words[0]) if words else None
        if not mode:
            return MODE_MENU + self._ask(Menu.MODE)
        if mode > len(MODES):
            return b"Nonexistent protocol!\r\n" + PROMPT
        return self._mode_chosen(mode) + PROMPT

    def _ask(self, menu: Menu) -> bytes:
        self.state = State.NUMBER
        self._menu = menu
        self._digits.clear()
        self._negative = False
        return f"\r\n({QUESTIONS[menu].default})>".encode()

    def _answer(self) -> bytes:
        q = QUESTIONS[self._menu]
        if not self._digits:
            return self._chosen(q.default)
        value = int(self._digits)
        if not q.minimum <= value <= q.maximum or self._negative:
            # a negative answer is out of every menu's range here (the firmware would
            # pass it on as a garbage index)
            return INVALID + self._ask(self._menu)
        return self._chosen(value)

    def _chosen(self, value: int) -> bytes:
        menu = self._menu
        self.state = State.LINE
        if menu is Menu.MODE:
            return (NO_MODE_CHANGE if value < 0 else self._mode_chosen(value)) + PROMPT
        if menu is Menu.BAUD:
            if value == BRG_OPTION:
                return BRG_QUESTION + self._ask(Menu.BRG)
            return self._switch(BAUD_PRESETS_BPS[value - 1])
        # the firmware keeps the BRG value in an unsigned char
        return self._switch(brg_baud_bps(value & 0xFF))

    def _mode_chosen(self, mode: int) -> bytes:
        if mode == 1:
            return READY
        self.unemulated_modes += 1
        return NO_MODE_CHANGE

    def _switch(self, baud_bps: int) -> bytes:
        """Confirm at the old rate, then switch and wait for a space at the new one."""
        self._baud_change = baud_bps
        self.state = State.WAIT_SPACE
        return ADJUST


def _int_or_none(word: bytes) -> int | None:
    return int(word) if word.isdigit() else None


_HANDLERS = {
    State.LINE: Terminal._feed_line,
    State.NUMBER: Terminal._feed_number,
    State.WAIT_SPACE: Terminal._feed_wait_space,
}
