"""MCP3204 wire constants and the bit-level protocol tables (Microchip DS21298E).

Bit protocol (DS21298E §5.0/§6.0, docs/protocols.md §2): with CS low, the first clock
with DIN high is the start bit; SGL/DIFF, D2, D1, D0 follow (D2 is don't-care on the
MCP3204). Sampling starts on the 4th rising edge after the start bit and ends on the falling
edge of the 5th clock, where DOUT leaves hi-Z with a null bit (0); then B11..B0 MSB first,
then B1..B11 LSB first (B0 not repeated), then zeros while CS stays low.
"""

from __future__ import annotations

from enum import Enum, IntEnum, unique

RESOLUTION_BITS = 12
FULL_SCALE_CODES = 1 << RESOLUTION_BITS  #: 4096 codes span VREF
MAX_CODE = FULL_SCALE_CODES - 1
N_CHANNELS = 4


@unique
class InputMode(IntEnum):
    """The SGL/DIFF bit."""

    PSEUDO_DIFFERENTIAL = 0
    SINGLE_ENDED = 1


@unique
class SpiMode(IntEnum):
    """SPI mode number = CPOL << 1 | CPHA."""

    MODE0 = 0  #: CPOL 0, CPHA 0: supported by the part
    MODE1 = 1  #: CPOL 0, CPHA 1: wrong phase, data shifted by one bit
    MODE2 = 2  #: CPOL 1, CPHA 0: wrong phase, data shifted by one bit
    MODE3 = 3  #: CPOL 1, CPHA 1: supported by the part


#: DS21298E §6.1: "SPI serial interface (modes 0,0 and 1,1)".
SUPPORTED_SPI_MODES = frozenset({SpiMode.MODE0, SpiMode.MODE3})

#: Table 5-1, SGL/DIFF = 0: (D1, D0) -> (IN+, IN-).
DIFF_PAIRS: dict[int, tuple[int, int]] = {0: (0, 1), 1: (1, 0), 2: (2, 3), 3: (3, 2)}


class Phase(Enum):
    """Where the part is in a CS-low frame."""

    POWER_UP_CS_LOW = "power-up with CS low: needs CS high first"
    IDLE = "CS high (shutdown)"
    WAIT_START = "leading zeros until the start bit"
    SGL_DIFF = "next rising edge latches SGL/DIFF"
    D2 = "next rising edge latches D2"
    D1 = "next rising edge latches D1"
    D0 = "next rising edge latches D0"
    SAMPLE = "sampling; the next rising edge is the 5th clock"
    HOLD = "the falling edge ends the sample and drives the null bit"
    OUTPUT = "null, B11..B0, B1..B11, zeros on falling edges"


#: Rising-edge transitions of the command phase (DIN latched on the edge). WAIT_START leaves
#: only on DIN = 1 (the start bit); the device ignores clocks in the other phases.
RISING_NEXT: dict[Phase, Phase] = {
    Phase.SGL_DIFF: Phase.D2,
    Phase.D2: Phase.D1,
    Phase.D1: Phase.D0,
    Phase.D0: Phase.SAMPLE,
    Phase.SAMPLE: Phase.HOLD,
}

#: Index of B0 in the output bit sequence (0 is the null bit, 1..12 are B11..B0).
B0_INDEX = RESOLUTION_BITS


def output_bits(code: int) -> tuple[int, ...]:
    """DOUT bits after the sample: null, B11..B0, then B1..B11 (LSB first)."""
    msb_first = tuple((code >> i) & 1 for i in range(RESOLUTION_BITS - 1, -1, -1))
    lsb_first = tuple((code >> i) & 1 for i in range(1, RESOLUTION_BITS))
    return (0, *msb_first, *lsb_first)


def fig61_request(channel: int, single_ended: bool = True) -> bytes:
    """The usual 3-byte request of DS21298E Fig. 6-1 (mode 0,0), e.g. CH1 -> 06 40 00.

    Byte 0 = 0000 01 S D2, byte 1 = D1 D0 xxxxxx, byte 2 = don't care.
    """
    d = channel & 0b111
    return bytes([0x04 | (int(single_ended) << 1) | (d >> 2), (d & 0b11) << 6, 0x00])


def fig61_decode(rx: bytes) -> int:
    """The 12-bit result of a Fig. 6-1 exchange: ``(rx1 & 0x0F) << 8 | rx2``."""
    return ((rx[1] & 0x0F) << 8) | rx[2]
