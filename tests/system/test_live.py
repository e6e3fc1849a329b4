"""``hil run --live``: an independent foxglove.sdk.v1 client (tests/system/live_client.py) sees
the run and steers it; a bad /hil/inject changes nothing; the live view never changes the flight.

Readiness is waited on (the URL's announcement, events on /hil/events), never slept for.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import json
from collections.abc import AsyncIterator
from typing import Any

import pytest
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

from hil.live.topics import DEFAULT_TOPICS, INJECT_TOPIC, STEER_TOPIC, LiveConfig
from hil.record import iter_messages
from tests.system.conftest import explain
from tests.system.live_client import LiveClient

pytestmark = [pytest.mark.system, pytest.mark.pty]


def events(client: LiveClient) -> list[dict[str, Any]]:
    return [json.loads(p) for _, p in client.messages["/hil/events"]]


def live_events(client: LiveClient, name: str) -> list[dict[str, Any]]:
    return [e for e in events(client) if e["kind"] == "live" and e["name"] == name]


def decode_protobuf(channel: dict[str, Any], payload: bytes) -> Any:
    """A message decoded with nothing but the schema the server advertised."""
    fds = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for f in fds.file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"])).FromString(payload)


class GatedRun:
    """A live run whose tick 0 waits until the test's client is connected (an ``on_ready``
    gate: it changes nothing in the flight)."""

    def __init__(self, topics: tuple[str, ...] = DEFAULT_TOPICS, *, read_delay_s: float = 0.0) -> None:
        self.url: asyncio.Future[str] = asyncio.get_running_loop().create_future()
        self.open = asyncio.Event()
        self.config = LiveConfig(topics=topics, announce=self.url.set_result)
        self.read_delay_s = read_delay_s

    def on_ready(self, loop: Any, devices: Any, runner: Any) -> None:
        async def gate() -> None:
            await self.open.wait()

        loop.tick_gate = gate

    async def client(self) -> LiveClient:
        client = LiveClient(await self.url, read_delay_s=self.read_delay_s)
        await client.connect()
        return client


TICK_NS = 2_500_000


def stop_time(client: LiveClient, i: int) -> int:
    """Log time (Unix ns) of the ``i``-th "paused" event: where the run stopped."""
    stops = [t for t, p in client.messages["/hil/events"] if json.loads(p)["name"] == "paused"]
    return stops[i]


async def stop(run: GatedRun, flight: asyncio.Task[Any]) -> None:
    """A failed test ends its run (finalized) rather than leave it paused."""
    run.open.set()
    if not flight.done():
        flight.cancel()
    await asyncio.gather(flight, return_exceptions=True)


@contextlib.asynccontextmanager
async def connected(run: GatedRun, flight: asyncio.Task[Any]) -> AsyncIterator[LiveClient]:
    """The test's client on ``run``'s server; on the way out it closes, and a run still flying
    (a failed test) is ended finalized rather than left paused."""
    try:
        client = await run.client()
    except BaseException:
        await stop(run, flight)
        raise
    try:
        yield client
    finally:
        await client.close()
        await stop(run, flight)


async def paused_after(client: LiveClient, run: GatedRun, ticks: int) -> None:
    """Let the gated run fly ``ticks`` ticks, then wait until it stands paused."""
    await client.subscribe("/hil/events")
    await client.advertise(1, STEER_TOPIC, "hil.Steer")
    await send_json(client, 1, {"command": "step", "ticks": ticks})
    run.open.set()
    await client.wait(lambda: live_events(client, "paused"))


async def send_json(client: LiveClient, channel_id: int, msg: Any) -> None:
    await client.publish(channel_id, msg if isinstance(msg, bytes) else json.dumps(msg).encode())


async def test_client_sees_steers_and_injects(fly):
    run = GatedRun()
    flight = asyncio.create_task(fly("hover", duration_s=3.0, live=run.config, on_ready=run.on_ready))
    async with connected(run, flight) as client:
        info = client.server_info
        assert {"time", "clientPublish", "playbackControl"} <= set(info["capabilities"])
        assert "json" in info["supportedEncodings"]
        topics = {ch["topic"] for ch in client.channels.values()}
        assert set(DEFAULT_TOPICS) | {INJECT_TOPIC, STEER_TOPIC} == topics
        inject_schema = json.loads(client.channel(INJECT_TOPIC)["schema"])
        assert inject_schema["required"] == ["kind"]
        await client.subscribe("/sim/truth", "/hil/events", "/hil/esc/output")
        [tf_sub] = await client.subscribe("/tf")
        await client.advertise(1, STEER_TOPIC, "hil.Steer")
        await client.advertise(2, INJECT_TOPIC, "hil.Inject")
        await send_json(client, 1, {"command": "step", "ticks": 400})  # 1 s, then paused
        run.open.set()
        await client.wait(lambda: live_events(client, "paused"))
        t_pause = stop_time(client, 0)
        # paused: the clock stopped; what came before is all in (the event came after it)
        assert client.messages["/tf"] and client.times
        assert max(t for t, _ in client.messages["/sim/truth"]) <= t_pause
        await client.unsubscribe(tf_sub)
        # bad messages: an error each on /hil/events, nothing else
        for bad in ({"kind": "no.such.fault"}, {"kind": "baro.bias", "bias_Pa": "much"}, b"{not json"):
            await send_json(client, 2, bad)
        await send_json(client, 1, {"command": "fly"})
        await send_json(client, 1, {"command": "step", "ticks": 8})
        await client.wait(lambda: len(live_events(client, "paused")) == 2)
        await send_json(client, 2, {"kind": "baro.bias", "bias_Pa": 50.0, "duration_s": 0.2})
        await send_json(client, 1, {"command": "step", "ticks": 8})
        await client.wait(lambda: len(live_events(client, "paused")) == 3)
        errors = [e["detail"] for e in live_events(client, "error")]
        assert [e["topic"] for e in errors] == [STEER_TOPIC] + [INJECT_TOPIC] * 3, errors
        assert "command: must be pause, resume or step" in errors[0]["error"]
        assert "no.such.fault" in errors[1]["error"]
        assert "bias_Pa" in errors[2]["error"]
        assert "malformed JSON" in errors[3]["error"]
        faults = [e for e in events(client) if e["kind"] == "fault"]
        assert [e["name"] for e in faults] == ["baro.bias start"], faults
        assert live_events(client, "inject")[0]["detail"]["fault"]["bias_Pa"] == 50.0
        # each step ran its 8 ticks and stopped; /tf stayed unsubscribed; the app's clock followed
        assert stop_time(client, 2) - stop_time(client, 1) == stop_time(client, 1) - t_pause == 8 * TICK_NS
        assert all(t <= t_pause for t, _ in client.messages["/tf"])
        assert t_pause < max(client.times) <= stop_time(client, 2)
        truth = decode_protobuf(client.channel("/sim/truth"), client.messages["/sim/truth"][-1][1])
        assert 0.0 <= truth.h_m < 5.0
        await send_json(client, 1, {"command": "resume"})
        result = await flight
    assert result.end_reason.value == "completed", explain(result)
    recorded = [m for _, _, m in iter_messages(result.log_path, topics=["/hil/events"])]
    assert any(m["kind"] == "live" and m["name"] == "inject" for m in recorded)


async def test_live_view_and_pause_never_change_the_flight(fly, tmp_path):
    """Same seed: without --live; with a slow client subscribed to every topic; and paused
    for wall seconds at sim 2 s. The truth and every control wire are identical."""
    from hil.record.topics import TOPICS
    from tests.system.test_determinism import assert_same_flight

    plain = await fly("hover", duration_s=3.0, out_dir=tmp_path / "plain")

    slow = GatedRun(tuple(TOPICS), read_delay_s=0.01)  # reads 100 frames a second: the server drops
    flight = asyncio.create_task(fly("hover", duration_s=3.0, out_dir=tmp_path / "slow", live=slow.config,
                                     on_ready=slow.on_ready))
    async with connected(slow, flight) as client:
        await client.subscribe(*TOPICS)
        slow.open.set()
        watched = await flight
    assert client.messages["/sim/truth"]  # it did see the flight, slowly
    assert_same_flight(plain, watched)

    held = GatedRun()
    flight = asyncio.create_task(fly("hover", duration_s=3.0, out_dir=tmp_path / "held", live=held.config,
                                     on_ready=held.on_ready))
    async with connected(held, flight) as client:
        await paused_after(client, held, 800)
        await asyncio.sleep(2.0)  # the pause itself: the flight code waits these wall seconds
        await send_json(client, 1, {"command": "resume"})
        paused = await flight
    assert live_events(client, "paused")[0]["detail"]["t_s"] == pytest.approx(1.9975)
    assert_same_flight(plain, paused)


async def test_a_paused_run_goes_on_when_the_recorder_and_server_die(fly):
    """The live server lives in the recorder's child process: killed while the app holds the
    run paused, the run must not wait for a resume that cannot come. It flies on to its end
    and says what happened (the recording itself is lost with its writer: `hil recover`)."""
    import psutil

    run = GatedRun()
    flight = asyncio.create_task(fly("hover", duration_s=1.0, live=run.config, on_ready=run.on_ready))
    async with connected(run, flight) as client:
        await paused_after(client, run, 40)
        me = psutil.Process()
        # the recorder is forked without exec: a child with this process's command line
        [recorder] = [p for p in me.children() if p.cmdline() == me.cmdline()]
        recorder.kill()
        result = await asyncio.wait_for(asyncio.shield(flight), 120)
    assert any("the live server ended at t = 0.098 s" in n for n in result.notes), result.notes
    assert result.end_reason.value == "bench error" and "not finalized" in result.message
    part = [n for n in result.notes if "hil recover" in n]
    assert part and ".mcap.part" in part[0], result.notes
