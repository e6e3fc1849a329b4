"""ARM semihosting (ARM DUI 0058/0471, "Semihosting"): the firmware's log output on a board
whose two UARTs are taken. SWI 0x123456 in ARM state, SWI 0xAB in Thumb, with the operation
in r0 and its argument in r1; the debugger (here, the bench) serves it and the core goes on
after the SWI.

Served: SYS_WRITEC (a character at [r1]), SYS_WRITE0 (a NUL-terminated string at r1),
SYS_WRITE (handle, buffer, length at [r1]: handles 1 and 2 are the console), SYS_EXIT (the
program stopped; r1 the reason, ADP_Stopped_ApplicationExit for a normal end). Anything else
is an error naming the operation.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum

from hil.board.errors import CoreFault

ARM_SWI = 0x12_3456
THUMB_SWI = 0xAB
ADP_STOPPED_APPLICATION_EXIT = 0x2_0026
MAX_STRING = 4096


class SysOp(IntEnum):
    WRITEC = 0x03
    WRITE0 = 0x04
    WRITE = 0x05
    EXIT = 0x18


@dataclass
class Semihost:
    """The console: complete lines go to ``on_line`` (default: kept in ``lines``)."""

    on_line: Callable[[str], None] | None = None
    lines: list[str] = field(default_factory=list)
    exit_reason: int | None = None
    _partial: bytearray = field(default_factory=bytearray)

    def serve(self, op: int, arg: int, read: Callable[[int, int], bytes], pc: int) -> int:
        """Serve operation ``op`` with argument ``arg``; returns r0's new value."""
        if op == SysOp.WRITEC:
            self._out(read(arg, 1))
            return arg
        if op == SysOp.WRITE0:
            text = bytearray()
            while len(text) < MAX_STRING:
                chunk = read(arg + len(text), 64)
                end = chunk.find(0)
                text += chunk if end < 0 else chunk[:end]
                if end >= 0:
                    break
            self._out(bytes(text))
            return arg
        if op == SysOp.WRITE:
            words = read(arg, 12)
            handle, buf, n = (int.from_bytes(words[i:i + 4], "little") for i in (0, 4, 8))
            if handle not in (1, 2):
                raise CoreFault(f"semihosting SYS_WRITE to handle {handle} (only the console, 1 and 2)", pc)
            self._out(read(buf, min(n, MAX_STRING)))
            return 0
        if op == SysOp.EXIT:
            self.exit_reason = arg
            return 0
        raise CoreFault(f"semihosting operation {op:#x} is not served (SYS_WRITEC, SYS_WRITE0, SYS_WRITE, SYS_EXIT)",
                        pc)

    def _out(self, data: bytes) -> None:
        self._partial += data
        while (nl := self._partial.find(b"\n")) >= 0:
            line = self._partial[:nl].decode("utf-8", "replace").rstrip("\r")
            del self._partial[:nl + 1]
            if self.on_line is not None:
                self.on_line(line)
            else:
                self.lines.append(line)
