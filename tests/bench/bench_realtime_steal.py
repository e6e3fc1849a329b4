"""Benchmark (not a test): realtime misses against the hypervisor's steal time, run by run.

Run: ``.venv/bin/python tests/bench/bench_realtime_steal.py [--runs N] [--seconds S]``

Flies N realtime hovers of S seconds one after another (the default rig: SCHED_FIFO and the
CPU latency request where the host allows them) and prints, per run, the steal time the run
saw over its tick loop (``timing["host_steal_ms"]``, hil/host/steal.py), its late ticks, samples
without a command and response p99; then the runs split by whether any steal time was
counted. On a virtual machine this shows whether what is left of the realtime misses comes
from inside the guest (misses in runs without steal time) or from the host.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from hil.flight.tickloop import Mode  # noqa: E402
from hil.flight.run import run_flight  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--seconds", type=float, default=10.0)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.runs):
            res = run_flight(None, "hover", mode=Mode.REALTIME, duration_s=args.seconds, out_dir=Path(tmp) / f"r{i}",
                             record=True)
            t = res.timing
            row = (t.get("host_steal_ms", float("nan")), int(t.get("late_ticks", 0)), int(t.get("rt_no_command", 0)),
                   t.get("latency_p99_us", float("nan")), int(t.get("ticks", 0)))
            rows.append(row)
            print(f"run {i + 1:2d}: steal {row[0]:5.0f} ms  late ticks {row[1]:3d}  without a command {row[2]:3d} "
                  f"of {row[4]}  response p99 {row[3]:6.0f} us", flush=True)
    for label, group in (("no steal time", [r for r in rows if r[0] == 0]),
                         ("steal time", [r for r in rows if r[0] > 0])):
        if not group:
            print(f"{label}: no runs")
            continue
        print(f"{label}: {len(group)} runs, late ticks {sum(r[1] for r in group)}, without a command "
              f"{sum(r[2] for r in group)} (per run {', '.join(str(r[2]) for r in group)}), "
              f"response p99 median {statistics.median(r[3] for r in group):.0f} us")


if __name__ == "__main__":
    main()
