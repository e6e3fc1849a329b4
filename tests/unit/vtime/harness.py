"""Run a program under the clock shim with a minimal scheduler (no devices, no plant).

``run_virtual(argv)`` starts the program with the shim preloaded, then repeatedly waits
until it is idle and moves sim time to its earliest deadline, until it exits. Optional
``ports`` (PtyPorts) let the program wait on ptys the test writes to at chosen sim times
(``at``: sim ns -> callable run when sim time reaches it, before the program's deadlines
at the same instant are ended).
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import signal
import shutil
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from hil.transport.pty import PtyPort
from hil.vtime.control import ControlBlock
from hil.vtime.preload import shim_library
from hil.vtime.scheduler import INLINE_WAIT_S, VirtualClock
from hil.vtime.stall import Stall


@dataclass
class Outcome:
    returncode: int
    stdout: str
    stderr: str
    calls: dict[str, int]
    uncovered: dict[str, int]
    times_ns: list[int] = field(default_factory=list)  #: sim times the scheduler moved to
    cpu_ns: int = 0
    inline_waits: int = 0  #: idle waits made without a turn of the event loop
    loop_waits: int = 0


async def run_virtual(
    argv: list[str],
    *,
    ports: Mapping[str, PtyPort] | None = None,
    at: Mapping[int, Callable[[], None]] | None = None,
    limit_ns: int = 60 * 10**9,
    spin_limit: int = 100_000,
    run_dir: Path | None = None,
    inline_wait_s: float = INLINE_WAIT_S,
    stall_warn_s: float = 5.0,
    stalls: list[Stall] | None = None,
) -> Outcome:
    """``stall_warn_s``: the scheduler's stall warning (and the first look for a process the
    shim cannot see, which raises ``HiddenWait`` once confirmed); each stall is appended to
    ``stalls``."""
    own = run_dir is None
    run_dir = run_dir or Path(tempfile.mkdtemp(prefix="hil-vt-test-"))
    try:  # the directory goes whatever fails, setup included (a missing shim, a bad argv)
        return await _run_in(argv, run_dir, ports=ports, at=at, limit_ns=limit_ns, spin_limit=spin_limit,
                             inline_wait_s=inline_wait_s, stall_warn_s=stall_warn_s, stalls=stalls)
    finally:
        if own:
            shutil.rmtree(run_dir, ignore_errors=True)


async def _run_in(
    argv: list[str],
    run_dir: Path,
    *,
    ports: Mapping[str, PtyPort] | None,
    at: Mapping[int, Callable[[], None]] | None,
    limit_ns: int,
    spin_limit: int,
    inline_wait_s: float,
    stall_warn_s: float,
    stalls: list[Stall] | None,
) -> Outcome:
    os.chmod(run_dir, 0o700)
    library = shim_library()
    assert isinstance(library, Path), library
    ctl = ControlBlock(run_dir, spin_limit=spin_limit)
    env = dict(os.environ) | ctl.env(library)
    vc = VirtualClock(ctl, ports or {}, inline_wait_s=inline_wait_s, stall_warn_s=stall_warn_s,
                      on_stall=stalls.append if stalls is not None else None)
    vc.library = str(library)
    vc.start(0)
    proc = await asyncio.create_subprocess_exec(
        *argv, env=env, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE, stdin=asyncio.subprocess.DEVNULL,
        start_new_session=True,
    )
    vc.attach(proc.pid)
    out_task = asyncio.ensure_future(proc.communicate())
    out_task.add_done_callback(lambda _: vc.process_gone(proc.pid))
    events = dict(sorted((at or {}).items()))
    times: list[int] = []
    cpu = 0
    running = lambda: proc.returncode is None and not out_task.done()  # noqa: E731
    try:
        while running():
            if not await vc.idle(running):
                break
            cpu += vc.cpu_ns()
            deadline = vc.next_deadline()
            nxt = min([d for d in (deadline, *events) if d is not None], default=None)
            if nxt is None or nxt > limit_ns:
                break  # idle for ever: the program waits on something we will not provide
            vc.set_time(nxt)
            times.append(nxt)
            action = events.pop(nxt, None)
            if action is not None:
                action()
                vc.flush_written()
            vc.wake_due()
        stdout, stderr = await asyncio.wait_for(out_task, 30)
    finally:
        # the whole group (its own): a launcher's children hold the output pipes, and asyncio's
        # wait() returns only once those are closed
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        await proc.wait()
        calls, uncovered = ctl.calls(), ctl.uncovered()
        vc.close()
        ctl.close()
    return Outcome(proc.returncode or 0, stdout.decode(), stderr.decode(), calls, uncovered, times, cpu,
                   vc.inline_waits, vc.loop_waits)
