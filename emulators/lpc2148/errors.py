"""The errors the LPC2148 models raise: firmware touching what the model does not know.

A real part reads an unimplemented address as something (often zero) and goes on; a model that
did the same would let firmware run on values nobody modelled. So every access the models do
not cover is an error naming the address and why.
"""

from __future__ import annotations


class Lpc2148Error(Exception):
    """Base of every error of the LPC2148 models."""


class UnmodelledRegister(Lpc2148Error):
    """An access to an address no model covers (or an offset the model does not implement).

    ``address`` is the full bus address (``0xE000C02C``), ``access`` "read" or "write".
    """

    def __init__(self, address: int, access: str, where: str = "") -> None:
        self.address = address
        self.access = access
        self.where = where
        place = f" ({where})" if where else ""
        super().__init__(f"unmodelled register: {access} of 0x{address:08X}{place}")


class RegisterAccessError(Lpc2148Error):
    """A modelled register used in a way the manual does not allow or the model does not cover:
    a read of a write-only register, a write to a read-only one, a sub-word write to a 32-bit
    register, an access to a peripheral powered off in PCONP."""

    def __init__(self, address: int, reason: str) -> None:
        self.address = address
        self.reason = reason
        super().__init__(f"register 0x{address:08X}: {reason}")


class NotModelled(Lpc2148Error):
    """A register value selecting a mode the models do not implement (SPI slave mode, the
    timer's counter mode, fast GPIO, UART auto-baud...). ``address`` is the register's."""

    def __init__(self, address: int, what: str) -> None:
        self.address = address
        self.what = what
        super().__init__(f"register 0x{address:08X}: {what} is not modelled")
