"""Timing of the flight code's 400 Hz loop, from a run's MCAP log (or arrays).

Figures (all microseconds unless noted):

* **period**: host-time interval between consecutive ESC commands (the loop's output
  cadence). In realtime mode this is the loop's real period; in lockstep it is paced by
  the bench and reported for completeness.
* **latency**: IMU sample emitted (bench, host clock) -> ESC command received. This is the
  flight code's response time including both pty hops. In lockstep it is the compute
  latency of one sample, checked against the 2.5 ms budget even though the run itself is
  faster than real time.
* **jitter**: period minus its nominal value.
* **misses**: samples whose latency exceeded the budget, plus samples with no command at
  all (barrier timeouts).
* **compute**: the flight code's compute per loop (:func:`compute_samples_us`, the one rule
  shared by the run summary and ``hil timing``): with virtual time, the bench's per-sample
  measurement of the flight code's CPU time (read by the clock shim at each blocking call)
  scaled to the target by the rig's ``cpu_scale`` (docs/time.md); otherwise the flight
  code's own figure from its telemetry.
* **lateness** (realtime only): how late each tick started against its absolute wall
  deadline. A run whose ticks fell behind is not a 400 Hz run, whatever its RTF says:
  :func:`realtime_verdict` says whether realtime was held.

A board run (the firmware on the emulated LPC2148, docs/board.md) has every figure in the
core's time: latency and period in sim time, compute as the busy cycles of the loop iteration
that answered each sample (``board_cclk_hz`` turns them into cycles; no ``cpu_scale``).
"""

from __future__ import annotations

import enum
import json
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from hil.native.frozen import by_fields


NOMINAL_PERIOD_US = 2500.0
#: a realtime tick that starts this late counts as late (the run's late_ticks and hil timing)
LATE_US = 1000.0
#: realtime is not held when any tick starts later than this: the flight code then saw a
#: gap of ten samples (its IMU watchdog is 100 ms; this machine's worst scheduling gaps are
#: about 3 ms, docs/time.md "Host interruptions")
REALTIME_MAX_LATE_US = 25_000.0
@dataclass(frozen=True)
class Stats:
    n: int
    p50: float
    p99: float
    p999: float
    max: float
    mean: float

    def __reduce__(self) -> tuple[type, tuple[object, ...]]:
        return by_fields(self)  # compiled records pickle by field (hil/native/frozen.py)

    @staticmethod
    def of(values: np.ndarray) -> Stats:
        v = np.asarray(values, dtype=float)
        v = v[np.isfinite(v)]
        if v.size == 0:
            nan = float("nan")
            return Stats(0, nan, nan, nan, nan, nan)
        return Stats(
            int(v.size),
            float(np.percentile(v, 50)),
            float(np.percentile(v, 99)),
            float(np.percentile(v, 99.9)),
            float(v.max()),
            float(v.mean()),
        )


def compute_samples_us(
    fc_cpu_us: np.ndarray | None, telemetry_compute_us: np.ndarray | None, cpu_scale: float = 1.0
) -> np.ndarray:
    """The flight code's compute per loop in us (target processor), from what a run has.

    ``fc_cpu_us``: the bench's per-sample CPU measurement (virtual time), host us, negative
    where not measured. ``telemetry_compute_us``: the flight code's own figures (50 Hz).
    ``cpu_scale``: target time per host time. The per-sample measurement wins when it has
    any sample: it covers every loop, telemetry only every eighth. Non-finite values go.
    """
    if fc_cpu_us is not None:
        cpu = scaled_compute_us(fc_cpu_us, cpu_scale)
        if cpu.size:
            return cpu
    if telemetry_compute_us is None:
        return np.zeros(0)
    tm = np.asarray(telemetry_compute_us, dtype=float)
    return tm[np.isfinite(tm)]


class ComputeSource(enum.StrEnum):
    """Where a report's ``compute_us`` came from."""

    CPU = "cpu"  #: the flight code's CPU per sample (virtual time), times the run's cpu_scale
    TELEMETRY = "telemetry"  #: the compute time the flight code reports in its telemetry


@dataclass(frozen=True)
class TimingReport:
    samples: int
    budget_us: float
    latency_us: Stats
    period_us: Stats
    jitter_us: Stats  #: |period - nominal|
    compute_us: Stats
    misses: int  #: latency over budget
    no_command: int  #: barrier timeouts (no ESC command for a sample)
    lateness_us: Stats | None = None  #: realtime: tick start - its wall deadline
    realtime: RealtimeVerdict | None = None  #: realtime runs only
    compute_source: ComputeSource = ComputeSource.TELEMETRY
    #: a board run: the emulated core's clock (compute in target cycles = us x MHz); else None
    board_cclk_hz: float | None = None
    #: a board run: the busy cycles of each answering loop iteration (the histogram's data)
    board_busy_cycles: tuple[float, ...] = ()

    def __reduce__(self) -> tuple[type, tuple[object, ...]]:
        return by_fields(self)  # compiled records pickle by field (hil/native/frozen.py)

    def as_dict(self) -> dict[str, object]:
        return asdict(self)

    @property
    def budget_cycles(self) -> float | None:
        """The budget in the board's cycles (a board run)."""
        return None if self.board_cclk_hz is None else self.budget_us * self.board_cclk_hz / 1e6


@dataclass(frozen=True)
class RealtimeVerdict:
    """Did a realtime run keep 400 Hz? From the pacer's per-tick lateness."""

    held: bool
    ticks: int
    late_ticks: int  #: more than LATE_US late
    p99_us: float
    max_us: float

    def __reduce__(self) -> tuple[type, tuple[object, ...]]:
        return by_fields(self)  # compiled records pickle by field (hil/native/frozen.py)

    @property
    def text(self) -> str:
        figures = (f"{self.late_ticks} of {self.ticks} ticks more than {LATE_US / 1e3:g} ms late, "
                   f"lateness p99 {self.p99_us:.0f} us, max {self.max_us / 1e3:.1f} ms")
        if self.held:
            return f"realtime held: {figures}"
        return (f"realtime NOT held: {figures} (allowed: p99 within one tick, none over "
                f"{REALTIME_MAX_LATE_US / 1e3:g} ms); the samples reached the flight code late, so this "
                "run's timing figures are not those of a 400 Hz loop")


def realtime_held(ticks: int, late_ticks: int, p99_us: float, max_us: float,
                  tick_us: float = NOMINAL_PERIOD_US) -> RealtimeVerdict:
    """Held when the lateness p99 is within one tick and no tick is over REALTIME_MAX_LATE_US
    late (from a run's streamed figures)."""
    return RealtimeVerdict(p99_us <= tick_us and max_us <= REALTIME_MAX_LATE_US, ticks, late_ticks, p99_us, max_us)


def realtime_verdict(lateness_us: np.ndarray, tick_us: float = NOMINAL_PERIOD_US) -> RealtimeVerdict | None:
    """:func:`realtime_held` from per-sample lateness (a log); None without lateness figures
    (a lockstep run)."""
    late = np.asarray(lateness_us, dtype=float)
    late = late[np.isfinite(late) & (late >= 0)]
    if late.size == 0:
        return None
    return realtime_held(int(late.size), int(np.sum(late > LATE_US)), float(np.percentile(late, 99)),
                         float(late.max()), tick_us)


def scaled_compute_us(fc_cpu_us: np.ndarray, cpu_scale: float) -> np.ndarray:
    """The flight code's compute per sample on the target processor: its CPU time on this
    host (us, -1 where not measured) times ``cpu_scale``; unmeasured samples dropped."""
    cpu = np.asarray(fc_cpu_us, dtype=float)
    return cpu[np.isfinite(cpu) & (cpu >= 0)] * cpu_scale


def analyze_arrays(
    latency_us: np.ndarray,
    esc_arrival_host_ns: np.ndarray,
    *,
    compute_us: np.ndarray | None = None,
    budget_us: float = NOMINAL_PERIOD_US,
    nominal_period_us: float = NOMINAL_PERIOD_US,
    lateness_us: np.ndarray | None = None,
    compute_source: ComputeSource = ComputeSource.TELEMETRY,
) -> TimingReport:
    """The report from raw per-sample arrays; negative latency marks a missing command,
    negative lateness a lockstep sample."""
    lat = np.asarray(latency_us, dtype=float)
    missing = lat < 0
    lat_ok = lat[~missing]
    arrivals = np.asarray(esc_arrival_host_ns, dtype=np.int64)
    arrivals = arrivals[arrivals > 0]
    period = np.diff(arrivals) / 1e3 if arrivals.size > 1 else np.zeros(0)
    jitter = np.abs(period - nominal_period_us)
    comp = np.zeros(0) if compute_us is None else np.asarray(compute_us, dtype=float)
    late = np.zeros(0) if lateness_us is None else np.asarray(lateness_us, dtype=float)
    verdict = realtime_verdict(late, nominal_period_us)
    return TimingReport(
        samples=int(lat.size),
        budget_us=budget_us,
        latency_us=Stats.of(lat_ok),
        period_us=Stats.of(period),
        jitter_us=Stats.of(jitter),
        compute_us=Stats.of(comp),
        misses=int(np.sum(lat_ok > budget_us)),
        no_command=int(np.sum(missing)),
        lateness_us=None if verdict is None else Stats.of(late[late >= 0]),
        realtime=verdict,
        compute_source=compute_source,
    )


def analyze_log(log: Path, budget_us: float = NOMINAL_PERIOD_US) -> TimingReport:
    """The report of a run's MCAP (topics /hil/timing/tick and /fc/telemetry; the run's
    ``cpu_scale`` from its verdict metadata)."""
    from hil.record import read_metadata, read_topic

    tick = read_topic(log, "/hil/timing/tick")
    tm = read_topic(log, "/fc/telemetry")
    telemetry = None
    for key in ("compute_last_us", "compute_us", "loop_compute_us"):
        if key in tm and tm[key].size:
            telemetry = tm[key]
            break
    meta = read_metadata(log)
    cclk = board_cclk_hz(meta)
    try:
        cpu_scale = 1.0 if cclk is not None else float(meta.get("verdict", {}).get("cpu_scale", 1.0))
    except ValueError:
        cpu_scale = 1.0
    cpu = tick.get("fc_cpu_us") if tick else None
    source = ComputeSource.CPU if cpu is not None and np.any(np.asarray(cpu) >= 0) else ComputeSource.TELEMETRY
    compute = compute_samples_us(cpu, telemetry, cpu_scale)
    if not tick or "latency_us" not in tick:
        return analyze_arrays(np.zeros(0), np.zeros(0), compute_us=compute, budget_us=budget_us, compute_source=source)
    arrivals = tick["esc_arrival_host_ns"]
    if cclk is not None:  # the commands' instants are the board's (sim time), not the host's
        lat = tick["latency_us"].astype(float)
        arrivals = np.where(lat >= 0, tick["t_ns"] + np.round(lat * 1e3), -1).astype(np.int64)
    rep = analyze_arrays(tick["latency_us"], arrivals, compute_us=compute, budget_us=budget_us,
                         lateness_us=tick.get("lateness_us"), compute_source=source)
    if cclk is None:
        return rep
    return replace(rep, board_cclk_hz=cclk, board_busy_cycles=tuple((compute * cclk / 1e6).tolist()))


def board_cclk_hz(meta: dict[str, dict[str, str]]) -> float | None:
    """A board run's core clock from its log's metadata (None: not a board run)."""
    if not meta.get("run", {}).get("board"):
        return None
    try:
        return float(json.loads(meta.get("verdict", {}).get("timing", "{}")).get("board_cclk_hz", 60e6))
    except (ValueError, AttributeError):
        return 60e6


def plot_latency(log: Path, png: Path, budget_us: float = NOMINAL_PERIOD_US) -> Path | None:
    """Latency over time and its histogram, with the budget marked; None if no timing data."""
    from hil.record import read_topic

    tick = read_topic(log, "/hil/timing/tick")
    if not tick or "latency_us" not in tick or tick["latency_us"].size == 0:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lat = tick["latency_us"].astype(float)
    t = (tick["log_time_ns"] - tick["log_time_ns"][0]) / 1e9
    ok = lat >= 0
    arrivals = tick["esc_arrival_host_ns"].astype(np.int64)
    arrivals = arrivals[arrivals > 0]
    period = np.diff(arrivals) / 1e3
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    axes[0].plot(t[ok], lat[ok], ".", ms=1)
    axes[0].axhline(budget_us, color="r", ls="--", label=f"budget {budget_us:g} us")
    axes[0].set_xlabel("sim time [s]")
    axes[0].set_ylabel("IMU -> ESC latency [us]")
    axes[0].legend()
    axes[1].hist(lat[ok], bins=100, log=True)
    axes[1].axvline(budget_us, color="r", ls="--")
    axes[1].set_xlabel("latency [us]")
    axes[1].set_ylabel("samples")
    if period.size:
        axes[2].hist(period, bins=100, log=True)
        axes[2].axvline(NOMINAL_PERIOD_US, color="g", ls="--", label="2.5 ms")
        axes[2].legend()
    axes[2].set_xlabel("ESC command period [us] (host clock)")
    rep = analyze_log(log, budget_us)
    if rep.board_cclk_hz is not None and rep.board_busy_cycles:  # a board run: the loop's cycles
        axes[2].clear()
        axes[2].hist(rep.board_busy_cycles, bins=100, log=True)
        axes[2].axvline(rep.budget_cycles, color="r", ls="--", label=f"{budget_us:g} us = {rep.budget_cycles:,.0f} cycles")
        axes[2].legend()
        axes[2].set_xlabel(f"loop busy cycles per sample (LPC2148 at {rep.board_cclk_hz / 1e6:g} MHz)")
    for ax in axes:
        ax.grid(True)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)
    return png
