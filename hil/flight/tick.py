"""What the tick loop drives and what it reports: its modes and clocks, why a run ended, the
timing it keeps, the protocol of the devices it drives (``TickDevices``, implemented by
:class:`hil.flight.devices.DeviceSet`; tests drive fakes) and the hooks it calls.

Host ns are the bench's monotonic clock (:mod:`hil.clock`); sim ns are sim time (0 = the first
IMU sample).
"""

from __future__ import annotations

import enum
from array import array
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Protocol

from hil.analysis.timing_stream import LatencySample, LatencyStats, StreamingStats


class Mode(enum.Enum):
    LOCKSTEP = "lockstep"
    REALTIME = "realtime"


class Clock(enum.Enum):
    """The clock the flight code lived on during a run."""

    VIRTUAL = "virtual"  #: lockstep, flight code on sim time (clock shim)
    WALL = "wall"  #: lockstep fallback, flight code on the host clock
    REALTIME = "realtime"  #: realtime mode: everything on the host clock
    BOARD = "board"  #: lockstep, the firmware on the emulated LPC2148: its time is the board's cycles


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
    barrier_misses: int = 0  #: lockstep: no ESC command for an emitted sample (before the next tick)
    late_ticks: int = 0  #: realtime: tick started more than 1 ms late
    no_command: int = 0  #: realtime: samples that got no ESC command before the next sample
    #: realtime and wall-clock lockstep: ESC commands that came while the newest sample was
    #: still unread by the flight code, so answered an older one (already counted in
    #: ``no_command`` or ``barrier_misses``): credited to none
    late_commands: int = 0
    # streamed (hil.analysis.timing.StreamingStats: percentiles in bounded memory, not every sample)
    latencies_ns: StreamingStats = field(default_factory=StreamingStats)  #: IMU emit -> ESC command (wall; sim in VIRTUAL)
    lateness_ns: StreamingStats = field(default_factory=StreamingStats)  #: realtime pacer lateness
    tick_cost_ns: StreamingStats = field(default_factory=StreamingStats)  #: bench work per tick (excl. waits)
    #: VIRTUAL: flight-code CPU per sample, host ns. Kept whole (8 bytes a sample, 1.9 MB for
    #: 10 minutes) so the summary computes its figures from the same values as `hil timing`.
    fc_cpu_ns: array = field(default_factory=lambda: array("q"))
    wall_start_ns: int = 0
    wall_end_ns: int = 0
    #: the bench process's CPU time over the tick loop (all its threads; not the flight code
    #: or the recorder child): everything the bench spends per tick, ns
    cpu_ns: int = 0
    esc_commands: int = 0
    boot_sim_ns: int = 0  #: VIRTUAL: sim time the flight code took to configure its devices
    clock: Clock = Clock.WALL


class TickDevices(Protocol):
    """What the tick loop drives (``hil.flight.devices.DeviceSet``; tests drive fakes)."""

    t_ns: int
    on_esc_command: Callable[[int, int], None]
    latency_stats: LatencyStats  #: the response figures, read by the run's summary

    def advance_boot(self, t_ns: int) -> None: ...
    def unconfigured(self) -> dict[str, str]: ...
    def emit_rc_early(self, t_ns: int) -> None: ...
    async def confirm_rc(self) -> None: ...
    def actuate_and_step(self, t_ns: int) -> None: ...
    def latch_analog(self, t_ns: int) -> None: ...
    def emit_imu(self, t_ns: int) -> tuple[bool, bool]: ...
    def newest_sample_unread(self) -> bool: ...
    def note_latency(self, sample: LatencySample) -> None: ...
    def finish_tick(self, t_ns: int) -> None: ...


TickHook = Callable[[int, int], None]
#: realtime: called after each tick's bookkeeping with the next tick's deadline (host
#: monotonic ns): work that may wait for the time the tick leaves (hil/flight/run.py: the criteria's
#: per-chunk work); it must return before the deadline
SlackWork = Callable[[int], object]  # its result is not used
#: awaited before every lockstep tick on virtual time (the pytest plugin: tick only while the
#: test awaits the bench, so sim time stands still while test code runs)
TickGate = Callable[[], Awaitable[None]]
