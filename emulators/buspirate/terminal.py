"""The Bus Pirate user terminal, as far as a binary-mode host meets it.

After a reset the firmware prints CR LF, the version information and the ``HiZ>`` prompt
(main.c Initialize -> versionInfo, baseUI.c serviceuser). Printable characters echo into a
line buffer; backspace erases; Enter runs the line: ``i`` prints the version information,
``#`` resets, an empty line re-prompts, anything else is answered with a syntax error (the
bus commands of the real terminal are not emulated). 0x00 bytes are counted, never echoed;
the 20th enters binary mode (the count is cumulative until the next reset, as in
serviceuser). Other control characters ring the bell.
"""

from __future__ import annotations

from emulators.buspirate.defs import BELL, ZEROS_TO_BINARY
from emulators.buspirate.params import BusPirateParams

PROMPT = b"HiZ>"
LINE_MAX = 255  #: baseUI.c CMDBUFLEN 256 with the end marker


class Terminal:
    """Line discipline of the terminal; returns the bytes to send and whether to go binary."""

    def __init__(self, params: BusPirateParams) -> None:
        self.params = params
        self.zeros = 0
        self.line = bytearray()
        self._escape = 0  # bytes of an ANSI escape sequence still to swallow

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
        return b"\r\n" + self.version_info() + PROMPT

    def feed(self, byte: int) -> tuple[bytes, bool]:
        """One received byte -> (bytes to send, enter binary mode now)."""
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
            return b"\r\n" + self._run(bytes(self.line)), False
        if byte == 0x08:
            if self.line:
                self.line.pop()
                return b"\x08 \x08", False
            return bytes([BELL]), False
        if 0x20 <= byte < 0x7F and len(self.line) < LINE_MAX:
            self.line.append(byte)
            return bytes([byte]), False
        return bytes([BELL]), False

    def _run(self, line: bytes) -> bytes:
        self.line.clear()
        cmd = line.strip()
        if not cmd:
            return PROMPT
        if cmd == b"i":
            return self.version_info() + PROMPT
        if cmd == b"#":
            return b"RESET\r\n" + self.reset()
        return b"Syntax error at char 1\r\n" + PROMPT
