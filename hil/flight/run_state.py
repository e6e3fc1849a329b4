"""What one run holds between its steps (hil/flight/run.py acquires, flies and finishes it;
hil/flight/run_finish.py ends it)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hil.analysis.criteria_stream import CriteriaStream
from hil.analysis.trace import Trace
from hil.analysis.trace_stream import TraceStream
from hil.config.rig import Rig
from hil.config.scenario import Scenario
from hil.flight.board_run import BoardRun
from hil.flight.devices import DeviceSet
from hil.flight.process import FlightProcess
from hil.flight.run_setup import VirtualTimeRequired
from hil.flight.runlog import RunLogger
from hil.flight.scenario_runner import ScenarioRunner
from hil.flight.tickloop import Mode, TickLoop
from hil.live.steer import Steering
from hil.record.process import ProcessRecorder
from hil.transport.base import Port
from hil.vtime.session import VirtualTime


@dataclass(eq=False)
class RunState:
    """What one run holds between its steps (mutable: filled as the steps go)."""

    rig: Rig
    scenario: Scenario
    runner: ScenarioRunner
    mode: Mode
    seed: int
    duration_ns: int
    started_ns: int | None
    attached: dict[str, Port] = field(default_factory=dict)
    run_dir: Path | None = None
    ports: dict[str, Port] = field(default_factory=dict)
    devices: DeviceSet | None = None
    recorder: ProcessRecorder | None = None
    stream: TraceStream | None = None
    trace: Trace | None = None
    logger: RunLogger | None = None
    criteria_stream: CriteriaStream | None = None
    telemetry_compute_us: Any = None
    vt: VirtualTime | None = None
    clock_note: str = ""
    flight: FlightProcess | None = None
    loop: TickLoop | None = None
    notes: list[str] = field(default_factory=list)
    #: --require-virtual-time: a fallback to the host clock is an error, not a note
    require_vt: bool = False
    vt_refused: VirtualTimeRequired | None = None
    steering: Steering | None = None  #: --live: the app's pause, step, speed and injects
    board: BoardRun | None = None  #: a board run's loop, figures and criteria (hil/flight/board_run.py)
    #: ``--gdb``: the TCP port of the board's debugger (0: any free one); None: no debugger
    gdb_port: int | None = None

    def note(self, text: str) -> None:
        self.notes.append(text)
        if self.logger is not None and self.devices is not None:
            self.logger.event(max(self.devices.t_ns, 0), "run", "note", {"text": text})

    def host_clock(self, why: str) -> None:
        """Lockstep fell back to the host clock (at open or during boot)."""
        if self.require_vt:
            raise VirtualTimeRequired(f"virtual time is required (--require-virtual-time or the rig's "
                                      f"[flight] require_virtual_time), but lockstep would fly on the host clock: {why}")
        self.note(f"lockstep on the host clock (load changes the flight): {why}")
