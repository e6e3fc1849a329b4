"""The clock shim's waits on other processes (a launcher's): for a child, for a tracee, on a pipe.

Each program runs under the shim with the harness's minimal scheduler (harness.py): a wait the
scheduler does not count as idle would keep sim time at 0 until the stall warning, and a
process blocked where the shim cannot see ends the wait with ``HiddenWait``."""

from __future__ import annotations

import ast
import asyncio
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from hil.vtime.stall import HiddenWait, Stall
from tests.unit.vtime.harness import run_virtual

S = 1_000_000_000
#: the harness's stall warning in these tests: a wait not seen as idle shows within a second
STALL_S = 0.5


def _py(code: str) -> list[str]:
    return [sys.executable, "-c", code]


def _in_start_up(stalls: list[Stall]) -> bool:
    """Every stall note came while a program was still starting (its slot had published
    nothing yet; the others blocked): on a loaded machine Python's start-up alone can pass
    STALL_S of wall time. A wait the bench did not take for idle ends the run with HiddenWait."""
    return all(t.blocked or t.seq == 0 for stall in stalls for t in stall.threads)


#: a child that sleeps 0.25 s of sim time, then exits 3; the parent waits for it with ``WAIT``
_WAIT_FOR_CHILD = """
import os, time, sys
pid = os.fork()
if pid == 0:
    time.sleep(0.25)
    os._exit(3)
t0 = time.monotonic_ns()
status = {wait}
print(repr((time.monotonic_ns() - t0, status)))
"""
WAITS = {
    "waitpid": "os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])",
    "wait": "os.waitstatus_to_exitcode(os.wait()[1])",
    "wait3": "os.waitstatus_to_exitcode(os.wait3(0)[1])",
    "wait4": "os.waitstatus_to_exitcode(os.wait4(pid, 0)[1])",
    "waitid": "os.waitid(os.P_PID, pid, os.WEXITED).si_status",
}


@pytest.mark.parametrize("call", sorted(WAITS))
async def test_a_parent_waiting_for_its_child_is_idle_and_sim_time_moves(call: str) -> None:
    stalls: list[Stall] = []
    out = await run_virtual(_py(_WAIT_FOR_CHILD.format(wait=WAITS[call])), stall_warn_s=STALL_S, stalls=stalls)
    assert out.returncode == 0, out.stderr
    waited, status = ast.literal_eval(out.stdout.strip())
    assert (waited, status) == (S // 4, 3)
    assert out.times_ns == [S // 4]
    assert out.calls.get("wait_child", 0) >= 1 and _in_start_up(stalls)


async def test_a_wait_that_can_end_at_once_is_not_published() -> None:
    """WNOHANG, and a child already gone: no blocked slot, nothing counted."""
    code = """
import os, time
pid = os.fork()
if pid == 0:
    os._exit(0)
while os.waitid(os.P_PID, pid, os.WEXITED | os.WNOWAIT | os.WNOHANG) is None:
    time.sleep(0.001)
print(os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]))  # blocking, but the child is already done
"""
    out = await run_virtual(_py(code), stall_warn_s=STALL_S)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "0" and "wait_child" not in out.calls


async def test_sh_c_without_exec_runs_its_child_on_sim_time() -> None:
    """The launcher of issue 43: a shell that does not exec its one command."""
    sh = shutil.which("sh") or "/bin/sh"
    child = f"{sys.executable} -c 'import time; time.sleep(0.5); print(time.monotonic_ns())'"
    stalls: list[Stall] = []
    out = await run_virtual([sh, "-c", f"{child}; echo done"], stall_warn_s=STALL_S, stalls=stalls)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == [str(1_000_000 * S + S // 2), "done"]
    assert out.times_ns == [S // 2] and _in_start_up(stalls)


@pytest.mark.parametrize("call", ["read", "readv"])
async def test_a_read_on_a_pipe_another_process_writes_is_idle_until_it_writes(call: str) -> None:
    read = "os.read(r, 16)" if call == "read" else "(lambda b: bytes(b[:os.readv(r, [b])]))(bytearray(16))"
    code = f"""
import os, time
r, w = os.pipe()
if os.fork() == 0:
    os.close(r)
    time.sleep(0.3)
    os.write(w, b"hello")
    os._exit(0)
os.close(w)
t0 = time.monotonic_ns()
data = {read}
print(repr((data, time.monotonic_ns() - t0)))
os.wait()
"""
    stalls: list[Stall] = []
    out = await run_virtual(_py(code), stall_warn_s=STALL_S, stalls=stalls)
    assert out.returncode == 0, out.stderr
    assert ast.literal_eval(out.stdout.strip()) == (b"hello", 3 * S // 10)
    assert out.calls.get("read_block", 0) >= 1 and _in_start_up(stalls)


async def test_reads_that_do_not_block_are_not_published() -> None:
    """Data already there, a non-blocking descriptor, a regular file: the read goes straight on."""
    code = """
import os
r, w = os.pipe()
os.write(w, b"x")
assert os.read(r, 1) == b"x"
os.set_blocking(r, False)
try:
    os.read(r, 1)
except BlockingIOError:
    pass
with open(os.devnull, "rb") as f:
    f.read()
print("ok")
"""
    out = await run_virtual(_py(code), stall_warn_s=STALL_S)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr
    assert "read_block" not in out.calls


@pytest.mark.skipif(shutil.which("strace") is None, reason="strace is not installed")
async def test_a_tracer_waiting_on_its_tracee_is_idle(tmp_path: Path) -> None:
    """strace -f: the tracer blocks in wait4 while its tracee sleeps in sim time."""
    code = "import time; t0 = time.monotonic_ns(); time.sleep(0.5); print(time.monotonic_ns() - t0)"
    stalls: list[Stall] = []
    out = await run_virtual(["strace", "-f", "-o", str(tmp_path / "trace"), *_py(code)], stall_warn_s=STALL_S,
                            stalls=stalls)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == str(S // 2) and out.times_ns == [S // 2]
    assert "ppoll(" in (tmp_path / "trace").read_text()  # it was traced (its sleep is a ppoll under the shim)
    assert out.calls.get("wait_child", 0) >= 1  # the tracer's wait4


async def test_a_launcher_blocked_in_a_call_the_shim_does_not_interpose_ends_the_wait_naming_it() -> None:
    code = "import signal, subprocess, sys; subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(60)']); signal.pause()"
    stalls: list[Stall] = []
    with pytest.raises(HiddenWait) as err:
        await asyncio.wait_for(run_virtual(_py(code), stall_warn_s=STALL_S, stalls=stalls), 60)
    msg = str(err.value)
    assert "waits in pause, a call the clock shim does not interpose" in msg and "(python" in msg, msg
    assert len(stalls) == 1 and any("pause" in line for line in stalls[0].unseen)


def _static_sleeper(tmp_path: Path) -> Path:
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler (cc/gcc) to build a static program")
    src, exe = tmp_path / "sleeper.c", tmp_path / "sleeper"
    src.write_text("#include <unistd.h>\nint main(void) { sleep(60); return 0; }\n")
    built = subprocess.run([cc, "-static", "-o", str(exe), str(src)], capture_output=True, text=True)
    if built.returncode != 0:
        pytest.skip(f"the C compiler cannot link statically (no static libc): {built.stderr.strip()[:200]}")
    return exe


async def test_a_static_program_in_the_tree_ends_the_wait_naming_it(tmp_path: Path) -> None:
    sleeper = _static_sleeper(tmp_path)
    sh = shutil.which("sh") or "/bin/sh"
    with pytest.raises(HiddenWait) as err:
        await asyncio.wait_for(run_virtual([sh, "-c", f"{sleeper}; echo done"], stall_warn_s=STALL_S), 60)
    msg = str(err.value)
    assert "(sleeper) of the flight command never loaded the clock shim" in msg, msg
    assert "nanosleep" in msg, msg


async def test_a_stopped_child_is_waited_for_not_an_error() -> None:
    """A debugger stop (SIGSTOP here) of a launcher's child: the scheduler waits, past the
    stall warning and its confirmation, and the run goes on once it is continued."""
    code = """
import os, signal, sys, time
pid = os.fork()
if pid == 0:
    time.sleep(0.1)
    os._exit(0)
os.kill(pid, signal.SIGSTOP)
os.waitpid(pid, 0)
print(time.monotonic_ns())
"""
    stalls: list[Stall] = []
    task = asyncio.ensure_future(run_virtual(_py(code), stall_warn_s=STALL_S, stalls=stalls))
    while not stalls:  # the child is stopped: a stall, noted
        assert not task.done(), task.result()
        await asyncio.sleep(0.05)
    await asyncio.sleep(1.5)  # past the confirmation: a stopped process is not a hidden wait
    assert not task.done()
    assert any("stopped" in line for line in stalls[0].unseen), stalls[0].unseen
    child = next(int(p) for p in os.listdir("/proc") if p.isdigit() and _stopped_child(int(p)))
    os.kill(child, signal.SIGCONT)
    out = await asyncio.wait_for(task, 60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == [str(1_000_000 * S + S // 10)]


def _stopped_child(pid: int) -> bool:
    """A stopped process whose parent is a child of this test process (the harness's program)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            fields = f.read().rsplit(b")", 1)[1].split()
        with open(f"/proc/{int(fields[1])}/stat", "rb") as f:
            grand = int(f.read().rsplit(b")", 1)[1].split()[1])
    except (OSError, ValueError, IndexError):
        return False
    return fields[0] == b"T" and grand == os.getpid()
