"""The clock shim in real processes: Python (the flight code's language) and C (any other).

Each test runs a program under the shim with a minimal scheduler (tests/unit/vtime/harness.py)
and checks that what it read from its clocks and how long its waits lasted follow sim time
exactly, whatever the host does meanwhile."""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from hil.transport.pty import PtyPort
from hil.vtime.control import MONO_BASE_NS, REAL_BASE_NS
from tests.unit.vtime.harness import run_virtual

pytestmark = pytest.mark.pty

S = 1_000_000_000
HERE = Path(__file__).parent


def _py(code: str) -> list[str]:
    return [sys.executable, "-c", code]


async def test_python_clocks_and_sleeps_run_on_sim_time() -> None:
    code = """
import os, select, time
m0, p0, r0, c0 = time.monotonic_ns(), time.perf_counter_ns(), time.time_ns(), time.thread_time_ns()
time.sleep(0.5)
m1, p1 = time.monotonic_ns(), time.perf_counter_ns()
x = 0
for i in range(300000):
    x += i
m2, c2 = time.monotonic_ns(), time.thread_time_ns()
r, w = os.pipe()
t = time.monotonic_ns()
ready = select.select([r], [], [], 0.25)
t2 = time.monotonic_ns()
print(repr((m0, r0, m1 - m0, p1 - p0, m2 - m1, c2 - c0, ready == ([], [], []), t2 - t)))
"""
    out = await run_virtual(_py(code))
    assert out.returncode == 0, out.stderr
    m0, r0, slept, perf_slept, burn_mono, burn_cpu, timed_out, select_ns = ast.literal_eval(out.stdout.strip())
    assert m0 == MONO_BASE_NS  # the flight code's clock starts at the block's base, sim 0
    assert r0 == REAL_BASE_NS  # wall clock: a fixed epoch + sim time (reproducible)
    assert slept == perf_slept == S // 2
    assert burn_mono == 0  # computing costs no sim time...
    assert burn_cpu > 0  # ...but CPU clocks pass through
    assert timed_out and select_ns == S // 4
    assert out.times_ns == [S // 2, 3 * S // 4]
    assert {"clock_gettime", "clock_nanosleep", "select", "cpu_clock"} <= set(out.calls)
    assert out.uncovered == {}


async def test_pyserial_read_timeout_and_data_follow_sim_time(tmp_path: Path) -> None:
    """A pyserial read with a timeout (the flight code's IMU watchdog) returns when the
    bytes arrive in sim time, and times out after exactly its timeout of sim time."""
    port = PtyPort("imu", tmp_path)
    await port.start()
    code = f"""
import serial, time
s = serial.Serial({port.path!r}, 115200, timeout=0.1)
t0 = time.monotonic_ns()
a = s.read(3)
t1 = time.monotonic_ns()
b = s.read(3)
t2 = time.monotonic_ns()
print(repr((a, t1 - t0, b, t2 - t1)))
"""
    try:
        out = await run_virtual(_py(code), ports={"imu": port}, at={S // 20: lambda: port.write(b"abc")})
    finally:
        port.close()
    assert out.returncode == 0, out.stderr
    a, wait_a, b, wait_b = ast.literal_eval(out.stdout.strip())
    assert (a, b) == (b"abc", b"")
    assert wait_a == S // 20  # the bytes came at sim 50 ms (the timeout was 100 ms)
    assert wait_b == S // 10  # silence: exactly the read timeout


async def test_threads_each_wait_on_sim_time() -> None:
    code = """
import threading, time
t0 = time.monotonic_ns()
out = {}
def worker(name, s):
    time.sleep(s)
    out[name] = time.monotonic_ns() - t0
ts = [threading.Thread(target=worker, args=(n, s)) for n, s in (("a", 0.3), ("b", 0.1), ("c", 0.2))]
for t in ts: t.start()
for t in ts: t.join()
print(repr(sorted(out.items())))
"""
    out = await run_virtual(_py(code))
    assert out.returncode == 0, out.stderr
    assert ast.literal_eval(out.stdout.strip()) == [("a", 3 * S // 10), ("b", S // 10), ("c", 2 * S // 10)]


async def test_a_busy_wait_on_the_clock_still_ends() -> None:
    """A loop that only reads the clock would never see sim time move: the shim grants it
    quanta of sim time, counted so the run can warn."""
    code = """
import time
time.sleep(0.001)  # detection starts after the first wait (start-up is not a busy-wait)
t0 = time.monotonic()
while time.monotonic() < t0 + 0.0005:
    pass
print("done")
"""
    out = await run_virtual(_py(code), spin_limit=1000)
    assert out.returncode == 0 and out.stdout.strip() == "done", out.stderr
    assert out.calls.get("spin_yield", 0) >= 5  # 0.5 ms in quanta of 100 us


@pytest.fixture(scope="module")
def c_client(tmp_path_factory: pytest.TempPathFactory) -> Path:
    cc = shutil.which("cc") or shutil.which("gcc")
    assert cc, "a C compiler is needed (the package's own install compiles the shim with it)"
    exe = tmp_path_factory.mktemp("client") / "client"
    subprocess.run([cc, "-O1", "-o", str(exe), str(HERE / "client.c")], check=True)
    return exe


async def test_a_c_client_runs_on_sim_time(c_client: Path, tmp_path: Path) -> None:
    """Language independence: the same interposition serves a C program's libc calls."""
    port = PtyPort("imu", tmp_path)
    await port.start()
    try:
        out = await run_virtual([str(c_client), port.path], ports={"imu": port},
                                at={S // 2: lambda: port.write(b"xyz"), 13 * S // 10: lambda: port.write(b"ep")})
    finally:
        port.close()
    assert out.returncode == 0, out.stderr
    seen = {line.split()[0]: line.split()[1:] for line in out.stdout.splitlines()}
    assert int(seen["monotonic"][0]) == MONO_BASE_NS
    assert int(seen["realtime"][0]) == REAL_BASE_NS
    assert int(seen["boottime"][0]) == MONO_BASE_NS
    assert int(seen["nanosleep"][0]) == S // 4
    assert int(seen["clock_nanosleep_abs"][0]) == 35 * S // 100
    assert seen["poll_data"] == ["1", str(S // 2), "xyz"]  # woken by the bytes, at their sim time
    assert seen["poll_timeout"] == ["0", str(7 * S // 10)]  # 200 ms of sim time later
    assert seen["select_timeout"] == ["0", str(S)]
    assert seen["epoll_timeout"] == ["0", str(115 * S // 100)]
    assert int(seen["usleep"][0]) == 1_151_000_000
    assert seen["epoll_data"] == ["1", str(13 * S // 10), "ep"]
    assert int(seen["gettimeofday"][0]) == (REAL_BASE_NS + 13 * S // 10) // 1000
    cpu, mono = map(int, seen["cpu_burn"])
    assert cpu > 0 and mono == 0
    assert out.times_ns == [S // 4, 35 * S // 100, S // 2, 7 * S // 10, S, 115 * S // 100, 1_151_000_000,
                            13 * S // 10]
    for call in ("clock_gettime", "nanosleep", "clock_nanosleep", "poll", "select", "epoll_wait", "usleep",
                 "gettimeofday", "cpu_clock"):
        assert out.calls.get(call, 0) > 0, call
    assert out.uncovered == {}


async def test_uncovered_calls_are_counted() -> None:
    code = """
import signal, threading, time
signal.setitimer(signal.ITIMER_REAL, 0)
lock = threading.Lock(); lock.acquire()
lock.acquire(timeout=0.001)  # a futex wait: translated to the host clock, counted
print("ok")
"""
    out = await run_virtual(_py(code))
    assert out.returncode == 0, out.stderr
    assert "setitimer" in out.uncovered
    assert "sem_timedwait" in out.uncovered or "cond_timedwait" in out.uncovered
