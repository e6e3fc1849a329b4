"""Typed event records of the XSENS emulator (drained with ``take_events``)."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from emulators.base import DeviceEvent


class State(Enum):
    """Device state (mtidocs "States")."""

    WAKEUP = "wakeup"  #: booting / WakeUp sent, waiting for WakeUpAck
    CONFIG = "config"
    MEASUREMENT = "measurement"


@dataclass(frozen=True, init=False)
class SampleSent(DeviceEvent):
    """One data message put on the wire (MTData2, or MTData for a legacy device).

    Values are as sent: in the message's output frame and units; None when the message
    does not carry that item. ``packet_counter`` is the legacy sample counter for MTData;
    ``sample_time_fine`` (10 kHz ticks) is None for MTData. ``nbytes`` counts the frame.
    """

    packet_counter: int | None
    sample_time_fine: int | None
    euler_deg: tuple[float, float, float] | None
    rate_radps: tuple[float, float, float] | None
    acc_mps2: tuple[float, float, float] | None
    nbytes: int

    def __init__(self, t_ns: int, packet_counter: int | None, sample_time_fine: int | None,
                 euler_deg: tuple[float, float, float] | None, rate_radps: tuple[float, float, float] | None,
                 acc_mps2: tuple[float, float, float] | None, nbytes: int) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "packet_counter", packet_counter)
        object.__setattr__(self, "sample_time_fine", sample_time_fine)
        object.__setattr__(self, "euler_deg", euler_deg)
        object.__setattr__(self, "rate_radps", rate_radps)
        object.__setattr__(self, "acc_mps2", acc_mps2)
        object.__setattr__(self, "nbytes", nbytes)


@dataclass(frozen=True)
class SampleDropped(DeviceEvent):
    """A due sample that did not go out. ``reason``: "overrun" (line too slow)."""

    reason: str
    error_mode: int


@dataclass(frozen=True)
class StateChanged(DeviceEvent):
    old: State
    new: State


@dataclass(frozen=True, init=False)
class CommandHandled(DeviceEvent):
    """A host message was handled; ``reply_mid`` is the ack, 0x42 for Error, None if silent."""

    mid: int
    reply_mid: int | None
    error_code: int | None = None

    def __init__(self, t_ns: int, mid: int, reply_mid: int | None, error_code: int | None = None) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "mid", mid)
        object.__setattr__(self, "reply_mid", reply_mid)
        object.__setattr__(self, "error_code", error_code)


@dataclass(frozen=True)
class ProtocolError(DeviceEvent):
    """Bad input from the host (counted too): checksum, unknown MID, wrong state, ..."""

    reason: str


@dataclass(frozen=True)
class LineOverload(DeviceEvent):
    """The output configuration needs more bytes per second than the line carries.

    Reported when measurement starts with such a configuration; samples will be dropped
    (see :class:`SampleDropped`). Capacity = ``baud_bps / 10`` (8N1).
    """

    bytes_per_s: int
    capacity_bytes_per_s: int
    baud_bps: int


@dataclass(frozen=True)
class BaudChanged(DeviceEvent):
    """The device's own line rate changed (SetBaudrate takes effect at Reset/power-up)."""

    baud_bps: int
