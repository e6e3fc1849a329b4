"""In-memory twin of :class:`~hil.transport.pty.PtyPort` for fast, OS-free tests.

The client end (:class:`MemoryClient`) behaves like an opened serial port: ``open(baud)``
produces the same line notification a pyserial open does on a pty, ``write`` delivers to
the bench on the next loop iteration, ``read`` returns what the bench wrote. The client's
receive buffer is bounded like a tty's (4095 bytes), so overflow behaves the same.
"""

from __future__ import annotations

import asyncio

from hil.transport.base import Direction, LineSettings, Port

TTY_BUFFER = 4095


class MemoryClient:
    """The flight-code end of a :class:`MemoryPort`."""

    def __init__(self, port: MemoryPort) -> None:
        self._port = port
        self._rx = bytearray()
        self._readable = asyncio.Event()
        self.is_open = False

    def open(self, baud: int = 115200, bytesize: int = 8, parity: str = "N", stopbits: int = 1) -> None:
        self.is_open = True
        self._rx.clear()  # pyserial flushes input on open
        self._port._notify(LineSettings(baud, bytesize, parity, stopbits, opened=True))

    def set_baud(self, baud: int) -> None:
        line = self._port.line or LineSettings(None)
        self._port._notify(LineSettings(baud, line.bytesize, line.parity, line.stopbits, opened=False))

    def close(self) -> None:
        self.is_open = False

    def write(self, data: bytes) -> None:
        asyncio.get_running_loop().call_soon(self._port._deliver_rx, bytes(data))

    def in_waiting(self) -> int:
        return len(self._rx)

    def read_now(self, n: int = 1 << 20) -> bytes:
        out = bytes(self._rx[:n])
        del self._rx[:n]
        if self._port._pending:
            self._port._flush()
        if not self._rx:
            self._readable.clear()
        return out

    async def read(self, n: int, timeout_s: float = 1.0) -> bytes:
        """Read exactly ``n`` bytes or what arrived before the timeout."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while len(self._rx) < n:
            remaining = deadline - loop.time()
            if remaining <= 0:
                break
            self._readable.clear()
            try:
                await asyncio.wait_for(self._readable.wait(), remaining)
            except TimeoutError:
                break
        return self.read_now(n)

    def _push(self, data: bytes) -> int:
        room = TTY_BUFFER - len(self._rx)
        taken = data[: max(room, 0)]
        self._rx += taken
        if taken:
            self._readable.set()
        return len(taken)


class MemoryPort(Port):
    """A port whose client lives in the same process."""

    def __init__(self, name: str, *, buffer_limit: int = 65536) -> None:
        super().__init__(name, buffer_limit=buffer_limit)
        self.client = MemoryClient(self)
        self._pending = bytearray()

    def write(self, data: bytes) -> int:
        if not data:
            return 0
        self.stats.writes += 1
        self._tap(Direction.TX, data, self.sim_time())
        self._pending += data
        self._flush()
        return len(data)

    def _flush(self) -> None:
        n = self.client._push(bytes(self._pending))
        self.stats.bytes_tx += n
        del self._pending[:n]
        if len(self._pending) > self.buffer_limit:
            dropped = len(self._pending) - self.buffer_limit
            del self._pending[self.buffer_limit :]
            self.stats.overflow_bytes += dropped
            self.stats.overflow_events += 1

    def client_inq(self) -> int:
        return self.client.in_waiting()

    def accepted_bytes(self) -> int:
        return self.stats.bytes_tx + len(self._pending)

    def client_consumed(self) -> int | None:
        return self.stats.bytes_tx - self.client.in_waiting()

    async def write_confirmed(self, data: bytes, timeout_s: float = 0.05) -> bool:
        self.write(data)
        return not self._pending

    def write_tracked(self, data: bytes) -> int:
        self.write(data)
        return 0

    async def confirm(self, want: int, timeout_s: float = 0.05) -> bool:
        return not self._pending

    def _notify(self, settings: LineSettings) -> None:
        self._line_changed(settings)

    def close(self) -> None:
        self.client.close()
