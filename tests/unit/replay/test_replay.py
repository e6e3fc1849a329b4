"""hil.fleet.replay.replay: recorded device->client bytes played on real ptys, read back by real
pyserial clients. Assertions are on content and order (and on the one-sided property that
paced playback never runs ahead of the recording), never on wall-time tolerances."""

from __future__ import annotations

import asyncio
import io
from pathlib import Path
from typing import Any

import pytest
import serial
from rich.console import Console

from hil.fleet.replay import replay, replay_ports
from hil.fleet.replay_error import ReplayError
from hil.transport.base import WireRecord
from tests.unit.replay.support import S, synthetic_chunks, write_synthetic

pytestmark = pytest.mark.pty


async def _open(path: str) -> serial.Serial:
    return await asyncio.to_thread(serial.Serial, path, 115200, timeout=10.0)


async def _read(ser: serial.Serial, n: int) -> bytes:
    return await asyncio.to_thread(ser.read, n)


async def _replay_to_clients(log: Path, expected: dict[str, bytes], **kwargs: Any) -> tuple[dict[str, Any], dict[str, bytes], list[WireRecord], str]:
    """Run a replay, attach one pyserial client per port once the ptys exist, read what is expected."""
    ready: asyncio.Future[dict[str, str]] = asyncio.get_running_loop().create_future()
    taps: list[WireRecord] = []
    out = io.StringIO()
    task = asyncio.create_task(replay(log, on_ready=ready.set_result, tap=taps.append,
                                      console=Console(file=out, width=200), **kwargs))
    paths = await asyncio.wait_for(ready, 10)
    clients = {name: await _open(path) for name, path in paths.items()}
    try:
        got = dict(zip(clients, await asyncio.gather(*(_read(c, len(expected[n])) for n, c in clients.items())), strict=True))
        summary = await asyncio.wait_for(task, 30)
    finally:
        for c in clients.values():
            c.close()
    return summary, got, taps, out.getvalue()


def _by_port(chunks: list[tuple[str, int, bytes]]) -> dict[str, bytes]:
    out: dict[str, bytes] = {}
    for port, _, data in chunks:
        out[port] = out.get(port, b"") + data
    return out


async def test_speed_0_every_port_gets_its_bytes_in_recorded_order(tmp_path: Path) -> None:
    chunks = synthetic_chunks()
    log = write_synthetic(tmp_path / "s.mcap", chunks)
    assert replay_ports(log) == {"imu": 81, "rc": 9, "ground": 10}
    expected = _by_port(chunks)
    summary, got, taps, printed = await _replay_to_clients(log, expected, speed=0)
    assert got == expected  # identical bytes, nothing of the rx topic or the truth
    assert summary["completed"] and summary["drained"] and summary["chunks"] == len(chunks)
    assert summary["bytes"] == sum(len(d) for _, _, d in chunks)
    # the order across ports is the recorded order, each chunk stamped with its sim time
    assert [(r.port, r.t_ns, r.data) for r in taps] == chunks
    for name, st in summary["ports"].items():
        assert st["bytes"] == st["bytes_to_client"] == len(expected[name])
        assert st["overflow_bytes"] == 0 and st["client_opens"] >= 1
    # the paths are printed as plain lines a user can copy
    for name, st in summary["ports"].items():
        assert f"  {name:<14} {st['path']}\n" in printed


async def test_paced_from_time_zero_never_runs_ahead_of_the_recording(tmp_path: Path) -> None:
    chunks = synthetic_chunks(span_s=0.3)
    log = write_synthetic(tmp_path / "s.mcap", chunks)
    played = [c for c in chunks if c[0] in ("imu", "rc") and c[1] >= 0]  # boot skipped, ground not asked for
    speed = 2.0
    summary, got, taps, _ = await _replay_to_clients(log, _by_port(played), ports=["imu", "rc"], speed=speed, from_s=0.0)
    assert set(summary["ports"]) == {"imu", "rc"}
    assert got == _by_port(played)
    assert [(r.port, r.t_ns, r.data) for r in taps] == played
    assert summary["t_first_ns"] == 0 and summary["t_last_ns"] == played[-1][1]
    # One-sided and load-independent: a chunk never leaves before its scaled recorded time.
    start = summary["started_host_ns"]
    early = [r for r in taps if r.t_host_ns - start < (r.t_ns - summary["t_first_ns"]) / speed]
    assert not early
    assert summary["lateness_p50_us"] >= 0


async def test_speed_0_does_not_wait_for_sim_time_and_cancel_stops_a_paced_replay(tmp_path: Path) -> None:
    # An hour of recorded silence between two chunks: speed 0 plays through it (this test
    # would hit the pytest timeout otherwise); paced, it waits and a cancel (Ctrl-C) stops it.
    chunks = [("imu", 0, b"first"), ("imu", 3600 * S, b"second")]
    log = write_synthetic(tmp_path / "gap.mcap", chunks, rx=False)
    summary, got, _, _ = await _replay_to_clients(log, {"imu": b"firstsecond"}, speed=0)
    assert got == {"imu": b"firstsecond"} and summary["completed"]

    ready: asyncio.Future[dict[str, str]] = asyncio.get_running_loop().create_future()
    task = asyncio.create_task(replay(log, speed=1.0, on_ready=ready.set_result, console=Console(file=io.StringIO())))
    client = await _open((await asyncio.wait_for(ready, 10))["imu"])
    try:
        assert await _read(client, 5) == b"first"
        task.cancel()
        summary = await asyncio.wait_for(task, 10)
    finally:
        client.close()
    assert not summary["completed"]
    assert summary["chunks"] == 1 and summary["ports"]["imu"]["bytes"] == 5


async def test_refusals_name_the_problem(tmp_path: Path) -> None:
    log = write_synthetic(tmp_path / "s.mcap", synthetic_chunks(span_s=0.05))
    with pytest.raises(ReplayError, match=r"port\(s\) esc .*recorded: imu, rc, ground"):
        await replay(log, ports=["esc"], console=Console(file=io.StringIO()))
    with pytest.raises(ReplayError, match="speed"):
        await replay(log, speed=-1.0, console=Console(file=io.StringIO()))
    empty = write_synthetic(tmp_path / "empty.mcap", [])
    with pytest.raises(ReplayError, match="no device->client bytes"):
        await replay(empty, console=Console(file=io.StringIO()))
