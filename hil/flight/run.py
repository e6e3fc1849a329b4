"""One closed-loop run: rig + scenario + seed -> a finished MCAP and a verdict.

``run_flight`` is the unit of work of ``hil run``, of the system tests, of the pytest
plugin and of campaigns. It builds the run directory (mode 0700) with the device
symlinks, the plant and every emulator, writes the flight code's config pointing at the
symlinks, starts the flight code, boots, runs the ticks, and always - on success,
criteria failure, flight-code crash, boot failure, Ctrl-C or a bench error - stops the
flight code, closes the ports and finalizes the MCAP.
"""

from __future__ import annotations

import asyncio
import contextlib
import gc
import json
import math
import shutil
import sys
import traceback
from collections.abc import Awaitable, Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import tomli_w

from hil import __version__, clock, native
from hil.config.attach import follow_device_rates, open_attached, refuse_lockstep, resolve_attachments
from hil.flight.tickloop import BootError, Clock, EndReason, Mode, TickLoop
from hil.config import ConfigError, load_toml
from hil.analysis.criteria import CriterionResult
from hil.analysis.criteria_stream import CriteriaStream
from hil.flight.devices import DeviceSet
from hil.flight.process import FlightProcess, expand_command
from hil.record.process import ProcessRecorder
from hil.config.rig import Rig, load_rig
from hil.host import cpulatency, rtsched
from hil.host.cpulatency import CpuLatency, LatencyMode
from hil.host.cpuuse import ChildCpu
from hil.host.rtsched import RtPolicy, RtScheduling
from hil.flight.rundir import make_run_dir
from hil.flight.runlog import STAMP_MAX_AGE_NS, RunLogger
from hil.config.scenario import Scenario, apply_to_rig, load_scenario
from hil.flight.scenario_runner import ScenarioRunner
from hil.flight.stress import CpuHog
from hil.analysis.signal_stream import Held
from hil.host.steal import StealMeter, realtime_note
from hil.analysis.timing import REALTIME_MAX_LATE_US, StreamingStats, realtime_held, scaled_compute_us
from hil.analysis.trace import Trace
from hil.analysis.trace_stream import TraceSink, TraceStream, TraceTee
from hil.transport.base import Port
from hil.transport.pty import PtyPort
from hil.vtime.preload import Fallback
from hil.vtime.session import ShimUsage, VirtualTime, describe_stall

PORTS = ("imu", "adc", "rc", "esc", "telemetry", "ground")
SWITCH_INTERVAL_S = 0.0005
_T = TypeVar("_T")


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


def deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = deep_merge(out[key], value)
        else:
            out[key] = value
    return out


def write_flight_config(rig: Rig, scenario: Scenario, ports: Mapping[str, Port], run_dir: Path) -> Path:
    """The flight code's own config, from the rig's template, pointing at the symlinks."""
    template_path = rig.flight_config_path
    config = load_toml(template_path)
    config = deep_merge(config, rig.flight.overrides)
    config = deep_merge(config, scenario.flight)
    port_table = dict(config.get("ports", {}))
    for name in ("imu", "adc", "rc", "esc", "telemetry"):
        entry = dict(port_table.get(name, {}))
        client_path = ports[name].client_path  # None: a real line whose far end the template names
        if client_path is not None:
            entry["path"] = client_path
        # A template that names a baud keeps it (a wrong one is a test of the flight code);
        # otherwise the device's own line rate from the rig.
        entry.setdefault("baud", rig.device_baud(name))
        port_table[name] = entry
    config["ports"] = port_table
    path = run_dir / "flight.toml"
    path.write_text(tomli_w.dumps(config))
    return path


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


async def _despite_cancel(aw: Awaitable[_T]) -> _T:
    """Await ``aw`` to its end even if this task is cancelled meanwhile (a run's cleanup).
    The cancel is taken back (``uncancel``): the run is ending anyway, and its result is
    the answer to whoever asked it to stop."""
    fut = asyncio.ensure_future(aw)
    while True:
        try:
            return await asyncio.shield(fut)
        except asyncio.CancelledError:
            if fut.cancelled():
                raise
            task = asyncio.current_task()
            if task is not None:
                task.uncancel()


def _timing_summary(loop: TickLoop, tick_ns: int, telemetry_compute_us: StreamingStats | None = None,
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
    virtual = st.clock is Clock.VIRTUAL
    out |= _percentiles("latency", st.latencies_ns, 1e-3)
    out |= _percentiles("host_latency", lat.host_latency_ns, 1e-3)
    if st.tick_cost_ns:
        cost = st.tick_cost_ns
        out |= {"bench_cost_p50_us": cost.percentile(50) / 1e3, "bench_cost_p99_us": cost.percentile(99) / 1e3}
    if st.clock is Clock.REALTIME:
        out["rt_no_command"] = float(st.no_command)
    if st.clock is not Clock.VIRTUAL:
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


def _cores_used(loop: TickLoop, fc_cpu_ns: int | None, rec_cpu_ns: int | None, *, recorded: bool) -> dict[str, float]:
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
                           "" if verdict.held else verdict.text)


def _held_stats(stream: TraceStream, name: str) -> StreamingStats:
    """Streamed statistics of the irregular series ``name`` held on the tick grid."""
    stats, held = StreamingStats(), Held(name)
    stream.subscribe(lambda chunk: stats.extend(held.block(chunk)[1]))
    return stats


def default_log_path(out_dir: Path, rig: Rig, scenario: Scenario, seed: int) -> Path:
    stamp = clock.wall_ns()
    import datetime

    utc = datetime.datetime.fromtimestamp(stamp / 1e9, tz=datetime.UTC).strftime("%Y%m%dT%H%M%S")
    return out_dir / f"{utc}_{rig.name}_{scenario.name}_s{seed}.mcap"


#: realtime: chunk work stops this long before the next tick's deadline: the pacer's spin
#: (clock.SPIN_NS) and one subscriber call (one criterion on a chunk: 0.1-0.3 ms)
SLACK_MARGIN_NS = 600_000
#: realtime: with more chunks than this queued, a tick makes one call even without slack,
#: so a host too busy to leave any still delivers (late ticks rather than an unbounded queue)
SLACK_MAX_QUEUED = 2


def pump_before(stream: TraceStream, deadline_ns: int) -> int:
    """Realtime: hand queued chunks to the stream's subscribers until ``SLACK_MARGIN_NS``
    before ``deadline_ns`` (host monotonic ns); returns the calls made."""
    if not stream.queued_chunks:  # most ticks: nothing to build a closure for
        return 0
    stop_ns = deadline_ns - SLACK_MARGIN_NS
    calls = stream.pump(lambda: clock.monotonic_ns() < stop_ns)
    if calls == 0 and stream.queued_chunks > SLACK_MAX_QUEUED:
        once = iter((True,))
        calls = stream.pump(lambda: next(once, False))
    return calls


async def run_flight_async(
    rig: Rig,
    scenario: Scenario,
    *,
    mode: Mode = Mode.LOCKSTEP,
    seed: int | None = None,
    duration_s: float | None = None,
    out_dir: Path | str | None = None,
    log_path: Path | None = None,
    record: bool = True,
    progress: Callable[[float, float, str], None] | None = None,
    keep_run_dir: bool = False,
    on_ready: Callable[[TickLoop, DeviceSet, ScenarioRunner], None] | None = None,
    scenario_source: Path | None = None,
    stress_cpu: int = 0,
    stress_adc_delay_us: float = 0.0,
    virtual_time: bool | None = None,
    attach: Mapping[str, str] | None = None,
    started_ns: int | None = None,
    keep_trace: bool = False,
) -> RunResult:
    """Run one flight (see module docstring). Never raises for run-time failures; a scenario
    the rig refuses raises :class:`ConfigError` before anything is created.

    ``virtual_time``: lockstep on sim time through the clock shim (None: the rig's
    ``[flight] virtual_time``, on by default); False runs lockstep on the host clock.
    ``attach``: port -> device or URL over the rig's ``[ports]`` (hil/config/attach.py); realtime only.
    ``started_ns``: host monotonic instant the run was asked for (``hil run`` passes its process
    start): the timing figures then include ``start_to_tick0_s``, the wall time to tick 0.
    ``keep_trace``: keep every sample of the run's signals in ``RunResult.trace`` (the pytest
    plugin's ``bench.signal``; 8 bytes a value, about 6 MB per flight minute). Without it the
    bench's memory does not grow with the flight's length: the criteria stream
    (hil/analysis/criteria_stream.py)."""
    # The recorder's writer thread must not hold the GIL for the default 5 ms while the
    # tick waits on a pty (hil/record measurements: wake-ups 2.2 ms late otherwise).
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    seed = scenario.scenario.seed if seed is None else seed
    duration_ns = scenario.duration_ns if duration_s is None else int(duration_s * 1e9)
    # The scenario is checked against the rig (faults, budgets) before anything is created:
    # a refused scenario raises ConfigError and leaves nothing behind.
    rig = apply_to_rig(rig, scenario)  # the scenario's [wind] over the rig's
    runner = ScenarioRunner(scenario, rig, scenario_source)
    # Real serial ports open first, all or none: a missing/busy one leaves nothing behind.
    attachments = resolve_attachments(rig.ports, attach or {}, PORTS, command="run")
    refuse_lockstep(attachments, mode.value)
    rt = rtsched.for_rig(rig, realtime=mode is Mode.REALTIME)  # "fifo" refused: nothing is created yet
    wake = cpulatency.for_rig(rig)  # "require" refused: likewise
    attached = open_attached(attachments, rig.port_baud)
    run_dir = make_run_dir(f"hil-{rig.name}-")
    dev_dir = run_dir / "dev"
    dev_dir.mkdir(mode=0o700)

    devices = DeviceSet(rig, seed=seed, stick_script=runner.stick_script())
    devices.adc_reply_delay_ns = int(stress_adc_delay_us * 1000)
    runner.bind(devices)
    ports: dict[str, Port] = {name: attached.get(name) or PtyPort(name, dev_dir) for name in PORTS}
    for port in ports.values():
        await port.start()
    devices.attach(dict(ports))
    follow_device_rates(devices, attached)

    run_start_unix_ns = clock.wall_ns()
    recorder: ProcessRecorder | None = None
    if record:
        out_dir = Path(out_dir or "logs")
        out_dir.mkdir(parents=True, exist_ok=True)
        log_path = log_path or default_log_path(out_dir, rig, scenario, seed)
        recorder = ProcessRecorder(
            log_path,
            run_start_unix_ns=run_start_unix_ns,
            metadata=_metadata(rig, scenario, seed, mode, duration_ns),
            attachments=[
                (rig.path.name, "application/toml", rig.path.read_bytes()),
                (rig.flight_config_path.name, "application/toml", rig.flight_config_path.read_bytes()),
                (f"{scenario.name}.toml", "application/toml", runner.source_bytes()),
            ],
        )
        recorder.start()
    # The criteria read the run's signals as they stream (a delay line longer than the oldest
    # stamp a telemetry frame may carry), so no sample is kept for the whole run unless asked.
    # Realtime: the criteria's work on a chunk (0.5-2.3 ms, once a second) waits for the time
    # the ticks leave, instead of making one tick late (docs/performance.md, tenth round).
    stream = TraceStream(horizon_ns=STAMP_MAX_AGE_NS + 100 * rig.tick_ns, deferred=mode is Mode.REALTIME)
    trace = Trace() if keep_trace else None
    sink: TraceSink = stream if trace is None else TraceTee(stream, trace)
    logger = RunLogger(recorder, sink, devices, ports, rig, run_start_unix_ns)
    runner.log_event = logger.event
    criteria_stream = CriteriaStream(scenario.criteria, stream)
    telemetry_compute_us = _held_stats(stream, "tm.compute_last_us")

    flight_config = write_flight_config(rig, scenario, ports, run_dir)
    argv = expand_command(rig.flight.command, config=flight_config)
    notes: list[str] = []

    def note(text: str) -> None:
        notes.append(text)
        logger.event(max(devices.t_ns, 0), "run", "note", {"text": text})

    for port in attached.values():
        for text in port.notes:
            note(text)
    stale = native.stale()
    if stale:  # the run is the old build's, not the sources': say so in its summary and log
        note(native.stale_message(stale))

    vt: VirtualTime | None = None
    clock_note = ""
    if mode is Mode.LOCKSTEP:
        wanted = rig.flight.virtual_time if virtual_time is None else virtual_time
        opened: VirtualTime | Fallback = (
            VirtualTime.open(run_dir, ports, argv, on_stall=lambda st: note(describe_stall(st)))
            if wanted else Fallback("virtual time switched off (rig [flight] virtual_time or --wall-clock)")
        )
        if isinstance(opened, Fallback):
            clock_note = opened.reason
            note(f"lockstep on the host clock (load changes the flight): {clock_note}")
        else:
            vt = opened
    flight = FlightProcess(
        argv,
        cwd=Path.cwd(),
        on_line=lambda stream, line: logger.flight_line(stream, line),
        env=vt.env if vt is not None else None,
    )
    if vt is not None:
        vt.bind(flight)
    loop = TickLoop(
        devices,
        mode=mode,
        tick_ns=rig.tick_ns,
        duration_ns=duration_ns,
        barrier_timeout_s=rig.flight.barrier_timeout_s,
        boot_timeout_s=rig.flight.boot_timeout_s,
        before_tick=runner.before_tick,
        after_tick=logger.after_tick,
        flight_exited=flight.exited,
        # on virtual time a restart's new process is waited for from the tick its downtime ends
        flight_running=(lambda: flight.running or flight.starting) if vt is not None else (lambda: flight.running),
        vclock=vt.clock if vt is not None else None,
        on_fallback=lambda why: note(f"lockstep on the host clock (load changes the flight): {why}"),
    )
    if stream.deferred:
        loop.slack_work = lambda deadline_ns: pump_before(stream, deadline_ns)
    runner.attach_flight(flight)
    if on_ready is not None:
        on_ready(loop, devices, runner)
    if progress is not None:
        logger.progress = lambda t_ns: progress(t_ns / 1e9, duration_ns / 1e9, runner.phase(t_ns))

    end = EndReason.ERROR
    message = ""
    hog = CpuHog(stress_cpu)
    steal = StealMeter()  # the hypervisor's pauses over the tick loop (hil/host/steal.py)
    # the other processes' CPU over the tick loop, beside the bench's own (hil/host/cpuuse.py)
    fc_cpu = ChildCpu(lambda: flight.pid)
    rec_cpu = ChildCpu(lambda: recorder.pid if recorder is not None else None)
    frozen = False
    try:
        hog.__enter__()
        wake_got = wake.__enter__()
        if not wake_got.held and wake.mode is LatencyMode.AUTO and mode is Mode.REALTIME:
            # lockstep flies the same either way, only slower: the summary's host line says it
            note(f"the host's idle CPUs may sleep, so every wake-up of the bench and the flight code "
                 f"comes later and so do the responses: {wake_got.reason}")
        rt_got = rt.__enter__()
        if rt_got.policy is not RtPolicy.FIFO and rt.policy is RtPolicy.AUTO:
            note(f"realtime on the default scheduling policy, so other load on this host delays ticks: {rt_got.reason}")
        await flight.start()
        try:
            await loop.boot()
        except BootError as exc:
            end, message = EndReason.BOOT_FAILED, str(exc)
        else:
            logger.event(0, "run", "boot complete", {"boot_sim_s": loop.stats.boot_sim_ns / 1e9,
                                                     "clock": loop.stats.clock.value})
            # Everything built so far lives for the whole run: freeze it, so the collector's
            # full passes do not traverse it in the middle of a tick (docs/performance.md,
            # "Garbage collection": fewer late realtime ticks and a shorter worst response).
            gc.collect()
            gc.freeze()
            frozen = True
            steal.start()
            fc_cpu.start()
            rec_cpu.start()
            end = await loop.run()
            if end is EndReason.FLIGHT_EXITED:
                message = f"the flight code exited with status {flight.returncode} at t = {loop.t_ns / 1e9:.3f} s"
    except asyncio.CancelledError:
        end, message = EndReason.INTERRUPTED, "interrupted (Ctrl-C)"
    except Exception as exc:  # a bench bug must still finalize the log
        end, message = EndReason.ERROR, f"bench error: {type(exc).__name__}: {exc}"
        # the traceback goes into the log: a bench bug is found from the run it spoiled
        logger.event(max(loop.t_ns, 0), "run", "bench error", {"error": repr(exc), "traceback": traceback.format_exc()})
    except BaseException as exc:  # KeyboardInterrupt, a test framework's timeout: finalize, then raise
        end, message = EndReason.INTERRUPTED, f"interrupted by {type(exc).__name__}: {exc}"
        raise
    finally:
        steal_ms = steal.stop()  # the tick loop's, before the teardown
        fc_cpu_ns, rec_cpu_ns = fc_cpu.stop(), rec_cpu.stop()
        rt.__exit__(None, None, None)
        wake.__exit__(None, None, None)
        if frozen:
            gc.unfreeze()
        hog.__exit__(None, None, None)
        runner.finish(max(loop.t_ns, 0))
        # A stop that comes while the run is ending (a test's teardown racing the run's own
        # end, a second Ctrl-C) must not cut this short: the flight code would outlive the run.
        await _despite_cancel(runner.aclose())
        if vt is not None:
            vt.free_run()  # its shutdown and last words at the host's pace
        returncode = await _despite_cancel(flight.stop())
        with contextlib.suppress(Exception):
            await _despite_cancel(asyncio.sleep(0))  # let the last stderr lines reach the logger
        for port in ports.values():
            port.close()
        clock_used = loop.stats.clock
        shim: ShimUsage | None = None
        if vt is not None:
            if clock_used is Clock.VIRTUAL:
                shim = vt.usage()
                for warning in shim.warnings:
                    note(warning)
            vt.close()
        clock_note = loop.fallback_reason or clock_note
        try:
            stream.finish()
        except Exception as exc:  # noqa: BLE001 - the verdict must not cost the log
            note(f"bench error in the trace stream: {exc!r}")
        if stream.late_points:
            note(f"{stream.late_points} trace samples were stamped more than "
                 f"{stream.horizon_ns / 1e9:g} s before they arrived: the criteria used them late")
        timing = _timing_summary(loop, rig.tick_ns, telemetry_compute_us, rig.flight.cpu_scale)
        if started_ns is not None and loop.stats.wall_start_ns:
            timing["start_to_tick0_s"] = (loop.stats.wall_start_ns - started_ns) / 1e9
        timing |= _cores_used(loop, fc_cpu_ns, rec_cpu_ns, recorded=recorder is not None)
        if steal_ms is not None:
            timing["host_steal_ms"] = steal_ms
            if mode is Mode.REALTIME:
                steal_note = realtime_note(steal_ms, loop.stats.late_ticks, loop.stats.no_command)
                if steal_note is not None:
                    note(steal_note)
        criteria = criteria_stream.results() if end is EndReason.COMPLETED else []
        timing_criteria = runner.timing_criteria(timing, logger)
        criteria += timing_criteria
        held = realtime_criterion(loop, rig.tick_ns) if mode is Mode.REALTIME and end is EndReason.COMPLETED else None
        if held is not None:
            criteria.append(held)
        counters = logger.counters()
        stats = None
        if recorder is not None:
            logger.finish(end, criteria, timing, message, returncode)
            final = {
                "end_reason": end.value,
                "passed": str(end is EndReason.COMPLETED and all(c.passed for c in criteria)).lower(),
                "message": message,
                "flight_returncode": str(returncode),
                "timing": json.dumps({k: (v if math.isfinite(v) else None) for k, v in timing.items()}),
                "clock": clock_used.value,
                "clock_note": clock_note,
                "rt_scheduling": rt.result.describe() if rt.result is not None and mode is Mode.REALTIME else "",
                "cpu_latency": wake.result.describe() if wake.result is not None else "",
                "cpu_scale": f"{rig.flight.cpu_scale:g}",
                "shim_calls": json.dumps(shim.calls if shim else {}),
                "idle_waits": json.dumps({"inline": shim.idle_waits_inline, "event_loop": shim.idle_waits_loop}
                                         if shim else {}),
                "notes": json.dumps(notes),
            }
            stats = recorder.close(final)
        if not keep_run_dir:
            shutil.rmtree(run_dir, ignore_errors=True)
    return RunResult(
        log_path=stats.path if stats else None,
        end_reason=end,
        criteria=criteria,
        flight_returncode=returncode,
        flight_stderr_tail=list(flight.last_stderr),
        timing=timing,
        counters=counters,
        message=message,
        trace=trace,
        recorded=dict(stats.messages_by_topic) if stats else {},
        dropped=stats.dropped if stats else 0,
        seed=seed,
        sim_s=loop.stats.ticks * rig.tick_ns / 1e9,
        clock=clock_used,
        clock_note=clock_note,
        shim=shim,
        notes=notes,
        rt_scheduling=rt.result if mode is Mode.REALTIME else None,
        cpu_latency=wake.result,
    )


def _metadata(rig: Rig, scenario: Scenario, seed: int, mode: Mode, duration_ns: int) -> dict[str, str]:
    import platform
    import subprocess

    try:
        sha = subprocess.run(
            ["git", "rev-parse", "HEAD"], capture_output=True, text=True, cwd=Path(__file__).parent, timeout=5
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain"], capture_output=True, text=True, cwd=Path(__file__).parent, timeout=5
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        sha, dirty = "", ""
    return {
        "rig": rig.name,
        "rig_file": str(rig.path),
        "scenario": scenario.name,
        "seed": str(seed),
        "mode": mode.value,
        "duration_s": f"{duration_ns / 1e9:g}",
        "tick_ns": str(rig.tick_ns),
        "bench_version": __version__,
        "git_sha": sha or "unknown",
        "git_dirty": str(bool(dirty)).lower(),
        "python": platform.python_version(),
        "host": platform.node(),
        "device_models": native.describe(),
    }


def run_flight(
    rig_name: str | Path | None = None,
    scenario_name: str | Path | None = None,
    **kwargs: Any,
) -> RunResult:
    """Blocking wrapper: resolve files, run, return the result (campaign unit of work)."""
    rig = load_rig(rig_name)
    source = rig.scenario_path(scenario_name)
    scenario = load_scenario(source)
    return asyncio.run(run_flight_async(rig, scenario, scenario_source=source, **kwargs))


__all__ = ["ConfigError", "RunResult", "run_flight", "run_flight_async"]
