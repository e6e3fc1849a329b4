"""The tick loop of a board run: the firmware on the emulated LPC2148 in lockstep, in cycles.

The same tick as every lockstep run (docs/architecture.md), with the flight code's time in
the board's cycles instead of a process's (docs/board.md, "Flying the firmware"):

1. the firmware runs from t_{k-1} to t_k (150,000 cycles at 60 MHz): it receives sample
   k-1 on UART0 as the XSENS sends it, reads the ADC over SPI, takes the PPM edges on its
   capture pin, computes and sets its ESC outputs, sends telemetry on UART1;
2. scenario actions and faults due by t_k; the ESC models take the pins' pulses up to t_k and
   the plant steps to t_k; the analog front-end latches for t_k;
3. the XSENS emits sample k: its bytes go onto UART0's RXD pin from t_k's cycle on;
4. the telemetry link, slow devices, recording.

A sample's **command** is the firmware's first ``hal_esc_write`` after the sample's first
byte reached the pin and before the next sample's: its latency is sim time (cycles at the
core's clock), its **compute** the busy cycles of the loop iteration that issued it
(hil/flight/board_probes.py). A sample with no command before the next one is a miss
(``barrier_misses``). Nothing here reads the host's clock except the bench's own cost
figures: the flight is the same on any host, loaded or not.

Boot starts the board from reset at ``-boot_timeout_s`` of sim time and runs it tick by tick
until the firmware has configured the required devices; the first sample comes one tick
later, and sim time is rebased there (the board's own clock runs on).
"""

from __future__ import annotations

import asyncio
import time
from collections import deque
from dataclasses import dataclass

from hil import clock
from hil.analysis.timing_stream import LatencySample, StreamingStats
from hil.board.errors import BoardError
from hil.flight.board_devices import BoardDevices
from hil.flight.board_gdb import GdbServer
from hil.flight.board_probes import Answer, Iteration
from hil.flight.tick import BootError, Clock, EndReason, SlackWork, TickGate, TickHook, TickStats

#: ticks between two turns of the event loop (Ctrl-C, a test's stop, the live view)
YIELD_EVERY = 8


@dataclass(frozen=True)
class _Sample:
    k: int
    t_ns: int
    cycle: int  #: the cycle its first byte went onto the pin
    emitted: bool
    due: bool
    t_emit_host_ns: int
    counter: int  #: the XSENS packet counter it carries (-1: not emitted)


class BoardTickLoop:
    """Boot and the ticks of a board run (see the module docstring); the surface the run uses
    is :class:`~hil.flight.tickloop.TickLoop`'s."""

    def __init__(self, devices: BoardDevices, *, tick_ns: int, duration_ns: int, boot_timeout_s: float,
                 before_tick: TickHook | None = None, after_tick: TickHook | None = None) -> None:
        self.devices = devices
        self.wiring = devices.wiring
        self.tick_ns = tick_ns
        self.duration_ns = duration_ns
        self.boot_timeout_s = boot_timeout_s
        self.before_tick = before_tick
        self.after_tick = after_tick
        self.tick_gate: TickGate | None = None
        self.slack_work: SlackWork | None = None
        self.fallback_reason = ""
        self.stats = TickStats(clock=Clock.BOARD)
        self.t_ns = -int(boot_timeout_s * 1e9)
        self.k = -1
        self.fault: BoardError | None = None  #: what stopped the firmware, if it faulted
        #: per-tick CPU load (busy cycles over the tick's cycles, %)
        self.load_pct = StreamingStats()
        self.busy_cycles = 0
        self.run_cycles = 0
        self.irq_latency = StreamingStats()  #: cycles from the VIC's request to the exception entry
        #: the last tick's figures (the run's recording takes them in ``after_tick``)
        self.tick_figures: dict[str, float] = {}
        self._pending: deque[_Sample] = deque()
        self._iterations: deque[Iteration] = deque()
        self._answers: deque[Answer] = deque()
        self._commands: deque[int] = deque()
        self._mark = (0, 0)  #: (cycle, idle cycles) at the last tick's end
        #: ``hil run --gdb``: the tick holds while the debugger holds the core (hil/flight/board_gdb.py)
        self.gdb: GdbServer | None = None

    # -- boot -------------------------------------------------------------------------------------
    async def boot(self) -> None:
        """Run the firmware from reset until it has configured the required devices."""
        devices, wiring = self.devices, self.wiring
        boot_ns = int(self.boot_timeout_s * 1e9)
        t = -boot_ns
        wiring.offset_ns = boot_ns  # the board's reset is at sim time -boot_timeout_s
        n = 0
        while True:
            self.t_ns = devices.t_ns = t
            if not await self._advance_held(t):
                raise BootError(f"{self.exit_text()}; not configured: " + ", ".join(devices.unconfigured()))
            devices.advance_boot(t)
            if not devices.unconfigured():
                break
            t += self.tick_ns
            if t >= 0:
                missing = "; ".join(f"{name}: {why}" for name, why in devices.unconfigured().items())
                raise BootError(f"not configured within {self.boot_timeout_s:g} s of sim time: {missing}")
            n += 1
            if n % YIELD_EVERY == 0:
                await asyncio.sleep(0)
        self.stats.boot_sim_ns = t + boot_ns
        wiring.rebase(t + self.tick_ns, 0)
        wiring.probes.restart()
        self._mark = (wiring.cycles, wiring.core.idle_cycles)

    async def _advance_held(self, t_ns: int) -> bool:
        """:meth:`_advance`, held wherever a debugger halts the core on the way (its
        interrupt is taken at the tick's start)."""
        gdb = self.gdb
        if gdb is None:
            return self._advance(t_ns)
        core = self.wiring.core
        gdb.debugger.take_interrupt()
        while True:
            if core.halted:
                await gdb.hold()  # a kill there makes _advance say the firmware stopped
            running = self._advance(t_ns)
            if not running or not core.halted:
                return running

    def _advance(self, t_ns: int) -> bool:
        """The firmware to ``t_ns``; False if it stopped (ended or faulted)."""
        if self.fault is not None or self.wiring.stopped or (self.gdb is not None and self.gdb.killed):
            return False
        try:
            self.devices.advance_to(t_ns)
        except BoardError as exc:
            self.fault = exc
            return False
        return not self.wiring.stopped

    @property
    def samples_processed(self) -> int:
        """Samples the firmware's loop processed (``loop_tick`` entries) since boot."""
        return self.wiring.probes.samples

    def exit_text(self) -> str:
        """Why the firmware is not running, in words."""
        if self.fault is not None:
            return f"the firmware faulted: {self.fault}"
        if self.gdb is not None and self.gdb.killed:
            return "the debugger ended the firmware (GDB kill)"
        reason = self.wiring.core.semihost.exit_reason
        return f"the firmware stopped (semihosting SYS_EXIT, reason {reason:#x})" if reason is not None else \
            "the firmware runs"

    # -- ticks ------------------------------------------------------------------------------------
    async def run(self) -> EndReason:
        """Run ticks until the duration, the firmware's end, or cancellation."""
        stats = self.stats
        stats.wall_start_ns = clock.monotonic_ns()
        cpu_start = time.process_time_ns()
        try:
            return await self._run()
        finally:
            stats.wall_end_ns = clock.monotonic_ns()
            stats.cpu_ns = time.process_time_ns() - cpu_start

    async def _run(self) -> EndReason:
        devices, stats, tick_ns = self.devices, self.stats, self.tick_ns
        last = self.duration_ns // tick_ns
        for k in range(last + 1):
            t_ns = k * tick_ns
            if self.tick_gate is not None:
                await self.tick_gate()
            elif k % YIELD_EVERY == 0:
                await asyncio.sleep(0)
            running = await self._advance_held(t_ns)
            self._tick_figures(k)
            self._settle(final=not running)
            if not running:
                return EndReason.FLIGHT_EXITED
            work_start = clock.monotonic_ns()
            self.k, self.t_ns = k, t_ns
            if self.before_tick is not None:
                self.before_tick(k, t_ns)
            devices.actuate_and_step(t_ns)
            devices.latch_analog(t_ns)
            emitted, due = devices.emit_imu(t_ns)
            if emitted:
                stats.samples += 1
            if emitted or due:
                self._pending.append(_Sample(k, t_ns, self.wiring.cycles, emitted, due, clock.monotonic_ns(),
                                             devices.sample_counter if emitted else -1))
            if k == last and await self._advance_held(t_ns + tick_ns):
                # the last sample's answer: the firmware runs one tick on (the plant does not),
                # settled before this tick's recording so that the log has every sample
                self._settle(final=True)
            after = clock.monotonic_ns()
            devices.finish_tick(t_ns)
            if self.after_tick is not None:
                self.after_tick(k, t_ns)
            stats.tick_cost_ns.append(after - work_start + clock.monotonic_ns() - after)
            stats.ticks += 1
        return EndReason.COMPLETED

    def _tick_figures(self, k: int) -> None:
        """The tick that just ran: its busy cycles over its cycles (the CPU load), its
        interrupts' latencies."""
        core = self.wiring.core
        cycle, idle = self.wiring.cycles, core.idle_cycles
        c0, i0 = self._mark
        self._mark = (cycle, idle)
        interrupts = self.wiring.probes.interrupts
        worst = 0
        for _, requested, entry in interrupts:
            latency = entry - requested
            self.irq_latency.append(latency)
            worst = max(worst, latency)
        figures = {"irqs": float(len(interrupts)), "irq_latency_max_cycles": float(worst)}
        interrupts.clear()
        if k > 0 and cycle > c0:
            busy = (cycle - c0) - (idle - i0)
            self.busy_cycles += busy
            self.run_cycles += cycle - c0
            load = 100.0 * busy / (cycle - c0)
            self.load_pct.append(load)
            figures |= {"cycles": float(cycle - c0), "busy_cycles": float(busy), "load_pct": load}
        self.tick_figures = figures

    def _settle(self, *, final: bool) -> None:
        """Match the samples sent to the loop's answers, in order: sample k is answered by the
        iteration whose ``loop_tick`` processed the sample with k's packet counter, its command
        the first ``hal_esc_write`` of that iteration. A sample not answered before a later one
        was, or by the run's end, was dropped; an answer after the next sample's first byte is a
        miss. An answer whose iteration is still running waits for the next settle."""
        probes = self.wiring.probes
        self._iterations.extend(probes.iterations)
        self._answers.extend(probes.answers)
        self._commands.extend(probes.commands)
        self.stats.esc_commands += len(probes.commands)
        probes.iterations.clear()
        probes.answers.clear()
        probes.commands.clear()
        pending, answers = self._pending, self._answers
        while pending:
            s = pending[0]
            if not s.emitted:  # a sample a fault silenced: nothing to answer
                pending.popleft()
                continue
            while answers and _before(answers[0].counter, s.counter):
                answers.popleft()  # an older sample's (from before the count, or a repeat)
            if answers and answers[0].counter == s.counter:
                got = self._answer(answers[0], answers[1].tick_cycle if len(answers) > 1 else None, final)
                if got is None:
                    break  # its iteration is still running
                answers.popleft()
                pending.popleft()
                self._record(s, *got)
            elif answers or final:  # a later sample answered first, or the run ended
                pending.popleft()
                self._record(s, None, None)
            else:
                break

    def _answer(self, a: Answer, next_tick: int | None, final: bool) -> tuple[int | None, int | None] | None:
        """(command cycle, busy cycles of its iteration) of answer ``a``; None while its
        iteration runs on."""
        its = self._iterations
        while its and its[0].start_cycle + its[0].cycles <= a.tick_cycle:
            its.popleft()
        it = its[0] if its and its[0].start_cycle <= a.tick_cycle else None
        if it is not None:
            end: int | None = it.start_cycle + it.cycles
        else:  # still running, or it began before the count did (the first sample after boot)
            running = self.wiring.probes.running_since()
            in_progress = running is not None and running <= a.tick_cycle
            if in_progress and not final:
                return None
            end = next_tick if next_tick is not None else (None if in_progress else running)
        commands = self._commands
        while commands and commands[0] < a.tick_cycle:
            commands.popleft()
        cmd = commands[0] if commands and (end is None or commands[0] < end) else None
        return cmd, (it.busy_cycles if it is not None else None)

    def _record(self, s: _Sample, cmd: int | None, busy: int | None) -> None:
        """Sample ``s``'s figures: answered by the command at cycle ``cmd`` (None: never)."""
        stats, wiring = self.stats, self.wiring
        if cmd is None:
            stats.barrier_misses += 1
            self.devices.note_latency(LatencySample(s.t_ns, s.t_emit_host_ns, None))
            return
        t_cmd = wiring.sim_ns(cmd)
        busy_ns = None if busy is None else busy * 1_000_000_000 // wiring.bus.cclk_hz
        stats.latencies_ns.append(t_cmd - s.t_ns)
        if busy_ns is not None:
            stats.fc_cpu_ns.append(busy_ns)
        late = bool(self._pending) and cmd >= self._pending[0].cycle
        if late:
            stats.barrier_misses += 1
        # a board's answer has no host instant (None marks the late one as a miss in the log)
        self.devices.note_latency(LatencySample(s.t_ns, s.t_emit_host_ns, None if late else s.t_emit_host_ns,
                                                t_cmd, busy_ns))


def _before(a: int, b: int) -> bool:
    """Packet counter ``a`` comes before ``b`` (16 bits, wrapping)."""
    return 0 < (b - a) & 0xFFFF < 0x8000
