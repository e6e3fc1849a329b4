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
import sys
import traceback
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from hil import clock, native
from hil.analysis.criteria_stream import CriteriaStream
from hil.analysis.trace import Trace
from hil.analysis.trace_stream import TraceSink, TraceStream, TraceTee
from hil.config import ConfigError
from hil.config.attach import follow_device_rates, refuse_lockstep, resolve_attachments
from hil.config.rig import Rig, load_rig
from hil.config.scenario import Scenario, apply_to_rig, load_scenario
from hil.flight import run_setup
from hil.flight.board_run import acquire_board, check_board_run
from hil.flight.devices import DeviceSet
from hil.flight.flight_check import check_flight_config
from hil.flight.process import expand_command
from hil.flight.run_files import deep_merge, default_log_path, run_metadata, write_flight_config
from hil.flight.run_finish import finish_run
from hil.flight.run_state import RunState
from hil.flight.run_result import RunResult, held_stats, realtime_criterion
from hil.flight.run_setup import RunStartError, VirtualTimeRequired
from hil.flight.runlog import STAMP_MAX_AGE_NS, RunLogger
from hil.flight.scenario_runner import ScenarioRunner
from hil.flight.stress import CpuHog
from hil.flight.tickloop import BootError, EndReason, Mode, TickLoop
from hil.host import cpulatency, rtsched
from hil.host.cpulatency import LatencyMode
from hil.host.cpuuse import ChildCpu
from hil.host.rtsched import RtPolicy
# looked up here at run time: tests put a fake host in its place (tests/system/test_host_figures.py)
from hil.host.steal import StealMeter
from hil.live.steer import attach_live
from hil.live.topics import LiveConfig
from hil.record.process import ProcessRecorder
from hil.vtime.preload import Fallback
from hil.vtime.stall import HiddenWait
from hil.vtime.session import describe_stall

PORTS = ("imu", "adc", "rc", "esc", "telemetry", "ground")
SWITCH_INTERVAL_S = 0.0005


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
    require_virtual_time: bool | None = None,
    attach: Mapping[str, str] | None = None,
    started_ns: int | None = None,
    keep_trace: bool = False,
    live: LiveConfig | None = None,
    gdb_port: int | None = None,
) -> RunResult:
    """Run one flight (see module docstring). Never raises for run-time failures; a scenario
    the rig refuses raises :class:`ConfigError` before anything is created, and a resource
    that cannot be had raises :class:`RunStartError` after everything acquired was released.

    ``virtual_time``: lockstep on sim time through the clock shim (None: the rig's
    ``[flight] virtual_time``, on by default); False runs lockstep on the host clock.
    ``require_virtual_time``: lockstep's fall-back to the host clock raises
    :class:`VirtualTimeRequired` (a ConfigError) instead (None: the rig's ``[flight]
    require_virtual_time``); a fall-back during boot first finalizes the log.
    ``attach``: port -> device or URL over the rig's ``[ports]`` (hil/config/attach.py); realtime only.
    ``started_ns``: host monotonic instant the run was asked for (``hil run`` passes its process
    start): the timing figures then include ``start_to_tick0_s``, the wall time to tick 0.
    ``keep_trace``: keep every sample of the run's signals in ``RunResult.trace`` (the pytest
    plugin's ``bench.signal``; 8 bytes a value, about 6 MB per flight minute). ``live``: serve the
    run to Foxglove and take its steering (hil/live, docs/live.md; needs ``record``). Without it the
    bench's memory does not grow with the flight's length: the criteria stream
    (hil/analysis/criteria_stream.py). ``gdb_port``: a board run waits for GDB on this TCP port
    (0: a free one, announced on stderr) and holds while it holds the core (hil/flight/board_gdb.py)."""
    # The recorder's writer thread must not hold the GIL for the default 5 ms while the
    # tick waits on a pty (hil/record measurements: wake-ups 2.2 ms late otherwise).
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    # The scenario is checked against the rig (faults, budgets) before anything is created:
    # a refused scenario raises ConfigError and leaves nothing behind.
    rig = apply_to_rig(rig, scenario)  # the scenario's [wind] over the rig's
    run = RunState(rig, scenario, ScenarioRunner(scenario, rig, scenario_source), mode,
               seed=scenario.scenario.seed if seed is None else seed,
               duration_ns=scenario.duration_ns if duration_s is None else int(duration_s * 1e9),
               started_ns=started_ns,
               require_vt=rig.flight.require_virtual_time if require_virtual_time is None else require_virtual_time)
    if rig.flight.board:
        check_board_run(rig, mode, attach)
    elif gdb_port is not None:
        raise ConfigError(f"{rig.path}: --gdb: the rig's flight code is a process, not the emulated board "
                          "([flight] board); debug it with its own debugger as the launcher (docs/time.md, "
                          "`gdb --batch -ex run --args ...`)")
    run.gdb_port = gdb_port
    attachments = resolve_attachments(rig.ports, attach or {}, PORTS, command="run")
    refuse_lockstep(attachments, mode.value)
    rt = rtsched.for_rig(rig, realtime=mode is Mode.REALTIME)  # "fifo" refused: nothing is created yet
    wake = cpulatency.for_rig(rig)  # "require" refused: likewise
    if not rig.flight.board:  # a board's firmware checks the config it is given, at boot
        await check_flight_config(rig, scenario, scenario_source)  # the flight code's own word on [flight] overrides
    async with contextlib.AsyncExitStack() as stack:
        await _acquire(stack, run, attachments, keep_run_dir=keep_run_dir, stress_adc_delay_us=stress_adc_delay_us,
                       record=record, out_dir=out_dir, log_path=log_path, keep_trace=keep_trace,
                       virtual_time=virtual_time, live=live)
        loop = run.loop
        assert loop is not None and run.logger is not None
        if on_ready is not None:
            on_ready(loop, run.devices, run.runner)  # type: ignore[arg-type]
        # after on_ready: steering chains the tick gate a test may have set
        run.steering = attach_live(run.recorder, loop, run.runner, run.logger, lockstep=run.mode is Mode.LOCKSTEP,
                                   note=run.note)
        if run.steering is not None:
            stack.callback(run.steering.close)  # idempotent: the flight's own end closes it first
        if progress is not None:
            duration_ns = run.duration_ns
            run.logger.progress = lambda t_ns: progress(t_ns / 1e9, duration_ns / 1e9, run.runner.phase(t_ns))
        result = await _fly_and_finish(run, rt, wake, CpuHog(stress_cpu), keep_run_dir=keep_run_dir)
    if run.vt_refused is not None:
        raise run.vt_refused
    return result


async def _acquire(stack: contextlib.AsyncExitStack, run: RunState, attachments: Mapping[str, Any], *,
                   keep_run_dir: bool, stress_adc_delay_us: float, record: bool, out_dir: Path | str | None,
                   log_path: Path | None, keep_trace: bool, virtual_time: bool | None,
                   live: LiveConfig | None) -> None:
    """Every resource of the run, each on ``stack`` as soon as it exists (hil/flight/run_setup.py)."""
    rig, scenario, runner = run.rig, run.scenario, run.runner
    if rig.flight.board:  # the emulated board in place of a process, its ptys and clock session
        await acquire_board(stack, run, lambda ports, files, meta: _record(
            stack, run, ports, files, meta, record=record, out_dir=out_dir, log_path=log_path,
            keep_trace=keep_trace, live=live))
        return
    with run_setup.started("opening the serial lines"):  # all or none: a missing/busy one leaves nothing
        run.attached = run_setup.open_serial_lines(stack, attachments, rig)
    with run_setup.started("creating the run directory"):
        run.run_dir = run_setup.make_private_dir(stack, rig, keep=keep_run_dir)
    devices = run.devices = DeviceSet(rig, seed=run.seed, stick_script=runner.stick_script())
    devices.adc_reply_delay_ns = int(stress_adc_delay_us * 1000)
    runner.bind(devices)
    with run_setup.started("opening the ports"):
        run.ports = await run_setup.open_ports(stack, PORTS, run.run_dir / "dev", run.attached)
    devices.attach(dict(run.ports))
    follow_device_rates(devices, run.attached)  # type: ignore[arg-type]
    logger = _record(stack, run, run.ports, [], {}, record=record, out_dir=out_dir, log_path=log_path,
                     keep_trace=keep_trace, live=live)
    stream = run.stream
    assert stream is not None
    with run_setup.started("writing the flight code's config"):
        argv = expand_command(rig.flight.command,
                              config=run_setup.write_config(rig, scenario, run.ports, run.run_dir))
    for port in run.attached.values():
        for text in port.notes:  # type: ignore[attr-defined]
            run.note(text)
    stale = native.stale()
    if stale:  # the compiled build is older than the sources: this run is interpreted, say so
        run.note(native.stale_message(stale, native.state().groups))
    if run.mode is Mode.LOCKSTEP:
        wanted = rig.flight.virtual_time if virtual_time is None else virtual_time
        with run_setup.started("setting up virtual time"):
            opened = run_setup.open_virtual_time(stack, run.run_dir, run.ports, argv, wanted,
                                                 on_stall=lambda st: run.note(describe_stall(st)))
        if isinstance(opened, Fallback):
            run.clock_note = opened.reason
            run.host_clock(opened.reason)
        else:
            run.vt = opened
    with run_setup.started("preparing the flight code's process"):
        flight = run.flight = run_setup.make_flight(stack, argv, logger, run.vt, rig.flight.stop_grace_s)
    vt = run.vt
    loop = run.loop = TickLoop(
        devices, mode=run.mode, tick_ns=rig.tick_ns, duration_ns=run.duration_ns,
        barrier_timeout_s=rig.flight.barrier_timeout_s, boot_timeout_s=rig.flight.boot_timeout_s,
        before_tick=runner.before_tick, after_tick=logger.after_tick, flight_exited=flight.exited,
        # on virtual time a restart's new process is waited for from the tick its downtime ends
        flight_running=(lambda: flight.running or flight.starting) if vt is not None else (lambda: flight.running),
        vclock=vt.clock if vt is not None else None, on_fallback=run.host_clock,
    )
    if stream.deferred:
        loop.slack_work = lambda deadline_ns: pump_before(stream, deadline_ns)
    runner.attach_flight(flight)


def _record(stack: contextlib.AsyncExitStack, run: RunState, ports: Mapping[str, Any],
            files: list[tuple[str, str, bytes]], meta: dict[str, str], *, record: bool,
            out_dir: Path | str | None, log_path: Path | None, keep_trace: bool,
            live: LiveConfig | None) -> RunLogger:
    """The recorder child (with the run's files and ``files``, its metadata and ``meta``), the
    criteria's stream and the run logger on ``ports``."""
    rig, scenario, runner, devices = run.rig, run.scenario, run.runner, run.devices
    assert devices is not None
    run_start_unix_ns = clock.wall_ns()
    if record:
        out = Path(out_dir or "logs")
        meta = run_metadata(rig, scenario, run.seed, run.mode, run.duration_ns) | meta
        files = [(rig.path.name, "application/toml", rig.path.read_bytes()),
                 (rig.flight_config_path.name, "application/toml", rig.flight_config_path.read_bytes()),
                 (f"{scenario.name}.toml", "application/toml", runner.source_bytes()), *files]
        with run_setup.started("starting the recorder"):
            out.mkdir(parents=True, exist_ok=True)
            run.recorder = run_setup.start_recorder(
                stack, lambda path: ProcessRecorder(path, run_start_unix_ns=run_start_unix_ns, metadata=meta,
                                                    attachments=files, live=live,
                                                    duration_ns=run.duration_ns),
                log_path or default_log_path(out, rig, scenario, run.seed), unique=log_path is None)
    # The criteria read the run's signals as they stream (a delay line longer than the oldest
    # stamp a telemetry frame may carry), so no sample is kept for the whole run unless asked.
    # Realtime: the criteria's work on a chunk (0.5-2.3 ms, once a second) waits for the time
    # the ticks leave, instead of making one tick late (docs/performance.md, "Realtime").
    stream = run.stream = TraceStream(horizon_ns=STAMP_MAX_AGE_NS + 100 * rig.tick_ns,
                                      deferred=run.mode is Mode.REALTIME)
    run.trace = Trace() if keep_trace else None
    sink: TraceSink = stream if run.trace is None else TraceTee(stream, run.trace)
    logger = run.logger = RunLogger(run.recorder, sink, devices, ports, rig, run_start_unix_ns)
    runner.log_event = logger.event
    run.criteria_stream = CriteriaStream(scenario.criteria, stream)
    run.telemetry_compute_us = held_stats(stream, "tm.compute_last_us")
    return logger


async def _fly_and_finish(run: RunState, rt: Any, wake: Any, hog: CpuHog, *, keep_run_dir: bool) -> RunResult:
    """Start the flight code, boot, run the ticks; then, whatever happened, stop everything in
    order and finalize the log with the verdict."""
    loop, flight, logger, recorder = run.loop, run.flight, run.logger, run.recorder
    assert loop is not None and flight is not None and logger is not None
    end = EndReason.ERROR
    message = ""
    steal = StealMeter()  # the hypervisor's pauses over the tick loop (hil/host/steal.py)
    # the other processes' CPU over the tick loop, beside the bench's own (hil/host/cpuuse.py)
    fc_cpu = ChildCpu(lambda: flight.pid, others=flight.tree_pids)  # a launcher's flight code too
    rec_cpu = ChildCpu(lambda: recorder.pid if recorder is not None else None)
    frozen = False
    try:
        hog.__enter__()
        wake_got = wake.__enter__()
        if not wake_got.held and wake.mode is LatencyMode.AUTO and run.mode is Mode.REALTIME:
            # lockstep flies the same either way, only slower: the summary's host line says it
            run.note(f"the host's idle CPUs may sleep, so every wake-up of the bench and the flight code "
                     f"comes later and so do the responses: {wake_got.reason}")
        rt_got = rt.__enter__()
        if rt_got.policy is not RtPolicy.FIFO and rt.policy is RtPolicy.AUTO:
            run.note(f"realtime on the default scheduling policy, so other load on this host delays ticks: {rt_got.reason}")
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
                message = (run.board.exit_message(loop.t_ns) if run.board is not None else
                           f"the flight code exited with status {flight.returncode} at t = {loop.t_ns / 1e9:.3f} s")
    except asyncio.CancelledError:
        end, message = EndReason.INTERRUPTED, "interrupted (Ctrl-C)"
    except VirtualTimeRequired as exc:  # a fall-back during boot: finalize the log, then say so
        end, message, run.vt_refused = EndReason.ERROR, str(exc), exc
    except HiddenWait as exc:  # a process of the flight command waits where the clock shim cannot see
        end, message = EndReason.ERROR, str(exc)
        logger.event(max(loop.t_ns, 0), "run", "hidden wait", {"error": str(exc)})
    except Exception as exc:  # a bench bug must still finalize the log
        end, message = EndReason.ERROR, f"bench error: {type(exc).__name__}: {exc}"
        # the traceback goes into the log: a bench bug is found from the run it spoiled
        logger.event(max(loop.t_ns, 0), "run", "bench error", {"error": repr(exc), "traceback": traceback.format_exc()})
    except BaseException as exc:  # KeyboardInterrupt, a test framework's timeout: finalize, then raise
        end, message = EndReason.INTERRUPTED, f"interrupted by {type(exc).__name__}: {exc}"
        raise
    finally:
        if run.steering is not None:
            run.steering.close()  # a gate still paused lets the teardown go on
        steal_ms = steal.stop()  # the tick loop's, before the teardown
        fc_cpu_ns, rec_cpu_ns = fc_cpu.stop(), rec_cpu.stop()
        rt.__exit__(None, None, None)
        wake.__exit__(None, None, None)
        if frozen:
            gc.unfreeze()
        hog.__exit__(None, None, None)
        result = await finish_run(run, end, message, steal_ms, fc_cpu_ns, rec_cpu_ns, rt, wake,
                                  keep_run_dir=keep_run_dir)
    return result


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
    "PORTS", "ConfigError", "RunResult", "RunStartError", "VirtualTimeRequired", "deep_merge", "default_log_path", "pump_before", "realtime_criterion",
    "run_flight", "run_flight_async", "write_flight_config",
]
