"""Bus Pirate v3 binary-mode wire constants.

Sources: the firmware (DangerousPrototypes/Bus_Pirate, Firmware/binIO.c, SPI.c, baseUI.c),
the DP wiki "SPI (binary)" / "Bitbang" pages, and docs/protocols.md §7.1.
"""

from __future__ import annotations

from enum import Enum, IntEnum, unique

OK = 0x01
ERROR = 0x00
BELL = 0x07

#: The terminal counts 0x00 bytes (not echoed) and enters binary mode at exactly 20
#: (baseUI.c serviceuser: ``case 0x00: binmodecnt++; if (binmodecnt == 20) binBB();``).
ZEROS_TO_BINARY = 20


class Mode(Enum):
    """What the firmware's main loop is doing."""

    TERMINAL = "user terminal (HiZ>)"
    BBIO = "raw bitbang (BBIO1)"
    SPI = "raw SPI (SPI1)"
    OTHER = "binary protocol not wired on this rig"
    SELFTEST = "binary self-test echo"
    ADC_STREAM = "continuous probe-ADC stream"
    SNIFF = "SPI sniffer"


@unique
class BbioCmd(IntEnum):
    """binIO.c: commands with bit 7 and bit 6 clear."""

    RESET_BBIO = 0x00
    SPI = 0x01
    I2C = 0x02
    UART = 0x03
    ONE_WIRE = 0x04
    RAW_WIRE = 0x05
    RESET_TO_TERMINAL = 0x0F
    SELFTEST_SHORT = 0x10
    SELFTEST_FULL = 0x11
    PWM_SETUP = 0x12
    PWM_CLEAR = 0x13
    ADC_MEASURE = 0x14
    ADC_CONTINUOUS = 0x15
    FREQ_MEASURE = 0x16


BBIO_VERSION = b"BBIO1"

#: Version strings of the binary protocol modes (DP wiki binmode pages); only SPI is
#: emulated beyond the greeting: the MCP3204 is wired to the SPI pins.
MODE_VERSION: dict[BbioCmd, bytes] = {
    BbioCmd.SPI: b"SPI1",
    BbioCmd.I2C: b"I2C1",
    BbioCmd.UART: b"ART1",
    BbioCmd.ONE_WIRE: b"1W01",
    BbioCmd.RAW_WIRE: b"RAW1",
}

#: 1xxxxxxx sets the pins; 010xxxxx sets their direction (1 = input). Both reply the read.
PIN_SET_FLAG = 0x80
PIN_DIR_FLAG = 0x40


@unique
class Pin(IntEnum):
    """Bit positions in the bitbang pin bytes (binIO.c, pyBusPirateLite BBIO_base)."""

    CS = 0x01
    MISO = 0x02
    CLK = 0x04
    MOSI = 0x08
    AUX = 0x10
    PULLUP = 0x20
    POWER = 0x40


PIN_MASK = 0x1F


@unique
class SpiCmd(IntEnum):
    """SPI.c binSPI(): the single-byte commands 0000xxxx."""

    EXIT = 0x00
    VERSION = 0x01
    CS_LOW = 0x02
    CS_HIGH = 0x03
    WRITE_THEN_READ = 0x04
    WRITE_THEN_READ_NO_CS = 0x05
    SNIFF_ALL = 0x0D
    SNIFF_CS_LOW = 0x0E


@unique
class SpiGroup(IntEnum):
    """SPI.c binSPI(): the command groups by high nibble."""

    SETUP = 0x0
    BULK = 0x1  #: 0001xxxx: xxxx+1 bytes, full duplex
    PERIPHERALS = 0x4  #: 0100wxyz: power, pull-ups, AUX, CS
    READ_PERIPHERALS = 0x5
    SPEED = 0x6  #: 01100xxx
    READ_SPEED = 0x7
    CONFIG = 0x8  #: 1000wxyz: output 3.3 V (1) / HiZ (0), CKP, CKE, SMP
    READ_CONFIG = 0x9


@unique
class SpiConfigBit(IntEnum):
    SMP = 0x01  #: input sample phase: 0 middle, 1 end
    CKE = 0x02  #: output edge: 1 active-to-idle (CPHA 0)
    CKP = 0x04  #: clock idle level (CPOL)
    PUSH_PULL = 0x08  #: 1: 3.3 V push-pull outputs, 0: open drain (HiZ)


@unique
class PeripheralBit(IntEnum):
    CS = 0x01
    AUX = 0x02
    PULLUPS = 0x04
    POWER = 0x08


#: SPI1CON1 prescaler bits per speed code (SPI.c binSPIspeed). Firmware up to 6.1 had wrong
#: values for codes 5-7 (flashrom caps 6.1 at 2 MHz for this reason); 6.2 fixed them.
SPI_CON1_V61 = (0b00000, 0b11000, 0b11100, 0b11101, 0b00011, 0b01000, 0b10000, 0b11000)
SPI_CON1_V62 = (0b00000, 0b11000, 0b11100, 0b11101, 0b00011, 0b01011, 0b10011, 0b11011)

FCY_HZ = 16_000_000  #: PIC24FJ64GA002 at 32 MHz, 2 clocks per instruction
_PRIMARY = {0b11: 1, 0b10: 4, 0b01: 16, 0b00: 64}


def sck_Hz(con1: int) -> float:
    """SCK frequency for SPI1CON1 prescaler bits (PPRE = bits 1:0, SPRE = bits 4:2)."""
    secondary = 8 - ((con1 >> 2) & 0b111)
    return FCY_HZ / (_PRIMARY[con1 & 0b11] * secondary)


def spi_mode_number(config: int) -> int:
    """SPI mode (CPOL << 1 | CPHA) from the config bits: CPOL = CKP, CPHA = not CKE."""
    cpol = 1 if config & SpiConfigBit.CKP else 0
    cpha = 0 if config & SpiConfigBit.CKE else 1
    return cpol << 1 | cpha
