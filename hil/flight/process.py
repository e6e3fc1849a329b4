"""Start and stop the flight code as its own process and capture its output.

The command line comes from the rig (any language): ``{python}`` is replaced by this
interpreter and ``{config}`` by the generated flight config. stdout and stderr are read
line by line; each line goes to ``on_line(stream, text)`` (the bench logs it to MCAP as
foxglove.Log) and the last lines are kept for the run summary.
"""

from __future__ import annotations

import asyncio
import collections
import os
import signal
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

LineCallback = Callable[[str, str], None]

PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:
    """In the child, before exec: get SIGKILL when the bench dies (even by SIGKILL), so a
    killed bench never leaves a flight code running on vanished ports."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except OSError:
        pass


def expand_command(template: Sequence[str], *, config: Path) -> list[str]:
    """Substitute ``{python}`` and ``{config}`` in the rig's command template."""
    return [part.replace("{python}", sys.executable).replace("{config}", str(config)) for part in template]


class FlightProcess:
    """The flight code subprocess."""

    def __init__(self, argv: list[str], *, cwd: Path, on_line: LineCallback, keep_lines: int = 20,
                 env: dict[str, str] | None = None) -> None:
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

    async def start(self, extra_env: dict[str, str] | None = None) -> None:
        env = dict(os.environ)
        env.setdefault("PYTHONUNBUFFERED", "1")
        env.update(self.env)
        if extra_env:
            env.update(extra_env)
        self.proc = await asyncio.create_subprocess_exec(
            *self.argv,
            cwd=self.cwd,
            stdin=asyncio.subprocess.DEVNULL,
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.PIPE,
            env=env,
            start_new_session=True,  # Ctrl-C in the terminal reaches the bench only
            preexec_fn=_die_with_parent,
        )
        assert self.proc.stdout is not None and self.proc.stderr is not None
        self._readers = [
            asyncio.create_task(self._pump(self.proc.stdout, "stdout")),
            asyncio.create_task(self._pump(self.proc.stderr, "stderr")),
        ]
        # keep a reference: the loop holds tasks weakly, and this one sets ``exited``
        self._watcher = asyncio.create_task(self._watch())
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

    async def _watch(self) -> None:
        assert self.proc is not None
        proc = self.proc
        await proc.wait()
        for hook in self.on_exit:
            hook(proc.pid)
        await asyncio.gather(*self._readers, return_exceptions=True)
        # a restart swaps in a private event before the kill: set whichever is current
        self.exited.set()

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
        """SIGKILL now (fault injection: the flight code killed)."""
        if self.running:
            assert self.proc is not None
            self.killed_by_bench = True
            self.proc.kill()

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
            if self.running:
                self.proc.kill()
        else:
            gone.set()
        try:
            await gone.wait()
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

    async def stop(self, timeout_s: float = 3.0) -> int | None:
        """SIGTERM, then SIGKILL after ``timeout_s``; returns the exit status."""
        if self.proc is None:
            return None
        if self.running:
            try:
                self.proc.send_signal(signal.SIGTERM)
            except ProcessLookupError:
                pass
            try:
                await asyncio.wait_for(self.exited.wait(), timeout_s)
            except TimeoutError:
                self.kill()
                await self.exited.wait()
        else:
            await self.exited.wait()
        return self.proc.returncode
