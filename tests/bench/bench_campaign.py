"""Benchmark of campaign throughput (not a test): flights per hour against the worker count.

Run: ``.venv/bin/python tests/bench/bench_campaign.py [--cases 20] [--workers 1 2 4] [--executor dask]``

A campaign of ``--cases`` lockstep hover flights (``rigs/scenarios/hover.toml``, seeds 1..N,
logs not kept, so unrecorded) is run once per worker count, in the order given. For each:
wall time, flights per hour, the speed-up over the first count, and the machine's busy
share of its cores during the campaign (from /proc/stat). Right before each campaign, the
same number of copies of a fixed CPU-bound Python loop run side by side (median of 5, in
alternating order): their speed-up over one copy is what this machine gives any CPU-bound
Python work with that many processes, the ceiling to read the campaign's speed-up against.
Then every case's criteria values are compared across the worker counts (all but the
``timing:`` ones, which judge the host's CPU time): on virtual time they must be identical,
however many flights share the cores (more flights than cores included).

Absolute times on shared machines swing 2-4x: read the ratios, and run it on a quiet machine.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))


def _cpu_busy() -> tuple[int, int]:
    """(busy, total) jiffies of all cores, from /proc/stat."""
    with open("/proc/stat") as f:
        fields = [int(x) for x in f.readline().split()[1:]]
    idle = fields[3] + fields[4]
    return sum(fields) - idle, sum(fields)


#: a fixed amount of pure-Python work (dict and float operations, about 0.5 s on one core)
_REFERENCE_WORK = """
d = {}
s = 0.0
for i in range(3_000_000):
    d[i & 1023] = i * 0.5
    s += d.get((i * 7) & 1023, 0.0)
"""


def _reference_wall_s(copies: int) -> float:
    """Wall time for ``copies`` processes, each doing ``_REFERENCE_WORK``, side by side."""
    t0 = time.monotonic()
    procs = [subprocess.Popen([sys.executable, "-c", _REFERENCE_WORK]) for _ in range(copies)]
    for p in procs:
        if p.wait() != 0:
            raise RuntimeError("the reference workload failed")
    return time.monotonic() - t0


def _machine_speedup(copies: int, repeats: int = 5) -> float:
    """Throughput of ``copies`` CPU-bound processes over one (medians of ``repeats`` pairs).

    After a discarded warm-up run, the pairs alternate which count runs first: run in a fixed
    order, the first run of every pair came out about 1.4x slower (the reference of one copy
    against itself gave 1.41x, 2026-11-26), which biased the ceiling."""
    if copies == 1:
        return 1.0
    _reference_wall_s(1)
    one, many = [], []
    for i in range(repeats):
        for n in ((1, copies) if i % 2 == 0 else (copies, 1)):
            (one if n == 1 else many).append(_reference_wall_s(n))
    return copies * statistics.median(one) / statistics.median(many)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=20)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4])
    ap.add_argument("--duration", type=float, default=None, help="sim seconds per case (default: the scenario's 30 s)")
    ap.add_argument("--executor", default="auto", choices=["auto", "dask", "process"])
    args = ap.parse_args()

    from rich.console import Console

    from hil.fleet.campaign import run_campaign
    from hil.fleet.campaign_file import load_campaign

    quiet = Console(file=open(os.devnull, "w"))  # noqa: SIM115 - lives as long as the run
    rows = []
    values: dict[int, dict[str, list]] = {}
    with tempfile.TemporaryDirectory(prefix="bench-campaign-") as tmp:
        path = Path(tmp) / "bench.toml"
        duration = f"duration_s = {args.duration}\n" if args.duration else ""
        path.write_text(
            "[campaign]\n"
            'name = "bench"\n'
            f'rig = "{ROOT / "rigs" / "paper-quad.toml"}"\n'
            'scenarios = ["hover"]\n'
            f"seeds = {{ from = 1, count = {args.cases} }}\n"
            'mode = "lockstep"\n'
            f"{duration}"
            'keep_logs = "none"\n'
            "case_timeout_s = 900.0\n"
        )
        campaign = load_campaign(path)
        for n in args.workers:
            machine = _machine_speedup(n)
            busy0, total0 = _cpu_busy()
            t0 = time.monotonic()
            run = run_campaign(campaign, workers=n, executor=args.executor, out_dir=Path(tmp) / f"w{n}", console=quiet)
            wall = time.monotonic() - t0
            busy1, total1 = _cpu_busy()
            s = run.summary
            rows.append((n, wall, s["passed"], s["failed"], s["done"], (busy1 - busy0) / max(total1 - total0, 1), machine))
            # the flight's criteria; "timing:" ones judge the host's CPU time, which load may change
            values[n] = {r["case_id"]: [(c["name"], c.get("value")) for c in r.get("criteria", [])
                                        if not c["name"].startswith("timing:")] for r in run.results}
            for r in run.results:
                failing = [f"{c['name']} = {c.get('value')}" for c in r.get("criteria", []) if not c.get("passed")]
                if failing:
                    print(f"  seed {r['seed']} failed: " + "; ".join(failing), flush=True)
            print(f"workers {n}: {wall:.1f} s, {s['done']} flights ({s['passed']} passed), "
                  f"{s['done'] / wall * 3600:.0f} flights/h, cores busy {rows[-1][5]:.0%}; "
                  f"{n} CPU-bound reference processes: {machine:.2f}x one", flush=True)
    n1, wall1 = rows[0][0], rows[0][1]
    print()
    print(f"| workers | wall s | flights/h | speed-up vs {n1} | CPU-bound reference, n processes vs 1 | cores busy | passed |")
    print("|---|---|---|---|---|---|---|")
    for n, wall, passed, _failed, done, busy, machine in rows:
        print(f"| {n} | {wall:.1f} | {done / wall * 3600:.0f} | {wall1 / wall:.2f} | {machine:.2f} | {busy:.0%} | {passed}/{done} |")
    ref = values[n1]
    same = all(values[n] == ref for n in values)
    print(f"\nflight criteria values identical across worker counts: {same}")
    if not same:
        for n in values:
            for case, v in values[n].items():
                if v != ref.get(case):
                    print(f"  workers {n} {case}: {json.dumps(v)} != {json.dumps(ref.get(case))}")
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
