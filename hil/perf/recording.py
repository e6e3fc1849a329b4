"""Measured cost of recording (for ``hil perf`` and the report), not a test.

``measure_recording(directory)`` logs a 400 Hz-like mix of topics as fast as it can and
reports what the tick path pays per ``log()`` call and what the writer thread sustains.
"""

from __future__ import annotations

import statistics
from dataclasses import dataclass
from pathlib import Path

from hil import clock
from hil.record.topics import TOPICS
from hil.record.writer import Recorder

_BATCH = 100  # log() calls per timing sample (the clock read costs about as much as a call)


@dataclass(frozen=True)
class RecordPerf:
    """``log_us_median``/``log_us_p99``: cost of one ``log()`` call on the caller's thread, us
    (per-sample mean over a batch of calls); ``writer_msgs_per_s``: messages written per second
    of wall time from the first log() to the end of close() (encoding, chunking, zstd, finish);
    ``dropped``: must be 0 (queue large enough); ``file_bytes``: size of the file. ``messages``
    counts what was logged (each wire chunk once)."""

    messages: int
    log_us_median: float
    log_us_p99: float
    writer_msgs_per_s: float
    dropped: int
    file_bytes: int


def measure_recording(directory: Path, ticks: int = 5000) -> RecordPerf:
    """Record ``ticks`` ticks of 10 topics (truth + its 2 derived, IMU, ESC, wire x3, timing) in ``directory``."""
    path = Path(directory) / "perf.mcap"
    imu = TOPICS["/hil/imu/sample"].example
    esc = TOPICS["/hil/esc/command"].example
    tick = TOPICS["/hil/timing/tick"].example
    truth = TOPICS["/sim/truth"].example
    frame = bytes(range(60))
    rec = Recorder(path, run_start_unix_ns=clock.wall_ns(), metadata={"purpose": "perf"}, queue_max=10 * ticks + 10)
    rec.start()
    samples: list[float] = []
    t_start = clock.monotonic_ns()
    for k in range(0, ticks, _BATCH // 8):
        t0 = clock.monotonic_ns()
        for j in range(k, k + _BATCH // 8):
            t_ns = j * 2_500_000
            rec.log("/hil/imu/sample", t_ns, imu, t0)
            rec.log_wire("imu", "tx", t_ns, t0, frame)
            rec.log_wire("esc", "rx", t_ns, t0, frame[:9])
            rec.log("/hil/esc/command", t_ns, esc, t0)
            rec.log_wire("adc", "rx", t_ns, t0, frame[:3])
            rec.log("/hil/timing/tick", t_ns, tick, t0)
            rec.log_truth(t_ns, truth, t0)
            rec.log("/hil/events", t_ns, {"kind": "bench", "name": "tick", "detail": ""}, t0)
        calls = 8 * (_BATCH // 8)
        samples.append((clock.monotonic_ns() - t0) / calls / 1000)
    stats = rec.close()
    elapsed_s = (clock.monotonic_ns() - t_start) / 1e9
    samples.sort()
    # what was logged: wire chunks count one each (the file holds them in 100 ms messages)
    logged = sum(n for t, n in stats.messages_by_topic.items() if not t.startswith("/hil/wire/"))
    logged += sum(stats.chunks_by_topic.values())
    return RecordPerf(messages=logged, log_us_median=statistics.median(samples),
                      log_us_p99=samples[min(len(samples) - 1, int(0.99 * len(samples)))],
                      writer_msgs_per_s=logged / elapsed_s,
                      dropped=stats.dropped, file_bytes=path.stat().st_size)
