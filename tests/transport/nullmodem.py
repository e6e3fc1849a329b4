"""Test helpers for real serial lines without hardware.

* :func:`null_modem`: a pty pair bridged by a relay, the software twin of a null-modem cable
  between two USB-serial adapters. Both ends are real ttys; whatever one writes the other
  reads. The relay is socat when it is installed (an independent implementation, what CI
  uses) and otherwise :mod:`tests.transport.ptyrelay`, which the tests own (same pty
  settings, same behaviour for what the tests use; its docstring says what it carries).
* :func:`loopback_server`: a one-connection TCP server on 127.0.0.1, the twin of a serial
  server (ser2net) for ``socket://`` URLs; the test talks through the accepted socket.

Readiness is waited on, never slept for: both relays say "starting data transfer loop" on
stderr once both ptys exist.
"""

from __future__ import annotations

import asyncio
import shutil
import socket
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager, suppress
from pathlib import Path

PTY_RELAY = Path(__file__).with_name("ptyrelay.py")
#: how long a relay may take to come up, and to go when told to
RELAY_START_TIMEOUT_S = 10.0
RELAY_STOP_TIMEOUT_S = 5.0


def relay_command(a: Path, b: Path, *, own: bool = False) -> list[str]:
    """The command linking ``a`` and ``b``: socat if installed (and not ``own``), else the
    tests' own relay."""
    socat = None if own else shutil.which("socat")
    if socat is not None:
        return [socat, "-d", "-d", f"pty,rawer,link={a}", f"pty,rawer,link={b}"]
    return [sys.executable, "-I", "-S", str(PTY_RELAY), str(a), str(b)]


@asynccontextmanager
async def null_modem(directory: Path, name: str = "line", *, own_relay: bool = False,
                     started: list[asyncio.subprocess.Process] | None = None) -> AsyncIterator[tuple[str, str]]:
    """Two linked pty paths ``(bench_end, client_end)`` in ``directory``; the relay process is
    appended to ``started`` when given (for the relay's own tests)."""
    a, b = directory / f"{name}-bench", directory / f"{name}-client"
    # stdin is a pipe: our relay ends when it reads end of file, should this process die
    proc = await asyncio.create_subprocess_exec(
        *relay_command(a, b, own=own_relay),
        stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.PIPE,
    )
    if started is not None:
        started.append(proc)
    assert proc.stderr is not None
    seen: list[str] = []
    drain: asyncio.Task[bytes] | None = None
    try:
        while True:
            line = (await asyncio.wait_for(proc.stderr.readline(), RELAY_START_TIMEOUT_S)).decode(errors="replace")
            if not line:
                raise RuntimeError(f"the null-modem relay exited: {''.join(seen)}")
            seen.append(line)
            if "starting data transfer loop" in line:
                break
        # keep draining the relay's stderr so it never blocks on a full pipe
        drain = asyncio.create_task(proc.stderr.read())
        yield str(a), str(b)
    finally:
        if proc.returncode is None:
            proc.terminate()
            try:
                await asyncio.wait_for(proc.wait(), RELAY_STOP_TIMEOUT_S)
            except TimeoutError:
                proc.kill()
                await proc.wait()
        if proc.stdin is not None:
            proc.stdin.close()
        if drain is not None:
            drain.cancel()
            with suppress(asyncio.CancelledError):
                await drain


class LoopbackServer:
    """Accepts one connection; ``sock`` is the test's end of the ``socket://`` line."""

    def __init__(self) -> None:
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.url = f"socket://127.0.0.1:{self.listener.getsockname()[1]}"
        self.sock: socket.socket | None = None

    async def accept(self, timeout_s: float = 5.0) -> socket.socket:
        self.listener.settimeout(timeout_s)
        self.sock, _ = await asyncio.to_thread(self.listener.accept)
        self.sock.settimeout(0.05)
        return self.sock

    async def read(self, n: int, timeout_s: float = 2.0) -> bytes:
        assert self.sock is not None
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        got = bytearray()
        while len(got) < n and loop.time() < deadline:
            try:
                chunk = await asyncio.to_thread(self.sock.recv, n - len(got))
            except TimeoutError:
                continue
            if not chunk:
                break
            got += chunk
        return bytes(got)

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
        self.listener.close()


@asynccontextmanager
async def loopback_server() -> AsyncIterator[LoopbackServer]:
    server = LoopbackServer()
    try:
        yield server
    finally:
        server.close()


class Rfc2217Server:
    """A one-connection RFC 2217 (Telnet COM-port) server in front of a serial device, built
    on pyserial's own :class:`serial.rfc2217.PortManager` (the twin of ser2net in telnet
    mode): ``url`` is what the bench opens; ``device`` is the serial line behind it."""

    def __init__(self, device: str) -> None:
        import threading

        import serial

        self.listener = socket.create_server(("127.0.0.1", 0))
        self.url = f"rfc2217://127.0.0.1:{self.listener.getsockname()[1]}"
        class PtyLine(serial.Serial):
            """A pty has no modem lines (TIOCMGET/TIOCMBIS fail): report them idle, ignore sets."""

            cts = dsr = ri = cd = False  # type: ignore[assignment]

            def _update_rts_state(self) -> None:
                pass

            def _update_dtr_state(self) -> None:
                pass

            def _update_break_state(self) -> None:
                pass

        self.serial = PtyLine(device, 115200, timeout=0.05)
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._sock: socket.socket | None = None
        self._lock = threading.Lock()
        accept = threading.Thread(target=self._serve, name="rfc2217 server", daemon=True)
        accept.start()
        self._threads.append(accept)

    def write(self, data: bytes) -> None:  # PortManager's connection
        with self._lock:
            if self._sock is not None:
                self._sock.sendall(data)

    def _serve(self) -> None:
        import threading

        from serial.rfc2217 import PortManager

        self.listener.settimeout(0.1)
        while not self._stop.is_set():
            try:
                sock, _ = self.listener.accept()
            except TimeoutError:
                continue
            break
        else:
            return
        sock.settimeout(0.05)
        self._sock = sock
        manager = PortManager(self.serial, self)

        def to_serial() -> None:
            while not self._stop.is_set():
                try:
                    data = sock.recv(4096)
                except TimeoutError:
                    continue
                except OSError:
                    return
                if not data:
                    return
                self.serial.write(b"".join(manager.filter(data)))

        def to_network() -> None:
            while not self._stop.is_set():
                data = self.serial.read(self.serial.in_waiting or 1)
                if data:
                    self.write(b"".join(manager.escape(data)))

        for target in (to_serial, to_network):
            t = threading.Thread(target=target, daemon=True)
            t.start()
            self._threads.append(t)

    def close(self) -> None:
        self._stop.set()
        for t in self._threads:
            t.join(timeout=2.0)
        if self._sock is not None:
            self._sock.close()
        self.listener.close()
        self.serial.close()


@asynccontextmanager
async def rfc2217_server(device: str) -> AsyncIterator[Rfc2217Server]:
    server = Rfc2217Server(device)
    try:
        yield server
    finally:
        await asyncio.to_thread(server.close)
