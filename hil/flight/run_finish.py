"""The end of a run, whatever ended it: stop the flight code, close the ports and the clock
session, settle the criteria and the timing figures, finalize the log with the verdict, and
remove the run directory; then the :class:`~hil.flight.run_result.RunResult`.

The order matters: the scenario's processes and the flight code stop first (on virtual
time, their last words at the host's pace), the ports close after their last bytes were
read, the clock session is asked what the flight code used before it closes, and the log
is closed last, with everything the verdict needs.
"""

from __future__ import annotations

import asyncio
import contextlib
import shutil
from collections.abc import Awaitable
from typing import TYPE_CHECKING, Any, TypeVar

from hil.flight.run_files import verdict_metadata
from hil.flight.run_result import RunResult, cores_used, realtime_criterion, timing_summary
from hil.flight.tickloop import Clock, EndReason, Mode
# looked up here at run time: tests put a fake host in its place (tests/system/test_host_figures.py)
from hil.host.steal import realtime_note
from hil.vtime.session import ShimUsage

if TYPE_CHECKING:
    from hil.flight.run_state import RunState

_T = TypeVar("_T")


async def despite_cancel(aw: Awaitable[_T]) -> _T:
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


async def finish_run(run: RunState, end: EndReason, message: str, steal_ms: float | None, fc_cpu_ns: Any,
                     rec_cpu_ns: Any, rt: Any, wake: Any, *, keep_run_dir: bool) -> RunResult:
    """Release the run's resources in order and finalize its log (see module docstring)."""
    loop, flight, vt, stream, logger, recorder, rig = run.loop, run.flight, run.vt, run.stream, run.logger, \
        run.recorder, run.rig
    assert loop is not None and flight is not None and stream is not None and logger is not None
    run.runner.finish(max(loop.t_ns, 0))
    # A stop that comes while the run is ending (a test's teardown racing the run's own
    # end, a second Ctrl-C) must not cut this short: the flight code would outlive the run.
    await despite_cancel(run.runner.aclose())
    if vt is not None:
        vt.free_run()  # its shutdown and last words at the host's pace
    returncode = await despite_cancel(flight.stop())
    for st in flight.survivors:  # stuck in the kernel: SIGKILL has not taken yet
        run.note(f"process {st.pid} ({st.comm}) of the flight command was still there {st.state!r} after SIGKILL")
    with contextlib.suppress(Exception):
        await despite_cancel(asyncio.sleep(0))  # let the last stderr lines reach the logger
    for port in run.ports.values():
        port.close()
    clock_used = loop.stats.clock
    shim: ShimUsage | None = None
    if vt is not None:
        if clock_used is Clock.VIRTUAL:
            shim = vt.usage()
            for warning in shim.warnings:
                run.note(warning)
        vt.close()
    clock_note = loop.fallback_reason or run.clock_note
    try:
        stream.finish()
    except Exception as exc:  # noqa: BLE001 - the verdict must not cost the log
        run.note(f"bench error in the trace stream: {exc!r}")
    if stream.late_points:
        run.note(f"{stream.late_points} trace samples were stamped more than "
                 f"{stream.horizon_ns / 1e9:g} s before they arrived: the criteria used them late")
    timing = timing_summary(loop, rig.tick_ns, run.telemetry_compute_us, rig.flight.cpu_scale)
    if run.started_ns is not None and loop.stats.wall_start_ns:
        timing["start_to_tick0_s"] = (loop.stats.wall_start_ns - run.started_ns) / 1e9
    timing |= cores_used(loop, fc_cpu_ns, rec_cpu_ns, recorded=recorder is not None)
    realtime = run.mode is Mode.REALTIME
    if steal_ms is not None:
        timing["host_steal_ms"] = steal_ms
        steal_note = realtime_note(steal_ms, loop.stats.late_ticks, loop.stats.no_command) if realtime else None
        if steal_note is not None:
            run.note(steal_note)
    if run.board is not None:  # the board's own figures, in target cycles (hil/flight/board_timing.py)
        timing |= run.board.figures()
    assert run.criteria_stream is not None
    criteria = run.criteria_stream.results() if end is EndReason.COMPLETED else []
    criteria += run.runner.timing_criteria(timing, logger)
    if run.board is not None and end is EndReason.COMPLETED:
        criteria += run.board.criteria(timing)
    held = realtime_criterion(loop, rig.tick_ns) if realtime and end is EndReason.COMPLETED else None
    if held is not None:
        criteria.append(held)
    counters = logger.counters()
    rt_scheduling = rt.result if realtime else None
    stats = None
    if recorder is not None:
        logger.finish(end, criteria, timing, message, returncode)
        final = verdict_metadata(end, criteria, message, returncode, timing, clock_used=clock_used,
                                 clock_note=clock_note, rt_scheduling=rt_scheduling, cpu_latency=wake.result,
                                 cpu_scale=rig.flight.cpu_scale, shim=shim, notes=run.notes)
        try:
            stats = recorder.close(final)
        except OSError as exc:  # the writer died (killed, out of memory): its .part is what is left
            end, message = EndReason.ERROR, f"the recording was not finalized: {exc}"
            part = recorder.path.with_name(recorder.path.name + ".part")
            run.note(f"the recorder died before the end of the run: {part} holds what it wrote; "
                     f"`hil recover {part}` salvages it")
    if not keep_run_dir and run.run_dir is not None:
        shutil.rmtree(run.run_dir, ignore_errors=True)
    return RunResult(
        log_path=stats.path if stats else None, end_reason=end, criteria=criteria, flight_returncode=returncode,
        flight_stderr_tail=list(flight.last_stderr), timing=timing, counters=counters, message=message,
        trace=run.trace, recorded=dict(stats.messages_by_topic) if stats else {},
        dropped=stats.dropped if stats else 0, seed=run.seed, sim_s=loop.stats.ticks * rig.tick_ns / 1e9,
        clock=clock_used, clock_note=clock_note, shim=shim, notes=run.notes, rt_scheduling=rt_scheduling,
        cpu_latency=wake.result,
    )
