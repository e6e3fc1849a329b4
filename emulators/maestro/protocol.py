"""Maestro serial protocol constants, CRC-7 and packet builders (Pololu 0J40 section 5).

Command bytes have the MSB set, data bytes have it clear (7 bits each), except the two
data bytes of a Mini SSC packet (0..254). 14-bit values go low 7 bits first. Replies are
little-endian and never carry a CRC.
"""

from __future__ import annotations

from collections.abc import Sequence
from enum import IntEnum, IntFlag, unique


@unique
class Command(IntEnum):
    """Compact-protocol command bytes (the Pololu protocol sends them with the MSB clear)."""

    SET_TARGET = 0x84
    SET_SPEED = 0x87
    SET_ACCELERATION = 0x89
    SET_PWM = 0x8A
    GET_POSITION = 0x90
    GET_MOVING_STATE = 0x93
    SET_MULTIPLE_TARGETS = 0x9F
    GET_ERRORS = 0xA1
    GO_HOME = 0xA2
    STOP_SCRIPT = 0xA4
    RESTART_SCRIPT_AT_SUBROUTINE = 0xA7
    RESTART_SCRIPT_WITH_PARAMETER = 0xA8
    GET_SCRIPT_STATUS = 0xAE


@unique
class Prefix(IntEnum):
    """Bytes that open the other two sub-protocols."""

    POLOLU = 0xAA
    MINI_SSC = 0xFF


#: Data bytes after each command byte; None = variable (Set Multiple Targets: 2 + 2n).
DATA_LENGTH: dict[Command, int | None] = {
    Command.SET_TARGET: 3,
    Command.SET_SPEED: 3,
    Command.SET_ACCELERATION: 3,
    Command.SET_PWM: 4,
    Command.GET_POSITION: 1,
    Command.GET_MOVING_STATE: 0,
    Command.SET_MULTIPLE_TARGETS: None,
    Command.GET_ERRORS: 0,
    Command.GO_HOME: 0,
    Command.STOP_SCRIPT: 0,
    Command.RESTART_SCRIPT_AT_SUBROUTINE: 1,
    Command.RESTART_SCRIPT_WITH_PARAMETER: 3,
    Command.GET_SCRIPT_STATUS: 0,
}


@unique
class ErrorBit(IntFlag):
    """The Maestro error register (User's Guide 4.e)."""

    SERIAL_SIGNAL = 1 << 0
    SERIAL_OVERRUN = 1 << 1
    SERIAL_BUFFER_FULL = 1 << 2
    SERIAL_CRC = 1 << 3
    SERIAL_PROTOCOL = 1 << 4
    SERIAL_TIMEOUT = 1 << 5
    SCRIPT_STACK = 1 << 6
    SCRIPT_CALL_STACK = 1 << 7
    SCRIPT_PROGRAM_COUNTER = 1 << 8


CRC7_POLY = 0x91


def crc7(data: bytes) -> int:
    """Pololu CRC-7: polynomial 0x91 processed LSB first (0J40 5.d; ``83 01`` -> ``0x17``)."""
    crc = 0
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc ^ CRC7_POLY) >> 1 if crc & 1 else crc >> 1
    return crc


def split14(value: int) -> bytes:
    """A 14-bit value as (bits 0-6, bits 7-13)."""
    if not 0 <= value < 0x4000:
        raise ValueError("value must fit in 14 bits")
    return bytes((value & 0x7F, (value >> 7) & 0x7F))


def join14(lo: int, hi: int) -> int:
    """Inverse of :func:`split14`."""
    return (lo & 0x7F) | ((hi & 0x7F) << 7)


def compact(cmd: Command, data: bytes = b"", *, crc: bool = False) -> bytes:
    """A compact-protocol packet (optionally with its CRC-7 byte)."""
    pkt = bytes((cmd,)) + data
    return pkt + bytes((crc7(pkt),)) if crc else pkt


def pololu(device: int, cmd: Command, data: bytes = b"", *, crc: bool = False) -> bytes:
    """A Pololu-protocol packet ``AA dev cmd&7F data``."""
    pkt = bytes((Prefix.POLOLU, device, cmd & 0x7F)) + data
    return pkt + bytes((crc7(pkt),)) if crc else pkt


def set_target(channel: int, target_qus: int, *, crc: bool = False) -> bytes:
    """Compact Set Target."""
    return compact(Command.SET_TARGET, bytes((channel,)) + split14(target_qus), crc=crc)


def set_multiple_targets(first_channel: int, targets_qus: Sequence[int], *, crc: bool = False) -> bytes:
    """Compact Set Multiple Targets."""
    data = bytes((len(targets_qus), first_channel)) + b"".join(split14(t) for t in targets_qus)
    return compact(Command.SET_MULTIPLE_TARGETS, data, crc=crc)


def get_position(channel: int, *, crc: bool = False) -> bytes:
    """Compact Get Position (reply: 2 bytes little-endian, qus)."""
    return compact(Command.GET_POSITION, bytes((channel,)), crc=crc)


def mini_ssc(address: int, value: int) -> bytes:
    """Mini SSC packet ``FF address value`` (0..254 each)."""
    return bytes((Prefix.MINI_SSC, address, value))
