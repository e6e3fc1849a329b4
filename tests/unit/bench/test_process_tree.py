"""The bench owns the flight command's whole process tree (hil/flight/process_tree.py): a stop
ends every process the command started, whatever it did (outlived its launcher, ignored
SIGTERM, left the session), and nothing is left, as /proc shows."""

from __future__ import annotations

import asyncio
import ctypes
import os
import sys
from pathlib import Path

import pytest

from hil.flight.process import FlightProcess
from hil.vtime.tree import read_stat
from tests.proc_token import with_token

PR_GET_CHILD_SUBREAPER = 37
PY = sys.executable
SLEEPER = f"{PY} -c 'import time; time.sleep(120)'"
#: a process that ignores SIGTERM (it must be SIGKILLed after the grace)
STUBBORN = f"{PY} -c 'import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); time.sleep(120)'"


def tree_of(flight: FlightProcess) -> list[int]:
    """Every live process carrying this start's token (found through /proc, whoever its parent)."""
    assert flight.owner is not None
    return tagged(flight.owner.token)


def tagged(token: str) -> list[int]:
    return [pid for pid, _ in with_token(token)]


def ignores_sigterm(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/status") as f:
            mask = next(int(line.split()[1], 16) for line in f if line.startswith("SigIgn:"))
    except (OSError, StopIteration):
        return False
    return bool(mask & (1 << 14))  # SIGTERM is 15: bit 14


def subreaper() -> int:
    value = ctypes.c_int(-1)
    ctypes.CDLL(None, use_errno=True).prctl(PR_GET_CHILD_SUBREAPER, ctypes.byref(value), 0, 0, 0)
    return value.value


async def started(script: str, tmp_path: Path, n: int) -> tuple[FlightProcess, str]:
    """``sh -c script`` started as the flight command, once ``n`` of its processes are up."""
    lines: list[str] = []
    flight = FlightProcess(["sh", "-c", script], cwd=tmp_path, on_line=lambda stream, line: lines.append(line))
    await flight.start()
    assert flight.owner is not None
    token = flight.owner.token
    loop = asyncio.get_running_loop()
    give_up = loop.time() + 30
    while len(tagged(token)) < n:
        assert loop.time() < give_up, f"only {tagged(token)} of {n} processes started"
        await asyncio.sleep(0.02)
    return flight, token


async def test_stop_ends_every_process_the_command_started(tmp_path: Path) -> None:
    flight, token = await started(f"{SLEEPER} & {SLEEPER} & {SLEEPER}; echo done", tmp_path, 4)
    assert subreaper() == 1  # while a flight runs, its orphans come to the bench
    await asyncio.wait_for(flight.stop(grace_s=5.0), 30)
    assert tagged(token) == [] and flight.owner is None
    assert subreaper() == 0  # and not after


async def test_a_process_that_ignores_sigterm_is_killed_after_the_grace(tmp_path: Path) -> None:
    flight, token = await started(f"{STUBBORN} & {SLEEPER}", tmp_path, 3)
    loop = asyncio.get_running_loop()
    while not any(ignores_sigterm(pid) for pid in tagged(token)):  # its handler is set
        await asyncio.sleep(0.02)
    t0 = loop.time()
    await asyncio.wait_for(flight.stop(grace_s=0.5), 30)
    assert tagged(token) == []
    assert loop.time() - t0 >= 0.5  # it had its grace, then SIGKILL


async def test_an_orphan_that_left_the_session_is_found_and_ended(tmp_path: Path) -> None:
    """A daemon's double fork: the launcher exits at once, its child starts a session of its
    own; the bench, as subreaper, becomes its parent and still ends it."""
    flight, token = await started(f"setsid {STUBBORN} & exit 0", tmp_path, 1)
    await asyncio.wait_for(flight.exited.wait(), 30)  # the launcher is gone, its pipes held by the orphan
    (orphan,) = tagged(token)
    # /proc shows the forked child before it has exec'd setsid and left the session: wait for that
    # state change itself (bounded), not for a guessed time
    loop = asyncio.get_running_loop()
    deadline = loop.time() + 30
    st = read_stat(orphan)
    while st is not None and st.session != orphan and loop.time() < deadline:
        await asyncio.sleep(0.005)
        st = read_stat(orphan)
    assert st is not None and st.ppid == os.getpid() and st.session == orphan
    await asyncio.wait_for(flight.stop(grace_s=0.5), 30)
    assert tagged(token) == []
    assert read_stat(orphan) is None  # reaped by the bench, not left a zombie


async def test_the_kill_fault_ends_the_whole_tree(tmp_path: Path) -> None:
    flight, token = await started(f"{SLEEPER}; echo done", tmp_path, 2)
    flight.kill()
    await asyncio.wait_for(flight.exited.wait(), 30)
    assert flight.returncode == -9 and flight.killed_by_bench
    await asyncio.wait_for(flight.stop(), 30)
    assert tagged(token) == []


async def test_a_start_that_fails_gives_the_subreaper_back(tmp_path: Path) -> None:
    before = subreaper()
    flight = FlightProcess([str(tmp_path / "no-such-program")], cwd=tmp_path, on_line=lambda s, l: None)
    with pytest.raises(FileNotFoundError):
        await flight.start()
    assert subreaper() == before == 0


async def test_a_start_cancelled_while_asyncio_starts_the_command_leaves_nothing(tmp_path: Path,
                                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """A Ctrl-C or SIGTERM while asyncio is still connecting the command's pipes: asyncio kills
    the command's own process and re-raises, but what the command had started already (make's
    flight code) outlived it, owned by the bench with nobody to end it, and the run hung. The
    cancel is played here where asyncio takes it, once the launcher's children are up."""
    loop = asyncio.get_running_loop()
    real = loop.subprocess_exec

    async def cancelled_while_connecting(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        transport, _ = await real(*args, **kwargs)
        give_up = loop.time() + 30
        while len(with_token(f"{os.getpid()}-")) < 3:
            assert loop.time() < give_up
            await asyncio.sleep(0.02)
        transport.close()  # what asyncio does on a cancel there: SIGKILL to the command's own process
        raise asyncio.CancelledError

    monkeypatch.setattr(loop, "subprocess_exec", cancelled_while_connecting)
    flight = FlightProcess(["sh", "-c", f"{STUBBORN} & {SLEEPER} & wait"], cwd=tmp_path, on_line=lambda s, l: None)
    with pytest.raises(asyncio.CancelledError):
        await flight.start()
    assert with_token(f"{os.getpid()}-") == []
    assert subreaper() == 0


@pytest.mark.parametrize("steps", [1, 2, 3, 4, 6])
async def test_a_start_cancelled_at_any_step_of_asyncio_connecting_the_pipes_ends(tmp_path: Path, steps: int) -> None:
    """The real ``subprocess_exec``, cancelled ``steps`` loop iterations into the start (after
    the fork, while asyncio connects stdout and stderr). Python 3.11's asyncio then waits, in
    its own clean-up, for the pipes that were never connected to close (CPython gh-125502,
    gh-103847): the start never ended, and a SIGTERM at a launcher's boot hung ``hil run``
    (its one task cancelling, the event loop idle). The start must end, leaving nothing."""
    flight = FlightProcess(["sh", "-c", f"{SLEEPER} & wait"], cwd=tmp_path, on_line=lambda s, l: None)
    start = asyncio.create_task(flight.start())
    for _ in range(steps):
        await asyncio.sleep(0)
    start.cancel()
    done, _ = await asyncio.wait([start], timeout=20)  # a bound on a hang, not a timing claim
    if not done:
        start.cancel()  # asyncio's wait for the pipes is cancellable: free the test
        await asyncio.wait([start], timeout=5)
    assert done, f"start() cancelled {steps} loop steps in never ended"
    if not start.cancelled():  # the start won the race: it owns a running command to stop
        assert start.exception() is None
        await flight.stop()
    assert with_token(f"{os.getpid()}-") == []
    assert subreaper() == 0


@pytest.mark.parametrize("steps", [1, 2, 3])
async def test_the_flight_check_cancelled_while_it_starts_ends_with_its_group(tmp_path: Path, steps: int) -> None:
    """The flight code's own config check (hil/flight/flight_check.py) is started the same way
    and ends the same way: a cancel in its start ends it, its launcher's children too."""
    from hil.flight.flight_check import _ask

    marker = f"check-{os.getpid()}-{steps}"
    ask = asyncio.create_task(_ask(["sh", "-c", f"{PY} -c 'import time; time.sleep(120)' {marker} & wait"]))
    for _ in range(steps):
        await asyncio.sleep(0)
    ask.cancel()
    done, _ = await asyncio.wait([ask], timeout=20)  # a bound on a hang, not a timing claim
    assert done, f"the check cancelled {steps} loop steps in never ended"
    loop = asyncio.get_running_loop()
    give_up = loop.time() + 10
    while _with_arg(marker):  # SIGKILLed: gone as soon as the kernel reaps it
        assert loop.time() < give_up, _with_arg(marker)
        await asyncio.sleep(0.02)


def _with_arg(arg: str) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        try:
            if entry.name.isdigit() and arg.encode() in (entry / "cmdline").read_bytes().split(b"\0"):
                found.append(int(entry.name))
        except OSError:
            continue
    return found
