"""Xbus wire constants of the XSENS MTi (legacy MTi and mk4 MTi 100-series).

Sources (docs/protocols.md §1, which cites them): MID values from ethz-asl
``mtdef.py`` and xspublic ``xsxbusmessageid.h``; XDI values from xspublic
``xsdataidentifier.h``; error codes from xspublic ``xsresultvalue.h``; baud codes from
xspublic ``xsbaudcode.h``; legacy output mode/settings bits from MT0100P pp. 27-28.
Payload sizes are given in the comments (Req = LEN 0, Set = LEN > 0 on a shared MID).
"""

from __future__ import annotations

from enum import IntEnum, unique

PREAMBLE = 0xFA
#: Bus id of a directly connected device ("master"); devices answer with it.
BID_MASTER = 0xFF
#: Bus id of the first device on an Xbus; XDA accepts it from a direct device too.
BID_FIRST = 0x01
#: LEN value that announces a 16-bit extended length.
LEN_EXTENDED = 0xFF
#: Largest payload of a standard (non-extended) message.
MAX_STD_PAYLOAD = 254
#: Legacy period unit: SetPeriod counts 1/115200 s.
PERIOD_CLOCK_HZ = 115_200
#: SampleTimeFine counts 10 kHz ticks (Xsens ROS driver SAMPLE_TIME_FINE_HZ).
SAMPLE_TIME_FINE_HZ = 10_000
#: Frequency value of SetOutputConfiguration meaning "in every packet / as fast as possible".
FREQ_EVERY_PACKET = 0xFFFF


@unique
class MID(IntEnum):
    """Message identifiers. The reply to a message is MID + 1 (Error is 0x42)."""

    REQ_DID = 0x00  # -> DEVICE_ID, 4 bytes
    DEVICE_ID = 0x01
    INIT_MT = 0x02  # -> INIT_MT_RESULTS, 4-byte device id
    INIT_MT_RESULTS = 0x03
    SET_PERIOD = 0x04  # Req: 0 B; Set: 2 B (1/115200 s)
    SET_PERIOD_ACK = 0x05
    REQ_DATA_LENGTH = 0x0A  # legacy; -> 2 bytes MTData length
    DATA_LENGTH = 0x0B
    REQ_CONFIGURATION = 0x0C  # -> 118 bytes
    CONFIGURATION = 0x0D
    RESTORE_FACTORY_DEF = 0x0E
    RESTORE_FACTORY_DEF_ACK = 0x0F
    GOTO_MEASUREMENT = 0x10
    GOTO_MEASUREMENT_ACK = 0x11
    REQ_FW_REV = 0x12  # -> 3 B (legacy) or 11 B (mk4: + build u32, svn rev u32)
    FIRMWARE_REV = 0x13
    SET_BAUDRATE = 0x18  # Req: 0 B; Set: 1 B baud code
    SET_BAUDRATE_ACK = 0x19
    REQ_PRODUCT_CODE = 0x1C  # -> 20 ASCII bytes, space padded
    PRODUCT_CODE = 0x1D
    REQ_HARDWARE_VERSION = 0x1E  # -> 2 bytes major, minor
    HARDWARE_VERSION = 0x1F
    SET_NO_ROTATION = 0x22
    SET_NO_ROTATION_ACK = 0x23
    RUN_SELFTEST = 0x24  # -> 2 bytes result bits
    SELFTEST_RESULTS = 0x25
    SET_SYNC_SETTINGS = 0x2C  # mk4; Set: N x 12 B
    SET_SYNC_SETTINGS_ACK = 0x2D
    GOTO_CONFIG = 0x30
    GOTO_CONFIG_ACK = 0x31
    MTDATA = 0x32  # legacy data message
    REQ_DATA = 0x34  # polled data request
    MTDATA2 = 0x36  # mk4 data message
    WAKEUP = 0x3E
    WAKEUP_ACK = 0x3F
    RESET = 0x40
    RESET_ACK = 0x41
    ERROR = 0x42  # 1 byte error code
    SET_OPTION_FLAGS = 0x48  # Req: 0 B; Set: 4 B set flags + 4 B clear flags
    SET_OPTION_FLAGS_ACK = 0x49
    REQ_UTC_TIME = 0x60
    UTC_TIME = 0x61
    REQ_AVAILABLE_FILTER_PROFILES = 0x62  # -> N x 22 B (type, version, 20-char label)
    AVAILABLE_FILTER_PROFILES = 0x63
    SET_FILTER_PROFILE = 0x64  # Req: 0 B; Set: 2 B
    SET_FILTER_PROFILE_ACK = 0x65
    SET_LAT_LON_ALT = 0x6E
    SET_GNSS_PLATFORM = 0x76
    SET_LOCATION_ID = 0x84  # Req: 0 B; Set: 2 B
    SET_LOCATION_ID_ACK = 0x85
    SET_EXT_OUTPUT_MODE = 0x86
    SET_STRING_OUTPUT_TYPE = 0x8E  # Req: 0 B; Set: 2 B
    SET_STRING_OUTPUT_TYPE_ACK = 0x8F
    REQ_EMTS = 0x90  # 2 B (first page, page count) -> extended-length opaque blob
    EMTS_DATA = 0x91
    RESET_ORIENTATION = 0xA4
    SET_OUTPUT_CONFIGURATION = 0xC0  # mk4; Req: 0 B; Set: N x 4 B, N <= 32
    OUTPUT_CONFIGURATION = 0xC1
    SET_OUTPUT_MODE = 0xD0  # Req: 0 B; Set: 2 B
    SET_OUTPUT_MODE_ACK = 0xD1
    SET_OUTPUT_SETTINGS = 0xD2  # Req: 0 B; Set: 4 B
    SET_OUTPUT_SETTINGS_ACK = 0xD3
    SET_OUTPUT_SKIP_FACTOR = 0xD4  # Req: 0 B; Set: 2 B (0xFFFF = polled only)
    SET_OUTPUT_SKIP_FACTOR_ACK = 0xD5
    SET_ERROR_MODE = 0xDA  # Req: 0 B; Set: 2 B (0..3)
    SET_ERROR_MODE_ACK = 0xDB
    SET_TRANSMIT_DELAY = 0xDC  # RS-485 only
    SET_ALIGNMENT_ROTATION = 0xEC  # Req: 1 B frame; Set: 1 B frame + 16 B quaternion
    SET_ALIGNMENT_ROTATION_ACK = 0xED


@unique
class XDI(IntEnum):
    """MTData2 data identifiers with the format bits (coordinates, precision) cleared."""

    TEMPERATURE = 0x0810  # 1 value, degC
    UTC_TIME = 0x1010
    PACKET_COUNTER = 0x1020  # u16
    SAMPLE_TIME_FINE = 0x1060  # u32, 10 kHz ticks
    SAMPLE_TIME_COARSE = 0x1070  # u32, s
    QUATERNION = 0x2010  # 4 values (w, x, y, z)
    ROTATION_MATRIX = 0x2020  # 9 values, column-major
    EULER_ANGLES = 0x2030  # 3 values (roll, pitch, yaw), deg
    BARO_PRESSURE = 0x3010  # u32, Pa
    DELTA_V = 0x4010  # 3 values, m/s
    ACCELERATION = 0x4020  # 3 values, m/s^2
    FREE_ACCELERATION = 0x4030  # 3 values, m/s^2
    RATE_OF_TURN = 0x8020  # 3 values, rad/s
    DELTA_Q = 0x8030  # 4 values
    MAGNETIC_FIELD = 0xC020  # 3 values, a.u.
    STATUS_BYTE = 0xE010  # u8
    STATUS_WORD = 0xE020  # u32


#: XDI bits 3..2: coordinate system of orientation (and, in this emulator, vector) outputs.
XDI_COORD_MASK = 0x000C
#: XDI bits 1..0: precision of floating outputs.
XDI_PRECISION_MASK = 0x0003
XDI_FORMAT_MASK = XDI_COORD_MASK | XDI_PRECISION_MASK


@unique
class Precision(IntEnum):
    """XDI precision bits; bytes per scalar in the comment."""

    FLOAT32 = 0x0  # 4
    FP1220 = 0x1  # 4, signed 12.20 fixed point
    FP1632 = 0x2  # 6, 4-byte fraction then 2-byte signed integer
    FLOAT64 = 0x3  # 8


@unique
class CoordSys(IntEnum):
    """XDI coordinate-system bits."""

    ENU = 0x0
    NED = 0x4
    NWU = 0x8


@unique
class ErrorCode(IntEnum):
    """Codes carried by the Error message (0x42)."""

    NO_BUS = 0x01
    BUS_NOT_READY = 0x02
    INVALID_PERIOD = 0x03
    INVALID_MESSAGE = 0x04  # message invalid or not implemented
    TIMER_OVERFLOW = 0x1E
    BAUDRATE_INVALID = 0x20
    INVALID_PARAM = 0x21
    DEVICE_ERROR = 0x28
    DATA_OVERFLOW = 0x29  # more data than the line can carry
    BUFFER_OVERFLOW = 0x2A
    INVALID_FILTER_PROFILE = 0x31
    OUTPUT_CONFIG_ERROR = 0x35


@unique
class ErrorMode(IntEnum):
    """SetErrorMode values: what the device does when a sample cannot be sent."""

    IGNORE = 0  # drop the sample, counter not increased
    INCREASE_COUNTER = 1  # drop, increase the sample/packet counter (legacy default)
    INCREASE_COUNTER_SEND_ERROR = 2  # as 1, plus Error 0x29 (mk4 behaviour per XDA)
    SEND_ERROR_GO_CONFIG = 3  # Error 0x29 and go to Config state


@unique
class BaudCode(IntEnum):
    """SetBaudrate data byte."""

    B460800 = 0x00
    B230400 = 0x01
    B115200 = 0x02
    B76800 = 0x03
    B57600 = 0x04
    B38400 = 0x05
    B28800 = 0x06
    B19200 = 0x07
    B14400 = 0x08
    B9600 = 0x09
    B921600 = 0x0A  # from MTi/x FW 2.4.6
    B4800 = 0x0B
    B2000000 = 0x0C
    B4000000 = 0x0D
    B3500000 = 0x0E
    B921600_LEGACY = 0x80


BAUD_BPS_BY_CODE: dict[BaudCode, int] = {
    BaudCode.B460800: 460_800,
    BaudCode.B230400: 230_400,
    BaudCode.B115200: 115_200,
    BaudCode.B76800: 76_800,
    BaudCode.B57600: 57_600,
    BaudCode.B38400: 38_400,
    BaudCode.B28800: 28_800,
    BaudCode.B19200: 19_200,
    BaudCode.B14400: 14_400,
    BaudCode.B9600: 9_600,
    BaudCode.B921600: 921_600,
    BaudCode.B4800: 4_800,
    BaudCode.B2000000: 2_000_000,
    BaudCode.B4000000: 4_000_000,
    BaudCode.B3500000: 3_500_000,
    BaudCode.B921600_LEGACY: 921_600,
}


def baud_code_for(baud_bps: int) -> BaudCode:
    """The code a device reports for ``baud_bps`` (921600 -> 0x80, as real devices answer)."""
    if baud_bps == 921_600:
        return BaudCode.B921600_LEGACY
    for code, bps in BAUD_BPS_BY_CODE.items():
        if bps == baud_bps:
            return code
    raise ValueError(f"no Xbus baud code for {baud_bps} bit/s")


@unique
class LegacyMode(IntEnum):
    """Legacy SetOutputMode bits (2 bytes)."""

    TEMPERATURE = 0x0001
    CALIBRATED = 0x0002
    ORIENTATION = 0x0004
    AUXILIARY = 0x0008
    POSITION = 0x0010  # MTi-G
    VELOCITY = 0x0020  # MTi-G
    STATUS = 0x0800
    RAW_GPS = 0x1000  # MTi-G
    RAW_INERTIAL = 0x4000


@unique
class LegacyTimestamp(IntEnum):
    """Legacy SetOutputSettings bits 1..0."""

    NONE = 0
    SAMPLE_COUNTER = 1
    UTC = 2  # MTi-G


@unique
class LegacyOrientation(IntEnum):
    """Legacy SetOutputSettings bits 3..2."""

    QUATERNION = 0
    EULER = 1
    MATRIX = 2


@unique
class LegacyFormat(IntEnum):
    """Legacy SetOutputSettings bits 9..8."""

    FLOAT32 = 0
    FP1220 = 1


@unique
class LegacySettingsBit(IntEnum):
    """Single-bit flags of the legacy SetOutputSettings word (4 bytes)."""

    NO_ACC = 0x0000_0010
    NO_GYR = 0x0000_0020
    NO_MAG = 0x0000_0040
    NO_AIN1 = 0x0000_0400
    NO_AIN2 = 0x0000_0800
    NED = 0x8000_0000


@unique
class StatusFlag(IntEnum):
    """StatusByte / StatusWord bits (xspublic ``xsstatusflag.h``)."""

    SELFTEST_OK = 0x0000_0001
    ORIENTATION_VALID = 0x0000_0002
    CLIP_ACC_X = 0x0000_0100
    CLIP_ACC_Y = 0x0000_0200
    CLIP_ACC_Z = 0x0000_0400
    CLIP_GYR_X = 0x0000_0800
    CLIP_GYR_Y = 0x0000_1000
    CLIP_GYR_Z = 0x0000_2000
    CLIPPING_DETECTED = 0x0008_0000
