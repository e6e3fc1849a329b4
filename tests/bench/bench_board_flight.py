"""Benchmark of a board flight (not a test): the firmware's ARM build on the emulated LPC2148
beside its host build, same scenario and seed, in one session.

Run: ``.venv/bin/python tests/bench/bench_board_flight.py [--scenario hover] [--duration 10]
[--rounds 1]``. Each round flies the board rig (rigs/paper-quad-lpc2148.toml) and then the
host build's rig (rigs/paper-quad-c.toml), recorded, and prints per flight: RTF, the bench's
CPU per tick, and for the board the loop's busy cycles (p50/p99/max), the CPU load, the
compute budget's margin, the interrupt latency, and where the bench's time went (a cProfile
of one more board flight with ``--profile``). Prints; asserts nothing about time.
"""

from __future__ import annotations

import argparse
import asyncio
import cProfile
import pstats
import statistics
import sys
import tempfile
from pathlib import Path

from hil.config.rig import load_rig
from hil.config.scenario import load_scenario
from hil.flight.run import run_flight_async
from hil.flight.run_result import RunResult

ROOT = Path(__file__).resolve().parents[2]
RIGS = {"board": ROOT / "rigs" / "paper-quad-lpc2148.toml", "host": ROOT / "rigs" / "paper-quad-c.toml"}


def fly(which: str, scenario: str, duration_s: float, out: Path) -> RunResult:
    rig = load_rig(RIGS[which])
    source = rig.scenario_path(scenario)
    return asyncio.run(run_flight_async(rig, load_scenario(source), scenario_source=source, duration_s=duration_s,
                                        out_dir=out))


def line(which: str, r: RunResult) -> str:
    t = r.timing
    text = (f"{which:<5} rtf {t['rtf']:.3f}  bench CPU/tick {t.get('bench_cpu_per_tick_us', float('nan')) / 1e3:.2f} ms"
            f"  misses {t['barrier_misses']:.0f}")
    if "board_cclk_hz" in t:
        c = next((c for c in r.criteria if c.signal == "timing.fc_compute_p99_us"), None)
        text += (f"\n      loop busy cycles p50/p99/max {t['board_loop_busy_p50_cycles']:.0f}/"
                 f"{t['board_loop_busy_p99_cycles']:.0f}/{t['board_loop_busy_max_cycles']:.0f}"
                 f" ({t['fc_compute_p50_us']:.0f}/{t['fc_compute_p99_us']:.0f}/{t['fc_compute_max_us']:.0f} us)"
                 f"  load {t['board_cpu_load_pct']:.1f} % (busiest tick {t['board_cpu_load_max_pct']:.1f} %)"
                 f"\n      irq latency p50/p99/max {t['board_irq_latency_p50_cycles']:.0f}/"
                 f"{t['board_irq_latency_p99_cycles']:.0f}/{t['board_irq_latency_max_cycles']:.0f} cycles"
                 f"  latency p50/p99/max {t['latency_p50_us']:.0f}/{t['latency_p99_us']:.0f}/{t['latency_max_us']:.0f} us"
                 f"\n      compute budget: {c.verdict if c else 'none'} ({c.detail if c else ''})")
    return text


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="hover")
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--profile", action="store_true", help="one more board flight under cProfile")
    args = ap.parse_args(argv)
    rtf: dict[str, list[float]] = {"board": [], "host": []}
    with tempfile.TemporaryDirectory(prefix="bench-board-") as tmp:
        for k in range(args.rounds):
            for which in ("board", "host"):
                r = fly(which, args.scenario, args.duration, Path(tmp) / f"{which}{k}")
                rtf[which].append(r.timing["rtf"])
                print(line(which, r), flush=True)
        if args.profile:
            prof = cProfile.Profile()
            prof.enable()
            fly("board", args.scenario, args.duration, Path(tmp) / "profile")
            prof.disable()
            pstats.Stats(prof).sort_stats("tottime").print_stats(15)
    print(f"median RTF: board {statistics.median(rtf['board']):.3f}, host build {statistics.median(rtf['host']):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
