"""The run loop: boot, then the 400 Hz tick in lockstep or realtime.

One tick k (t_k = k * tick_ns), see docs/architecture.md and docs/time.md:

1. scenario actions due by t_k (sticks are continuous; plant events and faults fire);
2. ESC models -> throttles -> plant steps to t_k;
3. RC edges due by t_k are written and made readable (ordering across ports);
4. analog values are latched for t_k;
5. the IMU sample k is emitted;
6. lockstep: wait until the flight code has dealt with it (see below);
   realtime: wait for the next absolute wall deadline, commands apply when they arrive;
7. the telemetry link moves packets; the tick is recorded.

Lockstep runs on one of two clocks (``Clock``):

* ``VIRTUAL`` (the default): the flight code's clocks and timeouts run on sim time through
  the clock shim, and the bench is its scheduler (:mod:`hil.vtime`): after writing sample k
  it waits until the flight code is idle, then moves sim time to the next tick or to the
  earliest deadline the flight code waits for, whichever comes first. Boot happens in sim
  time too. Nothing depends on the host's speed or load.
* ``WALL`` (the fallback where the shim cannot be preloaded, said loudly): sample k's ESC
  command is the barrier, awaited for ``barrier_timeout_s`` of wall time (a miss); boot runs
  at negative sim time paced by the wall clock.

Sim time 0 is the first IMU sample after boot.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable

from hil import clock
from hil.analysis.timing import LATE_US
from hil.analysis.timing_stream import LatencySample
# the tick loop's records and protocol (the run and the tests import them from here too)
from hil.flight.tick import (BootError, Clock, EndReason, Mode, SlackWork, TickDevices, TickGate, TickHook,
                             TickStats)
from hil.vtime.scheduler import VirtualClock, resolve_pending
from hil.vtime.stall import ShimLost

#: realtime: a tick that starts this late counts as late (one constant with hil timing)
LATE_NS = round(LATE_US * 1000)
#: realtime: after emitting a sample, the tick's bookkeeping (telemetry link, recording)
#: waits for the flight code's ESC command up to this share of the tick, so the event loop
#: is free to answer the flight code's ADC request at once. 1 ms: a later answer has missed
#: the response budget anyway, and the bookkeeping must end before the pacer's spin before
#: the next tick (0.6 made the tick lateness p99 1.3x worse)
RT_ANSWER_SHARE = 0.4


class TickLoop:
    """Drives a :class:`~hil.flight.devices.DeviceSet` through boot and the tick loop."""

    def __init__(
        self,
        devices: TickDevices,
        *,
        mode: Mode,
        tick_ns: int,
        duration_ns: int,
        barrier_timeout_s: float,
        boot_timeout_s: float,
        before_tick: TickHook | None = None,
        after_tick: TickHook | None = None,
        flight_exited: asyncio.Event | None = None,
        flight_running: Callable[[], bool] | None = None,
        vclock: VirtualClock | None = None,
        attach_timeout_s: float = 10.0,
        on_fallback: Callable[[str], None] | None = None,
    ) -> None:
        self.devices = devices
        self.mode = mode
        self.tick_ns = tick_ns
        self.duration_ns = duration_ns
        self.barrier_timeout_s = barrier_timeout_s
        self.boot_timeout_s = boot_timeout_s
        self.before_tick = before_tick
        self.after_tick = after_tick
        self.flight_exited = flight_exited or asyncio.Event()
        #: False while no flight code process exists (a restart fault's downtime): no one
        #: can answer, so the tick does not wait
        self.flight_running = flight_running or (lambda: True)
        self.vclock = vclock if mode is Mode.LOCKSTEP else None
        self.attach_timeout_s = attach_timeout_s
        self.on_fallback = on_fallback
        self.tick_gate: TickGate | None = None
        self.slack_work: SlackWork | None = None
        self.fallback_reason = ""
        self.stats = TickStats(clock=Clock.REALTIME if mode is Mode.REALTIME else Clock.WALL)
        self.t_ns = -int(boot_timeout_s * 1e9)
        self.k = -1
        self._barrier: asyncio.Future[int] | None = None
        self._rt_emit: tuple[int, int, int] | None = None  #: realtime: (sim ns, host emit ns, lateness ns)
        self._rt_answer: asyncio.Future[None] | None = None  #: realtime: resolved by the sample's command
        self._awaiting: int | None = None  #: VIRTUAL: the sample whose command is due
        self._arrival: tuple[int, int] | None = None  #: VIRTUAL: (host ns, sim ns) of that command
        devices.on_esc_command = self._esc_command

    # -- commands ---------------------------------------------------------------------------------
    def _esc_command(self, t_host_ns: int, t_ns: int) -> None:
        self.stats.esc_commands += 1
        if self._awaiting is not None:
            if self._arrival is None:
                self._arrival = (t_host_ns, t_ns)
            return
        fut = self._barrier
        barrier = fut is not None and not fut.done()
        if not barrier and self._rt_emit is None:
            return
        # The first command after a sample answers that sample (wall-clock lockstep's barrier,
        # realtime), unless the flight code has not begun reading it: then it answers an
        # older one, whose miss is already counted.
        if self.devices.newest_sample_unread():
            self.stats.late_commands += 1
        elif barrier:
            assert fut is not None
            fut.set_result(t_host_ns)
        elif self._rt_emit is not None:
            t_sample, t_emit, late = self._rt_emit
            self._rt_emit = None
            self.stats.latencies_ns.append(t_host_ns - t_emit)
            self.devices.note_latency(LatencySample(t_sample, t_emit, t_host_ns, lateness_ns=late))
            if self._rt_answer is not None:
                resolve_pending(self._rt_answer)

    # -- boot ---------------------------------------------------------------------------------------
    async def boot(self) -> None:
        """Let the flight code configure the devices (sim time runs negative).

        Ends when every required device reports configured; raises :class:`BootError`
        naming the devices that were not, or if the flight code exits first."""
        if self.vclock is not None:
            vc = self.vclock
            if await vc.wait_attached(self.attach_timeout_s, self._alive):
                self.stats.clock = Clock.VIRTUAL
                try:
                    return await self._boot_virtual(vc)
                except ShimLost as lost:
                    # boot is still free to change clocks: go on on the host's, loudly
                    self._fall_back(str(lost))
                    return await self._boot_wall(start_t_ns=self.t_ns)
            if self.flight_exited.is_set():
                raise BootError("the flight code exited during boot; not configured: "
                                + ", ".join(self.devices.unconfigured()))
            self._fall_back(f"the flight code did not load the clock shim within {self.attach_timeout_s:g} s "
                            "(a static or set-user-ID program, or it clears LD_PRELOAD)")
        await self._boot_wall()

    def _fall_back(self, reason: str) -> None:
        self.vclock = None
        self.fallback_reason = reason
        self.stats.clock = Clock.WALL
        if self.on_fallback is not None:
            self.on_fallback(reason)

    def _alive(self) -> bool:
        return not self.flight_exited.is_set()

    def _missing(self) -> str:
        return "; ".join(f"{name}: {why}" for name, why in self.devices.unconfigured().items())

    async def _boot_wall(self, start_t_ns: int | None = None) -> None:
        """Boot paced by the wall clock, from ``start_t_ns`` (default: -boot_timeout_s)."""
        start = clock.monotonic_ns()
        boot_ns = int(self.boot_timeout_s * 1e9)
        t0 = -boot_ns if start_t_ns is None else max(start_t_ns, -boot_ns)
        while True:
            elapsed = clock.monotonic_ns() - start
            self.t_ns = min(-1, t0 + elapsed)
            self.devices.advance_boot(self.t_ns)
            missing = self.devices.unconfigured()
            if not missing:
                return
            if self.flight_exited.is_set():
                raise BootError("the flight code exited during boot; not configured: " + ", ".join(missing))
            if t0 + elapsed >= 0:
                raise BootError(f"not configured within {self.boot_timeout_s:g} s: {self._missing()}")
            await asyncio.sleep(0.001)

    async def _boot_virtual(self, vc: VirtualClock) -> None:
        """Boot on sim time: device timers on the tick grid, the flight code's own deadlines
        exactly. The flight code's start-up (imports, parsing) costs no sim time."""
        boot_ns = int(self.boot_timeout_s * 1e9)
        t = -boot_ns
        vc.start(t)
        while True:
            self.t_ns = t
            vc.set_time(t)
            self.devices.advance_boot(t)
            vc.wake_due()
            await self._settle()
            if self.flight_exited.is_set():
                raise BootError("the flight code exited during boot; not configured: "
                                + ", ".join(self.devices.unconfigured()))
            if not self.devices.unconfigured():
                break
            deadline = vc.next_deadline()
            nxt = t + self.tick_ns if deadline is None else min(t + self.tick_ns, deadline)
            if nxt >= 0:
                raise BootError(f"not configured within {self.boot_timeout_s:g} s of sim time: {self._missing()}")
            t = nxt
        self.stats.boot_sim_ns = t + boot_ns
        vc.cpu_ns()  # start-up and boot are not a sample's compute
        # The first sample comes one tick after the flight code started the IMU; the plant's
        # clock starts there at 0 while the flight code's clock runs on without a jump.
        vc.rebase(t + self.tick_ns, 0)

    # -- ticks ----------------------------------------------------------------------------------------
    async def run(self) -> EndReason:
        """Run ticks until the duration, the flight code's exit, or cancellation."""
        self.stats.wall_start_ns = clock.monotonic_ns()
        cpu_start = time.process_time_ns()
        try:
            if self.vclock is not None:
                return await self._run_virtual(self.vclock)
            return await self._run_wall()
        finally:
            self.stats.wall_end_ns = clock.monotonic_ns()
            self.stats.cpu_ns = time.process_time_ns() - cpu_start

    async def _settle(self) -> None:
        """Until the flight code is idle. When there is none to wait for (a restart's downtime,
        an exit being reaped), yield once so process management can run."""
        assert self.vclock is not None
        if not await self.vclock.idle(self.flight_running):
            await asyncio.sleep(0)

    async def _advance_to(self, vc: VirtualClock, t_ns: int) -> None:
        """Move sim time to ``t_ns``, stopping at every flight-code deadline on the way."""
        while True:
            await self._settle()
            if self.flight_exited.is_set():
                return
            deadline = vc.next_deadline()
            if deadline is None or deadline >= t_ns:
                break
            vc.set_time(deadline)
            self.devices.t_ns = deadline  # bytes written now are stamped with that time
            vc.wake_due()
        vc.set_time(t_ns)

    async def _run_virtual(self, vc: VirtualClock) -> EndReason:
        devices, stats = self.devices, self.stats
        tick_ns = self.tick_ns
        for k in range(self.duration_ns // tick_ns + 1):
            t_ns = k * tick_ns
            if self.tick_gate is not None:
                await self.tick_gate()
            await self._advance_to(vc, t_ns)
            if self.flight_exited.is_set():
                return EndReason.FLIGHT_EXITED
            work_start = self._begin_tick(k, t_ns)
            vc.flush_written()  # everything but the sample is readable before the sample wakes it
            self._expect_command(k)
            emitted, due = devices.emit_imu(t_ns)
            vc.wake_due()  # a deadline at exactly t_k ends after the sample is there
            t_emit = clock.monotonic_ns()
            work = t_emit - work_start
            await self._settle()
            arrival = self._take_command()
            cpu_ns = vc.cpu_ns()
            if emitted:
                stats.samples += 1
            # A sample a fault silenced asks nothing of the flight code: no miss without a
            # command; its watchdog's command, if one comes at this tick, is recorded.
            if (emitted or (due and arrival is not None)) and self.flight_running():
                stats.fc_cpu_ns.append(cpu_ns)
                if arrival is None:
                    stats.barrier_misses += 1
                    devices.note_latency(LatencySample(t_ns, t_emit, None, fc_cpu_ns=cpu_ns))
                else:
                    stats.latencies_ns.append(arrival[1] - t_ns)
                    devices.note_latency(LatencySample(t_ns, t_emit, arrival[0], arrival[1], cpu_ns))
            self._end_tick(k, t_ns, work)
        return EndReason.COMPLETED

    def _begin_tick(self, k: int, t_ns: int) -> int:
        """Steps 1-4 of tick ``k`` at sim ``t_ns``, every clock alike: the scenario's actions, RC
        edges (written early: the kernel delivers them while the plant steps), the plant, the
        analog latch. Returns the host ns the tick's work began."""
        work_start = clock.monotonic_ns()
        self.k, self.t_ns = k, t_ns
        if self.before_tick is not None:
            self.before_tick(k, t_ns)
        devices = self.devices
        devices.emit_rc_early(t_ns)
        devices.actuate_and_step(t_ns)
        devices.latch_analog(t_ns)
        return work_start

    def _end_tick(self, k: int, t_ns: int, work_ns: int) -> None:
        """Step 7 of tick ``k``: the link, the recording; the tick's cost is ``work_ns`` (before
        the wait for the flight code) plus this bookkeeping."""
        after = clock.monotonic_ns()
        self.devices.finish_tick(t_ns)
        if self.after_tick is not None:
            self.after_tick(k, t_ns)
        self.stats.tick_cost_ns.append(work_ns + clock.monotonic_ns() - after)
        self.stats.ticks += 1

    # Methods, not assignments in the loop: compiled (mypyc), a read of ``self._arrival`` right
    # after ``self._arrival = None`` in the same function is checked as None, although
    # ``on_esc_command`` sets it while the loop awaits.
    def _expect_command(self, k: int) -> None:
        """Virtual time: sample ``k``'s ESC command, not yet arrived, is awaited."""
        self._awaiting, self._arrival = k, None

    def _take_command(self) -> tuple[int, int] | None:
        """Virtual time: (host ns, sim ns) of the awaited sample's ESC command, if it came."""
        self._awaiting = None
        return self._arrival

    async def _run_wall(self) -> EndReason:
        loop = asyncio.get_running_loop()
        pacer = clock.RealtimePacer() if self.mode is Mode.REALTIME else None
        devices, stats = self.devices, self.stats
        tick_ns = self.tick_ns
        timeout_s = self.barrier_timeout_s
        if pacer is not None:
            # Tick 0 is due a tick from now, not now: started at once it began 0.5-1.2 ms late
            # (the pacer's thread starting, the hand-over), and in half the runs the flight
            # code, on its first sample since boot, missed that sample's command.
            stats.wall_start_ns = clock.monotonic_ns() + tick_ns
        try:
            for k in range(self.duration_ns // tick_ns + 1):
                if self.flight_exited.is_set():
                    return EndReason.FLIGHT_EXITED
                t_ns = k * tick_ns
                lateness = 0
                if pacer is not None:
                    lateness = await pacer.wait(stats.wall_start_ns + t_ns)
                    stats.lateness_ns.append(lateness)
                    if lateness > LATE_NS:
                        stats.late_ticks += 1
                work_start = self._begin_tick(k, t_ns)
                if pacer is None:
                    # lockstep only: the flight code is blocked on the IMU, so the RC bytes
                    # can be seen arriving; in realtime it reads them whenever they come
                    await devices.confirm_rc()
                self._barrier = loop.create_future() if pacer is None else None
                emitted, due = devices.emit_imu(t_ns)
                t_emit = clock.monotonic_ns()
                work = t_emit - work_start
                if emitted:
                    stats.samples += 1
                if self._barrier is not None and (emitted or due) and self.flight_running():
                    fut = self._barrier
                    handle = loop.call_later(timeout_s, _time_out, fut)
                    try:
                        t_arrival = await fut
                        stats.latencies_ns.append(t_arrival - t_emit)
                        devices.note_latency(LatencySample(t_ns, t_emit, t_arrival))
                    except TimeoutError:
                        stats.barrier_misses += 1
                        devices.note_latency(LatencySample(t_ns, t_emit, None))
                    finally:
                        handle.cancel()
                    self._barrier = None
                elif emitted:
                    if self._rt_emit is not None:  # the previous sample got no command
                        stats.no_command += 1
                        t_prev, emit_prev, late_prev = self._rt_emit
                        devices.note_latency(LatencySample(t_prev, emit_prev, None, lateness_ns=late_prev))
                    self._rt_emit = (t_ns, t_emit, lateness)
                    if pacer is not None:
                        await self._await_answer(loop, stats.wall_start_ns + t_ns + round(tick_ns * RT_ANSWER_SHARE))
                self._end_tick(k, t_ns, work)
                if pacer is not None and self.slack_work is not None:
                    self.slack_work(stats.wall_start_ns + t_ns + tick_ns)
            return EndReason.COMPLETED
        finally:
            if pacer is not None:
                pacer.close()

    async def _await_answer(self, loop: asyncio.AbstractEventLoop, until_ns: int) -> None:
        """Realtime: until the emitted sample's ESC command arrives, or host ``until_ns``."""
        remaining_s = (until_ns - clock.monotonic_ns()) / 1e9
        if remaining_s <= 0 or self._rt_emit is None:
            return
        answer = self._rt_answer = loop.create_future()
        handle = loop.call_later(remaining_s, resolve_pending, answer)
        try:
            await answer
        finally:
            handle.cancel()
            self._rt_answer = None


def _time_out(fut: asyncio.Future[int]) -> None:
    if not fut.done():
        fut.set_exception(TimeoutError())
