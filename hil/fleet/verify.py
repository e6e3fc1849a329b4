"""Verify a recording by re-running it.

``verify``: re-run the recorded run from the log's own attachments (rig file, flight-code
config template, scenario) with the recorded seed, mode and duration, and compare the control
wires (IMU tx, ADC tx/rx, RC tx, ESC rx) byte for byte and the plant truth message by message.
A lockstep run is deterministic for a given seed, so any difference means the code, the
environment or the file changed; the report names the first divergence (stream, byte offset,
sim time). See docs/replay-and-campaigns.md.
"""

from __future__ import annotations

import bisect
import itertools
import tempfile
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from hil.fleet.replay_error import ReplayError
from hil.record import iter_messages, message_counts, read_attachments, read_metadata

#: The wires verify compares byte for byte: (port, direction), named from the bench's side.
CONTROL_WIRES: tuple[tuple[str, str], ...] = (("imu", "tx"), ("adc", "tx"), ("adc", "rx"), ("rc", "tx"), ("esc", "rx"))
TRUTH_TOPIC = "/sim/truth"
#: a board run's control wires: the UARTs' bytes both ways, and the pins' traffic message by
#: message (stream name -> topic): SPI words, ESC inputs, PPM edges and captures
BOARD_WIRES: tuple[tuple[str, str], ...] = (("imu", "tx"), ("imu", "rx"), ("telemetry", "rx"))
BOARD_TOPICS: dict[str, str] = {"spi": "/hil/board/spi", "esc": "/hil/board/esc", "capture": "/hil/board/capture"}


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
        unit = "byte" if "/" in self.stream else "message"
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
            unit = "bytes" if "/" in stream else "messages"
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
    return compare_messages(recorded, rerun, TRUTH_TOPIC, "truth")


def compare_messages(recorded: Path, rerun: Path, topic: str, stream: str) -> tuple[int, Divergence | None]:
    """Compare ``topic`` message by message: (recorded message count, first divergence)."""
    n = message_counts(recorded).get(topic, 0)
    pairs = itertools.zip_longest(iter_messages(recorded, [topic]), iter_messages(rerun, [topic]))
    for i, (a, b) in enumerate(pairs):
        if a is None or b is None:
            which, t_ns = ("recording", b[2].get("t_ns")) if a is None else ("re-run", a[2].get("t_ns"))
            return n, Divergence(stream, i, t_ns, f"the {which} has no more {stream} messages")
        d = _first_field_diff(a[2], b[2])
        if d is not None:
            return n, Divergence(stream, i, a[2].get("t_ns"), d)
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
    if flight.get("board"):  # the firmware flown, as recorded (not today's build)
        from hil.flight.board_run import FIRMWARE_ATTACHMENT

        if FIRMWARE_ATTACHMENT not in att:
            raise ReplayError(f"{log}: a board run without its {FIRMWARE_ATTACHMENT!r} attachment")
        (work / FIRMWARE_ATTACHMENT).write_bytes(att[FIRMWARE_ATTACHMENT][1])
        flight["firmware"] = FIRMWARE_ATTACHMENT
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
    board = bool(run.get("board"))
    for port, direction in BOARD_WIRES if board else CONTROL_WIRES:
        n, d = compare_wire(log, result.log_path, port, direction)
        compared[f"{port}/{direction}"] = n
        if d is not None:
            divergences.append(d)
    for stream, topic in (BOARD_TOPICS if board else {}).items():
        n, d = compare_messages(log, result.log_path, topic, stream)
        compared[stream] = n
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


__all__ = ["BOARD_TOPICS", "BOARD_WIRES", "CONTROL_WIRES", "TRUTH_TOPIC", "Divergence", "VerifyResult", "compare_messages",
           "compare_truth", "compare_wire", "verify"]
