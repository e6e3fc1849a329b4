"""Host interruptions: how long a thread that does nothing but run loses its CPU.

A realtime run's tick loop and flight code run at ``SCHED_FIFO`` (hil/host/rtsched.py): no
ordinary process of the guest can take their CPU. What still can is below the guest: on a
virtual machine the host deschedules a virtual CPU whenever it runs something else, and the
guest's thread stops without knowing (the kernel's steal time counts it afterwards, in 10 ms
steps, hil/host/steal.py). A tick or a flight-code sample caught by such a pause is late, and if
the pause is long enough the sample gets no command.

This measures those pauses the way ``rtla osnoise`` and ``hwlatdetect`` do, from user space
(this kernel has neither tracer): one process per CPU, pinned there and at the realtime run's
priority, reads the monotonic clock in a loop, and every step between two reads longer than
``threshold_us`` is a time its CPU was taken away. The guest's own interrupts take
microseconds; gaps of hundreds of microseconds to milliseconds are the host's. The loop runs
in windows of 0.9 s with 0.1 s asleep between them, so the kernel's real-time throttling
(0.95 s of every second by default) never cuts in and reads as a gap.

``hil perf`` prints it beside the realtime figures (docs/time.md, "Host interruptions").
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.connection
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from hil import clock

#: a step between two clock reads longer than this is an interruption (the loop's own step
#: is well under 1 us; the guest's timer and device interrupts take a few us)
THRESHOLD_US = 200.0
#: spin this long at a time, then sleep ``_REST_S``: a real-time thread that never sleeps is
#: throttled by the kernel after 0.95 s of every second, which would read as a 50 ms gap
_WINDOW_S = 0.9
_REST_S = 0.1


@dataclass(frozen=True)
class CpuNoise:
    """What one CPU's spinning thread saw."""

    cpu: int
    measured_s: float  #: time spent spinning (the rests not included), s
    gaps_ns: tuple[int, ...]  #: each interruption longer than the threshold, ns
    policy: str  #: the scheduling policy it ran on ("SCHED_FIFO priority 50", "SCHED_OTHER")

    @property
    def longest_us(self) -> float:
        return max(self.gaps_ns, default=0) / 1e3

    @property
    def lost_ms(self) -> float:
        return sum(self.gaps_ns) / 1e6

    def per_10s(self) -> float:
        """Interruptions per 10 s of spinning."""
        return len(self.gaps_ns) * 10.0 / self.measured_s if self.measured_s > 0 else float("nan")


def spin_window(read: Callable[[], int], span_ns: int, threshold_ns: int) -> tuple[list[int], int]:
    """Read the clock ``read`` (ns) until ``span_ns`` have passed since its first reading;
    returns the steps between consecutive readings longer than ``threshold_ns``, in order,
    and the ns from the first reading to the last."""
    start = prev = read()
    stop = start + span_ns
    gaps: list[int] = []
    while prev < stop:
        now = read()
        if now - prev > threshold_ns:
            gaps.append(now - prev)
        prev = now
    return gaps, prev - start


def _spin(cpu: int, seconds: float, threshold_ns: int, priority: int, out: multiprocessing.connection.Connection) -> None:
    """Child process: spin on ``cpu`` for ``seconds`` of windows; send (measured_s, gaps, policy)."""
    os.sched_setaffinity(0, {cpu})
    policy = "SCHED_OTHER"
    if priority > 0:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
            policy = f"SCHED_FIFO priority {priority}"
        except OSError:
            pass  # measured at the default policy, and said so
    gaps: list[int] = []
    measured = 0
    left = int(seconds * 1e9)
    while left > 0:
        span = min(left, int(_WINDOW_S * 1e9))
        window_gaps, spanned = spin_window(clock.monotonic_ns, span, threshold_ns)
        gaps += window_gaps
        measured += spanned
        left -= span
        if left > 0:
            clock.sleep_until_ns(clock.monotonic_ns() + int(_REST_S * 1e9), spin_ns=0)
    out.send((measured / 1e9, gaps, policy))
    out.close()


def measure(seconds: float = 5.0, *, threshold_us: float = THRESHOLD_US, priority: int = 0,
            cpus: Sequence[int] | None = None) -> list[CpuNoise]:
    """Spin on every CPU this process may use (or ``cpus``) at once for ``seconds`` each;
    ``priority`` > 0: at ``SCHED_FIFO`` that priority where allowed (else the default policy,
    named in the result). Returns one :class:`CpuNoise` per CPU, in CPU order."""
    if seconds <= 0:
        raise ValueError(f"seconds must be > 0, got {seconds!r}")
    targets = sorted(os.sched_getaffinity(0) if cpus is None else cpus)
    ctx = multiprocessing.get_context("spawn")  # a clean process: no threads, no inherited state
    threshold_ns = int(threshold_us * 1e3)
    runs = []
    for cpu in targets:
        receive, send = ctx.Pipe(duplex=False)
        proc = ctx.Process(target=_spin, args=(cpu, seconds, threshold_ns, priority, send), daemon=True)
        proc.start()
        send.close()
        runs.append((cpu, proc, receive))
    out = []
    for cpu, proc, receive in runs:
        try:
            measured_s, gaps, policy = receive.recv()
        except EOFError:
            proc.join()
            raise RuntimeError(f"the interruption probe on CPU {cpu} ended without a result "
                               f"(exit status {proc.exitcode})") from None
        finally:
            receive.close()
        proc.join()
        out.append(CpuNoise(cpu, measured_s, tuple(gaps), policy))
    return out
