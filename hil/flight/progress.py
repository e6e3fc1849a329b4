"""A run's progress on the console for ``hil run``: a live bar on a terminal
(:class:`ConsoleProgress`), plain lines on anything else (:class:`PlainProgress`: CI logs,
pipes).

A progress bar redraws one line in place, which a pipe cannot show: a piped ``hil run``
would print nothing until the summary. The plain lines come one when the run enters a new
phase and one every ``every_sim_s`` seconds of sim time in between. They depend only on sim
time and phase (plus the wall-clock RTF figure), so a log reads the same on any host.

``hil`` imports this module only once the run's arguments are checked: rich's live display
is not needed to answer ``--help`` or an argument error.
"""

from __future__ import annotations

from collections.abc import Callable

from rich.console import Console
from rich.progress import BarColumn, Progress, TaskID, TextColumn, TimeElapsedColumn

from hil import clock


class PlainProgress:
    """Callable with the run's progress signature ``(sim_s, total_s, phase)``.

    ``write`` takes one line (no newline); ``every_sim_s`` is the sim-time spacing of the
    periodic lines in seconds; ``wall_s`` gives elapsed wall seconds for the RTF figure.
    """

    def __init__(self, label: str, write: Callable[[str], None], wall_s: Callable[[], float],
                 every_sim_s: float = 10.0) -> None:
        if every_sim_s <= 0:
            raise ValueError(f"every_sim_s must be > 0 (got {every_sim_s})")
        self.label = label
        self.write = write
        self.wall_s = wall_s
        self.every_sim_s = every_sim_s
        self._phase: str | None = None
        self._next_sim_s = 0.0

    def __call__(self, sim_s: float, total_s: float, phase: str) -> None:
        if phase == self._phase and sim_s < self._next_sim_s:
            return
        self._phase = phase
        # the next periodic line: the first multiple of every_sim_s after now
        self._next_sim_s = (int(sim_s // self.every_sim_s) + 1) * self.every_sim_s
        wall = self.wall_s()
        rtf = f"{sim_s / wall:.1f}x" if wall > 0 and sim_s > 0.5 else "-"
        pct = 100.0 * sim_s / total_s if total_s else 100.0
        self.write(f"{self.label}: sim {sim_s:7.2f}/{total_s:.1f} s ({pct:3.0f}%)  RTF {rtf}  phase: {phase}")


class ConsoleProgress:
    """Callable with the run's progress signature ``(sim_s, total_s, phase)`` (seconds of sim
    time so far and in all, the scenario's phase). ``bar`` is the rich display to hold open
    (``with progress.bar:``) around the run; :meth:`begin` when the run starts. The RTF
    figure is sim seconds over wall seconds since the first progress call."""

    def __init__(self, console: Console, label: str, *, quiet: bool) -> None:
        self.console = console
        self.label = label
        self.quiet = quiet
        self.bar = Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            TextColumn("{task.fields[sim]}"),
            TextColumn("RTF {task.fields[rtf]}"),
            TextColumn("{task.fields[phase]}"),
            TimeElapsedColumn(),
            console=console,
            disable=quiet or not console.is_terminal,
            transient=True,
        )
        # Not a terminal (CI log, pipe): plain progress lines instead of the bar.
        self.plain: PlainProgress | None = None
        self._task: TaskID | None = None
        self._wall_start_ns = 0  #: host monotonic ns of the first progress call; 0 before it

    def begin(self) -> None:
        """The run is starting: the bar's task (phase "boot") and, off a terminal, the plain lines."""
        self._task = self.bar.add_task(self.label, total=1.0, sim="", rtf="-", phase="boot")
        if not self.quiet and not self.console.is_terminal:
            self.plain = PlainProgress(
                self.label,
                lambda line: self.console.print(line, markup=False, highlight=False, soft_wrap=True),
                lambda: (clock.monotonic_ns() - self._wall_start_ns) / 1e9 if self._wall_start_ns else 0.0,
            )

    def __call__(self, sim_s: float, total_s: float, phase: str) -> None:
        now = clock.monotonic_ns()
        if not self._wall_start_ns:
            self._wall_start_ns = now
        wall = max((now - self._wall_start_ns) / 1e9, 1e-6)
        assert self._task is not None, "begin() before the run's first progress"
        self.bar.update(
            self._task,
            completed=sim_s / total_s if total_s else 1.0,
            sim=f"{sim_s:6.2f}/{total_s:.1f} s",
            rtf=f"{sim_s / wall:5.1f}x" if sim_s > 0.5 else "-",
            phase=phase,
        )
        if self.plain is not None:
            self.plain(sim_s, total_s, phase)
