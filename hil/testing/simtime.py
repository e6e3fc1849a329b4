"""Driving a bench's sim time: the tick gate that lets the run tick only while the test awaits
the bench (virtual time), the hooks on the tick path that judge the test's waits and run its
requests at the next tick, the event-loop stall watch (host clock), and the waits
(``until``, ``always``, ``run_for``). Times: ``t_ns`` sim ns; waits return sim s."""

from __future__ import annotations

import asyncio
import inspect
from collections.abc import Callable
from typing import Any, Self

from hil.testing.observe import BenchObserver
from hil.testing.records import STALL_WARN_S, S, PredicateFailed, RunEnded, SimTimeout
from hil.testing.state import Watch

_STALL_PERIOD_S = 0.02  #: the stall watch's period, s


def _label_of(predicate: Callable[..., object]) -> str:
    """A readable name for messages: the function's name, or a lambda's source text."""
    name = getattr(predicate, "__name__", repr(predicate))
    if name != "<lambda>":
        return name
    try:
        text = " ".join(inspect.getsource(predicate).split())
    except (OSError, TypeError):
        return name
    start = text.find("lambda")
    depth, end = 0, len(text)
    for i in range(start, len(text)):  # the lambda ends at a "," or ")" outside its brackets
        c = text[i]
        if c in "([{":
            depth += 1
        elif c in ")]}" and depth == 0 or c == "," and depth == 0:
            end = i
            break
        elif c in ")]}":
            depth -= 1
    return text[start:end].strip()[:120] if start >= 0 else name


class BenchSimTime(BenchObserver):
    """Sim time for the test: ticks pass only while it awaits the bench (on virtual time)."""

    # -- the tick gate ------------------------------------------------------------------------------------
    def _test_waits(self) -> bool:
        """The test awaits this bench (a wait, a fault's start or end, finish), or it is over."""
        test = self._test_task
        return (test is None or test.done() or self.torn_down or self._finishing
                or any(not w.future.done() for w in self._watches) or any(not f.done() for _, f in self._requests))

    async def _gate(self) -> None:
        """On virtual time the bench ticks only while the test awaits it: the test's code between
        two waits takes no sim time, however long it runs, so what it sees is deterministic. On
        the host clock (realtime, the fallback) the flight code would not wait: no gate."""
        from hil.flight.tickloop import Clock

        if self.loop is None or self.loop.stats.clock is not Clock.VIRTUAL:
            return
        while not self._test_waits():
            self._gate_open.clear()
            await self._gate_open.wait()

    # -- hooks on the tick path (never raise: errors go to the waiting test) ----------------------------
    def _before_tick(self, k: int, t_ns: int) -> None:
        if self._before is not None:
            self._before(k, t_ns)
        if self._own_schedule and self.schedule is not None:
            self.schedule.before_tick(t_ns)
        requests, self._requests = self._requests, []
        for action, fut in requests:
            if fut.done():
                continue
            try:
                fut.set_result(action(t_ns))
            except Exception as exc:  # noqa: BLE001 - the test's error, raised in the test
                fut.set_exception(exc)

    def _after_tick(self, k: int, t_ns: int) -> None:
        if self._after is not None:
            self._after(k, t_ns)
        if k == 0:
            self._start_stall_watch()
        if k == self._last_k and self._own_schedule and self.schedule is not None:
            self.schedule.finish(t_ns)
        if self._watches:
            self._judge(t_ns)

    def _judge(self, t_ns: int) -> None:
        keep: list[Watch] = []
        for w in self._watches:
            if w.future.done():
                continue
            try:
                ok = True if w.predicate is None else bool(w.predicate(self))
            except Exception as exc:  # noqa: BLE001 - the predicate's error, raised in the test
                w.future.set_exception(exc)
                continue
            due = t_ns >= w.deadline_ns
            if w.kind == "until" and ok:
                w.future.set_result(t_ns / S)
                self.log_event("until held", {"predicate": w.label, "t_s": t_ns / S})
            elif w.kind == "always" and not ok:
                w.future.set_exception(PredicateFailed(
                    f"always({w.label}) was false at t = {t_ns / S:.4f} s (checked since {w.t0_ns / S:.4f} s); "
                    f"{self._state_text()}"))
            elif due and w.kind == "until":
                w.future.set_exception(SimTimeout(
                    f"until({w.label}) did not hold within {(w.deadline_ns - w.t0_ns) / S:g} s of sim time "
                    f"(t = {w.t0_ns / S:.4f} .. {t_ns / S:.4f} s); {self._state_text()}"))
            elif due:
                w.future.set_result(t_ns / S)
            else:
                keep.append(w)
        self._watches = keep

    # -- the event-loop stall watch (host clock) ----------------------------------------------------
    def _start_stall_watch(self) -> None:
        from hil import clock

        self._stall_due_ns = clock.monotonic_ns() + int(_STALL_PERIOD_S * S)
        self._stall_handle = asyncio.get_running_loop().call_later(_STALL_PERIOD_S, self._stall_tick)

    def _stall_tick(self) -> None:
        from hil import clock

        now = clock.monotonic_ns()
        late_s = (now - self._stall_due_ns) / S
        ticking = self.loop is not None and self.loop.stats.wall_end_ns == 0  # not the end-of-run work
        # on virtual time the flight code's clock stops with the bench: a stall changes nothing
        from hil.flight.tickloop import Clock

        host_clock = self.loop is not None and self.loop.stats.clock is not Clock.VIRTUAL
        if late_s > STALL_WARN_S and ticking and host_clock:
            self.stalls.append((self.t_s, late_s))
        if ticking:
            self._stall_due_ns = now + int(_STALL_PERIOD_S * S)
            self._stall_handle = asyncio.get_running_loop().call_later(_STALL_PERIOD_S, self._stall_tick)

    # -- waiting ------------------------------------------------------------------------------------
    async def _watch(self, kind: str, predicate: Callable[[Self], object] | None, span_ns: int, label: str) -> float:
        fut: asyncio.Future[float] = asyncio.get_running_loop().create_future()
        t0 = self.loop.t_ns if self.loop is not None else 0
        self._watches.append(Watch(kind, predicate, max(t0, 0) + span_ns, fut, label, t0))
        self._gate_open.set()
        return await self._outcome(fut, label)

    async def _outcome(self, fut: asyncio.Future[Any], label: str) -> Any:
        task = self._require_task()
        try:
            await asyncio.wait({fut, task}, return_when=asyncio.FIRST_COMPLETED)
        except asyncio.CancelledError:
            if self.interrupted is not None:
                raise self.interrupted from None  # the test fails with the timeout's own report
            raise
        if fut.done():
            return fut.result()
        fut.cancel()
        if self.torn_down:
            # the test is over (it timed out, or failed while this wait was left suspended):
            # end the orphaned wait quietly rather than raise into a task nobody awaits
            raise asyncio.CancelledError(f"the test's teardown stopped the run before {label}")
        if task.cancelled():
            raise RunEnded(f"the run's task was cancelled before {label}")
        if task.exception() is not None:
            raise task.exception()  # type: ignore[misc]
        r = task.result()
        tail = "\n".join("  " + s for s in r.flight_stderr_tail[-8:])
        raise RunEnded(f"the run ended ({r.end_reason.value}{': ' + r.message if r.message else ''}) "
                       f"at t = {r.sim_s:.4f} s, before {label}; MCAP {r.log_path}\nflight stderr:\n{tail}")

    async def until(self, predicate: Callable[[Self], object], timeout_s: float) -> float:
        """Wait for the first tick (from the next one) at which ``predicate(bench)`` is true;
        return its sim time (s). ``timeout_s`` is sim time: :class:`SimTimeout` after it,
        :class:`RunEnded` if the run ends first."""
        return await self._watch("until", predicate, round(timeout_s * S), _label_of(predicate))

    async def always(self, predicate: Callable[[Self], object], for_s: float) -> float:
        """Check ``predicate(bench)`` at every tick for ``for_s`` of sim time; return the sim
        time (s) at the end, or raise :class:`PredicateFailed` at the first false tick."""
        return await self._watch("always", predicate, round(for_s * S), _label_of(predicate))

    async def run_for(self, seconds: float) -> float:
        """Let ``seconds`` of sim time pass; return the sim time (s) of the tick reached."""
        return await self._watch("time", None, round(seconds * S), f"{seconds:g} s of sim time")

    async def _at_next_tick(self, action: Callable[[int], Any], label: str) -> Any:
        fut: asyncio.Future[Any] = asyncio.get_running_loop().create_future()
        self._requests.append((action, fut))
        self._gate_open.set()
        return await self._outcome(fut, label)
