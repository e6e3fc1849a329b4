"""Progress of a run as plain lines, for a stdout that is not a terminal (CI logs, pipes).

A progress bar redraws one line in place, which a pipe cannot show: a piped ``hil run``
would print nothing until the summary. This prints one line when the run enters a new
phase and one every ``every_sim_s`` seconds of sim time in between. Lines depend only on
sim time and phase (plus the wall-clock RTF figure), so a log reads the same on any host.
"""

from __future__ import annotations

from collections.abc import Callable


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
