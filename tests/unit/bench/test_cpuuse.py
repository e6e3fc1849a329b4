"""The CPU of a run's other processes (hil/host/cpuuse.py): read from /proc, over a stretch, and
refused where the process was not there at both ends or was replaced."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from hil.host.cpuuse import ChildCpu, process_cpu_ns

TICK_NS = 1_000_000_000 // os.sysconf("SC_CLK_TCK")


def _fake_proc(root: Path, pid: int, comm: str, utime: int, stime: int) -> Path:
    (root / str(pid)).mkdir(parents=True, exist_ok=True)
    rest = ["S", "1", "1", "1", "0", "-1", "4194560", "100", "0", "0", "0", str(utime), str(stime)] + ["0"] * 30
    (root / str(pid) / "stat").write_text(f"{pid} ({comm}) " + " ".join(rest) + "\n")
    return root


def test_user_and_system_time_of_a_process(tmp_path: Path) -> None:
    proc = _fake_proc(tmp_path, 42, "python3", 150, 25)
    assert process_cpu_ns(42, proc) == 175 * TICK_NS


def test_a_command_name_with_spaces_and_parentheses(tmp_path: Path) -> None:
    proc = _fake_proc(tmp_path, 7, "a) b (c", 3, 4)
    assert process_cpu_ns(7, proc) == 7 * TICK_NS


@pytest.mark.parametrize("pid", [None, 999_999_999])
def test_no_such_process(pid: int | None) -> None:
    assert process_cpu_ns(pid) is None


def test_this_process_on_the_real_proc() -> None:
    before = process_cpu_ns(os.getpid())
    assert before is not None
    sum(i * i for i in range(2_000_000))  # some tens of ms of CPU
    after = process_cpu_ns(os.getpid())
    assert after is not None and after >= before


def test_the_cpu_a_child_used_between_start_and_stop() -> None:
    child = subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.read(); sum(i * i for i in range(30_000_000))"],
                             stdin=subprocess.PIPE)
    try:
        meter = ChildCpu(lambda: child.pid)
        meter.start()
        assert child.stdin is not None
        child.stdin.close()  # now it computes
        while child.poll() is None and (process_cpu_ns(child.pid) or 0) < 20 * TICK_NS:
            pass
        used = meter.stop()
        assert used is not None and used >= 20 * TICK_NS
    finally:
        child.kill()
        child.wait()


def test_none_when_the_process_was_replaced_or_never_there(tmp_path: Path) -> None:
    proc = _fake_proc(tmp_path, 10, "fc", 5, 5)
    _fake_proc(proc, 11, "fc", 9, 9)
    pid = [10]
    meter = ChildCpu(lambda: pid[0], proc)
    meter.start()
    pid[0] = 11  # a restart: another process now
    assert meter.stop() is None
    absent = ChildCpu(lambda: None, proc)
    absent.start()
    assert absent.stop() is None
    assert ChildCpu(lambda: 10, proc).stop() is None  # never started


def test_none_when_the_process_is_gone_at_the_end(tmp_path: Path) -> None:
    proc = _fake_proc(tmp_path, 10, "fc", 5, 5)
    meter = ChildCpu(lambda: 10, proc)
    meter.start()
    (proc / "10" / "stat").unlink()
    assert meter.stop() is None


def test_a_launchers_children_are_counted_with_it(tmp_path: Path) -> None:
    """``sh -c`` waits while its child flies: the child's CPU between the ends is the flight
    code's (one that started in between counts whole, one gone at the end does not)."""
    proc = _fake_proc(tmp_path, 10, "sh", 1, 1)
    _fake_proc(proc, 11, "python3", 100, 10)
    _fake_proc(proc, 12, "helper", 4, 0)
    others = [11, 12]
    meter = ChildCpu(lambda: 10, proc, others=lambda: others)
    meter.start()
    _fake_proc(proc, 10, "sh", 1, 2)  # +1
    _fake_proc(proc, 11, "python3", 150, 20)  # +60
    (proc / "12" / "stat").unlink()  # exited: not counted
    _fake_proc(proc, 13, "late", 3, 0)  # started in between: +3
    others[:] = [10, 11, 13]  # the root among the others is not counted twice
    assert meter.stop() == 64 * TICK_NS
