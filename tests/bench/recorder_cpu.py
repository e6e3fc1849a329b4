"""CPU and memory of each process of a ``hil run`` (not a test): bench, recorder child, flight code.

Run: ``.venv/bin/python tests/bench/recorder_cpu.py [hil run arguments ...]``
(e.g. ``--out /tmp/logs -q``). Starts ``hil run`` with the arguments, samples
``/proc/<pid>/stat`` of the bench and all its descendants every 50 ms, and prints each
process's user+system CPU seconds at its last sample, with the CPU per tick (the tick count
from the run's summary table, 400 per sim second), and the largest resident set size seen
(VmRSS, sampled: the peak between samples can be missed). The recorder child is the descendant
whose command line is the bench's own (a fork); the flight code is ``-m flightcode``.
A process's last sample can be up to 50 ms before it exits: CPU is a slight undercount.

Also printed: launch -> tick 0, from this script's monotonic clock at launch to the host time
the bench wrote IMU sample 0 (``imu_emit_host_ns`` of the first ``/hil/timing/tick`` message
at t_ns 0, read from the run's log: works for logs of any format); and the ``start_to_tick0_s``
figure of the run's summary table where the bench prints it.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

_TICKS_PER_S = os.sysconf("SC_CLK_TCK")


def _stat(pid: int) -> tuple[int, float] | None:
    """(parent pid, user+system CPU seconds) of ``pid``; None if it is gone."""
    try:
        raw = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = raw[raw.rindex(")") + 2 :].split()
    return int(fields[1]), (int(fields[11]) + int(fields[12])) / _TICKS_PER_S


def _rss_kb(pid: int) -> int:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except OSError:
        pass
    return 0


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace").strip()
    except OSError:
        return ""


def main(argv: list[str]) -> int:
    hil = str(Path(sys.executable).with_name("hil"))
    launched_ns = time.monotonic_ns()
    proc = subprocess.Popen([hil, "run", *argv], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    cpu: dict[int, float] = {}
    cmd: dict[int, str] = {}
    rss: dict[int, int] = {}
    while proc.poll() is None:
        parents: dict[int, int] = {}
        for entry in os.listdir("/proc"):
            if entry.isdigit():
                st = _stat(int(entry))
                if st is not None:
                    parents[int(entry)] = st[0]
        family = {proc.pid}
        grew = True
        while grew:
            grew = False
            for pid, ppid in parents.items():
                if ppid in family and pid not in family:
                    family.add(pid)
                    grew = True
        for pid in family:
            st = _stat(pid)
            if st is not None:
                cpu[pid] = st[1]
                rss[pid] = max(rss.get(pid, 0), _rss_kb(pid))
                cmd[pid] = _cmdline(pid) or cmd.get(pid, "")  # the latest: a fork execs after its first sample
        time.sleep(0.05)
    out = proc.stdout.read() if proc.stdout else ""
    m = re.search(r"ticks\s*│\s*([0-9.e+]+)", out)
    ticks = float(m.group(1)) if m else 0.0
    bench_cmd = cmd.get(proc.pid, "")
    print(f"exit {proc.returncode}; ticks {ticks:g}")
    log = re.search(r"^log: (\S+\.mcap)", out, re.M)
    if log:
        from hil.record import iter_messages

        first = next((m for _, _, m in iter_messages(log.group(1), ["/hil/timing/tick"]) if m["t_ns"] >= 0), None)
        if first is not None:
            print(f"  launch -> tick 0 (IMU sample 0 written): {(first['imu_emit_host_ns'] - launched_ns) / 1e9:.2f} s")
    m0 = re.search(r"start_to_tick0_s\s*│\s*([0-9.e+]+)", out)
    if m0:
        print(f"  start_to_tick0_s (the run's own figure): {m0.group(1)} s")
    for pid in sorted(cpu):
        role = ("bench" if pid == proc.pid else "recorder" if cmd[pid] == bench_cmd
                else "flight code" if "flightcode" in cmd[pid] else "other")
        per_tick = f"{cpu[pid] / ticks * 1e6:8.1f} us/tick" if ticks else ""
        print(f"  {role:<12} pid {pid:>7} cpu {cpu[pid]:7.2f} s {per_tick}  max RSS {rss.get(pid, 0) / 1024:6.1f} MB"
              f"  {cmd[pid][:60]}")
    return proc.returncode


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
