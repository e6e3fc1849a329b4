"""Rig ports attached to real serial devices: the rig's ``[ports]`` table and ``--attach``.

In a rig file (one table per port; any port not listed stays a pty)::

    [ports.imu]
    device = "/dev/ttyUSB0"      # or "socket://host:4001", "rfc2217://host:2217"
    bytesize = 8                 # framing; the baud is the emulated device's own (e.g. [imu] baud_bps)
    parity = "N"                 # "N", "E" or "O"
    stopbits = 1
    low_latency = true           # set ASYNC_LOW_LATENCY where the driver supports it
    client_path = "/dev/ttyUSB1" # optional: what a bench-started flight code opens (the far end
                                 # of a null-modem cable); without it the flight config keeps its own

On the command line ``--attach imu=/dev/ttyUSB0`` (one flag per port) sets or overrides the
device of a port, keeping the rig's framing for it. A board keeps its own clock, so a run
with an attached port is realtime only (:func:`refuse_lockstep`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, Protocol

from emulators.base import DeviceEvent
from emulators.buspirate.events import BusPirateUartRate
from emulators.xsens.events import BaudChanged
from hil.config import ConfigError, check_keys, validate

if TYPE_CHECKING:
    from hil.transport.serialport import SerialPort

#: every port a rig can attach (hil run uses all but adc-spidriver)
ATTACHABLE_PORTS = ("imu", "adc", "adc-spidriver", "rc", "esc", "telemetry", "ground")


@dataclass(frozen=True)
class PortAttachment:
    """One port on a real serial line. ``device``: a tty path or a pyserial URL."""

    __pydantic_config__ = {"extra": "forbid"}
    device: str
    bytesize: Literal[5, 6, 7, 8] = 8
    parity: Literal["N", "E", "O"] = "N"
    stopbits: Literal[1, 2] = 1
    low_latency: bool = True
    client_path: str | None = None


def load_ports_table(table: Any, *, file: Path | str) -> dict[str, PortAttachment]:
    """The rig's ``[ports]`` table: one validated :class:`PortAttachment` per port name."""
    if not isinstance(table, Mapping):
        raise ConfigError(f"{file}: [ports] must be a table of [ports.<port>] tables")
    check_keys(table, set(ATTACHABLE_PORTS), file=file, section="ports")
    out: dict[str, PortAttachment] = {}
    for name, entry in table.items():
        if not isinstance(entry, Mapping):
            raise ConfigError(f"{file}: [ports] {name}: must be a table (device = \"/dev/ttyUSB0\", ...)")
        att = validate(PortAttachment, entry, file=file, section=f"ports.{name}")
        if not att.device.strip():
            raise ConfigError(f"{file}: [ports.{name}] device: must not be empty")
        out[name] = att
    return out


def parse_attach_flags(flags: Iterable[str]) -> dict[str, str]:
    """``["imu=/dev/ttyUSB0", ...]`` -> ``{"imu": "/dev/ttyUSB0"}``; errors name the flag."""
    out: dict[str, str] = {}
    for flag in flags:
        name, sep, target = flag.partition("=")
        name, target = name.strip(), target.strip()
        if not sep or not name or not target:
            raise ConfigError(f"--attach {flag!r}: expected PORT=DEVICE, e.g. imu=/dev/ttyUSB0 or imu=socket://host:4001")
        if name not in ATTACHABLE_PORTS:
            raise ConfigError(f"--attach {flag!r}: unknown port {name!r} (ports: {', '.join(ATTACHABLE_PORTS)})")
        if name in out:
            raise ConfigError(f"--attach {flag!r}: port {name!r} given twice")
        out[name] = target
    return out


def resolve_attachments(rig_ports: Mapping[str, PortAttachment], flags: Mapping[str, str],
                        ports: Sequence[str], *, command: str) -> dict[str, PortAttachment]:
    """The rig's attachments with ``--attach`` devices over them, limited to ``ports`` (the
    ports ``command`` serves); a port it does not serve is an error, not ignored."""
    merged = dict(rig_ports)
    for name, target in flags.items():
        merged[name] = replace(merged[name], device=target) if name in merged else PortAttachment(device=target)
    extra = [name for name in merged if name not in ports]
    if extra:
        where = "--attach" if any(n in flags for n in extra) else "rig [ports]"
        raise ConfigError(f"{where} {extra[0]}: `hil {command}` has no port {extra[0]!r} (ports: {', '.join(ports)})")
    return merged


def refuse_lockstep(attachments: Mapping[str, PortAttachment], mode: str) -> None:
    """A real port means a real clock on the far side: lockstep cannot own its time."""
    if attachments and mode == "lockstep":
        name, att = next(iter(attachments.items()))
        raise ConfigError(
            f"port {name} is attached to {att.device}: a real serial port runs in realtime only (the board keeps "
            "its own clock; lockstep needs the bench to own the flight code's time). Use --mode realtime."
        )


def open_attached(attachments: Mapping[str, PortAttachment], baud_of: Any) -> dict[str, Any]:
    """Open every attached port (``baud_of(port) -> bit/s``), all or none: on the first
    failure the ones already opened are closed and the :class:`PortOpenError` propagates."""
    from hil.transport.serialport import Framing, SerialPort

    opened: dict[str, SerialPort] = {}
    try:
        for name, att in attachments.items():
            framing = Framing(int(baud_of(name)), att.bytesize, att.parity, att.stopbits)
            port = SerialPort(name, att.device, framing, low_latency=att.low_latency)
            port.client_path = att.client_path
            opened[name] = port
    except BaseException:
        for port in opened.values():
            port.close()
        raise
    return opened


#: device events after which the device's own UART runs at the event's ``baud_bps``
RATE_EVENTS = (BaudChanged, BusPirateUartRate)


class EventSource(Protocol):
    """What hands out device events: ``hil.flight.devices.DeviceSet`` (port name, event)."""

    event_sinks: list[Callable[[str, DeviceEvent], None]]


def follow_device_rates(devices: EventSource, attached: Mapping[str, SerialPort]) -> None:
    """On a real line the bench owns the line settings: when an emulated device switches its
    UART (Bus Pirate ``b`` menu, XSENS SetBaudrate + Reset), switch the attached port too, after
    the bytes already written (the device's confirmation at the old rate)."""
    if not attached:
        return

    def sink(port: str, event: DeviceEvent) -> None:
        if port in attached and isinstance(event, RATE_EVENTS):
            attached[port].set_baud(event.baud_bps)

    devices.event_sinks.append(sink)

