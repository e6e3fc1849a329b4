"""One conformance suite for every transport (trio ``check_two_way_stream`` idea).

A transport under test is given as a ``PortHarness``: the bench-side ``Port`` plus a
client end with ``open(baud)``, ``write``, ``read(n, timeout)``, ``close`` coroutines.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable
from contextlib import AbstractAsyncContextManager
from typing import Protocol

from hil.transport import LineSettings, Port
from hil.transport.base import Direction
from hil.transport.tap import WireCollector


class Client(Protocol):
    async def open(self, baud: int) -> None: ...
    async def set_baud(self, baud: int) -> None: ...
    async def write(self, data: bytes) -> None: ...
    async def read(self, n: int, timeout_s: float) -> bytes: ...
    async def close(self) -> None: ...


HarnessFactory = Callable[[], AbstractAsyncContextManager[tuple[Port, Client]]]


async def _collect(port: Port) -> tuple[asyncio.Queue[bytes], list[LineSettings]]:
    rx: asyncio.Queue[bytes] = asyncio.Queue()
    lines: list[LineSettings] = []
    port.on_data = lambda data, t_ns: rx.put_nowait(data)
    port.on_line = lines.append
    return rx, lines


async def _recv(rx: asyncio.Queue[bytes], n: int, timeout_s: float = 2.0) -> bytes:
    got = bytearray()
    while len(got) < n:
        got += await asyncio.wait_for(rx.get(), timeout_s)
    return bytes(got)


async def check_bench_to_client(make: HarnessFactory) -> None:
    async with make() as (port, client):
        await client.open(115200)
        payload = bytes(range(256)) * 4
        assert port.write(payload) == len(payload)
        assert await client.read(len(payload), 2.0) == payload


async def check_client_to_bench(make: HarnessFactory) -> None:
    async with make() as (port, client):
        rx, _ = await _collect(port)
        await client.open(115200)
        payload = bytes(range(256)) * 3
        await client.write(payload)
        assert await _recv(rx, len(payload)) == payload
        assert port.stats.bytes_rx == len(payload)


async def check_open_and_baud_noticed(make: HarnessFactory) -> None:
    async with make() as (port, client):
        _, lines = await _collect(port)
        opened = asyncio.Event()
        changed = asyncio.Event()
        orig = port.on_line

        def on_line(s: LineSettings) -> None:
            orig(s)
            (opened if s.opened else changed).set()

        port.on_line = on_line
        await client.open(921600)
        await asyncio.wait_for(opened.wait(), 2.0)
        assert port.line is not None and port.line.baud == 921600
        await client.set_baud(57600)
        await asyncio.wait_for(changed.wait(), 2.0)
        assert port.line.baud == 57600
        assert port.stats.opens >= 1 and port.stats.line_changes >= 1


async def check_overflow_counted(make: HarnessFactory) -> None:
    """A client that never reads: the bench keeps going and counts the loss."""
    async with make() as (port, client):
        await client.open(115200)
        chunk = b"\x55" * 1024
        for _ in range(200):  # 200 KiB >> tty buffer + port buffer (64 KiB)
            port.write(chunk)
            await asyncio.sleep(0)
        assert port.stats.overflow_bytes > 0
        assert port.stats.overflow_events > 0


async def check_tap_sees_both_directions(make: HarnessFactory) -> None:
    async with make() as (port, client):
        rx, _ = await _collect(port)
        tap = WireCollector()
        port.taps.append(tap)
        port.sim_time = lambda: 12_345
        await client.open(115200)
        port.write(b"hello")
        assert await client.read(5, 2.0) == b"hello"
        await client.write(b"world!")
        await _recv(rx, 6)
        assert tap.joined(port.name, Direction.TX) == b"hello"
        assert tap.joined(port.name, Direction.RX) == b"world!"
        assert all(r.t_ns == 12_345 for r in tap.records)


async def check_reopen(make: HarnessFactory) -> None:
    """The client closes and reopens; the bench side keeps working (no EIO)."""
    async with make() as (port, client):
        rx, _ = await _collect(port)
        await client.open(115200)
        await client.write(b"a")
        await _recv(rx, 1)
        await client.close()
        port.write(b"lost-or-flushed")  # written while nobody has the port open
        await asyncio.sleep(0)
        await client.open(115200)
        port.write(b"xyz")
        assert (await client.read(3, 2.0)) == b"xyz"
        await client.write(b"b")
        assert await _recv(rx, 1) == b"b"


async def check_write_confirmed(make: HarnessFactory) -> None:
    async with make() as (port, client):
        await client.open(115200)
        assert await port.write_confirmed(b"frame-1", 1.0)
        assert await client.read(7, 1.0) == b"frame-1"


async def check_client_consumed(make: HarnessFactory) -> None:
    """What the client has read, against what the port took (how the bench tells whether the
    flight code has begun reading the newest IMU sample)."""
    async with make() as (port, client):
        await client.open(115200)
        start = port.accepted_bytes()
        port.write(b"0123456789")
        assert port.accepted_bytes() == start + 10
        assert port.client_consumed() == start
        assert await client.read(4, 1.0) == b"0123"
        assert port.client_consumed() == start + 4
        assert await client.read(6, 1.0) == b"456789"
        assert port.client_consumed() == start + 10


async def check_client_end_unseen(make: HarnessFactory) -> None:
    """A real serial line: the bench cannot see what the far end has read, and says so."""
    async with make() as (port, client):
        await client.open(115200)
        port.write(b"0123")
        assert port.client_consumed() is None
        assert await client.read(4, 1.0) == b"0123"


ALL_CHECKS = [
    check_bench_to_client,
    check_client_to_bench,
    check_open_and_baud_noticed,
    check_overflow_counted,
    check_tap_sees_both_directions,
    check_reopen,
    check_write_confirmed,
    check_client_consumed,
]




#: a real serial line (SerialPort): the bench owns the line settings (no client termios to
#: notice) and a null-modem peer that closes may end the line, so those two checks do not apply
SERIAL_CHECKS = [
    check_bench_to_client,
    check_client_to_bench,
    check_overflow_counted,
    check_tap_sees_both_directions,
    check_write_confirmed,
    check_client_end_unseen,
]
#: socket:// - the kernel's TCP buffers hold megabytes, so a non-reading peer shows no overflow soon
SOCKET_CHECKS = [c for c in SERIAL_CHECKS if c is not check_overflow_counted]


async def _unused() -> AsyncIterator[None]:  # pragma: no cover - typing helper
    yield None
