"""``hil devices --live``: an independent foxglove.sdk.v1 client (tests/system/live_client.py) sees
the emulated devices in real time with a run's channels and schemas, has its pause refused
(realtime) and its /hil/inject faults started or refused, each with an event on /hil/events.

Readiness is waited on (the URL line on stderr, frames from the server), never slept for;
every wait has a timeout, and the command is stopped (Ctrl-C, then kill) whatever happens.
"""

from __future__ import annotations

import asyncio
import json
import os
import re
import signal
import sys
from pathlib import Path

import jsonschema
import pytest

from hil.live.topics import DEFAULT_TOPICS, INJECT_TOPIC, MIN_PERIOD_NS, STEER_TOPIC
from tests.system.live_client import LiveClient
from tests.system.test_live import decode_protobuf, events, live_events, send_json

pytestmark = [pytest.mark.system, pytest.mark.pty]

REPO = Path(__file__).resolve().parents[2]
URL = re.compile(rb"^live: (ws://127\.0\.0\.1:\d+)\s")
#: sim seconds the command is given: far more than the checks need; Ctrl-C ends it sooner
DURATION_S = 120


async def _url(proc: asyncio.subprocess.Process, seen: list[bytes]) -> str:
    """The URL the command prints on stderr (the lines before it kept in ``seen``)."""
    assert proc.stderr is not None
    while True:
        line = await asyncio.wait_for(proc.stderr.readline(), 60)
        assert line, b"".join(seen)  # the command ended without announcing a server
        seen.append(line)
        m = URL.match(line)
        if m:
            return m.group(1).decode()


async def _stop(proc: asyncio.subprocess.Process) -> tuple[bytes, bytes]:
    """Ctrl-C, as a person would; a command that does not end within the timeout is killed."""
    if proc.returncode is None:
        proc.send_signal(signal.SIGINT)
    try:
        return await asyncio.wait_for(proc.communicate(), 60)
    except TimeoutError:
        proc.kill()
        await proc.wait()
        raise


async def test_devices_live_as_a_client_sees_it(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    runs.mkdir()
    env = dict(os.environ, TMPDIR=str(runs), COLUMNS="300")
    proc = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "hil.cli", "devices", "--live", "--duration", str(DURATION_S),
        cwd=REPO, env=env, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    client: LiveClient | None = None
    seen: list[bytes] = []
    try:
        client = LiveClient(await _url(proc, seen))
        await client.connect()
        info = client.server_info
        assert {"time", "clientPublish", "playbackControl"} <= set(info["capabilities"])
        assert "json" in info["supportedEncodings"]
        assert {ch["topic"] for ch in client.channels.values()} == set(DEFAULT_TOPICS) | {INJECT_TOPIC, STEER_TOPIC}
        await client.subscribe("/hil/events", "/sim/truth", "/tf", "/sim/pose")
        await client.advertise(1, STEER_TOPIC, "hil.Steer")
        await client.advertise(2, INJECT_TOPIC, "hil.Inject")
        await client.wait(lambda: len(client.messages["/sim/truth"]) >= 3 and client.messages["/tf"] and client.times)

        # realtime: a pause changes nothing and is refused with an event
        await send_json(client, 1, {"command": "pause"})
        await client.wait(lambda: live_events(client, "error"))
        [refused] = [e["detail"] for e in live_events(client, "error")]
        assert refused["topic"] == STEER_TOPIC and "lockstep" in refused["error"], refused
        assert not live_events(client, "paused")

        # a catalogue fault starts (a live/inject event and the fault's own); an unknown kind is refused
        await send_json(client, 2, {"kind": "no.such.fault"})
        await send_json(client, 2, {"kind": "baro.bias", "bias_Pa": 50.0, "duration_s": 0.2})
        await client.wait(lambda: len(live_events(client, "error")) == 2 and live_events(client, "inject")
                          and any(e["kind"] == "fault" for e in events(client)))
        bad = live_events(client, "error")[1]["detail"]
        assert bad["topic"] == INJECT_TOPIC and "no.such.fault" in bad["error"], bad
        [inject] = live_events(client, "inject")
        assert inject["detail"]["fault"] == {"kind": "baro.bias", "bias_Pa": 50.0, "duration_s": 0.2}
        assert [e["name"] for e in events(client) if e["kind"] == "fault"][0] == "baro.bias start"

        # the schemas the server advertised decode its messages; the default set is at most 50 Hz
        truth = decode_protobuf(client.channel("/sim/truth"), client.messages["/sim/truth"][-1][1])
        assert truth.h_m >= 0.0 and truth.battery_V > 0.0
        for topic in ("/sim/pose", "/hil/events"):  # JSON topics: valid against the advertised JSON Schema
            channel = client.channel(topic)
            assert channel["schemaEncoding"] == "jsonschema", channel
            jsonschema.validate(json.loads(client.messages[topic][-1][1]), json.loads(channel["schema"]))
        for topic in ("/sim/truth", "/tf", "/sim/pose"):
            stamps = [t for t, _ in client.messages[topic]]
            assert all(b - a >= MIN_PERIOD_NS for a, b in zip(stamps, stamps[1:], strict=False)), topic
        # the app's clock: Unix ns of sim time, moving forward with the messages (a time precedes each 20 ms of them)
        assert client.times == sorted(client.times) and client.times[0] > 1_600_000_000 * 10**9
        assert max(client.times) >= client.messages["/sim/truth"][0][0] - MIN_PERIOD_NS
    finally:
        if client is not None:
            await client.close()
        out, err = await _stop(proc)
    printed = out.decode()
    assert proc.returncode == 0, b"".join(seen).decode() + err.decode()
    assert "emulated devices in real time" in printed and printed.rstrip().endswith("stopped"), printed
    assert list(runs.iterdir()) == []  # the run directory, its ptys and the recording are gone


def test_devices_live_beyond_loopback_is_said_loudly(tmp_path: Path) -> None:
    """An explicit --live-addr beyond loopback: the warning comes before the URL."""
    import subprocess

    runs = tmp_path / "runs"
    runs.mkdir()
    env = dict(os.environ, TMPDIR=str(runs), COLUMNS="300")
    done = subprocess.run([sys.executable, "-m", "hil.cli", "devices", "--live", "--live-addr", "0.0.0.0:0",
                           "--duration", "0.5"], cwd=REPO, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    warning, url = done.stderr.index("WARNING: the live server listens on 0.0.0.0"), done.stderr.index("live: ws://0.0.0.0:")
    assert warning < url and "WITHOUT AUTHENTICATION" in done.stderr
    assert list(runs.iterdir()) == []
