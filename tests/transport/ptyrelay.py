"""A null-modem pty pair for the tests when socat is not installed.

    python ptyrelay.py LINK_A LINK_B

makes two pseudo-terminals, links ``LINK_A`` and ``LINK_B`` to their slave ends and copies
bytes between the two masters in both directions until SIGTERM, SIGINT or SIGHUP, or end of
file on stdin when stdin is a pipe (so a test that dies takes its relay with it). It does what
``socat -d -d pty,rawer,link=LINK_A pty,rawer,link=LINK_B`` does for the tests:

* both slaves start with the settings socat's ``rawer`` leaves (``RAWER``, read from socat
  1.7.4.4: no input or output processing, 8 data bits, receiver on, no echo, no signals, speed
  B0). A program that opens an end sets its own rate and framing on that end; as with socat
  they stay on that end (the kernel keeps them; a pty carries bytes, not a bit rate).
* the relay keeps both slaves open, as socat does, so a program may close its end and open it
  again while the line stays up;
* at most one read (8192 bytes, socat's default buffer) waits per direction: an end that
  nobody reads fills, then the relay stops reading the other end, whose writer then sees a
  full line, as through socat;
* modem lines (RTS/CTS/DTR/DSR/DCD/RI) and breaks are not carried: a pty has none
  (TIOCMGET fails on either end with ENOTTY), the same with socat;
* a file already at a link's path is replaced, and the links are removed on exit; a stop
  signal ends it with status 128 + the signal's number.

Readiness is announced on stderr with socat's words: ``starting data transfer loop``.
Only the standard library is used: the tests run it with ``python -I -S``.
"""

from __future__ import annotations

import errno
import os
import select
import signal
import stat
import sys
import termios

BUFFER_BYTES = 8192

#: [iflag, oflag, cflag, lflag, ispeed, ospeed] of a slave right after ``socat pty,rawer``
RAWER = [0, 0, termios.CS8 | termios.CREAD, 0, termios.B0, termios.B0]


class _Stop(Exception):
    """A stop signal arrived."""


def _stop(signum: int, frame: object) -> None:
    raise _Stop(signum)


def _make_pty() -> tuple[int, int]:
    master, slave = os.openpty()
    attrs = termios.tcgetattr(slave)
    attrs[:6] = RAWER
    attrs[6][termios.VMIN] = 1
    attrs[6][termios.VTIME] = 0
    termios.tcsetattr(slave, termios.TCSANOW, attrs)
    os.set_blocking(master, False)
    return master, slave


def _replace_link(target: str, link: str) -> None:
    """Link ``link`` to ``target``, replacing a file already there (socat's ``link=`` does)."""
    try:
        os.symlink(target, link)
    except FileExistsError:
        os.unlink(link)
        os.symlink(target, link)


def _log(message: str) -> None:
    sys.stderr.write(f"ptyrelay[{os.getpid()}] N {message}\n")
    sys.stderr.flush()


class _Direction:
    """Bytes from one master to the other, with at most one read in flight."""

    def __init__(self, src: int, dst: int) -> None:
        self.src, self.dst = src, dst
        self.pending = b""

    def on_readable(self) -> None:
        self.pending = os.read(self.src, BUFFER_BYTES)
        self.on_writable()  # most writes go through at once: no extra wake-up

    def on_writable(self) -> None:
        try:
            written = os.write(self.dst, self.pending)
        except BlockingIOError:
            return
        self.pending = self.pending[written:]


def relay(masters: tuple[int, int], stdin_fd: int | None) -> None:
    """Copy until a stop signal or end of file on ``stdin_fd``."""
    a, b = masters
    directions = (_Direction(a, b), _Direction(b, a))
    poller = select.poll()
    if stdin_fd is not None:
        poller.register(stdin_fd, select.POLLIN)
    registered: dict[int, int] = {}
    while True:
        wanted: dict[int, int] = {}
        for d in directions:
            if d.pending:
                wanted[d.dst] = wanted.get(d.dst, 0) | select.POLLOUT
            else:
                wanted[d.src] = wanted.get(d.src, 0) | select.POLLIN
        for fd in set(registered) | set(wanted):
            if fd not in wanted:
                poller.unregister(fd)
            elif fd not in registered:
                poller.register(fd, wanted[fd])
            elif registered[fd] != wanted[fd]:
                poller.modify(fd, wanted[fd])
        registered = wanted
        for fd, events in poller.poll():
            if fd == stdin_fd:
                if not os.read(stdin_fd, 4096):
                    return
                continue
            if events & (select.POLLERR | select.POLLNVAL):
                raise OSError(errno.EIO, f"pty master {fd}: poll events {events:#x}")
            for d in directions:
                if fd == d.dst and d.pending and events & select.POLLOUT:
                    d.on_writable()
                if fd == d.src and not d.pending and events & (select.POLLIN | select.POLLHUP):
                    d.on_readable()


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        sys.stderr.write("usage: ptyrelay.py LINK_A LINK_B\n")
        return 2
    for signum in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
        signal.signal(signum, _stop)
    links: list[str] = []
    fds: list[int] = []
    status = 0
    try:
        masters = []
        for link in argv:
            master, slave = _make_pty()
            fds += [master, slave]  # the slave stays open: the line outlives its users' closes
            _replace_link(os.ttyname(slave), link)
            links.append(link)
            _log(f"PTY is {os.ttyname(slave)}")
            masters.append(master)
        stdin_fd = 0 if stat.S_ISFIFO(os.fstat(0).st_mode) else None
        _log(f"starting data transfer loop with FDs [{masters[0]},{masters[0]}] and [{masters[1]},{masters[1]}]")
        relay((masters[0], masters[1]), stdin_fd)
    except _Stop as stop:
        status = 128 + stop.args[0]  # socat's exit status on a signal
    finally:
        for signum in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
            signal.signal(signum, signal.SIG_IGN)
        for link in links:
            try:
                os.unlink(link)
            except FileNotFoundError:
                pass
        for fd in fds:
            os.close(fd)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
