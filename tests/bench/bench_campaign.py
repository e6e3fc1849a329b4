"""Benchmark of campaign throughput (not a test): flights per hour against the worker count.

Run: ``.venv/bin/python tests/bench/bench_campaign.py [--cases 20] [--workers 1 2 4] [--executor dask]``

A campaign of ``--cases`` lockstep hover flights (``rigs/scenarios/hover.toml``, seeds 1..N,
everything recorded, logs not kept) is run once per worker count, in the order given. For
each: wall time, flights per hour, the speed-up over the first count, and the machine's
busy share of its cores during the campaign (from /proc/stat). Then every case's criteria
values are compared across the worker counts (all but the ``timing:`` ones, which judge the
host's CPU time): on virtual time they must be identical, however many flights share the
cores (more flights than cores included).

Absolute times on shared machines swing 2-4x: read the ratios, and run it on a quiet machine.
"""

from __future__ import annotations

import argparse
import json
import os
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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=20)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4])
    ap.add_argument("--duration", type=float, default=None, help="sim seconds per case (default: the scenario's 30 s)")
    ap.add_argument("--executor", default="auto", choices=["auto", "dask", "process"])
    args = ap.parse_args()

    from rich.console import Console

    from hil.campaign import load_campaign, run_campaign

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
            busy0, total0 = _cpu_busy()
            t0 = time.monotonic()
            run = run_campaign(campaign, workers=n, executor=args.executor, out_dir=Path(tmp) / f"w{n}", console=quiet)
            wall = time.monotonic() - t0
            busy1, total1 = _cpu_busy()
            s = run.summary
            rows.append((n, wall, s["passed"], s["failed"], s["done"], (busy1 - busy0) / max(total1 - total0, 1)))
            # the flight's criteria; "timing:" ones judge the host's CPU time, which load may change
            values[n] = {r["case_id"]: [(c["name"], c.get("value")) for c in r.get("criteria", [])
                                        if not c["name"].startswith("timing:")] for r in run.results}
            for r in run.results:
                failing = [f"{c['name']} = {c.get('value')}" for c in r.get("criteria", []) if not c.get("passed")]
                if failing:
                    print(f"  seed {r['seed']} failed: " + "; ".join(failing), flush=True)
            print(f"workers {n}: {wall:.1f} s, {s['done']} flights ({s['passed']} passed), "
                  f"{s['done'] / wall * 3600:.0f} flights/h, cores busy {rows[-1][5]:.0%}", flush=True)
    n1, wall1 = rows[0][0], rows[0][1]
    print()
    print(f"| workers | wall s | flights/h | speed-up vs {n1} | cores busy | passed |")
    print("|---|---|---|---|---|---|")
    for n, wall, passed, _failed, done, busy in rows:
        print(f"| {n} | {wall:.1f} | {done / wall * 3600:.0f} | {wall1 / wall:.2f} | {busy:.0%} | {passed}/{done} |")
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
