"""What one XBee module hands its radio and its host's events: the RF packet (802.15.4 MAC
addressing, what it carries) and the module's device events."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum, auto, unique

from emulators.base import DeviceEvent
from emulators.xbee import frames as fr

NO_16BIT = 0xFFFE  # MY = 0xFFFE/0xFFFF: the module sends with its 64-bit address


@unique
class RfKind(Enum):
    """What an RF packet carries."""

    DATA = auto()
    REMOTE_AT_REQUEST = auto()  # payload: frame id, options, command (2), parameter
    REMOTE_AT_RESPONSE = auto()  # payload: frame id, status, command (2), value


@dataclass(frozen=True, init=False)
class RfPacket:
    """One packet handed to the radio at ``t_ns``: addressing as the 802.15.4 MAC carries
    it (``dest16`` or ``dest64``; ``src16`` = ``NO_16BIT`` for 64-bit source addressing),
    ``ack`` True for an acknowledged unicast, ``tag`` the sender's handle for the result."""

    t_ns: int
    src16: int
    src64: int
    dest16: int | None
    dest64: int | None
    payload: bytes
    ack: bool
    broadcast_pan: bool
    channel: int
    pan_id: int
    tag: int
    kind: RfKind = RfKind.DATA

    def __init__(self, t_ns: int, src16: int, src64: int, dest16: int | None, dest64: int | None, payload: bytes,
                 ack: bool, broadcast_pan: bool, channel: int, pan_id: int, tag: int,
                 kind: RfKind = RfKind.DATA) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "src16", src16)
        object.__setattr__(self, "src64", src64)
        object.__setattr__(self, "dest16", dest16)
        object.__setattr__(self, "dest64", dest64)
        object.__setattr__(self, "payload", payload)
        object.__setattr__(self, "ack", ack)
        object.__setattr__(self, "broadcast_pan", broadcast_pan)
        object.__setattr__(self, "channel", channel)
        object.__setattr__(self, "pan_id", pan_id)
        object.__setattr__(self, "tag", tag)
        object.__setattr__(self, "kind", kind)

    @property
    def broadcast(self) -> bool:
        """Addressed to everybody."""
        return self.dest16 == fr.BROADCAST_16 or self.dest64 == fr.BROADCAST_64


@dataclass(frozen=True)
class AtCommandHandled(DeviceEvent):
    """An AT command was answered (``via`` "api" or "text"; ``status`` as in 0x88)."""

    command: str
    status: int
    via: str


@dataclass(frozen=True)
class ModeChanged(DeviceEvent):
    """AP changed to ``ap`` (0 transparent, 1 API, 2 escaped API)."""

    ap: int
