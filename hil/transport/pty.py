"""Linux pseudo-terminal port.

The bench holds the master; the client (flight code) opens the slave through a stable
symlink in the run directory. Design points (checked by tests/pty/):

* The bench keeps its own slave fd open for the port's whole life, so the master never
  reads EIO when the client closes and reopens.
* The slave is raw and mode 0600; the run directory is created 0700 by the caller.
* TIOCPKT with EXTPROC on the slave turns client opens (pyserial flushes input) and
  termios changes (baud) into status packets on the master, so we learn the client's
  line settings without polling.
* Writes never block the loop: the master is non-blocking; what the kernel will not take
  waits in a bounded buffer drained by ``add_writer``; beyond the bound bytes are dropped
  and counted (like a UART overrun), never hidden.
* ``write_confirmed`` makes sure the client can actually read the bytes: pty delivery goes
  through a kernel work item, which a zero-timeout poll of the tty runs at once (``flush``).
"""

from __future__ import annotations

import array
import asyncio
import errno
import fcntl
import os
import select
import struct
import termios
import tty
from pathlib import Path

from hil.transport.base import BufferedWrites, Direction, LineSettings

EXTPROC = 0o200000  # not exported by the termios module
TIOCPKT_DATA = 0
TIOCPKT_FLUSHREAD = 1
TIOCPKT_IOCTL = 64
TCGETS2 = 0x802C542A  # x86_64/aarch64
BOTHER = 0o010000

_BAUD_BY_CONST = {
    getattr(termios, f"B{rate}"): rate
    for rate in (
        50, 75, 110, 134, 150, 200, 300, 600, 1200, 1800, 2400, 4800, 9600, 19200, 38400,
        57600, 115200, 230400, 460800, 500000, 576000, 921600, 1000000, 1152000, 1500000,
        2000000, 2500000, 3000000, 3500000, 4000000,
    )
    if hasattr(termios, f"B{rate}")
}


def _read_line_settings(fd: int, opened: bool) -> LineSettings:
    """Decode the slave's termios (read through ``fd``) into :class:`LineSettings`."""
    iflag, oflag, cflag, lflag, ispeed, ospeed, cc = termios.tcgetattr(fd)
    baud = _BAUD_BY_CONST.get(ospeed)
    if ospeed == BOTHER or (cflag & termios.CBAUD) == BOTHER:
        buf = array.array("i", [0] * 64)
        try:
            fcntl.ioctl(fd, TCGETS2, buf)
            baud = buf[10]  # c_ospeed
        except OSError:
            baud = None
    size = {termios.CS5: 5, termios.CS6: 6, termios.CS7: 7, termios.CS8: 8}[cflag & termios.CSIZE]
    parity = "N"
    if cflag & termios.PARENB:
        parity = "O" if cflag & termios.PARODD else "E"
    stopbits = 2 if cflag & termios.CSTOPB else 1
    return LineSettings(baud, size, parity, stopbits, opened)


class WriteLog:
    """Writes the bench made to a group of ports, for a reader that must know whether and
    where anything was written since it last looked (the virtual-time scheduler, once or
    more a tick): a running count and the ports written since ``take``."""

    __slots__ = ("count", "_written")

    def __init__(self) -> None:
        self.count = 0  #: writes so far, never reset
        self._written: set[PtyPort] = set()

    def note(self, port: PtyPort) -> None:
        self.count += 1
        self._written.add(port)

    def take(self) -> set[PtyPort] | frozenset[PtyPort]:
        """The ports written since the last call (then none)."""
        written = self._written
        if not written:
            return frozenset()
        self._written = set()
        return written


class PtyPort(BufferedWrites):
    """A pty whose slave is published as ``<dev_dir>/<name>``."""

    def __init__(self, name: str, dev_dir: str | os.PathLike[str], *, buffer_limit: int = 65536) -> None:
        super().__init__(name, buffer_limit=buffer_limit)
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        attrs = termios.tcgetattr(self._slave)
        attrs[3] |= EXTPROC
        termios.tcsetattr(self._slave, termios.TCSANOW, attrs)
        os.fchmod(self._slave, 0o600)
        os.set_blocking(self._master, False)
        fcntl.ioctl(self._master, termios.TIOCPKT, struct.pack("i", 1))
        self.tty_name = os.ttyname(self._slave)
        st_rdev = os.fstat(self._slave).st_rdev
        #: the slave's device number as the clock shim publishes a wait on it (hil/vtime)
        self.rdev_key = (os.major(st_rdev) << 20) | os.minor(st_rdev)
        self._link = Path(dev_dir) / name
        if self._link.is_symlink() or self._link.exists():
            self._link.unlink()
        self._link.symlink_to(self.tty_name)
        self._pending = bytearray()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._writer_registered = False
        self._closed = False
        self.line = _read_line_settings(self._slave, opened=False)
        #: told of every write, if set (``hil.vtime``'s scheduler)
        self.write_log: WriteLog | None = None

    @property
    def path(self) -> str:
        return str(self._link)

    @property
    def master_fd(self) -> int:
        return self._master

    @property
    def slave_fd(self) -> int:
        """The bench's own descriptor of the slave (never read: readiness checks only)."""
        return self._slave

    @property
    def writes(self) -> int:
        return self.stats.writes

    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._loop.add_reader(self._master, self._on_readable)

    # -- client -> bench -------------------------------------------------------------------
    def _on_readable(self) -> None:
        self._read_packet()

    def _read_packet(self) -> bool:
        """Read and dispatch one packet; False if there was nothing to read."""
        try:
            pkt = os.read(self._master, 65537)
        except BlockingIOError:
            return False
        except OSError as exc:  # EIO cannot happen while we hold the slave; be safe anyway
            if exc.errno == errno.EIO:
                return False
            raise
        if not pkt:
            return False
        status = pkt[0]
        if status == TIOCPKT_DATA:
            if len(pkt) > 1:
                self._deliver_rx(pkt[1:])
            return True
        if status & (TIOCPKT_FLUSHREAD | TIOCPKT_IOCTL):
            self._line_changed(_read_line_settings(self._master, opened=bool(status & TIOCPKT_FLUSHREAD)))
        return True

    def read_available(self) -> bool:
        """Take in what the client has written: one read, for a caller that has just seen the
        master readable and polls again before it relies on having taken everything (a
        second read would mostly find nothing, at the cost of a failed system call)."""
        return self._read_packet()

    # -- bench -> client -------------------------------------------------------------------
    def write(self, data: bytes) -> int:
        if self._closed or not data:
            return 0
        self.stats.writes += 1
        if self.write_log is not None:
            self.write_log.note(self)
        self._tap(Direction.TX, data, self.sim_time())
        if self._pending:
            return self._buffer(data)
        try:
            n = os.write(self._master, data)
        except BlockingIOError:
            n = 0
        self.stats.bytes_tx += n
        if n < len(data):
            self._buffer(data[n:])
        return len(data)

    def _writer_fd(self) -> int | None:
        return self._master

    def _on_writable(self) -> None:
        try:
            n = os.write(self._master, self._pending)
        except BlockingIOError:
            return
        self.stats.bytes_tx += n
        del self._pending[:n]
        if not self._pending and self._loop is not None:
            self._loop.remove_writer(self._master)
            self._writer_registered = False

    def client_consumed(self) -> int | None:
        """Bytes the client has read: those handed to the pty, less those still readable at
        its end once the pty's delivery work has run (a flush)."""
        if self._closed:
            return None
        self.flush()
        return self.stats.bytes_tx - self.client_inq()

    def client_inq(self) -> int:
        """Bytes readable by the client right now (TIOCINQ on the bench's slave fd)."""
        buf = array.array("i", [0])
        fcntl.ioctl(self._slave, termios.FIONREAD, buf)
        return buf[0]

    async def write_confirmed(self, data: bytes, timeout_s: float = 0.05) -> bool:
        """Write, then wait until the client can read every byte (see :meth:`confirm`)."""
        return await self.confirm(self.write_tracked(data), timeout_s)

    def write_tracked(self, data: bytes) -> int:
        """Write and return the client-side byte count to :meth:`confirm` later.

        Splitting the two lets the bench do other work while the kernel's flush work item
        moves the bytes (a pty write is delivered asynchronously)."""
        want = self.client_inq() + len(data)
        self.write(data)
        return want

    def flush(self) -> None:
        """Run the pty's pending delivery work now: afterwards everything written so far is
        readable by the client (a zero-timeout poll of a tty does the flush first)."""
        if not self._closed:
            select.select([self._slave], [], [], 0)

    async def confirm(self, want: int, timeout_s: float = 0.05) -> bool:
        """Wait until the client can read ``want`` bytes (from :meth:`write_tracked`).

        Correct only while the client is not reading this port concurrently (the lockstep
        tick guarantees that: the flight code is blocked on the IMU). A flush makes written
        bytes readable at once; only bytes still waiting in our own buffer (the client let
        the kernel's fill) need time, and then the wait yields to the event loop. On timeout
        the delivery is counted in ``stats.delivery_timeouts`` and False is returned.
        """
        from hil import clock  # local: keep the import surface of this module small

        if self._pending_blocks(want):
            return True
        self.flush()
        if self.client_inq() >= want:
            return True
        deadline = clock.monotonic_ns() + int(timeout_s * 1e9)
        while self.client_inq() < want:
            if clock.monotonic_ns() > deadline:
                self.stats.delivery_timeouts += 1
                return False
            await asyncio.sleep(0)
            self.flush()
        return True

    def _pending_blocks(self, want: int) -> bool:
        # The n_tty buffer holds 4095 bytes; if the client let it fill, waiting cannot help.
        return want > 4095

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self._loop is not None:
            self._loop.remove_reader(self._master)
            if self._writer_registered:
                self._loop.remove_writer(self._master)
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        try:
            self._link.unlink()
        except FileNotFoundError:
            pass
