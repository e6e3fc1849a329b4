"""Run the transport conformance suite on the in-memory twin and on a real pty."""

from __future__ import annotations

import asyncio
import os
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import pytest
import serial

from hil.transport import MemoryPort, Port, PtyPort
from tests.transport import conformance


class MemClient:
    def __init__(self, port: MemoryPort) -> None:
        self.c = port.client

    async def open(self, baud: int) -> None:
        self.c.open(baud)

    async def set_baud(self, baud: int) -> None:
        self.c.set_baud(baud)

    async def write(self, data: bytes) -> None:
        self.c.write(data)
        await asyncio.sleep(0)

    async def read(self, n: int, timeout_s: float) -> bytes:
        return await self.c.read(n, timeout_s)

    async def close(self) -> None:
        self.c.close()


class SerialClient:
    """A real pyserial client on the pty slave; blocking calls run in a thread."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.ser: serial.Serial | None = None

    async def open(self, baud: int) -> None:
        self.ser = await asyncio.to_thread(serial.Serial, self.path, baud, timeout=0.05)

    async def set_baud(self, baud: int) -> None:
        assert self.ser is not None
        self.ser.baudrate = baud

    async def write(self, data: bytes) -> None:
        assert self.ser is not None
        await asyncio.to_thread(self.ser.write, data)

    async def read(self, n: int, timeout_s: float) -> bytes:
        assert self.ser is not None
        ser = self.ser
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        got = bytearray()
        while len(got) < n and loop.time() < deadline:
            got += await asyncio.to_thread(ser.read, n - len(got))
        return bytes(got)

    async def close(self) -> None:
        if self.ser is not None:
            self.ser.close()
            self.ser = None


@asynccontextmanager
async def memory_harness() -> AsyncIterator[tuple[Port, MemClient]]:
    port = MemoryPort("dev")
    await port.start()
    try:
        yield port, MemClient(port)
    finally:
        port.close()


def pty_harness_factory(tmp_path: Path):
    @asynccontextmanager
    async def make() -> AsyncIterator[tuple[Port, SerialClient]]:
        dev = tmp_path / "dev"
        dev.mkdir(mode=0o700, exist_ok=True)
        port = PtyPort("imu", dev)
        await port.start()
        client = SerialClient(port.path)
        try:
            yield port, client
        finally:
            await client.close()
            port.close()

    return make


@pytest.mark.parametrize("check", conformance.ALL_CHECKS, ids=lambda f: f.__name__)
async def test_memory_port(check) -> None:
    await check(memory_harness)


@pytest.mark.pty
@pytest.mark.parametrize("check", conformance.ALL_CHECKS, ids=lambda f: f.__name__)
async def test_pty_port(check, tmp_path: Path) -> None:
    await check(pty_harness_factory(tmp_path))


@pytest.mark.pty
async def test_pty_symlink_and_modes(tmp_path: Path) -> None:
    dev = tmp_path / "dev"
    dev.mkdir(mode=0o700)
    port = PtyPort("imu", dev)
    try:
        link = Path(port.path)
        assert link.is_symlink() and os.readlink(link) == port.tty_name
        assert (os.stat(port.tty_name).st_mode & 0o777) == 0o600
        assert (os.stat(dev).st_mode & 0o777) == 0o700
    finally:
        port.close()
    assert not Path(port.path).exists()
