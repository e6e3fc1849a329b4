"""The only module that reads the OS clock.

Everything else receives time as an argument (sim time, ``int`` ns) or asks this module
for host monotonic time. Pacers for realtime mode live here too.
"""

from __future__ import annotations

import time


def monotonic_ns() -> int:
    """Host CLOCK_MONOTONIC in ns (for emit stamps, timeouts and compute measurement)."""
    return time.monotonic_ns()


def wall_ns() -> int:
    """Unix time in ns (only for the run's start stamp and file names)."""
    return time.time_ns()
