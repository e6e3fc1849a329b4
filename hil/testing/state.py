"""The state one bench's parts share (the run's task, its tick loop, devices and runner, the
waits, the last values seen) and the few facts every part asks: sim time, whether the run is
going, logging an event."""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hil.testing.records import S, EscCommand, Predicate

if TYPE_CHECKING:
    from hil.live.topics import LiveConfig
    from emulators.base import DeviceEvent
    from emulators.xsens.events import SampleSent
    from hil.config.rig import Rig
    from hil.config.scenario import Scenario
    from hil.faults import FaultSchedule, ScheduledFault
    from hil.flight.devices import DeviceSet
    from hil.flight.run import RunResult
    from hil.flight.scenario_runner import ScenarioRunner
    from hil.flight.tickloop import TickLoop


@dataclass
class Watch:
    """One wait of the test (``until``, ``always``, ``run_for``), judged at each tick; sim ns."""

    kind: str  # "until" | "always" | "time"
    predicate: Predicate | None
    deadline_ns: int
    future: asyncio.Future[float]
    label: str
    t0_ns: int


class BenchState:
    """The state a bench's parts share (set up here, once), and what every part asks of it."""

    def __init__(self, rig: Rig, scenario: Scenario, *, source: Path | None, seed: int | None,
                 duration_s: float | None, mode: str, log_path: Path, faults: Sequence[ScheduledFault]) -> None:
        from hil.flight.telemetry import TelemetryDecoder

        self.rig, self.scenario, self.source = rig, scenario, source
        self.seed = scenario.scenario.seed if seed is None else seed
        self.duration_s = scenario.scenario.duration_s if duration_s is None else duration_s
        self.mode, self.log_path = mode, log_path
        self.live: LiveConfig | None = None  #: serve the run to Foxglove (the plugin's --hil-live)
        self.loop: TickLoop | None = None
        self.devices: DeviceSet | None = None
        self.runner: ScenarioRunner | None = None
        self.schedule: FaultSchedule | None = None
        self.stalls: list[tuple[float, float]] = []  #: (sim t_s, stall s) of event-loop stalls
        self.stopped_by_test = False
        #: set by the fixture's teardown: waits still suspended in the test end quietly
        self.torn_down = False
        #: an interrupt (pytest-timeout's Failed, KeyboardInterrupt) that landed in the bench's
        #: task or a loop callback instead of the test: passed on to the test (_interrupt)
        self.interrupted: BaseException | None = None
        self._test_task: asyncio.Task[Any] | None = None
        self._prev_handler: Any = None
        #: the tick gate (virtual time): opened whenever the test starts a bench wait
        self._gate_open = asyncio.Event()
        self._finishing = False
        self._faults = list(faults)
        self._own_schedule = False
        self._setup_error: Exception | None = None
        self._task: asyncio.Task[RunResult] | None = None
        self._watches: list[Watch] = []
        self._requests: list[tuple[Callable[[int], Any], asyncio.Future[Any]]] = []
        self._before: Callable[[int, int], None] | None = None
        self._after: Callable[[int, int], None] | None = None
        self._last_k = -1
        self._imu: SampleSent | None = None
        self._esc: EscCommand | None = None
        self._esc_us = [0.0, 0.0, 0.0, 0.0]
        self._telemetry: dict[str, Any] | None = None
        self._decoder = TelemetryDecoder()
        self._events: dict[str, DeviceEvent] = {}
        self._stall_handle: asyncio.TimerHandle | None = None
        self._stall_due_ns = 0

    @property
    def t_s(self) -> float:
        """Sim time of the current tick, s (negative during boot)."""
        return (self.loop.t_ns if self.loop is not None else 0) / S

    def log_event(self, name: str, detail: Mapping[str, Any] | None = None) -> None:
        """Record an event (kind "pytest") on the run's /hil/events topic."""
        if self.runner is not None and self.running:
            self.runner.log_event(max(self.loop.t_ns if self.loop else 0, 0), "pytest", name, dict(detail or {}))

    @property
    def running(self) -> bool:
        return self._task is not None and not self._task.done()

    def _require_task(self) -> asyncio.Task[RunResult]:
        if self._task is None:
            raise RuntimeError("the bench has not been started")
        return self._task
