"""Helpers of the replay/verify tests: synthetic recordings and a tampering copier."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from hil.record import Recorder, iter_messages, read_attachments, read_metadata

RUN_START_NS = 1_750_000_000_000_000_000
S = 1_000_000_000

Chunk = tuple[str, int, bytes]  # (port, sim t_ns, bytes) on /hil/wire/<port>/tx


def synthetic_chunks(span_s: float = 0.2) -> list[Chunk]:
    """Device->client chunks in recorded order: a boot exchange at negative sim time, then the
    IMU at 400 Hz, RC frames every 22.5 ms and ground-side XBee frames every 20 ms (distinct
    sim times so the cross-port order is unambiguous). Every chunk's bytes are distinct."""
    out: list[Chunk] = [("imu", -S // 2, b"\xfa\xff\x3f\x00\xc2" + b"boot")]
    end_ns = int(span_s * S)
    events: list[Chunk] = []
    for k, t in enumerate(range(0, end_ns, 2_500_000)):
        events.append(("imu", t, bytes([0xFA, 0xFF, 0x36, k & 0xFF, (k * 7) & 0xFF]) + bytes(range(k % 50))))
    for k, t in enumerate(range(1_000_000, end_ns, 22_500_000)):
        events.append(("rc", t, bytes([0x55, k & 0xFF]) + bytes(8 * [k & 0xFF])))
    for k, t in enumerate(range(1_700_000, end_ns, 20_000_000)):
        events.append(("ground", t, bytes([0x7E, 0x00, 0x05, 0x81, k & 0xFF, 0x11, 0x22, 0x33])))
    events.sort(key=lambda c: c[1])
    return out + events


def write_synthetic(path: Path, chunks: list[Chunk], *, rx: bool = True) -> Path:
    """A finished MCAP holding ``chunks`` as wire tx, plus client->device (rx) noise and truth
    that a replay must not play."""
    rec = Recorder(path, run_start_unix_ns=RUN_START_NS,
                   metadata={"rig": "synthetic", "scenario": "synthetic", "seed": "7"})
    with rec:
        for i, (port, t_ns, data) in enumerate(chunks):
            rec.log_wire(port, "tx", t_ns, 1000 + i, data)
            if rx and port == "imu" and i % 5 == 0:
                rec.log_wire("imu", "rx", t_ns, 1000 + i, b"\xfa\xff\x30\x00\xd1")
                rec.log("/sim/truth", max(t_ns, 0), {"h_m": 0.0}, 1000 + i)
    return path


def copy_log(src: Path, dst: Path, mutate: Callable[[str, int, dict[str, Any]], dict[str, Any]] | None = None) -> Path:
    """Copy a run's MCAP message by message through the Recorder (metadata, attachments,
    verdict kept); ``mutate(topic, t_ns, msg)`` may return a changed message."""
    meta = read_metadata(src)
    run = dict(meta["run"])
    run_start = int(run["run_start_unix_ns"])
    attachments = [(name, media, data) for name, (media, data) in read_attachments(src).items()]
    rec = Recorder(dst, run_start_unix_ns=run_start, metadata=run, attachments=attachments)
    rec.start()
    for topic, log_time, msg in iter_messages(src):
        t_ns = int(msg.get("t_ns", log_time - run_start))
        if mutate is not None:
            msg = mutate(topic, t_ns, msg)
        host = int(msg.get("t_host_ns", 0))
        if topic.startswith("/hil/wire/"):
            rec.log_wire(msg["port"], msg["direction"], t_ns, host, msg["data"])
        else:
            rec.log(topic, t_ns, msg, host)
    rec.close(meta.get("verdict"))
    return dst
