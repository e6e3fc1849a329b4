"""What ``hil build`` shows while it works: a bar on a terminal, a line every 10 s on a pipe.

The build's first step (mypy's type check and mypyc's C) takes 10-20 s before the count of
extension modules is known; the compile takes minutes, and one large group (``--groups one``)
compiles as one C file, on one core, for 5-9 minutes with nothing to count. Neither may leave
the user looking at a silent terminal: the bar's spinner and elapsed time move on their own,
and on a pipe a heartbeat thread prints what is being done at least every 10 s.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from types import TracebackType

from rich.console import Console
from rich.table import Column
from rich.progress import (BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TaskID, TextColumn,
                           TimeElapsedColumn)

from hil import clock

#: plain-line mode: a line at each phase change, and one at least every this many seconds
LINE_EVERY_S = 10.0


def _now_s() -> float:
    return clock.monotonic_ns() / 1e9


class BuildProgress:
    def __init__(self, console: Console, *, now: Callable[[], float] = _now_s, heartbeat: bool = True) -> None:
        self._console = console
        self._now = now
        self._heartbeat = heartbeat
        self._bar: Progress | None = None
        self._task: TaskID | None = None
        self._last_line = 0.0
        self._started = 0.0
        self._total = 0
        self._done = 0
        self._doing = "type-checking and generating C (mypyc)"
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def __enter__(self) -> BuildProgress:
        self._started = self._now()
        if self._console.is_terminal:
            # the description last, wrapping: a long one must not squeeze out the elapsed time
            self._bar = Progress(SpinnerColumn(), TimeElapsedColumn(), BarColumn(bar_width=20), MofNCompleteColumn(),
                                 TextColumn("{task.description}", table_column=Column(ratio=1)),
                                 console=self._console, transient=True)
            self._bar.start()
            self._task = self._bar.add_task(self._doing, total=None)
        else:
            self._line(self._doing)
            if self._heartbeat:
                self._thread = threading.Thread(target=self._beat, name="hil-build-progress", daemon=True)
                self._thread.start()
        return self

    def update(self, done: int, total: int) -> None:
        """``done`` of ``total`` extension modules started (0 of N: the C is ready)."""
        with self._lock:
            if total != self._total and self._doing.startswith("type-checking"):
                self._doing = "compiling C"
            changed, self._total, self._done = total != self._total, total, done
        if self._bar is not None and self._task is not None:
            self._bar.update(self._task, description=self._doing, completed=done, total=total)
            return
        if changed or self._now() - self._last_line >= LINE_EVERY_S or done == total:
            self._line(self._status())

    def note(self, doing: str) -> None:
        """What the build does now, for a step that gives nothing to count for a while."""
        with self._lock:
            self._doing = doing
        if self._bar is not None and self._task is not None:
            self._bar.update(self._task, description=doing)
        else:
            self._line(self._status())

    def tick(self) -> None:
        """Plain mode: a line saying what is being done if none was printed for LINE_EVERY_S."""
        if self._bar is None and self._now() - self._last_line >= LINE_EVERY_S:
            self._line(self._status() + ", still working")

    def _status(self) -> str:
        with self._lock:
            counted = f": {self._done}/{self._total} extension modules started" if self._total else ""
            return self._doing + counted

    def _beat(self) -> None:
        while not self._stop.wait(1.0):
            self.tick()

    def _line(self, text: str) -> None:
        self._last_line = self._now()
        self._console.print(f"[{self._last_line - self._started:5.0f} s] {text}", highlight=False, soft_wrap=True)

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if self._bar is not None:
            self._bar.stop()
