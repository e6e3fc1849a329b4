"""pytest plugin ``hil_bench``: closed-loop lockstep runs driven from users' own tests.

    async def test_hover(hil_bench):
        bench = await hil_bench.start(rig="paper-quad", scenario="hover", duration_s=15)
        await bench.until(lambda b: b.truth.h_m > 1.5, timeout_s=8)      # sim seconds
        await bench.always(lambda b: 1.0 < b.truth.h_m < 3.0, for_s=2)
        async with bench.fault("imu.silence"):
            await bench.until(lambda b: max(b.esc_command.pulse_us) <= 1000, timeout_s=0.05)

Each ``start`` is one :func:`hil.flight.run.run_flight_async` (own run dir, ptys, flight-code
process, MCAP) running as a task in the test's event loop. In lockstep the flight code runs
on the bench's clock (virtual time, docs/time.md) and the bench ticks only while the test
awaits one of its waits (``until``, ``always``, ``run_for``, a fault's start or end,
``finish``): the test's own code takes no sim time, however long it runs, so what a test
sees is the same on every run and every machine. Only where lockstep falls back to the host
clock (or in realtime) does the bench tick on regardless; event-loop stalls over
``STALL_WARN_S`` are then reported as :class:`HilBenchStallWarning`.
``until`` / ``always`` / ``run_for`` judge the predicate at every tick (hook after the
tick, no polling) and return the sim time of the deciding tick; a few more ticks may pass
before the test's next statement runs. Teardown stops the run (flight code stopped, MCAP
finalized); a failing test's MCAP is kept and its path printed. See docs/pytest-plugin.md.
"""

from __future__ import annotations

import asyncio
import contextlib
import inspect
import math
import re
import shutil
import tempfile
import warnings
from collections.abc import AsyncIterator, Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from emulators.base import DeviceEvent
    from hil.flight.tickloop import TickLoop
    from hil.flight.devices import DeviceSet
    from hil.faults import FaultHandle, FaultSchedule, ScheduledFault
    from hil.config.rig import Rig
    from hil.flight.run import RunResult
    from hil.config.scenario import Scenario
    from hil.flight.scenario_runner import ScenarioRunner
    from hil.analysis.timing import TimingReport
    from hil.analysis.trace import Trace
    from hil.transport.base import WireRecord

S = 1_000_000_000
RAD2DEG = 180.0 / math.pi
#: sim duration of an inline scenario that does not give one (the test usually stops first)
INLINE_DURATION_S = 60.0
#: host-clock runs: event-loop stalls longer than this are reported (the IMU watchdog is 0.1 s)
STALL_WARN_S = 0.05
_STALL_PERIOD_S = 0.02

Predicate = Callable[["Bench"], object]


class RunEnded(AssertionError):
    """The run ended (duration over, flight code exited, boot failed) before the awaited tick."""


class SimTimeout(AssertionError):
    """``until``: the predicate did not hold within ``timeout_s`` of sim time."""


class PredicateFailed(AssertionError):
    """``always``: the predicate was false at some tick."""


class HilBenchStallWarning(UserWarning):
    """The event loop was held (by the test's own code, usually) while the bench ran."""


@dataclass(frozen=True)
class Truth:
    """Plant truth at the last tick: NED world, FRD body, ZYX Euler angles in degrees."""

    t_s: float
    h_m: float  #: altitude above the field
    climb_mps: float  #: -v_N[2]
    roll_deg: float
    pitch_deg: float
    yaw_deg: float
    p_N_m: tuple[float, float, float]
    v_N_mps: tuple[float, float, float]
    omega_B_degps: tuple[float, float, float]
    rotor_omega_radps: tuple[float, float, float, float]
    on_ground: bool
    battery_V: float
    state: Any = field(repr=False)  #: the full hil.plant.records.PlantState


@dataclass(frozen=True)
class EscCommand:
    """The flight code's last Maestro command: pulse widths of motors 0..3 (us), at ``t_s``."""

    t_s: float
    pulse_us: tuple[float, float, float, float]


@dataclass
class InjectedFault:
    """One ``bench.fault`` activation: sim times of its start and end (None while active)."""

    kind: str
    handle: FaultHandle
    t_start_s: float
    t_end_s: float | None = None


@dataclass
class _Watch:
    kind: str  # "until" | "always" | "time"
    predicate: Predicate | None
    deadline_ns: int
    future: asyncio.Future[float]
    label: str
    t0_ns: int


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


class Bench:
    """One closed-loop run started by :meth:`HilBench.start` (do not build it directly)."""

    def __init__(self, rig: Rig, scenario: Scenario, *, source: Path | None, seed: int | None,
                 duration_s: float | None, mode: str, log_path: Path, faults: Sequence[ScheduledFault]) -> None:
        from hil.flight.telemetry import TelemetryDecoder

        self.rig, self.scenario, self.source = rig, scenario, source
        self.seed = scenario.scenario.seed if seed is None else seed
        self.duration_s = scenario.scenario.duration_s if duration_s is None else duration_s
        self.mode, self.log_path = mode, log_path
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
        self._watches: list[_Watch] = []
        self._requests: list[tuple[Callable[[int], Any], asyncio.Future[Any]]] = []
        self._before: Callable[[int, int], None] | None = None
        self._after: Callable[[int, int], None] | None = None
        self._last_k = -1
        self._imu: DeviceEvent | None = None
        self._esc: EscCommand | None = None
        self._esc_us = [0.0, 0.0, 0.0, 0.0]
        self._telemetry: dict[str, Any] | None = None
        self._decoder = TelemetryDecoder()
        self._events: dict[str, DeviceEvent] = {}
        self._stall_handle: asyncio.TimerHandle | None = None
        self._stall_due_ns = 0

    # -- start ------------------------------------------------------------------------------------
    async def _start(self) -> None:
        from hil.flight.tickloop import Mode
        from hil.flight.run import run_flight_async

        loop = asyncio.get_running_loop()
        self._test_task = asyncio.current_task()
        self._task = loop.create_task(run_flight_async(
            self.rig, self.scenario, mode=Mode(self.mode), seed=self.seed, duration_s=self.duration_s,
            out_dir=self.log_path.parent, log_path=self.log_path, on_ready=self._on_ready,
            scenario_source=self.source, keep_trace=True), name=f"hil-bench {self.log_path.stem}")
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
        existing = getattr(runner, "schedule", None)
        try:
            if isinstance(existing, FaultSchedule):
                self.schedule = existing
            else:
                self.schedule = FaultSchedule(self._faults, devices, log_event=runner.log_event, flight=runner.flight)
                self._own_schedule = True
        except Exception as exc:  # noqa: BLE001 - must not escape into run_flight_async's set-up
            self._setup_error = exc
            self.schedule = FaultSchedule([], devices, log_event=runner.log_event, flight=runner.flight)
            self._own_schedule = True

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
        keep: list[_Watch] = []
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

    def _on_event(self, port: str, ev: DeviceEvent) -> None:
        name = type(ev).__name__
        self._events[name] = ev
        if name == "SampleSent":
            self._imu = ev
        elif name == "TargetsSet":
            first = ev.first_channel  # type: ignore[attr-defined]
            for i, q in enumerate(ev.targets_qus):  # type: ignore[attr-defined]
                if 0 <= first + i < 4:
                    self._esc_us[first + i] = q / 4.0  # quarter-microseconds
            self._esc = EscCommand(ev.t_ns / S, (self._esc_us[0], self._esc_us[1], self._esc_us[2], self._esc_us[3]))

    def _on_telemetry_wire(self, rec: WireRecord) -> None:
        if rec.direction.value == "rx":  # written by the flight code to its XBee
            for frame in self._decoder.feed(rec.data):
                self._telemetry = frame | {"rx_t_s": rec.t_ns / S}

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
    async def _watch(self, kind: str, predicate: Predicate | None, span_ns: int, label: str) -> float:
        fut: asyncio.Future[float] = asyncio.get_running_loop().create_future()
        t0 = self.loop.t_ns if self.loop is not None else 0
        self._watches.append(_Watch(kind, predicate, max(t0, 0) + span_ns, fut, label, t0))
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

    async def until(self, predicate: Predicate, timeout_s: float) -> float:
        """Wait for the first tick (from the next one) at which ``predicate(bench)`` is true;
        return its sim time (s). ``timeout_s`` is sim time: :class:`SimTimeout` after it,
        :class:`RunEnded` if the run ends first."""
        return await self._watch("until", predicate, round(timeout_s * S), _label_of(predicate))

    async def always(self, predicate: Predicate, for_s: float) -> float:
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

    @contextlib.asynccontextmanager
    async def fault(self, kind: str, duration_s: float | None = None, **params: Any) -> AsyncIterator[InjectedFault]:
        """Apply catalogue fault ``kind`` (``hil faults``) at the next tick for the body of the
        block; it ends at the first tick after the block (or after ``duration_s`` of sim time,
        if that comes first). Invalid kinds or parameters raise ``hil.config.ConfigError``."""
        from hil.faults import CATALOGUE, Timing

        schedule = self.schedule

        def start(t_ns: int) -> InjectedFault:
            assert schedule is not None
            handle = schedule.start_now(kind, t_ns, duration_s=duration_s, **params)
            instant = CATALOGUE[kind].timing is Timing.INSTANT  # acted once, already over
            return InjectedFault(kind, handle, t_ns / S, t_ns / S if instant else None)

        injected: InjectedFault = await self._at_next_tick(start, f"the start of fault {kind}")
        try:
            yield injected
        finally:
            def stop(t_ns: int) -> None:
                assert schedule is not None
                if any(a.handle == injected.handle for a in schedule.active()):
                    schedule.stop(injected.handle, t_ns)
                    injected.t_end_s = t_ns / S

            if self.running:
                with contextlib.suppress(RunEnded):
                    await self._at_next_tick(stop, f"the end of fault {kind}")
            if injected.t_end_s is None and duration_s is not None:
                injected.t_end_s = injected.t_start_s + duration_s

    # -- live values ---------------------------------------------------------------------------------
    @property
    def t_s(self) -> float:
        """Sim time of the current tick, s (negative during boot)."""
        return (self.loop.t_ns if self.loop is not None else 0) / S

    @property
    def truth(self) -> Truth:
        """Plant truth now (see :class:`Truth`)."""
        assert self.devices is not None, "the bench has not started"
        st = self.devices.plant.state
        r, p, y = st.euler_rpy_rad
        w = st.omega_B_radps
        return Truth(self.t_s, st.h_m, -st.v_N_mps[2], r * RAD2DEG, p * RAD2DEG, y * RAD2DEG, st.p_N_m,
                     st.v_N_mps, (w[0] * RAD2DEG, w[1] * RAD2DEG, w[2] * RAD2DEG),
                     st.rotor_omega_radps, bool(st.on_ground), st.battery_V, st)

    @property
    def imu_sample(self) -> DeviceEvent | None:
        """The last XSENS sample sent (emulators.xsens.events.SampleSent: euler_deg, rate_radps,
        acc_mps2 as on the wire), or None before the first."""
        return self._imu

    @property
    def esc_command(self) -> EscCommand | None:
        """The flight code's last ESC command (see :class:`EscCommand`), or None before the first."""
        return self._esc

    @property
    def esc_throttle(self) -> tuple[float, ...]:
        """The four ESC models' throttle outputs, 0..1."""
        assert self.devices is not None, "the bench has not started"
        return tuple(self.devices.throttle)

    @property
    def esc_armed(self) -> tuple[bool, ...]:
        assert self.devices is not None, "the bench has not started"
        return tuple(e.armed for e in self.devices.escs)

    @property
    def telemetry(self) -> dict[str, Any] | None:
        """The last telemetry frame the flight code sent, decoded (hil.flight.telemetry keys, plus
        ``rx_t_s``: sim time it reached the bench), or None before the first."""
        return self._telemetry

    @property
    def flight_mode(self) -> str | None:
        """The flight code's mode from its last telemetry frame ("DISARMED", "FLYING", ...)."""
        return None if self._telemetry is None else str(self._telemetry["mode_name"])

    @property
    def counters(self) -> dict[str, dict[str, int]]:
        """Device counters by port, and ``port.<name>`` byte/open/overflow counters."""
        assert self.devices is not None, "the bench has not started"
        out = {name: {k: int(v) for k, v in d.counters.items()} for name, d in self.devices.by_port.items()}
        for name, port in self.devices.ports.items():
            # fields, not vars(): the ports' records are compiled (no __dict__)
            out[f"port.{name}"] = {f.name: v for f in fields(port.stats)
                                   if isinstance(v := getattr(port.stats, f.name), int)}
        return out

    def last_event(self, name: str) -> DeviceEvent | None:
        """The last device event of this type name ("EscDisarmed", "SampleSent", ...)."""
        return self._events.get(name)

    @property
    def flight(self) -> Any:
        """The flight code's hil.flight.process.FlightProcess (pid, last_stderr, returncode)."""
        return None if self.runner is None else self.runner.flight

    def log_event(self, name: str, detail: Mapping[str, Any] | None = None) -> None:
        """Record an event (kind "pytest") on the run's /hil/events topic."""
        if self.runner is not None and self.running:
            self.runner.log_event(max(self.loop.t_ns if self.loop else 0, 0), "pytest", name, dict(detail or {}))

    # -- the end -------------------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self._task is not None and not self._task.done()

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

    @property
    def result(self) -> RunResult:
        """The run's hil.flight.run.RunResult (after :meth:`stop` / :meth:`finish`)."""
        task = self._require_task()
        if not task.done():
            raise RuntimeError("the run is still going: await bench.stop() or bench.finish() first")
        if task.cancelled():
            raise RuntimeError("the run's task was cancelled from outside the plugin: no result")
        return task.result()

    def record(self, topic: str) -> dict[str, Any]:
        """A recorded topic as columns (hil.record.read_topic: ``log_time_ns`` + one numpy
        array per field), after the run."""
        from hil.record import read_topic

        return read_topic(self._log(), topic)

    def timing(self, budget_us: float = 2500.0) -> TimingReport:
        """The loop timing report of the run (hil.analysis.timing.analyze_log), after the run."""
        from hil.analysis.timing import analyze_log

        return analyze_log(self._log(), budget_us)

    def signal(self, name: str) -> tuple[Any, Any]:
        """``(t_s, values)`` of a trace signal ("truth.h_m", "esc.cmd_us[2]", "tm.alt_est_m"), after the run."""
        trace: Trace | None = self.result.trace
        assert trace is not None
        return trace.signal(name)

    def _log(self) -> Path:
        path = self.result.log_path
        if path is None:
            raise RuntimeError("this run has no MCAP log")
        return path

    def _require_task(self) -> asyncio.Task[RunResult]:
        if self._task is None:
            raise RuntimeError("the bench has not been started")
        return self._task

    def _state_text(self) -> str:
        tr = self.truth
        esc = self._esc.pulse_us if self._esc else None
        return (f"now h = {tr.h_m:.3f} m, roll {tr.roll_deg:.2f} deg, pitch {tr.pitch_deg:.2f} deg, "
                f"on_ground {tr.on_ground}, mode {self.flight_mode}, esc {esc}")

    def describe(self) -> str:
        """One paragraph for failure reports."""
        where = f"t = {self.t_s:.4f} s sim"
        if self._task is not None and self._task.done() and not self._task.cancelled() and not self._task.exception():
            r = self._task.result()
            where += f", ended: {r.end_reason.value} {r.message}"
        elif self.devices is not None:
            where += f", running; {self._state_text()}"
        lines = [f"rig {self.rig.name}, scenario {self.scenario.name}, seed {self.seed}: {where}"]
        lines += [f"event-loop stall of {s * 1e3:.0f} ms at t = {t:.3f} s" for t, s in self.stalls[:5]]
        if self.flight is not None and self.flight.last_stderr:
            lines += ["flight code stderr (last lines):", *("  " + s for s in list(self.flight.last_stderr)[-8:])]
        return "\n".join(lines)


def build_scenario(rig: Rig, scenario: str | Path | Mapping[str, Any] | Scenario | None, *,
                   sticks: Sequence[Mapping[str, Any]] | None = None, flight: Mapping[str, Any] | None = None,
                   duration_s: float | None = None, name: str = "pytest") -> tuple[Scenario, Path | None]:
    """The run's scenario and its file: a name or path (rigs/scenarios/), a dict shaped like a
    scenario TOML (``[scenario]`` header optional), a Scenario, or None (empty). ``sticks``
    replace the scenario's [[sticks]]; ``flight`` is deep-merged into its [flight] overrides."""
    from hil.config import ConfigError, validate
    from hil.flight.run import deep_merge
    from hil.config.scenario import Scenario, load_scenario

    source: Path | None = None
    if isinstance(scenario, Scenario):
        scen = scenario
    elif isinstance(scenario, (str, Path)):
        source = rig.scenario_path(scenario)
        scen = load_scenario(source)
    else:
        data = dict(scenario or {})
        header = {"name": name, "duration_s": duration_s or INLINE_DURATION_S} | dict(data.get("scenario", {}))
        scen = validate(Scenario, data | {"scenario": header}, file=f"<inline scenario of {name}>", section="")
    if sticks is not None or flight is not None:
        update: dict[str, Any] = {}
        if sticks is not None:
            update["sticks"] = list(sticks)
        if flight is not None:
            update["flight"] = deep_merge(scen.flight, dict(flight))
        data = scen.model_dump(exclude_none=True) | update
        scen = validate(Scenario, data, file=f"<scenario {scen.name} of {name}>", section="")
    times = [s.t_s for s in scen.sticks]
    if times != sorted(times):
        raise ConfigError(f"<scenario {scen.name} of {name}>: [[sticks]] times must not decrease ({times})")
    return scen, source


def _safe(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.=-]+", "_", text.replace("::", "--").replace("/", "-")).strip("_-")[:150]


class HilBench:
    """The ``hil_bench`` fixture: starts benches for one test, stops them at teardown."""

    def __init__(self, nodeid: str, name: str, *, keep_dir: Path, keep_all: bool = False) -> None:
        self.nodeid, self.name = nodeid, name
        self.keep_dir, self.keep_all = keep_dir, keep_all
        self.benches: list[Bench] = []
        self.kept: list[Path] = []
        self._tmp: Path | None = None

    async def start(self, rig: str | Path | Rig | None = None,
                    scenario: str | Path | Mapping[str, Any] | Scenario | None = None, *,
                    sticks: Sequence[Mapping[str, Any]] | None = None, flight: Mapping[str, Any] | None = None,
                    seed: int | None = None, duration_s: float | None = None, mode: str = "lockstep") -> Bench:
        """Start a run and return once its first tick (sim time 0) is done.

        ``rig``: name under rigs/ or path (None: the default rig); ``scenario``: see
        :func:`build_scenario` (None with ``sticks``: an inline scenario of
        ``duration_s`` or INLINE_DURATION_S); ``seed``: None = the scenario's; ``duration_s``:
        the run's sim length (None = the scenario's); ``mode``: "lockstep" or "realtime".
        """
        from hil.faults import load_faults
        from hil.config.rig import Rig, load_rig

        rig_obj = rig if isinstance(rig, Rig) else load_rig(rig)
        scen, source = build_scenario(rig_obj, scenario, sticks=sticks, flight=flight, duration_s=duration_s,
                                      name=_safe(self.name))
        # as `hil run --duration` does: a shorter run keeps the scenario's later faults (unplayed)
        faults = load_faults(scen.faults, rig_obj, source=str(source or f"<scenario {scen.name}>"),
                             run_duration_s=scen.scenario.duration_s)
        if self._tmp is None:
            self._tmp = Path(tempfile.mkdtemp(prefix="hil-pytest-"))
        bench = Bench(rig_obj, scen, source=source, seed=seed, duration_s=duration_s, mode=mode,
                      log_path=self._tmp / f"{self._stem(len(self.benches))}.mcap", faults=faults)
        self.benches.append(bench)
        bench.log_path.parent.mkdir(parents=True, exist_ok=True)
        await bench._start()
        bench.log_event("test", {"nodeid": self.nodeid})
        return bench

    def _stem(self, i: int) -> str:
        return _safe(self.nodeid) + (f"-{i + 1}" if i else "")

    def keep_path(self, bench: Bench) -> Path:
        """Where the bench's MCAP goes if the test fails (or with --hil-keep-all)."""
        return self.keep_dir / f"{self._stem(self.benches.index(bench))}.mcap"

    def describe(self) -> str:
        lines: list[str] = []
        for b in self.benches:
            lines += [f"MCAP: {self.keep_path(b)}  (kept; finalized at teardown; `hil report` plots it)", b.describe()]
        return "\n".join(lines)

    async def aclose(self, failure: str | None) -> None:
        """Stop every bench (flight code stopped, MCAP finalized); keep the logs of a failed
        test (``failure`` = its report text) or all logs with keep_all; remove the rest."""
        errors: list[BaseException] = []
        for b in self.benches:
            try:
                if failure is not None:
                    b.log_event("test failed", {"nodeid": self.nodeid, "report": failure[-4000:]})
                b.torn_down = True
                b._gate_open.set()
                try:
                    log: Path | None = (await b.stop()).log_path
                except BaseException as exc:  # noqa: BLE001 - the run ended by an interrupt: its log is final
                    if exc is not b.interrupted:
                        raise
                    log = b.log_path
                if b.stalls:
                    worst = max(s for _, s in b.stalls)
                    warnings.warn(HilBenchStallWarning(
                        f"{self.nodeid}: the event loop did not run for up to {worst * 1e3:.0f} ms "
                        f"({len(b.stalls)} time(s)) while the bench ran, so the flight code's wall-clock IMU watchdog "
                        "may have fired: slow test code between awaits (do heavy work after bench.stop()), or an "
                        "overloaded machine"), stacklevel=1)
                if log is not None and log.exists() and (failure is not None or self.keep_all):
                    dest = self.keep_path(b)
                    dest.parent.mkdir(parents=True, exist_ok=True)
                    shutil.move(log, dest)
                    self.kept.append(dest)
            except BaseException as exc:  # noqa: BLE001 - stop the other benches first, then raise
                errors.append(exc)
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
        if errors:
            raise errors[0]


# -- pytest hooks and the fixture ----------------------------------------------------------------------
_FACTORY = pytest.StashKey[HilBench]()
_REPORTS = pytest.StashKey[dict[str, pytest.TestReport]]()
_KEPT = pytest.StashKey[list[tuple[str, Path]]]()


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("hil-bench", "HIL bench (hil.pytest_plugin)")
    group.addoption("--hil-keep-logs", metavar="DIR", default=None,
                    help="keep the MCAP logs of failing hil_bench tests in DIR (default: <basetemp>/hil-logs)")
    group.addoption("--hil-keep-all", action="store_true", default=False,
                    help="keep the MCAP logs of passing hil_bench tests too")
    parser.addini("hil_keep_logs", "default for --hil-keep-logs", default="")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "hil_bench: the test starts a HIL bench (added to users of the hil_bench fixture)")
    config.stash[_KEPT] = []


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if "hil_bench" in getattr(item, "fixturenames", ()):
            item.add_marker("hil_bench")


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Any:
    report: pytest.TestReport = yield
    item.stash.setdefault(_REPORTS, {})[report.when] = report
    factory = item.stash.get(_FACTORY, None)
    if factory is not None and factory.benches and report.failed:
        report.sections.append(("hil-bench", factory.describe()))
    return report


def pytest_terminal_summary(terminalreporter: Any, config: pytest.Config) -> None:
    kept = config.stash.get(_KEPT, [])
    if kept:
        terminalreporter.write_sep("-", "hil-bench: MCAP logs kept")
        for nodeid, path in kept:
            terminalreporter.write_line(f"{nodeid}: {path}")


def keep_dir_of(config: pytest.Config, basetemp: Path) -> Path:
    """--hil-keep-logs, else the ``hil_keep_logs`` ini value, else ``<basetemp>/hil-logs``."""
    value = config.getoption("hil_keep_logs") or config.getini("hil_keep_logs")
    return Path(config.invocation_params.dir, value) if value else basetemp / "hil-logs"


async def _hil_bench(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> AsyncIterator[HilBench]:
    item = request.node
    keep = keep_dir_of(request.config, tmp_path_factory.getbasetemp())
    factory = HilBench(item.nodeid, item.name, keep_dir=keep, keep_all=bool(request.config.getoption("hil_keep_all")))
    item.stash[_FACTORY] = factory
    yield factory
    failed = [r for r in item.stash.get(_REPORTS, {}).values() if r.failed]
    await factory.aclose(failed[0].longreprtext if failed else None)
    request.config.stash[_KEPT].extend((item.nodeid, p) for p in factory.kept)


try:
    import pytest_asyncio
except ImportError:  # pragma: no cover - the test extra brings it
    @pytest.fixture
    def hil_bench() -> None:
        pytest.fail("the hil_bench fixture needs pytest-asyncio (pip install 'mav-hil-bench[test]')")
else:
    hil_bench = pytest_asyncio.fixture(_hil_bench, name="hil_bench")  # type: ignore[assignment]
