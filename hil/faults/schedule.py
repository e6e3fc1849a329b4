"""Applies and reverts faults in sim time, tick by tick, and logs every change.

The bench calls :meth:`FaultSchedule.before_tick` at the start of each tick (before the
plant steps). A fault scheduled at ``t_s`` is applied on the first tick at or after it and
reverted on the first later tick at or after ``t_s + duration_s``; hooks that take a time
(gust start, PPM loss window, RC changes) get the exact scheduled times. Tests and the
pytest plugin start and stop faults directly with :meth:`start_now` / :meth:`stop`.

Randomness: each scheduled fault gets a child of the schedule's generator
(``devices.rngs["faults"]``), spawned in file order when the schedule is built, so a
fault's random draws depend only on the seed and its place in the file; each
``start_now`` spawns the next child.

Events (``log_event(t_ns, "fault", name, detail)``): ``"<kind> start"`` and ``"<kind> end"``
with the target, parameters and what changed; background tasks (process restart) add
``"<kind> started"`` or ``"<kind> error"``.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Coroutine, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from hil.config import ConfigError
from hil.faults.base import NS_PER_S, Fault, Layer, ScheduledFault, Timing
from hil.faults.catalogue import CATALOGUE
from hil.faults.env import FaultEnv
from hil.faults.loader import check_fault
from hil.faults.wire import WireParams

if TYPE_CHECKING:
    from hil.flight.devices import DeviceSet
    from hil.flight.process import FlightProcess

EventLogger = Callable[[int, str, str, dict[str, Any]], None]


@dataclass(frozen=True)
class FaultHandle:
    """Identifies one activation (``id`` unique within the schedule)."""

    id: int
    kind: str


@dataclass(frozen=True)
class ActiveFault:
    """A fault acting now: since ``t_start_ns``, until ``end_ns`` (None: until stopped)."""

    handle: FaultHandle
    kind: str
    target: str
    t_start_ns: int
    end_ns: int | None
    params: dict[str, Any]


@dataclass
class _Entry:
    handle: FaultHandle
    spec: ScheduledFault
    fault: Fault
    start_ns: int
    end_ns: int | None
    applied_at_ns: int | None = None


class FaultSchedule:
    """The run's faults: ``faults`` from :func:`~hil.faults.load_faults`, applied to ``devices``.

    ``log_event(t_ns, kind, name, detail)`` records events; ``flight`` is needed by process
    faults (refused here if None); ``rng`` defaults to ``devices.rngs["faults"]``.
    """

    def __init__(
        self,
        faults: Sequence[ScheduledFault],
        devices: DeviceSet,
        *,
        log_event: EventLogger,
        flight: FlightProcess | None = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        self.devices = devices
        self.log_event = log_event
        self.flight = flight
        self._rng = rng if rng is not None else devices.rngs["faults"]
        self._tasks: set[asyncio.Task[None]] = set()
        self._next_id = 0
        self._t_ns = 0
        self.env = FaultEnv(devices, flight=flight, spawn=self._spawn, note=self._note)
        problems = [self._runtime_problem(f) for f in faults]
        if any(problems):
            raise ConfigError("\n".join(p for p in problems if p))
        children = self._rng.spawn(len(faults))
        self._pending: list[_Entry] = [self._entry(f, r, f.t_ns, f.end_ns) for f, r in zip(faults, children, strict=True)]
        self._pending.sort(key=lambda e: e.start_ns)  # stable: file order at equal times
        self._active: list[_Entry] = []

    # -- set-up ----------------------------------------------------------------------------------
    def _runtime_problem(self, f: ScheduledFault) -> str:
        where = f"{f.source}: [[faults]] #{f.index} ({f.kind})" if f.index is not None else f"{f.source}: ({f.kind})"
        cls = CATALOGUE[f.kind]
        if cls.layer is Layer.PROCESS and self.flight is None:
            return f"{where} kind: needs the flight code process, and this bench runs without one"
        if isinstance(f.params, WireParams) and f.params.port not in self.devices.by_port:
            return f"{where} port: no device on port {f.params.port!r} in this bench"
        return ""

    def _entry(self, spec: ScheduledFault, rng: np.random.Generator, start_ns: int, end_ns: int | None) -> _Entry:
        self._next_id += 1
        fault = CATALOGUE[spec.kind](spec.params, self.env, rng)
        return _Entry(FaultHandle(self._next_id, spec.kind), spec, fault, start_ns, end_ns)

    # -- the tick ----------------------------------------------------------------------------------
    def before_tick(self, t_ns: int) -> None:
        """Revert what ended, apply what is due, update time-varying faults (start of a tick)."""
        self._t_ns = t_ns
        for e in [e for e in self._active if e.end_ns is not None and e.end_ns <= t_ns and e.applied_at_ns != t_ns]:
            self._revert(e, t_ns, "ended")
        while self._pending and self._pending[0].start_ns <= t_ns:
            self._apply(self._pending.pop(0), t_ns)
        for e in self._active:
            e.fault.update(t_ns)
        self.env.sweep(t_ns)

    def _apply(self, e: _Entry, t_ns: int) -> None:
        fault = e.fault
        fault.t_start_ns = e.start_ns
        fault.end_ns = e.end_ns
        e.applied_at_ns = t_ns
        changed = fault.apply(t_ns)
        self.log_event(t_ns, "fault", f"{e.spec.kind} start", self._detail(e) | {"changed": changed})
        if type(fault).timing is Timing.INSTANT:
            self.log_event(t_ns, "fault", f"{e.spec.kind} end", {"handle": e.handle.id, "target": e.spec.target,
                                                               "instant": True})
        else:
            self._active.append(e)

    def _revert(self, e: _Entry, t_ns: int, why: str) -> dict[str, Any]:
        self._active.remove(e)
        changed = e.fault.revert(t_ns)
        self.log_event(
            t_ns,
            "fault",
            f"{e.spec.kind} end",
            {"handle": e.handle.id, "target": e.spec.target, "why": why,
             "active_s": (t_ns - e.start_ns) / NS_PER_S, "changed": changed},
        )
        return changed

    def _detail(self, e: _Entry) -> dict[str, Any]:
        return {
            "handle": e.handle.id,
            "kind": e.spec.kind,
            "target": e.spec.target,
            "t_s": e.start_ns / NS_PER_S,
            "duration_s": None if e.end_ns is None else (e.end_ns - e.start_ns) / NS_PER_S,
            "params": e.spec.params.model_dump(mode="json"),
            "index": e.spec.index,
        }

    # -- programmatic ------------------------------------------------------------------------------
    def start_now(self, kind: str, t_ns: int, *, duration_s: float | None = None, **params: Any) -> FaultHandle:
        """Apply fault ``kind`` with ``params`` at ``t_ns`` (validated like a scenario entry;
        raises ConfigError). With ``duration_s`` it ends by itself, else call :meth:`stop`."""
        raw: dict[str, Any] = {"kind": kind, "t_s": t_ns / NS_PER_S, **params}
        if duration_s is not None:
            raw["duration_s"] = duration_s
        spec = check_fault(raw, self.devices.rig, source=f"start_now({kind!r})")
        problem = self._runtime_problem(spec)
        if problem:
            raise ConfigError(problem)
        end_ns = None if duration_s is None else t_ns + round(duration_s * NS_PER_S)
        e = self._entry(spec, self._rng.spawn(1)[0], t_ns, end_ns)
        self._apply(e, t_ns)
        return e.handle

    def stop(self, handle: FaultHandle, t_ns: int) -> dict[str, Any]:
        """End an active fault now (or cancel one not started yet); returns what changed."""
        for e in self._active:
            if e.handle == handle:
                e.end_ns = t_ns if e.end_ns is None else min(e.end_ns, t_ns)
                e.fault.end_ns = e.end_ns
                changed = self._revert(e, t_ns, "stopped")
                self.env.sweep_filters()
                return changed
        for e in self._pending:
            if e.handle == handle:
                self._pending.remove(e)
                self.log_event(t_ns, "fault", f"{e.spec.kind} cancelled", {"handle": handle.id})
                return {}
        return {}

    def active(self) -> list[ActiveFault]:
        """The faults acting now."""
        return [
            ActiveFault(e.handle, e.spec.kind, e.spec.target, e.start_ns, e.end_ns, e.spec.params.model_dump())
            for e in self._active
        ]

    def pending(self) -> list[ScheduledFault]:
        """The faults still to come."""
        return [e.spec for e in self._pending]

    def finish(self, t_ns: int) -> None:
        """End of the run: revert every active fault (logged with why = "end of run")."""
        for e in list(self._active):
            self._revert(e, t_ns, "end of run")
        self.env.sweep_filters()

    # -- background tasks ----------------------------------------------------------------------------
    def _spawn(self, coro: Coroutine[Any, Any, None], name: str) -> None:
        task = asyncio.get_running_loop().create_task(coro, name=f"fault {name}")
        self._tasks.add(task)
        t_ns = self._t_ns
        task.add_done_callback(lambda t: self._task_done(t, name, t_ns))

    def _task_done(self, task: asyncio.Task[None], name: str, t_ns: int) -> None:
        self._tasks.discard(task)
        if not task.cancelled() and task.exception() is not None:
            self.log_event(self._t_ns, "fault", f"{name} error", {"error": repr(task.exception()), "since_t_ns": t_ns})

    def _note(self, t_ns: int, name: str, detail: dict[str, Any]) -> None:
        self.log_event(t_ns, "fault", name, detail)

    @property
    def tasks(self) -> tuple[asyncio.Task[None], ...]:
        """Background work of process faults still running."""
        return tuple(self._tasks)

    async def aclose(self) -> None:
        """Cancel and await background tasks (call before stopping the flight process)."""
        tasks = list(self._tasks)
        for t in tasks:
            t.cancel()
        if tasks:
            await asyncio.gather(*tasks, return_exceptions=True)
