"""Virtual time for one run: decide, set up, hook into the flight process, report, tear down.

``VirtualTime.open`` either returns a session (control block + scheduler) or a
:class:`Fallback` saying why the run goes on the host clock. The run then:

* starts the flight code with ``session.env`` (LD_PRELOAD + the control block's path) and
  ``session.bind(flight)`` (each start/exit of the process tells the scheduler);
* gives ``session.clock`` to the tick loop;
* at its end calls ``free_run()`` before stopping the flight code (its SIGTERM handling and
  last log lines then run at the host's pace), then ``usage()`` and ``close()``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from hil.vtime import abi
from hil.vtime.control import ControlBlock
from hil.vtime.preload import Fallback, check_program, shim_library
from hil.vtime.port_io import ScheduledPort
from hil.vtime.scheduler import VirtualClock
from hil.vtime.stall import Stall
from hil.vtime.tree import what_it_waits_in

if TYPE_CHECKING:
    from hil.flight.process import FlightProcess

#: what an uncovered call means for the flight code, for the warning
UNCOVERED_WHY = {
    "clock_other": "a clock the shim does not model (read from the host)",
    "timerfd": "timerfd timers (fire on the host clock)",
    "timer_create": "POSIX timers (fire on the host clock)",
    "setitimer": "interval timers (fire on the host clock)",
    "alarm": "alarm() (fires on the host clock)",
    "cond_timedwait": "condition-variable timed waits (wait on the host clock)",
    "sem_timedwait": "semaphore timed waits (wait on the host clock)",
    "mutex_timedlock": "mutex timed locks (wait on the host clock)",
    "no_slot": f"more than {abi.MAX_THREADS} threads (the extra ones wait on the host clock)",
}


@dataclass(frozen=True)
class ShimUsage:
    """Which interposed calls the flight code made (counts), and what that means."""

    calls: dict[str, int]
    uncovered: dict[str, int]
    busy_waits: int  #: spin-yields: clock reads in a loop turned into sim-time quanta
    stalls: int  #: waits for idle that took longer than the stall warning (wall time)
    warnings: list[str] = field(default_factory=list)
    #: waits for idle made without / through a turn of the bench's event loop
    idle_waits_inline: int = 0
    idle_waits_loop: int = 0


class VirtualTime:
    """One run's virtual time (see the module docstring)."""

    def __init__(self, ctl: ControlBlock, library: Path, vclock: VirtualClock) -> None:
        self.ctl = ctl
        self.library = library
        self.clock = vclock
        self.env = ctl.env(library)
        vclock.library = str(library)

    @classmethod
    def open(
        cls,
        run_dir: Path,
        ports: Mapping[str, ScheduledPort],
        argv: list[str],
        *,
        on_stall: Callable[[Stall], None] | None = None,
        stall_warn_s: float = 5.0,
    ) -> VirtualTime | Fallback:
        library = shim_library()
        if isinstance(library, Fallback):
            return library
        refused = check_program(argv)
        if refused is not None:
            return refused
        ctl = ControlBlock(run_dir)
        return cls(ctl, library, VirtualClock(ctl, ports, stall_warn_s=stall_warn_s, on_stall=on_stall))

    def bind(self, flight: FlightProcess) -> None:
        """Schedule whatever process ``flight`` runs, across restarts."""
        flight.on_start.append(self._started)
        flight.on_exit.append(self.clock.process_gone)

    def _started(self, pid: int) -> None:
        self.clock.attach(pid)
        self.clock.poke()

    def free_run(self) -> None:
        self.ctl.free_run()

    def usage(self) -> ShimUsage:
        calls = self.ctl.calls()
        uncovered = self.ctl.uncovered()
        warnings = [
            f"the flight code used {UNCOVERED_WHY.get(name, name)}: {n} call(s); see docs/time.md"
            for name, n in sorted(uncovered.items())
        ]
        busy = calls.get("spin_yield", 0)
        if busy:
            warnings.append(f"the flight code busy-waited on its clock {busy} time(s): each was granted "
                            f"{self.ctl.header.spin_quantum_ns / 1e3:g} us of sim time (docs/time.md)")
        return ShimUsage(calls, uncovered, busy, self.clock.stalls, warnings, self.clock.inline_waits,
                         self.clock.loop_waits)

    def close(self) -> None:
        self.clock.close()
        self.ctl.close()


#: what a blocked thread waits in, by its slot's wait kind (``abi.Wait``)
_WAIT_WHAT: dict[int, str] = {abi.Wait.FUTEX: " on another thread", abi.Wait.CHILD: " for a child process",
                              abi.Wait.READ: " reading a descriptor"}


def describe_stall(stall: Stall) -> str:
    """One line a user can act on: which threads the bench waits for, doing what."""
    parts = []
    for t in stall.threads:
        if t.blocked:
            what = "blocked" + _WAIT_WHAT.get(t.wait_kind, "") \
                + (f" until {t.deadline_ns / 1e9:.6f} s" if t.deadline_ns is not None else "")
        else:
            call = what_it_waits_in(t.pid, t.tid)
            what = "running" if call == "running" else f"in {call} (a call the shim does not see)"
        parts.append(f"process {t.pid} thread {t.tid} {what}")
    return (f"the bench has waited {stall.waited_s:g} s (wall) for the flight code to go idle: "
            + "; ".join(parts + list(stall.unseen) or ["no thread attached"]) + ". A debugger stop or SIGSTOP "
            "is fine; a process blocked in a call the clock shim does not interpose ends the run once confirmed: "
            "see docs/time.md.")
