"""Process faults: the flight code is killed, or killed and started again mid-flight.

Both need the run's :class:`~hil.flight.process.FlightProcess`; a schedule without one refuses
them when it is built. The kill is a signal (immediate); the restart runs as a task of the
schedule (``FlightProcess.restart``) so the tick never waits for the process: the old
process is reaped in the background, and the new one is started when the fault ends
(sim time), with the same command line.

* ``process.kill``: SIGKILL at t_s. The bench notices the exit like any other (the run ends
  with "flight code exited").
* ``process.restart``: SIGKILL at t_s, the same command started again at t_s + duration_s;
  the bench's ``exited`` event is not set in between (a restart is not the end of the run).
  The new process finds its devices streaming and must configure them again.
"""

from __future__ import annotations

import asyncio
from typing import Any

from hil.faults.base import Fault, Layer, NoParams, Refused, Timing


def _refuse_board(rig: Any) -> None:
    if rig.flight.board:
        raise Refused("kind", f"this rig flies the firmware on an emulated board ({rig.flight.board}): there is no "
                              "flight-code process to kill or restart")


class ProcessKill(Fault[NoParams]):
    """The flight code dies (SIGKILL) at t_s and does not come back."""

    kind = "process.kill"
    layer = Layer.PROCESS
    timing = Timing.INSTANT
    Params = NoParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        _refuse_board(rig)

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "flight code"

    def apply(self, t_ns: int) -> dict[str, Any]:
        flight = self.env.flight
        assert flight is not None  # the schedule refuses process faults without one
        pid = flight.pid
        running = flight.running
        flight.kill()
        return {"pid": pid, "was_running": running}


class ProcessRestart(Fault[NoParams]):
    """The flight code is killed at t_s and started again after duration_s (its downtime)."""

    kind = "process.restart"
    layer = Layer.PROCESS
    timing = Timing.BOUNDED
    Params = NoParams

    @classmethod
    def check(cls, params: Any, rig: Any) -> None:
        _refuse_board(rig)

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "flight code"

    def apply(self, t_ns: int) -> dict[str, Any]:
        flight = self.env.flight
        assert flight is not None
        self.resume = asyncio.Event()
        pid = flight.pid
        self.env.spawn(self._restart(), self.kind)
        return {"pid": pid, "was_running": flight.running}

    async def _restart(self) -> None:
        flight = self.env.flight
        assert flight is not None
        await flight.restart(resume=self.resume)
        self.env.note(self.t_restart_ns, f"{self.kind} started", {"pid": flight.pid})

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.t_restart_ns = t_ns
        assert self.env.flight is not None
        self.env.flight.begin_start()
        self.resume.set()
        return {"restart_at_s": t_ns / 1e9}


FAULTS: tuple[type[Fault[Any]], ...] = (ProcessKill, ProcessRestart)
