"""What a run produced: :class:`RunResult` (the verdict, the log and the figures), the run's
timing figures from the tick loop's statistics, and the criterion that says whether a
realtime run held 400 Hz.

Times in the figures are microseconds (``*_us``) or seconds (``*_s``), as their keys say.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hil.analysis.criteria import CriterionResult
from hil.analysis.signal_stream import Held
from hil.analysis.timing import REALTIME_MAX_LATE_US, realtime_held, scaled_compute_us
from hil.analysis.timing_stream import StreamingStats
from hil.analysis.trace import Trace
from hil.analysis.trace_stream import TraceStream
from hil.flight.tickloop import Clock, EndReason, TickLoop
from hil.host.cpulatency import CpuLatency
from hil.host.rtsched import RtScheduling
from hil.vtime.session import ShimUsage


@dataclass
class RunResult:
    """What a run produced; ``passed`` is the verdict used for the exit status."""

    log_path: Path | None
    end_reason: EndReason
    criteria: list[CriterionResult]
    flight_returncode: int | None
    flight_stderr_tail: list[str]
    timing: dict[str, float]
    counters: dict[str, dict[str, int]]
    message: str = ""
    #: the whole-run trace, when the run was asked to keep it (``keep_trace``)
    trace: Trace | None = None
    recorded: dict[str, int] = field(default_factory=dict)
    dropped: int = 0
    seed: int = 0
    sim_s: float = 0.0
    #: the clock the flight code ran on; why it was not virtual in a lockstep run
    clock: Clock = Clock.WALL
    clock_note: str = ""
    shim: ShimUsage | None = None
    #: things the user must know about this run (fallbacks, uncovered calls, stalls)
    notes: list[str] = field(default_factory=list)
    #: realtime: the scheduling policy the tick loop and the flight code ran on (hil/host/rtsched.py)
    rt_scheduling: RtScheduling | None = None
    #: the CPU latency request the run held, or why not (hil/host/cpulatency.py)
    cpu_latency: CpuLatency | None = None

    @property
    def passed(self) -> bool:
        return self.end_reason is EndReason.COMPLETED and all(c.passed for c in self.criteria)


def _percentiles(prefix: str, values: StreamingStats | np.ndarray, scale: float = 1.0) -> dict[str, float]:
    """p50/p99/max of ``values`` times ``scale`` (streamed stats or an array)."""
    if len(values) == 0:
        return {}
    if isinstance(values, StreamingStats):
        return {f"{prefix}_p50_us": values.percentile(50) * scale, f"{prefix}_p99_us": values.percentile(99) * scale,
                f"{prefix}_max_us": values.max * scale}
    return {
        f"{prefix}_p50_us": float(np.percentile(values, 50)) * scale,
        f"{prefix}_p99_us": float(np.percentile(values, 99)) * scale,
        f"{prefix}_max_us": float(values.max()) * scale,
    }


def timing_summary(loop: TickLoop, tick_ns: int, telemetry_compute_us: StreamingStats | None = None,
                   cpu_scale: float = 1.0) -> dict[str, float]:
    """The run's timing figures. ``latency_*``, ``period_*`` and ``fc_compute_*`` are on the
    flight code's clock: sim time with virtual time (deterministic, what budgets judge), the
    host clock otherwise. ``host_latency_*`` and ``bench_cost_*`` are host figures always.
    ``telemetry_compute_us``: the flight code's own compute figure held on the tick grid
    (streamed), for runs without the per-sample CPU measurement."""
    st = loop.stats
    wall_s = max((st.wall_end_ns - st.wall_start_ns) / 1e9, 1e-9)
    sim_s = st.ticks * tick_ns / 1e9
    out: dict[str, float] = {
        "ticks": float(st.ticks),
        "sim_s": sim_s,
        "wall_s": wall_s,
        "rtf": sim_s / wall_s,
        "barrier_misses": float(st.barrier_misses),
        "late_ticks": float(st.late_ticks),
        "esc_commands": float(st.esc_commands),
    }
    lat = loop.devices.latency_stats  # streamed: every sample's figures, bounded memory
    # on sim time: virtual time's flight code, or a board's firmware (its compute in target cycles)
    virtual = st.clock in (Clock.VIRTUAL, Clock.BOARD)
    if st.clock is Clock.BOARD:
        cpu_scale = 1.0  # the target's own cycles: nothing to scale
    out |= _percentiles("latency", st.latencies_ns, 1e-3)
    if st.clock is not Clock.BOARD:  # a board's answers come in its cycles, not at a host instant
        out |= _percentiles("host_latency", lat.host_latency_ns, 1e-3)
    if st.tick_cost_ns:
        cost = st.tick_cost_ns
        out |= {"bench_cost_p50_us": cost.percentile(50) / 1e3, "bench_cost_p99_us": cost.percentile(99) / 1e3}
    if st.clock is Clock.REALTIME:
        out["rt_no_command"] = float(st.no_command)
    if not virtual:
        out["late_commands"] = float(st.late_commands)
    if st.ticks:
        out["bench_cpu_per_tick_us"] = st.cpu_ns / st.ticks / 1e3
    arrivals = lat.sim_period if virtual else lat.host_period
    if len(arrivals.period) > 1:
        out |= {"period_p50_us": arrivals.period.percentile(50) / 1e3,
                "period_jitter_p99_us": arrivals.jitter.percentile(99) / 1e3}
    if virtual:
        out["boot_sim_s"] = st.boot_sim_ns / 1e9
    # one rule with `hil timing` (hil.analysis.timing.compute_samples_us): the per-sample CPU
    # measurement when there is one, on the same values; else the flight code's own figure
    cpu = scaled_compute_us(np.frombuffer(st.fc_cpu_ns, dtype=np.int64) / 1e3, cpu_scale) if virtual else np.zeros(0)
    out |= _percentiles("fc_compute", cpu if cpu.size or telemetry_compute_us is None else telemetry_compute_us)
    if st.lateness_ns:
        out |= _percentiles("lateness", st.lateness_ns, 1e-3)
    return out


def cores_used(loop: TickLoop, fc_cpu_ns: int | None, rec_cpu_ns: int | None, *, recorded: bool) -> dict[str, float]:
    """The flight code's and the recorder's CPU per tick over the tick loop, and the cores
    the run kept busy: bench, flight code and recorder CPU over the wall time (hil/host/cpuuse.py).
    ``cores_used`` only when every process of the run was measured."""
    st = loop.stats
    out: dict[str, float] = {}
    if not st.ticks:
        return out
    if fc_cpu_ns is not None:
        out["fc_cpu_per_tick_us"] = fc_cpu_ns / st.ticks / 1e3
    if rec_cpu_ns is not None:
        out["recorder_cpu_per_tick_us"] = rec_cpu_ns / st.ticks / 1e3
    wall_ns = st.wall_end_ns - st.wall_start_ns
    if fc_cpu_ns is not None and (rec_cpu_ns is not None or not recorded) and wall_ns > 0:
        out["cores_used"] = (st.cpu_ns + fc_cpu_ns + (rec_cpu_ns or 0)) / wall_ns
    return out


def realtime_criterion(loop: TickLoop, tick_ns: int) -> CriterionResult | None:
    """Realtime runs: did the pacer hold 400 Hz (hil.analysis.timing.realtime_verdict)? A run that
    fell behind must not read as a 400 Hz run because its RTF is about 1."""
    st = loop.stats
    if not st.lateness_ns:
        return None
    late = st.lateness_ns
    verdict = realtime_held(len(late), st.late_ticks, late.percentile(99) / 1e3, late.max / 1e3, tick_ns / 1e3)
    return CriterionResult("realtime held", "timing.lateness_us", "p99 / max", verdict.max_us,
                           f"p99 <= {tick_ns / 1e3:g}, max <= {REALTIME_MAX_LATE_US:g}", verdict.held,
                           "" if verdict.held else verdict.text,
                           margin=min(tick_ns / 1e3 - verdict.p99_us, REALTIME_MAX_LATE_US - verdict.max_us))


def held_stats(stream: TraceStream, name: str) -> StreamingStats:
    """Streamed statistics of the irregular series ``name`` held on the tick grid."""
    stats, held = StreamingStats(), Held(name)
    stream.subscribe(lambda chunk: stats.extend(held.block(chunk)[1]))
    return stats


__all__ = ["RunResult", "cores_used", "held_stats", "realtime_criterion", "timing_summary"]
