"""``hil run --gdb PORT``: a GDB remote port on the emulated LPC2148's core (docs/board.md).

The server takes one debugger at a time on TCP. The run waits for it before the firmware's
first instruction, as a board held in reset by a JTAG probe would; from then on the tick loop
holds while the debugger holds the core (a breakpoint, a step, GDB's interrupt) and goes on
when it continues. Sim time does not move while the core is held, so a debugging session
changes nothing the flight sees but the wall time. The protocol's commands are
hil/board/debug.py's; the framing is hil/board/rsp.py's.

A debugger that disconnects while the core is held detaches (its breakpoints go, the core
runs on); ``kill`` ends the run as the firmware's end, its log finalized.
"""

from __future__ import annotations

import asyncio
import contextlib

from hil.board import rsp
from hil.board.core import Core
from hil.board.debug import Debugger, Resume


class GdbServer:
    """The TCP side of a :class:`Debugger` (see the module docstring)."""

    def __init__(self, core: Core, host: str = "127.0.0.1", port: int = 0) -> None:
        self.debugger = Debugger(core)
        self.host, self.port = host, port
        self.killed = False
        self._server: asyncio.Server | None = None
        self._writer: asyncio.StreamWriter | None = None
        self._reader_task: asyncio.Task[None] | None = None
        self._packets: asyncio.Queue[bytes | None] = asyncio.Queue()  #: None: the client left
        self._connected = asyncio.Event()
        self._decoder = rsp.Decoder()

    async def start(self) -> int:
        """Listen; returns the port (an ephemeral one for ``port`` 0)."""
        self._server = await asyncio.start_server(self._accept, self.host, self.port)
        self.port = int(self._server.sockets[0].getsockname()[1])
        return self.port

    async def close(self) -> None:
        if self._reader_task is not None:
            self._reader_task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._reader_task
        if self._writer is not None:
            self._writer.close()
        if self._server is not None:
            self._server.close()
            await self._server.wait_closed()

    # -- the connection ---------------------------------------------------------------------------
    async def _accept(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        if self._writer is not None:  # one debugger at a time
            writer.close()
            return
        self._writer = writer
        self._decoder = rsp.Decoder()
        self._connected.set()
        self._reader_task = asyncio.current_task()
        try:
            while True:
                data = await reader.read(4096)
                if not data:
                    break
                self._take(data)
        except (ConnectionError, asyncio.CancelledError):
            pass
        finally:
            self._writer = None
            self._connected.clear()
            self._packets.put_nowait(None)
            writer.close()

    def _take(self, data: bytes) -> None:
        dec = self._decoder
        for item in dec.feed(data):
            if isinstance(item, rsp.Packet):
                self._send_raw(b"+")
                self._packets.put_nowait(item.data)
            elif item is rsp.Event.INTERRUPT:
                self.debugger.interrupt_requested = True
        while dec.nak_due:
            dec.nak_due -= 1
            self._send_raw(b"-")

    def _send_raw(self, data: bytes) -> None:
        if self._writer is not None and not self._writer.is_closing():
            self._writer.write(data)

    def _send(self, data: bytes) -> None:
        self._send_raw(rsp.encode(data))

    # -- holding the core -------------------------------------------------------------------------
    async def hold(self) -> None:
        """The core is halted: serve the debugger until it lets the core run (or ends the run:
        ``killed``). Waits for a debugger first if none is connected (the reset hold)."""
        dbg = self.debugger
        if self._writer is None:
            if dbg.stops:  # halted by a session that has gone: nothing holds the core now
                dbg.resume(Resume.DETACH)
                return
            await self._connected.wait()
        else:
            self._send(dbg.stop_reply())  # the stop a continue or a step was waiting for
        while True:
            packet = await self._packets.get()
            if packet is None:  # the debugger left while holding the core: it detaches
                if self._writer is None:
                    dbg.resume(Resume.DETACH)
                    return
                continue
            reply, how = dbg.command(packet)
            if reply is not None:
                self._send(reply)
            if how is Resume.STAY:
                continue
            if how is Resume.KILL:
                self.killed = True
                if self._writer is not None:
                    await self._writer.drain()
                return
            dbg.resume(how)
            if how is Resume.DETACH and self._writer is not None:
                await self._writer.drain()
                self._writer.close()
            return
