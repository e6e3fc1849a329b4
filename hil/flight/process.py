"""Start and stop the flight code as its own process and capture its output.

The command line comes from the rig (any language): ``{python}`` is replaced by this
interpreter and ``{config}`` by the generated flight config. stdout and stderr are read
line by line; each line goes to ``on_line(stream, text)`` (the bench logs it to MCAP as
foxglove.Log) and the last lines are kept for the run summary.

The command may be a launcher (``sh -c``, ``make``, ``strace``, ``gdb``): every process it
starts belongs to the run and is ended with it (:mod:`hil.flight.process_tree`).
"""

from __future__ import annotations

import asyncio
import collections
import os
import secrets
import signal
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from hil.flight.process_tree import TOKEN_ENV, TreeOwner, end_cancelled_start
from hil.flight.signals import on_hard_exit
from hil.flight.spawn import uncancelled_start
from hil.vtime.tree import ProcState

LineCallback = Callable[[str, str], None]
#: wall seconds to wait for the output pipes to end once the command's own process exited and
#: no other process of its tree is left (they end at once; the bound guards a hidden holder)
DRAIN_S = 1.0
#: the rig's ``[flight] stop_grace_s`` default: wall seconds between SIGTERM and SIGKILL
STOP_GRACE_S = 3.0

PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:
    """In the child, before exec: get SIGKILL when the bench dies (even by SIGKILL), so a
    killed bench never leaves a flight code running on vanished ports."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except OSError:
        pass


class _Protocol(asyncio.subprocess.SubprocessStreamProtocol):
    """The subprocess's protocol, telling when the command's own process has exited: asyncio's
    ``Process.wait()`` returns only once its output pipes are closed too, and a launcher's
    children may hold them after it exited."""

    def __init__(self, exited: asyncio.Event, loop: asyncio.AbstractEventLoop) -> None:
        super().__init__(limit=2**16, loop=loop)
        self._exited = exited

    def process_exited(self) -> None:
        super().process_exited()
        self._exited.set()


def expand_command(template: Sequence[str], *, config: Path) -> list[str]:
    """Substitute ``{python}`` and ``{config}`` in the rig's command template."""
    return [part.replace("{python}", sys.executable).replace("{config}", str(config)) for part in template]


class FlightProcess:
    """The flight code subprocess."""

    def __init__(self, argv: list[str], *, cwd: Path, on_line: LineCallback, keep_lines: int = 20,
                 env: dict[str, str] | None = None, stop_grace_s: float = STOP_GRACE_S) -> None:
        self.argv = argv
        self.cwd = cwd
        self.on_line = on_line
        #: added to the bench's environment at every start (the clock shim's, for one)
        self.env = dict(env or {})
        #: called with the pid after every start, and with the pid when that process is gone
        self.on_start: list[Callable[[int], None]] = []
        self.on_exit: list[Callable[[int], None]] = []
        #: a restart's new process is due (sim time) but not started yet
        self.starting = False
        self.last_stderr: collections.deque[str] = collections.deque(maxlen=keep_lines)
        self.proc: asyncio.subprocess.Process | None = None
        self._readers: list[asyncio.Task[None]] = []
        self.exited = asyncio.Event()
        self._watcher: asyncio.Task[None] | None = None
        self.killed_by_bench = False
        self.stop_grace_s = stop_grace_s
        #: every process of the current start's tree (None before the first start)
        self.owner: TreeOwner | None = None
        self._forget_hard_exit: Callable[[], None] = lambda: None
        #: processes of the tree still there after SIGKILL (stuck in the kernel), from the last stop
        self.survivors: list[ProcState] = []

    async def start(self, extra_env: dict[str, str] | None = None) -> None:
        env = dict(os.environ)
        env.setdefault("PYTHONUNBUFFERED", "1")
        env.update(self.env)
        if extra_env:
            env.update(extra_env)
        token = f"{os.getpid()}-{secrets.token_hex(8)}"
        env[TOKEN_ENV] = token  # finds the tree's orphans that left its session
        TreeOwner.hold()  # this process reaps the tree's orphans from now
        loop = asyncio.get_running_loop()
        root_exited = asyncio.Event()
        spawn = asyncio.ensure_future(loop.subprocess_exec(
            lambda: _Protocol(root_exited, loop),
            *self.argv,
            cwd=self.cwd,
            stdin=asyncio.subprocess.DEVNULL,
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.PIPE,
            env=env,
            start_new_session=True,  # its own group: Ctrl-C in the terminal reaches the bench only
            preexec_fn=_die_with_parent,
        ))
        try:
            transport, protocol = await uncancelled_start(spawn)
        except BaseException:
            try:
                await end_cancelled_start(token)
            finally:
                TreeOwner.release()
            raise
        self.proc = asyncio.subprocess.Process(transport, protocol, loop)
        self.owner = TreeOwner(self.proc.pid, token)
        self._forget_hard_exit = on_hard_exit(self.owner.kill_now)
        assert self.proc.stdout is not None and self.proc.stderr is not None
        self._readers = [
            asyncio.create_task(self._pump(self.proc.stdout, "stdout")),
            asyncio.create_task(self._pump(self.proc.stderr, "stderr")),
        ]
        # keep a reference: the loop holds tasks weakly, and this one sets ``exited``
        self._watcher = asyncio.create_task(self._watch(self.proc, root_exited, self.owner, list(self._readers)))
        for hook in self.on_start:
            hook(self.proc.pid)

    async def _pump(self, stream: asyncio.StreamReader, name: str) -> None:
        while True:
            raw = await stream.readline()
            if not raw:
                return
            text = raw.decode("utf-8", "replace").rstrip("\n")
            if name == "stderr":
                self.last_stderr.append(text)
            self.on_line(name, text)

    async def _watch(self, proc: asyncio.subprocess.Process, root_exited: asyncio.Event, owner: TreeOwner,
                     readers: list[asyncio.Task[None]]) -> None:
        await root_exited.wait()
        for hook in self.on_exit:
            hook(proc.pid)
        # Its output ends when every process holding the pipes has exited. A launcher's
        # children may outlive it (``stop`` ends them): then its last lines are not waited for.
        if not owner.live():
            await asyncio.wait(readers, timeout=DRAIN_S)
        # a restart swaps in a private event before the kill: set whichever is current
        self.exited.set()

    def tree_pids(self) -> list[int]:
        """Every process of the current start's tree (the command's own first)."""
        return self.owner.tree.discover({}) if self.owner is not None else []

    @property
    def pid(self) -> int | None:
        return self.proc.pid if self.proc else None

    @property
    def returncode(self) -> int | None:
        return self.proc.returncode if self.proc else None

    @property
    def running(self) -> bool:
        return self.proc is not None and self.proc.returncode is None

    def kill(self) -> None:
        """SIGKILL now, to every process of the command (fault injection: the flight code killed)."""
        if self.running and self.owner is not None:
            self.killed_by_bench = True
            self.owner.kill_now()

    def begin_start(self) -> None:
        """A restart's downtime is over: its new process counts as running from now (the
        bench waits for it instead of ticking on), though it is started a moment later."""
        self.starting = True

    async def restart(self, extra_env: dict[str, str] | None = None, *, resume: asyncio.Event | None = None) -> None:
        """Kill the flight code (if it runs) and start the same argv again.

        A restart is not an exit: the ``exited`` event the bench waits on is not set for the
        killed process (its watcher reports to a private event meanwhile). ``resume``: wait
        for it between the kill and the new start (the fault's downtime); meanwhile
        ``self.exited`` is that private event (set once the old process is reaped), so
        ``stop()`` returns at once. Cancelled before the new start, or if the start fails,
        the flight code stays dead and ``exited`` is set.
        """
        real = self.exited
        gone = asyncio.Event()
        if self.proc is not None and not real.is_set():
            self.exited = gone  # the old process's _watch sets this one
            if self.owner is not None:
                self.owner.kill_now()
        else:
            gone.set()
        try:
            await gone.wait()
            await self._end_tree(0.0)  # the old tree's other processes too, before the new start
            if resume is not None:
                await resume.wait()
        except asyncio.CancelledError:
            self.exited = real
            self.starting = False
            real.set()
            raise
        self.exited = real
        real.clear()
        try:
            await self.start(extra_env)
        except BaseException:
            real.set()  # it could not be started again: that is an exit
            raise
        finally:
            self.starting = False

    async def _end_tree(self, grace_s: float) -> None:
        """End every process of the current start: SIGTERM to the group and every member,
        ``grace_s`` to exit, SIGKILL to the rest (hil/flight/process_tree.py)."""
        owner, proc = self.owner, self.proc
        if owner is None or proc is None:
            return
        self.survivors = await owner.end(grace_s, lambda: proc.returncode is not None)
        self._forget_hard_exit()
        owner.close()
        self.owner = None

    async def stop(self, grace_s: float | None = None) -> int | None:
        """End the command's whole process tree (SIGTERM, ``grace_s``, default the rig's
        ``stop_grace_s``, then SIGKILL), take its last output lines; returns the exit status
        of the command's own process."""
        if self.proc is None:
            return None
        await self._end_tree(self.stop_grace_s if grace_s is None else grace_s)
        await self.exited.wait()  # set once the root is reaped (done above) and its output drained
        if self._readers:
            # every writer is gone: the pipes are at their end (bounded: a holder outside the tree)
            _, pending = await asyncio.wait(self._readers, timeout=DRAIN_S)
            for task in pending:
                task.cancel()
        return self.proc.returncode
