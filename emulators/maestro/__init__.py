"""Pololu Maestro servo controller (the ``esc`` port): compact, Pololu and Mini SSC protocols."""

from emulators.maestro.device import Maestro, ProtocolError, TargetsSet
from emulators.maestro.motion import ServoChannel
from emulators.maestro.params import MaestroParams
from emulators.maestro.protocol import (
    Command,
    ErrorBit,
    Prefix,
    compact,
    crc7,
    get_position,
    join14,
    mini_ssc,
    pololu,
    set_multiple_targets,
    set_target,
    split14,
)

__all__ = [
    "Command", "ErrorBit", "Maestro", "MaestroParams", "Prefix", "ProtocolError", "ServoChannel",
    "TargetsSet", "compact", "crc7", "get_position", "join14", "mini_ssc", "pololu",
    "set_multiple_targets", "set_target", "split14",
]
