"""Transport contract shared by the pty and in-memory ports."""

from __future__ import annotations

import asyncio
import enum
from collections.abc import Callable
from dataclasses import dataclass, field

from mypy_extensions import mypyc_attr

from hil import clock


class Direction(enum.Enum):
    """Wire direction, named from the bench's point of view."""

    TX = "tx"  #: bench (emulated device) -> client (flight code)
    RX = "rx"  #: client -> bench


@dataclass(frozen=True, init=False)
class WireRecord:
    """One chunk of bytes seen on a port. ``t_ns`` is sim time, ``t_host_ns`` monotonic."""

    port: str
    direction: Direction
    t_ns: int
    t_host_ns: int
    data: bytes

    def __init__(self, port: str, direction: Direction, t_ns: int, t_host_ns: int, data: bytes) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "port", port)
        object.__setattr__(self, "direction", direction)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "t_host_ns", t_host_ns)
        object.__setattr__(self, "data", data)


@dataclass(frozen=True)
class LineSettings:
    """What the client configured on its end of the line.

    ``baud`` in bit/s (None if unknown), ``bytesize`` 5..8, ``parity`` 'N'/'E'/'O',
    ``stopbits`` 1 or 2. ``opened`` is True for the notification caused by an open
    (input flush), False for a plain termios change.
    """

    baud: int | None
    bytesize: int = 8
    parity: str = "N"
    stopbits: int = 1
    opened: bool = False


@dataclass
class PortStats:
    """Counters of one port; never reset during a run."""

    bytes_tx: int = 0
    bytes_rx: int = 0
    writes: int = 0
    reads: int = 0
    overflow_bytes: int = 0  #: bytes dropped because the client did not read in time
    overflow_events: int = 0
    opens: int = 0  #: client opens noticed (input flush on open)
    line_changes: int = 0  #: termios changes noticed
    delivery_timeouts: int = 0  #: confirmed writes that did not reach the client in time
    extra: dict[str, int] = field(default_factory=dict)


DataCallback = Callable[[bytes, int], None]
LineCallback = Callable[[LineSettings], None]
TapCallback = Callable[[WireRecord], None]


def _no_data(data: bytes, t_ns: int) -> None:
    return None


def _no_line(settings: LineSettings) -> None:
    return None


@mypyc_attr(allow_interpreted_subclasses=True)  # the serial port and tests' fakes are interpreted
class Port:
    """Base of the transports: callbacks, tap and sim-time source.

    ``sim_time`` is a callable giving the current sim time in ns; the bench sets it so
    that taps and ``on_data`` get sim timestamps. ``on_data(data, t_ns)`` is called on
    the event loop for every chunk the client wrote.
    """

    def __init__(self, name: str, *, buffer_limit: int = 65536) -> None:
        self.name = name
        self.buffer_limit = buffer_limit
        self.stats = PortStats()
        self.on_data: DataCallback = _no_data
        self.on_line: LineCallback = _no_line
        self.taps: list[TapCallback] = []
        self.sim_time: Callable[[], int] = lambda: 0
        self.line: LineSettings | None = None

    # -- to implement --------------------------------------------------------------
    @property
    def path(self) -> str | None:
        """Path a client opens (a stable symlink for ptys), None for in-memory ports."""
        return None

    @property
    def client_path(self) -> str | None:
        """What a bench-started client (the flight code) opens to reach this port; None when
        the bench cannot say (a real line whose far end the client config names itself)."""
        return self.path

    def write(self, data: bytes) -> int:  # pragma: no cover - abstract
        """Queue ``data`` for the client without blocking; return bytes accepted."""
        raise NotImplementedError

    async def write_confirmed(self, data: bytes, timeout_s: float = 0.05) -> bool:
        """Write and wait until the bytes are readable by the client (or timeout)."""
        raise NotImplementedError  # pragma: no cover - abstract

    def write_tracked(self, data: bytes) -> int:  # pragma: no cover - abstract
        """Write and return a token for :meth:`confirm` (delivery checked later)."""
        raise NotImplementedError

    async def confirm(self, want: int, timeout_s: float = 0.05) -> bool:  # pragma: no cover - abstract
        """Wait until the bytes of a :meth:`write_tracked` are readable by the client."""
        raise NotImplementedError

    def close(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def flush(self) -> None:
        """Make everything written so far readable by the client now (no-op if immediate)."""

    def accepted_bytes(self) -> int:
        """Bytes this port has taken from ``write`` so far (handed over or still queued)."""
        return self.stats.bytes_tx

    def client_consumed(self) -> int | None:
        """Bytes the client has read so far, counted as :meth:`accepted_bytes`; None where
        the bench cannot see the client's end (a real serial line)."""
        return None

    async def start(self) -> None:
        """Register with the running event loop."""

    # -- shared helpers -----------------------------------------------------------------
    def _tap(self, direction: Direction, data: bytes, t_ns: int) -> None:
        if self.taps:
            rec = WireRecord(self.name, direction, t_ns, clock.monotonic_ns(), data)
            for tap in self.taps:
                tap(rec)

    def _deliver_rx(self, data: bytes) -> None:
        t_ns = self.sim_time()
        self.stats.bytes_rx += len(data)
        self.stats.reads += 1
        self._tap(Direction.RX, data, t_ns)
        self.on_data(data, t_ns)

    def _line_changed(self, settings: LineSettings) -> None:
        self.line = settings
        if settings.opened:
            self.stats.opens += 1
        else:
            self.stats.line_changes += 1
        self.on_line(settings)


@mypyc_attr(allow_interpreted_subclasses=True)
class BufferedWrites(Port):
    """A port with bounded non-blocking writes, for the transports with a file descriptor (pty,
    serial): what the kernel will not take now waits in ``_pending``, drained by the loop's
    writer callback; beyond ``buffer_limit`` bytes are dropped and counted (like a UART
    overrun), never hidden. The transport provides ``_writer_fd`` and ``_on_writable``.

    A base class, not a mixin: the pty port is compiled (setup.py), and mypyc compiles single
    inheritance only."""

    _pending: bytearray
    _writer_registered: bool
    _loop: asyncio.AbstractEventLoop | None

    def _writer_fd(self) -> int | None:
        raise NotImplementedError

    def _on_writable(self) -> None:
        raise NotImplementedError

    @property
    def writes_pending(self) -> bool:
        """Bytes wait in ``_pending`` for the kernel to take them (the loop's writer drains them)."""
        return bool(self._pending)

    def accepted_bytes(self) -> int:
        return self.stats.bytes_tx + len(self._pending)

    def drain_queued(self) -> None:
        """Hand the kernel what it takes of ``_pending`` now (the writer callback's work, for
        a caller that waits on the descriptor's writability itself)."""
        self._on_writable()

    def _buffer(self, data: bytes) -> int:
        room = self.buffer_limit - len(self._pending)
        accepted = data[: max(room, 0)]
        dropped = len(data) - len(accepted)
        if dropped:
            self.stats.overflow_bytes += dropped
            self.stats.overflow_events += 1
        self._pending += accepted
        fd = self._writer_fd()
        if self._pending and not self._writer_registered and self._loop is not None and fd is not None:
            self._loop.add_writer(fd, self._on_writable)
            self._writer_registered = True
        return len(accepted)
