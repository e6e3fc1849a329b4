"""Test helpers for real serial lines without hardware.

* :func:`null_modem`: a socat pty pair, the software twin of a null-modem cable between two
  USB-serial adapters. Both ends are real ttys; whatever one writes the other reads.
* :func:`loopback_server`: a one-connection TCP server on 127.0.0.1, the twin of a serial
  server (ser2net) for ``socket://`` URLs; the test talks through the accepted socket.

Readiness is waited on, never slept for: socat says "starting data transfer loop" on stderr
once both ptys exist.
"""

from __future__ import annotations

import asyncio
import shutil
import socket
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import pytest


@asynccontextmanager
async def null_modem(directory: Path, name: str = "line") -> AsyncIterator[tuple[str, str]]:
    """Two linked pty paths ``(bench_end, client_end)`` in ``directory``."""
    socat = shutil.which("socat")
    if socat is None:
        pytest.skip("socat is not installed (.ci/run installs it)")
    a, b = directory / f"{name}-bench", directory / f"{name}-client"
    proc = await asyncio.create_subprocess_exec(
        socat, "-d", "-d", f"pty,rawer,link={a}", f"pty,rawer,link={b}",
        stdin=asyncio.subprocess.DEVNULL, stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.PIPE,
    )
    assert proc.stderr is not None
    seen: list[str] = []
    try:
        while True:
            line = (await asyncio.wait_for(proc.stderr.readline(), 10)).decode(errors="replace")
            if not line:
                raise RuntimeError(f"socat exited: {''.join(seen)}")
            seen.append(line)
            if "starting data transfer loop" in line:
                break
        # keep draining socat's stderr so it never blocks on a full pipe
        drain = asyncio.create_task(proc.stderr.read())
        yield str(a), str(b)
    finally:
        if proc.returncode is None:
            proc.terminate()
            await proc.wait()
        if "drain" in locals():
            drain.cancel()


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
