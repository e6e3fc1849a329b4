"""start_to_tick0_s counts from the bench's own start, not from a shell it was exec'd from."""

from __future__ import annotations

import subprocess
import sys


def test_a_shell_that_execs_the_bench_does_not_lend_it_its_start_time() -> None:
    # the shell spends 2 s (the README's `pip install`) before it becomes the bench by exec;
    # the kernel's start time of the process is the shell's, the bench's start is not
    probe = ("import time, hil.clock as c; "
             "print((time.monotonic_ns() - c.bench_start_monotonic_ns()) / 1e9)")
    out = subprocess.run(["sh", "-c", f'sleep 2; exec "{sys.executable}" -c "{probe}"'],
                         capture_output=True, text=True, timeout=60, check=True)
    age_s = float(out.stdout)
    assert 0.0 <= age_s < 1.5, age_s
