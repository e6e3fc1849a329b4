"""SPIDriver wire constants.

Sources: the firmware (jamesbowman/spidriver firmware/main.fs: ``service`` and ``info``),
protocol.md of the same repository, and the PyPI client spidriver 1.1.1 (docs/
docs/protocols.md §7.2). Commands are single bytes; 0x80..0xBF transfer 1-64 bytes full duplex,
0xC0..0xFF write 1-64 bytes; any other byte without a meaning is ignored (the client's
64 x '@' flush relies on that).
"""

from __future__ import annotations

import binascii
from enum import IntEnum, unique

STATUS_LEN = 80  #: '[' + 78 characters (padded with spaces) + ']'
MAX_BLOCK = 64
CRC_INIT = 0xFFFF  #: the EFM8 CRC0 unit is initialised to all ones (CRC0CN0 = %1100)


@unique
class Cmd(IntEnum):
    STATUS = ord("?")
    ECHO = ord("e")
    SELECT = ord("s")
    UNSELECT = ord("u")
    SET_A = ord("a")
    SET_B = ord("b")
    SET_MODE = ord("m")  #: SPIDriver 2 only
    DETACH = ord("x")
    FLUSH = ord("@")  #: no meaning: ignored like any unknown byte


TRANSFER_BASE = 0x80  #: 0x80 + n - 1: write n bytes, return the n bytes read
WRITE_BASE = 0xC0  #: 0xC0 + n - 1: write n bytes


def crc16_ccitt(data: bytes, crc: int) -> int:
    """CCITT CRC-16 (polynomial 0x1021, MSB first), as the firmware's CRC0 unit and the C
    host library's table compute it; ``binascii.crc_hqx`` is exactly this."""
    return binascii.crc_hqx(data, crc)
