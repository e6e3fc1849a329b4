"""Peak resident memory of the bench process for a short and a long flight (not a test).

Run: ``.venv/bin/python tests/bench/bench_memory.py [--short 10] [--long 600] [--scenario hover]``

Each flight is one recorded lockstep ``hil.flight.run.run_flight`` (the scenario's duration
overridden) in a fresh interpreter, so one flight's memory cannot hide in the other's. The
figure is that interpreter's ``ru_maxrss`` (RUSAGE_SELF): the bench process alone, not the
flight code or the recorder (child processes). The issue's bound: the long flight within
10 MB of the short one. A 10-minute flight takes several minutes of wall time (lockstep at
about 2.5x real time).

``--top N`` runs each flight under tracemalloc instead (several times slower) and prints the
N source lines holding the most memory at the end of the run (before the run's result is
dropped): where memory that grows with the flight's length lives.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile

_CHILD = r"""
import json, resource, sys, tracemalloc
from pathlib import Path
from hil.flight.tickloop import Mode
from hil.flight.run import run_flight

scenario, duration_s, out, top = sys.argv[1], float(sys.argv[2]), Path(sys.argv[3]), int(sys.argv[4])
if top:
    tracemalloc.start(1)
result = run_flight(None, scenario, mode=Mode.LOCKSTEP, duration_s=duration_s, out_dir=out)
lines = []
if top:
    traced, peak = tracemalloc.get_traced_memory()
    stats = tracemalloc.take_snapshot().statistics("lineno")[:top]
    lines = [f"{s.size / 1e6:8.2f} MB {s.count:8d} blocks  {s.traceback[0]}" for s in stats]
    lines.insert(0, f"traced now {traced / 1e6:.1f} MB, traced peak {peak / 1e6:.1f} MB")
print(json.dumps({
    "duration_s": duration_s,
    "sim_s": result.sim_s,
    "end": result.end_reason.value,
    "passed": result.passed,
    "rtf": result.timing.get("rtf"),
    "maxrss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    "top": lines,
}))
"""


def fly(scenario: str, duration_s: float, top: int) -> dict[str, object]:
    """One flight in a fresh interpreter; its figures (maxrss_MB: the bench process's peak RSS)."""
    with tempfile.TemporaryDirectory(prefix="bench-memory-") as out:
        proc = subprocess.run([sys.executable, "-c", _CHILD, scenario, str(duration_s), out, str(top)],
                              capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"flight of {duration_s} s failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenario", default="hover")
    ap.add_argument("--short", type=float, default=10.0, help="short flight, sim seconds")
    ap.add_argument("--long", type=float, default=600.0, help="long flight, sim seconds")
    ap.add_argument("--top", type=int, default=0, help="tracemalloc: print the N biggest allocation sites")
    args = ap.parse_args()
    figures = []
    for duration_s in (args.short, args.long):
        r = fly(args.scenario, duration_s, args.top)
        figures.append(r)
        print(f"{duration_s:7.1f} s flight: bench peak RSS {r['maxrss_MB']:6.1f} MB  "
              f"({r['end']}, {'pass' if r['passed'] else 'FAIL'}, RTF {r['rtf']:.2f})", flush=True)
        for line in r["top"]:  # type: ignore[union-attr]
            print("   ", line)
    growth = figures[1]["maxrss_MB"] - figures[0]["maxrss_MB"]  # type: ignore[operator]
    print(f"long - short: {growth:+.1f} MB (bound: 10 MB) -> {'within' if growth <= 10 else 'OVER'}")


if __name__ == "__main__":
    main()
