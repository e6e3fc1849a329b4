"""Replay a recorded session on ptys, and verify a recording by re-running it.

``replay``: one pty per recorded device port; the bytes the bench sent on it (the
``/hil/wire/<port>/tx`` topic: device -> client) are played back at their recorded sim times,
scaled by ``speed`` (``speed=0``: as fast as the client reads). A ground station (port
``ground``) or a flight code (``imu``, ``adc``, ``rc``) can be fed a recorded session. It is
open loop: what the client writes is read and counted, never answered.

``verify``: re-run the recorded run from the log's own attachments (rig file, flight-code
config template, scenario) with the recorded seed, mode and duration, and compare the control
wires (IMU tx, ADC tx/rx, RC tx, ESC rx) byte for byte and the plant truth message by message.
A lockstep run is deterministic for a given seed, so any difference means the code, the
environment or the file changed; the report names the first divergence (stream, byte offset,
sim time). See docs/replay-and-campaigns.md.
"""

from __future__ import annotations

import asyncio
import bisect
import contextlib
import itertools
import math
import os
import shutil
import signal
import tempfile
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w
from rich.console import Console

from hil import clock
from hil.record import chunk_counts, iter_messages, iter_wire, message_counts, read_attachments, read_metadata
from hil.record.topics import WIRE_PORTS
from hil.flight.rundir import make_run_dir
from hil.transport.base import LineSettings, WireRecord
from hil.transport.pty import PtyPort

#: The wires verify compares byte for byte: (port, direction), named from the bench's side.
CONTROL_WIRES: tuple[tuple[str, str], ...] = (("imu", "tx"), ("adc", "tx"), ("adc", "rx"), ("rc", "tx"), ("esc", "rx"))
TRUTH_TOPIC = "/sim/truth"
#: speed=0: wait this long between checks while the client has not taken what was written
_DRAIN_POLL_S = 0.001


class ReplayError(ValueError):
    """The log cannot be replayed as asked (unknown port, bad speed, no recorded bytes)."""


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


# ---- verify -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Divergence:
    """First difference on one stream. ``stream``: ``"imu/tx"`` ... or ``"truth"``.

    ``offset``: byte offset into the stream's concatenated bytes (wires) or message index
    (truth). ``t_ns``: sim time (ns) of the recorded chunk/message holding it (of the re-run's
    when the recording ended first). ``detail``: what differs, in words.
    """

    stream: str
    offset: int
    t_ns: int | None
    detail: str

    def describe(self) -> str:
        at = "" if self.t_ns is None else f" at t = {self.t_ns / 1e9:.6f} s"
        unit = "message" if self.stream == "truth" else "byte"
        return f"{self.stream}: first divergence at {unit} {self.offset}{at}: {self.detail}"


@dataclass(frozen=True)
class VerifyResult:
    """Outcome of :func:`verify`. ``ok``: the re-run completed like the recording and every
    compared stream is identical. ``compared``: stream -> bytes (wires) or messages (truth)
    in the recording. ``divergences``: the first difference of each differing stream."""

    log: Path
    rerun_log: Path | None
    ok: bool
    recorded_end_reason: str
    rerun_end_reason: str
    compared: dict[str, int]
    divergences: tuple[Divergence, ...] = ()
    notes: tuple[str, ...] = field(default=())

    @property
    def first(self) -> Divergence | None:
        """The earliest divergence in sim time (streams without a time last)."""
        if not self.divergences:
            return None
        return min(self.divergences, key=lambda d: (d.t_ns is None, d.t_ns or 0))

    def report(self) -> str:
        """Plain-text report: verdict, first divergence, every stream, notes."""
        head = "IDENTICAL" if self.ok else "DIVERGED"
        lines = [f"{head}: {self.log} re-run as {self.rerun_log}",
                 f"  end: recorded {self.recorded_end_reason!r}, re-run {self.rerun_end_reason!r}"]
        if self.first is not None:
            lines.append(f"  first: {self.first.describe()}")
        bad = {d.stream: d for d in self.divergences}
        for stream, n in self.compared.items():
            unit = "messages" if stream == "truth" else "bytes"
            lines.append(f"  {stream:<8} {n:>9} {unit}  " + (bad[stream].describe() if stream in bad else "identical"))
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)


def _wire_chunks(log: Path, port: str, direction: str) -> tuple[bytes, list[int], list[int]]:
    """Concatenated bytes, each chunk's start offset and sim time."""
    data = bytearray()
    starts: list[int] = []
    times: list[int] = []
    for _, _, msg in iter_messages(log, [f"/hil/wire/{port}/{direction}"]):
        starts.append(len(data))
        times.append(int(msg["t_ns"]))
        data += msg["data"]
    return bytes(data), starts, times


def _time_at(starts: list[int], times: list[int], offset: int) -> int | None:
    i = bisect.bisect_right(starts, offset) - 1
    return times[i] if 0 <= i < len(times) else None


def compare_wire(recorded: Path, rerun: Path, port: str, direction: str) -> tuple[int, Divergence | None]:
    """Compare one wire of two logs byte for byte: (recorded byte count, first divergence)."""
    a, a_starts, a_times = _wire_chunks(recorded, port, direction)
    b, b_starts, b_times = _wire_chunks(rerun, port, direction)
    stream = f"{port}/{direction}"
    if a == b:
        return len(a), None
    n = min(len(a), len(b))
    diff = np.flatnonzero(np.frombuffer(a[:n], np.uint8) != np.frombuffer(b[:n], np.uint8))
    if diff.size:
        i = int(diff[0])
        return len(a), Divergence(stream, i, _time_at(a_starts, a_times, i),
                                  f"recorded 0x{a[i]:02x}, re-run 0x{b[i]:02x}")
    if len(a) > len(b):
        return len(a), Divergence(stream, n, _time_at(a_starts, a_times, n),
                                  f"the re-run ends after {len(b)} bytes; the recording has {len(a)}")
    return len(a), Divergence(stream, n, _time_at(b_starts, b_times, n),
                              f"the recording ends after {len(a)} bytes; the re-run has {len(b)}")


def _first_field_diff(a: Any, b: Any, path: str = "") -> str | None:
    if isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            d = _first_field_diff(a.get(k), b.get(k), f"{path}.{k}" if path else k)
            if d is not None:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            d = _first_field_diff(x, y, f"{path}[{i}]")
            if d is not None:
                return d
        return None
    return None if a == b else f"{path}: recorded {a!r}, re-run {b!r}"


def compare_truth(recorded: Path, rerun: Path) -> tuple[int, Divergence | None]:
    """Compare ``/sim/truth`` message by message: (recorded message count, first divergence)."""
    n = message_counts(recorded).get(TRUTH_TOPIC, 0)
    pairs = itertools.zip_longest(iter_messages(recorded, [TRUTH_TOPIC]), iter_messages(rerun, [TRUTH_TOPIC]))
    for i, (a, b) in enumerate(pairs):
        if a is None or b is None:
            which, t_ns = ("recording", b[2].get("t_ns")) if a is None else ("re-run", a[2].get("t_ns"))
            return n, Divergence("truth", i, t_ns, f"the {which} has no more truth messages")
        d = _first_field_diff(a[2], b[2])
        if d is not None:
            return n, Divergence("truth", i, a[2].get("t_ns"), d)
    return n, None


def _materialise(log: Path, run: dict[str, str], work: Path) -> tuple[Path, Path]:
    """Write the log's rig, flight-config template and scenario into ``work``."""
    missing = [k for k in ("rig_file", "scenario", "seed", "mode", "duration_s") if k not in run]
    if missing:
        raise ReplayError(f"{log}: the run metadata lacks {', '.join(missing)}: not a bench run log")
    att = read_attachments(log)
    rig_name = Path(run["rig_file"]).name
    scenario_name = f"{run['scenario']}.toml"
    for name in (rig_name, scenario_name):
        if name not in att:
            raise ReplayError(f"{log}: no attachment {name!r} (has {', '.join(att)})")
    rig_data = tomllib.loads(att[rig_name][1].decode())
    flight = dict(rig_data.get("flight", {}))
    wanted = Path(str(flight.get("config", "flightcode-paper-quad.toml"))).name
    others = [n for n in att if n not in (rig_name, scenario_name)]
    flight_name = wanted if wanted in att else (others[0] if len(others) == 1 else "")
    if not flight_name:
        raise ReplayError(f"{log}: cannot tell the flight config template among attachments {', '.join(att)}")
    rig_bytes = att[rig_name][1]
    if flight.get("config") != flight_name:  # make the rig point at the extracted template
        flight["config"] = flight_name
        rig_data["flight"] = flight
        rig_bytes = tomli_w.dumps(rig_data).encode()
    (work / rig_name).write_bytes(rig_bytes)
    (work / flight_name).write_bytes(att[flight_name][1])
    (work / "scenarios").mkdir(exist_ok=True)
    (work / "scenarios" / scenario_name).write_bytes(att[scenario_name][1])
    return work / rig_name, work / "scenarios" / scenario_name


def _flight_lines(log: Path, t_ns: int, window_ns: int = 20_000_000, limit: int = 4) -> list[str]:
    """The flight code's log lines within ``window_ns`` of sim time ``t_ns`` (why a run diverged:
    a wall-clock timeout in the flight code, e.g. an ADC resync, shows up here)."""
    start = int(read_metadata(log).get("run", {}).get("run_start_unix_ns", "0"))
    lines = [str(m.get("message", "")) for _, lt, m in iter_messages(log, ["/fc/log"])
             if abs(lt - start - t_ns) <= window_ns]
    return lines[:limit]


def verify(log: Path, out_dir: Path) -> VerifyResult:
    """Re-run ``log``'s run from its attachments into ``out_dir``; compare control wires and truth.

    Blocking (runs its own event loop; call it from a thread inside async code). The re-run
    uses the recorded seed, mode and duration and the bench as installed now; differences of
    git SHA or mode that make a divergence expected are listed in ``notes``.
    """
    from hil.flight.tickloop import Mode
    from hil.flight.run import run_flight

    log = Path(log)
    meta = read_metadata(log)
    run, verdict = meta.get("run", {}), meta.get("verdict", {})
    with tempfile.TemporaryDirectory(prefix="hil-verify-") as tmp:
        rig_path, scenario_path = _materialise(log, run, Path(tmp))
        mode = Mode(run["mode"])
        out_dir.mkdir(parents=True, exist_ok=True)
        result = run_flight(rig_path, scenario_path, mode=mode, seed=int(run["seed"]),
                            duration_s=float(run["duration_s"]), out_dir=out_dir)
    notes: list[str] = []
    if mode is not Mode.LOCKSTEP:
        notes.append(f"the recording ran in {mode.value} mode: only lockstep runs repeat byte for byte")
    rerun_meta = read_metadata(result.log_path).get("run", {}) if result.log_path else {}
    for key in ("git_sha", "git_dirty", "bench_version", "python"):
        if run.get(key) != rerun_meta.get(key):
            notes.append(f"{key}: recorded {run.get(key)!r}, now {rerun_meta.get(key)!r}")
    recorded_end = verdict.get("end_reason", "(no verdict: killed run?)")
    rerun_end = result.end_reason.value
    if result.log_path is None or not result.log_path.exists():
        return VerifyResult(log, None, False, recorded_end, rerun_end, {}, (), (*notes, f"the re-run wrote no log: {result.message}"))
    compared: dict[str, int] = {}
    divergences: list[Divergence] = []
    for port, direction in CONTROL_WIRES:
        n, d = compare_wire(log, result.log_path, port, direction)
        compared[f"{port}/{direction}"] = n
        if d is not None:
            divergences.append(d)
    n, d = compare_truth(log, result.log_path)
    compared["truth"] = n
    if d is not None:
        divergences.append(d)
    if recorded_end != rerun_end:
        notes.append(f"the runs ended differently: recorded {recorded_end!r}, re-run {rerun_end!r} ({result.message})")
    ok = not divergences and recorded_end == rerun_end
    first = min(divergences, key=lambda d: (d.t_ns is None, d.t_ns or 0)) if divergences else None
    if first is not None and first.t_ns is not None:
        for which, path in (("recorded", log), ("re-run", result.log_path)):
            notes += [f"{which} flight code near t = {first.t_ns / 1e9:.4f} s: {line}"
                      for line in _flight_lines(path, first.t_ns)]
    return VerifyResult(log, result.log_path, ok, recorded_end, rerun_end, compared, tuple(divergences), tuple(notes))
