"""The contract every byte-stream device model honours.

Theory of operation (h11 style, "bring your own I/O"):

* ``receive(data, t_ns)`` feeds bytes the host (flight code) wrote, in whatever fragments
  the transport delivered them. Replies are queued, never written.
* ``advance(t_ns)`` lets simulated time pass: streaming outputs that fall due, timeouts,
  windows. ``t_ns`` never goes backwards.
* ``take_output()`` drains the bytes the device wants to send to the host.
* ``take_events()`` drains typed, frozen-dataclass records for the recorder.
* ``line_settings_changed(baud, t_ns)`` tells the device which line rate the host set,
  so it can react like hardware to a wrong baud (garbage or silence).
* ``counters`` counts what happened (frames ok, checksum errors, resyncs, ...). Peer
  misbehaviour is counted and answered like the real device; it never raises.

Sim time is an ``int`` of nanoseconds everywhere.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, fields


@dataclass(frozen=True)
class DeviceEvent:
    """Base of every event record a device emits. ``t_ns`` is sim time."""

    t_ns: int

    def __reduce__(self) -> tuple[type, tuple[object, ...]]:
        # Pickled by field, rebuilt through __init__: compiled (mypyc) records have no
        # __dict__, and the default reduction would restore them through the frozen
        # __setattr__. Events go to the recorder's process pickled (hil/record/process.py).
        return type(self), tuple(getattr(self, f.name) for f in fields(self))


class ByteDevice:
    """Base class with the output/event/counter plumbing; subclasses add the protocol."""

    #: Short name used in logs and error messages ("imu", "adc", ...).
    name: str = "device"

    def __init__(self) -> None:
        self._out = bytearray()
        self._events: list[DeviceEvent] = []
        self.counters: Counter[str] = Counter()
        #: Line rate the host configured, in bit/s; None until the host opens the port.
        self.host_baud: int | None = None

    # -- host side -------------------------------------------------------------------
    def receive(self, data: bytes, t_ns: int) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def advance(self, t_ns: int) -> None:
        """Let sim time pass up to ``t_ns``; default: nothing is time driven."""

    def line_settings_changed(self, baud: int, t_ns: int) -> None:
        """The host (re)opened the port or changed termios; ``baud`` in bit/s."""
        self.host_baud = baud

    # -- bench side ------------------------------------------------------------------
    def take_output(self) -> bytes:
        """Drain and return the bytes queued for the host."""
        if not self._out:
            return b""
        out = bytes(self._out)
        self._out.clear()
        return out

    def take_events(self) -> list[DeviceEvent]:
        """Drain and return the events recorded since the last call."""
        events, self._events = self._events, []
        return events

    # -- for subclasses ----------------------------------------------------------------
    def _send(self, data: bytes) -> None:
        self._out += data

    def _event(self, event: DeviceEvent) -> None:
        self._events.append(event)
