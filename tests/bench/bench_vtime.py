"""Benchmark of virtual time (not a test): what the clock shim costs.

Run: ``.venv/bin/python tests/bench/bench_vtime.py [--repeats N] [--seconds S]``

1. **Per interposed call**: a small C program (compiled here with the system's cc) times
   ``clock_gettime(CLOCK_MONOTONIC)``, ``gettimeofday``, a zero-timeout ``poll`` and a
   ``read`` that does not block (a pipe with bytes in it: the shim's one extra ``poll``) in
   loops, on its own thread CPU clock (which the shim passes through), once under the shim
   with the test harness's scheduler and once without it. Medians over ``--repeats``
   interleaved runs.
2. **RTF**: a recorded lockstep hover of ``--seconds`` sim seconds on virtual time and on the
   wall-clock fallback (``virtual_time=False``), interleaved, medians and their ratio; with
   the flight code's CPU per tick on virtual time (``fc_compute_p50_us``: the shim's thread
   CPU per sample; ``fc_cpu_per_tick_us``: /proc over the tick loop).

``--library PATH`` measures another build of the shim (an older one, to compare) instead of
the installed one.

Absolute times on shared machines swing 2-4x: read the ratios, measured side by side.
"""

from __future__ import annotations

import argparse
import asyncio
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

C_SOURCE = r"""
#define _GNU_SOURCE
#include <poll.h>
#include <stdio.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>
static long long cpu(void) { struct timespec t; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t); return t.tv_sec * 1000000000LL + t.tv_nsec; }
int main(void) {
    enum { N = 1000000, M = 200000, R = 60000 };
    struct timespec ts; struct timeval tv; int fds[2], bytes[2]; pipe(fds); pipe(bytes);
    struct pollfd p = {fds[0], POLLIN, 0};
    static char buf[R];
    if (write(bytes[1], buf, R) != R) return 1;  /* R bytes waiting: every read below is ready */
    long long t0 = cpu();
    for (int i = 0; i < N; i++) clock_gettime(CLOCK_MONOTONIC, &ts);
    long long t1 = cpu();
    for (int i = 0; i < N; i++) gettimeofday(&tv, NULL);
    long long t2 = cpu();
    for (int i = 0; i < M; i++) poll(&p, 1, 0);
    long long t3 = cpu();
    for (int i = 0; i < R; i++) if (read(bytes[0], buf, 1) != 1) return 1;
    long long t4 = cpu();
    printf("%.1f %.1f %.1f %.1f\n", (double)(t1 - t0) / N, (double)(t2 - t1) / N, (double)(t3 - t2) / M,
           (double)(t4 - t3) / R);
    return 0;
}
"""
CALLS = ("clock_gettime", "gettimeofday", "poll(0)", "read (ready)")


def build_client(workdir: Path) -> Path:
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        raise SystemExit("no C compiler (cc/gcc) to build the timing client")
    src, exe = workdir / "calls.c", workdir / "calls"
    src.write_text(C_SOURCE)
    subprocess.run([cc, "-O2", "-o", str(exe), str(src)], check=True)
    return exe


def per_call(exe: Path, repeats: int) -> dict[str, tuple[float, float]]:
    from tests.unit.vtime.harness import run_virtual

    plain: list[list[float]] = []
    shim: list[list[float]] = []
    for _ in range(repeats):
        plain.append([float(x) for x in subprocess.run([str(exe)], capture_output=True, text=True,
                                                        check=True).stdout.split()])
        out = asyncio.run(run_virtual([str(exe)]))
        if out.returncode != 0:
            raise SystemExit(f"client failed under the shim: {out.stderr}")
        shim.append([float(x) for x in out.stdout.split()])
    return {name: (statistics.median(r[i] for r in plain), statistics.median(r[i] for r in shim))
            for i, name in enumerate(CALLS)}


def rtf(repeats: int, seconds: float) -> dict[str, list[float]]:
    from hil.flight.run import run_flight

    out: dict[str, list[float]] = {"virtual": [], "wall": [], "fc_compute_p50_us": [], "fc_cpu_per_tick_us": []}
    with tempfile.TemporaryDirectory(prefix="hil-bench-vtime-") as tmp:
        for i in range(repeats):
            for name, vt in (("virtual", True), ("wall", False)):
                r = run_flight(None, "hover", duration_s=seconds, out_dir=Path(tmp) / f"{name}{i}", virtual_time=vt)
                if r.end_reason.value != "completed":
                    raise SystemExit(f"{name} run {i}: {r.end_reason.value} {r.message}")
                out[name].append(r.timing["rtf"])
                if vt:
                    for key in ("fc_compute_p50_us", "fc_cpu_per_tick_us"):
                        out[key].append(r.timing.get(key, float("nan")))
    return out


def use_library(path: Path) -> None:
    """Measure the shim at ``path`` instead of the installed one (harness and runs alike)."""
    import hil.vtime.session
    import tests.unit.vtime.harness

    tests.unit.vtime.harness.shim_library = lambda: path  # type: ignore[assignment]
    hil.vtime.session.shim_library = lambda: path  # type: ignore[assignment]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--skip-rtf", action="store_true")
    ap.add_argument("--library", type=Path, help="another build of the shim to measure (default: the installed one)")
    args = ap.parse_args(argv)
    if args.library is not None:
        use_library(args.library.resolve())
    with tempfile.TemporaryDirectory(prefix="hil-bench-calls-") as tmp:
        costs = per_call(build_client(Path(tmp)), args.repeats)
    print(f"per call, thread CPU ns, median of {args.repeats} interleaved runs")
    print(f"  {'call':<16}{'plain':>10}{'shim':>10}{'ratio':>8}")
    for name, (plain, shim) in costs.items():
        print(f"  {name:<16}{plain:>10.1f}{shim:>10.1f}{shim / plain:>8.2f}")
    if not args.skip_rtf:
        r = rtf(args.repeats, args.seconds)
        v, w = statistics.median(r["virtual"]), statistics.median(r["wall"])
        print(f"recorded hover, {args.seconds:g} s sim, RTF median of {args.repeats} interleaved runs")
        print(f"  virtual time {v:.2f}x  {[round(x, 2) for x in r['virtual']]}")
        print(f"  wall clock   {w:.2f}x  {[round(x, 2) for x in r['wall']]}")
        print(f"  virtual / wall = {v / w:.3f}")
        for key in ("fc_compute_p50_us", "fc_cpu_per_tick_us"):
            print(f"  virtual time {key} {statistics.median(r[key]):.1f}  {[round(x, 1) for x in r[key]]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
