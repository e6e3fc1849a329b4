"""A rig port on a real serial device or a pyserial URL, instead of a pty.

``/dev/ttyUSB0`` (any tty device), ``socket://host:port`` (a raw TCP serial server, e.g.
``ser2net`` or ``socat``) and ``rfc2217://host:port`` (a Telnet COM-port server) are opened
with pyserial's ``serial_for_url``. Baud and framing come from the rig; the bench owns the
line (the client on the far side is a board with its own UART, so there is no termios
notification to follow, unlike on a pty).

* Local ttys and ``socket://`` expose a file descriptor: the port is driven like the pty,
  from the event loop (``add_reader``; non-blocking writes with a bounded pending buffer,
  overflow counted). ``rfc2217://`` has none (pyserial runs its own Telnet reader thread),
  so a small reader thread hands chunks to the loop.
* Opening is exclusive (``flock``), so two benches never share a device. Errors name the
  port and the path: :class:`PortOpenError` (a :class:`~hil.config.ConfigError`: rc 2).
* Low latency: on a local tty the driver's ``ASYNC_LOW_LATENCY`` flag is set through
  ``TIOCGSERIAL``/``TIOCSSERIAL`` where the driver supports it, and an FTDI adapter's USB
  latency timer (``/sys/bus/usb-serial/devices/<tty>/latency_timer``, 16 ms by default) above
  :data:`LATENCY_TIMER_LIMIT_MS` is reported in :attr:`SerialPort.notes`: the adapter would
  hold every sample back for up to that long, more than the 2.5 ms loop.
* Delivery confirmation means "handed to the driver" (our pending buffer is empty): what
  the far side has read cannot be known on a real line.
"""

from __future__ import annotations

import array
import asyncio
import errno
import fcntl
import os
import re
import termios
import threading
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import serial

from hil.config import ConfigError
from hil.transport.base import BufferedWrites, LineSettings

#: linux/serial.h: struct serial_struct and its flag for low-latency (no tty flip buffering)
TIOCGSERIAL = 0x541E
TIOCSSERIAL = 0x541F
ASYNC_LOW_LATENCY = 1 << 13
SERIAL_STRUCT_BYTES = 72  # x86_64/aarch64 sizeof(struct serial_struct)
SERIAL_FLAGS_OFFSET = 16  # int type, int line, unsigned int port, int irq, int flags

#: an adapter that holds received bytes longer than this breaks the 2.5 ms loop
LATENCY_TIMER_LIMIT_MS = 2
USB_SERIAL_SYSFS = Path("/sys/bus/usb-serial/devices")

URL_SCHEMES = ("socket://", "rfc2217://")
_READ_CHUNK = 4096


class PortOpenError(ConfigError):
    """A real serial port could not be opened (missing, busy, not permitted, refused)."""


@dataclass(frozen=True)
class Framing:
    """Line settings the bench applies: ``baud_bps`` bit/s, ``bytesize`` 5..8, ``parity``
    'N'/'E'/'O', ``stopbits`` 1 or 2."""

    baud_bps: int
    bytesize: int = 8
    parity: str = "N"
    stopbits: int = 1

    def describe(self) -> str:
        return f"{self.baud_bps} baud {self.bytesize}{self.parity}{self.stopbits}"


def is_url(target: str) -> bool:
    return target.startswith(URL_SCHEMES)


def set_low_latency(fd: int) -> str:
    """Set ``ASYNC_LOW_LATENCY`` on a tty; returns what happened, for the user
    ("set", "already set", or "not supported by this driver: <reason>")."""
    buf = array.array("B", bytes(SERIAL_STRUCT_BYTES))
    try:
        fcntl.ioctl(fd, TIOCGSERIAL, buf)
    except OSError as exc:
        return f"not supported by this driver ({os.strerror(exc.errno or 0)})"
    flags = int.from_bytes(buf[SERIAL_FLAGS_OFFSET : SERIAL_FLAGS_OFFSET + 4], "little", signed=True)
    if flags & ASYNC_LOW_LATENCY:
        return "already set"
    buf[SERIAL_FLAGS_OFFSET : SERIAL_FLAGS_OFFSET + 4] = array.array(
        "B", (flags | ASYNC_LOW_LATENCY).to_bytes(4, "little", signed=True)
    )
    try:
        fcntl.ioctl(fd, TIOCSSERIAL, buf)
    except OSError as exc:
        return f"not supported by this driver ({os.strerror(exc.errno or 0)})"
    return "set"


def usb_latency_timer_ms(device: str, sysfs: Path = USB_SERIAL_SYSFS) -> int | None:
    """The USB-serial adapter's latency timer (ms) of ``device`` (a path or symlink to
    /dev/ttyUSBn), None if it has none (not a usb-serial tty, or a driver without it)."""
    name = Path(os.path.realpath(device)).name
    try:
        return int((sysfs / name / "latency_timer").read_text().strip())
    except (OSError, ValueError):
        return None


def latency_timer_note(port: str, device: str, sysfs: Path = USB_SERIAL_SYSFS) -> str | None:
    """A warning if the adapter's latency timer exceeds :data:`LATENCY_TIMER_LIMIT_MS`."""
    ms = usb_latency_timer_ms(device, sysfs)
    if ms is None or ms <= LATENCY_TIMER_LIMIT_MS:
        return None
    name = Path(os.path.realpath(device)).name
    return (
        f"{port}: {device} is a USB serial adapter whose latency timer is {ms} ms (> {LATENCY_TIMER_LIMIT_MS} ms): "
        f"it holds received bytes up to {ms} ms, longer than the 2.5 ms loop. Lower it: "
        f"echo 1 | sudo tee {sysfs / name / 'latency_timer'}"
    )


def _describe_open_error(port: str, target: str, exc: BaseException) -> str:
    code = getattr(exc, "errno", None)
    text = str(exc)
    if code is None:
        m = re.search(r"\[Errno (\d+)\]", text)
        code = int(m.group(1)) if m else None
    if code == errno.ENOENT:
        why = "no such device"
    elif code in (errno.EACCES, errno.EPERM):
        why = f"permission denied (user {os.getuid()}: add it to the device's group, e.g. dialout)"
    elif code in (errno.EBUSY, errno.EWOULDBLOCK) or "exclusively lock" in text:
        why = "busy: another process has it open (exclusive)"
    elif code == errno.ECONNREFUSED:
        why = "connection refused (is the serial server running?)"
    elif code == errno.ENOTTY:
        why = "not a serial device"
    else:
        why = text
    return f"port {port}: {target}: cannot open: {why}"


def open_serial(port: str, target: str, framing: Framing) -> serial.SerialBase:
    """Open ``target`` exclusively with ``framing``; :class:`PortOpenError` naming the port
    and the path otherwise."""
    kwargs: dict[str, Any] = dict(
        baudrate=framing.baud_bps,
        bytesize=framing.bytesize,
        parity=framing.parity,
        stopbits=framing.stopbits,
        timeout=0,
        write_timeout=0,
        do_not_open=True,
    )
    try:
        ser = serial.serial_for_url(target, **kwargs)
        if not is_url(target):
            ser.exclusive = True
        if target.startswith("rfc2217://"):
            ser.timeout = 0.05  # its reader thread's poll
            ser.write_timeout = None  # pyserial's RFC 2217 client refuses any write timeout
        ser.open()
    except (serial.SerialException, OSError, ValueError) as exc:
        raise PortOpenError(_describe_open_error(port, target, exc)) from exc
    return ser


class SerialPort(BufferedWrites):
    """A bench port on a real serial line (see module docstring).

    ``target`` is the device path or URL; ``notes`` collects what the user should know
    (low-latency mode, the adapter's latency timer)."""

    def __init__(self, name: str, target: str, framing: Framing, *, low_latency: bool = True,
                 buffer_limit: int = 65536, sysfs: Path = USB_SERIAL_SYSFS) -> None:
        super().__init__(name, buffer_limit=buffer_limit)
        self.target = target
        self.framing = framing
        self.notes: list[str] = []
        self._client_path: str | None = None
        self._ser = open_serial(name, target, framing)
        self._fd: int | None = None
        if not target.startswith("rfc2217://"):
            self._fd = self._ser.fileno()
        if self._fd is not None and not is_url(target):
            if low_latency:
                result = set_low_latency(self._fd)
                if result.startswith("not supported"):
                    self.notes.append(f"{name}: {target}: low-latency mode {result}")
            note = latency_timer_note(name, target, sysfs)
            if note:
                self.notes.append(note)
        self.line = LineSettings(framing.baud_bps, framing.bytesize, framing.parity, framing.stopbits)
        self._pending = bytearray()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._writer_registered = False
        self._closed = False  #: no more writes (closed, or the line failed)
        self._shut = False  #: close() ran
        self._baud_after_drain: int | None = None  #: a rate switch waiting for the pending bytes
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    @property
    def path(self) -> str:
        return self.target

    @property
    def client_path(self) -> str | None:
        """The far end a bench-started client opens (rig ``client_path``), None if not given."""
        return self._client_path

    @client_path.setter
    def client_path(self, value: str | None) -> None:
        self._client_path = value

    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        if self._fd is not None:
            self._loop.add_reader(self._fd, self._on_readable)
        else:
            self._thread = threading.Thread(target=self._reader_thread, name=f"serial {self.name}", daemon=True)
            self._thread.start()

    # -- far side -> bench -----------------------------------------------------------------
    def _on_readable(self) -> None:
        assert self._fd is not None
        try:
            data = os.read(self._fd, _READ_CHUNK) if not is_url(self.target) else self._ser._socket.recv(_READ_CHUNK)  # type: ignore[attr-defined]
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            self._lost(f"read failed: {exc}")
            return
        if not data:
            self._lost("the far side closed the connection")
            return
        self._deliver_rx(data)

    def _reader_thread(self) -> None:
        while not self._stop.is_set():
            try:
                data = self._ser.read(max(1, self._ser.in_waiting))
            except (serial.SerialException, OSError) as exc:
                if self._loop is not None and not self._stop.is_set():
                    self._loop.call_soon_threadsafe(self._lost, f"read failed: {exc}")
                return
            if data and self._loop is not None:
                self._loop.call_soon_threadsafe(self._deliver_if_open, bytes(data))

    def _deliver_if_open(self, data: bytes) -> None:
        if not self._closed:
            self._deliver_rx(data)

    def _lost(self, why: str) -> None:
        """The line is gone (adapter unplugged, server closed): stop reading, count it."""
        self.stats.extra["line_lost"] = self.stats.extra.get("line_lost", 0) + 1
        self.notes.append(f"{self.name}: {self.target}: {why}")
        if self._loop is not None and self._fd is not None:
            self._loop.remove_reader(self._fd)

    # -- bench -> far side -----------------------------------------------------------------
    def write(self, data: bytes) -> int:
        if self._closed or not data:
            return 0
        self.stats.writes += 1
        self._tap_tx(data)
        if self._pending:
            return self._buffer(data)
        n = self._write_now(data)
        if n < len(data):
            self._buffer(data[n:])
        return len(data)

    def _tap_tx(self, data: bytes) -> None:
        from hil.transport.base import Direction

        self._tap(Direction.TX, data, self.sim_time())

    def _write_now(self, data: bytes | bytearray) -> int:
        try:
            if self._fd is None:
                n = self._ser.write(bytes(data)) or 0  # rfc2217: a short blocking sendall
            elif is_url(self.target):
                n = self._ser._socket.send(data)  # type: ignore[attr-defined]
            else:
                n = os.write(self._fd, data)
        except (BlockingIOError, InterruptedError):
            n = 0
        except (OSError, serial.SerialException) as exc:
            self._lost(f"write failed: {exc}")
            self._closed = True
            return len(data)
        self.stats.bytes_tx += n
        return n

    def _writer_fd(self) -> int | None:
        return self._fd  # None for rfc2217: its writes are short blocking sends, never buffered here

    def _on_writable(self) -> None:
        n = self._write_now(self._pending)
        del self._pending[:n]
        if (not self._pending or self._closed) and self._loop is not None and self._fd is not None:
            self._loop.remove_writer(self._fd)
            self._writer_registered = False
            if self._baud_after_drain is not None:
                self._apply_baud()

    # -- the device changes its own rate -----------------------------------------------------
    def set_baud(self, baud_bps: int) -> None:
        """Switch the line to ``baud_bps`` once everything written so far has left (a device
        confirms at the old rate, then switches: the Bus Pirate's ``b`` menu, XSENS
        SetBaudrate + Reset). A raw ``socket://`` has no line rate: noted, nothing else."""
        if self.target.startswith("socket://"):
            self.notes.append(f"{self.name}: {self.target}: the device switched to {baud_bps} bit/s; "
                              "a raw TCP serial server has no line rate to follow (set it on the server)")
            return
        self._baud_after_drain = baud_bps
        if not self._pending:
            self._apply_baud()

    def _apply_baud(self) -> None:
        baud, self._baud_after_drain = self._baud_after_drain, None
        if baud is None or self._closed:
            return
        try:
            if self._fd is not None:
                termios.tcdrain(self._fd)  # the confirmation leaves at the old rate (a few ms)
            self._ser.baudrate = baud  # rfc2217: SET-BAUDRATE to the server, in stream order
        except (OSError, ValueError, serial.SerialException) as exc:
            self.notes.append(f"{self.name}: {self.target}: cannot switch to {baud} bit/s: {exc}")
            return
        self.framing = replace(self.framing, baud_bps=baud)
        self.line = LineSettings(baud, self.framing.bytesize, self.framing.parity, self.framing.stopbits)
        self.stats.line_changes += 1

    def write_tracked(self, data: bytes) -> int:
        self.write(data)
        return 0

    async def confirm(self, want: int, timeout_s: float = 0.05) -> bool:
        """Wait until everything written is handed to the driver (the far side's reads are
        not observable on a real line)."""
        from hil import clock

        deadline = clock.monotonic_ns() + int(timeout_s * 1e9)
        while self._pending and not self._closed:
            if clock.monotonic_ns() > deadline:
                self.stats.delivery_timeouts += 1
                return False
            await asyncio.sleep(0)
        return True

    async def write_confirmed(self, data: bytes, timeout_s: float = 0.05) -> bool:
        return await self.confirm(self.write_tracked(data), timeout_s)

    def close(self) -> None:
        if self._shut:
            return
        self._shut = self._closed = True
        self._stop.set()
        if self._loop is not None and self._fd is not None:
            self._loop.remove_reader(self._fd)
            if self._writer_registered:
                self._loop.remove_writer(self._fd)
                self._writer_registered = False
        try:
            self._ser.close()
        except (OSError, serial.SerialException):
            pass
        if self._thread is not None:
            self._thread.join(timeout=1.0)

