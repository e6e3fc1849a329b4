"""What every driver shares: the serial-port interface it uses and its error type.

Drivers talk to a :class:`SerialLike`: the subset of ``serial.Serial`` (pyserial 3.5) they
call. On the vehicle and on the bench that is a real ``serial.Serial``; unit tests pass small
in-process fakes. Timeouts are set once when the port is opened (``__main__``), never on the
tick path: pyserial's ``timeout`` setter re-applies termios (a ``tcsetattr`` per change).

Each driver is split into a sans-I/O part (frame encoders, streaming parsers: bytes in,
records out, no clock, no port) and a thin serial part that owns the port.
"""

from __future__ import annotations

from typing import Protocol


class SerialLike(Protocol):
    """The pyserial calls the drivers make (see ``serial.Serial``)."""

    @property
    def in_waiting(self) -> int:
        """Bytes received and not yet read."""

    @property
    def out_waiting(self) -> int:
        """Bytes written and not yet sent."""

    def read(self, size: int = 1) -> bytes:
        """Read up to ``size`` bytes, waiting at most the port's ``timeout``."""

    def write(self, data: bytes) -> int | None:
        """Write ``data``; with ``write_timeout=0`` returns the count actually written."""

    def reset_input_buffer(self) -> None:
        """Discard received bytes."""

    def close(self) -> None:
        """Close the port."""


def read_waiting(port: SerialLike) -> bytes:
    """What has arrived on ``port``, without waiting (b"" when nothing has). Asks
    ``in_waiting`` (an ``ioctl``) first: on most samples nothing has come, and a read would
    spend a ``select`` to find that out."""
    n = port.in_waiting
    return port.read(n) if n else b""


class DeviceError(RuntimeError):
    """A device did not answer (or answered wrongly) while it was being brought up.

    ``device`` is the port name of the config (``imu``, ``adc``, ``rc``, ``esc``,
    ``telemetry``); the message says what was sent and what came back.
    """

    def __init__(self, device: str, message: str) -> None:
        super().__init__(f"{device}: {message}")
        self.device = device
        self.reason = message
