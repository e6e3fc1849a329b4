"""Benchmark of the LPC2148 peripheral bus (emulators/lpc2148; not a test): what a register
access, a tick of time and a tick with a UART burst cost in host CPU time.

Run: ``.venv/bin/python tests/bench/bench_lpc2148_bus.py [--rounds R] [--baseline DIR]
[--checkout DIR] [--only bus|board]``

The part is set up as the firmware leaves it: PLL0 at 60 MHz, PCLK = CCLK, UART0 at 921600
baud (FIFO trigger 8, RDA and RLS interrupts), UART1 at 115200, Timer0 interrupting every
2.5 ms (150,000 cycles) through VIC slot 0, Timer1 counting microseconds with a match output
toggling every 1000 counts, the PWM at 400 Hz. Then, each on this process's CPU time
(``time.process_time``; the machine's other work changes wall time more):

- ``read``/``write`` rows: one register access through ``Lpc2148.read``/``write``, the cycle
  moving on by 23 between accesses (as a core's accesses do), us per access;
- ``tick, Timer0 only``: a 2.5 ms tick as the core's run loop drives the bus: from event to
  event (``next_irq_cycle``, or ``next_event_cycle`` on a bus without it; ``advance_to``), the
  Timer0 handler's accesses at its interrupt (VICVectAddr read, T0IR write, VICVectAddr
  write); us per tick;
- ``tick, 69-byte burst``: the same with 69 bytes (an XSENS MTData2 sample) arriving on RXD0 at
  921600 baud at the tick's start, drained by a UART0 handler (VICVectAddr, U0IIR, U0LSR and
  U0RBR until the FIFO is empty, VICVectAddr) at each RDA or CTI interrupt; us per tick;
- ``board tick`` (with arm-none-eabi-gcc): the hardware layer's probe program
  (tests/unit/board/fw_hal_probe.c) on the emulated core, fed the same burst every 2.5 ms: the
  whole tick, core and bus, ms per tick, and the run loop's slices per tick.

Every scenario also prints a digest of what the firmware would observe (each read's value and
cycle, the interrupt requests' cycles, the bytes sent with their cycles; for the board tick the
console lines, the interrupt entries' cycles, the cycle counts and UART1's bytes): with
``--baseline DIR`` (an export of an older commit: ``git archive <commit> | tar -x -C DIR``)
each round runs both checkouts, interleaved, each in a fresh process, and the digests must
agree (printed "same"); the ratio of the medians is printed. Prints; asserts nothing about
time.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

_ROOT = Path(__file__).resolve().parents[2]

SCB, VIC = 0xE01F_C000, 0xFFFF_F000
T0, T1, U0, U1, PWM = 0xE000_4000, 0xE000_8000, 0xE000_C000, 0xE001_0000, 0xE001_4000
PINSEL0, IO0PIN = 0xE002_C000, 0xE002_8000
TICK = 150_000  # cycles of 2.5 ms at 60 MHz
BURST = bytes((i * 37 + 11) & 0xFF for i in range(69))


def configure(bus: Any) -> int:
    """The firmware's set-up, as register writes; returns the cycle after it."""
    w = bus.write
    c = 0
    w(SCB + 0x000, 0, 4, c)
    w(SCB + 0x004, 3, 4, c)
    w(SCB + 0x000, 2, 4, c)
    w(SCB + 0x084, 0x24, 4, c)  # PLL0: M = 5, P = 2
    w(SCB + 0x080, 1, 4, c)
    w(SCB + 0x08C, 0xAA, 4, c)
    w(SCB + 0x08C, 0x55, 4, c + 1)
    while not bus.read(SCB + 0x088, 4, c) & (1 << 10):
        c += 100
    w(SCB + 0x080, 3, 4, c)
    w(SCB + 0x08C, 0xAA, 4, c)
    w(SCB + 0x08C, 0x55, 4, c + 1)
    c += 2
    w(SCB + 0x100, 1, 4, c)  # PCLK = CCLK
    w(PINSEL0, 0b0101 | (0b0101 << 16) | (0b10 << 14), 4, c)  # TXD0, RXD0, TXD1, RXD1, PWM2 on P0.7
    w(0xE002_C004, 0b11 << 2, 4, c)  # P0.17 = MAT1.2
    for base, dll, fcr, ier in ((U0, 4, 0x81, 0x05), (U1, 33, 0x07, 0x00)):
        w(base + 0x0C, 0x83, 1, c)
        w(base + 0x00, dll, 1, c)
        w(base + 0x04, 0, 1, c)
        w(base + 0x0C, 0x03, 1, c)
        w(base + 0x08, fcr, 1, c)
        w(base + 0x04, ier, 1, c)
    w(T0 + 0x18, TICK - 1, 4, c)  # MR0: 2.5 ms
    w(T0 + 0x14, 0b011, 4, c)  # interrupt and reset on MR0
    w(T1 + 0x0C, 59, 4, c)  # 1 us counts
    w(T1 + 0x20, 1000, 4, c)  # MR2
    w(T1 + 0x14, 0b010 << 6, 4, c)  # reset on MR2
    w(T1 + 0x3C, 0b11 << 8, 4, c)  # EM2 toggles
    w(PWM + 0x0C, 59, 4, c)
    w(PWM + 0x18, 2499, 4, c)
    w(PWM + 0x20, 1200, 4, c)
    w(PWM + 0x14, 0b010, 4, c)
    w(PWM + 0x4C, 1 << 10, 4, c)
    w(PWM + 0x04, 0b1010, 4, c)
    w(PWM + 0x04, 0b1001, 4, c)
    w(VIC + 0x100, 0x1000, 4, c)
    w(VIC + 0x200, 0x20 | 4, 4, c)  # slot 0: Timer0
    w(VIC + 0x104, 0x2000, 4, c)
    w(VIC + 0x204, 0x20 | 6, 4, c)  # slot 1: UART0
    w(VIC + 0x010, (1 << 4) | (1 << 6), 4, c)
    w(T0 + 0x04, 1, 4, c)
    w(T1 + 0x04, 1, 4, c)
    return c + 1


class Trace:
    """A running digest of what the firmware observes."""

    def __init__(self) -> None:
        self.h = hashlib.sha256()
        self.n = 0

    def add(self, *items: object) -> None:
        self.h.update(repr(items).encode())
        self.n += 1

    def digest(self) -> str:
        return self.h.hexdigest()[:12]


def _board() -> tuple[Any, int]:
    from emulators.lpc2148 import Lpc2148

    bus = Lpc2148()
    return bus, configure(bus)


def bench_accesses(n: int) -> dict[str, Any]:
    """us per access for a few registers, the cycle moving on by 23 between accesses."""
    rows: dict[str, Any] = {}
    trace = Trace()
    for name, address, value in (("read U0LSR", U0 + 0x14, None), ("read T1TC", T1 + 0x08, None),
                                 ("read IO0PIN", IO0PIN, None), ("read VICIRQStatus", VIC + 0x000, None),
                                 ("write T0IR", T0 + 0x00, 0), ("write VICVectAddr", VIC + 0x030, 0)):
        bus, c = _board()
        read, write = bus.read, bus.write
        values: list[int] = []
        keep = values.append
        t = time.process_time()
        if value is None:
            for k in range(n):
                keep(read(address, 4, c + 23 * k))
        else:
            for k in range(n):
                write(address, value, 4, c + 23 * k)
        rows[name] = (time.process_time() - t) / n * 1e6
        trace.add(name, values, bus.irq_request)
    return {"us": rows, "digest": trace.digest()}


def _run_ticks(bus: Any, c: int, ticks: int, burst: bool, trace: Trace) -> None:
    """The core's run loop at the bus: slices from event to event, the handlers at interrupts."""
    read, write = bus.read, bus.write
    # the core's slicing horizon: the next interrupt-relevant event where the bus has one
    next_event = getattr(bus, "next_irq_cycle", bus.next_event_cycle)
    for _ in range(ticks):
        end = c + TICK
        if burst:
            bus.uart_line_in(0, BURST, c, 921600)
        while c < end:
            bus.advance_to(c)
            if bus.irq_request:
                trace.add("irq", c)
                vector = read(VIC + 0x030, 4, c)
                c += 20
                if vector == 0x1000:
                    write(T0 + 0x00, 1, 4, c)
                else:
                    iir = read(U0 + 0x08, 4, c)
                    got = []
                    while read(U0 + 0x14, 4, c) & 1:
                        got.append(read(U0 + 0x00, 4, c))
                        c += 23
                    trace.add(iir, bytes(got))
                write(VIC + 0x030, 0, 4, c)
                c += 10
                continue
            nxt = next_event()
            c = end if nxt is None or nxt > end else nxt
        trace.add("tick", c, [(t.value, t.start_cycle) for t in bus.take_uart_tx(0)],
                  [(m.tick, m.level) for m in bus.timer1.take_match_outputs()])


def bench_ticks(ticks: int, burst: bool) -> dict[str, Any]:
    bus, c = _board()
    trace = Trace()
    _run_ticks(bus, c, 2, burst, trace)  # the first burst and interrupt
    c = bus.cycle
    t = time.process_time()
    _run_ticks(bus, c, ticks, burst, trace)
    return {"us": (time.process_time() - t) / ticks * 1e6, "digest": trace.digest()}


def bench_board(ticks: int) -> dict[str, Any] | None:
    """The probe program on the emulated core, a burst every 2.5 ms."""
    import shutil

    if shutil.which("arm-none-eabi-gcc") is None:
        return None
    from emulators.lpc2148 import Lpc2148
    from hil.board.core import Core
    from hil.board.elf import load_elf
    from tests.unit.board.armfw import build_on_hal

    image = load_elf(build_on_hal(_ROOT / "tests" / "unit" / "board" / "fw_hal_probe.c"))
    bus = Lpc2148()
    core = Core(bus)
    core.load(image)
    core.reset(image.entry)
    trace = Trace()
    core.semihost.on_line = lambda line: trace.add(core.cycles, line)
    core.on_interrupt = lambda kind, requested, entry: trace.add(kind, entry)
    bus.attach_spi_slave(lambda mosi, transfer: (mosi * 7 + 3) & 0xFF)
    core.run_until(5 * 60_000)

    def tick() -> None:
        bus.uart_line_in(0, BURST, core.cycles, baud=921600)
        core.run_until(core.cycles + TICK)

    for _ in range(4):
        tick()
    slices = core.slices
    t = time.process_time()
    for _ in range(ticks):
        tick()
    cpu = time.process_time() - t
    slices = core.slices - slices
    bus.advance_to(core.cycles)  # what UART1 sent up to the core's cycle, wherever the run loop left the bus
    tx = bus.take_uart_tx(1)
    trace.add(core.cycles, core.idle_cycles, core.poll_cycles, core.spin_cycles, core.interrupts,
              [(x.value, x.start_cycle) for x in tx])
    return {"ms": cpu / ticks * 1e3, "slices": slices / ticks, "digest": trace.digest()}


def one_round(only: str | None) -> dict[str, Any]:
    out: dict[str, Any] = {}
    if only in (None, "bus"):
        out["access"] = bench_accesses(20_000)
        out["tick"] = bench_ticks(40, burst=False)
        out["burst"] = bench_ticks(40, burst=True)
    if only in (None, "board"):
        out["board"] = bench_board(40)
    return out


def _round_in(root: Path, only: str | None) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(root), HIL_NATIVE="0")
    cmd = [sys.executable, str(Path(__file__).resolve()), "--one-round", "--root", str(root)]
    if only:
        cmd += ["--only", only]
    done = subprocess.run(cmd, env=env, cwd=root, check=True, capture_output=True, text=True)
    return json.loads(done.stdout.splitlines()[-1])


def _rows(result: dict[str, Any]) -> dict[str, tuple[float, str, str]]:
    """name -> (value, unit, digest)."""
    rows: dict[str, tuple[float, str, str]] = {}
    if "access" in result:
        for name, us in result["access"]["us"].items():
            rows[name] = (us, "us", result["access"]["digest"])
        rows["tick, Timer0 only"] = (result["tick"]["us"], "us", result["tick"]["digest"])
        rows["tick, 69-byte burst"] = (result["burst"]["us"], "us", result["burst"]["digest"])
    board = result.get("board")
    if board:
        rows["board tick (probe program)"] = (board["ms"], "ms", board["digest"])
        rows["board tick slices"] = (board["slices"], "", board["digest"])
    return rows


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--baseline", type=Path)
    ap.add_argument("--checkout", type=Path, default=_ROOT,
                    help="the tree measured as 'this checkout' (e.g. a copy built with mypyc)")
    ap.add_argument("--only", choices=("bus", "board"))
    ap.add_argument("--one-round", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--root", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one_round:
        import emulators.lpc2148

        where = Path(emulators.lpc2148.__file__).resolve()
        if args.root is not None and not where.is_relative_to(args.root.resolve()):
            raise SystemExit(f"emulators.lpc2148 came from {where}, not from {args.root}")
        print(json.dumps(one_round(args.only)))
        return 0
    now: list[dict[str, tuple[float, str, str]]] = []
    base: list[dict[str, tuple[float, str, str]]] = []
    for _ in range(args.rounds):
        if args.baseline is not None:
            base.append(_rows(_round_in(args.baseline.resolve(), args.only)))
        now.append(_rows(_round_in(args.checkout.resolve(), args.only)))
    print(f"LPC2148 bus, host CPU time, median of {args.rounds} rounds"
          + (f"; baseline {args.baseline}" if base else ""))
    head = f"  {'':28s} {'this checkout':>14s}"
    if base:
        head += f" {'baseline':>12s} {'ratio':>7s}  digests"
    print(head)
    for name in now[0]:
        unit = now[0][name][1]
        med: Callable[[list[dict[str, tuple[float, str, str]]]], float] = \
            lambda rounds: statistics.median(r[name][0] for r in rounds)  # noqa: B023
        line = f"  {name:28s} {med(now):11.2f} {unit:2s}"
        if base:
            digests = {r[name][2] for r in now + base}
            line += f" {med(base):9.2f} {unit:2s} {med(base) / med(now):6.1f}x  "
            line += "same" if len(digests) == 1 else "DIFFERENT " + " ".join(sorted(digests))
        else:
            line += f"  {now[0][name][2]}"
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
