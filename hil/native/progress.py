"""What ``hil build`` shows while it works: a bar on a terminal, a line every 10 s on a pipe.

The build's first step (mypy's type check and mypyc's C) takes 10-20 s before the count of
extension modules is known; the compile takes minutes. Neither may leave the user looking at a
silent terminal.
"""

from __future__ import annotations

from types import TracebackType

from rich.console import Console

from hil import clock
from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

#: plain-line mode: at most one line per this many seconds (and one at each phase change)
LINE_EVERY_S = 10.0


class BuildProgress:
    def __init__(self, console: Console) -> None:
        self._console = console
        self._bar: Progress | None = None
        self._task: int | None = None
        self._last_line = 0.0
        self._started = 0.0
        self._total = 0

    def __enter__(self) -> BuildProgress:
        self._started = clock.monotonic_ns() / 1e9
        first = "type-checking and generating C (mypyc)"
        if self._console.is_terminal:
            self._bar = Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(),
                                 MofNCompleteColumn(), TimeElapsedColumn(), console=self._console, transient=True)
            self._bar.start()
            self._task = self._bar.add_task(first, total=None)
        else:
            self._line(first)
        return self

    def update(self, done: int, total: int) -> None:
        """``done`` of ``total`` extension modules compiled (0 of N: the C is ready)."""
        if self._bar is not None and self._task is not None:
            self._bar.update(self._task, description="compiling C", completed=done, total=total)
            return
        now = clock.monotonic_ns() / 1e9
        if total != self._total or now - self._last_line >= LINE_EVERY_S or done == total:
            self._total = total
            self._line(f"compiling C: {done}/{total} extension modules")

    def _line(self, text: str) -> None:
        self._last_line = clock.monotonic_ns() / 1e9
        self._console.print(f"[{self._last_line - self._started:5.0f} s] {text}", highlight=False)

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if self._bar is not None:
            self._bar.stop()
