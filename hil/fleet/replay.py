"""Replay a recorded session on ptys.

``replay``: one pty per recorded device port; the bytes the bench sent on it (the
``/hil/wire/<port>/tx`` topic: device -> client) are played back at their recorded sim times,
scaled by ``speed`` (``speed=0``: as fast as the client reads). A ground station (port
``ground``) or a flight code (``imu``, ``adc``, ``rc``) can be fed a recorded session. It is
open loop: what the client writes is read and counted, never answered.

Verifying a recording by re-running it is hil/fleet/verify.py; its names are importable from
here too (``from hil.fleet.replay import replay, verify``). See docs/replay-and-campaigns.md.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import shutil
import signal
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console

from hil import clock
from hil.fleet.replay_error import ReplayError
from hil.fleet.verify import CONTROL_WIRES, TRUTH_TOPIC, Divergence, VerifyResult, compare_truth, compare_wire, verify
from hil.flight.rundir import make_run_dir
from hil.record import chunk_counts, iter_wire, read_metadata
from hil.record.topics import WIRE_PORTS
from hil.transport.base import LineSettings, WireRecord
from hil.transport.pty import PtyPort

#: speed=0: wait this long between checks while the client has not taken what was written
_DRAIN_POLL_S = 0.001


def replay_ports(log: Path | str) -> dict[str, int]:
    """Ports with recorded device->client bytes in ``log``: port -> number of chunks."""
    counts = chunk_counts(log)
    out = {p: counts.get(f"/hil/wire/{p}/tx", 0) for p in WIRE_PORTS}
    return {p: n for p, n in out.items() if n > 0}


def _choose_ports(wanted: list[str] | None, available: dict[str, int], log: Path) -> list[str]:
    if not available:
        raise ReplayError(f"{log}: no device->client bytes recorded on any port")
    if wanted is None:
        return list(available)
    unknown = [p for p in wanted if p not in available]
    if unknown:
        raise ReplayError(f"{log}: no recorded bytes for port(s) {', '.join(unknown)} "
                          f"(recorded: {', '.join(available)})")
    return list(dict.fromkeys(wanted))


class _Drain:
    """Bytes handed to a PtyPort that the kernel has not taken yet (its user-space buffer)."""

    def __init__(self, port: PtyPort) -> None:
        self.port = port
        self.given = 0

    def pending(self) -> int:
        st = self.port.stats
        return self.given - st.bytes_tx - st.overflow_bytes


async def replay(
    log: Path,
    *,
    ports: list[str] | None = None,
    speed: float = 1.0,
    on_ready: Callable[[dict[str, str]], None] | None = None,
    console: Console | None = None,
    from_s: float | None = None,
    wait_open: bool = True,
    tap: Callable[[WireRecord], None] | None = None,
    drain_timeout_s: float = 5.0,
) -> dict[str, Any]:
    """Play ``log``'s device->client bytes on ptys; returns a summary dict (see below).

    ``ports``: which recorded ports to open (default: every port with recorded tx bytes).
    ``speed``: sim seconds per wall second (1.0 = as recorded; 0 = as fast as each client
    reads: nothing is ever dropped). Paced playback behaves like the device: a client that does
    not read loses bytes (counted as ``overflow_bytes``). ``from_s``: skip bytes recorded before
    this sim time (0.0 skips the boot exchange). ``wait_open``: start only once a client has
    opened every port (noticed by the input flush pyserial and most serial tools do on open),
    because bytes written before an open are flushed by it. ``on_ready(paths)`` is called with
    port -> symlink path once the ptys exist; the same paths are printed on ``console``.
    ``tap`` receives every chunk written (``WireRecord`` with the recorded sim time ``t_ns``).
    After the last chunk the ptys stay open until the clients have read everything (at most
    ``drain_timeout_s`` of wall time): closing them earlier would throw unread bytes away.
    Ctrl-C (SIGINT) stops the replay; the summary then has ``completed = False``.

    Summary: ``completed``, ``drained`` (every client read every byte), ``speed``, ``chunks``, ``bytes``, ``t_first_ns``/``t_last_ns``
    (recorded sim time span played), ``started_host_ns`` (monotonic, the wall instant of
    ``t_first_ns``), ``wall_s``, ``lateness_p50_us``/``_p99_us``/``_max_us`` (paced only:
    how late chunks left against their scaled deadlines), and ``ports`` -> {``path``,
    ``chunks``, ``bytes``, ``bytes_to_client``, ``overflow_bytes``, ``client_opens``,
    ``bytes_from_client``}.
    """
    log = Path(log)
    if not (math.isfinite(speed) and speed >= 0):
        raise ReplayError(f"speed must be >= 0 (0 = as fast as possible), got {speed}")
    chosen = _choose_ports(ports, replay_ports(log), log)
    run = read_metadata(log).get("run", {})
    out = console if console is not None else Console()
    run_dir = make_run_dir("hil-replay-")
    os.chmod(run_dir, 0o700)
    dev_dir = run_dir / "dev"
    dev_dir.mkdir(mode=0o700)
    cursor = [0]  # sim time of the chunk being written: the ports' taps stamp it
    opened = {name: asyncio.Event() for name in chosen}
    pty: dict[str, PtyPort] = {}
    summary: dict[str, Any] = {"log": str(log), "speed": speed, "completed": False, "chunks": 0, "bytes": 0,
                               "t_first_ns": None, "t_last_ns": None, "started_host_ns": None, "wall_s": 0.0,
                               "drained": False}
    per_port = {name: {"chunks": 0, "bytes": 0} for name in chosen}
    aloop = asyncio.get_running_loop()
    task = asyncio.current_task()
    try:
        for name in chosen:
            port = PtyPort(name, dev_dir)
            port.sim_time = lambda: cursor[0]
            port.on_line = _opened_setter(opened[name])
            if tap is not None:
                port.taps.append(tap)
            await port.start()
            pty[name] = port
        _print_ports(out, log, run, pty, speed)
        if on_ready is not None:
            on_ready({name: port.path for name, port in pty.items()})
        if task is not None:
            with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):
                aloop.add_signal_handler(signal.SIGINT, task.cancel)
        if wait_open:
            out.print("waiting for a client to open every port ...", highlight=False)
            await asyncio.gather(*(ev.wait() for ev in opened.values()))
        drains = {name: _Drain(port) for name, port in pty.items()}
        await _play(log, drains, per_port, summary, cursor, speed=speed,
                    from_ns=None if from_s is None else round(from_s * 1e9),
                    run_start_ns=int(run.get("run_start_unix_ns", "0")))
        summary["drained"] = await _drain(drains, drain_timeout_s)
        summary["completed"] = True
    except asyncio.CancelledError:
        out.print("stopped", highlight=False)
    finally:
        with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):
            aloop.remove_signal_handler(signal.SIGINT)
        summary["ports"] = {
            name: {"path": port.path, **per_port[name], "bytes_to_client": port.stats.bytes_tx,
                   "overflow_bytes": port.stats.overflow_bytes, "client_opens": port.stats.opens,
                   "bytes_from_client": port.stats.bytes_rx}
            for name, port in pty.items()}
        for port in pty.values():
            port.close()
        shutil.rmtree(run_dir, ignore_errors=True)
    out.print(f"replayed {summary['chunks']} chunks, {summary['bytes']} bytes in {summary['wall_s']:.2f} s",
              highlight=False)
    return summary


async def _drain(drains: dict[str, _Drain], timeout_s: float) -> bool:
    """Wait until no port holds bytes its client has not read (or ``timeout_s`` passes)."""
    deadline = clock.monotonic_ns() + int(timeout_s * 1e9)
    quiet = 0
    while quiet < 2:  # twice in a row: the kernel moves pty bytes through a work queue
        empty = all(d.pending() == 0 and d.port.client_inq() == 0 for d in drains.values())
        quiet = quiet + 1 if empty else 0
        if clock.monotonic_ns() > deadline:
            return False
        await asyncio.sleep(_DRAIN_POLL_S)
    return True


def _opened_setter(event: asyncio.Event) -> Callable[[LineSettings], None]:
    def on_line(settings: LineSettings) -> None:
        if settings.opened:
            event.set()

    return on_line


def _print_ports(out: Console, log: Path, run: dict[str, str], pty: dict[str, PtyPort], speed: float) -> None:
    # Plain lines, never wrapped, so a path can be copied into a client's command line.
    what = f"{run.get('rig', '?')}/{run.get('scenario', '?')} seed {run.get('seed', '?')}"
    pace = "as fast as the clients read" if speed == 0 else f"{speed:g}x recorded speed"
    out.print(f"replaying {log} ({what}) at {pace} (Ctrl-C to stop)", highlight=False, markup=False, soft_wrap=True)
    for name, port in pty.items():
        out.print(f"  {name:<14} {port.path}", highlight=False, markup=False, soft_wrap=True)


async def _play(log: Path, drains: dict[str, _Drain], per_port: dict[str, dict[str, int]], summary: dict[str, Any],
                cursor: list[int], *, speed: float, from_ns: int | None, run_start_ns: int) -> None:
    topics = [f"/hil/wire/{name}/tx" for name in drains]
    pacer = clock.RealtimePacer() if speed > 0 else None
    lateness_ns: list[int] = []
    t0: int | None = None
    wall0 = clock.monotonic_ns()
    try:
        for _topic, log_time, msg in iter_wire(log, topics):
            name = msg["port"]
            data: bytes = msg["data"]
            t_ns = int(msg.get("t_ns", log_time - run_start_ns))
            if (from_ns is not None and t_ns < from_ns) or not data:
                continue
            if t0 is None:
                t0, wall0 = t_ns, clock.monotonic_ns()
                summary["t_first_ns"], summary["started_host_ns"] = t0, wall0
            if pacer is not None:
                deadline = wall0 + int((t_ns - t0) / speed)
                now = clock.monotonic_ns()
                lateness_ns.append(await pacer.wait(deadline) if deadline > now else now - deadline)
            else:
                drain = drains[name]
                while drain.pending() > 0:  # flow control: never outrun the client, never drop
                    await asyncio.sleep(_DRAIN_POLL_S)
            cursor[0] = t_ns
            drains[name].port.write(data)
            drains[name].given += len(data)
            per_port[name]["chunks"] += 1
            per_port[name]["bytes"] += len(data)
            summary["chunks"] += 1
            summary["bytes"] += len(data)
            summary["t_last_ns"] = t_ns
    finally:
        if pacer is not None:
            pacer.close()
        summary["wall_s"] = (clock.monotonic_ns() - wall0) / 1e9
        if lateness_ns:
            late_us = np.asarray(lateness_ns) / 1e3
            summary |= {"lateness_p50_us": float(np.percentile(late_us, 50)),
                        "lateness_p99_us": float(np.percentile(late_us, 99)),
                        "lateness_max_us": float(late_us.max())}



__all__ = ["CONTROL_WIRES", "TRUTH_TOPIC", "Divergence", "ReplayError", "VerifyResult", "compare_truth", "compare_wire",
           "replay", "replay_ports", "verify"]
