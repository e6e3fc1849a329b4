"""One closed-loop run driven by a test: :class:`Bench` starts it as a task in the test's event
loop, wires itself into the tick loop, devices and scenario runner, passes on interrupts that
land in the bench to the test, and stops it. Its other jobs are its bases': observing
(``observe``), sim time and waits (``simtime``), faults (``act``)."""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING, Any

from hil.testing.act import BenchActions

if TYPE_CHECKING:
    from hil.flight.devices import DeviceSet
    from hil.flight.run import RunResult
    from hil.flight.scenario_runner import ScenarioRunner
    from hil.flight.tickloop import TickLoop


class Bench(BenchActions):
    """One closed-loop run started by :meth:`HilBench.start` (do not build it directly)."""

    # -- start ------------------------------------------------------------------------------------
    async def _start(self) -> None:
        from hil.flight.tickloop import Mode
        from hil.flight.run import run_flight_async

        loop = asyncio.get_running_loop()
        self._test_task = asyncio.current_task()
        self._task = loop.create_task(run_flight_async(
            self.rig, self.scenario, mode=Mode(self.mode), seed=self.seed, duration_s=self.duration_s,
            out_dir=self.log_path.parent, log_path=self.log_path, on_ready=self._on_ready,
            scenario_source=self.source, keep_trace=True, live=self.live), name=f"hil-bench {self.log_path.stem}")
        self._task.add_done_callback(self._run_done)
        if self._test_task is not None:
            self._test_task.add_done_callback(lambda _: self._gate_open.set())
        self._prev_handler = loop.get_exception_handler()
        loop.set_exception_handler(self._loop_exception)
        await self._watch("time", None, 0, "the first tick")
        if self._setup_error is not None:
            await self.stop()
            raise self._setup_error

    # -- interrupts that land in the bench ---------------------------------------------------------------
    # pytest-timeout (signal method) and Ctrl-C raise in whatever code runs when the signal
    # comes, and the bench's tick is usually what runs. Raised in the run's task it ends the run
    # (its log finalized) while the test would wait for ever; raised in a loop callback asyncio
    # would only log it. Either way the test is cancelled and its bench waits raise it.
    def _run_done(self, task: asyncio.Task[RunResult]) -> None:
        if not task.cancelled() and task.exception() is not None and not isinstance(task.exception(), Exception):
            self._interrupt(task.exception())  # type: ignore[arg-type]

    def _loop_exception(self, loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
        exc = context.get("exception")
        if exc is not None and not isinstance(exc, Exception):
            self._interrupt(exc)
            if self._task is not None and not self._task.done():
                self._task.cancel()  # the run cannot trust its state any more: end it, finalized
        if self._prev_handler is not None:
            self._prev_handler(loop, context)
        else:
            loop.default_exception_handler(context)

    def _interrupt(self, exc: BaseException) -> None:
        if self.interrupted is not None or self.torn_down:
            return
        self.interrupted = exc
        test = self._test_task
        if test is not None and not test.done():
            test.cancel(f"the bench was interrupted by {type(exc).__name__}: {exc}")

    def _on_ready(self, loop: TickLoop, devices: DeviceSet, runner: ScenarioRunner) -> None:
        from hil.faults import FaultSchedule

        self.loop, self.devices, self.runner = loop, devices, runner
        loop.tick_gate = self._gate
        self._last_k = loop.duration_ns // loop.tick_ns
        self._before, self._after = loop.before_tick, loop.after_tick
        loop.before_tick, loop.after_tick = self._before_tick, self._after_tick
        devices.event_sinks.append(self._on_event)
        devices.ports["telemetry"].taps.append(self._on_telemetry_wire)
        # The runner's schedule (it plays the scenario's [[faults]]) takes the test's faults
        # too; a runner without one gets ours, fed the scenario's faults from before_tick.
        existing = runner.schedule
        try:
            if existing is not None:
                self.schedule = existing
            else:
                self.schedule = FaultSchedule(self._faults, devices, log_event=runner.log_event, flight=runner.flight)
                self._own_schedule = True
        except Exception as exc:  # noqa: BLE001 - must not escape into run_flight_async's set-up
            self._setup_error = exc
            self.schedule = FaultSchedule([], devices, log_event=runner.log_event, flight=runner.flight)
            self._own_schedule = True

    # -- the end -------------------------------------------------------------------------------------
    async def finish(self) -> RunResult:
        """Wait for the run's own end (its duration, or the flight code's exit); the result."""
        self._finishing = True
        self._gate_open.set()
        await asyncio.wait({self._require_task()})
        return await self._closed()

    async def stop(self) -> RunResult:
        """End the run now (EndReason.INTERRUPTED, a "pytest"/"stop" event before it); the result."""
        task = self._require_task()
        if not task.done():
            self.stopped_by_test = True
            self.log_event("stop", {"t_s": self.t_s})
            if self._own_schedule and self.schedule is not None and self.loop is not None:
                self.schedule.finish(max(self.loop.t_ns, 0))
            task.cancel()
        await asyncio.wait({task})
        return await self._closed()

    async def _closed(self) -> RunResult:
        if self._stall_handle is not None:
            self._stall_handle.cancel()
        if self._test_task is not None:
            loop = asyncio.get_running_loop()
            if loop.get_exception_handler() == self._loop_exception:
                loop.set_exception_handler(self._prev_handler)
            self._test_task = None
        if self._own_schedule and self.schedule is not None:
            await self.schedule.aclose()
        for w in self._watches:
            w.future.cancel()
        return self.result
