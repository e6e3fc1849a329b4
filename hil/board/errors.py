"""What can go wrong on the emulated board, each naming where."""

from __future__ import annotations


class BoardError(Exception):
    """The emulated board cannot go on."""


class FirmwareError(BoardError):
    """The firmware image itself is unusable (not an ARM ELF, does not fit the memory map)."""


class CoreFault(BoardError):
    """The firmware did something the LPC2148 would fault on or the board does not model: an
    access to unmapped memory, an undefined instruction, an unsupported SWI. ``pc`` is the
    instruction's address where known."""

    def __init__(self, message: str, pc: int | None = None) -> None:
        where = f" (pc {pc:#010x})" if pc is not None else ""
        super().__init__(message + where)
        self.pc = pc
