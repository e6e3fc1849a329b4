"""The run loop: boot, then the 400 Hz tick in lockstep or realtime.

One tick k (t_k = k * tick_ns), see docs/architecture.md:

1. scenario actions due by t_k (sticks are continuous; plant events and faults fire);
2. ESC models -> throttles -> plant steps to t_k;
3. RC edges due by t_k are written and confirmed delivered (ordering across ports);
4. analog values are latched for t_k;
5. the IMU sample k is emitted;
6. lockstep: wait for the flight code's ESC command (the barrier; a timeout is a miss);
   realtime: wait for the next absolute wall deadline, commands apply when they arrive;
7. the telemetry link moves packets; the tick is recorded.

Sim time 0 is the first IMU sample. Boot (device configuration by the flight code)
happens before it at negative sim time, paced by the wall clock.
"""

from __future__ import annotations

import asyncio
import enum
from collections.abc import Callable
from dataclasses import dataclass, field

from hil import clock
from hil.devices import DeviceSet


class Mode(enum.Enum):
    LOCKSTEP = "lockstep"
    REALTIME = "realtime"


class EndReason(enum.Enum):
    COMPLETED = "completed"  #: the scenario's duration elapsed
    INTERRUPTED = "interrupted"  #: Ctrl-C / cancelled
    FLIGHT_EXITED = "flight code exited"
    BOOT_FAILED = "boot failed"
    ERROR = "bench error"


class BootError(Exception):
    """The flight code did not configure a device in time (message names the device)."""


@dataclass
class TickStats:
    """Timing of the run, host ns unless noted."""

    ticks: int = 0
    samples: int = 0  #: ticks on which an IMU sample was emitted
    barrier_misses: int = 0  #: lockstep: no ESC command within the timeout
    late_ticks: int = 0  #: realtime: tick started more than 1 ms late
    latencies_ns: list[int] = field(default_factory=list)  #: IMU emit -> ESC command arrival
    lateness_ns: list[int] = field(default_factory=list)  #: realtime pacer lateness
    tick_cost_ns: list[int] = field(default_factory=list)  #: bench work per tick (excl. waits)
    wall_start_ns: int = 0
    wall_end_ns: int = 0
    esc_commands: int = 0


TickHook = Callable[[int, int], None]


class TickLoop:
    """Drives a :class:`DeviceSet` through boot and the tick loop."""

    def __init__(
        self,
        devices: DeviceSet,
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
        #: can answer the barrier then, so the tick does not wait for it
        self.flight_running = flight_running or (lambda: True)
        self.stats = TickStats()
        self.t_ns = -int(boot_timeout_s * 1e9)
        self.k = -1
        self._barrier: asyncio.Future[int] | None = None
        self._rt_emit: tuple[int, int] | None = None
        devices.on_esc_command = self._esc_command

    # -- barrier ------------------------------------------------------------------------------
    def _esc_command(self, t_host_ns: int) -> None:
        self.stats.esc_commands += 1
        fut = self._barrier
        if fut is not None and not fut.done():
            fut.set_result(t_host_ns)
        elif self._rt_emit is not None:
            # realtime: the first command after a sample answers that sample
            t_ns, t_emit = self._rt_emit
            self._rt_emit = None
            self.stats.latencies_ns.append(t_host_ns - t_emit)
            self.devices.note_latency(t_ns, t_emit, t_host_ns)

    # -- boot ------------------------------------------------------------------------------------
    async def boot(self) -> None:
        """Let the flight code configure the devices; sim time runs negative on the wall clock.

        Ends when every required device reports configured; raises :class:`BootError`
        naming the devices that were not, or if the flight code exits first.
        """
        start = clock.monotonic_ns()
        boot_ns = int(self.boot_timeout_s * 1e9)
        while True:
            elapsed = clock.monotonic_ns() - start
            self.t_ns = min(-1, -boot_ns + elapsed)
            self.devices.advance_boot(self.t_ns)
            missing = self.devices.unconfigured()
            if not missing:
                return
            if self.flight_exited.is_set():
                raise BootError("the flight code exited during boot; not configured: " + ", ".join(missing))
            if elapsed > boot_ns:
                details = "; ".join(f"{name}: {why}" for name, why in missing.items())
                raise BootError(f"not configured within {self.boot_timeout_s:g} s: {details}")
            await asyncio.sleep(0.001)

    # -- ticks -----------------------------------------------------------------------------------
    async def run(self) -> EndReason:
        """Run ticks until the duration, the flight code's exit, or cancellation."""
        loop = asyncio.get_running_loop()
        self.stats.wall_start_ns = clock.monotonic_ns()
        pacer = clock.RealtimePacer() if self.mode is Mode.REALTIME else None
        devices = self.devices
        tick_ns = self.tick_ns
        timeout_s = self.barrier_timeout_s
        n_ticks = self.duration_ns // tick_ns + 1
        try:
            for k in range(n_ticks):
                if self.flight_exited.is_set():
                    return EndReason.FLIGHT_EXITED
                t_ns = k * tick_ns
                if pacer is not None:
                    lateness = await pacer.wait(self.stats.wall_start_ns + t_ns)
                    self.stats.lateness_ns.append(lateness)
                    if lateness > 1_000_000:
                        self.stats.late_ticks += 1
                work_start = clock.monotonic_ns()
                self.k, self.t_ns = k, t_ns
                if self.before_tick is not None:
                    self.before_tick(k, t_ns)
                devices.emit_rc_early(t_ns)  # delivered by the kernel while the plant steps
                devices.actuate_and_step(t_ns)
                devices.latch_analog(t_ns)
                if pacer is None:
                    # lockstep only: the flight code is blocked on the IMU, so the RC bytes
                    # can be seen arriving; in realtime it reads them whenever they come
                    await devices.confirm_rc()
                self._barrier = loop.create_future() if pacer is None else None
                emitted, due = devices.emit_imu(t_ns)
                t_emit = clock.monotonic_ns()
                work = t_emit - work_start
                if emitted:
                    self.stats.samples += 1
                if self._barrier is not None and (emitted or due) and self.flight_running():
                    fut = self._barrier
                    handle = loop.call_later(timeout_s, _time_out, fut)
                    try:
                        t_arrival = await fut
                        self.stats.latencies_ns.append(t_arrival - t_emit)
                        devices.note_latency(t_ns, t_emit, t_arrival)
                    except TimeoutError:
                        self.stats.barrier_misses += 1
                        devices.note_latency(t_ns, t_emit, None)
                    finally:
                        handle.cancel()
                    self._barrier = None
                elif emitted:
                    if self._rt_emit is not None:  # the previous sample got no command
                        devices.note_latency(self._rt_emit[0], self._rt_emit[1], None)
                    self._rt_emit = (t_ns, t_emit)
                after = clock.monotonic_ns()
                devices.finish_tick(t_ns)
                if self.after_tick is not None:
                    self.after_tick(k, t_ns)
                self.stats.tick_cost_ns.append(work + clock.monotonic_ns() - after)
                self.stats.ticks += 1
            return EndReason.COMPLETED
        finally:
            self.stats.wall_end_ns = clock.monotonic_ns()
            if pacer is not None:
                pacer.close()


def _time_out(fut: asyncio.Future[int]) -> None:
    if not fut.done():
        fut.set_exception(TimeoutError())
