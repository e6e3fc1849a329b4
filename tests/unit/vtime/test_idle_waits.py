"""How the virtual-time scheduler waits for the flight code to go idle: inline (no turn of the
event loop) while that is safe, through the event loop otherwise, and never so long inline
that the loop's own timers (the stall warning) or process exits go unserved."""

from __future__ import annotations

import ast
import asyncio
import os
import sys
from pathlib import Path

import pytest

from hil.transport.pty import PtyPort
from hil.vtime.control import ControlBlock
from hil.vtime.preload import shim_library
from hil.vtime.scheduler import VirtualClock
from hil.vtime.stall import Stall
from tests.unit.vtime.harness import run_virtual

pytestmark = pytest.mark.pty

S = 1_000_000_000
ECHOES = 20


async def test_an_echo_client_is_waited_for_inline_and_sees_every_byte_on_sim_time(tmp_path: Path) -> None:
    """A client that answers each byte after some computing (as the flight code answers each
    IMU sample): the scheduler waits for each answer without the event loop, and the run is
    the same as ever."""
    port = PtyPort("imu", tmp_path)
    got: list[bytes] = []
    port.on_data = lambda data, t_ns: got.append(data)
    await port.start()
    code = f"""
import serial, time
s = serial.Serial({port.path!r}, 115200, timeout=1.0)
seen = []
for _ in range({ECHOES}):
    b = s.read(1)
    seen.append((b, time.monotonic_ns()))
    sum(range(200_000))  # computes (host ms, no sim time): the bench must wait for the answer
    s.write(b)
print(repr([(b, t - seen[0][1]) for b, t in seen]))
"""
    at = {k * S // 100: (lambda k=k: port.write(bytes([65 + k]))) for k in range(ECHOES)}
    try:
        out = await run_virtual([sys.executable, "-c", code], ports={"imu": port}, at=at, inline_wait_s=1.0)
    finally:
        port.close()
    assert out.returncode == 0, out.stderr
    seen = ast.literal_eval(out.stdout.strip())
    assert [b for b, _ in seen] == [bytes([65 + k]) for k in range(ECHOES)]
    assert [t for _, t in seen] == [k * S // 100 for k in range(ECHOES)]  # each byte read at its sim time
    assert b"".join(got) == bytes(65 + k for k in range(ECHOES))
    # The answers end waits made inline, not turns of the event loop. How many waits a run
    # makes is the host's business (on a loaded machine an answer is often there before the
    # bench looks: 10-17 inline and 2 through the loop beside CPU hogs, 27-32 and 6-8 on an
    # idle one); bench_vtime.py measures the cost. Without the inline path every wait is a
    # turn of the loop.
    assert out.inline_waits > out.loop_waits, (out.inline_waits, out.loop_waits)


async def test_the_event_loop_gets_its_turns_while_every_wait_goes_inline(tmp_path: Path) -> None:
    """A run whose waits all go inline still yields to the event loop every 10 ms: other
    tasks (a test's own code, a stop, process exits) are not starved until the run ends."""
    port = PtyPort("imu", tmp_path)
    await port.start()
    code = f"""
import serial
s = serial.Serial({port.path!r}, 115200, timeout=1.0)
for _ in range({ECHOES}):
    b = s.read(1)
    sum(range(200_000))  # a few ms of computing per answer: the waits add up past 10 ms
    s.write(b)
"""
    turns = [0]

    async def count_turns() -> None:
        while True:
            turns[0] += 1
            await asyncio.sleep(0)

    seen: dict[int, int] = {}
    at = {k * S // 100: (lambda k=k: (seen.__setitem__(k, turns[0]), port.write(b"x"))) for k in range(ECHOES)}
    counter = asyncio.ensure_future(count_turns())
    try:
        out = await run_virtual([sys.executable, "-c", code], ports={"imu": port}, at=at, inline_wait_s=1.0)
    finally:
        counter.cancel()
        port.close()
    assert out.returncode == 0, out.stderr
    # nine answers, each computed for milliseconds, were waited for between these two
    assert seen[ECHOES - 1] > seen[10], seen


async def test_bytes_queued_for_a_slow_client_move_during_inline_waits(tmp_path: Path) -> None:
    """What the kernel would not take waits in the port's queue; while the scheduler waits
    inline (the event loop's writer callback does not run), it moves them as room appears."""
    port = PtyPort("imu", tmp_path)
    await port.start()
    ctl = ControlBlock(tmp_path)
    vc = VirtualClock(ctl, {"imu": port})
    data = bytes(range(256)) * 80  # 20 kB: more than the pty holds
    got = bytearray()
    try:
        port.write(data)
        assert port.writes_pending
        while port.writes_pending:
            got += os.read(port.slave_fd, 65536)  # the client reads: room in the pty again
            assert vc._wait_inline()  # the queue moved on without the event loop
        while len(got) < len(data):
            got += os.read(port.slave_fd, 65536)
        assert bytes(got) == data and port.stats.overflow_bytes == 0
        assert vc.inline_waits >= 1
    finally:
        vc.close()
        ctl.close()
        port.close()


async def test_a_flight_code_that_never_idles_gets_the_stall_warning_and_its_exit_ends_the_wait(
        tmp_path: Path) -> None:
    """Inline waits give the event loop its turn: the stall timer fires while the program
    spins, and its exit (noticed by the loop's child watcher) ends the wait."""
    ctl = ControlBlock(tmp_path)
    library = shim_library()
    assert isinstance(library, Path), library
    stalled = asyncio.Event()
    stalls: list[Stall] = []

    def on_stall(stall: Stall) -> None:
        stalls.append(stall)
        stalled.set()

    vc = VirtualClock(ctl, {}, stall_warn_s=0.2, on_stall=on_stall)
    vc.start(0)
    proc = await asyncio.create_subprocess_exec(sys.executable, "-c", "while True: pass",
                                                env=dict(os.environ) | ctl.env(library))
    try:
        vc.attach(proc.pid)
        exited = asyncio.ensure_future(proc.wait())
        exited.add_done_callback(lambda _: vc.process_gone(proc.pid))
        waiting = asyncio.ensure_future(vc.idle(lambda: proc.returncode is None))
        await asyncio.wait_for(stalled.wait(), 60)
        assert not waiting.done()  # a stall is reported, not an error: the wait goes on
        assert len(stalls) == 1 and stalls[0].waited_s == 0.2
        proc.kill()
        assert await asyncio.wait_for(waiting, 60) is False
        assert vc.loop_waits >= 1
    finally:
        if proc.returncode is None:
            proc.kill()
        await proc.wait()
        vc.close()
        ctl.close()


async def test_the_harness_removes_its_run_directory_when_setup_fails(monkeypatch: pytest.MonkeyPatch,
                                                                      tmp_path: Path) -> None:
    """A setup failure (here: no clock shim) must not leave the harness's directory behind."""
    import tempfile

    import tests.unit.vtime.harness as harness

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.setattr(harness, "shim_library", lambda: "no shim here")
    with pytest.raises(AssertionError, match="no shim here"):
        await run_virtual([sys.executable, "-c", "pass"])
    assert list(tmp_path.iterdir()) == []
