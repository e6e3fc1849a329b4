"""One closed-loop run: rig + scenario + seed -> a finished MCAP and a verdict.

``run_flight`` is the unit of work of ``hil run``, of the system tests, of the pytest
plugin and of campaigns. It builds the run directory (mode 0700) with the device
symlinks, the plant and every emulator, writes the flight code's config pointing at the
symlinks, starts the flight code, boots, runs the ticks, and always - on success,
criteria failure, flight-code crash, boot failure, Ctrl-C or a bench error - stops the
flight code, closes the ports and finalizes the MCAP.

What a run produced and its timing figures are in :mod:`hil.flight.run_result`; the files
it writes around the flight (the flight code's config, the log's name and metadata) in
:mod:`hil.flight.run_files`. Their public names are importable from here too.
"""

from __future__ import annotations

import asyncio
import contextlib
import gc
import shutil
import sys
import traceback
from collections.abc import Awaitable, Callable, Mapping
from pathlib import Path
from typing import Any, TypeVar

from hil import clock, native
from hil.analysis.criteria_stream import CriteriaStream
from hil.analysis.trace import Trace
from hil.analysis.trace_stream import TraceSink, TraceStream, TraceTee
from hil.config import ConfigError
from hil.config.attach import follow_device_rates, open_attached, refuse_lockstep, resolve_attachments
from hil.config.rig import Rig, load_rig
from hil.config.scenario import Scenario, apply_to_rig, load_scenario
from hil.flight.devices import DeviceSet
from hil.flight.process import FlightProcess, expand_command
from hil.flight.run_files import deep_merge, default_log_path, run_metadata, verdict_metadata, write_flight_config
from hil.flight.run_result import RunResult, cores_used, held_stats, realtime_criterion, timing_summary
from hil.flight.rundir import make_run_dir
from hil.flight.runlog import STAMP_MAX_AGE_NS, RunLogger
from hil.flight.scenario_runner import ScenarioRunner
from hil.flight.stress import CpuHog
from hil.flight.tickloop import BootError, Clock, EndReason, Mode, TickLoop
from hil.host import cpulatency, rtsched
from hil.host.cpulatency import LatencyMode
from hil.host.cpuuse import ChildCpu
from hil.live.topics import LiveConfig
from hil.live.steer import attach_live
from hil.host.rtsched import RtPolicy
# looked up here at run time: tests put a fake host in its place (tests/system/test_host_figures.py)
from hil.host.steal import StealMeter, realtime_note
from hil.record.process import ProcessRecorder
from hil.transport.base import Port
from hil.transport.pty import PtyPort
from hil.vtime.preload import Fallback
from hil.vtime.session import ShimUsage, VirtualTime, describe_stall

PORTS = ("imu", "adc", "rc", "esc", "telemetry", "ground")
SWITCH_INTERVAL_S = 0.0005
_T = TypeVar("_T")


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
    live: LiveConfig | None = None,
) -> RunResult:
    """Run one flight (see module docstring). Never raises for run-time failures; a scenario
    the rig refuses raises :class:`ConfigError` before anything is created.

    ``virtual_time``: lockstep on sim time through the clock shim (None: the rig's
    ``[flight] virtual_time``, on by default); False runs lockstep on the host clock.
    ``attach``: port -> device or URL over the rig's ``[ports]`` (hil/config/attach.py); realtime only.
    ``started_ns``: host monotonic instant the run was asked for (``hil run`` passes its process
    start): the timing figures then include ``start_to_tick0_s``, the wall time to tick 0.
    ``keep_trace``: keep every sample of the run's signals in ``RunResult.trace`` (the pytest
    plugin's ``bench.signal``; 8 bytes a value, about 6 MB per flight minute). ``live``: serve the
    run to Foxglove and take its steering (hil/live, docs/live.md; needs ``record``). Without it the
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
            metadata=run_metadata(rig, scenario, seed, mode, duration_ns),
            attachments=[
                (rig.path.name, "application/toml", rig.path.read_bytes()),
                (rig.flight_config_path.name, "application/toml", rig.flight_config_path.read_bytes()),
                (f"{scenario.name}.toml", "application/toml", runner.source_bytes()),
            ], live=live, duration_ns=duration_ns,
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
    telemetry_compute_us = held_stats(stream, "tm.compute_last_us")

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
    if stale:  # the compiled build is older than the sources: this run is interpreted, say so
        note(native.stale_message(stale))

    vt: VirtualTime | None = None
    clock_note = ""
    if mode is Mode.LOCKSTEP:
        wanted = rig.flight.virtual_time if virtual_time is None else virtual_time
        ptys = {n: p for n, p in ports.items() if isinstance(p, PtyPort)}
        assert len(ptys) == len(ports), "a real serial line in lockstep (refuse_lockstep let it through)"
        opened: VirtualTime | Fallback = (
            VirtualTime.open(run_dir, ptys, argv, on_stall=lambda st: note(describe_stall(st)))
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
    steering = attach_live(recorder, loop, runner, logger, lockstep=mode is Mode.LOCKSTEP)
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
        if steering is not None:
            steering.close()
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
        timing = timing_summary(loop, rig.tick_ns, telemetry_compute_us, rig.flight.cpu_scale)
        if started_ns is not None and loop.stats.wall_start_ns:
            timing["start_to_tick0_s"] = (loop.stats.wall_start_ns - started_ns) / 1e9
        timing |= cores_used(loop, fc_cpu_ns, rec_cpu_ns, recorded=recorder is not None)
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
        rt_scheduling = rt.result if mode is Mode.REALTIME else None
        stats = None
        if recorder is not None:
            logger.finish(end, criteria, timing, message, returncode)
            final = verdict_metadata(end, criteria, message, returncode, timing, clock_used=clock_used,
                                     clock_note=clock_note, rt_scheduling=rt_scheduling, cpu_latency=wake.result,
                                     cpu_scale=rig.flight.cpu_scale, shim=shim, notes=notes)
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
        seed=seed, sim_s=loop.stats.ticks * rig.tick_ns / 1e9,
        clock=clock_used, clock_note=clock_note,
        shim=shim,
        notes=notes,
        rt_scheduling=rt_scheduling, cpu_latency=wake.result,
    )


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


__all__ = [
    "PORTS", "ConfigError", "RunResult", "deep_merge", "default_log_path", "pump_before", "realtime_criterion",
    "run_flight", "run_flight_async", "write_flight_config",
]
