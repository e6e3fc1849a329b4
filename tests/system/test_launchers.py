"""The flight code started through a launcher, as firmware developers do (issue 43): a shell
that does not exec, a script, env, nice, taskset, make, strace -f, gdb.

Each flies on virtual time with plant truth and control wires identical to the direct command
on the same seed; SIGTERM at any moment ends the run with its log finalized and no process of
the command's tree left (checked through /proc); a second SIGTERM exits at once with status
130; a launcher blocked where the clock shim cannot see ends the run with one sentence."""

from __future__ import annotations

import asyncio
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hil.flight.run_result import RunResult
from hil.flight.tickloop import Clock, EndReason
from hil.record import iter_messages, read_metadata
from tests.proc_token import with_token
from tests.system.conftest import explain, rig_with_command
from tests.system.test_determinism import CONTROL_WIRES, TRUTH

pytestmark = [pytest.mark.system, pytest.mark.pty]
ROOT = Path(__file__).resolve().parents[2]
FLIGHT = ["{python}", "-m", "flightcode", "--config", "{config}"]
#: sim seconds of hover each launcher flies for the comparison with the direct command
SECONDS = 3.0

SCRIPT = """#!/bin/sh
# sets the environment, then runs the flight code without exec, and reports its status
export HIL_LAUNCHER=script
"$@"
status=$?
echo "flight code exited with status $status"
exit $status
"""
MAKEFILE = "run:\n\t$(PYTHON) -m flightcode --config $(CONFIG)\n"


def launcher(name: str, workdir: Path) -> list[str]:
    """The rig's [flight] command for launcher ``name`` (its files written into ``workdir``)."""
    if name == "sh -c":
        return ["sh", "-c", "{python} -m flightcode --config {config}; echo done"]
    if name == "bash script":
        (workdir / "run.sh").write_text(SCRIPT)
        return ["bash", str(workdir / "run.sh"), *FLIGHT]
    if name == "env":
        return ["env", "HIL_LAUNCHER=env", *FLIGHT]
    if name == "nice":
        return ["nice", "-n", "5", *FLIGHT]
    if name == "taskset":
        return ["taskset", "-c", ",".join(str(c) for c in sorted(os.sched_getaffinity(0))), *FLIGHT]
    if name == "make run":
        (workdir / "Makefile").write_text(MAKEFILE)
        return ["make", "-s", "-C", str(workdir), "run", "PYTHON={python}", "CONFIG={config}"]
    if name == "strace -f":
        return ["strace", "-f", "-o", str(workdir / "strace.out"), *FLIGHT]
    if name == "gdb":
        return ["gdb", "--batch", "-ex", "run", "--args", *FLIGHT]
    raise ValueError(name)


#: launcher -> the tool it needs (skipped, naming it, only if that tool is missing)
TOOLS = {"sh -c": "sh", "bash script": "bash", "env": "env", "nice": "nice", "taskset": "taskset", "make run": "make",
         "strace -f": "strace", "gdb": "gdb"}


def need(name: str) -> None:
    if shutil.which(TOOLS[name]) is None:
        pytest.skip(f"{TOOLS[name]} is not installed")


def rig_for(tmp_path: Path, name: str) -> Path:
    workdir = tmp_path / re.sub(r"\W+", "-", name)
    workdir.mkdir(parents=True, exist_ok=True)
    return rig_with_command(workdir, launcher(name, workdir), "launcher-rig")


def tree_of_bench(bench_pid: int) -> list[tuple[int, str]]:
    """Live processes started as a flight command by bench ``bench_pid`` (their token), from /proc."""
    return with_token(f"{bench_pid}-")


def run_dirs_of(pids: list[tuple[int, str]]) -> set[Path]:
    """The run directories named in these processes' command lines (the flight config's, also
    inside a shell's command string: ``sh -c "... --config DIR/flight.toml; echo done"`` may be
    all there is when the signal comes before the shell started the flight code)."""
    dirs = set()
    for pid, _ in pids:
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                args = f.read().decode(errors="replace").split("\0")
        except OSError:
            continue
        for arg in args:
            dirs.update(Path(m).parent for m in re.findall(r"(/[^\s=;'\"]*/flight\.toml)\b", arg))
    return dirs


def wire_before(path: Path, port: str, direction: str, end_ns: int) -> bytes:
    """The bytes of a control wire up to (not at) sim time ``end_ns``: what the flight was. At
    the end the flight code is stopped, and how its launcher passes the SIGTERM on is the
    launcher's (gdb interrupts the program before it kills it)."""
    topic = f"/hil/wire/{port}/{direction}"
    return b"".join(m["data"] for _, _, m in iter_messages(path, [topic]) if m["t_ns"] < end_ns)


def assert_same_flight(a: RunResult, b: RunResult) -> None:
    assert a.end_reason is EndReason.COMPLETED, explain(a)
    assert b.end_reason is EndReason.COMPLETED, explain(b)
    assert a.trace is not None and b.trace is not None and a.log_path is not None and b.log_path is not None
    for name in TRUTH:
        ta, va = a.trace.signal(name)
        tb, vb = b.trace.signal(name)
        np.testing.assert_array_equal(ta, tb)
        np.testing.assert_array_equal(va, vb, err_msg=name)
    end_ns = int(SECONDS * 1e9)
    for port, direction in CONTROL_WIRES:
        wa, wb = wire_before(a.log_path, port, direction, end_ns), wire_before(b.log_path, port, direction, end_ns)
        assert len(wa) > 0 and wa == wb, f"{port}/{direction} differs: {len(wa)} vs {len(wb)} bytes"


_direct: dict[str, RunResult] = {}


async def direct_flight(fly, tmp_path: Path) -> RunResult:
    """The direct command's flight (once per test process: every launcher compares with it)."""
    if "result" not in _direct:
        (tmp_path / "direct").mkdir()
        rig = rig_with_command(tmp_path / "direct", FLIGHT, "direct-rig")
        _direct["result"] = await fly("hover", rig=str(rig), duration_s=SECONDS, out_dir=tmp_path / "direct")
    return _direct["result"]


@pytest.mark.parametrize("name", list(TOOLS))
async def test_each_launcher_flies_as_the_direct_command(fly, tmp_path: Path, name: str) -> None:
    need(name)
    direct = await direct_flight(fly, tmp_path)
    result = await fly("hover", rig=str(rig_for(tmp_path, name)), duration_s=SECONDS, out_dir=tmp_path / "via")
    assert result.clock is Clock.VIRTUAL, (result.clock_note, explain(result))
    assert_same_flight(direct, result)
    assert tree_of_bench(os.getpid()) == []  # its whole tree ended with the run


#: wall seconds a signalled run has to end (its stop grace is 3 s; under pytest-timeout's 120)
END_WITHIN_S = 60


def _start_cli(rig: Path, out: Path) -> subprocess.Popen[bytes]:
    return subprocess.Popen([sys.executable, "-m", "hil.cli", "run", str(rig), "-s", "hover", "--out", str(out), "-q"],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)


async def _until(predicate, proc: subprocess.Popen[bytes], timeout_s: float = 120.0) -> None:
    loop = asyncio.get_running_loop()
    give_up = loop.time() + timeout_s
    while not predicate():
        assert proc.poll() is None, proc.communicate()[0].decode(errors="replace")
        assert loop.time() < give_up, "not reached in time"
        await asyncio.sleep(0.05)


def _flying(out: Path) -> bool:
    parts = list(out.glob("*.mcap.part"))
    return bool(parts) and parts[0].stat().st_size >= 150_000


async def _interrupt(tmp_path: Path, name: str, moment: str, signals: tuple[int, ...],
                     rig: Path | None = None) -> tuple[int, str, list[tuple[int, str]], set[Path]]:
    """Start ``hil run`` with launcher ``name`` (or the given ``rig``), signal it at ``moment``;
    its status, output, the flight command's processes seen before the signal, and their run
    directories."""
    out = tmp_path / "logs"
    proc = _start_cli(rig or rig_for(tmp_path, name), out)
    try:
        if moment == "booting":  # as soon as the flight command has started
            await _until(lambda: tree_of_bench(proc.pid) != [], proc)
        else:
            await _until(lambda: _flying(out), proc)
        seen = tree_of_bench(proc.pid)
        dirs = run_dirs_of(seen)
        for k, sig in enumerate(signals):
            if k:
                await asyncio.sleep(0.2)
            proc.send_signal(sig)
        try:
            text = proc.communicate(timeout=END_WITHIN_S)[0].decode(errors="replace")
        except subprocess.TimeoutExpired as exc:
            raise AssertionError(_still_running(proc, exc.output or b"")) from None
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        left = tree_of_bench(proc.pid)
        for pid, _ in left:
            os.kill(pid, signal.SIGKILL)
    assert left == [], f"survivors {left} of {seen}"
    return proc.returncode, text, seen, dirs


def _pipe_holders(fd: int) -> list[str]:
    """Every process holding the pipe behind our ``fd`` open, with where each thread waits (from /proc)."""
    pipe = os.readlink(f"/proc/self/fd/{fd}")
    held = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            if not any(os.readlink(f) == pipe for f in (entry / "fd").iterdir()):
                continue
            cmd = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")[:200]
            waits = sorted({(t / "wchan").read_text() for t in (entry / "task").iterdir()})
            held.append(f"{entry.name} ({cmd.strip()}): threads wait in {waits}")
        except OSError:
            continue
    return held


def _still_running(proc: subprocess.Popen[bytes], said: bytes) -> str:
    """Why ``communicate`` did not return: whether hil run itself still runs, who else holds its
    output pipe open (a survivor of its tree looks the same to communicate), and what hil run
    said, with its every thread's stack on SIGQUIT (hil/flight/signals.py)."""
    status = "still runs" if proc.poll() is None else f"has exited with status {proc.returncode}"
    holders = _pipe_holders(proc.stdout.fileno()) if proc.stdout is not None else []
    if proc.poll() is None:
        proc.send_signal(signal.SIGQUIT)
    try:  # communicate's output is cumulative: from the start, not from the timeout
        said = proc.communicate(timeout=10)[0] or said
    except subprocess.TimeoutExpired as exc:
        said = exc.output or said
    return (f"hil run did not close its output {END_WITHIN_S} s after the signal: it {status}; the pipe is "
            f"held by {holders or 'no one else'}; it said:\n{said.decode(errors='replace')[-12000:]}")


@pytest.mark.parametrize("moment", ["booting", "flying"])
@pytest.mark.parametrize("name", list(TOOLS))
async def test_sigterm_ends_the_run_and_every_process_of_the_launchers_tree(tmp_path: Path, name: str,
                                                                           moment: str) -> None:
    need(name)
    rc, text, seen, dirs = await _interrupt(tmp_path, name, moment, (signal.SIGTERM,))
    assert seen, "no process of the flight command was seen"
    assert rc == 1 and "interrupted" in text, text
    (log,) = (tmp_path / "logs").glob("*.mcap")  # finalized: no .part left
    assert read_metadata(log)["verdict"]["end_reason"] == "interrupted"
    assert dirs and not any(d.exists() for d in dirs), dirs


async def test_ctrl_c_ends_a_launchers_tree_too(tmp_path: Path) -> None:
    rc, text, seen, dirs = await _interrupt(tmp_path, "sh -c", "flying", (signal.SIGINT,))
    assert rc == 1 and "interrupted" in text, text
    assert dirs and not any(d.exists() for d in dirs)


async def test_a_second_sigterm_exits_at_once_with_130_and_leaves_nothing(tmp_path: Path) -> None:
    """The launcher ignores SIGTERM and lingers after the flight code (a 60 s grace): the first
    signal's stop would take a minute; the second one cuts it short."""
    trap = tmp_path / "trap.sh"
    trap.write_text('trap "" TERM\n"$@"\nsleep 100\n')
    rig = rig_with_command(tmp_path, ["sh", str(trap), *FLIGHT], "trap-rig")
    text = rig.read_text()
    assert "barrier_timeout_s = 0.5" in text
    rig.write_text(text.replace("barrier_timeout_s = 0.5", "barrier_timeout_s = 0.5\nstop_grace_s = 60", 1))
    rc, text, seen, dirs = await _interrupt(tmp_path, "trap", "flying", (signal.SIGTERM, signal.SIGTERM), rig=rig)
    assert rc == 130, text
    assert dirs and not any(d.exists() for d in dirs)
    logs = list((tmp_path / "logs").glob("*.mcap*"))
    assert len(logs) == 1  # finalized as aborted by the recorder, or a .part for hil recover


async def test_a_launcher_the_shim_cannot_see_through_ends_the_run_with_one_sentence(fly, tmp_path: Path) -> None:
    """A Python launcher blocked in signal.pause() (not interposed): the run ends with an
    error naming it, the log finalized, its tree ended; not a silent wait."""
    launcher_code = "import signal, subprocess, sys; subprocess.Popen(sys.argv[1:]); signal.pause()"
    rig = rig_with_command(tmp_path, ["{python}", "-c", launcher_code, *FLIGHT], "pause-rig")
    result = await fly("hover", rig=str(rig), duration_s=SECONDS)
    assert result.end_reason is EndReason.ERROR, explain(result)
    assert re.fullmatch(r"process \d+ \(python3?\) of the flight command waits in pause, a call the clock shim does "
                        r"not interpose: virtual time cannot go on \(.*\)\.", result.message), result.message
    assert result.log_path is not None
    assert "waits in pause" in read_metadata(result.log_path)["verdict"]["message"]
    assert tree_of_bench(os.getpid()) == []
