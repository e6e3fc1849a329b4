"""A small independent client of the foxglove.sdk.v1 WebSocket protocol (not foxglove-sdk's
own): what Foxglove or Lichtblick does to show a run, and to publish on /hil/inject.

Protocol: https://github.com/foxglove/foxglove-sdk (docs of the WebSocket protocol, "spec").
Text frames are JSON (``serverInfo``, ``advertise``, ``subscribe``...); binary frames start
with an opcode: server 1 = message data (u32 subscription id, u64 log time, payload),
2 = time (u64 ns); client 1 = message data (u32 client channel id, payload).
"""

from __future__ import annotations

import asyncio
import json
import struct
from collections import defaultdict
from typing import Any

import websockets

SUBPROTOCOL = "foxglove.sdk.v1"


class LiveClient:
    """Connects, keeps what the server said; ``read_delay_s`` makes it a slow reader."""

    def __init__(self, url: str, *, read_delay_s: float = 0.0) -> None:
        self.url = url
        self.read_delay_s = read_delay_s
        self.server_info: dict[str, Any] = {}
        self.channels: dict[int, dict[str, Any]] = {}  #: channel id -> advertised channel
        self.messages: dict[str, list[tuple[int, bytes]]] = defaultdict(list)  #: topic -> (log time, payload)
        self.times: list[int] = []
        self.status: list[dict[str, Any]] = []
        self._subs: dict[int, int] = {}  #: subscription id -> channel id
        self._next_sub = 1
        self._ws: Any = None
        self._task: asyncio.Task[None] | None = None
        self._changed = asyncio.Event()

    async def connect(self) -> None:
        self._ws = await websockets.connect(self.url, subprotocols=[SUBPROTOCOL], max_size=None)
        self._task = asyncio.create_task(self._read())
        await self.wait(lambda: self.server_info and self.channels)

    async def close(self) -> None:
        if self._ws is not None:
            await self._ws.close()
        if self._task is not None:
            self._task.cancel()
            await asyncio.gather(self._task, return_exceptions=True)

    async def _read(self) -> None:
        async for frame in self._ws:
            if self.read_delay_s:
                await asyncio.sleep(self.read_delay_s)
            if isinstance(frame, str):
                msg = json.loads(frame)
                op = msg.get("op")
                if op == "serverInfo":
                    self.server_info = msg
                elif op == "advertise":
                    for ch in msg["channels"]:
                        self.channels[ch["id"]] = ch
                elif op == "unadvertise":
                    for cid in msg["channelIds"]:
                        self.channels.pop(cid, None)
                elif op == "status":
                    self.status.append(msg)
            elif frame[0] == 1:
                sub, log_time = struct.unpack_from("<IQ", frame, 1)
                ch = self.channels.get(self._subs.get(sub, -1))
                if ch is not None:
                    self.messages[ch["topic"]].append((log_time, bytes(frame[13:])))
            elif frame[0] == 2:
                self.times.append(struct.unpack_from("<Q", frame, 1)[0])
            self._changed.set()

    async def wait(self, done: Any, timeout_s: float = 60.0) -> None:
        """Until ``done()`` is true (checked at every frame)."""
        async with asyncio.timeout(timeout_s):
            while not done():
                self._changed.clear()
                await self._changed.wait()

    def channel(self, topic: str) -> dict[str, Any]:
        return next(ch for ch in self.channels.values() if ch["topic"] == topic)

    async def subscribe(self, *topics: str) -> list[int]:
        subs = []
        for topic in topics:
            sid, self._next_sub = self._next_sub, self._next_sub + 1
            self._subs[sid] = self.channel(topic)["id"]
            subs.append({"id": sid, "channelId": self._subs[sid]})
        await self._ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
        return [s["id"] for s in subs]

    async def unsubscribe(self, *sub_ids: int) -> None:
        await self._ws.send(json.dumps({"op": "unsubscribe", "subscriptionIds": list(sub_ids)}))

    async def advertise(self, channel_id: int, topic: str, schema_name: str) -> None:
        await self._ws.send(json.dumps({"op": "advertise", "channels": [
            {"id": channel_id, "topic": topic, "encoding": "json", "schemaName": schema_name}]}))

    async def publish(self, channel_id: int, payload: bytes) -> None:
        await self._ws.send(struct.pack("<BI", 1, channel_id) + payload)
